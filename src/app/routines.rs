//! Routines of a program: start one (a cell teaches one at a time), list, read, resume, delete
//! one, finish it (the model learns it). Other edits are in `editing`.

use super::error::AppError;
use super::registry::{lock_map, stale_check};
use super::rows::{routine, waypoint};
use super::{App, Result, check_name};
use crate::api::{CreateRoutine, Finished, Routine, RoutineDetail};

impl App {
    /// Starts a routine at the end of a program. The cell must not have another routine
    /// being taught.
    pub async fn create_routine(&self, program_id: i64, input: CreateRoutine) -> Result<Routine> {
        self.following(move |app| {
            let input = input.clone();
            async move { app.create_routine_now(program_id, input).await }
        })
        .await
    }

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
        let expected = locked.model()?.revision;
        let (id, state) = self
            .store
            .insert_routine(&p, input.name.as_deref().map(str::trim), expected)
            .await
            .inspect_err(|e| stale_check(&mut locked, e))?;
        locked.model()?.opened(id, state.revision);
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

    /// Deletes a routine with its waypoints. The one being taught is forgotten by the model
    /// at once (as if never taught); a finished one that the model learned leaves it by a
    /// rebuild (the model version advances; see `editing`).
    pub async fn delete_routine(&self, id: i64) -> Result<()> {
        self.following(move |app| async move {
            if app.routine_row(id).await?.finished() {
                app.delete_finished_routine_now(id).await
            } else {
                app.delete_routine_now(id).await
            }
        })
        .await
    }

    async fn delete_routine_now(&self, id: i64) -> Result<()> {
        let (mut locked, r) = match self.lock_open_routine(id).await {
            // Finished while we waited for the lock.
            Err(AppError::Conflict(_)) => return self.delete_finished_routine_now(id).await,
            other => other?,
        };
        let expected = locked.model()?.revision;
        let state = self
            .store
            .delete_open_routine(r.id, r.cell_id, expected)
            .await
            .inspect_err(|e| stale_check(&mut locked, e))?;
        lock_map(&self.routine_cells).remove(&r.id);
        locked.model()?.abandoned(state.revision);
        Ok(())
    }

    /// Finishes a routine: it takes no more teaching (edits still apply) and the cell's model
    /// assimilates it.
    pub async fn finish_routine(&self, id: i64) -> Result<Finished> {
        self.following(move |app| async move { app.finish_routine_now(id).await })
            .await
    }

    async fn finish_routine_now(&self, id: i64) -> Result<Finished> {
        let (mut locked, r) = self.lock_open_routine(id).await?;
        let expected = locked.model()?.revision;
        let (finish_seq, state) = self
            .store
            .finish_routine(r.cell_id, r.id, expected)
            .await
            .inspect_err(|e| stale_check(&mut locked, e))?;
        let model = locked.model()?;
        model.finished(finish_seq, &state);
        let info = model.info();
        Ok(Finished {
            routine: routine(self.routine_row(id).await?),
            model: info,
        })
    }
}
