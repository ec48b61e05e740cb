//! The cells' models in memory and their locks: one slot per cell, loaded from the database on
//! first use; the routine→cell cache of the hot path; operations that run to completion on
//! their own task, and CPU work on blocking threads.

use super::cell_model::{Behind, CellModel};
use super::error::AppError;
use super::{App, Result};
use crate::storage::{CellRow, ProgramRow, Recorder, RoutineRow};
use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex};
use tokio::sync::{Mutex as AsyncMutex, OwnedMutexGuard};

pub(super) type Slot = Arc<AsyncMutex<Option<CellModel>>>;

/// Runs CPU-heavy work on a blocking thread, off the async workers.
pub(crate) async fn blocking<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + 'static,
) -> Result<T> {
    tokio::task::spawn_blocking(work)
        .await
        .map_err(|e| AppError::Internal(format!("blocking task: {e}")))
}

/// The routine being taught in a locked cell.
#[derive(Debug, Clone, Copy)]
pub(super) struct OpenRoutine {
    pub(super) id: i64,
    pub(super) cell_id: i64,
}

/// A locked, loaded cell model.
pub(super) struct Locked(pub(super) OwnedMutexGuard<Option<CellModel>>);

impl Locked {
    /// A write of ours found the cell changed elsewhere (or advanced its revision to a value
    /// the model does not know): the next lock checks the database first.
    pub(super) fn check_next_time(&mut self) {
        if let Some(model) = self.0.as_mut() {
            model.needs_check = true;
        }
    }

    pub(super) fn model(&mut self) -> Result<&mut CellModel> {
        self.0
            .as_mut()
            .ok_or_else(|| AppError::Internal("cell model not loaded".into()))
    }
}

/// After a failed write that follows a locked model: a stale cell is checked on the next lock.
pub(super) fn stale_check(locked: &mut Locked, e: &crate::storage::StorageError) {
    if matches!(e, crate::storage::StorageError::Stale { .. }) {
        locked.check_next_time();
    }
}

/// Locks a map guarded by a std mutex; a panic elsewhere while holding it cannot leave the map
/// half-updated (every update is a single insert), so a poisoned lock is still usable.
pub(super) fn lock_map<K, V>(m: &Mutex<HashMap<K, V>>) -> std::sync::MutexGuard<'_, HashMap<K, V>> {
    match m.lock() {
        Ok(g) => g,
        Err(poisoned) => poisoned.into_inner(),
    }
}

impl App {
    /// Runs an operation on a task of its own and waits for its answer. The caller may go
    /// away (its future dropped): the operation still completes, so a cell's model and the
    /// database change together or not at all.
    pub(super) async fn to_completion<T, F>(&self, op: impl FnOnce(App) -> F) -> Result<T>
    where
        F: Future<Output = Result<T>> + Send + 'static,
        T: Send + 'static,
    {
        // The request's audit trail goes with the operation onto its task.
        let work = op(self.clone());
        let recorder = Recorder::current();
        let work = async move {
            match recorder {
                Some(recorder) => recorder.scope(work).await,
                None => work.await,
            }
        };
        self.tasks
            .spawn(work)
            .await
            .map_err(|e| AppError::Internal(format!("operation task: {e}")))?
    }

    /// Runs a write that follows the cell's model in memory to completion, again (after the
    /// model has caught up) when the cell changed elsewhere between its check and its commit.
    pub(super) async fn following<T, F>(&self, op: impl Fn(App) -> F + Send + 'static) -> Result<T>
    where
        F: Future<Output = Result<T>> + Send + 'static,
        T: Send + 'static,
    {
        self.to_completion(move |app| async move {
            let mut tries = 0;
            loop {
                match op(app.clone()).await {
                    Err(AppError::Stale(m)) if tries < 4 => {
                        tries += 1;
                        tracing::debug!(tries, "{m}; trying again");
                    }
                    other => return other,
                }
            }
        })
        .await
    }

    /// Waits for the operations still running (their callers may have gone away); new
    /// operations can still start. Shutdown calls it once the listener has stopped.
    pub async fn finish_operations(&self) {
        self.tasks.close();
        self.tasks.wait().await;
        self.tasks.reopen();
    }

    pub(super) fn slot(&self, cell_id: i64) -> Slot {
        lock_map(&self.models).entry(cell_id).or_default().clone()
    }

    pub(super) async fn cell_row(&self, id: i64) -> Result<CellRow> {
        self.store
            .cell(id)
            .await?
            .ok_or_else(|| AppError::not_found("cell", id))
    }

    pub(super) async fn program_row(&self, id: i64) -> Result<ProgramRow> {
        self.store
            .program(id)
            .await?
            .ok_or_else(|| AppError::not_found("program", id))
    }

    pub(super) async fn routine_row(&self, id: i64) -> Result<RoutineRow> {
        self.store
            .routine(id)
            .await?
            .ok_or_else(|| AppError::not_found("routine", id))
    }

    /// Locks a cell's model, loading it from the database on first use (the cell must exist:
    /// a missing one is a 404, but callers check first so no slot is made for it).
    ///
    /// When other instances may write the database (PostgreSQL), or a write of ours found the
    /// cell changed, the model is first brought up to the database's state of the cell: what
    /// is new is learned, or the model is learned again when it cannot follow (an edit).
    pub(super) async fn lock_cell_id(&self, cell_id: i64) -> Result<Locked> {
        let mut guard = self.slot(cell_id).lock_owned().await;
        let check = match guard.as_ref() {
            None => {
                let cell = self.cell_row(cell_id).await?;
                *guard = Some(CellModel::load(&self.store, &cell, &self.robots).await?);
                false
            }
            Some(model) => model.needs_check || self.store.backend().shared(),
        };
        if check {
            let Some(state) = self.store.cell_state(cell_id).await? else {
                *guard = None;
                lock_map(&self.routine_cells).retain(|_, cell| *cell != cell_id);
                return Err(AppError::not_found("cell", cell_id));
            };
            let behind = match guard.as_mut() {
                Some(model) => model.catch_up(&self.store, &state).await?,
                None => Behind::Reload,
            };
            if behind == Behind::Reload {
                tracing::debug!(cell = cell_id, "cell changed elsewhere; learning it again");
                *guard = None;
                let cell = self.cell_row(cell_id).await?;
                *guard = Some(CellModel::load(&self.store, &cell, &self.robots).await?);
            }
        }
        Ok(Locked(guard))
    }

    /// Locks the cell of a routine being taught. The cell's model knows which routine is open,
    /// so under the lock no further read is needed; a finished routine is refused (409).
    pub(super) async fn lock_open_routine(&self, id: i64) -> Result<(Locked, OpenRoutine)> {
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
}
