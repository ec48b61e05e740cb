//! A program's history (see [`crate::storage`]'s `history`): its revisions, the program as of
//! one, what changed between two, and a restore, which makes the program equal to an earlier
//! revision as one more revision and has the cell's model learned again, as after any edit.

use std::collections::HashMap;

use super::cell_model::{stored_joint_values, stored_pose_values};
use super::error::AppError;
use super::registry::lock_map;
use super::rows::{program, stored_motion};
use super::{App, Result};
use crate::api::{
    ChangeKind, DiffQuery, HistoryQuery, ProgramDiff, ProgramHistory, ProgramRevision,
    RestoreProgram, Restored, Revision, RevisionChange, RoutineChanged, RoutineRevision,
    RoutineSummary, WaypointChanged, WaypointRevision, WaypointSummary,
};
use crate::storage::{
    CellWrite, Change, ProgramState, RevisionFilter, RevisionRow, RoutineState, StorageError,
    WaypointState,
};

/// Revisions per page unless asked otherwise, and at most.
const HISTORY_PAGE: u32 = 100;
const MAX_HISTORY_PAGE: u32 = 1000;

impl App {
    /// A program's revisions, newest first, in pages.
    pub async fn program_history(&self, id: i64, query: HistoryQuery) -> Result<ProgramHistory> {
        let limit = query.limit.unwrap_or(HISTORY_PAGE);
        if !(1..=MAX_HISTORY_PAGE).contains(&limit) {
            return Err(AppError::Invalid(format!(
                "limit must be 1 to {MAX_HISTORY_PAGE}, not {limit}"
            )));
        }
        if query.before.is_some_and(|b| b < 1) {
            return Err(AppError::Invalid("before must be a revision (≥ 1)".into()));
        }
        self.program_row(id).await?;
        let last = self.store.last_revision(id).await?;
        let mut rows = self
            .store
            .revisions(
                id,
                RevisionFilter {
                    before: query.before,
                    // One more than the page: whether there is a next one.
                    limit: i64::from(limit) + 1,
                },
            )
            .await?;
        let more = rows.len() > limit as usize;
        rows.truncate(limit as usize);
        let next = more.then(|| rows.last().map(|r| r.revision)).flatten();
        Ok(ProgramHistory {
            program_id: id,
            revision: last,
            revisions: rows.iter().map(revision).collect::<Result<_>>()?,
            next,
        })
    }

    /// A program as of `revision` (None: now) and its last revision; a 404 names a revision it
    /// does not have.
    pub(super) async fn program_state(
        &self,
        id: i64,
        revision: Option<i64>,
    ) -> Result<(ProgramState, i64)> {
        match self.store.program_as_of(id, revision).await {
            Ok(found) => Ok(found),
            Err(StorageError::NotFound) => match revision {
                Some(r) if r < 0 => Err(AppError::Invalid(format!(
                    "there is no revision {r}: revisions are numbered from 0"
                ))),
                Some(r) => {
                    self.program_row(id).await?;
                    Err(AppError::NoSuch(format!(
                        "program {id} has no revision {r} (its revisions are 0 to {})",
                        self.store.last_revision(id).await?
                    )))
                }
                None => Err(AppError::not_found("program", id)),
            },
            Err(e) => Err(e.into()),
        }
    }

    /// A program as of a revision.
    pub async fn program_revision(&self, id: i64, revision: i64) -> Result<ProgramRevision> {
        let row = self.program_row(id).await?;
        let (state, last) = self.program_state(id, Some(revision)).await?;
        let mut routines = Vec::with_capacity(state.routines.len());
        for (i, r) in state.routines.into_iter().enumerate() {
            let mut waypoints = Vec::with_capacity(r.waypoints.len());
            for (j, w) in r.waypoints.iter().enumerate() {
                waypoints.push(waypoint_revision(w, j as i64 + 1)?);
            }
            routines.push(RoutineRevision {
                id: r.id,
                position: i as i64 + 1,
                name: r.name.clone(),
                finished: !r.open(),
                learned: r.learned,
                imported: r.imported,
                waypoints,
            });
        }
        Ok(ProgramRevision {
            program: program(row),
            revision,
            last_revision: last,
            routines,
        })
    }

    /// What changed from one revision of a program to another.
    pub async fn diff_program(&self, id: i64, query: DiffQuery) -> Result<ProgramDiff> {
        self.program_row(id).await?;
        let (old, last) = self.program_state(id, Some(query.from)).await?;
        let to = query.to.unwrap_or(last);
        let (new, _) = self.program_state(id, Some(to)).await?;
        diff(id, query.from, to, &old, &new)
    }

    /// Makes a program equal to one of its revisions, as a new revision; the cell's model is
    /// learned again from the stored routines.
    pub async fn restore_program(&self, id: i64, input: RestoreProgram) -> Result<Restored> {
        self.to_completion(move |app| async move {
            let p = app.program_row(id).await?;
            let locked = app.lock_cell_id(p.cell_id).await?;
            let (target, last) = app.program_state(id, Some(input.revision)).await?;
            let (now, _) = app.program_state(id, None).await?;
            // A routine being taught that comes back needs the cell's one open place free.
            if let Some(back) = target
                .routines
                .iter()
                .find(|t| t.open() && !now.routines.iter().any(|r| r.id == t.id))
                && let Some(open) = app.store.open_routine(p.cell_id).await?
                && (open.program_id != id || target.routines.iter().any(|t| t.id == open.id))
            {
                return Err(AppError::Conflict(format!(
                    "routine {} was being taught at revision {} and routine {} of cell {} is \
                     being taught now; finish or delete it before restoring",
                    back.id, input.revision, open.id, p.cell_id
                )));
            }
            let (revision, state) = app
                .store
                .restore_program(id, p.cell_id, last, &target, CellWrite::edit(true, true))
                .await?;
            let changed = revision.is_some();
            if changed {
                {
                    let mut cache = lock_map(&app.routine_cells);
                    for r in &now.routines {
                        if !target.routines.iter().any(|t| t.id == r.id) {
                            cache.remove(&r.id);
                        }
                    }
                }
                app.after_edit(locked, p.cell_id, true);
            }
            let model_version = if changed {
                state.model_version
            } else {
                app.cell_row(p.cell_id).await?.model_version
            };
            tracing::info!(
                program = id,
                restored = input.revision,
                ?revision,
                "program restored"
            );
            Ok(Restored {
                program_id: id,
                restored: input.revision,
                revision: revision.unwrap_or(last),
                changed,
                model_version,
            })
        })
        .await
    }
}

fn revision(row: &RevisionRow) -> Result<Revision> {
    Ok(Revision {
        revision: row.revision,
        at: row.at.clone(),
        token: row.token.clone(),
        request_id: row.request_id.clone(),
        operation: row.operation.clone(),
        changes: row.changes()?.iter().map(change).collect(),
    })
}

fn change(c: &Change) -> RevisionChange {
    let (change, routine_id, waypoint_id, place, waypoints) = match c {
        Change::WaypointAdded { routine, seq } => (
            ChangeKind::WaypointAdded,
            Some(*routine),
            None,
            Some(*seq),
            None,
        ),
        Change::WaypointRemoved {
            routine,
            seq,
            waypoint,
        } => (
            ChangeKind::WaypointRemoved,
            Some(*routine),
            Some(waypoint.id),
            Some(*seq),
            None,
        ),
        Change::WaypointModified {
            routine, waypoint, ..
        } => (
            ChangeKind::WaypointModified,
            Some(*routine),
            Some(*waypoint),
            None,
            None,
        ),
        Change::RoutineAdded {
            routine,
            position,
            waypoints,
        } => (
            ChangeKind::RoutineAdded,
            Some(*routine),
            None,
            Some(*position),
            Some(*waypoints),
        ),
        Change::RoutineRemoved { position, routine } => (
            ChangeKind::RoutineRemoved,
            Some(routine.id),
            None,
            Some(*position),
            Some(routine.waypoints.len() as i64),
        ),
        Change::RoutineRenamed { routine, .. } => {
            (ChangeKind::RoutineRenamed, Some(*routine), None, None, None)
        }
        Change::RoutineMoved { routine, to, .. } => (
            ChangeKind::RoutineMoved,
            Some(*routine),
            None,
            Some(*to),
            None,
        ),
        Change::RoutineFinished { routine } => (
            ChangeKind::RoutineFinished,
            Some(*routine),
            None,
            None,
            None,
        ),
        Change::RoutinesReordered { .. } => (ChangeKind::RoutinesReordered, None, None, None, None),
    };
    RevisionChange {
        change,
        routine_id,
        waypoint_id,
        place,
        waypoints,
    }
}

fn waypoint_revision(w: &WaypointState, seq: i64) -> Result<WaypointRevision> {
    let v = &w.values;
    Ok(WaypointRevision {
        id: w.id,
        seq,
        pose: v.pose,
        joints: stored_joint_values(w.id, &v.joints)?,
        motion: stored_motion(w.id, &v.motion)?,
        name: v.name.clone(),
        reachable: v.reachable,
    })
}

/// Every waypoint of a program with its routine and place.
fn placed(state: &ProgramState) -> impl Iterator<Item = (&RoutineState, i64, &WaypointState)> {
    state.routines.iter().flat_map(|r| {
        r.waypoints
            .iter()
            .enumerate()
            .map(move |(i, w)| (r, i as i64 + 1, w))
    })
}

fn summary(r: &RoutineState, position: usize) -> RoutineSummary {
    RoutineSummary {
        id: r.id,
        name: r.name.clone(),
        position: position as i64 + 1,
        waypoints: r.waypoints.len() as i64,
    }
}

/// What differs between two states of a program, by id.
fn diff(
    id: i64,
    from: i64,
    to: i64,
    old: &ProgramState,
    new: &ProgramState,
) -> Result<ProgramDiff> {
    let index = |s: &ProgramState, rid: i64| s.routines.iter().position(|r| r.id == rid);
    let mut out = ProgramDiff {
        program_id: id,
        from,
        to,
        routines_added: Vec::new(),
        routines_removed: Vec::new(),
        routines_changed: Vec::new(),
        waypoints_added: Vec::new(),
        waypoints_removed: Vec::new(),
        waypoints_changed: Vec::new(),
    };
    // A place that differs only because routines before it came or went is not a change of
    // a routine: its place is compared among the routines in both.
    let kept = |s: &ProgramState, other: &ProgramState| -> Vec<i64> {
        s.routines
            .iter()
            .filter(|x| index(other, x.id).is_some())
            .map(|x| x.id)
            .collect()
    };
    let (kept_old, kept_new) = (kept(old, new), kept(new, old));
    for (i, r) in new.routines.iter().enumerate() {
        match index(old, r.id) {
            None => out.routines_added.push(summary(r, i)),
            Some(j) => {
                let before = &old.routines[j];
                let rank = |ids: &[i64]| ids.iter().position(|x| *x == r.id);
                let moved = rank(&kept_old) != rank(&kept_new);
                if before.name != r.name || moved {
                    out.routines_changed.push(RoutineChanged {
                        id: r.id,
                        name_from: before.name.clone(),
                        name_to: r.name.clone(),
                        position_from: j as i64 + 1,
                        position_to: i as i64 + 1,
                    });
                }
            }
        }
    }
    for (j, r) in old.routines.iter().enumerate() {
        if index(new, r.id).is_none() {
            out.routines_removed.push(summary(r, j));
        }
    }
    let by_id = |s: &ProgramState| -> HashMap<i64, i64> {
        placed(s).map(|(_, seq, w)| (w.id, seq)).collect()
    };
    let (old_ids, new_ids) = (by_id(old), by_id(new));
    let old_values: HashMap<i64, &WaypointState> = placed(old).map(|(_, _, w)| (w.id, w)).collect();
    for (r, seq, w) in placed(new) {
        match old_ids.get(&w.id).zip(old_values.get(&w.id)) {
            None => out.waypoints_added.push(WaypointSummary {
                id: w.id,
                routine_id: r.id,
                seq,
                pose: w.values.pose,
            }),
            Some((seq_from, before)) => {
                if before.values != w.values {
                    out.waypoints_changed
                        .push(changed(r.id, *seq_from, seq, before, w)?);
                }
            }
        }
    }
    for (r, seq, w) in placed(old) {
        if !new_ids.contains_key(&w.id) {
            out.waypoints_removed.push(WaypointSummary {
                id: w.id,
                routine_id: r.id,
                seq,
                pose: w.values.pose,
            });
        }
    }
    Ok(out)
}

fn changed(
    routine: i64,
    seq_from: i64,
    seq_to: i64,
    before: &WaypointState,
    after: &WaypointState,
) -> Result<WaypointChanged> {
    let (a, b) = (&before.values, &after.values);
    let p = stored_pose_values(&a.pose)?;
    let q = stored_pose_values(&b.pose)?;
    let mut fields = Vec::new();
    if a.pose != b.pose {
        fields.push("pose".to_string());
    }
    if a.joints != b.joints {
        fields.push("joints".to_string());
    }
    if a.motion != b.motion {
        fields.push("motion".to_string());
    }
    if a.name != b.name {
        fields.push("name".to_string());
    }
    if a.reachable != b.reachable {
        fields.push("reachable".to_string());
    }
    Ok(WaypointChanged {
        id: after.id,
        routine_id: routine,
        seq_from,
        seq_to,
        moved_mm: p.distance_to(&q),
        turned_degrees: p.angle_to(&q).to_degrees(),
        fields,
    })
}
