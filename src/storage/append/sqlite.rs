//! The append writer on SQLite: a batch as one script sent to the connection's thread once
//! (each statement is a wake-up of that thread and of the writer: under load, those hops, not
//! the database, made the tail). Between `BEGIN IMMEDIATE` and `COMMIT`, each waypoint, its
//! prediction, its program's revision and its request's audit row are inserted only while its
//! cell is at the revision its append was made from; then those cells' revisions advance. The
//! rows the script answers say which statement returned them (a `returned` column).
//!
//! The script is built for a power-of-two number of waypoints and of appends, the spare ones
//! empty (cell 0 does not exist): a handful of statement shapes, each prepared once per
//! connection and kept. An append of more than [`MAX_ROWS`] waypoints (alone in its batch) is
//! sent as several scripts in the one transaction: the last advances the cell.

use futures_util::TryStreamExt;
use sqlx::pool::PoolConnection;
use sqlx::{Any, AnyPool, FromRow, Row};

use super::{MAX_ROWS, Taught, Writes, Written};
use crate::engine::{Pose, PoseValues};
use crate::storage::error::{Result, StorageError, classify};
use crate::storage::inserts::{AuditRows, PredictionRows, RevisionRows, WaypointRows, Who};
use crate::storage::rows::{CellState, NewPrediction, NewWaypoint, Stored, WaypointRow};
use crate::storage::slots::{Params, Slot};

/// The tags of the script's rows (its `returned` column).
const WAYPOINT: &str = "waypoint";
const PREDICTION: &str = "prediction";
const CELL: &str = "cell";

/// Writes `batch`. Err: nothing was committed.
pub(super) async fn write(pool: &AnyPool, batch: &[&Writes]) -> Result<Written> {
    let rows: Vec<(&Writes, &Taught)> = batch
        .iter()
        .flat_map(|w| w.taught.iter().map(move |t| (*w, t)))
        .collect();
    let chunks: Vec<&[(&Writes, &Taught)]> = rows.chunks(MAX_ROWS).collect();
    let mut conn = pool.acquire().await?;
    let mut written = Written::default();
    let mut outcome = Ok(());
    for (i, chunk) in chunks.iter().enumerate() {
        let last = i + 1 == chunks.len();
        outcome = match script(chunk, i == 0, last.then_some(batch)) {
            Ok(script) => run(&mut conn, script, &mut written).await,
            Err(e) => Err(e),
        };
        if outcome.is_err() {
            break;
        }
    }
    if let Err(e) = outcome {
        // A script stopped part-way: whatever the transaction began is taken back on this
        // connection.
        let _ = sqlx::query("ROLLBACK").execute(&mut *conn).await;
        return Err(e);
    }
    Ok(written)
}

/// A script and its values.
struct Script {
    sql: String,
    params: Params,
}

/// The script of `rows` (the waypoints of the batch's appends, or some of them), opening the
/// transaction when `begin`, and with `tail` (the batch's appends) their revisions, audit rows
/// and cells, closing it.
fn script(rows: &[(&Writes, &Taught)], begin: bool, tail: Option<&[&Writes]>) -> Result<Script> {
    let empty = empty_writes();
    let mut params = Params::default();
    let mut waypoints = WaypointRows::default();
    let mut predictions = PredictionRows::default();
    for i in 0..rows.len().next_power_of_two() {
        let (w, t) = rows.get(i).copied().unwrap_or((&empty, &empty.taught[0]));
        let (_, fresh) = guard(&mut params, w);
        waypoints.push(&mut params, &t.waypoint, &fresh);
        // Every row has its prediction's values, placeholders when it has none (the SQL then
        // depends on the number of rows only).
        let (has, pr) = match &t.prediction {
            Some(pr) => (1, pr.clone()),
            None => (0, placeholder_prediction(w.cell_id, &t.waypoint)),
        };
        let has = params.push(has);
        let routine = params.push(t.waypoint.routine_id);
        let seq = params.push(t.waypoint.seq);
        let after =
            format!("(SELECT id FROM waypoints WHERE routine_id = {routine} AND seq = {seq})");
        predictions.push(&mut params, &pr, &after, &format!("{fresh} AND {has} = 1"));
    }
    let mut sql = String::new();
    if begin {
        sql.push_str("BEGIN IMMEDIATE; ");
    }
    sql.push_str(&waypoints.sql(&format!(
        "'{WAYPOINT}' AS returned, {}",
        WaypointRow::COLUMNS
    )));
    sql.push_str("; ");
    sql.push_str(&predictions.sql(&format!(
        "'{PREDICTION}' AS returned, id, after_waypoint_id"
    )));
    sql.push_str("; ");
    if let Some(appends) = tail {
        sql.push_str(&close(&mut params, appends, &empty)?);
    }
    Ok(Script { sql, params })
}

/// The end of a batch's last script: each append's revisions and audit row, while its cell is
/// at the revision expected, then those cells' revisions advanced, and `COMMIT`.
fn close(params: &mut Params, appends: &[&Writes], empty: &Writes) -> Result<String> {
    let mut revisions = RevisionRows::default();
    let mut audit = AuditRows::default();
    let mut cells = Vec::new();
    for i in 0..appends.len().next_power_of_two() {
        let w = appends.get(i).copied().unwrap_or(empty);
        let (cell, fresh) = guard(params, w);
        let [token, request_id, operation, target, key] = w.who();
        let who = Who::bind(params, [token, request_id, operation]);
        for (routine, changes) in w.revisions()? {
            let routine = params.push(routine);
            let changes = params.push(changes);
            let program = format!("(SELECT program_id FROM routines WHERE id = {routine})");
            revisions.push(&program, &who, changes, &fresh);
        }
        let named = [params.push(target), params.push(key)];
        audit.push(
            &who,
            named,
            cell,
            &format!("{fresh} AND {} IS NOT NULL", named[1]),
        );
        let revision = params.push(w.expected_revision);
        cells.push(format!("(id = {cell} AND revision = {revision})"));
    }
    Ok(format!(
        "{}; {}; UPDATE cells SET revision = revision + 1 WHERE {} \
         RETURNING '{CELL}' AS returned, {}; COMMIT;",
        revisions.sql(""),
        audit.sql(),
        cells.join(" OR "),
        CellState::COLUMNS
    ))
}

/// Binds `w`'s cell and the revision it was made from; answers the cell's slot and the
/// condition that the cell is still at that revision.
fn guard(params: &mut Params, w: &Writes) -> (Slot, String) {
    let cell = params.push(w.cell_id);
    let revision = params.push(w.expected_revision);
    (
        cell,
        format!("FROM cells WHERE id = {cell} AND revision = {revision}"),
    )
}

/// Runs a script, keeping what its rows say in `written`.
async fn run(conn: &mut PoolConnection<Any>, script: Script, written: &mut Written) -> Result<()> {
    let q = script.params.query(script.sql)?;
    let mut results = q.fetch(&mut **conn);
    while let Some(row) = results.try_next().await.map_err(classify)? {
        let returned: String = row.try_get("returned")?;
        match returned.as_str() {
            WAYPOINT => {
                let w = WaypointRow::from_row(&row)?;
                written.waypoints.insert((w.routine_id, w.seq), w);
            }
            PREDICTION => {
                written
                    .predictions
                    .insert(row.try_get("after_waypoint_id")?, row.try_get("id")?);
            }
            CELL => {
                let s = CellState::from_row(&row)?;
                written.cells.insert(s.id, s);
            }
            other => {
                return Err(StorageError::Database(sqlx::Error::Protocol(format!(
                    "the batch script returned a row of {other:?}"
                ))));
            }
        }
    }
    Ok(())
}

/// What fills a spare slot of a script: an append to no cell (ids start at 1), never stored.
fn empty_writes() -> Writes {
    Writes {
        cell_id: 0,
        expected_revision: -1,
        taught: vec![Taught {
            waypoint: NewWaypoint {
                routine_id: 0,
                seq: 0,
                pose: PoseValues::from(&Pose::identity()),
                joints: None,
                motion: None,
                name: None,
                reachable: None,
            },
            prediction: None,
        }],
        audit: None,
    }
}

/// The values bound for a waypoint without a prediction (not inserted: its flag is 0).
fn placeholder_prediction(cell_id: i64, w: &NewWaypoint) -> NewPrediction {
    NewPrediction {
        cell_id,
        routine_id: w.routine_id,
        after_seq: w.seq,
        pose: w.pose,
        phi: 0.0,
        psi: 1.0,
        misfit: None,
        end_probability: 0.0,
        model_version: 0,
    }
}
