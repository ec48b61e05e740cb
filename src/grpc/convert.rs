//! Resources ↔ protobuf messages. Outbound conversions are total; inbound ones refuse what the
//! wire allows but the resource cannot hold (a missing pose, an unknown enum value) with
//! `INVALID_ARGUMENT`, as the REST adapter refuses malformed JSON.

use tonic::Status;

use super::pb;
use crate::api::{
    ArmFrames, Cell, CellPatch, CellSettings, CellSettingsInput, CellStats, CreateCell, Criterion,
    Feedback, FeedbackRecorded, FeedbackStats, Finished, FixturePoints, ImportRequest,
    ImportResult, InsertWaypoint, JointMargin, ModelInfo, MotionType, NewWaypoint, PlacementSearch,
    Placements, PoseValues, PredictQuery, Prediction, PredictionSet, Program, ProgramExport,
    ReachQuery, Reachability, ReplayRequest, Retarget, Retargeted, Robot, RobotUpload, Routine,
    RoutineDetail, RoutineEdit, RoutinePatch, ScaleSettings, Segmentation, Side, Taught,
    TrajectoryAnswer, TrajectoryPoint, TrajectoryRequest, TrajectorySample, TrajectorySegment,
    TrajectorySettings, Undone, Unreachable, UploadedFile, Verdict, Waypoint, WaypointEdit,
    WaypointPatch, Withheld,
};
use crate::engine::Noise;
use crate::engine::Profile;
use crate::engine::Tolerance;
use crate::export::ExportSettings;
use crate::kinematics::{BaseMounting, ReachPolicy};
use crate::replay::metrics::Scores;
use crate::replay::reliability::{Calibration, ReliabilityBin, RiskCoveragePoint};
use crate::replay::report::{MethodMetrics, OracleSection, Report};

type In<T> = Result<T, Status>;

fn required<T>(v: Option<T>, what: &str) -> In<T> {
    v.ok_or_else(|| Status::invalid_argument(format!("{what} is required")))
}

fn usize_from(v: u64, what: &str) -> In<usize> {
    usize::try_from(v).map_err(|_| Status::invalid_argument(format!("{what} is too large")))
}

// ---- poses ------------------------------------------------------------------------------------

impl From<PoseValues> for pb::Pose {
    fn from(p: PoseValues) -> pb::Pose {
        pb::Pose {
            x: p.x,
            y: p.y,
            z: p.z,
            qw: p.qw,
            qx: p.qx,
            qy: p.qy,
            qz: p.qz,
        }
    }
}

impl From<pb::Pose> for PoseValues {
    fn from(p: pb::Pose) -> PoseValues {
        PoseValues {
            x: p.x,
            y: p.y,
            z: p.z,
            qw: p.qw,
            qx: p.qx,
            qy: p.qy,
            qz: p.qz,
        }
    }
}

// ---- cells ------------------------------------------------------------------------------------

fn profile_in(v: i32) -> In<Option<Profile>> {
    match pb::Profile::try_from(v) {
        Ok(pb::Profile::Unspecified) => Ok(None),
        Ok(pb::Profile::Seed) => Ok(Some(Profile::Seed)),
        Ok(pb::Profile::Default) => Ok(Some(Profile::Default)),
        Err(_) => Err(Status::invalid_argument(format!("unknown profile {v}"))),
    }
}

fn profile_out(p: Profile) -> pb::Profile {
    match p {
        Profile::Seed => pb::Profile::Seed,
        Profile::Default => pb::Profile::Default,
    }
}

fn reach_policy_in(v: i32) -> In<Option<ReachPolicy>> {
    match pb::ReachPolicy::try_from(v) {
        Ok(pb::ReachPolicy::Unspecified) => Ok(None),
        Ok(pb::ReachPolicy::Withhold) => Ok(Some(ReachPolicy::Withhold)),
        Ok(pb::ReachPolicy::Flag) => Ok(Some(ReachPolicy::Flag)),
        Err(_) => Err(Status::invalid_argument(format!(
            "unknown reach policy {v}"
        ))),
    }
}

fn reach_policy_out(p: ReachPolicy) -> pb::ReachPolicy {
    match p {
        ReachPolicy::Withhold => pb::ReachPolicy::Withhold,
        ReachPolicy::Flag => pb::ReachPolicy::Flag,
    }
}

fn scale_in(s: pb::ScaleSettings) -> ScaleSettings {
    ScaleSettings {
        enabled: s.enabled,
        psi_min: s.psi_min,
        psi_max: s.psi_max,
    }
}

fn scale_out(s: ScaleSettings) -> pb::ScaleSettings {
    pb::ScaleSettings {
        enabled: s.enabled,
        psi_min: s.psi_min,
        psi_max: s.psi_max,
    }
}

pub fn create_cell(r: pb::CreateCellRequest) -> In<CreateCell> {
    Ok(CreateCell {
        name: r.name,
        settings: settings_input(r.settings.unwrap_or_default())?,
    })
}

pub fn cell_patch(r: pb::UpdateCellRequest) -> In<CellPatch> {
    Ok(CellPatch {
        name: r.name,
        settings: r.settings.map(settings_input).transpose()?,
    })
}

fn settings_input(s: pb::CellSettingsInput) -> In<CellSettingsInput> {
    Ok(CellSettingsInput {
        profile: profile_in(s.profile)?,
        delta: s.delta,
        phi_min: s.phi_min,
        horizon: s.horizon.map(|h| usize_from(h, "horizon")).transpose()?,
        sigma_t_mm: s.sigma_t_mm,
        sigma_q: s.sigma_q,
        scale: s.scale.map(scale_in),
        robot: s.robot,
        base: s.base.map(PoseValues::from),
        tool: s.tool.map(PoseValues::from),
        reach_policy: reach_policy_in(s.reach_policy)?,
        noise: s.noise.map(|n| Noise {
            mm: n.mm,
            rad: n.rad,
        }),
        tolerance: s.tolerance.map(|t| Tolerance {
            mm: t.mm,
            rad: t.rad,
        }),
        offer_threshold: s.offer_threshold,
        export: s.export.map(export_settings_in),
    })
}

fn export_settings_in(e: pb::ExportSettings) -> ExportSettings {
    ExportSettings {
        speed_mm_s: e.speed_mm_s,
        zone_mm: e.zone_mm,
        work_object: e.work_object,
        tool: e.tool,
    }
}

fn export_settings_out(e: ExportSettings) -> pb::ExportSettings {
    pb::ExportSettings {
        speed_mm_s: e.speed_mm_s,
        zone_mm: e.zone_mm,
        work_object: e.work_object,
        tool: e.tool,
    }
}

impl From<ProgramExport> for pb::ProgramExport {
    fn from(e: ProgramExport) -> pb::ProgramExport {
        pb::ProgramExport {
            format: e.format,
            files: e
                .files
                .into_iter()
                .map(|f| pb::ExportedFile {
                    file_name: f.file_name,
                    text: f.text,
                })
                .collect(),
            warnings: e.warnings,
            unreachable: e.unreachable,
        }
    }
}

fn tolerance_out(mm: f64, rad: f64) -> pb::Tolerance {
    pb::Tolerance { mm, rad }
}

fn settings_out(s: CellSettings) -> pb::CellSettings {
    pb::CellSettings {
        profile: profile_out(s.profile).into(),
        delta: s.delta,
        phi_min: s.phi_min,
        horizon: s.horizon as u64,
        sigma_t_mm: s.sigma_t_mm,
        sigma_q: s.sigma_q,
        scale: Some(scale_out(s.scale)),
        robot: s.robot,
        base: Some(s.base.into()),
        tool: Some(s.tool.into()),
        reach_policy: reach_policy_out(s.reach_policy).into(),
        noise: Some(tolerance_out(s.noise.mm, s.noise.rad)),
        tolerance: Some(tolerance_out(s.tolerance.mm, s.tolerance.rad)),
        offer_threshold: s.offer_threshold,
        export: Some(export_settings_out(s.export)),
    }
}

impl From<Cell> for pb::Cell {
    fn from(c: Cell) -> pb::Cell {
        pb::Cell {
            id: c.id,
            name: c.name,
            settings: Some(settings_out(c.settings)),
            created_at: c.created_at,
            settings_changed_at: c.settings_changed_at,
        }
    }
}

impl From<ModelInfo> for pb::ModelInfo {
    fn from(m: ModelInfo) -> pb::ModelInfo {
        pb::ModelInfo {
            states: m.states as u64,
            edges: m.edges as u64,
            perplexity: m.perplexity,
            routines: m.routines,
            depth: m.depth as u64,
            observations: m.observations,
            version: m.version,
        }
    }
}

impl From<CellStats> for pb::CellStats {
    fn from(s: CellStats) -> pb::CellStats {
        let f = s.feedback;
        pb::CellStats {
            cell_id: s.cell_id,
            model: Some(s.model.into()),
            feedback: Some(pb::FeedbackStats {
                offered: f.offered,
                accepted: f.accepted,
                adjusted: f.adjusted,
                rejected: f.rejected,
                pending: f.pending,
                acceptance: f.acceptance,
                median_adjustment_mm: f.median_adjustment_mm,
            }),
        }
    }
}

// ---- programs and routines --------------------------------------------------------------------

impl From<Program> for pb::Program {
    fn from(p: Program) -> pb::Program {
        pb::Program {
            id: p.id,
            cell_id: p.cell_id,
            name: p.name,
            created_at: p.created_at,
        }
    }
}

impl From<Routine> for pb::Routine {
    fn from(r: Routine) -> pb::Routine {
        pb::Routine {
            id: r.id,
            program_id: r.program_id,
            cell_id: r.cell_id,
            position: r.position,
            name: r.name,
            finished: r.finished,
            finish_seq: r.finish_seq,
            finished_at: r.finished_at,
            waypoint_count: r.waypoint_count,
            created_at: r.created_at,
            learned: r.learned,
            imported: r.imported,
        }
    }
}

impl From<RoutineDetail> for pb::RoutineDetail {
    fn from(d: RoutineDetail) -> pb::RoutineDetail {
        pb::RoutineDetail {
            routine: Some(d.routine.into()),
            waypoints: d.waypoints.into_iter().map(Into::into).collect(),
        }
    }
}

impl From<Finished> for pb::Finished {
    fn from(f: Finished) -> pb::Finished {
        pb::Finished {
            routine: Some(f.routine.into()),
            model: Some(f.model.into()),
        }
    }
}

// ---- waypoints and predictions ------------------------------------------------------------------

fn motion_in(v: i32) -> In<Option<MotionType>> {
    match pb::Motion::try_from(v) {
        Ok(pb::Motion::Unspecified) => Ok(None),
        Ok(pb::Motion::Joint) => Ok(Some(MotionType::Joint)),
        Ok(pb::Motion::Linear) => Ok(Some(MotionType::Linear)),
        Ok(pb::Motion::Circular) => Ok(Some(MotionType::Circular)),
        Err(_) => Err(Status::invalid_argument(format!("unknown motion {v}"))),
    }
}

fn motion_out(m: Option<MotionType>) -> pb::Motion {
    match m {
        None => pb::Motion::Unspecified,
        Some(MotionType::Joint) => pb::Motion::Joint,
        Some(MotionType::Linear) => pb::Motion::Linear,
        Some(MotionType::Circular) => pb::Motion::Circular,
    }
}

pub fn new_waypoint(w: pb::NewWaypoint) -> In<NewWaypoint> {
    Ok(NewWaypoint {
        pose: required(w.pose, "pose")?.into(),
        joints: (!w.joints.is_empty()).then_some(w.joints),
        motion: motion_in(w.motion)?,
        name: w.name,
    })
}

impl From<Waypoint> for pb::Waypoint {
    fn from(w: Waypoint) -> pb::Waypoint {
        pb::Waypoint {
            id: w.id,
            routine_id: w.routine_id,
            seq: w.seq,
            pose: Some(w.pose.into()),
            joints: w.joints.unwrap_or_default(),
            motion: motion_out(w.motion).into(),
            name: w.name,
            reachable: w.reachable,
            created_at: w.created_at,
        }
    }
}

fn unreachable_out(u: Unreachable) -> pb::Unreachable {
    pb::Unreachable {
        reason: u.reason,
        message: u.message,
    }
}

fn margin_out(m: JointMargin) -> pb::JointMargin {
    pb::JointMargin {
        name: m.name,
        margin_rad: m.margin_rad,
    }
}

impl From<Reachability> for pb::Reachability {
    fn from(r: Reachability) -> pb::Reachability {
        pb::Reachability {
            robot: r.robot,
            reachable: r.reachable,
            unreachable: r.unreachable.map(unreachable_out),
            solutions: r.solutions as u64,
            chosen: r.chosen.unwrap_or_default(),
            sigma_min: r.sigma_min,
            manipulability: r.manipulability,
            limiting_joint: r.limiting_joint.map(margin_out),
        }
    }
}

impl From<ArmFrames> for pb::ArmFrames {
    fn from(f: ArmFrames) -> pb::ArmFrames {
        pb::ArmFrames {
            robot: f.robot,
            joints: f.joints,
            base: Some(f.base.into()),
            links: f
                .links
                .into_iter()
                .map(|l| pb::LinkFrame {
                    name: l.name,
                    pose: Some(l.pose.into()),
                })
                .collect(),
            flange: Some(f.flange.into()),
            tcp: Some(f.tcp.into()),
        }
    }
}

/// A reach question: the pose is required; no `near` joints is none given.
pub fn reach_query(r: pb::CheckReachRequest) -> In<ReachQuery> {
    Ok(ReachQuery {
        pose: required(r.pose, "pose")?.into(),
        near: (!r.near.is_empty()).then_some(r.near),
    })
}

impl From<Prediction> for pb::Prediction {
    fn from(p: Prediction) -> pb::Prediction {
        pb::Prediction {
            id: p.id,
            offered: p.offered,
            withheld: p.withheld.map(|w| pb::Withheld {
                reason: w.reason,
                message: w.message,
            }),
            reachability: p.reachability.map(Into::into),
            pose: p.pose.map(Into::into),
            relative: p.relative.map(|r| pb::RelativeMove {
                x: r.x,
                y: r.y,
                z: r.z,
                qw: r.qw,
                qx: r.qx,
                qy: r.qy,
                qz: r.qz,
            }),
            phi: p.phi,
            psi: p.psi,
            routine_scale: p.routine_scale,
            end_probability: p.end_probability,
            misfit: p.misfit,
            spread: p.spread,
            support: p.support,
            window: p.window as u64,
            states: p.states as u64,
            after_waypoints: p.after_waypoints,
            model_version: p.model_version,
            p_useful: p.p_useful,
            expert: p.expert.unwrap_or_default(),
        }
    }
}

impl From<Taught> for pb::Taught {
    fn from(t: Taught) -> pb::Taught {
        pb::Taught {
            waypoint: Some(t.waypoint.into()),
            prediction: Some(t.prediction.into()),
        }
    }
}

impl From<Undone> for pb::Undone {
    fn from(u: Undone) -> pb::Undone {
        pb::Undone {
            removed: Some(u.removed.into()),
            prediction: Some(u.prediction.into()),
        }
    }
}

pub fn predict_query(r: &pb::PredictRequest) -> In<PredictQuery> {
    Ok(PredictQuery {
        horizon: r.horizon.map(|h| usize_from(h, "horizon")).transpose()?,
        phi_min: r.phi_min,
        scale: r.scale,
        k: r.k.map(|k| usize_from(k, "k")).transpose()?,
    })
}

impl From<PredictionSet> for pb::PredictionSet {
    fn from(s: PredictionSet) -> pb::PredictionSet {
        pb::PredictionSet {
            routine_id: s.routine_id,
            predictions: s.predictions.into_iter().map(Into::into).collect(),
        }
    }
}

// ---- feedback -----------------------------------------------------------------------------------

fn verdict_out(v: Verdict) -> pb::Verdict {
    match v {
        Verdict::Accepted => pb::Verdict::Accepted,
        Verdict::Adjusted => pb::Verdict::Adjusted,
        Verdict::Rejected => pb::Verdict::Rejected,
    }
}

pub fn feedback(r: pb::FeedbackRequest) -> In<Feedback> {
    let verdict = match pb::Verdict::try_from(r.verdict) {
        Ok(pb::Verdict::Accepted) => Verdict::Accepted,
        Ok(pb::Verdict::Adjusted) => Verdict::Adjusted,
        Ok(pb::Verdict::Rejected) => Verdict::Rejected,
        Ok(pb::Verdict::Unspecified) => {
            return Err(Status::invalid_argument("verdict is required"));
        }
        Err(_) => {
            return Err(Status::invalid_argument(format!(
                "unknown verdict {}",
                r.verdict
            )));
        }
    };
    Ok(Feedback {
        verdict,
        pose: r.pose.map(Into::into),
    })
}

impl From<FeedbackRecorded> for pb::FeedbackRecorded {
    fn from(f: FeedbackRecorded) -> pb::FeedbackRecorded {
        pb::FeedbackRecorded {
            prediction_id: f.prediction_id,
            verdict: verdict_out(f.verdict).into(),
            adjustment_mm: f.adjustment_mm,
        }
    }
}

// ---- robots -------------------------------------------------------------------------------------

impl From<Robot> for pb::Robot {
    fn from(r: Robot) -> pb::Robot {
        pb::Robot {
            name: r.name,
            source: r.source.as_str().to_string(),
            maker: r.maker,
            product: r.product,
            payload_kg: r.payload_kg,
            reach_mm: r.reach_mm,
            computed_reach_mm: r.computed_reach_mm,
            languages: r.languages,
            solver: r.solver,
            root: r.root,
            tip: r.tip,
            joints: r
                .joints
                .into_iter()
                .map(|j| pb::Joint {
                    name: j.name,
                    lower: j.lower,
                    upper: j.upper,
                    velocity: j.velocity,
                })
                .collect(),
        }
    }
}

// ---- import and replay ------------------------------------------------------------------------

fn uploaded(files: Vec<pb::UploadedFile>) -> Vec<UploadedFile> {
    files
        .into_iter()
        .map(|f| UploadedFile {
            name: f.name,
            content: f.content,
        })
        .collect()
}

pub fn import_request(r: pb::ImportProgramsRequest) -> ImportRequest {
    ImportRequest {
        files: uploaded(r.files),
        learn: r.learn,
    }
}

/// An empty `files` is "not given" (protobuf cannot tell the two apart), so the application's
/// "files or cell_id" rule decides.
pub fn replay_request(r: pb::ReplayRequest) -> In<ReplayRequest> {
    Ok(ReplayRequest {
        files: (!r.files.is_empty()).then(|| uploaded(r.files)),
        cell_id: r.cell_id,
        profile: profile_in(r.profile)?,
        delta: r.delta,
        phi_min: r.phi_min,
        horizon: r.horizon.map(|h| usize_from(h, "horizon")).transpose()?,
        scale: r.scale,
    })
}

impl From<ImportResult> for pb::ImportResult {
    fn from(r: ImportResult) -> pb::ImportResult {
        pb::ImportResult {
            programs: r
                .programs
                .into_iter()
                .map(|p| pb::ImportedProgram {
                    program: Some(p.program.into()),
                    language: p.language,
                    source: p.source,
                    routines: p.routines as u64,
                    waypoints: p.waypoints as u64,
                })
                .collect(),
            skipped: r
                .skipped
                .into_iter()
                .map(|s| pb::Skipped {
                    file: s.file,
                    line: s.line as u64,
                    routine: s.routine,
                    reason: s.reason,
                    text: s.text,
                })
                .collect(),
            model: Some(r.model.into()),
        }
    }
}

impl From<Scores> for pb::ReplayMetrics {
    fn from(m: Scores) -> pb::ReplayMetrics {
        let n = |v: usize| v as u64;
        pb::ReplayMetrics {
            predictable: n(m.predictable),
            offered: n(m.offered),
            useful: n(m.useful),
            offered_pct: m.offered_pct,
            useful_pct: m.useful_pct,
            precision_pct: m.precision_pct,
            saved_pct: m.saved_pct,
            median_cart_mm: m.median_cart_mm,
            median_angle_rad: m.median_angle_rad,
            median_cart_pct_travel: m.median_cart_pct_travel,
            median_angle_pct_travel: m.median_angle_pct_travel,
            spearman_conf_err: m.spearman_conf_err,
            pearson_conf_err: m.pearson_conf_err,
            spearman_phi_err: m.spearman_phi_err,
            predictable_n1: n(m.predictable_n1),
            offered_n1: n(m.offered_n1),
            useful_n1: n(m.useful_n1),
            offered_pct_n1: m.offered_pct_n1,
            useful_pct_n1: m.useful_pct_n1,
            precision_pct_n1: m.precision_pct_n1,
            saved_pct_n1: m.saved_pct_n1,
            median_cart_mm_n1: m.median_cart_mm_n1,
            median_angle_rad_n1: m.median_angle_rad_n1,
            spearman_conf_err_n1: m.spearman_conf_err_n1,
            states: m.states.map(n),
            edges: m.edges.map(n),
            perplexity: m.perplexity,
            us_per_waypoint: m.us_per_waypoint,
            reachable_pct: m.reachable_pct,
            taught_reachable_pct: m.taught_reachable_pct,
        }
    }
}

fn method_metrics(m: MethodMetrics) -> Vec<pb::MethodMetrics> {
    m.0.into_iter()
        .map(|(method, metrics)| pb::MethodMetrics {
            method,
            metrics: Some(metrics.into()),
        })
        .collect()
}

impl From<Report> for pb::ReplayReport {
    fn from(r: Report) -> pb::ReplayReport {
        // Serialising plain data into a string does not fail; an empty `json` if it ever did.
        let json = serde_json::to_string(&r.config).unwrap_or_default();
        let c = r.config;
        pb::ReplayReport {
            config: Some(pb::ReplayConfig {
                profile: c.profile,
                delta: c.engine.delta,
                phi_min: c.engine.predict.phi_min,
                horizon: c.engine.predict.horizon as u64,
                scale: c.engine.predict.scale.enabled,
                sigma_t: c.engine.sigma_t,
                sigma_q: c.engine.sigma_q,
                nearest_seq_gate: c.nearest_seq_gate,
                useful_max_mm: c.useful_max_mm,
                useful_max_rad: c.useful_max_rad,
                json,
            }),
            totals: method_metrics(r.totals),
            programs: r
                .programs
                .into_iter()
                .map(|p| pb::ProgramScore {
                    program: p.program,
                    language: p.language,
                    methods: method_metrics(p.methods),
                })
                .collect(),
            oracles: r.oracles.map(Into::into),
            calibration: r
                .calibration
                .0
                .into_iter()
                .map(|(method, c)| calibration_out(method, c))
                .collect(),
        }
    }
}

impl From<OracleSection> for pb::ReplayOracles {
    fn from(o: OracleSection) -> pb::ReplayOracles {
        pb::ReplayOracles {
            meaning: o.meaning.to_string(),
            useful_max_mm: o.useful_max_mm,
            useful_max_rad: o.useful_max_rad,
            kinds: o
                .kinds
                .into_iter()
                .map(|k| pb::OracleBound {
                    name: k.name,
                    candidates: k.candidates,
                    predictable: k.predictable as u64,
                    covered: k.covered as u64,
                    share_pct: k.share_pct,
                    predictable_n1: k.predictable_n1 as u64,
                    covered_n1: k.covered_n1 as u64,
                    share_pct_n1: k.share_pct_n1,
                })
                .collect(),
        }
    }
}

impl From<ReliabilityBin> for pb::ReliabilityBin {
    fn from(b: ReliabilityBin) -> pb::ReliabilityBin {
        pb::ReliabilityBin {
            from: b.from,
            to: b.to,
            candidates: b.candidates as u64,
            useful: b.useful as u64,
            mean_p_useful: b.mean_p_useful,
            observed: b.observed,
            gap: b.gap,
            within_target: b.within_target,
        }
    }
}

impl From<RiskCoveragePoint> for pb::RiskCoveragePoint {
    fn from(p: RiskCoveragePoint) -> pb::RiskCoveragePoint {
        pb::RiskCoveragePoint {
            threshold: p.threshold,
            offered: p.offered as u64,
            useful: p.useful as u64,
            offered_pct: p.offered_pct,
            precision_pct: p.precision_pct,
            useful_pct: p.useful_pct,
            saved_pct: p.saved_pct,
        }
    }
}

fn calibration_out(method: String, c: Calibration) -> pb::MethodCalibration {
    pb::MethodCalibration {
        method,
        meaning: c.meaning.to_string(),
        predictable: c.predictable as u64,
        candidates: c.candidates as u64,
        useful: c.useful as u64,
        offered: c.offered as u64,
        target_gap: c.target_gap,
        bins: c.bins.into_iter().map(Into::into).collect(),
        ece: c.ece,
        max_abs_gap: c.max_abs_gap,
        meets_target: c.meets_target,
        spearman_p_err: c.spearman_p_err,
        as_offered: Some(c.as_offered.into()),
        risk_coverage: c.risk_coverage.into_iter().map(Into::into).collect(),
        target_precision_pct: c.threshold_for_target_precision.target_precision_pct,
        threshold_for_target_precision: c.threshold_for_target_precision.point.map(Into::into),
    }
}

// ---- the client's direction: resources → requests, answers → resources ------------------------
//
// Used by `crate::client::grpc`. Requests are built from the same resource types the REST
// client sends; an answer missing a message the server always sets is `INVALID_ARGUMENT`.

fn settings_input_out(s: CellSettingsInput) -> pb::CellSettingsInput {
    pb::CellSettingsInput {
        profile: s
            .profile
            .map_or(pb::Profile::Unspecified, profile_out)
            .into(),
        delta: s.delta,
        phi_min: s.phi_min,
        horizon: s.horizon.map(|h| h as u64),
        sigma_t_mm: s.sigma_t_mm,
        sigma_q: s.sigma_q,
        scale: s.scale.map(scale_out),
        robot: s.robot,
        base: s.base.map(Into::into),
        tool: s.tool.map(Into::into),
        reach_policy: s
            .reach_policy
            .map_or(pb::ReachPolicy::Unspecified, reach_policy_out)
            .into(),
        noise: s.noise.map(|n| tolerance_out(n.mm, n.rad)),
        tolerance: s.tolerance.map(|t| tolerance_out(t.mm, t.rad)),
        offer_threshold: s.offer_threshold,
        export: s.export.map(export_settings_out),
    }
}

pub fn create_cell_request(c: CreateCell) -> pb::CreateCellRequest {
    pb::CreateCellRequest {
        name: c.name,
        settings: Some(settings_input_out(c.settings)),
    }
}

pub fn new_waypoint_out(w: NewWaypoint) -> pb::NewWaypoint {
    pb::NewWaypoint {
        pose: Some(w.pose.into()),
        joints: w.joints.unwrap_or_default(),
        motion: motion_out(w.motion).into(),
        name: w.name,
    }
}

pub fn feedback_request(prediction_id: i64, f: Feedback) -> pb::FeedbackRequest {
    pb::FeedbackRequest {
        prediction_id,
        verdict: verdict_out(f.verdict).into(),
        pose: f.pose.map(Into::into),
    }
}

pub fn predict_request(routine_id: i64, q: PredictQuery) -> pb::PredictRequest {
    pb::PredictRequest {
        routine_id,
        horizon: q.horizon.map(|h| h as u64),
        phi_min: q.phi_min,
        scale: q.scale,
        k: q.k.map(|k| k as u64),
    }
}

pub fn import_programs_request(cell_id: i64, r: ImportRequest) -> pb::ImportProgramsRequest {
    pb::ImportProgramsRequest {
        cell_id,
        files: r
            .files
            .into_iter()
            .map(|f| pb::UploadedFile {
                name: f.name,
                content: f.content,
            })
            .collect(),
        learn: r.learn,
    }
}

impl TryFrom<pb::Waypoint> for Waypoint {
    type Error = Status;
    fn try_from(w: pb::Waypoint) -> In<Waypoint> {
        Ok(Waypoint {
            id: w.id,
            routine_id: w.routine_id,
            seq: w.seq,
            pose: required(w.pose, "waypoint.pose")?.into(),
            joints: (!w.joints.is_empty()).then_some(w.joints),
            motion: motion_in(w.motion)?,
            name: w.name,
            reachable: w.reachable,
            created_at: w.created_at,
        })
    }
}

impl From<pb::Reachability> for Reachability {
    fn from(r: pb::Reachability) -> Reachability {
        Reachability {
            robot: r.robot,
            reachable: r.reachable,
            unreachable: r.unreachable.map(|u| Unreachable {
                reason: u.reason,
                message: u.message,
            }),
            solutions: r.solutions as usize,
            chosen: (!r.chosen.is_empty()).then_some(r.chosen),
            sigma_min: r.sigma_min,
            manipulability: r.manipulability,
            limiting_joint: r.limiting_joint.map(|m| JointMargin {
                name: m.name,
                margin_rad: m.margin_rad,
            }),
        }
    }
}

impl TryFrom<pb::Prediction> for Prediction {
    type Error = Status;
    fn try_from(p: pb::Prediction) -> In<Prediction> {
        Ok(Prediction {
            id: p.id,
            offered: p.offered,
            withheld: p.withheld.map(|w| Withheld {
                reason: w.reason,
                message: w.message,
            }),
            reachability: p.reachability.map(Into::into),
            pose: p.pose.map(Into::into),
            relative: p.relative.map(|r| PoseValues {
                x: r.x,
                y: r.y,
                z: r.z,
                qw: r.qw,
                qx: r.qx,
                qy: r.qy,
                qz: r.qz,
            }),
            phi: p.phi,
            psi: p.psi,
            routine_scale: p.routine_scale,
            end_probability: p.end_probability,
            misfit: p.misfit,
            spread: p.spread,
            support: p.support,
            window: usize_from(p.window, "window")?,
            states: usize_from(p.states, "states")?,
            after_waypoints: p.after_waypoints,
            model_version: p.model_version,
            p_useful: p.p_useful,
            expert: (!p.expert.is_empty()).then_some(p.expert),
        })
    }
}

impl TryFrom<pb::Taught> for Taught {
    type Error = Status;
    fn try_from(t: pb::Taught) -> In<Taught> {
        Ok(Taught {
            waypoint: required(t.waypoint, "taught.waypoint")?.try_into()?,
            prediction: required(t.prediction, "taught.prediction")?.try_into()?,
        })
    }
}

impl TryFrom<pb::PredictionSet> for PredictionSet {
    type Error = Status;
    fn try_from(s: pb::PredictionSet) -> In<PredictionSet> {
        Ok(PredictionSet {
            routine_id: s.routine_id,
            predictions: s
                .predictions
                .into_iter()
                .map(TryInto::try_into)
                .collect::<In<_>>()?,
        })
    }
}

impl TryFrom<pb::ModelInfo> for ModelInfo {
    type Error = Status;
    fn try_from(m: pb::ModelInfo) -> In<ModelInfo> {
        Ok(ModelInfo {
            states: usize_from(m.states, "states")?,
            edges: usize_from(m.edges, "edges")?,
            perplexity: m.perplexity,
            routines: m.routines,
            depth: usize_from(m.depth, "depth")?,
            observations: m.observations,
            version: m.version,
        })
    }
}

impl TryFrom<pb::CellStats> for CellStats {
    type Error = Status;
    fn try_from(s: pb::CellStats) -> In<CellStats> {
        let f = required(s.feedback, "stats.feedback")?;
        Ok(CellStats {
            cell_id: s.cell_id,
            model: required(s.model, "stats.model")?.try_into()?,
            feedback: FeedbackStats {
                offered: f.offered,
                accepted: f.accepted,
                adjusted: f.adjusted,
                rejected: f.rejected,
                pending: f.pending,
                acceptance: f.acceptance,
                median_adjustment_mm: f.median_adjustment_mm,
            },
        })
    }
}

pub fn waypoint_patch(r: &pb::ModifyWaypointRequest) -> In<WaypointPatch> {
    Ok(WaypointPatch {
        pose: r.pose.map(Into::into),
        joints: r
            .joints
            .as_ref()
            .map(|j| (!j.values.is_empty()).then(|| j.values.clone())),
        motion: r.motion.map(motion_in).transpose()?,
        name: r.name.as_ref().map(|n| (!n.is_empty()).then(|| n.clone())),
    })
}

pub fn insert_waypoint(r: pb::InsertWaypointRequest) -> In<InsertWaypoint> {
    let side = match pb::Side::try_from(r.side) {
        Ok(pb::Side::Before) => Side::Before,
        Ok(pb::Side::After) => Side::After,
        Ok(pb::Side::Unspecified) => {
            return Err(Status::invalid_argument(
                "side must be SIDE_BEFORE or SIDE_AFTER",
            ));
        }
        Err(_) => return Err(Status::invalid_argument(format!("unknown side {}", r.side))),
    };
    Ok(InsertWaypoint {
        side,
        waypoint: new_waypoint(required(r.waypoint, "waypoint")?)?,
    })
}

pub fn routine_patch(r: &pb::EditRoutineRequest) -> RoutinePatch {
    RoutinePatch {
        name: r.name.as_ref().map(|n| (!n.is_empty()).then(|| n.clone())),
        position: r.position,
    }
}

impl From<WaypointEdit> for pb::WaypointEdit {
    fn from(e: WaypointEdit) -> pb::WaypointEdit {
        pb::WaypointEdit {
            waypoint: e.waypoint.map(Into::into),
            previous: e.previous.map(Into::into),
            model_version: e.model_version,
        }
    }
}

impl From<RoutineEdit> for pb::RoutineEdit {
    fn from(e: RoutineEdit) -> pb::RoutineEdit {
        pb::RoutineEdit {
            routine: Some(e.routine.into()),
            previous: Some(e.previous.into()),
        }
    }
}

pub fn retarget(r: pb::RetargetRequest) -> Retarget {
    let points = |v: Vec<pb::Point>| v.into_iter().map(|p| [p.x, p.y, p.z]).collect();
    Retarget {
        frame: r.frame.map(Into::into),
        points: r.points.map(|p| FixturePoints {
            old: points(p.old),
            new: points(p.new),
        }),
        name: r.name,
    }
}

impl From<Retargeted> for pb::Retargeted {
    fn from(r: Retargeted) -> pb::Retargeted {
        pb::Retargeted {
            program: Some(r.program.into()),
            routines: r.routines.into_iter().map(Into::into).collect(),
            unreachable: r.unreachable as u64,
        }
    }
}

impl From<pb::UploadRobotRequest> for RobotUpload {
    fn from(r: pb::UploadRobotRequest) -> RobotUpload {
        RobotUpload {
            name: r.name,
            urdf: r.urdf,
            maker: r.maker,
            product: r.product,
            payload_kg: r.payload_kg,
        }
    }
}

// ---- layout -------------------------------------------------------------------------------------

/// The request's search (its robot name is taken apart by the caller). No `targets` means the
/// targets are stored (`program_id` or `cell_id`).
pub fn placement_search(r: pb::SearchPlacementsRequest) -> In<PlacementSearch> {
    let mounting = match r.mounting.as_str() {
        "" | "floor" => BaseMounting::Floor,
        "ceiling" => BaseMounting::Ceiling,
        other => {
            return Err(Status::invalid_argument(format!(
                "unknown mounting {other:?} (floor or ceiling)"
            )));
        }
    };
    let small = |v: Option<u32>, what: &str| v.map(|v| usize_from(u64::from(v), what)).transpose();
    Ok(PlacementSearch {
        program_id: r.program_id,
        cell_id: r.cell_id,
        targets: (!r.targets.is_empty()).then(|| r.targets.into_iter().map(Into::into).collect()),
        mounting,
        tool: r.tool.map(Into::into),
        keep: small(r.keep, "keep")?,
        seed: r.seed,
        evaluations: small(r.evaluations, "evaluations")?,
    })
}

impl From<Placements> for pb::Placements {
    fn from(p: Placements) -> pb::Placements {
        pb::Placements {
            robot: p.robot,
            targets: p.targets as u64,
            placements: p
                .placements
                .into_iter()
                .map(|p| pb::Placement {
                    base: Some(p.base.into()),
                    reached: p.reached as u64,
                    total: p.total as u64,
                    unreached: p.unreached.into_iter().map(|i| i as u64).collect(),
                    unreached_waypoints: p.unreached_waypoints.unwrap_or_default(),
                    min_joint_margin_deg: p.min_joint_margin_deg,
                    min_sigma: p.min_sigma,
                    score: p.score,
                })
                .collect(),
        }
    }
}

// ---- hand-guided trajectories --------------------------------------------------------------------

fn criterion_in(v: i32) -> In<Option<Criterion>> {
    match pb::SegmentCriterion::try_from(v) {
        Ok(pb::SegmentCriterion::Unspecified) => Ok(None),
        Ok(pb::SegmentCriterion::Direction) => Ok(Some(Criterion::Direction)),
        Ok(pb::SegmentCriterion::Seed) => Ok(Some(Criterion::Seed)),
        Err(_) => Err(Status::invalid_argument(format!(
            "unknown segment criterion {v}"
        ))),
    }
}

fn criterion_out(c: Option<Criterion>) -> pb::SegmentCriterion {
    match c {
        None => pb::SegmentCriterion::Unspecified,
        Some(Criterion::Direction) => pb::SegmentCriterion::Direction,
        Some(Criterion::Seed) => pb::SegmentCriterion::Seed,
    }
}

/// A trajectory to append: every sample needs its pose; empty joints are none sent.
pub fn trajectory_request(r: pb::AppendTrajectoryRequest) -> In<TrajectoryRequest> {
    let s = r.settings.unwrap_or_default();
    Ok(TrajectoryRequest {
        samples: r
            .samples
            .into_iter()
            .enumerate()
            .map(|(i, s)| {
                Ok(TrajectorySample {
                    t: s.t,
                    pose: required(s.pose, &format!("samples[{i}].pose"))?.into(),
                    joints: (!s.joints.is_empty()).then_some(s.joints),
                })
            })
            .collect::<In<_>>()?,
        preview: r.preview,
        settings: TrajectorySettings {
            epsilon_max: s.epsilon_max,
            criterion: criterion_in(s.criterion)?,
            min_step_mm: s.min_step_mm,
            rotation_mm_per_rad: s.rotation_mm_per_rad,
            zeta_mm: s.zeta_mm,
            min_segment_steps: s
                .min_segment_steps
                .map(|v| usize_from(v, "min_segment_steps"))
                .transpose()?,
            kappa_max: s.kappa_max,
            rank_tolerance: s.rank_tolerance,
        },
    })
}

/// The request as a client sends it.
pub fn trajectory_request_out(
    routine_id: i64,
    r: TrajectoryRequest,
) -> pb::AppendTrajectoryRequest {
    let s = r.settings;
    pb::AppendTrajectoryRequest {
        routine_id,
        samples: r
            .samples
            .into_iter()
            .map(|s| pb::TrajectorySample {
                t: s.t,
                pose: Some(s.pose.into()),
                joints: s.joints.unwrap_or_default(),
            })
            .collect(),
        preview: r.preview,
        settings: Some(pb::TrajectorySettings {
            epsilon_max: s.epsilon_max,
            criterion: criterion_out(s.criterion).into(),
            min_step_mm: s.min_step_mm,
            rotation_mm_per_rad: s.rotation_mm_per_rad,
            zeta_mm: s.zeta_mm,
            min_segment_steps: s.min_segment_steps.map(|v| v as u64),
            kappa_max: s.kappa_max,
            rank_tolerance: s.rank_tolerance,
        }),
    }
}

impl From<TrajectoryPoint> for pb::TrajectoryPoint {
    fn from(p: TrajectoryPoint) -> pb::TrajectoryPoint {
        pb::TrajectoryPoint {
            sample: p.sample as u64,
            t: p.t,
            pose: Some(p.pose.into()),
            joints: p.joints.unwrap_or_default(),
            taught: p.taught,
        }
    }
}

impl From<TrajectoryAnswer> for pb::TrajectoryAnswer {
    fn from(a: TrajectoryAnswer) -> pb::TrajectoryAnswer {
        let s = a.segmentation;
        pb::TrajectoryAnswer {
            preview: a.preview,
            start: Some(a.start.into()),
            attractors: a.attractors.into_iter().map(Into::into).collect(),
            waypoints: a.waypoints.into_iter().map(Into::into).collect(),
            segmentation: Some(pb::Segmentation {
                samples: s.samples as u64,
                kept: s.kept as u64,
                segments: s
                    .segments
                    .into_iter()
                    .map(|g| pb::TrajectorySegment {
                        from: g.from as u64,
                        to: g.to as u64,
                        steps: g.steps as u64,
                        rank: g.rank as u64,
                        condition: g.condition,
                        identity: g.identity,
                        alpha: g.alpha,
                        epsilon: g.epsilon,
                        r: g.r,
                    })
                    .collect(),
                mean_error_mm: s.mean_error_mm,
                max_error_mm: s.max_error_mm,
                converged: s.converged,
                parameters: s.parameters as u64,
                raw_parameters: s.raw_parameters as u64,
            }),
        }
    }
}

impl TryFrom<pb::TrajectoryPoint> for TrajectoryPoint {
    type Error = Status;
    fn try_from(p: pb::TrajectoryPoint) -> In<TrajectoryPoint> {
        Ok(TrajectoryPoint {
            sample: usize_from(p.sample, "sample")?,
            t: p.t,
            pose: required(p.pose, "point.pose")?.into(),
            joints: (!p.joints.is_empty()).then_some(p.joints),
            taught: p.taught,
        })
    }
}

impl TryFrom<pb::TrajectoryAnswer> for TrajectoryAnswer {
    type Error = Status;
    fn try_from(a: pb::TrajectoryAnswer) -> In<TrajectoryAnswer> {
        let s = required(a.segmentation, "answer.segmentation")?;
        Ok(TrajectoryAnswer {
            preview: a.preview,
            start: required(a.start, "answer.start")?.try_into()?,
            attractors: a
                .attractors
                .into_iter()
                .map(TryInto::try_into)
                .collect::<In<_>>()?,
            waypoints: a
                .waypoints
                .into_iter()
                .map(TryInto::try_into)
                .collect::<In<_>>()?,
            segmentation: Segmentation {
                samples: usize_from(s.samples, "samples")?,
                kept: usize_from(s.kept, "kept")?,
                segments: s
                    .segments
                    .into_iter()
                    .map(|g| {
                        Ok(TrajectorySegment {
                            from: usize_from(g.from, "from")?,
                            to: usize_from(g.to, "to")?,
                            steps: usize_from(g.steps, "steps")?,
                            rank: usize_from(g.rank, "rank")?,
                            condition: g.condition,
                            identity: g.identity,
                            alpha: g.alpha,
                            epsilon: g.epsilon,
                            r: g.r,
                        })
                    })
                    .collect::<In<_>>()?,
                mean_error_mm: s.mean_error_mm,
                max_error_mm: s.max_error_mm,
                converged: s.converged,
                parameters: usize_from(s.parameters, "parameters")?,
                raw_parameters: usize_from(s.raw_parameters, "raw_parameters")?,
            },
        })
    }
}
