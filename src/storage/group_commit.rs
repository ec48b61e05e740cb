//! Group commit for appends: one writer task takes the appends queued while it was busy and
//! commits them in one transaction, then answers each. Under load many cells' appends share
//! one commit; alone, an append waits for nothing (the batch is whatever is queued, no timer).
//!
//! An append is answered only once its transaction has committed, so "acknowledged = durable"
//! holds as for any other write. Appends on one cell never share a batch: the service holds the
//! cell's lock until its append is answered, which also keeps their order.
//!
//! Whatever its size, a batch is one script on SQLite ([`in_one_trip`]: one wake-up of the
//! connection's thread) and three multi-row statements on PostgreSQL ([`together`]: the cells'
//! revisions, the waypoints, the predictions). Both are built to the batch's size with named
//! parameter slots ([`super::slots`]): each value is bound where the SQL names it, so nothing
//! counts positions; the script's rows say which of its statements returned them (a `returned`
//! column). Each append's audit row ([`super::audit`]) and its program's revision
//! ([`super::history`]) go in with it. A failing statement rolls back the whole batch (PostgreSQL aborts the transaction),
//! so the writer then commits the batch's appends one by one, each with its own answer. A stale cell ([`StorageError::Stale`]) is not a failure: that
//! append is left out and the rest commit.

use sqlx::AnyPool;
use tokio::sync::{mpsc, oneshot};

use std::collections::HashMap;

use super::audit::Recorder;
use super::backend::Backend;
use super::binds::Binds;
use super::cell_write::CellWrite;
use super::error::{Result, StorageError, classify};
use super::history;
use super::rows::{CellState, NewPrediction, NewWaypoint, Stored, WaypointRow};
use super::slots::{Params, Run, Slot};
use super::transaction::{Tx, insert_prediction, insert_waypoint, touch_cell};
use crate::engine::{Pose, PoseValues};

/// Most appends in one transaction: bounds the latency of the first append of a long queue and
/// the number of statement shapes (one per power of two up to it) each connection prepares
/// and keeps.
const MAX_BATCH: usize = 64;

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
    /// How many appends its transaction committed (1: alone).
    pub batch: usize,
}

struct Job {
    append: Append,
    /// The request it is part of, whose audit row goes in with it.
    audit: Option<Recorder>,
    reply: oneshot::Sender<Result<Appended>>,
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

    /// Queues an append and waits until it has committed (or failed).
    pub(super) async fn append(&self, append: Append) -> Result<Appended> {
        let (reply, answer) = oneshot::channel();
        self.jobs
            .send(Job {
                append,
                audit: Recorder::current(),
                reply,
            })
            .map_err(|_| StorageError::Unavailable("the append writer has stopped".into()))?;
        answer
            .await
            .map_err(|_| StorageError::Unavailable("the append writer has stopped".into()))?
    }
}

async fn run(pool: AnyPool, backend: Backend, mut queue: mpsc::UnboundedReceiver<Job>) {
    let mut batch = Vec::with_capacity(MAX_BATCH);
    while let Some(first) = queue.recv().await {
        batch.push(first);
        while batch.len() < MAX_BATCH {
            match queue.try_recv() {
                Ok(job) => batch.push(job),
                Err(_) => break,
            }
        }
        commit(&pool, backend, std::mem::take(&mut batch)).await;
    }
}

/// Commits a batch and answers each of its appends. (On SQLite a lone append takes the
/// one-trip script too: the fewest hops is what its latency is made of.)
async fn commit(pool: &AnyPool, backend: Backend, batch: Vec<Job>) {
    if batch.len() > 1 || backend == Backend::Sqlite {
        let done = match backend {
            Backend::Sqlite => in_one_trip(pool, &batch).await,
            Backend::Postgres => together(pool, &batch).await,
        };
        match done {
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
        let result = alone(pool, &job).await;
        let _ = job.reply.send(result);
    }
}

/// The whole batch in one transaction of three statements, whatever its size: the cells'
/// revisions checked and advanced, the waypoints, the predictions. Err: nothing was committed.
async fn together(pool: &AnyPool, batch: &[Job]) -> Result<Vec<Result<Appended>>> {
    let appends: Vec<&Append> = batch.iter().map(|j| &j.append).collect();
    let mut tx = pool.begin().await?;
    let states = advance_cells(&mut tx, &appends).await?;
    let fresh: Vec<&Append> = appends
        .iter()
        .copied()
        .filter(|a| states.contains_key(&a.cell_id))
        .collect();
    let rows = insert_waypoint_rows(&mut tx, &fresh).await?;
    let with_prediction: Vec<(&NewPrediction, i64)> = fresh
        .iter()
        .filter_map(|a| {
            let row = rows.get(&(a.waypoint.routine_id, a.waypoint.seq))?;
            Some((a.prediction.as_ref()?, row.id))
        })
        .collect();
    let predictions = insert_prediction_rows(&mut tx, &with_prediction).await?;
    for job in batch {
        if !states.contains_key(&job.append.cell_id) {
            continue;
        }
        let w = &job.append.waypoint;
        history::record_taught(&mut tx, w.routine_id, w.seq, job.audit.as_ref()).await?;
        if let Some(r) = &job.audit {
            r.record(&mut tx, Some(job.append.cell_id)).await?;
        }
    }
    tx.commit().await?;
    Ok(answers(&appends, &states, rows, predictions))
}

/// Each append's answer from what the batch stored.
fn answers(
    appends: &[&Append],
    states: &HashMap<i64, CellState>,
    mut rows: HashMap<(i64, i64), WaypointRow>,
    mut predictions: HashMap<i64, i64>,
) -> Vec<Result<Appended>> {
    appends
        .iter()
        .map(|a| {
            let Some(state) = states.get(&a.cell_id) else {
                return Err(StorageError::Stale {
                    cell: a.cell_id,
                    expected: a.expected_revision,
                });
            };
            let row = rows
                .remove(&(a.waypoint.routine_id, a.waypoint.seq))
                .ok_or_else(|| {
                    StorageError::Unavailable("a batched waypoint went missing".into())
                })?;
            let prediction_id = match a.prediction {
                Some(_) => Some(predictions.remove(&row.id).ok_or_else(|| {
                    StorageError::Unavailable("a batched prediction went missing".into())
                })?),
                None => None,
            };
            Ok(Appended {
                row,
                prediction_id,
                revision: state.revision,
                batch: appends.len(),
            })
        })
        .collect()
}

/// SQLite: the whole batch as one script sent to the connection's thread once (each
/// statement is a wake-up of that thread and of the writer: under load, those hops, not the
/// database, made the tail). Each waypoint and prediction is inserted only if its cell is
/// still at the revision its append was made from, then those cells' revisions advance, all
/// between `BEGIN IMMEDIATE` and `COMMIT`. Err: nothing was committed.
async fn in_one_trip(pool: &AnyPool, batch: &[Job]) -> Result<Vec<Result<Appended>>> {
    use futures_util::TryStreamExt;
    use sqlx::{FromRow, Row};

    let appends: Vec<&Append> = batch.iter().map(|j| &j.append).collect();
    // Slots for a power-of-two number of appends, the spare ones empty (cell 0 does not
    // exist): a handful of statement shapes, each prepared once per connection and kept.
    let slots = appends.len().next_power_of_two();
    let empty = empty_append();
    let filled: Vec<&Append> = (0..slots)
        .map(|i| appends.get(i).copied().unwrap_or(&empty))
        .collect();
    let mut params = Params::default();
    let waypoints: Vec<WaypointSlots> = filled
        .iter()
        .map(|a| WaypointSlots::bind(&mut params, a))
        .collect();
    // Each append's prediction after all the waypoints, whether it has one or not (the SQL
    // then depends on the batch's size only, so it is prepared once per size).
    let predictions: Vec<PredictionSlots> = filled
        .iter()
        .map(|a| PredictionSlots::bind(&mut params, a))
        .collect();

    // Each append's rows are inserted only while its cell is at the revision expected.
    let fresh = |w: &WaypointSlots| {
        format!(
            "FROM cells WHERE id = {} AND revision = {}",
            w.cell, w.revision
        )
    };
    let waypoint_rows: Vec<String> = waypoints
        .iter()
        .map(|w| format!("SELECT {}, {}, {} {}", w.routine, w.seq, w.values, fresh(w)))
        .collect();
    let prediction_rows: Vec<String> = waypoints
        .iter()
        .zip(&predictions)
        .map(|(w, p)| {
            format!(
                "SELECT {cell}, {routine}, {after_seq}, \
                   (SELECT id FROM waypoints WHERE routine_id = {routine} AND seq = {seq}), \
                   {values} {from} AND {has} = 1",
                cell = w.cell,
                routine = w.routine,
                seq = w.seq,
                after_seq = p.after_seq,
                values = p.values,
                has = p.has,
                from = fresh(w),
            )
        })
        .collect();
    // The requests' audit rows, all in one parameter (a JSON array: binding is per parameter,
    // and a batch has many), each kept only while its cell is at the revision expected, and
    // when its request has no row already.
    let audit = params.push(audit_json(batch));
    // And the programs' revisions, likewise (each append is one of its program's).
    let revisions = params.push(revisions_json(batch));
    let cells: Vec<String> = waypoints
        .iter()
        .map(|w| format!("(id = {} AND revision = {})", w.cell, w.revision))
        .collect();
    // Every row the script answers with says first which statement returned it.
    let sql = format!(
        "BEGIN IMMEDIATE; \
         INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
           reachable) {waypoints} RETURNING '{WAYPOINT}' AS returned, {columns}; \
         INSERT INTO predictions (cell_id, routine_id, after_seq, after_waypoint_id, x, y, z, \
           qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version) {predictions} \
           RETURNING '{PREDICTION}' AS returned, id, after_waypoint_id; \
         INSERT OR IGNORE INTO audit (token, request_id, operation, target, cell_id, outcome, \
           request_key) \
           SELECT json_extract(a.value, '$.token'), json_extract(a.value, '$.request_id'), \
             json_extract(a.value, '$.operation'), json_extract(a.value, '$.target'), c.id, 'ok', \
             json_extract(a.value, '$.key') \
           FROM json_each({audit}) a JOIN cells c ON c.id = json_extract(a.value, '$.cell') \
             AND c.revision = json_extract(a.value, '$.revision'); \
         INSERT INTO program_history (program_id, revision, token, request_id, operation, \
           changes) \
           SELECT r.program_id, \
             (SELECT COALESCE(MAX(h.revision), 0) + 1 FROM program_history h \
              WHERE h.program_id = r.program_id), \
             json_extract(a.value, '$.token'), json_extract(a.value, '$.request_id'), \
             json_extract(a.value, '$.operation'), json_extract(a.value, '$.changes') \
           FROM json_each({revisions}) a JOIN cells c ON c.id = json_extract(a.value, '$.cell') \
             AND c.revision = json_extract(a.value, '$.revision') \
             JOIN routines r ON r.id = json_extract(a.value, '$.routine'); \
         UPDATE cells SET revision = revision + 1 WHERE {cells} \
           RETURNING '{CELL}' AS returned, {state}; \
         COMMIT;",
        waypoints = waypoint_rows.join(" UNION ALL "),
        columns = WaypointRow::COLUMNS,
        predictions = prediction_rows.join(" UNION ALL "),
        cells = cells.join(" OR "),
        state = CellState::COLUMNS,
    );
    let q = params.query(sql)?;

    let mut conn = pool.acquire().await?;
    let mut rows: HashMap<(i64, i64), WaypointRow> = HashMap::new();
    let mut predictions: HashMap<i64, i64> = HashMap::new();
    let mut states: HashMap<i64, CellState> = HashMap::new();
    let outcome: std::result::Result<(), sqlx::Error> = async {
        let mut results = q.fetch(&mut *conn);
        while let Some(row) = results.try_next().await? {
            let returned: String = row.try_get("returned")?;
            match returned.as_str() {
                WAYPOINT => {
                    let w = WaypointRow::from_row(&row)?;
                    rows.insert((w.routine_id, w.seq), w);
                }
                PREDICTION => {
                    predictions.insert(row.try_get("after_waypoint_id")?, row.try_get("id")?);
                }
                CELL => {
                    let s = CellState::from_row(&row)?;
                    states.insert(s.id, s);
                }
                other => {
                    return Err(sqlx::Error::Protocol(format!(
                        "the batch script returned a row of {other:?}"
                    )));
                }
            }
        }
        Ok(())
    }
    .await;
    if let Err(e) = outcome {
        // The script stopped part-way: whatever it began is taken back on this connection.
        let _ = sqlx::query("ROLLBACK").execute(&mut *conn).await;
        return Err(classify(e));
    }
    for job in batch {
        if let Some(r) = &job.audit
            && states.contains_key(&job.append.cell_id)
        {
            r.mark_recorded();
        }
    }
    Ok(answers(&appends, &states, rows, predictions))
}

/// The audit rows of a batch's appends made in a request, as one JSON array.
fn audit_json(batch: &[Job]) -> String {
    let rows: Vec<serde_json::Value> = batch
        .iter()
        .filter_map(|job| {
            let [token, request_id, operation, target, key] = job.audit.as_ref()?.values();
            Some(serde_json::json!({
                "cell": job.append.cell_id,
                "revision": job.append.expected_revision,
                "token": token,
                "request_id": request_id,
                "operation": operation,
                "target": target,
                "key": key,
            }))
        })
        .collect();
    serde_json::Value::Array(rows).to_string()
}

/// The programs' revisions of a batch's appends (each the waypoint added, by whom), as one
/// JSON array: each entry names its cell and the revision its append was made at (it is
/// written only while the cell is at it), its routine, who, and its changes (a JSON text).
fn revisions_json(batch: &[Job]) -> String {
    let rows: Vec<serde_json::Value> = batch
        .iter()
        .map(|job| {
            let a = &job.append;
            let [token, request_id, operation] = Recorder::who(job.audit.as_ref());
            let added = history::Change::WaypointAdded {
                routine: a.waypoint.routine_id,
                seq: a.waypoint.seq,
            };
            serde_json::json!({
                "cell": a.cell_id,
                "revision": a.expected_revision,
                "routine": a.waypoint.routine_id,
                "token": token,
                "request_id": request_id,
                "operation": operation,
                "changes": serde_json::json!([added]).to_string(),
            })
        })
        .collect();
    serde_json::Value::Array(rows).to_string()
}

/// The tags of the script's rows (its `returned` column).
const WAYPOINT: &str = "waypoint";
const PREDICTION: &str = "prediction";
const CELL: &str = "cell";

/// Where an append's waypoint and cell check are bound in the script.
struct WaypointSlots {
    routine: Slot,
    seq: Slot,
    /// `x` to `reachable`, as in [`Binds::waypoint_values`].
    values: Run,
    cell: Slot,
    revision: Slot,
}

impl WaypointSlots {
    fn bind(params: &mut Params, a: &Append) -> WaypointSlots {
        let w = &a.waypoint;
        let routine = params.push(w.routine_id);
        let seq = params.push(w.seq);
        let values = params.run(|p| {
            p.waypoint_values(&w.pose, &w.joints, &w.motion, &w.name, w.reachable);
        });
        let cell = params.push(a.cell_id);
        let revision = params.push(a.expected_revision);
        WaypointSlots {
            routine,
            seq,
            values,
            cell,
            revision,
        }
    }
}

/// Where an append's prediction is bound in the script (placeholder values when it has none).
struct PredictionSlots {
    /// 1 when the append has a prediction to store, else 0.
    has: Slot,
    after_seq: Slot,
    /// `x` to `model_version`, as in [`Binds::prediction_values`].
    values: Run,
}

impl PredictionSlots {
    fn bind(params: &mut Params, a: &Append) -> PredictionSlots {
        let (has, pr) = match &a.prediction {
            Some(pr) => (1, pr.clone()),
            None => (0, placeholder_prediction(a)),
        };
        let has = params.push(has);
        let after_seq = params.push(pr.after_seq);
        let values = params.run(|p| {
            p.prediction_values(&pr);
        });
        PredictionSlots {
            has,
            after_seq,
            values,
        }
    }
}

/// What fills a spare slot of a batch: an append to no cell (ids start at 1), never stored.
fn empty_append() -> Append {
    Append {
        cell_id: 0,
        expected_revision: -1,
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
    }
}

/// The values bound for an append without a prediction (not inserted: its flag is 0).
fn placeholder_prediction(a: &Append) -> NewPrediction {
    NewPrediction {
        cell_id: a.cell_id,
        routine_id: a.waypoint.routine_id,
        after_seq: a.waypoint.seq,
        pose: a.waypoint.pose,
        phi: 0.0,
        psi: 1.0,
        misfit: None,
        end_probability: 0.0,
        model_version: 0,
    }
}

/// Advances the revision of each append's cell that is still at the revision the append was
/// made from; returns the states of those cells (the others are stale). A cell that does not
/// exist any more is an error for the whole batch (committed one by one, it gets its 404).
async fn advance_cells(tx: &mut Tx<'_>, appends: &[&Append]) -> Result<HashMap<i64, CellState>> {
    let mut params = Params::default();
    let terms: Vec<String> = appends
        .iter()
        .map(|a| {
            let cell = params.push(a.cell_id);
            let revision = params.push(a.expected_revision);
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
    if states.len() < appends.len() {
        let mut params = Params::default();
        let missing = params.run(|p| {
            for a in appends.iter().filter(|a| !states.contains_key(&a.cell_id)) {
                p.push(a.cell_id);
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

/// Inserts the waypoints; returns them as stored, by (routine, seq).
async fn insert_waypoint_rows(
    tx: &mut Tx<'_>,
    appends: &[&Append],
) -> Result<HashMap<(i64, i64), WaypointRow>> {
    if appends.is_empty() {
        return Ok(HashMap::new());
    }
    let mut params = Params::default();
    let values: Vec<String> = appends
        .iter()
        .map(|a| {
            let w = &a.waypoint;
            let row = params.run(|p| {
                p.new_waypoint(w);
            });
            format!("({row})")
        })
        .collect();
    let sql = format!(
        "INSERT INTO waypoints (routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, \
         reachable) VALUES {} RETURNING {}",
        values.join(", "),
        WaypointRow::COLUMNS
    );
    Ok(params
        .query_as::<WaypointRow>(sql)?
        .fetch_all(&mut **tx)
        .await
        .map_err(classify)?
        .into_iter()
        .map(|r| ((r.routine_id, r.seq), r))
        .collect())
}

/// Inserts the predictions, each made after the waypoint given; returns their ids by that
/// waypoint.
async fn insert_prediction_rows(
    tx: &mut Tx<'_>,
    predictions: &[(&NewPrediction, i64)],
) -> Result<HashMap<i64, i64>> {
    if predictions.is_empty() {
        return Ok(HashMap::new());
    }
    let mut params = Params::default();
    let values: Vec<String> = predictions
        .iter()
        .map(|(pr, after)| {
            let row = params.run(|p| {
                p.value(pr.cell_id)
                    .value(pr.routine_id)
                    .value(pr.after_seq)
                    .value(*after)
                    .prediction_values(pr);
            });
            format!("({row})")
        })
        .collect();
    let sql = format!(
        "INSERT INTO predictions (cell_id, routine_id, after_seq, after_waypoint_id, x, y, z, \
           qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version) \
         VALUES {} RETURNING id, after_waypoint_id",
        values.join(", ")
    );
    Ok(params
        .query_as::<(i64, i64)>(sql)?
        .fetch_all(&mut **tx)
        .await
        .map_err(classify)?
        .into_iter()
        .map(|(id, after)| (after, id))
        .collect())
}

async fn alone(pool: &AnyPool, job: &Job) -> Result<Appended> {
    let mut tx = pool.begin().await?;
    let done = store(&mut tx, &job.append).await?;
    history::record_taught(
        &mut tx,
        done.row.routine_id,
        done.row.seq,
        job.audit.as_ref(),
    )
    .await?;
    if let Some(r) = &job.audit {
        r.record(&mut tx, Some(job.append.cell_id)).await?;
    }
    tx.commit().await?;
    Ok(done)
}

/// One append's statements: the cell's revision checked and advanced, the waypoint, the
/// prediction made after it.
async fn store(tx: &mut Tx<'_>, a: &Append) -> Result<Appended> {
    let state = touch_cell(tx, a.cell_id, CellWrite::following(a.expected_revision)).await?;
    let row = insert_waypoint(tx, &a.waypoint).await?;
    let prediction_id = match &a.prediction {
        Some(p) => Some(insert_prediction(tx, p, Some(row.id)).await?),
        None => None,
    };
    Ok(Appended {
        row,
        prediction_id,
        revision: state.revision,
        batch: 1,
    })
}
