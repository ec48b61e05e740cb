//! The resources the service exposes, as both adapters send and receive them.
//!
//! Inputs refuse unknown fields (a misspelt setting must not be silently ignored). Poses are
//! position in mm and a unit quaternion `w, x, y, z` in the cell's work frame; a quaternion
//! within 1e-3 of unit norm is normalised, anything farther is refused.

use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::settings::{CellSettings, CellSettingsInput};

pub use crate::engine::PoseValues;

// ---- cells ------------------------------------------------------------------------------------

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateCell {
    /// Unique name of the work cell (not blank; at most 200 characters).
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
    /// Engine, robot and frame settings; anything left out takes the profile's default.
    #[serde(default)]
    pub settings: CellSettingsInput,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Cell {
    pub id: i64,
    pub name: String,
    pub settings: CellSettings,
    pub created_at: String,
    /// When the settings last changed (`null`: as created).
    pub settings_changed_at: Option<String>,
}

/// Changes to a cell: its name, and settings given as at creation (only the fields given
/// change; the rest keep their values, except that a new profile brings its own offer rule
/// unless `offer_threshold` is given too). New settings are validated like a new cell's; the
/// model is learned again with them and its version advances.
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CellPatch {
    /// Not blank; at most 200 characters; unique.
    #[schema(min_length = 1, max_length = 200)]
    pub name: Option<String>,
    pub settings: Option<CellSettingsInput>,
}

/// The learned model of a cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ModelInfo {
    pub states: usize,
    /// Distinct transitions between states.
    pub edges: usize,
    /// Mean out-degree (edges / states).
    pub perplexity: f64,
    /// Finished routines assimilated.
    pub routines: u32,
    /// Longest routine assimilated, in moves.
    pub depth: usize,
    /// Moves assimilated.
    pub observations: u64,
    /// Increases by one with every finished routine; predictions record it.
    pub version: i64,
}

/// What operators did with the offered predictions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct FeedbackStats {
    /// Predictions offered (recorded).
    pub offered: i64,
    pub accepted: i64,
    pub adjusted: i64,
    pub rejected: i64,
    /// Offered predictions without feedback yet.
    pub pending: i64,
    /// (accepted + adjusted) / predictions with feedback; null without feedback.
    pub acceptance: Option<f64>,
    /// Median distance (mm) between adjusted predictions and the pose finally taught.
    pub median_adjustment_mm: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct CellStats {
    pub cell_id: i64,
    pub model: ModelInfo,
    pub feedback: FeedbackStats,
}

// ---- programs and routines --------------------------------------------------------------------

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateProgram {
    /// Name, unique within the cell (not blank; at most 200 characters).
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Program {
    pub id: i64,
    pub cell_id: i64,
    pub name: String,
    pub created_at: String,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateRoutine {
    /// Not blank; at most 200 characters.
    #[schema(min_length = 1, max_length = 200)]
    pub name: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Routine {
    pub id: i64,
    pub program_id: i64,
    pub cell_id: i64,
    /// Order within the program (1, 2, ...).
    pub position: i64,
    pub name: Option<String>,
    /// Immutable: finished by the operator, or imported.
    pub finished: bool,
    /// Part of the cell's model (finished, or imported with `learn`).
    pub learned: bool,
    /// Imported from an offline program.
    pub imported: bool,
    /// Order in which the cell's model assimilated it (finished routines only).
    pub finish_seq: Option<i64>,
    pub finished_at: Option<String>,
    pub waypoint_count: i64,
    pub created_at: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct RoutineDetail {
    #[serde(flatten)]
    pub routine: Routine,
    pub waypoints: Vec<Waypoint>,
}

// ---- waypoints --------------------------------------------------------------------------------

/// How the arm moves to a waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum MotionType {
    Joint,
    Linear,
    Circular,
}

impl MotionType {
    pub fn as_str(self) -> &'static str {
        match self {
            MotionType::Joint => "joint",
            MotionType::Linear => "linear",
            MotionType::Circular => "circular",
        }
    }

    pub fn parse(s: &str) -> Option<MotionType> {
        match s {
            "joint" => Some(MotionType::Joint),
            "linear" => Some(MotionType::Linear),
            "circular" => Some(MotionType::Circular),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewWaypointDto {
    pub pose: PoseValues,
    /// Taught joint values (rad), when the pendant sends them (1 to 12 values).
    #[schema(min_items = 1, max_items = 12)]
    pub joints: Option<Vec<f64>>,
    pub motion: Option<MotionType>,
    /// Not blank; at most 200 characters.
    #[schema(min_length = 1, max_length = 200)]
    pub name: Option<String>,
}

impl NewWaypointDto {
    /// A waypoint taught by its pose alone.
    pub fn at(pose: &crate::engine::Pose) -> NewWaypointDto {
        NewWaypointDto {
            pose: pose.into(),
            joints: None,
            motion: None,
            name: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Waypoint {
    pub id: i64,
    pub routine_id: i64,
    /// Teaching order within the routine (1, 2, ...).
    pub seq: i64,
    pub pose: PoseValues,
    pub joints: Option<Vec<f64>>,
    pub motion: Option<MotionType>,
    pub name: Option<String>,
    /// Whether the cell's arm reaches this waypoint (stored and flagged either way: the
    /// operator is the authority); null when not checked.
    pub reachable: Option<bool>,
    pub created_at: String,
}

// ---- predictions ------------------------------------------------------------------------------

/// Why no prediction is offered.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WithheldDto {
    /// One of `nothing_taught`, `empty_model`, `too_few_states`, `no_match`, `likely_end`,
    /// `poor_match`, `low_confidence`, `wide_spread`, `little_evidence`, `unlikely` (the experts' best
    /// candidate is below the cell's p_useful threshold), `unreachable` (the
    /// cell's arm cannot reach the proposal; see `reachability`).
    pub reason: String,
    pub message: String,
}

/// A prediction of the next waypoint, offered or not, with every figure that decided it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PredictionDto {
    /// Id of the recorded prediction, for feedback (offered predictions only).
    pub id: Option<i64>,
    pub offered: bool,
    /// Why it is withheld; null when offered.
    pub withheld: Option<WithheldDto>,
    /// The proposal checked against the cell's arm (null when nothing was proposed, or the
    /// cell's robot model is not installed).
    pub reachability: Option<ReachabilityDto>,
    /// The proposed next pose (null when nothing could be proposed).
    pub pose: Option<PoseValues>,
    /// The relative move from the last waypoint to the proposal, in the last waypoint's frame
    /// (SRHCT 7-vector: mm and a quaternion with `qw ≥ 0`).
    pub relative: Option<PoseValues>,
    /// Confidence φ ∈ [0, 1] (entropy of the next-state distribution).
    pub phi: f64,
    /// ψ: the factor mapping the taught window onto the learned pattern.
    pub psi: f64,
    /// Size of the routine relative to the learned pattern (1/ψ: 2 for a 2× copy).
    pub routine_scale: f64,
    /// Probability that the routine ends here.
    pub end_probability: f64,
    /// Match quality: mean squared Mahalanobis misfit of the window to its likeliest states
    /// (null without a window).
    pub misfit: Option<f64>,
    /// Expected squared Mahalanobis distance of the next move from the proposal.
    pub spread: Option<f64>,
    /// Earlier continuations of the matched states that agree with the proposal.
    pub support: f64,
    /// Moves the prediction conditioned on.
    pub window: usize,
    /// States of the model.
    pub states: usize,
    /// Waypoints of the routine when the prediction was made.
    pub after_waypoints: i64,
    pub model_version: i64,
    /// The estimated probability that the proposal is within the cell's tolerance of the next
    /// waypoint: the experts' offer rule offers the likeliest candidate when this reaches the
    /// threshold (null for the seed profile, which uses the model's own gates).
    pub p_useful: Option<f64>,
    /// Who proposed it: `model` (the CDHMM), `tool`, `work` or `absolute` (the sequence
    /// experts over tool-frame moves, work-frame moves and absolute poses); null for the seed
    /// profile.
    pub expert: Option<String>,
}

/// A taught waypoint and the prediction for the next one.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Taught {
    pub waypoint: Waypoint,
    pub prediction: PredictionDto,
}

/// The waypoint an undo removed and the prediction for the routine as it is now.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Undone {
    pub removed: Waypoint,
    pub prediction: PredictionDto,
}

/// A field an edit may leave out (unchanged), set, or clear with `null`.
fn present<'de, D, T>(d: D) -> Result<Option<Option<T>>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<T>::deserialize(d).map(Some)
}

/// Changes to a waypoint ("modify position" and more): fields left out stay as they are;
/// `joints`, `motion` and `name` may be cleared with `null`.
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WaypointPatch {
    pub pose: Option<PoseValues>,
    /// Taught joint values (rad; 1 to 12 values), or `null` to clear them.
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<Vec<f64>>, nullable, min_items = 1, max_items = 12)]
    pub joints: Option<Option<Vec<f64>>>,
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<MotionType>, nullable)]
    pub motion: Option<Option<MotionType>>,
    /// Not blank; at most 200 characters; `null` to clear it.
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<String>, nullable, min_length = 1, max_length = 200)]
    pub name: Option<Option<String>>,
}

/// Where an inserted waypoint goes, next to an existing one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Before,
    After,
}

/// A waypoint to insert before or after an existing one of any routine.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct InsertWaypoint {
    pub side: Side,
    pub waypoint: NewWaypointDto,
}

/// What an edit of a waypoint did, and what reverts it: `previous` holds the waypoint's
/// values before a change or a delete (re-insert them at its `seq`; `null` after an insert,
/// which a delete of `waypoint` reverts). `model_version` is the cell's model version after
/// the edit: it advances when a learned (finished) routine changed; the model is rebuilt from
/// the stored routines.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct WaypointEdit {
    /// The waypoint as it is now (`null` after a delete).
    pub waypoint: Option<Waypoint>,
    pub previous: Option<Waypoint>,
    pub model_version: i64,
}

/// Changes to a routine: its name (`null` clears it) and its place in its program (1 = first;
/// beyond the last is the last).
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RoutinePatch {
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    #[schema(value_type = Option<String>, nullable, min_length = 1, max_length = 200)]
    pub name: Option<Option<String>>,
    #[schema(minimum = 1)]
    pub position: Option<i64>,
}

/// A routine after an edit, with its values before (what reverts it).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct RoutineEdit {
    pub routine: Routine,
    pub previous: Routine,
}

/// A new name for a program or a cell.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Rename {
    /// Not blank; at most 200 characters; unique among its siblings.
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
}

/// Three points measured on a fixture (mm, work frame): the origin, a point on its x axis
/// and a point in its xy plane (the pendant's three-point frame), in its old and its new place.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FixturePoints {
    #[schema(min_items = 3, max_items = 3)]
    pub old: Vec<[f64; 3]>,
    #[schema(min_items = 3, max_items = 3)]
    pub new: Vec<[f64; 3]>,
}

/// Where a routine's or program's fixture went: either `frame`, the moved work object's frame in
/// the current one, or `points` measured on it before and after. The copy is stored under `name`
/// (default: the original's with " (moved)").
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Retarget {
    pub frame: Option<PoseValues>,
    pub points: Option<FixturePoints>,
    /// Not blank; at most 200 characters.
    #[schema(min_length = 1, max_length = 200)]
    pub name: Option<String>,
}

/// The re-targeted copy: a new program (or a new routine at the end of the program), finished and
/// not learned (it was not taught), every waypoint checked for reach (`reachable`), and how many
/// the arm does not reach.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Retargeted {
    pub program: Program,
    pub routines: Vec<RoutineDetail>,
    pub unreachable: usize,
}

/// Query of a program export.
#[derive(Debug, Clone, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ExportQuery {
    /// `rapid` (one `.mod`), `krl` (a `.src` and its `.dat`) or `fanuc` (one `.ls` per
    /// routine).
    pub format: String,
}

/// One file of an exported program.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ExportedFileDto {
    pub file_name: String,
    pub text: String,
}

/// A program written for a controller: the files, what the export had to change or could not
/// say (renamed targets, unpaired circles, unknown configurations, unreachable targets), and
/// the waypoints out of the arm's reach (their moves carry a comment in the file).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ProgramExport {
    pub format: String,
    pub files: Vec<ExportedFileDto>,
    pub warnings: Vec<String>,
    pub unreachable: Vec<i64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Finished {
    pub routine: Routine,
    pub model: ModelInfo,
}

/// Per-request overrides of the cell's settings for `GET .../prediction`.
#[derive(Debug, Clone, Default, Serialize, Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct PredictQuery {
    /// Moves to condition on (1–50).
    #[param(minimum = 1, maximum = 50)]
    pub horizon: Option<usize>,
    /// Minimum confidence φ (0–1).
    #[param(minimum = 0, maximum = 1)]
    pub phi_min: Option<f64>,
    /// Estimate the routine's scale.
    pub scale: Option<bool>,
    /// Number of next waypoints to predict (open-loop completion, 1–100; stops at the first
    /// prediction that is not offered).
    #[param(minimum = 1, maximum = 100)]
    pub k: Option<usize>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct PredictionSet {
    pub routine_id: i64,
    /// The predictions in order; the last one says why the completion stopped when it is not
    /// offered.
    pub predictions: Vec<PredictionDto>,
}

// ---- feedback ---------------------------------------------------------------------------------

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Accepted as is.
    Accepted,
    /// Accepted, then adjusted to the given pose.
    Adjusted,
    Rejected,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Accepted => "accepted",
            Verdict::Adjusted => "adjusted",
            Verdict::Rejected => "rejected",
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FeedbackDto {
    pub verdict: Verdict,
    /// The pose finally taught; required when `adjusted`, refused otherwise.
    pub pose: Option<PoseValues>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct FeedbackRecorded {
    pub prediction_id: i64,
    pub verdict: Verdict,
    /// Distance (mm) from the prediction to the final pose (0 when accepted as is).
    pub adjustment_mm: Option<f64>,
}

// ---- import -----------------------------------------------------------------------------------

/// One uploaded program file.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct UploadedFile {
    /// File name with its extension (`.mod`, `.modx`, `.prg`, `.sys`, `.src`, `.dat`, `.ls`);
    /// keep the folder (`job/main.ls`) where programs span several files. Not blank; at most
    /// 200 characters.
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
    /// The file's text.
    pub content: String,
}

/// Offline programs to import into a cell.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ImportRequest {
    /// The files of one upload, parsed together (RAPID targets resolve across modules; a KRL
    /// `.src` pairs with its `.dat`).
    #[schema(min_items = 1)]
    pub files: Vec<UploadedFile>,
    /// Learn the imported routines into the cell's model, in program order (default true).
    /// The cell must not be teaching a routine.
    pub learn: Option<bool>,
}

/// A program created by an import.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ImportedProgramDto {
    pub program: Program,
    /// `rapid`, `krl` or `fanuc`.
    pub language: String,
    pub source: String,
    pub routines: usize,
    pub waypoints: usize,
}

/// Something in the upload that was not imported, and why.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct SkippedDto {
    pub file: String,
    pub line: usize,
    pub routine: Option<String>,
    /// `joint-move`, `unresolved-name`, `computed-at-run-time`, `in-error-handler`,
    /// `invalid-target`, `short-routine`, `data-only`, `no-routines` (a file or FANUC folder
    /// with no routine left: no program is made of it).
    pub reason: String,
    pub text: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ImportResult {
    pub programs: Vec<ImportedProgramDto>,
    pub skipped: Vec<SkippedDto>,
    /// The cell's model after the import.
    pub model: ModelInfo,
}

// ---- replay -----------------------------------------------------------------------------------

/// A replay of programs through the engine and the baselines (the scoreboard).
#[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReplayRequest {
    /// Program files to replay (as for an import). Give these or `cell_id`.
    #[schema(min_items = 1)]
    pub files: Option<Vec<UploadedFile>>,
    /// Replay a cell's stored programs (taught and imported), in the order they were created.
    pub cell_id: Option<i64>,
    /// Engine settings to start from (default `default`).
    pub profile: Option<crate::engine::Profile>,
    /// Complexity δ ∈ (0, 1].
    #[schema(exclusive_minimum = 0, maximum = 1)]
    pub delta: Option<f64>,
    /// Minimum confidence φ ∈ [0, 1].
    #[schema(minimum = 0, maximum = 1)]
    pub phi_min: Option<f64>,
    /// Moves a prediction conditions on (1–50).
    #[schema(minimum = 1, maximum = 50)]
    pub horizon: Option<usize>,
    /// Estimate the scale ψ.
    pub scale: Option<bool>,
}

// ---- reachability ------------------------------------------------------------------------------

/// Why a pose is unreachable, for clients.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct UnreachableDto {
    /// `outside_reach`, `joint_limit` or `singular`.
    pub reason: String,
    pub message: String,
}

/// The joint nearest its limit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct JointMarginDto {
    pub name: String,
    /// Radians to the nearer limit.
    pub margin_rad: f64,
}

/// Whether the cell's arm reaches a pose, and how.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ReachabilityDto {
    pub robot: String,
    pub reachable: bool,
    /// Why not, when not.
    pub unreachable: Option<UnreachableDto>,
    /// Number of joint solutions within limits (multi-turn variants included).
    pub solutions: usize,
    /// The solution nearest the previous waypoint's joints (rad).
    pub chosen: Option<Vec<f64>>,
    /// Smallest singular value of the Jacobian at the chosen solution (singularity margin).
    pub sigma_min: Option<f64>,
    pub manipulability: Option<f64>,
    pub limiting_joint: Option<JointMarginDto>,
}

/// A layout search: where to stand an arm so that it reaches a program's waypoints. The
/// targets are one of `program_id` (its routines' waypoints), `cell_id` (every program of the
/// cell) or `targets` (poses in the work frame, mm).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PlacementSearch {
    pub program_id: Option<i64>,
    pub cell_id: Option<i64>,
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
pub struct PlacementDto {
    /// Robot base frame in the work frame, mm.
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
    pub placements: Vec<PlacementDto>,
}

// ---- the arm, as a pendant draws and jogs it --------------------------------------------------

/// `GET /v1/cells/{cell_id}/frames`: the joint vector to draw.
#[derive(Debug, Clone, Default, Serialize, Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct FramesQuery {
    /// Six joint values (rad), comma-separated (`0,0.3,-0.2,0,0.8,0`); left out: the arm's
    /// ready position (flange pointing down in front of the base).
    pub joints: Option<String>,
}

impl FramesQuery {
    /// The joint values given, as numbers (the service checks that there are six).
    pub fn values(&self) -> Result<Option<Vec<f64>>, super::AppError> {
        let Some(text) = &self.joints else {
            return Ok(None);
        };
        text.split(',')
            .enumerate()
            .map(|(i, v)| {
                v.trim().parse::<f64>().map_err(|_| {
                    super::AppError::Invalid(format!(
                        "joints: value {} ({v:?}) is not a number",
                        i + 1
                    ))
                })
            })
            .collect::<Result<Vec<f64>, _>>()
            .map(Some)
    }
}

/// One frame of the arm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct LinkFrame {
    /// The robot base link's name, then each joint's.
    pub name: String,
    pub pose: PoseValues,
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
    pub flange: PoseValues,
    /// The tool centre point: the flange with the cell's `tool` mounted.
    pub tcp: PoseValues,
}

/// `POST /v1/cells/{cell_id}/reach`: can the arm put its TCP at `pose`, and with which
/// joints (the solution nearest `near`, as a jog from where the arm is)?
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReachQuery {
    /// TCP pose in the work frame.
    pub pose: PoseValues,
    /// Where the arm is (six joint values, rad); left out: the solution nearest the middle of
    /// the joint ranges.
    #[schema(min_items = 6, max_items = 6)]
    pub near: Option<Vec<f64>>,
}

// ---- hand-guided trajectories ------------------------------------------------------------------

pub use crate::engine::segment::Criterion;

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
    /// Fewest steps of a segment before it may be cut (default 2).
    #[schema(minimum = 1)]
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
pub struct SegmentationDto {
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
    pub segmentation: SegmentationDto,
}
