//! Program history: every change to a program's routines or waypoints is a revision (1, 2, …
//! per program), written by the change's own transaction ([`record`]), with who made it (the
//! request's token, request id and operation, as in the audit trail).
//!
//! A revision stores its [`Change`]s, not a copy of the program; the program as of revision
//! `n` is its present state with the revisions after `n` taken back in reverse order
//! ([`ProgramState::take_back`]); revision 0 is the program when its history began. The
//! changes and the taking back are the program model's ([`crate::program::revisions`]); this
//! file writes and reads them. A restore ([`Store::restore_program`]) makes the changes that
//! make the program equal to an earlier state (the program model plans them:
//! [`ProgramState::changes_to`]; here each is made in SQL) and writes them as one more
//! revision, keeping the ids of what it brings back.

use super::Store;
use super::audit::Recorder;
use super::binds::Binds;
use super::cell_write::CellWrite;
use super::error::{Result, StorageError, classify};
use super::inserts::{RevisionRows, Who, insert_kept_waypoints};
use super::query::select;
use super::rows::{CellState, NewWaypoint, RoutineRow, Stored, WaypointRow, flag};
use super::slots::Params;
use super::transaction::{Places, Tx, UPDATE_WAYPOINT, close_gap, make_room, touch_cell};
pub(super) use crate::program::revisions::{
    Change, ProgramState, RoutineState, WaypointState, WaypointValues,
};

/// A revision as listed.
#[derive(Debug, Clone, sqlx::FromRow)]
pub struct RevisionRow {
    pub program_id: i64,
    pub revision: i64,
    pub at: String,
    pub token: Option<String>,
    pub request_id: Option<String>,
    pub operation: Option<String>,
    /// JSON array of [`Change`]s.
    pub changes: String,
}

impl Stored for RevisionRow {
    const COLUMNS: &'static str = "program_id, revision, at, token, request_id, operation, changes";
    const FROM: &'static str = "program_history";
}

impl RevisionRow {
    pub fn changes(&self) -> Result<Vec<Change>> {
        serde_json::from_str(&self.changes).map_err(|e| {
            StorageError::History(format!(
                "revision {} of program {}: {e}",
                self.revision, self.program_id
            ))
        })
    }
}

fn inconsistent(what: String) -> StorageError {
    StorageError::History(what)
}

/// Writes `changes` to `program` as its next revision, in `tx`; returns the revision's number
/// (with no changes, nothing is written and the last revision is answered).
pub(super) async fn record(tx: &mut Tx<'_>, program: i64, changes: &[Change]) -> Result<i64> {
    record_for(tx, program, changes, Recorder::current().as_ref()).await
}

/// [`record`] for the request `recorder` (None: no request).
async fn record_for(
    tx: &mut Tx<'_>,
    program: i64,
    changes: &[Change],
    recorder: Option<&Recorder>,
) -> Result<i64> {
    if changes.is_empty() {
        return last_revision(tx, program).await;
    }
    let json = serde_json::to_string(changes)
        .map_err(|e| inconsistent(format!("a change could not be written: {e}")))?;
    let mut params = Params::default();
    let who = Who::bind(&mut params, Recorder::who(recorder));
    let program = params.push(program);
    let changes = params.push(json);
    let mut rows = RevisionRows::default();
    rows.push(&program.to_string(), &who, changes, "");
    let (revision,): (i64,) = params
        .query_as(rows.sql("revision"))?
        .fetch_one(&mut **tx)
        .await
        .map_err(classify)?;
    Ok(revision)
}

/// The program a routine is part of.
pub(super) async fn program_of(tx: &mut Tx<'_>, routine: i64) -> Result<i64> {
    let (program,): (i64,) = sqlx::query_as("SELECT program_id FROM routines WHERE id = $1")
        .bind(routine)
        .fetch_optional(&mut **tx)
        .await?
        .ok_or(StorageError::NotFound)?;
    Ok(program)
}

/// A routine as it is in `tx`, with its waypoints.
pub(super) async fn routine_state(tx: &mut Tx<'_>, routine: &RoutineRow) -> Result<RoutineState> {
    let rows = select::<WaypointRow>("WHERE routine_id = $1 ORDER BY seq", &[routine.id])
        .fetch_all(&mut **tx)
        .await?;
    Ok(RoutineState {
        id: routine.id,
        name: routine.name.clone(),
        imported: routine.imported,
        learned: routine.learned(),
        waypoints: rows
            .iter()
            .map(|w| WaypointState {
                id: w.id,
                values: WaypointValues::of(w),
            })
            .collect(),
    })
}

/// A program as it is in `tx`.
async fn program_state(tx: &mut Tx<'_>, program: i64) -> Result<ProgramState> {
    let routines = select::<RoutineRow>("WHERE r.program_id = $1 ORDER BY r.position", &[program])
        .fetch_all(&mut **tx)
        .await?;
    let mut state = ProgramState::default();
    for r in &routines {
        state.routines.push(routine_state(tx, r).await?);
    }
    Ok(state)
}

/// The number of a program's last revision (0: none yet).
async fn last_revision(conn: &mut sqlx::AnyConnection, program: i64) -> Result<i64> {
    let (n,): (i64,) = sqlx::query_as(
        "SELECT COALESCE(MAX(revision), 0) FROM program_history WHERE program_id = $1",
    )
    .bind(program)
    .fetch_one(conn)
    .await?;
    Ok(n)
}

/// Which revisions [`Store::revisions`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RevisionFilter {
    /// Only revisions before this one (the next page of a newest-first listing).
    pub before: Option<i64>,
    pub limit: i64,
}

impl Store {
    /// The number of a program's last revision (0: none yet).
    pub async fn last_revision(&self, program: i64) -> Result<i64> {
        last_revision(&mut *self.pool.acquire().await?, program).await
    }

    /// A program's revisions, newest first.
    pub async fn revisions(
        &self,
        program: i64,
        filter: RevisionFilter,
    ) -> Result<Vec<RevisionRow>> {
        let sql = format!(
            "SELECT {} FROM {} WHERE program_id = $1 AND ($2 IS NULL OR revision < $2) \
             ORDER BY revision DESC LIMIT $3",
            RevisionRow::COLUMNS,
            RevisionRow::FROM
        );
        Ok(sqlx::query_as::<_, RevisionRow>(sqlx::AssertSqlSafe(sql))
            .bind(program)
            .bind(filter.before)
            .bind(filter.limit)
            .fetch_all(&self.pool)
            .await?)
    }

    /// A program as of `revision` (None: as it is now), and its last revision. NotFound when
    /// the program has no such revision.
    pub async fn program_as_of(
        &self,
        program: i64,
        revision: Option<i64>,
    ) -> Result<(ProgramState, i64)> {
        // One transaction: the state and the revisions to take back are read at one moment.
        let mut tx = self.pool.begin().await?;
        let last = last_revision(&mut tx, program).await?;
        let mut state = program_state(&mut tx, program).await?;
        let revision = revision.unwrap_or(last);
        if !(0..=last).contains(&revision) {
            return Err(StorageError::NotFound);
        }
        let later = format!(
            "SELECT {} FROM {} WHERE program_id = $1 AND revision > $2 ORDER BY revision DESC",
            RevisionRow::COLUMNS,
            RevisionRow::FROM
        );
        let rows = sqlx::query_as::<_, RevisionRow>(sqlx::AssertSqlSafe(later))
            .bind(program)
            .bind(revision)
            .fetch_all(&mut *tx)
            .await?;
        tx.commit().await?;
        for row in &rows {
            for change in row.changes()?.iter().rev() {
                state
                    .take_back(change)
                    .map_err(|e| StorageError::History(e.0))?;
            }
        }
        Ok((state, last))
    }

    /// Makes the program `program` of cell `cell_id` equal to `target` (its routines, their
    /// names, order and waypoints; a routine there now keeps whether it is finished), as one
    /// revision, in one transaction; what comes back keeps its ids. `last` is the program's
    /// last revision when `target` was read: refused with `Stale` when it has moved on.
    /// Returns the new revision (None: nothing differed, nothing written) and the cell's
    /// state.
    pub async fn restore_program(
        &self,
        program: i64,
        cell_id: i64,
        last: i64,
        target: &ProgramState,
        write: CellWrite,
    ) -> Result<(Option<i64>, CellState)> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, write).await?;
        if last_revision(&mut tx, program).await? != last {
            return Err(StorageError::Stale {
                cell: cell_id,
                expected: last,
            });
        }
        let changes = program_state(&mut tx, program).await?.changes_to(target);
        for change in &changes {
            make(
                &mut tx,
                program,
                cell_id,
                target,
                change,
                self.backend.now(),
            )
            .await?;
        }
        if changes.is_empty() {
            // Nothing differed: nothing is written (the cell's revision stays).
            return Ok((None, state));
        }
        let revision = record(&mut tx, program, &changes).await?;
        tx.commit().await?;
        Ok((Some(revision), state))
    }
}

/// Makes `change`, one of the changes towards `target` ([`ProgramState::changes_to`]), to
/// program `program` of cell `cell_id` in `tx`: the values it puts in are the target's.
async fn make(
    tx: &mut Tx<'_>,
    program: i64,
    cell_id: i64,
    target: &ProgramState,
    change: &Change,
    now: &str,
) -> Result<()> {
    let target_routine = |id: i64| target.routine(id).map_err(|e| inconsistent(e.0));
    match change {
        Change::RoutineRemoved { position, routine } => {
            sqlx::query("DELETE FROM routines WHERE id = $1")
                .bind(routine.id)
                .execute(&mut **tx)
                .await?;
            close_gap(tx, Places::Routines, program, *position).await?;
        }
        Change::RoutineRenamed { routine, .. } => {
            sqlx::query("UPDATE routines SET name = $1 WHERE id = $2")
                .bind(target_routine(*routine)?.name.clone())
                .bind(routine)
                .execute(&mut **tx)
                .await?;
        }
        Change::WaypointRemoved {
            routine,
            seq,
            waypoint,
        } => {
            sqlx::query("DELETE FROM waypoints WHERE id = $1")
                .bind(waypoint.id)
                .execute(&mut **tx)
                .await?;
            close_gap(tx, Places::Waypoints, *routine, *seq).await?;
        }
        Change::WaypointModified {
            routine, waypoint, ..
        } => {
            let v = &target_routine(*routine)?
                .waypoints
                .iter()
                .find(|w| w.id == *waypoint)
                .ok_or_else(|| inconsistent(format!("waypoint {waypoint} is not in the target")))?
                .values;
            sqlx::query(UPDATE_WAYPOINT)
                .waypoint_values(&v.pose, &v.joints, &v.motion, &v.name, v.reachable)
                .bind(waypoint)
                .execute(&mut **tx)
                .await?;
        }
        Change::WaypointAdded { routine, seq } => {
            let x = usize::try_from(*seq - 1)
                .ok()
                .and_then(|i| target_routine(*routine).ok()?.waypoints.get(i))
                .ok_or_else(|| inconsistent(format!("routine {routine} has no place {seq}")))?;
            // The waypoints kept are in the target's order: this one's place is free.
            make_room(tx, Places::Waypoints, *routine, *seq).await?;
            insert_kept_waypoints(tx, &[(x.id, x.values.at(*routine, *seq))]).await?;
        }
        Change::RoutineAdded {
            routine, position, ..
        } => {
            let t = target_routine(*routine)?;
            bring_back(tx, program, cell_id, *position, t, now).await?;
        }
        Change::RoutinesReordered { .. } => {
            for (i, r) in target.routines.iter().enumerate() {
                sqlx::query("UPDATE routines SET position = $1 WHERE id = $2")
                    .bind(-(i as i64 + 1))
                    .bind(r.id)
                    .execute(&mut **tx)
                    .await?;
            }
            sqlx::query("UPDATE routines SET position = -position WHERE program_id = $1")
                .bind(program)
                .execute(&mut **tx)
                .await?;
        }
        Change::RoutineMoved { .. } | Change::RoutineFinished { .. } => {
            return Err(inconsistent(format!("a restore does not make {change:?}")));
        }
    }
    Ok(())
}

/// Puts a routine of the target back at `position`, with its id, status and waypoints.
async fn bring_back(
    tx: &mut Tx<'_>,
    program: i64,
    cell_id: i64,
    position: i64,
    t: &RoutineState,
    now: &str,
) -> Result<()> {
    let sql = format!(
        "INSERT INTO routines (id, program_id, cell_id, position, name, imported, finish_seq, \
           finished_at) \
         VALUES ($1, $2, $3, $4, $5, $6, \
           CASE WHEN $7 = 1 THEN (SELECT COALESCE(MAX(finish_seq), 0) + 1 FROM routines \
                                  WHERE cell_id = $3) END, \
           CASE WHEN $7 = 1 THEN {now} END)"
    );
    sqlx::query(sqlx::AssertSqlSafe(sql))
        .bind(t.id)
        .bind(program)
        .bind(cell_id)
        .bind(position)
        .bind(t.name.clone())
        .bind(flag(t.imported))
        .bind(flag(t.learned))
        .execute(&mut **tx)
        .await
        .map_err(classify)?;
    let waypoints: Vec<(i64, NewWaypoint)> = (1..)
        .zip(&t.waypoints)
        .map(|(seq, w)| (w.id, w.values.at(t.id, seq)))
        .collect();
    insert_kept_waypoints(tx, &waypoints).await
}

/// The place (1, 2, …) of a routine in its program's order.
pub(super) async fn routine_place(tx: &mut Tx<'_>, routine: i64) -> Result<i64> {
    let (n,): (i64,) = sqlx::query_as(
        "SELECT COUNT(*) FROM routines o, routines r \
         WHERE r.id = $1 AND o.program_id = r.program_id AND o.position <= r.position",
    )
    .bind(routine)
    .fetch_one(&mut **tx)
    .await?;
    if n == 0 {
        return Err(StorageError::NotFound);
    }
    Ok(n)
}

/// What deleting a routine takes away, read before it goes: its program and the change.
pub(super) async fn removal(tx: &mut Tx<'_>, routine: i64) -> Result<(i64, Change)> {
    let row = select::<RoutineRow>("WHERE r.id = $1", &[routine])
        .fetch_optional(&mut **tx)
        .await?
        .ok_or(StorageError::NotFound)?;
    let position = routine_place(tx, routine).await?;
    let state = routine_state(tx, &row).await?;
    Ok((
        row.program_id,
        Change::RoutineRemoved {
            position,
            routine: state,
        },
    ))
}
