//! What an append writes, and one writer per dialect that stores a batch of appends in one
//! transaction ([`sqlite`]: the batch as one script; [`postgres`]: a statement per table over
//! the batch). The group-commit queue ([`super::group_commit`]) hands them their batches; a
//! single append is a batch of one.
//!
//! An append ([`Writes`]) is the waypoints taught at the end of one routine of one cell (one
//! taught waypoint, or a recorded trajectory's), made by the cell's model at a revision of the
//! cell, in one request. It writes, all or nothing:
//!
//! - the cell's revision, advanced once, and only while it is the one the append was made from
//!   (else the append is stale and writes nothing: [`StorageError::Stale`]);
//! - each waypoint, at its place;
//! - the prediction offered after each waypoint, when one was, naming that waypoint;
//! - one revision of the routine's program, whose changes are the waypoints added
//!   ([`super::history`]);
//! - its request's audit row, on the cell ([`super::audit`]).
//!
//! Each table's `INSERT` is rendered once, in [`super::inserts`], for both writers. A batch
//! holds at most one append per cell (the service holds a cell's lock until its append is
//! answered); a statement holds at most [`MAX_ROWS`] waypoints, so an append larger than that
//! (a long trajectory) is a batch of its own, written over several statements.

mod postgres;
mod sqlite;
#[cfg(test)]
mod tests;

use std::collections::HashMap;

use sqlx::AnyPool;

use super::audit::Recorder;
use super::backend::Backend;
use super::error::{Result, StorageError};
use super::history::Change;
use super::rows::{CellState, NewPrediction, NewWaypoint, WaypointRow};

pub(super) use super::inserts::MAX_ROWS;

/// An append as the service hands it over: one taught waypoint.
#[derive(Debug, Clone)]
pub struct Append {
    pub cell_id: i64,
    /// The cell's revision the model in memory was at (the write is refused when the database
    /// has moved on).
    pub expected_revision: i64,
    pub waypoint: NewWaypoint,
    /// The prediction offered after the waypoint, stored with it.
    pub prediction: Option<NewPrediction>,
}

/// What a committed append stored, for each of its waypoints.
#[derive(Debug, Clone)]
pub struct Appended {
    pub row: WaypointRow,
    pub prediction_id: Option<i64>,
    /// The cell's revision after the append.
    pub revision: i64,
    /// How many appends its transaction committed (1: alone).
    pub batch: usize,
}

/// A waypoint taught and the prediction offered after it.
#[derive(Debug, Clone)]
pub(super) struct Taught {
    pub waypoint: NewWaypoint,
    pub prediction: Option<NewPrediction>,
}

/// What one append writes (see the module doc).
#[derive(Debug, Clone)]
pub(super) struct Writes {
    pub cell_id: i64,
    /// The cell's revision the append was made from.
    pub expected_revision: i64,
    /// In order, at the end of their routine.
    pub taught: Vec<Taught>,
    /// The request it is part of, whose audit row goes in with it (None: no request).
    pub audit: Option<Recorder>,
}

impl Writes {
    /// `append`, made in the request `audit`.
    pub(super) fn one(append: Append, audit: Option<Recorder>) -> Writes {
        Writes {
            cell_id: append.cell_id,
            expected_revision: append.expected_revision,
            taught: vec![Taught {
                waypoint: append.waypoint,
                prediction: append.prediction,
            }],
            audit,
        }
    }

    /// The revisions it writes: for each routine it adds to (one, in practice), the routine and
    /// its changes as a JSON array.
    pub(super) fn revisions(&self) -> Result<Vec<(i64, String)>> {
        let mut by_routine: Vec<(i64, Vec<Change>)> = Vec::new();
        for t in &self.taught {
            let w = &t.waypoint;
            let added = Change::WaypointAdded {
                routine: w.routine_id,
                seq: w.seq,
            };
            match by_routine.iter_mut().find(|(r, _)| *r == w.routine_id) {
                Some((_, changes)) => changes.push(added),
                None => by_routine.push((w.routine_id, vec![added])),
            }
        }
        by_routine
            .into_iter()
            .map(|(routine, changes)| {
                let json = serde_json::to_string(&changes).map_err(|e| {
                    StorageError::History(format!("a change could not be written: {e}"))
                })?;
                Ok((routine, json))
            })
            .collect()
    }

    /// The values of its request's audit row, or all None.
    pub(super) fn who(&self) -> [Option<String>; 5] {
        self.audit
            .as_ref()
            .map_or([None, None, None, None, None], Recorder::values)
    }
}

/// What a writer stored for a batch.
#[derive(Debug, Default)]
pub(super) struct Written {
    /// The state after the write of each cell that was at the revision expected (the others'
    /// appends are stale and wrote nothing).
    pub cells: HashMap<i64, CellState>,
    /// The waypoints stored, by (routine, seq).
    pub waypoints: HashMap<(i64, i64), WaypointRow>,
    /// The ids of the predictions stored, by the waypoint they were made after.
    pub predictions: HashMap<i64, i64>,
}

/// Stores a batch in one transaction on `backend`'s dialect, answering each append (stale
/// ones: [`StorageError::Stale`]). Err: nothing was committed.
pub(super) async fn write(
    pool: &AnyPool,
    backend: Backend,
    batch: &[&Writes],
) -> Result<Vec<Result<Vec<Appended>>>> {
    let written = match backend {
        Backend::Sqlite => sqlite::write(pool, batch).await?,
        Backend::Postgres => postgres::write(pool, batch).await?,
    };
    for w in batch {
        if let Some(r) = &w.audit
            && written.cells.contains_key(&w.cell_id)
        {
            r.mark_recorded();
        }
    }
    Ok(answers(batch, written))
}

/// Each append's answer from what its batch stored.
fn answers(batch: &[&Writes], mut written: Written) -> Vec<Result<Vec<Appended>>> {
    batch
        .iter()
        .map(|w| {
            let Some(state) = written.cells.get(&w.cell_id) else {
                return Err(StorageError::Stale {
                    cell: w.cell_id,
                    expected: w.expected_revision,
                });
            };
            w.taught
                .iter()
                .map(|t| {
                    let key = (t.waypoint.routine_id, t.waypoint.seq);
                    let row = written.waypoints.remove(&key).ok_or_else(|| {
                        StorageError::Unavailable("a batched waypoint went missing".into())
                    })?;
                    let prediction_id = match t.prediction {
                        Some(_) => Some(written.predictions.remove(&row.id).ok_or_else(|| {
                            StorageError::Unavailable("a batched prediction went missing".into())
                        })?),
                        None => None,
                    };
                    Ok(Appended {
                        row,
                        prediction_id,
                        revision: state.revision,
                        batch: batch.len(),
                    })
                })
                .collect()
        })
        .collect()
}
