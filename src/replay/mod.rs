//! Replay: the product's scoreboard (ALGORITHM §5, dissertation §4.3.1).
//!
//! Recorded programs are played back waypoint by waypoint, as an operator would have taught
//! them, through the engine and through baselines that any learned model must beat. Every method
//! implements the same [`Method`] trait and is measured by the same harness on the same
//! waypoints, so the figures are comparable.
//!
//! - [`corpus`]: reads the shared corpus's JSON programs (or raw program files) into
//!   [`Program`]s.
//! - [`method`]: the [`Method`] trait every predictor implements.
//! - [`methods`]: the engine behind that trait, the baselines (repeat-last-move,
//!   nearest-sequence) and `map`, the dissertation's MAP structure-estimation baseline with its
//!   comparison to the engine (dissertation §4.4.1, Figure 4.14).
//! - [`playback`]: the replay loop ([`replay_program`]): one program through one method, one
//!   record per waypoint, judged useful or not at the scoreboard's tolerance.
//! - [`frames`]: the three readings of a routine (tool-frame moves, work-frame moves, poses) at
//!   that tolerance.
//! - [`score`]: the figures computed from the records: the scoreboard line ([`Scores`]), oracle
//!   bounds, reachability of the guesses, calibration of `p_useful`.
//! - [`report`]: all methods on all programs ([`replay_all`]), the scoreboard of the CLI and
//!   the service ([`report::scoreboard`]), JSON and text tables.
//! - [`placements`]: each program's arm placement, searched once and kept in a cache
//!   directory (the search is most of a corpus replay's time).
//! - [`sweep`]: the engine over a grid of settings.
//! - [`table`]: the plain text tables the report, the calibration section and the sweep print.
//! - `plots` (cargo feature `plots`, on by default): the dissertation's figures (φ_min, δ, learning
//!   curve), confidence vs error, reliability of `p_useful` and risk–coverage, PNG/SVG.

pub mod corpus;
pub mod frames;
pub mod method;
pub mod methods;
pub mod placements;
pub mod playback;
#[cfg(feature = "plots")]
pub mod plots;
pub mod report;
pub mod score;
pub mod sweep;
pub mod table;

pub use corpus::{CorpusError, Program, Routine, load_paths};
pub use method::{Candidate, Guess, Method, ModelSummary, Proposal};
pub use playback::{CandidateRecord, ProgramRecord, WaypointRecord, replay_program};
pub use report::{Report, RunConfig, replay_all};
pub use score::Scores;
pub use sweep::{SweepRow, sweep};
