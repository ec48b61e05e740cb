//! The prediction engine: pure computation, no I/O. One [`Teacher`] per work cell learns the
//! routines an operator teaches and, between two waypoints, proposes the next one.
//!
//! In the order a taught waypoint meets it:
//!
//! 1. [`pose`] turns it into a relative move from the last waypoint (an SRHCT 7-vector);
//!    [`metric`] holds the precision matrix that says how alike two moves are.
//! 2. [`cdhmm`], the dissertation's model: the learner merges the move into an observation graph,
//!    read as a continuous-density HMM, and the prediction runs the forward recursion over the
//!    last few moves and proposes the next move, with the figures its gates read.
//! 3. [`experts`]: every expert behind one trait ([`experts::Expert`]): sequence experts in
//!    three frames (tool, work, absolute), in a cell with teaching noise the template expert,
//!    and the lattice expert propose candidates of their own, matched within the cell's
//!    tolerance widened by that noise; the calibration gives every candidate, the model's among
//!    them, `p_useful`, the probability that it is right.
//! 4. [`teach`]: the [`Teacher`] ties these together for one cell (learning within the routine,
//!    undo, the prediction kept ready for the next waypoint) and applies the one offer rule to
//!    every candidate: the likeliest is offered when it reaches the threshold; [`config`] holds
//!    its settings and
//!    the two profiles. `default` is all of the above; `seed`, the dissertation's engine, is the
//!    CDHMM alone, learning finished routines, with φ as its only gate.
//!
//! Hand-guided teaching comes in another way: [`lead_through`] cuts a recorded trajectory into
//! linear dynamical systems whose attractors are taught like waypoints.

pub mod cdhmm;
pub mod config;
pub mod error;
pub mod experts;
pub mod lead_through;
pub mod metric;
pub mod pose;
pub mod teach;

pub use cdhmm::predict::{Prediction, Withheld};
pub use config::{EngineConfig, OfferRule, PredictOptions, Profile};
pub use error::{ConfigError, PoseError};
pub use experts::frames::Tolerance;
pub use experts::noise::Noise;
pub use pose::{Move, Observation, POSITION_LIMIT_MM, Pose, PoseValues};
pub use teach::Teacher;
