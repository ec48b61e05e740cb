//! The simulated arm and operator (issue 7): the pure half of `nextpose simulate`.
//!
//! We cannot bring operators in to repeat the dissertation's lab study (Table 4.1), so a simulated
//! operator teaches corpus programs on a simulated arm, against the real service, and the
//! simulated programming times are compared across prediction settings. Everything here is
//! deterministic given a seed and does no I/O beyond loading the bundled robot models; the
//! driver that talks to a server is [`crate::simulation_driver`].
//!
//! - [`arm`]: a six-joint arm from the URDF models: joints, FK/IK, joint and Cartesian jogs
//!   timed by the TCP speed limit and the joints' velocity limits.
//! - [`operator`]: the operator's time model (arm travel + Fitts aiming + recording), placement
//!   error, and decisions on suggestions (accept, fine-tune, reject), each mapped to the
//!   feedback the service expects.
//! - [`lab`]: the dissertation's online lab (§4.5) as programs: four tasks, three users, work
//!   pieces placed anew and waypoints taught with a joystick operator's error; and a welding cell.
//! - [`pattern`]: pallets, machine-tending trays and grids, a tuning and a held-out set.
//! - [`plan`]: the conditions (the dissertation's φ_min/h rows and our default profile), the arm's
//!   placement per program, the random stream per waypoint, the per-routine result.
//! - [`stats`]: mean, standard deviation, Wilcoxon rank-sum test.
//! - [`table`]: the summary per condition, as Markdown, an SVG bar chart, and JSON (serde).

pub mod arm;
pub mod lab;
pub mod operator;
pub mod pattern;
pub mod plan;
pub mod stats;
pub mod table;

use thiserror::Error;

pub use arm::{Arm, Jog, JogLimits};
pub use operator::{Decision, Feedback, Operator, OperatorModel, Step, Suggestion, Time};
pub use plan::{Condition, History, Plan, RoutineResult, table_4_1_conditions};
pub use stats::{RankSum, StatsError, rank_sum};
pub use table::{
    ConditionSummary, arms_markdown, breakdown_markdown, change_chart_svg, markdown, summarise,
};

/// Why a simulation cannot be set up or summarised.
#[derive(Debug, Error)]
pub enum SimulationError {
    #[error(transparent)]
    Kinematics(#[from] crate::kinematics::KinematicsError),
    #[error(transparent)]
    Stats(#[from] StatsError),
    #[error("program {0:?} has no waypoints, or no library arm for its language, to place")]
    NoPlacement(String),
    #[error("placing the arm of program {0:?}: {1}")]
    Layout(String, crate::kinematics::LayoutError),
    #[error("the plan has no conditions")]
    EmptyPlan,
    #[error("no results for condition {0:?}")]
    NoResults(String),
}
