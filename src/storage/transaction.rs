//! The statements that several writes make inside their own transaction: opening the write on
//! its cell ([`touch_cell`], always first, which also puts the request's audit row in the
//! transaction), storing a new routine's waypoints, and keeping a list's places 1, 2, … when one
//! is put in or taken out ([`make_room`], [`close_gap`]). Each is written once here (the inserts
//! of the rows an append writes, once in [`super::inserts`]), so a table's file says what a
//! write does, not how a row is spelled.

use super::cell_write::CellWrite;
use super::error::{Result, StorageError};
use super::inserts;
use super::rows::{CellState, NewWaypoint, WaypointValues, flag};

pub(super) type Tx<'c> = sqlx::Transaction<'c, sqlx::Any>;

/// Opens a write on a cell (see [`CellWrite`]): the first statement of the write's transaction,
/// so the cell's row is held until it commits. Returns the cell's state after the write.
pub(super) async fn touch_cell(
    tx: &mut Tx<'_>,
    cell_id: i64,
    write: CellWrite,
) -> Result<CellState> {
    let state = sqlx::query_as::<_, CellState>(
        "UPDATE cells SET revision = revision + 1, model_version = model_version + $2, \
           reload_revision = CASE WHEN $3 = 1 THEN revision + 1 ELSE reload_revision END \
         WHERE id = $1 AND ($4 IS NULL OR revision = $4) \
         RETURNING id, revision, reload_revision, model_version",
    )
    .bind(cell_id)
    .bind(write.advance)
    .bind(flag(write.reload))
    .bind(write.expected)
    .fetch_optional(&mut **tx)
    .await?;
    if let Some(state) = state {
        // The request's audit row, in the transaction of its change.
        super::audit::record(tx, Some(cell_id)).await?;
        return Ok(state);
    }
    match write.expected {
        Some(expected) => {
            let exists: Option<(i64,)> = sqlx::query_as("SELECT id FROM cells WHERE id = $1")
                .bind(cell_id)
                .fetch_optional(&mut **tx)
                .await?;
            match exists {
                Some(_) => Err(StorageError::Stale {
                    cell: cell_id,
                    expected,
                }),
                None => Err(StorageError::NotFound),
            }
        }
        None => Err(StorageError::NotFound),
    }
}

/// Holds a cell's row until the transaction commits, without advancing its revision: for a
/// change to one of its programs that no model follows (a routine renamed or moved, an
/// unlearned copy added), so that it is serialised with the cell's other writes, as
/// [`touch_cell`] serialises those (a program's revisions are numbered in turn).
pub(super) async fn hold_cell(tx: &mut Tx<'_>, cell_id: i64) -> Result<()> {
    sqlx::query("UPDATE cells SET revision = revision WHERE id = $1")
        .bind(cell_id)
        .execute(&mut **tx)
        .await?;
    Ok(())
}

/// Sets a waypoint's values (bound as [`Binds::waypoint_values`], then its id).
pub(super) const UPDATE_WAYPOINT: &str = "UPDATE waypoints SET x = $1, y = $2, z = $3, qw = $4, \
    qx = $5, qy = $6, qz = $7, joints = $8, motion = $9, name = $10, reachable = $11 WHERE id = $12";

/// Stores a new routine's waypoints, numbered 1, 2, … in order.
pub(super) async fn insert_waypoints(
    tx: &mut Tx<'_>,
    routine_id: i64,
    waypoints: &[WaypointValues],
) -> Result<()> {
    let rows: Vec<NewWaypoint> = (1..)
        .zip(waypoints)
        .map(|(seq, v)| v.at(routine_id, seq))
        .collect();
    inserts::insert_waypoints(tx, &rows).await?;
    Ok(())
}

/// A numbered list: a routine's waypoints (`seq`) or a program's routines (`position`), whose
/// places stay 1, 2, … through every edit.
#[derive(Debug, Clone, Copy)]
pub(super) enum Places {
    /// The waypoints of a routine, by `seq`.
    Waypoints,
    /// The routines of a program, by `position`.
    Routines,
}

/// Makes room at place `at` of `parent`'s list: the places from there on move one down.
pub(super) async fn make_room(tx: &mut Tx<'_>, places: Places, parent: i64, at: i64) -> Result<()> {
    shift(tx, places, parent, at, "+ 1").await
}

/// Closes the gap a row left at place `at` of `parent`'s list: the places after it move one up.
pub(super) async fn close_gap(tx: &mut Tx<'_>, places: Places, parent: i64, at: i64) -> Result<()> {
    shift(tx, places, parent, at + 1, "- 1").await
}

/// Moves the places of `parent`'s list from `from` on by `step` (`+ 1` or `- 1`). Through
/// negative values, since SQLite checks `UNIQUE` per row: first each moved row to minus its
/// new place, then all of them back.
async fn shift(
    tx: &mut Tx<'_>,
    places: Places,
    parent: i64,
    from: i64,
    step: &'static str,
) -> Result<()> {
    let (table, place, parent_column) = match places {
        Places::Waypoints => ("waypoints", "seq", "routine_id"),
        Places::Routines => ("routines", "position", "program_id"),
    };
    let away = format!(
        "UPDATE {table} SET {place} = -({place} {step}) \
         WHERE {parent_column} = $1 AND {place} >= $2"
    );
    sqlx::query(sqlx::AssertSqlSafe(away))
        .bind(parent)
        .bind(from)
        .execute(&mut **tx)
        .await?;
    let back =
        format!("UPDATE {table} SET {place} = -{place} WHERE {parent_column} = $1 AND {place} < 0");
    sqlx::query(sqlx::AssertSqlSafe(back))
        .bind(parent)
        .execute(&mut **tx)
        .await?;
    Ok(())
}
