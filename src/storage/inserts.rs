//! The `INSERT` of each table an append writes, written once: waypoints, predictions, program
//! revisions, audit rows. Each renders any number of rows as one statement
//! (`INSERT … SELECT … UNION ALL SELECT …`, the same SQL on SQLite and PostgreSQL), every value
//! bound where the SQL names it ([`super::slots`]). A row may carry a condition, a
//! `FROM … WHERE …` clause: the SQLite script of the append writer inserts a row only while its
//! cell is at the revision its append was made from ([`super::append`]).
//!
//! The append writers of both dialects and every other write that stores one of these rows (an
//! edit, an import, a restore, a prediction asked for again, any request's audit row) render
//! their statements here, so a table's column list stands in one place.

use sqlx::AnyConnection;

use super::binds::Binds;
use super::error::{Result, classify};
use super::rows::{NewPrediction, NewWaypoint, Stored, WaypointRow};
use super::slots::{Params, Slot};

/// Most rows one statement inserts: bounds its parameters (SQLite takes at most 32,766, a
/// waypoint with its prediction binds about 30) and, with rows padded to a power of two, the
/// number of statement shapes a connection prepares and keeps.
pub(super) const MAX_ROWS: usize = 64;

/// The rows of one insert, each a `SELECT` of its values and its condition.
#[derive(Default)]
struct Selects(Vec<String>);

impl Selects {
    fn push(&mut self, values: String, condition: &str) {
        self.0.push(match condition {
            "" => format!("SELECT {values}"),
            c => format!("SELECT {values} {c}"),
        });
    }

    fn sql(&self) -> String {
        self.0.join(" UNION ALL ")
    }
}

/// `RETURNING …`, or nothing.
fn returning(columns: &str) -> String {
    match columns {
        "" => String::new(),
        c => format!(" RETURNING {c}"),
    }
}

/// Waypoints: new ones (their ids given by the database) or ones brought back with their ids.
#[derive(Default)]
pub(super) struct WaypointRows {
    /// Each row names its id (a restore brings a waypoint back as it was).
    kept_ids: bool,
    rows: Selects,
}

impl WaypointRows {
    /// Waypoints that keep the ids they had ([`WaypointRows::push_kept`]).
    pub(super) fn keeping_ids() -> WaypointRows {
        WaypointRows {
            kept_ids: true,
            rows: Selects::default(),
        }
    }

    /// A new waypoint, inserted when `condition` holds (`""`: always).
    pub(super) fn push(&mut self, params: &mut Params, w: &NewWaypoint, condition: &str) {
        debug_assert!(!self.kept_ids, "a waypoint without its id among kept ones");
        let values = params.run(|p| {
            p.new_waypoint(w);
        });
        self.rows.push(values.to_string(), condition);
    }

    /// A waypoint with the id `id` it had.
    pub(super) fn push_kept(&mut self, params: &mut Params, id: i64, w: &NewWaypoint) {
        debug_assert!(self.kept_ids, "a kept id among new waypoints");
        let values = params.run(|p| {
            p.value(id).new_waypoint(w);
        });
        self.rows.push(values.to_string(), "");
    }

    /// The statement, answering `columns` of each row stored (`""`: nothing).
    pub(super) fn sql(&self, columns: &str) -> String {
        let id = if self.kept_ids { "id, " } else { "" };
        format!(
            "INSERT INTO waypoints ({id}routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, \
             name, reachable) {}{}",
            self.rows.sql(),
            returning(columns)
        )
    }
}

/// Predictions, each made after a waypoint.
#[derive(Default)]
pub(super) struct PredictionRows {
    rows: Selects,
}

impl PredictionRows {
    /// `pr`, made after the waypoint whose id `after` gives (SQL: a slot, or a query of it),
    /// inserted when `condition` holds (`""`: always).
    pub(super) fn push(
        &mut self,
        params: &mut Params,
        pr: &NewPrediction,
        after: &str,
        condition: &str,
    ) {
        let cell = params.push(pr.cell_id);
        let routine = params.push(pr.routine_id);
        let after_seq = params.push(pr.after_seq);
        let values = params.run(|p| {
            p.prediction_values(pr);
        });
        self.rows.push(
            format!("{cell}, {routine}, {after_seq}, {after}, {values}"),
            condition,
        );
    }

    /// The statement, answering `columns` of each row stored (`""`: nothing).
    pub(super) fn sql(&self, columns: &str) -> String {
        format!(
            "INSERT INTO predictions (cell_id, routine_id, after_seq, after_waypoint_id, x, y, z, \
               qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version) {}{}",
            self.rows.sql(),
            returning(columns)
        )
    }
}

/// Who made a change, as bound: the request's token, request id and operation (all NULL for a
/// change made outside a request).
#[derive(Debug, Clone, Copy)]
pub(super) struct Who {
    pub token: Slot,
    pub request_id: Slot,
    pub operation: Slot,
}

impl Who {
    /// Binds `values` (token, request id, operation).
    pub(super) fn bind(params: &mut Params, values: [Option<String>; 3]) -> Who {
        let [token, request_id, operation] = values;
        Who {
            token: params.push(token),
            request_id: params.push(request_id),
            operation: params.push(operation),
        }
    }
}

/// Revisions of programs (`program_history`), each numbered after its program's last.
#[derive(Default)]
pub(super) struct RevisionRows {
    rows: Selects,
}

impl RevisionRows {
    /// A revision of `program` (SQL: a slot, or a query of it) made by `who`, holding
    /// `changes` (a JSON array), inserted when `condition` holds (`""`: always).
    pub(super) fn push(&mut self, program: &str, who: &Who, changes: Slot, condition: &str) {
        self.rows.push(
            format!(
                "{program}, (SELECT COALESCE(MAX(h.revision), 0) + 1 FROM program_history h \
                   WHERE h.program_id = {program}), {}, {}, {}, {changes}",
                who.token, who.request_id, who.operation
            ),
            condition,
        );
    }

    /// The statement, answering `columns` of each revision written (`""`: nothing).
    pub(super) fn sql(&self, columns: &str) -> String {
        format!(
            "INSERT INTO program_history (program_id, revision, token, request_id, operation, \
               changes) {}{}",
            self.rows.sql(),
            returning(columns)
        )
    }
}

/// Audit rows: one per request, the first of its writes to commit puts it (a request already
/// recorded is left as it is).
#[derive(Default)]
pub(super) struct AuditRows {
    rows: Selects,
}

impl AuditRows {
    /// The row of `who`'s request, naming the resource `target`, with its unique `key`,
    /// about the cell `cell`, inserted when `condition` holds (`""`: always).
    pub(super) fn push(
        &mut self,
        who: &Who,
        [target, key]: [Slot; 2],
        cell: Slot,
        condition: &str,
    ) {
        // SQLite reads the `ON` of an upsert after `INSERT … SELECT` as a join's unless the
        // `SELECT` ends with a `WHERE`.
        let condition = match condition {
            "" => "WHERE 1 = 1",
            c => c,
        };
        self.rows.push(
            format!(
                "{}, {}, {}, {target}, {cell}, 'ok', {key}",
                who.token, who.request_id, who.operation
            ),
            condition,
        );
    }

    pub(super) fn sql(&self) -> String {
        format!(
            "INSERT INTO audit (token, request_id, operation, target, cell_id, outcome, \
               request_key) {} ON CONFLICT (request_key) DO NOTHING",
            self.rows.sql()
        )
    }
}

/// Stores new waypoints (in the transaction `conn` is in), [`MAX_ROWS`] to a statement; returns them as stored, in the
/// order given.
pub(super) async fn insert_waypoints(
    conn: &mut AnyConnection,
    waypoints: &[NewWaypoint],
) -> Result<Vec<WaypointRow>> {
    let mut stored = Vec::with_capacity(waypoints.len());
    for chunk in waypoints.chunks(MAX_ROWS) {
        let mut params = Params::default();
        let mut rows = WaypointRows::default();
        for w in chunk {
            rows.push(&mut params, w, "");
        }
        let mut got = params
            .query_as::<WaypointRow>(rows.sql(WaypointRow::COLUMNS))?
            .fetch_all(&mut *conn)
            .await
            .map_err(classify)?;
        // In the order given (a routine's places are unique).
        got.sort_by_key(|r| {
            chunk
                .iter()
                .position(|w| (w.routine_id, w.seq) == (r.routine_id, r.seq))
        });
        stored.extend(got);
    }
    Ok(stored)
}

/// Stores waypoints with the ids they had (`(id, waypoint)`).
pub(super) async fn insert_kept_waypoints(
    conn: &mut AnyConnection,
    waypoints: &[(i64, NewWaypoint)],
) -> Result<()> {
    for chunk in waypoints.chunks(MAX_ROWS) {
        let mut params = Params::default();
        let mut rows = WaypointRows::keeping_ids();
        for (id, w) in chunk {
            rows.push_kept(&mut params, *id, w);
        }
        params
            .query(rows.sql(""))?
            .execute(&mut *conn)
            .await
            .map_err(classify)?;
    }
    Ok(())
}

/// Stores predictions, each made after the waypoint whose id is given with it (None: before
/// the first); returns the id of each with that waypoint's, in the order given.
pub(super) async fn insert_predictions(
    conn: &mut AnyConnection,
    predictions: &[(&NewPrediction, Option<i64>)],
) -> Result<Vec<(i64, Option<i64>)>> {
    let mut ids = Vec::with_capacity(predictions.len());
    for chunk in predictions.chunks(MAX_ROWS) {
        let mut params = Params::default();
        let mut rows = PredictionRows::default();
        for (pr, after) in chunk {
            let after = params.push(*after);
            rows.push(&mut params, pr, &after.to_string(), "");
        }
        let mut got: Vec<(i64, Option<i64>)> = params
            .query_as(rows.sql("id, after_waypoint_id"))?
            .fetch_all(&mut *conn)
            .await
            .map_err(classify)?;
        // Ids are given in the order rows are inserted, and never reused.
        got.sort_unstable();
        ids.extend(got);
    }
    Ok(ids)
}
