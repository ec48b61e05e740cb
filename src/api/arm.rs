//! The cell's arm as a pendant draws and jogs it (its frames, the reach of a pose) and the
//! search for where to stand it.

use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::PoseValues;

/// A layout search: where to stand an arm so that it reaches a program's waypoints. The
/// targets are one of `program_id` (its routines' waypoints), `cell_id` (every program of the
/// cell) or `targets` (poses in the work frame, mm).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PlacementSearch {
    pub program_id: Option<i64>,
    pub cell_id: Option<i64>,
    /// 1 to 20,000 poses.
    #[schema(min_items = 1, max_items = 20000)]
    pub targets: Option<Vec<PoseValues>>,
    /// `floor` (default) or `ceiling`.
    #[serde(default)]
    pub mounting: crate::kinematics::BaseMounting,
    /// TCP in the flange frame; default: the cell's tool when the targets are stored, else
    /// the flange.
    pub tool: Option<PoseValues>,
    /// How many distinct placements to return, best first (1–10, default 3).
    #[schema(minimum = 1, maximum = 10)]
    pub keep: Option<usize>,
    /// Seed of the search's random stage (the same request gives the same answer).
    pub seed: Option<u64>,
    /// Search effort: placement evaluations (100–20000, default 1200).
    #[schema(minimum = 100, maximum = 20000)]
    pub evaluations: Option<usize>,
}

/// One robot base placement and how well the arm reaches the targets from it.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[schema(as = PlacementDto)]
pub struct Placement {
    /// Robot base frame in the work frame, mm.
    #[schema(schema_with = computed_pose)]
    pub base: PoseValues,
    pub reached: usize,
    pub total: usize,
    /// Places (from 0) in the target list of the targets not reached.
    pub unreached: Vec<usize>,
    /// The stored waypoints not reached, when the targets are stored waypoints.
    pub unreached_waypoints: Option<Vec<i64>>,
    /// Smallest distance to a joint limit over the reached targets (degrees).
    pub min_joint_margin_deg: Option<f64>,
    /// Smallest Jacobian singular value over the reached targets (the singularity margin).
    pub min_sigma: Option<f64>,
    /// Reached count plus a margin term in [0, 1): higher is better.
    pub score: f64,
}

/// The placements found, best first.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Placements {
    pub robot: String,
    pub targets: usize,
    pub placements: Vec<Placement>,
}

/// `GET /v1/cells/{cell_id}/frames`: the joint vector to draw.
#[derive(Debug, Clone, Default, Serialize, Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct FramesQuery {
    /// Six joint values (rad), comma-separated (`0,0.3,-0.2,0,0.8,0`); left out: the arm's
    /// ready position (flange pointing down in front of the base).
    #[param(pattern = r"^-?[0-9]{1,6}(\.[0-9]{1,12})?(,-?[0-9]{1,6}(\.[0-9]{1,12})?){5}$")]
    pub joints: Option<String>,
}

/// One frame of the arm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct LinkFrame {
    /// The robot base link's name, then each joint's.
    pub name: String,
    #[schema(schema_with = computed_pose)]
    pub pose: PoseValues,
}

/// The schema of a frame the service computes (an arm's links, flange and TCP): a pose as
/// [`PoseValues`], but its position may lie past the ±100 m a given pose keeps to (an arm based
/// near that limit reaches beyond it).
fn computed_pose() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
    use utoipa::openapi::RefOr;
    use utoipa::openapi::schema::Schema;
    let mut schema = <PoseValues as utoipa::PartialSchema>::schema();
    if let RefOr::T(Schema::Object(object)) = &mut schema {
        for axis in ["x", "y", "z"] {
            if let Some(RefOr::T(Schema::Object(p))) = object.properties.get_mut(axis) {
                p.minimum = None;
                p.maximum = None;
            }
        }
        object.description = Some(
            "A frame the service computes: a pose as `PoseValues`, whose position may lie past \
             ±100,000 mm."
                .into(),
        );
    }
    schema
}

/// The cell's arm at a joint vector, every frame in the cell's work frame (mm): segments from
/// each frame's origin to the next, then to `flange` and `tcp`, draw the arm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ArmFrames {
    pub robot: String,
    /// The joints drawn (rad).
    pub joints: Vec<f64>,
    /// The robot base in the work frame (the cell's `base` setting).
    pub base: PoseValues,
    /// The base, then each of the six joints' frames after its rotation.
    pub links: Vec<LinkFrame>,
    /// The flange (`tool0`).
    #[schema(schema_with = computed_pose)]
    pub flange: PoseValues,
    /// The tool centre point: the flange with the cell's `tool` mounted.
    #[schema(schema_with = computed_pose)]
    pub tcp: PoseValues,
}

/// `POST /v1/cells/{cell_id}/reach`: can the arm put its TCP at `pose`, and with which
/// joints (the solution nearest `near`, as a jog from where the arm is)?
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReachQuery {
    /// TCP pose in the work frame.
    pub pose: PoseValues,
    /// Where the arm is (six joint values, rad, each within its joint's range); left out: the
    /// solution nearest the middle of the joint ranges.
    #[schema(min_items = 6, max_items = 6)]
    pub near: Option<Vec<f64>>,
}
