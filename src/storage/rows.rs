//! Rows as stored. Poses are flat columns: position in mm, quaternion `w, x, y, z`.

use sqlx::FromRow;

/// A pose as seven columns.
#[derive(Debug, Clone, Copy, PartialEq, FromRow)]
pub struct PoseColumns {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub qw: f64,
    pub qx: f64,
    pub qy: f64,
    pub qz: f64,
}

/// An arm model uploaded through the API.
#[derive(Debug, Clone, PartialEq, FromRow)]
pub struct RobotRow {
    pub name: String,
    pub urdf: String,
    pub maker: Option<String>,
    pub product: Option<String>,
    pub payload_kg: Option<f64>,
    pub created_at: String,
}

#[derive(Debug, Clone, FromRow)]
pub struct CellRow {
    pub id: i64,
    pub name: String,
    pub settings: String,
    pub created_at: String,
    /// Advanced each time the cell's learned model changes (a routine learned, an edit of a
    /// learned routine, a change of settings).
    pub model_version: i64,
    /// When the settings last changed (None: as created).
    pub settings_changed_at: Option<String>,
}

#[derive(Debug, Clone, FromRow)]
pub struct ProgramRow {
    pub id: i64,
    pub cell_id: i64,
    pub name: String,
    pub created_at: String,
}

#[derive(Debug, Clone, FromRow)]
pub struct RoutineRow {
    pub id: i64,
    pub program_id: i64,
    pub cell_id: i64,
    pub position: i64,
    pub name: Option<String>,
    pub finish_seq: Option<i64>,
    pub finished_at: Option<String>,
    pub created_at: String,
    /// Imported from an offline program (takes no teaching; learned only when `finish_seq` is set).
    pub imported: bool,
    /// Number of waypoints.
    pub waypoints: i64,
}

impl RoutineRow {
    /// Immutable: finished, or imported.
    pub fn finished(&self) -> bool {
        self.finish_seq.is_some() || self.imported
    }

    /// Part of the cell's model.
    pub fn learned(&self) -> bool {
        self.finish_seq.is_some()
    }
}

/// A routine of an imported program, ready to store.
#[derive(Debug, Clone)]
pub struct NewImportedRoutine {
    pub name: String,
    pub waypoints: Vec<WaypointValues>,
}

#[derive(Debug, Clone, FromRow)]
pub struct WaypointRow {
    pub id: i64,
    pub routine_id: i64,
    pub seq: i64,
    #[sqlx(flatten)]
    pub pose: PoseColumns,
    /// JSON array of joint values (rad).
    pub joints: Option<String>,
    pub motion: Option<String>,
    pub name: Option<String>,
    /// Whether the cell's arm reaches it (None: not checked).
    pub reachable: Option<bool>,
    pub created_at: String,
}

/// A waypoint's values as an edit sets them (its routine and place stay).
#[derive(Debug, Clone)]
pub struct WaypointValues {
    pub pose: PoseColumns,
    pub joints: Option<String>,
    pub motion: Option<String>,
    pub name: Option<String>,
    pub reachable: Option<bool>,
}

#[derive(Debug, Clone)]
pub struct NewWaypoint {
    pub routine_id: i64,
    pub seq: i64,
    pub pose: PoseColumns,
    pub joints: Option<String>,
    pub motion: Option<String>,
    pub name: Option<String>,
    pub reachable: Option<bool>,
}

#[derive(Debug, Clone)]
pub struct NewPrediction {
    pub cell_id: i64,
    pub routine_id: i64,
    pub after_seq: i64,
    pub pose: PoseColumns,
    pub phi: f64,
    pub psi: f64,
    pub misfit: Option<f64>,
    pub end_probability: f64,
    pub model_version: i64,
}

#[derive(Debug, Clone, FromRow)]
pub struct PredictionRow {
    pub id: i64,
    pub cell_id: i64,
    pub routine_id: i64,
    pub after_seq: i64,
    #[sqlx(flatten)]
    pub pose: PoseColumns,
    pub phi: f64,
    pub psi: f64,
    pub misfit: Option<f64>,
    pub end_probability: f64,
    pub model_version: i64,
    pub created_at: String,
    /// The feedback verdict, when there is one.
    pub verdict: Option<String>,
}

#[derive(Debug, Clone)]
pub struct NewFeedback {
    pub prediction_id: i64,
    /// `accepted`, `adjusted` or `rejected`.
    pub verdict: &'static str,
    pub pose: Option<PoseColumns>,
    pub adjustment_mm: Option<f64>,
}

#[derive(Debug, Clone, Default)]
pub struct FeedbackCounts {
    pub offered: i64,
    pub accepted: i64,
    pub adjusted: i64,
    pub rejected: i64,
    pub adjustments_mm: Vec<f64>,
}
