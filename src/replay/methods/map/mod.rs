//! `map`: the dissertation's comparison learner (dissertation §3.9, §4.4.1), used only by the
//! replay.
//!
//! The dissertation argues that its similarity merge beats MAP structure estimation on
//! teach-pendant data; these modules let the scoreboard measure that claim on our corpus.
//!
//! - [`merge`]: best-first MAP state merging ([`MapLearner`], [`MapSettings`]), building the
//!   same observation graph the engine predicts from.
//! - [`method`]: [`MapMethod`], that learner behind the replay's `Method` trait, predicting with
//!   the engine's own machinery.
//! - [`comparison`]: the engine and `map` by confidence threshold (Figure 4.14).

pub mod comparison;
pub mod merge;
pub mod method;

pub use merge::{MapLearner, MapSettings};
pub use method::MapMethod;
