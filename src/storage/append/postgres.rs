//! The append writer on PostgreSQL: a batch in one transaction of one statement per table,
//! whatever its size: the cells' revisions checked and advanced (first, so that their rows are
//! held until the commit, across instances), then the fresh appends' waypoints, their
//! predictions, their programs' revisions and their audit rows.

use std::collections::HashMap;

use sqlx::AnyPool;

use super::{Writes, Written};
use crate::storage::error::{Result, StorageError};
use crate::storage::inserts::{self, AuditRows, RevisionRows, Who};
use crate::storage::rows::{CellState, NewPrediction, NewWaypoint, Stored};
use crate::storage::slots::Params;
use crate::storage::transaction::Tx;

/// Writes `batch`. Err: nothing was committed.
pub(super) async fn write(pool: &AnyPool, batch: &[&Writes]) -> Result<Written> {
    let mut tx = pool.begin().await?;
    let cells = advance_cells(&mut tx, batch).await?;
    let fresh: Vec<&Writes> = batch
        .iter()
        .copied()
        .filter(|w| cells.contains_key(&w.cell_id))
        .collect();
    let new: Vec<NewWaypoint> = fresh
        .iter()
        .flat_map(|w| w.taught.iter().map(|t| t.waypoint.clone()))
        .collect();
    let stored = inserts::insert_waypoints(&mut tx, &new).await?;
    let made_after: Vec<(&NewPrediction, Option<i64>)> = fresh
        .iter()
        .flat_map(|w| &w.taught)
        .zip(&stored)
        .filter_map(|(t, row)| Some((t.prediction.as_ref()?, Some(row.id))))
        .collect();
    let predictions = inserts::insert_predictions(&mut tx, &made_after).await?;
    record(&mut tx, &fresh).await?;
    tx.commit().await?;
    Ok(Written {
        cells,
        waypoints: stored
            .into_iter()
            .map(|r| ((r.routine_id, r.seq), r))
            .collect(),
        predictions: predictions
            .into_iter()
            .filter_map(|(id, after)| Some((after?, id)))
            .collect(),
    })
}

/// The programs' revisions and the audit rows of the fresh appends.
async fn record(tx: &mut Tx<'_>, fresh: &[&Writes]) -> Result<()> {
    let mut params = Params::default();
    let mut revisions = RevisionRows::default();
    let mut audit = AuditRows::default();
    for w in fresh {
        let [token, request_id, operation, target, key] = w.who();
        let who = Who::bind(&mut params, [token, request_id, operation]);
        for (routine, changes) in w.revisions()? {
            let routine = params.push(routine);
            let changes = params.push(changes);
            let program = format!("(SELECT program_id FROM routines WHERE id = {routine})");
            revisions.push(&program, &who, changes, "");
        }
        if w.audit.is_some() {
            let named = [params.push(target), params.push(key)];
            let cell = params.push(w.cell_id);
            audit.push(&who, named, cell, "");
        }
    }
    if fresh.is_empty() {
        return Ok(());
    }
    let audited = fresh.iter().any(|w| w.audit.is_some());
    let sql = match audited {
        true => format!(
            "WITH revisions AS ({}) {}",
            revisions.sql("program_id"),
            audit.sql()
        ),
        false => revisions.sql(""),
    };
    params.query(sql)?.execute(&mut **tx).await?;
    Ok(())
}

/// Advances the revision of each append's cell that is still at the revision the append was
/// made from; returns the states of those cells (the others are stale). A cell that does not
/// exist any more is an error for the whole batch (committed one by one, it gets its 404).
async fn advance_cells(tx: &mut Tx<'_>, batch: &[&Writes]) -> Result<HashMap<i64, CellState>> {
    let mut params = Params::default();
    let terms: Vec<String> = batch
        .iter()
        .map(|w| {
            let cell = params.push(w.cell_id);
            let revision = params.push(w.expected_revision);
            format!("(id = {cell} AND revision = {revision})")
        })
        .collect();
    let sql = format!(
        "UPDATE cells SET revision = revision + 1 WHERE {} RETURNING {}",
        terms.join(" OR "),
        CellState::COLUMNS
    );
    let states: HashMap<i64, CellState> = params
        .query_as::<CellState>(sql)?
        .fetch_all(&mut **tx)
        .await?
        .into_iter()
        .map(|s| (s.id, s))
        .collect();
    if states.len() < batch.len() {
        let mut params = Params::default();
        let missing = params.run(|p| {
            for w in batch.iter().filter(|w| !states.contains_key(&w.cell_id)) {
                p.push(w.cell_id);
            }
        });
        let sql = format!("SELECT COUNT(*) FROM cells WHERE id IN ({missing})");
        let (present,): (i64,) = params.query_as(sql)?.fetch_one(&mut **tx).await?;
        if present < missing.count() as i64 {
            return Err(StorageError::NotFound);
        }
    }
    Ok(states)
}
