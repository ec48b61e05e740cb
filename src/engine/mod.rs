//! The prediction engine: pure computation, no I/O.
pub mod config;
pub mod error;
pub mod pose;

pub use config::{EngineConfig, Profile};
pub use error::{ConfigError, PoseError};
pub use pose::{Move, Observation, Pose, PoseValues};
