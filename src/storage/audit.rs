//! The audit trail: one row per request that changed the database, appended in the same
//! transaction as the request's first change, so that there is never a change without its row
//! nor a row without its change.
//!
//! An adapter runs a request that may write inside its [`Recorder`] ([`Recorder::scope`]: a
//! task-local, carried over to the tasks the application runs writes on and into the append
//! writer's batches with each append). Every write transaction calls [`record`] before it
//! commits; the row is keyed by the request, so a request committing several transactions
//! leaves one row (the first to commit). A request that changed nothing (refused, failed,
//! or a read) leaves none. The row says `ok`; a request that fails after one of its changes
//! committed has its answer written into the row ([`Store::audit_failure`]), so the answer
//! costs the usual request nothing.

use std::future::Future;
use std::sync::{Arc, Mutex, MutexGuard};

use sqlx::AnyConnection;

use super::Store;
use super::error::Result;
use super::inserts::{AuditRows, Who};
use super::rows::{AuditRow, Stored};
use super::slots::Params;

/// Who is changing what, for the request being served.
#[derive(Debug, Clone)]
pub struct Recorder {
    token: Arc<str>,
    request_id: Arc<str>,
    operation: Arc<str>,
    /// Unique to this request (a request id is the client's to choose and may repeat); a
    /// UUID v7, ordered by time, so that the unique index grows at its end.
    key: Arc<str>,
    state: Arc<Mutex<State>>,
}

#[derive(Debug, Default)]
struct State {
    target: Option<String>,
    recorded: bool,
}

tokio::task_local! {
    static CURRENT: Recorder;
}

impl Recorder {
    /// A request by the token named `token` (never its secret), with its request id, doing
    /// `operation` (REST: method and route; gRPC: the method's path).
    pub fn new(token: &str, request_id: &str, operation: &str) -> Recorder {
        Recorder {
            token: token.into(),
            request_id: request_id.into(),
            operation: operation.into(),
            key: uuid::Uuid::now_v7().to_string().into(),
            state: Arc::default(),
        }
    }

    /// Runs `f` as this request: its writes are recorded.
    pub async fn scope<F: Future>(self, f: F) -> F::Output {
        CURRENT.scope(self, f).await
    }

    /// The request being served on this task, if an adapter set one.
    pub fn current() -> Option<Recorder> {
        CURRENT.try_with(Clone::clone).ok()
    }

    /// Names the resource the request is about ("routine 12"), once the adapter knows it.
    pub fn name_target(&self, target: String) {
        self.state().target = Some(target);
    }

    /// Whether a write of this request has put its row in a transaction (which may since
    /// have been rolled back: then the row is not there).
    pub fn recorded(&self) -> bool {
        self.state().recorded
    }

    fn state(&self) -> MutexGuard<'_, State> {
        // Every update is a single assignment: a poisoned lock is still consistent.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Puts the request's row in `tx` (nothing when it is there already).
    pub(super) async fn record(&self, tx: &mut AnyConnection, cell_id: Option<i64>) -> Result<()> {
        let mut params = Params::default();
        let [token, request_id, operation, target, key] = self.values();
        let who = Who::bind(&mut params, [token, request_id, operation]);
        let named = [params.push(target), params.push(key)];
        let cell = params.push(cell_id);
        let mut rows = AuditRows::default();
        rows.push(&who, named, cell, "");
        params.query(rows.sql())?.execute(&mut *tx).await?;
        self.state().recorded = true;
        Ok(())
    }

    /// The values of its row (token, request id, operation, target, key), for the append
    /// writer's batches.
    pub(super) fn values(&self) -> [Option<String>; 5] {
        [
            Some(self.token.to_string()),
            Some(self.request_id.to_string()),
            Some(self.operation.to_string()),
            self.state().target.clone(),
            Some(self.key.to_string()),
        ]
    }

    /// Who made a change: the token, request id and operation of `recorder`'s request (none
    /// for a change made without a request).
    pub(super) fn who(recorder: Option<&Recorder>) -> [Option<String>; 3] {
        let [token, request_id, operation, _, _] =
            recorder.map_or([None, None, None, None, None], Recorder::values);
        [token, request_id, operation]
    }

    pub(super) fn mark_recorded(&self) {
        self.state().recorded = true;
    }
}

/// Puts the current request's row in `tx`, if a request is being served (see the module doc);
/// `cell_id` is the cell the change is to.
pub(super) async fn record(tx: &mut AnyConnection, cell_id: Option<i64>) -> Result<()> {
    match Recorder::current() {
        Some(r) => r.record(tx, cell_id).await,
        None => Ok(()),
    }
}

/// Which rows [`Store::audit_rows`] reads.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AuditFilter {
    /// Only changes to this cell.
    pub cell_id: Option<i64>,
    /// Only rows written at or after this time (`YYYY-MM-DDTHH:MM:SS…Z`, compared as text).
    pub since: Option<String>,
    /// Only rows before this id (the next page of a newest-first listing).
    pub before: Option<i64>,
    pub limit: i64,
}

impl Store {
    /// Writes the answer of a request that failed after changing the database into its row.
    pub async fn audit_failure(&self, recorder: &Recorder, outcome: &str) -> Result<()> {
        if !recorder.recorded() {
            return Ok(());
        }
        sqlx::query("UPDATE audit SET outcome = $1 WHERE request_key = $2")
            .bind(outcome)
            .bind(&*recorder.key)
            .execute(&self.pool)
            .await?;
        Ok(())
    }

    /// Audit rows, newest first.
    pub async fn audit_rows(&self, filter: &AuditFilter) -> Result<Vec<AuditRow>> {
        let sql = format!(
            "SELECT {} FROM {} WHERE ($1 IS NULL OR cell_id = $1) AND ($2 IS NULL OR at >= $2) \
             AND ($3 IS NULL OR id < $3) ORDER BY id DESC LIMIT $4",
            AuditRow::COLUMNS,
            AuditRow::FROM
        );
        Ok(sqlx::query_as::<_, AuditRow>(sqlx::AssertSqlSafe(sql))
            .bind(filter.cell_id)
            .bind(filter.since.clone())
            .bind(filter.before)
            .bind(filter.limit)
            .fetch_all(&self.pool)
            .await?)
    }
}

impl Store {
    /// Puts the current request's row in a transaction of its own: for a change that is not
    /// to a table (a backup written).
    pub async fn audit_alone(&self) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(())
    }
}
