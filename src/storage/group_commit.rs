//! Group commit for appends: one writer task takes the appends queued while it was busy and
//! commits them in one transaction, then answers each. Under load many cells' appends share
//! one commit; alone, an append waits for nothing (the batch is whatever is queued, no timer).
//!
//! An append is answered only once its transaction has committed, so "acknowledged = durable"
//! holds as for any other write. Appends on one cell never share a batch: the service holds the
//! cell's lock until its append is answered, which also keeps their order.
//!
//! What an append writes, and how each dialect writes a batch, is [`super::append`]'s. A
//! failing statement rolls back the whole batch (PostgreSQL aborts the transaction), so the
//! queue then commits the batch's appends one by one, each a batch of one with its own answer.
//! A stale cell ([`StorageError::Stale`]) is not a failure: that append is left out and the
//! rest commit.

use sqlx::AnyPool;
use tokio::sync::{mpsc, oneshot};

use super::append::{self, Append, Appended, MAX_ROWS, Taught, Writes};
use super::audit::Recorder;
use super::backend::Backend;
use super::error::{Result, StorageError};
use super::rows::{NewPrediction, NewWaypoint};

/// Most appends in one transaction: bounds the latency of the first append of a long queue and,
/// with the waypoints of a batch bounded by [`MAX_ROWS`] likewise, the number of statement
/// shapes (one per power of two up to it) each connection prepares and keeps.
const MAX_BATCH: usize = 64;

struct Job {
    writes: Writes,
    reply: oneshot::Sender<Result<Vec<Appended>>>,
}

/// The handle of the writer task (cheap to clone; the task ends when the last handle goes).
#[derive(Debug, Clone)]
pub(super) struct Writer {
    jobs: mpsc::UnboundedSender<Job>,
}

impl Writer {
    pub(super) fn start(pool: AnyPool, backend: Backend) -> Writer {
        let (jobs, queue) = mpsc::unbounded_channel();
        tokio::spawn(run(pool, backend, queue));
        Writer { jobs }
    }

    /// Queues one taught waypoint and waits until it has committed (or failed).
    pub(super) async fn append(&self, append: Append) -> Result<Appended> {
        let mut done = self.queue(Writes::one(append, Recorder::current())).await?;
        done.pop()
            .ok_or_else(|| StorageError::Unavailable("an append went missing".into()))
    }

    /// Queues several waypoints taught at once to a routine of `cell_id` (a trajectory), each
    /// with the prediction offered after it, as one append: all or nothing, the cell's revision
    /// advanced once.
    pub(super) async fn append_all(
        &self,
        cell_id: i64,
        expected_revision: i64,
        taught: &[(NewWaypoint, Option<NewPrediction>)],
    ) -> Result<Vec<Appended>> {
        if taught.is_empty() {
            return Ok(Vec::new());
        }
        self.queue(Writes {
            cell_id,
            expected_revision,
            taught: taught
                .iter()
                .map(|(waypoint, prediction)| Taught {
                    waypoint: waypoint.clone(),
                    prediction: prediction.clone(),
                })
                .collect(),
            audit: Recorder::current(),
        })
        .await
    }

    async fn queue(&self, writes: Writes) -> Result<Vec<Appended>> {
        let (reply, answer) = oneshot::channel();
        self.jobs
            .send(Job { writes, reply })
            .map_err(|_| StorageError::Unavailable("the append writer has stopped".into()))?;
        answer
            .await
            .map_err(|_| StorageError::Unavailable("the append writer has stopped".into()))?
    }
}

async fn run(pool: AnyPool, backend: Backend, mut queue: mpsc::UnboundedReceiver<Job>) {
    // A job taken from the queue that did not fit the last batch: it opens the next.
    let mut next: Option<Job> = None;
    loop {
        let first = match next.take() {
            Some(job) => job,
            None => match queue.recv().await {
                Some(job) => job,
                None => return,
            },
        };
        let mut rows = first.writes.taught.len();
        let mut batch = vec![first];
        while batch.len() < MAX_BATCH {
            let Ok(job) = queue.try_recv() else { break };
            if rows + job.writes.taught.len() > MAX_ROWS {
                next = Some(job);
                break;
            }
            rows += job.writes.taught.len();
            batch.push(job);
        }
        commit(&pool, backend, batch).await;
    }
}

/// Commits a batch and answers each of its appends; when it fails, each of them alone.
async fn commit(pool: &AnyPool, backend: Backend, batch: Vec<Job>) {
    let answers = {
        let writes: Vec<&Writes> = batch.iter().map(|j| &j.writes).collect();
        match append::write(pool, backend, &writes).await {
            Ok(answers) => answers,
            Err(e) if writes.len() == 1 => vec![Err(e)],
            Err(e) => {
                tracing::debug!(error = %e, size = writes.len(), "batch failed; committing its appends one by one");
                let mut answers = Vec::with_capacity(writes.len());
                for w in writes {
                    answers.push(match append::write(pool, backend, &[w]).await {
                        Ok(mut one) => one.pop().unwrap_or_else(|| {
                            Err(StorageError::Unavailable("an append went missing".into()))
                        }),
                        Err(e) => Err(e),
                    });
                }
                answers
            }
        }
    };
    for (job, answer) in batch.into_iter().zip(answers) {
        // The caller may have gone away; the append stands all the same.
        let _ = job.reply.send(answer);
    }
}
