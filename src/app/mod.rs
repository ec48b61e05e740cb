//! The application service: what a pendant can ask of nextpose, independent of the wire.
//!
//! Both adapters (HTTP now, gRPC next) call these operations and nothing else. Each operation
//! checks its input, writes to the database in one transaction, and keeps the cell's model in
//! memory in step. The database is the source of truth: a cell's model is rebuilt from it on
//! first use after start-up (and on request), and that rebuild gives the same model as the
//! incremental updates.
//!
//! **Concurrency.** Requests on one cell are serialised by the cell's lock, held from the first
//! read of the routine's state to the last write, so the model and the database never diverge;
//! different cells proceed in parallel. A cell has at most one routine being taught (one arm,
//! one operator); the database enforces it too.
//!
//! **Cancellation.** Every operation that changes a cell's model runs to completion on a task of
//! its own ([`App::to_completion`]): a caller that goes away (a client hanging up, a REST
//! timeout, a cancelled gRPC call) stops waiting for the answer, not the operation, so the
//! model and the database change together or not at all. Shutdown waits for these tasks.
//! CPU-heavy work (predictions on request, open-loop completions, parsing and learning
//! imports, learning a model from the database) runs on blocking threads ([`blocking`]), so one
//! cell's import does not stall other cells' requests.

mod cell_model;
pub mod error;
pub mod reach;
pub mod resources;
pub mod settings;

use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex};

use tokio::sync::{Mutex as AsyncMutex, OwnedMutexGuard};
use tokio_util::task::TaskTracker;

use crate::engine::{PredictOptions, Prediction, Withheld};
use crate::kinematics::{Joints, ReachPolicy, Reachability, RobotModel};
use crate::storage::{
    CellRow, NewFeedback, NewImportedRoutine, NewPrediction, NewWaypoint, PoseColumns, ProgramRow,
    RoutineRow, Store, WaypointRow,
};
use crate::telemetry::Metrics;
use cell_model::{CellModel, parse_settings};
pub use error::AppError;
use reach::Robots;
use resources::*;
use settings::MAX_HORIZON;

/// Longest open-loop completion a request may ask for.
pub const MAX_COMPLETION: usize = 100;
/// Longest name accepted for cells, programs, routines and waypoints.
pub const MAX_NAME: usize = 200;

type Result<T> = std::result::Result<T, AppError>;
type Slot = Arc<AsyncMutex<Option<CellModel>>>;

/// The application: storage, the cells' models and the metrics. Cloning is cheap (shared
/// handles), so an operation can own a copy on its own task.
#[derive(Debug, Clone)]
pub struct App {
    store: Store,
    models: Arc<Mutex<HashMap<i64, Slot>>>,
    metrics: Arc<Metrics>,
    robots: Arc<Robots>,
    /// Routine id → cell id (a routine never changes cell), so the hot path finds the cell to
    /// lock without a query. Deleting a routine removes its entry.
    routine_cells: Arc<Mutex<HashMap<i64, i64>>>,
    /// The operations running to completion (see [`App::to_completion`]).
    tasks: TaskTracker,
}

/// A prediction after the reachability check.
struct Checked {
    prediction: Prediction,
    reach: Option<Reachability>,
    /// Withheld because the arm cannot reach it (policy `withhold`).
    unreachable: bool,
}

/// Runs CPU-heavy work on a blocking thread, off the async workers.
pub(crate) async fn blocking<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + 'static,
) -> Result<T> {
    tokio::task::spawn_blocking(work)
        .await
        .map_err(|e| AppError::Internal(format!("blocking task: {e}")))
}

impl Checked {
    fn offered(&self) -> bool {
        self.prediction.offered() && !self.unreachable
    }

    /// The withheld reason code, if withheld.
    fn reason(&self) -> Option<&'static str> {
        match (&self.prediction.withheld, self.unreachable) {
            (Some(w), _) => Some(w.code()),
            (None, true) => Some("unreachable"),
            (None, false) => None,
        }
    }
}

/// Checks an engine prediction against the cell's arm (when it has one).
fn check(arm: Option<&reach::Arm>, prediction: Prediction, previous: Option<&Joints>) -> Checked {
    let reach = match (arm, &prediction.pose) {
        (Some(arm), Some(pose)) if prediction.offered() => Some(arm.check(pose, previous)),
        _ => None,
    };
    let unreachable = match (arm, &reach) {
        (Some(arm), Some(r)) => !r.is_reachable() && arm.policy() == ReachPolicy::Withhold,
        _ => false,
    };
    Checked {
        prediction,
        reach,
        unreachable,
    }
}

/// The routine being taught in a locked cell.
#[derive(Debug, Clone, Copy)]
struct OpenRoutine {
    id: i64,
    cell_id: i64,
}

/// A locked, loaded cell model.
struct Locked(OwnedMutexGuard<Option<CellModel>>);

impl Locked {
    fn model(&mut self) -> Result<&mut CellModel> {
        self.0
            .as_mut()
            .ok_or_else(|| AppError::Internal("cell model not loaded".into()))
    }
}

/// Locks a map guarded by a std mutex; a panic elsewhere while holding it cannot leave the map
/// half-updated (every update is a single insert), so a poisoned lock is still usable.
fn lock_map<K, V>(m: &Mutex<HashMap<K, V>>) -> std::sync::MutexGuard<'_, HashMap<K, V>> {
    match m.lock() {
        Ok(g) => g,
        Err(poisoned) => poisoned.into_inner(),
    }
}

/// The motion type of an imported instruction (`MoveL`, `ArcCStart`, `PTP`, `L`, `C`, ...).
fn motion_of(instruction: &str) -> MotionType {
    let m = instruction.to_ascii_lowercase();
    if m == "j" || m == "ptp" || m.starts_with("ptp_") || m.starts_with("movej") {
        MotionType::Joint
    } else if m == "c"
        || m.starts_with("movec")
        || m.starts_with("arcc")
        || m.starts_with("circ")
        || m.starts_with("triggc")
    {
        MotionType::Circular
    } else {
        MotionType::Linear
    }
}

fn check_name(what: &str, name: &str) -> Result<()> {
    if name.trim().is_empty() {
        return Err(AppError::Invalid(format!("{what} must not be empty")));
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Err(AppError::Invalid(format!(
            "{what} must not contain control characters (found U+{:04X})",
            c as u32
        )));
    }
    if name.chars().count() > MAX_NAME {
        return Err(AppError::Invalid(format!(
            "{what} is longer than {MAX_NAME} characters"
        )));
    }
    Ok(())
}

fn pose_columns(p: &PoseDto) -> PoseColumns {
    PoseColumns {
        x: p.x,
        y: p.y,
        z: p.z,
        qw: p.qw,
        qx: p.qx,
        qy: p.qy,
        qz: p.qz,
    }
}

fn pose_dto(p: &PoseColumns) -> PoseDto {
    PoseDto {
        x: p.x,
        y: p.y,
        z: p.z,
        qw: p.qw,
        qx: p.qx,
        qy: p.qy,
        qz: p.qz,
    }
}

/// A stored waypoint as clients see it. Its joints and motion were validated when taught, so
/// one that does not read back is an internal error, like a bad stored pose.
fn waypoint(w: WaypointRow) -> Result<Waypoint> {
    let joints = cell_model::stored_joints(&w)?;
    let motion = match w.motion.as_deref() {
        None => None,
        Some(m) => Some(MotionType::parse(m).ok_or_else(|| {
            AppError::Internal(format!("stored motion {m:?} of waypoint {}", w.id))
        })?),
    };
    Ok(Waypoint {
        id: w.id,
        routine_id: w.routine_id,
        seq: w.seq,
        pose: pose_dto(&w.pose),
        joints,
        motion,
        name: w.name,
        reachable: w.reachable,
        created_at: w.created_at,
    })
}

fn routine(r: RoutineRow) -> Routine {
    Routine {
        id: r.id,
        program_id: r.program_id,
        cell_id: r.cell_id,
        position: r.position,
        finished: r.finished(),
        learned: r.learned(),
        imported: r.imported,
        name: r.name,
        finish_seq: r.finish_seq,
        finished_at: r.finished_at,
        waypoint_count: r.waypoints,
        created_at: r.created_at,
    }
}

fn program(p: ProgramRow) -> Program {
    Program {
        id: p.id,
        cell_id: p.cell_id,
        name: p.name,
        created_at: p.created_at,
    }
}

/// A human-readable account of why a prediction is withheld.
fn describe(w: &Withheld, opts: &PredictOptions) -> String {
    match w {
        Withheld::NothingTaught => "the routine has no waypoint yet".into(),
        Withheld::EmptyModel => "nothing has been learned in this cell yet".into(),
        Withheld::TooFewStates { states } => {
            format!("the model has {states} state(s); at least 2 are needed")
        }
        Withheld::NoMatch => "the last moves match nothing learned".into(),
        Withheld::LikelyEnd { end_probability } => format!(
            "the routine probably ends here (p = {end_probability:.2}); taught routines like \
             this one usually stop at this point"
        ),
        Withheld::PoorMatch { misfit } => format!(
            "the last moves resemble learned ones only loosely (misfit {misfit:.2} above {:.2})",
            opts.max_misfit.unwrap_or(f64::INFINITY)
        ),
        Withheld::LowConfidence { phi } => {
            format!(
                "confidence φ = {phi:.2} is below φ_min = {:.2}",
                opts.phi_min
            )
        }
        Withheld::WideSpread { spread } => {
            format!("the moves that followed this pattern before disagree (spread {spread:.2})")
        }
        Withheld::LittleEvidence { support } => {
            format!("the pattern was followed by this move only {support:.1} time(s) before")
        }
    }
}

impl App {
    pub fn new(store: Store, metrics: Arc<Metrics>, robots: Arc<Robots>) -> App {
        App {
            store,
            models: Arc::default(),
            metrics,
            robots,
            routine_cells: Arc::default(),
            tasks: TaskTracker::new(),
        }
    }

    /// Runs an operation on a task of its own and waits for its answer. The caller may go
    /// away (its future dropped): the operation still completes, so a cell's model and the
    /// database change together or not at all.
    async fn to_completion<T, F>(&self, op: impl FnOnce(App) -> F) -> Result<T>
    where
        F: Future<Output = Result<T>> + Send + 'static,
        T: Send + 'static,
    {
        self.tasks
            .spawn(op(self.clone()))
            .await
            .map_err(|e| AppError::Internal(format!("operation task: {e}")))?
    }

    /// Waits for the operations still running (their callers may have gone away); new
    /// operations can still start. Shutdown calls it once the listener has stopped.
    pub async fn finish_operations(&self) {
        self.tasks.close();
        self.tasks.wait().await;
        self.tasks.reopen();
    }

    /// The robot models cells can use.
    pub fn robots(&self) -> Vec<RobotModel> {
        self.robots.models()
    }

    pub fn robot(&self, name: &str) -> Result<RobotModel> {
        self.robots
            .get(name)
            .map(|r| r.model())
            .ok_or_else(|| AppError::NotFoundName {
                what: "robot",
                name: name.to_string(),
            })
    }

    pub fn store(&self) -> &Store {
        &self.store
    }

    pub fn metrics(&self) -> &Arc<Metrics> {
        &self.metrics
    }

    /// Health: the database answers.
    pub async fn health(&self) -> Result<()> {
        Ok(self.store.ping().await?)
    }

    // ---- operations that change a cell's model: each runs to completion ------------------

    pub async fn create_routine(&self, program_id: i64, input: CreateRoutine) -> Result<Routine> {
        self.to_completion(
            move |app| async move { app.create_routine_now(program_id, input).await },
        )
        .await
    }

    pub async fn delete_routine(&self, id: i64) -> Result<()> {
        self.to_completion(move |app| async move { app.delete_routine_now(id).await })
            .await
    }

    pub async fn finish_routine(&self, id: i64) -> Result<Finished> {
        self.to_completion(move |app| async move { app.finish_routine_now(id).await })
            .await
    }

    pub async fn append_waypoint(&self, routine_id: i64, input: NewWaypointDto) -> Result<Taught> {
        self.to_completion(
            move |app| async move { app.append_waypoint_now(routine_id, input).await },
        )
        .await
    }

    pub async fn undo(&self, routine_id: i64) -> Result<Undone> {
        self.to_completion(move |app| async move { app.undo_now(routine_id).await })
            .await
    }

    pub async fn predict(&self, routine_id: i64, q: PredictQuery) -> Result<PredictionSet> {
        self.to_completion(move |app| async move { app.predict_now(routine_id, q).await })
            .await
    }

    pub async fn import(&self, cell_id: i64, input: ImportRequest) -> Result<ImportResult> {
        self.to_completion(move |app| async move { app.import_now(cell_id, input).await })
            .await
    }

    pub async fn rebuild(&self, id: i64) -> Result<ModelInfo> {
        self.to_completion(move |app| async move { app.rebuild_now(id).await })
            .await
    }

    // ---- locking ----------------------------------------------------------------------------

    fn slot(&self, cell_id: i64) -> Slot {
        lock_map(&self.models).entry(cell_id).or_default().clone()
    }

    async fn cell_row(&self, id: i64) -> Result<CellRow> {
        self.store
            .cell(id)
            .await?
            .ok_or_else(|| AppError::not_found("cell", id))
    }

    async fn program_row(&self, id: i64) -> Result<ProgramRow> {
        self.store
            .program(id)
            .await?
            .ok_or_else(|| AppError::not_found("program", id))
    }

    async fn routine_row(&self, id: i64) -> Result<RoutineRow> {
        self.store
            .routine(id)
            .await?
            .ok_or_else(|| AppError::not_found("routine", id))
    }

    /// Locks a cell's model, loading it from the database on first use (the cell must exist:
    /// a missing one is a 404, but callers check first so no slot is made for it).
    async fn lock_cell_id(&self, cell_id: i64) -> Result<Locked> {
        let mut guard = self.slot(cell_id).lock_owned().await;
        if guard.is_none() {
            let cell = self.cell_row(cell_id).await?;
            *guard = Some(CellModel::load(&self.store, &cell, &self.robots).await?);
        }
        Ok(Locked(guard))
    }

    /// Locks the cell of a routine being taught. The cell's model knows which routine is open,
    /// so under the lock no further read is needed; a finished routine is refused (409).
    async fn lock_open_routine(&self, id: i64) -> Result<(Locked, OpenRoutine)> {
        let cached = lock_map(&self.routine_cells).get(&id).copied();
        let cell_id = match cached {
            Some(cell) => cell,
            None => {
                let (cell, _) = self
                    .store
                    .routine_cell(id)
                    .await?
                    .ok_or_else(|| AppError::not_found("routine", id))?;
                lock_map(&self.routine_cells).insert(id, cell);
                cell
            }
        };
        let mut locked = self.lock_cell_id(cell_id).await?;
        if locked.model()?.open == Some(id) {
            return Ok((locked, OpenRoutine { id, cell_id }));
        }
        // Not the open routine: finished, or deleted while we waited for the lock.
        match self.store.routine_cell(id).await? {
            None => Err(AppError::not_found("routine", id)),
            Some((_, true)) => Err(AppError::Conflict(format!(
                "routine {id} is finished; a finished routine cannot change"
            ))),
            Some((_, false)) => Err(AppError::Internal(format!(
                "routine {id} is open in the database but not in the cell's model"
            ))),
        }
    }

    // ---- cells ------------------------------------------------------------------------------

    fn cell(&self, row: CellRow) -> Result<Cell> {
        Ok(Cell {
            settings: parse_settings(&row)?,
            id: row.id,
            name: row.name,
            created_at: row.created_at,
        })
    }

    pub async fn create_cell(&self, input: CreateCell) -> Result<Cell> {
        check_name("cell name", &input.name)?;
        let settings = input.settings.resolve()?;
        self.robots.require(&settings.robot)?;
        let json = serde_json::to_string(&settings)
            .map_err(|e| AppError::Internal(format!("settings: {e}")))?;
        let row = self
            .store
            .insert_cell(input.name.trim(), &json)
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => {
                    AppError::Exists(format!("a cell named {:?} exists", input.name.trim()))
                }
                other => other,
            })?;
        self.cell(row)
    }

    pub async fn cells(&self) -> Result<Vec<Cell>> {
        self.store
            .cells()
            .await?
            .into_iter()
            .map(|r| self.cell(r))
            .collect()
    }

    pub async fn get_cell(&self, id: i64) -> Result<Cell> {
        let row = self.cell_row(id).await?;
        self.cell(row)
    }

    pub async fn cell_stats(&self, id: i64) -> Result<CellStats> {
        self.cell_row(id).await?;
        let model = {
            let mut locked = self.lock_cell_id(id).await?;
            locked.model()?.info()
        };
        let counts = self.store.feedback_counts(id).await?;
        let judged = counts.accepted + counts.adjusted + counts.rejected;
        let mut adj = counts.adjustments_mm.clone();
        adj.sort_by(f64::total_cmp);
        let median = match adj.len() {
            0 => None,
            n if n % 2 == 1 => Some(adj[n / 2]),
            n => Some(0.5 * (adj[n / 2 - 1] + adj[n / 2])),
        };
        Ok(CellStats {
            cell_id: id,
            model,
            feedback: FeedbackStats {
                offered: counts.offered,
                accepted: counts.accepted,
                adjusted: counts.adjusted,
                rejected: counts.rejected,
                pending: counts.offered - judged,
                acceptance: (judged > 0)
                    .then(|| (counts.accepted + counts.adjusted) as f64 / judged as f64),
                median_adjustment_mm: median,
            },
        })
    }

    /// Re-learns the cell's model from the stored routines, in the order they were finished.
    async fn rebuild_now(&self, id: i64) -> Result<ModelInfo> {
        let cell = self.cell_row(id).await?;
        let mut guard = self.slot(id).lock_owned().await;
        let model = CellModel::load(&self.store, &cell, &self.robots).await?;
        let info = model.info();
        if let Some(previous) = guard.as_ref()
            && !previous.in_step_with(&model)
        {
            tracing::error!(cell = id, before = ?previous.info(), rebuilt = ?info, "the cell's model in memory differed from the database");
            self.metrics.record_divergence();
        }
        *guard = Some(model);
        Ok(info)
    }

    // ---- programs ---------------------------------------------------------------------------

    pub async fn create_program(&self, cell_id: i64, input: CreateProgram) -> Result<Program> {
        check_name("program name", &input.name)?;
        self.cell_row(cell_id).await?;
        let row = self
            .store
            .insert_program(cell_id, input.name.trim())
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {cell_id} already has a program named {:?}",
                    input.name.trim()
                )),
                other => other,
            })?;
        Ok(program(row))
    }

    pub async fn programs(&self, cell_id: i64) -> Result<Vec<Program>> {
        self.cell_row(cell_id).await?;
        Ok(self
            .store
            .programs(cell_id)
            .await?
            .into_iter()
            .map(program)
            .collect())
    }

    pub async fn get_program(&self, id: i64) -> Result<Program> {
        Ok(program(self.program_row(id).await?))
    }

    // ---- routines ---------------------------------------------------------------------------

    /// Starts a routine at the end of a program. The cell must not have another routine
    /// being taught.
    async fn create_routine_now(&self, program_id: i64, input: CreateRoutine) -> Result<Routine> {
        if let Some(n) = &input.name {
            check_name("routine name", n)?;
        }
        let p = self.program_row(program_id).await?;
        let mut locked = self.lock_cell_id(p.cell_id).await?;
        if let Some(open) = self.store.open_routine(p.cell_id).await? {
            return Err(AppError::Conflict(format!(
                "routine {} of cell {} is still being taught; finish or delete it first",
                open.id, p.cell_id
            )));
        }
        let id = self
            .store
            .insert_routine(&p, input.name.as_deref().map(str::trim))
            .await?;
        locked.model()?.open = Some(id);
        Ok(routine(self.routine_row(id).await?))
    }

    pub async fn routines(&self, program_id: i64) -> Result<Vec<Routine>> {
        self.program_row(program_id).await?;
        Ok(self
            .store
            .routines(program_id)
            .await?
            .into_iter()
            .map(routine)
            .collect())
    }

    pub async fn get_routine(&self, id: i64) -> Result<RoutineDetail> {
        let r = self.routine_row(id).await?;
        let waypoints = self.store.waypoints(id).await?;
        Ok(RoutineDetail {
            routine: routine(r),
            waypoints: waypoints.into_iter().map(waypoint).collect::<Result<_>>()?,
        })
    }

    /// A routine to go on teaching (a teach session attaching to it): its detail, or a
    /// conflict when it is finished.
    pub async fn resume_routine(&self, id: i64) -> Result<RoutineDetail> {
        let detail = self.get_routine(id).await?;
        if detail.routine.finished {
            return Err(AppError::Conflict(format!(
                "routine {id} is finished; a finished routine cannot change"
            )));
        }
        Ok(detail)
    }

    /// Deletes a routine that is being taught, with its waypoints; the model forgets it.
    async fn delete_routine_now(&self, id: i64) -> Result<()> {
        let (mut locked, r) = self.lock_open_routine(id).await?;
        self.store.delete_open_routine(r.id).await?;
        lock_map(&self.routine_cells).remove(&r.id);
        let model = locked.model()?;
        model.teacher.abandon_routine();
        if let Some(arm) = model.arm.as_mut() {
            arm.clear();
        }
        model.open = None;
        Ok(())
    }

    /// Finishes a routine: it becomes immutable and the cell's model assimilates it.
    async fn finish_routine_now(&self, id: i64) -> Result<Finished> {
        let (mut locked, r) = self.lock_open_routine(id).await?;
        self.store.finish_routine(r.cell_id, r.id).await?;
        let model = locked.model()?;
        model.teacher.finish_routine();
        if let Some(arm) = model.arm.as_mut() {
            arm.clear();
        }
        model.open = None;
        model.version += 1;
        let info = model.info();
        Ok(Finished {
            routine: routine(self.routine_row(id).await?),
            model: info,
        })
    }

    // ---- teaching ---------------------------------------------------------------------------

    fn validate_waypoint(input: &NewWaypointDto) -> Result<Option<String>> {
        if let Some(n) = &input.name {
            check_name("waypoint name", n)?;
        }
        match &input.joints {
            None => Ok(None),
            Some(j) if j.is_empty() || j.len() > 12 => Err(AppError::Invalid(format!(
                "joints must hold 1 to 12 values, not {}",
                j.len()
            ))),
            Some(j) if j.iter().any(|v| !v.is_finite()) => {
                Err(AppError::Invalid("joint values must be finite".into()))
            }
            Some(j) => serde_json::to_string(j)
                .map(Some)
                .map_err(|e| AppError::Internal(e.to_string())),
        }
    }

    /// Appends a taught waypoint to an open routine and predicts the next one.
    async fn append_waypoint_now(&self, routine_id: i64, input: NewWaypointDto) -> Result<Taught> {
        // Everything the client can get wrong is checked before anything changes.
        let joints = Self::validate_waypoint(&input)?;
        let pose = input.pose.to_pose()?;
        let stored = PoseDto::from(&pose);
        // The model learns the pose as it will be read back from the database, so a rebuild
        // gives bit-identical results.
        let pose = stored.to_pose()?;
        let (mut locked, r) = self.lock_open_routine(routine_id).await?;
        let model = locked.model()?;
        if let (Some(arm), Some(j)) = (&model.arm, &input.joints) {
            arm.check_joints(j)?;
        }
        model.teacher.teach(pose);
        let taught_reach = model
            .arm
            .as_mut()
            .map(|arm| arm.taught(&pose, input.joints.as_deref()));
        let opts = PredictOptions::from_config(model.teacher.config());
        let checked = check(
            model.arm.as_ref(),
            model.teacher.predict_with(&opts),
            model.arm.as_ref().and_then(|a| a.previous()),
        );
        let after = model.teacher.routine().len() as i64;
        let record = self.new_prediction(&r, after, model.version, &checked);
        let wp = NewWaypoint {
            routine_id,
            seq: after,
            pose: pose_columns(&stored),
            joints,
            motion: input.motion.map(|m| m.as_str().to_string()),
            name: input.name.map(|n| n.trim().to_string()),
            reachable: taught_reach.as_ref().map(Reachability::is_reachable),
        };
        let (row, id) = match self.store.append_waypoint(&wp, record.as_ref()).await {
            Ok(done) => done,
            Err(e) => {
                model.teacher.undo();
                if let Some(arm) = model.arm.as_mut() {
                    arm.undo();
                }
                return Err(e.into());
            }
        };
        let version = model.version;
        let prediction = self.dto(model.arm.as_ref(), &checked, &opts, id, after, version);
        self.metrics.record_prediction(checked.reason());
        Ok(Taught {
            waypoint: waypoint(row)?,
            prediction,
        })
    }

    /// Removes the last waypoint of an open routine; the prediction rolls back with it.
    async fn undo_now(&self, routine_id: i64) -> Result<Undone> {
        let (mut locked, r) = self.lock_open_routine(routine_id).await?;
        let Some(removed) = self.store.delete_last_waypoint(r.id).await? else {
            return Err(AppError::Conflict(format!(
                "routine {routine_id} has no waypoint to undo"
            )));
        };
        let model = locked.model()?;
        model.teacher.undo();
        if let Some(arm) = model.arm.as_mut() {
            arm.undo();
        }
        let opts = PredictOptions::from_config(model.teacher.config());
        let checked = check(
            model.arm.as_ref(),
            model.teacher.predict_with(&opts),
            model.arm.as_ref().and_then(|a| a.previous()),
        );
        let after = model.teacher.routine().len() as i64;
        let version = model.version;
        let id = match self.new_prediction(&r, after, version, &checked) {
            Some(np) => Some(self.store.record_prediction(&np).await?),
            None => None,
        };
        Ok(Undone {
            removed: waypoint(removed)?,
            prediction: self.dto(model.arm.as_ref(), &checked, &opts, id, after, version),
        })
    }

    /// The prediction for an open routine as it stands, with per-request overrides; `k > 1`
    /// asks for an open-loop completion of up to k waypoints.
    async fn predict_now(&self, routine_id: i64, q: PredictQuery) -> Result<PredictionSet> {
        let k = q.k.unwrap_or(1);
        if !(1..=MAX_COMPLETION).contains(&k) {
            return Err(AppError::Invalid(format!(
                "k must be between 1 and {MAX_COMPLETION}"
            )));
        }
        if let Some(h) = q.horizon
            && !(1..=MAX_HORIZON).contains(&h)
        {
            return Err(AppError::Invalid(format!(
                "horizon must be between 1 and {MAX_HORIZON}"
            )));
        }
        if let Some(phi) = q.phi_min
            && !(0.0..=1.0).contains(&phi)
        {
            return Err(AppError::Invalid("phi_min must be between 0 and 1".into()));
        }
        let (locked, r) = self.lock_open_routine(routine_id).await?;
        // Up to k predictions, each checked for reach: CPU work, on a blocking thread (with
        // the cell's lock).
        let (mut locked, opts, checked) = blocking(move || -> Result<_> {
            let mut locked = locked;
            let model = locked.model()?;
            let mut opts = PredictOptions::from_config(model.teacher.config());
            if let Some(h) = q.horizon {
                opts.horizon = h;
            }
            if let Some(phi) = q.phi_min {
                opts.phi_min = phi;
            }
            if let Some(s) = q.scale {
                opts.scale.enabled = s;
            }
            let arm = model.arm.as_ref();
            let mut previous = arm.and_then(|a| a.previous()).copied();
            let mut checked = Vec::new();
            for p in model.teacher.complete(k, &opts) {
                let c = check(arm, p, previous.as_ref());
                previous = c.reach.as_ref().and_then(|r| r.chosen).or(previous);
                let stop = !c.offered();
                checked.push(c);
                if stop {
                    break;
                }
            }
            Ok((locked, opts, checked))
        })
        .await??;
        let model = locked.model()?;
        let version = model.version;
        let taught = model.teacher.routine().len() as i64;
        let arm = model.arm.as_ref();
        let mut out = Vec::with_capacity(checked.len());
        for (i, c) in checked.iter().enumerate() {
            let after = taught + i as i64;
            // The first prediction is recorded (once) so that feedback can refer to it.
            let id = match (i, self.new_prediction(&r, after, version, c)) {
                (0, Some(np)) => Some(self.store.record_prediction(&np).await?),
                _ => None,
            };
            out.push(self.dto(arm, c, &opts, id, after, version));
        }
        drop(locked);
        Ok(PredictionSet {
            routine_id,
            predictions: out,
        })
    }

    fn new_prediction(
        &self,
        r: &OpenRoutine,
        after: i64,
        version: i64,
        c: &Checked,
    ) -> Option<NewPrediction> {
        let p = &c.prediction;
        let pose = p.pose.as_ref().filter(|_| c.offered())?;
        Some(NewPrediction {
            cell_id: r.cell_id,
            routine_id: r.id,
            after_seq: after,
            pose: pose_columns(&pose.into()),
            phi: p.phi,
            psi: p.psi,
            misfit: p.misfit,
            end_probability: p.end_probability,
            model_version: version,
        })
    }

    fn dto(
        &self,
        arm: Option<&reach::Arm>,
        c: &Checked,
        opts: &PredictOptions,
        id: Option<i64>,
        after: i64,
        version: i64,
    ) -> PredictionDto {
        let p = &c.prediction;
        let reachability = match (arm, &c.reach) {
            (Some(arm), Some(r)) => Some(arm.dto(r)),
            _ => None,
        };
        let withheld = match (&p.withheld, &reachability) {
            (Some(w), _) => Some(WithheldDto {
                reason: w.code().to_string(),
                message: describe(w, opts),
            }),
            (None, Some(r)) if c.unreachable => Some(WithheldDto {
                reason: "unreachable".to_string(),
                message: r
                    .unreachable
                    .as_ref()
                    .map(|u| u.message.clone())
                    .unwrap_or_else(|| "the arm cannot reach it".into()),
            }),
            _ => None,
        };
        PredictionDto {
            id,
            offered: c.offered(),
            withheld,
            reachability,
            pose: p.pose.as_ref().map(PoseDto::from),
            relative: p.relative.as_ref().map(|x| RelativeMove {
                x: x[0],
                y: x[1],
                z: x[2],
                qw: x[3],
                qx: x[4],
                qy: x[5],
                qz: x[6],
            }),
            phi: p.phi,
            psi: p.psi,
            routine_scale: p.routine_scale(),
            end_probability: p.end_probability,
            misfit: p.misfit,
            spread: p.spread,
            support: p.support,
            window: p.window,
            states: p.states,
            after_waypoints: after,
            model_version: version,
        }
    }

    // ---- import -----------------------------------------------------------------------------

    /// Imports offline programs (RAPID, KRL, FANUC TP) into a cell as new programs whose
    /// routines are immutable; with `learn` (default) the model learns them in program order.
    /// All of it is one transaction: a syntax error or a name clash imports nothing.
    async fn import_now(&self, cell_id: i64, input: ImportRequest) -> Result<ImportResult> {
        if input.files.is_empty() {
            return Err(AppError::Invalid("no files to import".into()));
        }
        for f in &input.files {
            check_name("file name", &f.name)?;
        }
        let learn = input.learn.unwrap_or(true);
        // Parsing is CPU work (seconds for large uploads): off the async workers.
        let n_files = input.files.len();
        tracing::info!(cell = cell_id, files = n_files, "parsing an upload");
        let report = blocking(move || {
            let files: Vec<(&str, &str)> = input
                .files
                .iter()
                .map(|f| (f.name.as_str(), f.content.as_str()))
                .collect();
            crate::import::parse_files(&files)
        })
        .await?
        .map_err(|e| AppError::Invalid(format!("cannot import: {e}")))?;
        tracing::info!(
            cell = cell_id,
            files = n_files,
            programs = report.programs.len(),
            skipped = report.skipped.len(),
            "parsed an upload"
        );
        let mut programs = Vec::with_capacity(report.programs.len());
        let mut poses = Vec::new();
        for p in &report.programs {
            let mut routines = Vec::with_capacity(p.routines.len());
            for r in &p.routines {
                let mut waypoints = Vec::with_capacity(r.waypoints.len());
                let mut taught = Vec::with_capacity(r.waypoints.len());
                for w in &r.waypoints {
                    let stored = PoseDto::from(&w.pose);
                    taught.push(stored.to_pose()?);
                    waypoints.push(NewWaypoint {
                        routine_id: 0,
                        seq: 0,
                        pose: pose_columns(&stored),
                        joints: None,
                        motion: Some(motion_of(&w.motion).as_str().to_string()),
                        name: Some(w.name.chars().take(MAX_NAME).collect()),
                        reachable: None,
                    });
                }
                poses.push(taught);
                routines.push(NewImportedRoutine {
                    name: r.name.chars().take(MAX_NAME).collect(),
                    waypoints,
                });
            }
            programs.push((p.name.chars().take(MAX_NAME).collect::<String>(), routines));
        }
        self.cell_row(cell_id).await?;
        let mut locked = self.lock_cell_id(cell_id).await?;
        let model = locked.model()?;
        if learn && model.open.is_some() {
            return Err(AppError::Conflict(format!(
                "cell {cell_id} is teaching a routine; finish or delete it before importing \
                 with learn"
            )));
        }
        let stored = self
            .store
            .import_programs(cell_id, &programs, learn)
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {cell_id} already has a program with one of the names {:?}",
                    programs.iter().map(|p| p.0.as_str()).collect::<Vec<_>>()
                )),
                other => other,
            })?;
        // Learning is CPU work too: on a blocking thread, with the cell's lock.
        let info = blocking(move || -> Result<ModelInfo> {
            let mut locked = locked;
            let model = locked.model()?;
            if learn {
                for routine in &poses {
                    for pose in routine {
                        model.teacher.teach(*pose);
                    }
                    model.teacher.finish_routine();
                    model.version += 1;
                }
            }
            Ok(model.info())
        })
        .await??;
        let out = stored
            .into_iter()
            .zip(&report.programs)
            .map(|((row, _), p)| ImportedProgramDto {
                program: program(row),
                language: format!("{:?}", p.language).to_lowercase(),
                source: p.source.clone(),
                routines: p.routines.len(),
                waypoints: p.routines.iter().map(|r| r.waypoints.len()).sum(),
            })
            .collect();
        let skipped = report
            .skipped
            .iter()
            .map(|s| SkippedDto {
                file: s.file.clone(),
                line: s.line,
                routine: s.routine.clone(),
                reason: serde_json::to_value(s.reason)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_else(|| format!("{:?}", s.reason)),
                text: s.text.clone(),
            })
            .collect();
        Ok(ImportResult {
            programs: out,
            skipped,
            model: info,
        })
    }

    // ---- replay -----------------------------------------------------------------------------

    /// Replays programs (uploaded files or a cell's stored programs) through the engine and the
    /// baselines, each program learned from scratch as in `nextpose replay`; returns the
    /// scoreboard (serialised, the JSON form of `nextpose replay --json`).
    pub async fn replay(&self, input: ReplayRequest) -> Result<crate::replay::report::Report> {
        use crate::replay::corpus::{Program as ReplayProgram, Routine as ReplayRoutine};
        use crate::replay::report::{RunConfig, replay_all};
        use crate::replay::{Method, baselines, engine_method::EngineMethod};

        let profile = input.profile.unwrap_or(settings::ProfileName::Default);
        let mut config = crate::engine::EngineConfig::profile(profile.into());
        if let Some(v) = input.delta {
            config.delta = v;
        }
        if let Some(v) = input.phi_min {
            config.phi_min = v;
        }
        if let Some(v) = input.horizon {
            if v > MAX_HORIZON {
                return Err(AppError::Invalid(format!(
                    "horizon must be between 1 and {MAX_HORIZON}"
                )));
            }
            config.horizon = v;
        }
        if let Some(v) = input.scale {
            config.scale.enabled = v;
        }
        config.validate()?;
        let programs: Vec<ReplayProgram> = match (&input.files, input.cell_id) {
            (Some(files), None) if !files.is_empty() => {
                let files: Vec<(&str, &str)> = files
                    .iter()
                    .map(|f| (f.name.as_str(), f.content.as_str()))
                    .collect();
                crate::import::parse_files(&files)
                    .map_err(|e| AppError::Invalid(format!("cannot read the programs: {e}")))?
                    .to_replay()
            }
            (None, Some(cell)) => {
                self.cell_row(cell).await?;
                let mut out = Vec::new();
                for p in self.store.programs(cell).await? {
                    let mut routines = Vec::new();
                    for r in self.store.routines(p.id).await? {
                        let mut waypoints = Vec::new();
                        for w in self.store.waypoints(r.id).await? {
                            waypoints.push(cell_model::stored_pose(&w)?);
                        }
                        routines.push(ReplayRoutine {
                            name: r.name.unwrap_or_else(|| format!("routine {}", r.position)),
                            waypoints,
                        });
                    }
                    out.push(ReplayProgram {
                        name: p.name,
                        source: std::path::PathBuf::from(format!("cell {cell}")),
                        language: "stored".into(),
                        routines,
                    });
                }
                out
            }
            _ => {
                return Err(AppError::Invalid(
                    "give either non-empty `files` or `cell_id`".into(),
                ));
            }
        };
        let gate = baselines::DEFAULT_NEAREST_SEQ_GATE;
        let profile_name = crate::engine::Profile::from(profile).name();
        // The replay is CPU work (seconds for a large corpus): off the async workers.
        blocking(move || -> Result<_> {
            let mut methods: Vec<Box<dyn Method>> = vec![Box::new(
                EngineMethod::new(config.clone()).map_err(AppError::from)?,
            )];
            methods.extend(baselines::all(&config, gate));
            replay_all(
                &programs,
                &mut methods,
                RunConfig::new(profile_name, config, gate),
            )
            .map_err(|e| AppError::Internal(format!("the replay's arm model: {e}")))
        })
        .await?
    }

    // ---- feedback ---------------------------------------------------------------------------

    pub async fn feedback(
        &self,
        prediction_id: i64,
        input: FeedbackDto,
    ) -> Result<FeedbackRecorded> {
        let final_pose = match (input.verdict, &input.pose) {
            (Verdict::Adjusted, Some(p)) => Some(p.to_pose()?),
            (Verdict::Adjusted, None) => {
                return Err(AppError::Invalid(
                    "an adjusted prediction needs the pose finally taught".into(),
                ));
            }
            (_, Some(_)) => {
                return Err(AppError::Invalid(format!(
                    "a pose is only given with the verdict \"adjusted\", not {:?}",
                    input.verdict.as_str()
                )));
            }
            (_, None) => None,
        };
        let pr = self
            .store
            .prediction(prediction_id)
            .await?
            .ok_or_else(|| AppError::not_found("prediction", prediction_id))?;
        if let Some(v) = &pr.verdict {
            return Err(AppError::Conflict(format!(
                "prediction {prediction_id} already has feedback ({v})"
            )));
        }
        let predicted = cell_model::stored_pose_columns(&pr.pose)?;
        let adjustment_mm = match (input.verdict, &final_pose) {
            (Verdict::Accepted, _) => Some(0.0),
            (Verdict::Adjusted, Some(f)) => Some(predicted.distance_to(f)),
            _ => None,
        };
        self.store
            .insert_feedback(&NewFeedback {
                prediction_id,
                verdict: input.verdict.as_str(),
                pose: final_pose.as_ref().map(|p| pose_columns(&p.into())),
                adjustment_mm,
            })
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => {
                    AppError::Conflict(format!("prediction {prediction_id} already has feedback"))
                }
                other => other,
            })?;
        Ok(FeedbackRecorded {
            prediction_id,
            verdict: input.verdict,
            adjustment_mm,
        })
    }
}
