//! The wire types: what clients send and what the service answers, one file per resource.
//!
//! One set of types serves both ends of the wire, as in mini-redis: the REST adapter
//! ([`crate::http`]) reads and writes them as JSON, the gRPC adapter ([`crate::grpc`]) converts
//! them to and from protobuf, the application ([`crate::app`]) takes and answers them, and the
//! typed client ([`crate::client`]), the simulated operator and the tests use the same ones.
//! They derive `Serialize` and `Deserialize` both ways and `utoipa::ToSchema`, from which
//! `openapi.yaml` is generated (`nextpose openapi`).
//!
//! Conventions:
//! - Inputs refuse unknown fields (a misspelt setting must not be silently ignored).
//! - Poses are position in mm and a unit quaternion `w, x, y, z` in the cell's work frame
//!   ([`PoseValues`]); a quaternion within 1e-3 of unit norm is normalised, anything farther is
//!   refused.
//! - A few schemas keep the names they were published under (`PredictionDto`,
//!   `NewWaypointDto`, …: `#[schema(as = …)]`), so clients generated from `openapi.yaml` keep
//!   theirs.
//! - The engine's own types that travel as they are (a pose's numbers, the noise, the
//!   tolerance, the profile) get their schemas in [`schema`]: the engine derives no web traits.

pub mod arm;
pub mod audit;
pub mod backups;
pub mod cells;
pub mod error;
pub mod feedback;
pub mod history;
pub mod imports;
pub mod integral;
pub mod predictions;
pub mod programs;
pub mod replays;
pub mod robots;
pub mod routines;
mod schema;
pub mod settings;
pub mod system;
pub mod tokens;
pub mod trajectory;
pub mod waypoints;

use serde::{Deserialize, Deserializer};

pub use arm::{
    ArmFrames, FramesQuery, LinkFrame, Placement, PlacementSearch, Placements, ReachQuery,
};
pub use audit::{AuditEntry, AuditPage, AuditQuery};
pub use backups::{Backup, BackupRequest};
pub use cells::{
    CalibrationRoutine, Cell, CellPatch, CellStats, CreateCell, FeedbackStats, ModelInfo,
    TeachingStats,
};
pub use error::{ErrorBody, ErrorDetail};
pub use feedback::{Feedback, FeedbackRecorded, Verdict};
pub use history::{
    ChangeKind, DiffQuery, HistoryQuery, ProgramDiff, ProgramHistory, ProgramRevision,
    RestoreProgram, Restored, Revision, RevisionChange, RoutineChanged, RoutineRevision,
    RoutineSummary, WaypointChanged, WaypointRevision, WaypointSummary,
};
pub use imports::{ImportRequest, ImportResult, ImportedProgram, Skipped, UploadedFile};
pub use predictions::{
    JointMargin, PredictQuery, Prediction, PredictionSet, Reachability, Unreachable, Withheld,
};
pub use programs::{
    CreateProgram, ExportQuery, ExportedFile, FixturePoints, Program, ProgramExport, Rename,
    Retarget, Retargeted,
};
pub use replays::ReplayRequest;
pub use robots::{Joint, Robot, RobotSource, RobotUpload};
pub use routines::{CreateRoutine, Finished, Routine, RoutineDetail, RoutineEdit, RoutinePatch};
pub use settings::{CellSettings, CellSettingsInput, ScaleSettings};
pub use system::Health;
pub use tokens::{CreatedToken, NewToken, Role, Token, WhoAmI};
pub use trajectory::{
    Criterion, Segmentation, TrajectoryAnswer, TrajectoryPoint, TrajectoryRequest,
    TrajectorySample, TrajectorySegment, TrajectorySettings,
};
pub use waypoints::{
    InsertWaypoint, MotionType, NewWaypoint, Side, Taught, Undone, Waypoint, WaypointEdit,
    WaypointPatch,
};

pub use crate::engine::PoseValues;

/// A field an edit may leave out (unchanged), set, or clear with `null`.
fn present<'de, D, T>(d: D) -> Result<Option<Option<T>>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<T>::deserialize(d).map(Some)
}
