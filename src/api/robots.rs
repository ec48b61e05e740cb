//! The arm models cells can name (`/v1/robots`): the bundled ones and those uploaded.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// Where a model comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum RobotSource {
    /// Shipped with the service (`robots/`).
    Bundled,
    /// Uploaded through the API (`POST /v1/robots`), kept in the database.
    Uploaded,
}

impl RobotSource {
    pub fn as_str(self) -> &'static str {
        match self {
            RobotSource::Bundled => "bundled",
            RobotSource::Uploaded => "uploaded",
        }
    }
}

/// An arm model to upload.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotUpload {
    /// The name cells will use: letters, digits, `_` and `-`, at most 64 characters, not one
    /// the service already has.
    #[schema(pattern = "^[A-Za-z0-9_-]{1,64}$")]
    pub name: String,
    /// The URDF text: a serial chain of six revolute joints from the root link to `tool0`
    /// (or the only leaf), each with `<limit lower upper velocity>`; lengths in metres.
    pub urdf: String,
    /// Not blank; at most 200 characters.
    #[serde(default)]
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub maker: Option<String>,
    /// Not blank; at most 200 characters.
    #[serde(default)]
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub product: Option<String>,
    /// Rated payload, kg: positive.
    #[serde(default)]
    #[schema(exclusive_minimum = 0.0)]
    pub payload_kg: Option<f64>,
}

/// One joint: limits (rad) and velocity limit (rad/s).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = JointDto)]
pub struct Joint {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
}

/// A robot model (a bundled URDF in `robots/`, or one uploaded).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[schema(as = RobotDto)]
pub struct Robot {
    /// The name cells use (`abb_irb140`).
    pub name: String,
    pub source: RobotSource,
    /// The maker and its designation (`ABB`, `IRB 2600-12/1.65`), when known.
    pub maker: Option<String>,
    pub product: Option<String>,
    /// Rated payload (kg), from the data sheet, when known.
    pub payload_kg: Option<f64>,
    /// Reach (mm): the data sheet's, when known.
    pub reach_mm: Option<f64>,
    /// Reach (mm) computed from the kinematics: from the axis-1 line to the wrist centre at
    /// full stretch (UR arms: to the flange).
    pub computed_reach_mm: f64,
    /// Program languages of the arm's controller (`rapid`, `krl`, `fanuc`, `urscript`).
    pub languages: Vec<String>,
    /// Inverse-kinematics solver: `opw` (spherical wrist) or `ur`.
    pub solver: String,
    pub root: String,
    /// Poses are of this link (the flange) in the root frame, before the cell's tool frame.
    pub tip: String,
    pub joints: Vec<Joint>,
}
