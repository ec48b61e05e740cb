//! Hand-guided (lead-through) trajectories: a recording cut into linear dynamical systems
//! whose attractors become waypoints (`POST /v1/routines/{id}/trajectory`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::PoseValues;
use super::waypoints::Taught;
pub use crate::engine::lead_through::segment::Criterion;

/// One sample of a hand-guided (lead-through) recording: the TCP pose at time `t`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySample {
    /// Seconds (any origin); each sample's time is greater than the one before.
    pub t: f64,
    pub pose: PoseValues,
    /// Joint values (rad) as recorded: on every sample or on none, the same number on each
    /// (one per joint of the cell's arm: 6; 1 to 12 when the cell's robot model is not
    /// installed). An appended waypoint keeps its sample's joints.
    #[schema(min_items = 1, max_items = 12)]
    pub joints: Option<Vec<f64>>,
}

/// How a trajectory is cut into linear dynamical systems; anything left out takes the
/// default.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySettings {
    /// Largest prediction error ε of a segment before it is cut (default 0.5: with
    /// `direction`, a turn of about 29°).
    #[schema(exclusive_minimum = 0)]
    pub epsilon_max: Option<f64>,
    /// How ε is measured: `direction` (default: the predicted step's direction against the
    /// observed one) or `seed` (the seed's Eq. 5.7, error over step length).
    pub criterion: Option<Criterion>,
    /// A sample is used when it is at least this far (mm; rotation weighted by
    /// `rotation_mm_per_rad`) from the last one used (default 1). Also the distance below
    /// which the trajectory's first sample is not appended (see the route's description).
    #[schema(exclusive_minimum = 0)]
    pub min_step_mm: Option<f64>,
    /// Weight of orientation against position: mm per radian (default 50; at most 10000).
    #[schema(minimum = 0, maximum = 10000)]
    pub rotation_mm_per_rad: Option<f64>,
    /// The reproduction of a segment has reached its attractor within this distance (mm,
    /// default 0.5).
    #[schema(exclusive_minimum = 0)]
    pub zeta_mm: Option<f64>,
    /// Fewest steps of a segment before it may be cut (default 2; at most 20000, the most
    /// samples a trajectory may hold).
    #[schema(minimum = 1, maximum = 20000)]
    pub min_segment_steps: Option<usize>,
    /// Largest condition number of a fitted dynamics matrix; above it the segment moves
    /// straight to its attractor (default 10000; at least 1).
    #[schema(minimum = 1)]
    pub kappa_max: Option<f64>,
    /// Directions the segment spans less than this fraction of its largest are not fitted
    /// (default 0.001; between 0 and 1 exclusive).
    #[schema(exclusive_minimum = 0, exclusive_maximum = 1)]
    pub rank_tolerance: Option<f64>,
}

/// A hand-guided trajectory for an open routine: its attractors are appended as taught
/// waypoints, or with `preview` only shown.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrajectoryRequest {
    /// The recording in time order: 2 to 20000 samples.
    #[schema(min_items = 2, max_items = 20000)]
    pub samples: Vec<TrajectorySample>,
    /// Show the attractors, the segments and the reproduction error without storing
    /// anything (default false).
    #[serde(default)]
    pub preview: bool,
    #[serde(default)]
    pub settings: TrajectorySettings,
}

/// A sample of the trajectory that is (or would be) a waypoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TrajectoryPoint {
    /// Place of the sample in the request (from 0).
    pub sample: usize,
    pub t: f64,
    pub pose: PoseValues,
    pub joints: Option<Vec<f64>>,
    /// Appended as a waypoint (with `preview`: would be). An attractor closer than
    /// `min_step_mm` to the waypoint before it is not appended again.
    pub taught: bool,
}

/// One segment of the trajectory: a linear dynamical system `x ← x + R (x − a)` moving to its
/// attractor `a`, the sample `to`. The state is position (mm) and the rotation vector scaled
/// by `rotation_mm_per_rad`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TrajectorySegment {
    /// The sample it starts at.
    pub from: usize,
    /// The sample that is its attractor.
    pub to: usize,
    /// Steps (between samples used) it was fitted to.
    pub steps: usize,
    /// Dimension of the subspace the segment spans (fitted by least squares).
    pub rank: usize,
    /// Condition number of the fitted `R` (null: infinite).
    pub condition: Option<f64>,
    /// `R` was replaced by `−alpha I` (straight to the attractor).
    pub identity: bool,
    /// Rate of the scaled identity used outside the spanned subspace (or for all of `R`).
    pub alpha: f64,
    /// The ε that closed the segment (null for the last, closed by the trajectory's end).
    pub epsilon: Option<f64>,
    /// `R`, 6 × 6 row-major.
    #[schema(min_items = 36, max_items = 36)]
    pub r: Vec<f64>,
}

/// The trajectory as segments, and how well their control laws reproduce it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = SegmentationDto)]
pub struct Segmentation {
    /// Samples given.
    pub samples: usize,
    /// Samples used (each at least `min_step_mm` from the one before).
    pub kept: usize,
    pub segments: Vec<TrajectorySegment>,
    /// Mean distance (mm) of the recorded positions to the reproduced path.
    pub mean_error_mm: f64,
    /// Largest such distance (mm).
    pub max_error_mm: f64,
    /// Every segment's reproduction came within `zeta_mm` of its attractor.
    pub converged: bool,
    /// Numbers that describe the trajectory as segments (36 + 6 per segment).
    pub parameters: usize,
    /// Numbers of the recorded trajectory (6 per sample).
    pub raw_parameters: usize,
}

/// What a trajectory became: the waypoints appended (each with the prediction that followed
/// it, as a single append answers), the samples they came from, and the segmentation.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct TrajectoryAnswer {
    /// Nothing was stored (the request's `preview`).
    pub preview: bool,
    /// The trajectory's first sample; `taught` when it was appended before the attractors.
    pub start: TrajectoryPoint,
    /// Each segment's attractor, in order.
    pub attractors: Vec<TrajectoryPoint>,
    /// The waypoints appended, in order, each with the prediction made after it (empty with
    /// `preview`).
    pub waypoints: Vec<Taught>,
    pub segmentation: Segmentation,
}
