//! What reads programs, mostly those of the shared corpus (`../shared/corpus`; see
//! `common/corpus.rs` for what happens without it): the whole-corpus scoreboard (`scoreboard`),
//! the replay harness (`harness`), the MAP baseline (`map_baseline`), the plots (`plots`, with
//! the `plots` feature), the importer and the exporter on every corpus file (`importer`,
//! `exporter`) and the arm chosen and placed for each program (`layout`). One binary, so the
//! whole stack is linked once for all of them.

#[path = "../common/corpus.rs"]
mod corpus;
mod exporter;
mod harness;
mod importer;
mod layout;
mod map_baseline;
#[cfg(feature = "plots")]
mod plots;
mod scoreboard;
