//! Group commit for appends: one writer task takes the appends queued while it was busy and
//! commits them in one transaction, then answers each. Under load many cells' appends share
//! one commit; alone, an append waits for nothing (the batch is whatever is queued, no timer).
//!
//! An append is answered only once its transaction has committed, so "acknowledged = durable"
//! holds as for any other write. Appends on one cell never share a batch: the service holds the
//! cell's lock until its append is answered, which also keeps their order.
//!
//! A failing statement rolls back the whole batch (PostgreSQL aborts the transaction), so the
//! writer then commits the batch's appends one by one, each with its own answer. A stale cell
//! ([`StorageError::Stale`]) is not a failure: that append is left out and the rest commit.

use sqlx::AnyPool;
use tokio::sync::{mpsc, oneshot};

use super::rows::{NewPrediction, NewWaypoint, WaypointRow};
use super::{CellWrite, Result, StorageError, Tx, insert_prediction, touch_cell};

/// Most appends in one transaction (SQLite and PostgreSQL handle far more; this bounds the
/// latency of the first append of a long queue).
const MAX_BATCH: usize = 256;

/// An append as the service hands it over.
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

/// What a committed append stored.
#[derive(Debug, Clone)]
pub struct Appended {
    pub row: WaypointRow,
    pub prediction_id: Option<i64>,
    /// The cell's revision after the append.
    pub revision: i64,
}

struct Job {
    append: Append,
    reply: oneshot::Sender<Result<Appended>>,
}

/// The handle of the writer task (cheap to clone; the task ends when the last handle goes).
#[derive(Debug, Clone)]
pub(super) struct Writer {
    jobs: mpsc::UnboundedSender<Job>,
}

impl Writer {
    pub(super) fn start(pool: AnyPool) -> Writer {
        let (jobs, queue) = mpsc::unbounded_channel();
        tokio::spawn(run(pool, queue));
        Writer { jobs }
    }

    /// Queues an append and waits until it has committed (or failed).
    pub(super) async fn append(&self, append: Append) -> Result<Appended> {
        let (reply, answer) = oneshot::channel();
        self.jobs
            .send(Job { append, reply })
            .map_err(|_| StorageError::Unavailable("the append writer has stopped".into()))?;
        answer
            .await
            .map_err(|_| StorageError::Unavailable("the append writer has stopped".into()))?
    }
}

async fn run(pool: AnyPool, mut queue: mpsc::UnboundedReceiver<Job>) {
    let mut batch = Vec::with_capacity(MAX_BATCH);
    while let Some(first) = queue.recv().await {
        batch.push(first);
        while batch.len() < MAX_BATCH {
            match queue.try_recv() {
                Ok(job) => batch.push(job),
                Err(_) => break,
            }
        }
        commit(&pool, std::mem::take(&mut batch)).await;
    }
}

/// Commits a batch and answers each of its appends.
async fn commit(pool: &AnyPool, batch: Vec<Job>) {
    if batch.len() > 1 {
        match together(pool, &batch).await {
            Ok(results) => {
                for (job, result) in batch.into_iter().zip(results) {
                    // The caller may have gone away; the append stands all the same.
                    let _ = job.reply.send(result);
                }
                return;
            }
            Err(e) => {
                tracing::debug!(error = %e, size = batch.len(), "batch failed; committing its appends one by one");
            }
        }
    }
    for job in batch {
        let result = alone(pool, &job.append).await;
        let _ = job.reply.send(result);
    }
}

/// The whole batch in one transaction. Err: nothing was committed.
async fn together(pool: &AnyPool, batch: &[Job]) -> Result<Vec<Result<Appended>>> {
    let mut tx = pool.begin().await?;
    let mut results = Vec::with_capacity(batch.len());
    for job in batch {
        match store(&mut tx, &job.append).await {
            Ok(done) => results.push(Ok(done)),
            Err(e @ StorageError::Stale { .. }) => results.push(Err(e)),
            Err(e) => return Err(e),
        }
    }
    tx.commit().await?;
    Ok(results)
}

async fn alone(pool: &AnyPool, append: &Append) -> Result<Appended> {
    let mut tx = pool.begin().await?;
    let done = store(&mut tx, append).await?;
    tx.commit().await?;
    Ok(done)
}

/// One append's statements: the cell's revision checked and advanced, the waypoint, the
/// prediction made after it.
async fn store(tx: &mut Tx<'_>, a: &Append) -> Result<Appended> {
    let state = touch_cell(tx, a.cell_id, CellWrite::following(a.expected_revision)).await?;
    let row = super::insert_waypoint_row(tx, &a.waypoint).await?;
    let prediction_id = match &a.prediction {
        Some(p) => Some(insert_prediction(tx, p, Some(row.id)).await?),
        None => None,
    };
    Ok(Appended {
        row,
        prediction_id,
        revision: state.revision,
    })
}
