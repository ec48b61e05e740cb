//! The prediction engine: pure computation, no I/O.
//!
//! Data flow, in the order a taught waypoint meets it:
//! [`pose`] turns waypoints into relative moves (SRHCT observations); [`metric`] holds the
//! precision matrix that measures how alike two moves are; [`learner`] assimilates moves into an
//! observation graph by similarity-based merging; [`hmm`] reads that graph as a continuous-density
//! HMM; [`predict`] runs the forward recursion (`forward`, over `transitions`) on the last few
//! moves and proposes the next move (`mixture`), gated by confidence, match quality and
//! end-of-routine probability (`gates`) or settled by where the context was seen last (`recall`);
//! [`scale`] estimates how much larger or smaller the taught routine is than the learned pattern;
//! [`teach`] ties these together for one work cell while an operator teaches routine after
//! routine; [`config`] holds the settings and the named profiles (`seed`, `default`).
//!
//! Hand-guided teaching (seed chapter 5): [`lds`] fits one linear dynamical system to a simple
//! trajectory; [`segment`] cuts a recorded trajectory into a sequence of them, whose attractors
//! are the waypoints the model then learns like taught ones.

pub mod cdhmm;
pub mod config;
pub mod error;
pub mod experts;
pub mod lead_through;
pub mod map_merge;
pub mod metric;
pub mod pose;
pub mod teach;

// `map_merge` reads the learner at its old path until it moves to `replay/`.
use cdhmm::learner;

pub use cdhmm::predict::{Prediction, Withheld};
pub use config::{EngineConfig, PredictOptions, Profile};
pub use error::{ConfigError, PoseError};
pub use experts::frames::Tolerance;
pub use experts::noise::Noise;
pub use pose::{Move, Observation, Pose, PoseValues};
pub use teach::Teacher;
