//! Replay: the product's scoreboard (ALGORITHM §5, seed §4.3.1).
//!
//! Recorded programs are played back waypoint by waypoint, as an operator would have taught
//! them, through the engine and through baselines that any learned model must beat. Every method
//! implements the same [`Method`] trait and is measured by the same harness on the same
//! waypoints, so the figures are comparable.
//!
//! - [`corpus`]: reads the shared corpus's JSON programs into [`Program`]s.
//! - [`method`]: the [`Method`] trait every predictor implements.
//! - [`engine_method`]: the engine behind that trait.
//! - [`map_method`]: `map`, the seed's MAP structure-estimation baseline (best-first state
//!   merging, `engine::map_merge`) predicting with the engine's machinery; [`map_comparison`]:
//!   its comparison with the engine by confidence threshold (seed §4.4.1, Figure 4.14).
//! - [`baselines`]: repeat-last-move and nearest-sequence (tool-frame, work-frame, absolute).
//! - [`frames`]: the three readings of a routine (tool-frame moves, work-frame moves, poses).
//! - [`metrics`]: the replay loop ([`replay_program`]) and the figures computed from it.
//! - [`oracle`]: oracle bounds, the share of waypoints some earlier candidate of each kind
//!   would have got right (not methods: they see the answer).
//! - [`reach`]: whether the cell's arm could reach the guesses (kinematics).
//! - [`reliability`]: calibration of `p_useful` (reliability table by decile, ECE) and the
//!   risk–coverage curve of the offer threshold.
//! - [`report`]: all methods on all programs ([`replay_all`]), the scoreboard of the CLI and
//!   the service ([`report::scoreboard`]), JSON and text tables.
//! - [`sweep`]: the engine over a grid of settings.
//! - `plots` (cargo feature `plots`, on by default): the seed's figures (φ_min, δ, learning
//!   curve), confidence vs error, reliability of `p_useful` and risk–coverage, PNG/SVG.

pub mod baselines;
pub mod corpus;
pub mod engine_method;
pub mod frames;
pub mod map_comparison;
pub mod map_method;
pub mod method;
pub mod metrics;
pub mod oracle;
#[cfg(feature = "plots")]
pub mod plots;
pub mod reach;
pub mod reliability;
pub mod report;
pub mod sweep;

pub use corpus::{CorpusError, Program, Routine, load_paths};
pub use method::{Candidate, Guess, Method, ModelSummary, Proposal};
pub use metrics::{CandidateRecord, ProgramRecord, Scores, WaypointRecord, replay_program};
pub use report::{Report, RunConfig, replay_all};
pub use sweep::{SweepRow, sweep};
