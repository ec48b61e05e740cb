//! Editing what was taught: modify, insert and delete waypoints of any routine (finished or
//! being taught); rename, move and delete routines; rename and delete programs and cells.
//!
//! Every edit is checked before anything changes and written in one transaction. An edit that
//! changes what the cell's model learned (a waypoint's pose in a learned routine, a waypoint
//! inserted into or deleted from one, a learned routine deleted) advances the cell's model
//! version in that transaction. The model itself is then rebuilt from the stored routines: the
//! edit drops the cell's model from memory and a background task learns it again under the
//! cell's lock, so the edit answers at once and the next request on the cell waits for the
//! rebuild (the rebuild is what [`App::rebuild`] does: identical to the incremental model by
//! construction). Edits of the routine being taught rebuild the same way (its moves were
//! learned within the routine). Predictions keep the model version they were made with;
//! feedback on them is accepted whatever the version now.

use super::error::AppError;
use super::registry::{Locked, lock_map};
use super::rows::{motion_to_store, program, routine, waypoint};
use super::{App, Result, check_name};
use crate::api::{
    Cell, CellPatch, InsertWaypoint, NewWaypoint, PoseValues, Program, Rename, RoutineEdit,
    RoutinePatch, Side, WaypointEdit, WaypointPatch,
};
use crate::storage::{CellWrite, RoutineRow, WaypointRow, WaypointValues};

/// What an edit of a routine's waypoints does to the cell's model.
#[derive(Debug, Clone, Copy)]
struct Effect {
    /// The model must be learned again (a learned routine or the open one changed).
    rebuild: bool,
    /// The model version advances (a learned routine changed).
    advance: bool,
}

impl Effect {
    /// The edit's write on the cell (advancing the model version when `advance`).
    fn write(self, advance: bool) -> CellWrite {
        CellWrite::edit(advance, self.rebuild)
    }

    fn of(r: &RoutineRow, changes_poses: bool) -> Effect {
        let open = !r.finished();
        Effect {
            rebuild: changes_poses && (r.learned() || open),
            advance: changes_poses && r.learned(),
        }
    }
}

impl App {
    /// The waypoint's row and its routine's, or a 404.
    async fn waypoint_and_routine(&self, id: i64) -> Result<(WaypointRow, RoutineRow)> {
        let w = self
            .store
            .waypoint(id)
            .await?
            .ok_or_else(|| AppError::not_found("waypoint", id))?;
        let r = self.routine_row(w.routine_id).await?;
        Ok((w, r))
    }

    /// After an edit (which advanced the cell's revision): the model is learned again when
    /// the edit changed what it learned, else it checks the database on its next use.
    pub(super) fn after_edit(&self, mut locked: Locked, cell_id: i64, rebuild: bool) {
        if rebuild {
            self.rebuild_later(locked, cell_id);
        } else {
            locked.check_next_time();
        }
    }

    /// Drops the cell's model after an edit that changed what it learned, and learns it again
    /// from the database on a task of its own (see the module doc).
    fn rebuild_later(&self, mut locked: Locked, cell_id: i64) {
        *locked.0 = None;
        drop(locked);
        let app = self.clone();
        self.tasks.spawn(async move {
            if let Err(e) = app.lock_cell_id(cell_id).await {
                tracing::error!(cell = cell_id, error = %e, "rebuilding the cell's model after an edit");
            }
        });
    }

    /// The stored values of a waypoint as a client gives them: checked (pose, joints against
    /// the arm, name) and with the arm's verdict on the pose.
    fn waypoint_values(locked: &mut Locked, input: &NewWaypoint) -> Result<WaypointValues> {
        let joints = Self::validate_waypoint(input)?;
        let pose = input.pose.to_pose()?;
        let stored = PoseValues::from(&pose);
        let pose = stored.to_pose()?;
        let model = locked.model()?;
        if let (Some(arm), Some(j)) = (&model.arm, &input.joints) {
            arm.check_joints(j)?;
        }
        Ok(WaypointValues {
            pose: stored,
            joints,
            motion: motion_to_store(input.motion),
            name: input.name.as_ref().map(|n| n.trim().to_string()),
            reachable: model
                .arm
                .as_ref()
                .map(|arm| arm.check(&pose, None).is_reachable()),
        })
    }

    /// Modifies a waypoint of any routine ("modify position"): the fields given change.
    pub async fn modify_waypoint(&self, id: i64, patch: WaypointPatch) -> Result<WaypointEdit> {
        self.to_completion(move |app| async move { app.modify_waypoint_now(id, patch).await })
            .await
    }

    async fn modify_waypoint_now(&self, id: i64, patch: WaypointPatch) -> Result<WaypointEdit> {
        let (_, r) = self.waypoint_and_routine(id).await?;
        let mut locked = self.lock_cell_id(r.cell_id).await?;
        // Under the lock: the waypoint as it is now (an edit may have moved or removed it).
        let (before, r) = self.waypoint_and_routine(id).await?;
        let old = waypoint(before.clone())?;
        let input = NewWaypoint {
            pose: patch.pose.unwrap_or(old.pose),
            joints: patch.joints.clone().unwrap_or(old.joints.clone()),
            motion: patch.motion.unwrap_or(old.motion),
            name: patch.name.clone().unwrap_or(old.name.clone()),
            seq: None,
        };
        let mut values = Self::waypoint_values(&mut locked, &input)?;
        let moved = values.pose != before.pose;
        if !moved {
            values.reachable = before.reachable;
        }
        let effect = Effect::of(&r, moved || (patch.joints.is_some() && !r.finished()));
        let advance = effect.advance && moved;
        let (_, after, version) = self
            .store
            .update_waypoint(id, &values, r.cell_id, effect.write(advance))
            .await?;
        self.after_edit(locked, r.cell_id, effect.rebuild);
        Ok(WaypointEdit {
            waypoint: Some(waypoint(after)?),
            previous: Some(old),
            model_version: version,
        })
    }

    /// Inserts a waypoint before or after one of any routine.
    pub async fn insert_waypoint(&self, id: i64, input: InsertWaypoint) -> Result<WaypointEdit> {
        self.to_completion(move |app| async move { app.insert_waypoint_now(id, input).await })
            .await
    }

    async fn insert_waypoint_now(&self, id: i64, input: InsertWaypoint) -> Result<WaypointEdit> {
        let (_, r) = self.waypoint_and_routine(id).await?;
        let mut locked = self.lock_cell_id(r.cell_id).await?;
        let (next_to, r) = self.waypoint_and_routine(id).await?;
        let values = Self::waypoint_values(&mut locked, &input.waypoint)?;
        let seq = match input.side {
            Side::Before => next_to.seq,
            Side::After => next_to.seq + 1,
        };
        // A `seq` given with an inserted waypoint must be the place `side` gives it.
        if let Some(given) = input.waypoint.seq
            && given != seq
        {
            return Err(AppError::Conflict(format!(
                "the waypoint inserted {} waypoint {id} takes seq {seq}, not {given}",
                match input.side {
                    Side::Before => "before",
                    Side::After => "after",
                }
            )));
        }
        let effect = Effect::of(&r, true);
        let (row, version) = self
            .store
            .insert_waypoint(r.id, seq, &values, r.cell_id, effect.write(effect.advance))
            .await?;
        self.after_edit(locked, r.cell_id, effect.rebuild);
        Ok(WaypointEdit {
            waypoint: Some(waypoint(row)?),
            previous: None,
            model_version: version,
        })
    }

    /// Deletes a waypoint of any routine (undo is the way to take back the last one taught,
    /// with its prediction; this is for the others).
    pub async fn delete_waypoint(&self, id: i64) -> Result<WaypointEdit> {
        self.to_completion(move |app| async move { app.delete_waypoint_now(id).await })
            .await
    }

    async fn delete_waypoint_now(&self, id: i64) -> Result<WaypointEdit> {
        let (_, r) = self.waypoint_and_routine(id).await?;
        let locked = self.lock_cell_id(r.cell_id).await?;
        let (_, r) = self.waypoint_and_routine(id).await?;
        let effect = Effect::of(&r, true);
        let (row, version) = self
            .store
            .delete_waypoint(id, r.cell_id, effect.write(effect.advance))
            .await?;
        self.after_edit(locked, r.cell_id, effect.rebuild);
        Ok(WaypointEdit {
            waypoint: None,
            previous: Some(waypoint(row)?),
            model_version: version,
        })
    }

    /// Renames a routine and/or moves it within its program. The model does not change (it
    /// learns routines in the order they were finished, not their place in the program).
    pub async fn edit_routine(&self, id: i64, patch: RoutinePatch) -> Result<RoutineEdit> {
        if let Some(Some(n)) = &patch.name {
            check_name("routine name", n)?;
        }
        if let Some(p) = patch.position
            && p < 1
        {
            return Err(AppError::Invalid(format!(
                "position must be 1 or more, not {p}"
            )));
        }
        self.to_completion(move |app| async move {
            let r = app.routine_row(id).await?;
            let _locked = app.lock_cell_id(r.cell_id).await?;
            let before = app.routine_row(id).await?;
            if patch.name.is_some() || patch.position.is_some() {
                app.store
                    .edit_routine(
                        id,
                        patch.name.as_ref().map(|n| n.as_deref().map(str::trim)),
                        patch.position,
                    )
                    .await?;
            }
            Ok(RoutineEdit {
                routine: routine(app.routine_row(id).await?),
                previous: routine(before),
            })
        })
        .await
    }

    /// Deletes a finished or imported routine with its waypoints; a learned one leaves the
    /// model (rebuilt). (The routine being taught is deleted by [`App::delete_routine`], which
    /// calls this for the others.)
    pub(super) async fn delete_finished_routine_now(&self, id: i64) -> Result<()> {
        let r = self.routine_row(id).await?;
        let locked = self.lock_cell_id(r.cell_id).await?;
        let r = self.routine_row(id).await?;
        self.store
            .delete_routine(id, r.cell_id, CellWrite::edit(r.learned(), r.learned()))
            .await?;
        lock_map(&self.routine_cells).remove(&id);
        self.after_edit(locked, r.cell_id, r.learned());
        Ok(())
    }

    pub async fn rename_program(&self, id: i64, input: Rename) -> Result<Program> {
        check_name("program name", &input.name)?;
        let p = self.program_row(id).await?;
        let row = self
            .store
            .rename_program(id, input.name.trim())
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {} already has a program named {:?}",
                    p.cell_id,
                    input.name.trim()
                )),
                other => other,
            })?;
        Ok(program(row))
    }

    /// Deletes a program with its routines; its learned routines leave the model (rebuilt).
    pub async fn delete_program(&self, id: i64) -> Result<()> {
        self.to_completion(move |app| async move {
            let p = app.program_row(id).await?;
            let locked = app.lock_cell_id(p.cell_id).await?;
            let routines = app.store.routines(id).await?;
            let advance = routines.iter().any(RoutineRow::learned);
            let open = routines.iter().any(|r| !r.finished());
            let version = app
                .store
                .delete_program(id, p.cell_id, CellWrite::edit(advance, advance || open))
                .await?;
            {
                let mut cache = lock_map(&app.routine_cells);
                for r in &routines {
                    cache.remove(&r.id);
                }
            }
            app.after_edit(locked, p.cell_id, advance || open);
            tracing::info!(program = id, model_version = version, "program deleted");
            Ok(())
        })
        .await
    }

    /// Renames a cell and/or changes its settings (validated like a new cell's, before
    /// anything changes). New settings advance the model version, and the model is learned
    /// again with them from the stored routines.
    pub async fn edit_cell(&self, id: i64, patch: CellPatch) -> Result<Cell> {
        if let Some(n) = &patch.name {
            check_name("cell name", n)?;
        }
        self.to_completion(move |app| async move {
            app.cell_row(id).await?;
            let locked = app.lock_cell_id(id).await?;
            let row = app.cell_row(id).await?;
            let json = match patch.settings {
                None => None,
                Some(change) => {
                    let current = super::settings::parse_settings(&row)?;
                    let settings = change.over(current.as_input()).resolve()?;
                    app.robots.require(&settings.robot)?;
                    Some(
                        serde_json::to_string(&settings)
                            .map_err(|e| AppError::Internal(format!("settings: {e}")))?,
                    )
                }
            };
            let name = patch.name.as_deref().map(str::trim);
            let updated = app
                .store
                .update_cell(id, name, json.as_deref())
                .await
                .map_err(|e| match AppError::from(e) {
                    AppError::Conflict(_) => {
                        AppError::Exists(format!("a cell named {:?} exists", name.unwrap_or("")))
                    }
                    other => other,
                })?;
            app.after_edit(locked, id, json.is_some());
            app.cell(updated)
        })
        .await
    }

    /// Deletes a cell with its programs, routines, predictions and feedback, and its model.
    pub async fn delete_cell(&self, id: i64) -> Result<()> {
        self.to_completion(move |app| async move {
            app.cell_row(id).await?;
            let mut guard = app.slot(id).lock_owned().await;
            app.store.delete_cell(id).await?;
            *guard = None;
            lock_map(&app.models).remove(&id);
            lock_map(&app.routine_cells).retain(|_, cell| *cell != id);
            // Tokens limited to it no longer list it.
            app.credentials.tokens_changed();
            Ok(())
        })
        .await
    }
}
