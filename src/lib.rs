//! nextpose: suggests the next waypoint while an operator teaches an industrial robot arm.
//!
//! - [`engine`]: the pure prediction engine (poses, learner, HMM, predictor, scale). No I/O.
//! - [`kinematics`]: robot models from URDF, FK, all IK solutions, reachability. No I/O beyond
//!   reading URDF files.
//! - [`replay`]: replays recorded programs through the engine and baselines and reports accuracy
//!   (the product's scoreboard). Reads corpus files; everything else it does is computation.
//! - [`cli`]: the `nextpose` command line.

pub mod cli;
pub mod engine;
pub mod kinematics;
pub mod replay;
