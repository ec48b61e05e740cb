//! The methods the scoreboard measures, each behind the [`Method`](super::Method) trait: the
//! engine itself, the baselines any learned model must beat, and `map`, the dissertation's MAP
//! structure-estimation learner predicting with the engine's machinery.
//!
//! - [`engine`]: the engine ([`crate::engine::Teacher`]) driven waypoint by waypoint.
//! - [`baselines`]: repeat-last-move and nearest-sequence (tool-frame, work-frame, absolute).
//! - [`map`]: the MAP learner, the method over it and its comparison with the engine by
//!   confidence threshold (dissertation §4.4.1, Figure 4.14).

pub mod baselines;
pub mod engine;
pub mod map;

pub use baselines::{NearestSeq, RepeatLast};
pub use engine::EngineMethod;
pub use map::MapMethod;
