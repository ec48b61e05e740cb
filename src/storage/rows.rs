//! Rows as stored, and the columns each is read from. Poses are flat columns: position in mm,
//! quaternion `w, x, y, z`.

use sqlx::any::{Any, AnyRow};
use sqlx::decode::Decode;
use sqlx::error::BoxDynError;
use sqlx::types::Type;
use sqlx::{FromRow, Row, ValueRef};

use crate::engine::PoseValues;
/// A waypoint's values are the program model's; rows are read into them.
pub use crate::program::revisions::WaypointValues;

/// A 0/1 integer column read as a flag. Both dialects store flags as integers so that the same
/// SQL (`imported = 0`) and the same binds serve SQLite and PostgreSQL.
#[derive(Debug, Clone, Copy)]
pub struct Flag(bool);

impl From<Flag> for bool {
    fn from(f: Flag) -> bool {
        f.0
    }
}

impl Type<Any> for Flag {
    fn type_info() -> <Any as sqlx::Database>::TypeInfo {
        <i64 as Type<Any>>::type_info()
    }

    fn compatible(ty: &<Any as sqlx::Database>::TypeInfo) -> bool {
        <i64 as Type<Any>>::compatible(ty) || <i32 as Type<Any>>::compatible(ty)
    }
}

impl<'r> Decode<'r, Any> for Flag {
    fn decode(value: <Any as sqlx::Database>::ValueRef<'r>) -> Result<Self, BoxDynError> {
        Ok(Flag(<i64 as Decode<Any>>::decode(value)? != 0))
    }
}

/// A nullable 0/1 integer column (NULL: not known).
#[derive(Debug, Clone, Copy)]
pub struct MaybeFlag(Option<bool>);

impl From<MaybeFlag> for Option<bool> {
    fn from(f: MaybeFlag) -> Option<bool> {
        f.0
    }
}

impl Type<Any> for MaybeFlag {
    fn type_info() -> <Any as sqlx::Database>::TypeInfo {
        <Flag as Type<Any>>::type_info()
    }

    fn compatible(ty: &<Any as sqlx::Database>::TypeInfo) -> bool {
        <Flag as Type<Any>>::compatible(ty)
    }
}

impl<'r> Decode<'r, Any> for MaybeFlag {
    fn decode(value: <Any as sqlx::Database>::ValueRef<'r>) -> Result<Self, BoxDynError> {
        if value.is_null() {
            return Ok(MaybeFlag(None));
        }
        Ok(MaybeFlag(Some(
            <Flag as Decode<Any>>::decode(value)?.into(),
        )))
    }
}

/// A nullable float as it is bound: `Option<f64>` would do, but sqlx's Any driver sends a
/// missing f64 to PostgreSQL as a `float4` NULL, and a statement prepared with it then refuses
/// the next call's `float8` ("incorrect binary data format"). Declared as the other float
/// kind, a missing value goes out as a `float8` NULL; a present one is an f64 either way.
#[derive(Debug, Clone, Copy)]
pub(super) struct Real(f64);

impl Type<Any> for Real {
    fn type_info() -> <Any as sqlx::Database>::TypeInfo {
        <f32 as Type<Any>>::type_info()
    }
}

impl<'q> sqlx::Encode<'q, Any> for Real {
    fn encode_by_ref(
        &self,
        buf: &mut <Any as sqlx::Database>::ArgumentBuffer,
    ) -> Result<sqlx::encode::IsNull, BoxDynError> {
        <f64 as sqlx::Encode<'q, Any>>::encode_by_ref(&self.0, buf)
    }
}

/// A nullable float, ready to bind (see [`Real`]).
pub(super) fn real(v: Option<f64>) -> Option<Real> {
    v.map(Real)
}

/// A flag as it is bound (see [`Flag`]).
pub(super) fn flag(b: bool) -> i64 {
    i64::from(b)
}

/// A row type and where it is read from: `SELECT {COLUMNS} FROM {FROM} …` reads one, and a
/// write that answers with the row it made says `RETURNING {COLUMNS}` (where `FROM` is its table).
pub(super) trait Stored: for<'r> FromRow<'r, AnyRow> + Send + Unpin {
    /// The columns, in the order and with the names the row type reads.
    const COLUMNS: &'static str;
    /// The table (or join) they come from.
    const FROM: &'static str;
}

/// A pose is read from its seven columns `x, y, z, qw, qx, qy, qz` (as it is bound, see
/// `binds.rs`); rows hold it as the engine's plain values and the application checks it.
impl<'r> FromRow<'r, AnyRow> for PoseValues {
    fn from_row(row: &'r AnyRow) -> Result<Self, sqlx::Error> {
        Ok(PoseValues {
            x: row.try_get("x")?,
            y: row.try_get("y")?,
            z: row.try_get("z")?,
            qw: row.try_get("qw")?,
            qx: row.try_get("qx")?,
            qy: row.try_get("qy")?,
            qz: row.try_get("qz")?,
        })
    }
}

/// A row of the audit trail (see `storage::audit`).
#[derive(Debug, Clone, PartialEq, FromRow)]
pub struct AuditRow {
    pub id: i64,
    pub at: String,
    pub token: String,
    pub request_id: String,
    pub operation: String,
    pub target: Option<String>,
    pub cell_id: Option<i64>,
    pub outcome: String,
}

impl Stored for AuditRow {
    const COLUMNS: &'static str = "id, at, token, request_id, operation, target, cell_id, outcome";
    const FROM: &'static str = "audit";
}

/// A bearer token, without its secret (only its SHA-256 is stored).
#[derive(Debug, Clone, PartialEq, FromRow)]
pub struct TokenRow {
    pub id: i64,
    pub name: String,
    /// `operator`, `engineer` or `admin` (the database checks it).
    pub role: String,
    /// The SHA-256 of its secret, in hex.
    pub secret_sha256: String,
    /// 1: every cell; 0: only the cells in `token_cells`.
    pub all_cells: i64,
    pub created_at: String,
    pub revoked_at: Option<String>,
}

impl Stored for TokenRow {
    const COLUMNS: &'static str =
        "id, name, role, secret_sha256, all_cells, created_at, revoked_at";
    const FROM: &'static str = "tokens";
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

impl Stored for RobotRow {
    const COLUMNS: &'static str = "name, urdf, maker, product, payload_kg, created_at";
    const FROM: &'static str = "robots";
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
    /// See [`CellState`].
    pub revision: i64,
    pub reload_revision: i64,
}

impl Stored for CellRow {
    const COLUMNS: &'static str = "id, name, settings, created_at, model_version, settings_changed_at, \
        revision, reload_revision";
    const FROM: &'static str = "cells";
}

/// Where a cell's writes stand: every write to the cell advances `revision`; one after which a
/// model in memory cannot follow incrementally (an edit, new settings, an import) also sets
/// `reload_revision` to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, FromRow)]
pub struct CellState {
    pub id: i64,
    pub revision: i64,
    pub reload_revision: i64,
    pub model_version: i64,
}

impl Stored for CellState {
    const COLUMNS: &'static str = "id, revision, reload_revision, model_version";
    const FROM: &'static str = "cells";
}

#[derive(Debug, Clone, FromRow)]
pub struct ProgramRow {
    pub id: i64,
    pub cell_id: i64,
    pub name: String,
    pub created_at: String,
}

impl Stored for ProgramRow {
    const COLUMNS: &'static str = "id, cell_id, name, created_at";
    const FROM: &'static str = "programs";
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
    #[sqlx(try_from = "Flag")]
    pub imported: bool,
    /// Number of waypoints.
    pub waypoints: i64,
}

impl Stored for RoutineRow {
    const COLUMNS: &'static str = "r.id, r.program_id, r.cell_id, r.position, r.name, \
        r.finish_seq, r.finished_at, r.created_at, r.imported, \
        (SELECT COUNT(*) FROM waypoints w WHERE w.routine_id = r.id) AS waypoints";
    const FROM: &'static str = "routines r";
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
    pub pose: PoseValues,
    /// JSON array of joint values (rad).
    pub joints: Option<String>,
    pub motion: Option<String>,
    pub name: Option<String>,
    /// Whether the cell's arm reaches it (None: not checked).
    #[sqlx(try_from = "MaybeFlag")]
    pub reachable: Option<bool>,
    pub created_at: String,
}

impl Stored for WaypointRow {
    const COLUMNS: &'static str = "id, routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
        reachable, created_at";
    const FROM: &'static str = "waypoints";
}

/// A waypoint's values ([`WaypointValues`], the program model's) from and to rows.
impl WaypointValues {
    /// A stored waypoint's values.
    pub fn of(row: &WaypointRow) -> WaypointValues {
        WaypointValues {
            pose: row.pose,
            joints: row.joints.clone(),
            motion: row.motion.clone(),
            name: row.name.clone(),
            reachable: row.reachable,
        }
    }

    /// These values at place `seq` of a routine, ready to insert.
    pub(super) fn at(&self, routine_id: i64, seq: i64) -> NewWaypoint {
        NewWaypoint {
            routine_id,
            seq,
            pose: self.pose,
            joints: self.joints.clone(),
            motion: self.motion.clone(),
            name: self.name.clone(),
            reachable: self.reachable,
        }
    }
}

#[derive(Debug, Clone)]
pub struct NewWaypoint {
    pub routine_id: i64,
    pub seq: i64,
    pub pose: PoseValues,
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
    pub pose: PoseValues,
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
    /// The routine's last waypoint when the prediction was made (None: none, or made before
    /// this was kept).
    pub after_waypoint_id: Option<i64>,
    #[sqlx(flatten)]
    pub pose: PoseValues,
    pub phi: f64,
    pub psi: f64,
    pub misfit: Option<f64>,
    pub end_probability: f64,
    pub model_version: i64,
    pub created_at: String,
    /// The feedback verdict, when there is one.
    pub verdict: Option<String>,
}

impl Stored for PredictionRow {
    const COLUMNS: &'static str = "p.id, p.cell_id, p.routine_id, p.after_seq, p.after_waypoint_id, \
        p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz, p.phi, p.psi, p.misfit, \
        p.end_probability, p.model_version, p.created_at, f.verdict";
    const FROM: &'static str = "predictions p LEFT JOIN feedback f ON f.prediction_id = p.id";
}

#[derive(Debug, Clone)]
pub struct NewFeedback {
    pub prediction_id: i64,
    /// `accepted`, `adjusted` or `rejected`.
    pub verdict: &'static str,
    pub pose: Option<PoseValues>,
    pub adjustment_mm: Option<f64>,
    /// Given while its routine was being taught, about the waypoint taught after the
    /// prediction: the cell's model applies it with that waypoint (`app::feedback`).
    pub teaches: bool,
}

/// Feedback that teaches the cell, with the prediction it is about: what a model applies with
/// the waypoint taught after `after_waypoint_id` at place `after_seq + 1` of its routine.
#[derive(Debug, Clone)]
pub struct TeachingVerdictRow {
    pub after_seq: i64,
    pub after_waypoint_id: Option<i64>,
    /// The pose offered.
    pub offered: PoseValues,
    /// `accepted`, `adjusted` or `rejected`.
    pub verdict: String,
    /// The pose finally taught (adjusted only).
    pub taught_as: Option<PoseValues>,
}

impl<'r> FromRow<'r, AnyRow> for TeachingVerdictRow {
    fn from_row(row: &'r AnyRow) -> Result<Self, sqlx::Error> {
        let f = |c: &str| row.try_get::<Option<f64>, _>(c);
        let taught_as = match (f("fx")?, f("fy")?, f("fz")?, f("fqw")?) {
            (Some(x), Some(y), Some(z), Some(qw)) => Some(PoseValues {
                x,
                y,
                z,
                qw,
                qx: f("fqx")?.unwrap_or_default(),
                qy: f("fqy")?.unwrap_or_default(),
                qz: f("fqz")?.unwrap_or_default(),
            }),
            _ => None,
        };
        Ok(TeachingVerdictRow {
            after_seq: row.try_get("after_seq")?,
            after_waypoint_id: row.try_get("after_waypoint_id")?,
            offered: PoseValues::from_row(row)?,
            verdict: row.try_get("verdict")?,
            taught_as,
        })
    }
}

impl Stored for TeachingVerdictRow {
    const COLUMNS: &'static str = "p.after_seq, p.after_waypoint_id, p.x, p.y, p.z, p.qw, p.qx, \
        p.qy, p.qz, f.verdict, f.x AS fx, f.y AS fy, f.z AS fz, f.qw AS fqw, f.qx AS fqx, \
        f.qy AS fqy, f.qz AS fqz";
    const FROM: &'static str = "feedback f JOIN predictions p ON p.id = f.prediction_id";
}

#[derive(Debug, Clone, Default)]
pub struct FeedbackCounts {
    pub offered: i64,
    pub accepted: i64,
    pub adjusted: i64,
    pub rejected: i64,
    pub adjustments_mm: Vec<f64>,
}
