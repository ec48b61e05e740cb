//! The store's group commit, below the API: appends queued together share one transaction, a
//! stale cell is left out of it without failing the rest, and a failing append sends the batch
//! back to one-by-one commits with its own error. On SQLite, and on PostgreSQL in the
//! PostgreSQL pass (`helpers::test_database`).

use nextpose::engine::PoseValues;
use nextpose::server::Database;
use nextpose::storage::{
    Append, AuditFilter, Durability, NewPrediction, NewWaypoint, Recorder, StorageError, Store,
};

use crate::helpers::test_database;

/// `cells` cells, each with a program and an open routine; returns the store and the
/// (cell, routine, revision) of each.
async fn cells(db: &Database, cells: usize) -> (Store, Vec<(i64, i64, i64)>) {
    let store = Store::connect(db, Durability::Process).await.expect("open");
    let mut out = Vec::new();
    for c in 0..cells {
        let cell = store
            .insert_cell(&format!("c{c}"), "{}")
            .await
            .expect("cell");
        let program = store.insert_program(cell.id, "p").await.expect("program");
        let (routine, state) = store
            .insert_routine(&program, None, cell.revision)
            .await
            .expect("routine");
        out.push((cell.id, routine, state.revision));
    }
    (store, out)
}

fn append(cell: i64, routine: i64, revision: i64, seq: i64, predict: bool) -> Append {
    let pose = PoseValues {
        x: 10.0 * seq as f64,
        y: cell as f64,
        z: 0.0,
        qw: 1.0,
        qx: 0.0,
        qy: 0.0,
        qz: 0.0,
    };
    Append {
        cell_id: cell,
        expected_revision: revision,
        waypoint: NewWaypoint {
            routine_id: routine,
            seq,
            pose,
            joints: None,
            motion: None,
            name: Some(format!("w{seq}")),
            reachable: Some(seq % 2 == 0),
        },
        prediction: predict.then(|| NewPrediction {
            cell_id: cell,
            routine_id: routine,
            after_seq: seq,
            pose,
            phi: 0.9,
            psi: 1.0,
            misfit: (seq % 2 == 0).then_some(0.5),
            end_probability: 0.1,
            model_version: 0,
        }),
    }
}

/// Queues every append before the writer runs (on this single-threaded runtime the spawned
/// tasks run, in order, before the writer they wake), and waits for all the answers.
async fn all_at_once(
    store: &Store,
    appends: Vec<Append>,
) -> Vec<Result<nextpose::storage::Appended, StorageError>> {
    let tasks: Vec<_> = appends
        .into_iter()
        .map(|a| {
            let store = store.clone();
            tokio::spawn(async move { store.append_waypoint(a).await })
        })
        .collect();
    let mut out = Vec::new();
    for t in tasks {
        out.push(t.await.expect("task"));
    }
    out
}

#[tokio::test(flavor = "current_thread")]
async fn appends_queued_together_share_one_commit() {
    let dir = tempfile::tempdir().unwrap();
    let (store, cells) = cells(&test_database(dir.path()).await, 12).await;
    let appends = cells
        .iter()
        .enumerate()
        .map(|(i, &(c, r, rev))| append(c, r, rev, 1, i % 3 != 0))
        .collect();
    let done = all_at_once(&store, appends).await;
    for (i, (d, &(cell, routine, rev))) in done.iter().zip(&cells).enumerate() {
        let d = d.as_ref().expect("stored");
        assert_eq!(d.batch, 12, "one transaction for all");
        assert_eq!(d.revision, rev + 1);
        assert_eq!(d.row.routine_id, routine);
        assert_eq!(d.prediction_id.is_some(), i % 3 != 0);
        let stored = store.waypoints(routine).await.unwrap();
        assert_eq!(stored.len(), 1);
        assert_eq!(stored[0].id, d.row.id);
        assert_eq!(stored[0].reachable, Some(false));
        assert_eq!(stored[0].pose.y, cell as f64);
        if let Some(p) = d.prediction_id {
            let p = store
                .prediction(p)
                .await
                .unwrap()
                .expect("prediction stored");
            assert_eq!((p.cell_id, p.routine_id, p.after_seq), (cell, routine, 1));
            assert_eq!(p.misfit, None);
        }
        assert_eq!(
            store.cell_state(cell).await.unwrap().unwrap().revision,
            rev + 1
        );
    }
}

#[tokio::test(flavor = "current_thread")]
async fn a_stale_cell_is_left_out_of_its_batch() {
    let dir = tempfile::tempdir().unwrap();
    let (store, cells) = cells(&test_database(dir.path()).await, 3).await;
    let appends = cells
        .iter()
        .enumerate()
        // The second was made from a revision the cell has left.
        .map(|(i, &(c, r, rev))| append(c, r, if i == 1 { rev - 1 } else { rev }, 1, true))
        .collect();
    let done = all_at_once(&store, appends).await;
    assert!(
        matches!(done[1], Err(StorageError::Stale { .. })),
        "{:?}",
        done[1]
    );
    for i in [0, 2] {
        assert_eq!(done[i].as_ref().expect("stored").batch, 3);
    }
    assert!(store.waypoints(cells[1].1).await.unwrap().is_empty());
    assert_eq!(store.waypoints(cells[2].1).await.unwrap().len(), 1);
    let state = store.cell_state(cells[1].0).await.unwrap().unwrap();
    assert_eq!(state.revision, cells[1].2, "the stale cell did not change");
}

#[tokio::test(flavor = "current_thread")]
async fn a_failing_append_is_answered_alone_and_the_rest_commit() {
    let dir = tempfile::tempdir().unwrap();
    let (store, cells) = cells(&test_database(dir.path()).await, 4).await;
    let (c, r, rev) = cells[2];
    let first = store
        .append_waypoint(append(c, r, rev, 1, false))
        .await
        .unwrap();
    let mut appends: Vec<Append> = cells
        .iter()
        .map(|&(c, r, rev)| append(c, r, rev, 1, true))
        .collect();
    // Place 1 of routine 3 is taken: a unique violation.
    appends[2].expected_revision = first.revision;
    let done = all_at_once(&store, appends).await;
    assert!(
        matches!(done[2], Err(StorageError::Conflict(_))),
        "{:?}",
        done[2]
    );
    for i in [0, 1, 3] {
        let d = done[i].as_ref().expect("stored");
        assert_eq!(d.batch, 1, "committed alone after the batch failed");
        assert!(d.prediction_id.is_some());
        assert_eq!(store.waypoints(cells[i].1).await.unwrap().len(), 1);
    }
    assert_eq!(store.waypoints(r).await.unwrap().len(), 1);
}

/// Each append of a batch that commits leaves its request's audit row, on its cell; a stale
/// one, left out of the batch, leaves none; a request that fails after its change committed
/// has its answer written into its row.
#[tokio::test(flavor = "current_thread")]
async fn each_committed_append_of_a_batch_leaves_its_audit_row() {
    let dir = tempfile::tempdir().unwrap();
    let (store, cells) = cells(&test_database(dir.path()).await, 6).await;
    let tasks: Vec<_> = cells
        .iter()
        .enumerate()
        .map(|(i, &(c, r, rev))| {
            let store = store.clone();
            // The third cell's append is made from a revision the cell has left.
            let rev = if i == 2 { rev - 1 } else { rev };
            let recorder = Recorder::new("op", &format!("req-{i}"), "POST /test");
            tokio::spawn(
                recorder
                    .scope(async move { store.append_waypoint(append(c, r, rev, 1, true)).await }),
            )
        })
        .collect();
    let mut done = Vec::new();
    for t in tasks {
        done.push(t.await.expect("task"));
    }
    assert!(matches!(done[2], Err(StorageError::Stale { .. })));
    let batch = done[0].as_ref().expect("stored").batch;
    assert_eq!(batch, 6, "one transaction for all");
    let rows = store
        .audit_rows(&AuditFilter {
            limit: 100,
            ..AuditFilter::default()
        })
        .await
        .unwrap();
    let mut got: Vec<(String, Option<i64>, String)> = rows
        .iter()
        .map(|r| (r.request_id.clone(), r.cell_id, r.outcome.clone()))
        .collect();
    got.sort();
    let want: Vec<(String, Option<i64>, String)> = cells
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 2)
        .map(|(i, &(c, _, _))| (format!("req-{i}"), Some(c), "ok".to_string()))
        .collect();
    assert_eq!(got, want);
    assert!(
        rows.iter()
            .all(|r| r.token == "op" && r.operation == "POST /test")
    );

    // A request of two writes: one row; it failed after the first, so its row says so.
    let (cell, _, _) = cells[0];
    let recorder = Recorder::new("eng", "req-two", "PATCH /test");
    recorder
        .clone()
        .scope(async {
            store
                .update_cell(cell, Some("renamed"), None)
                .await
                .unwrap();
            store.update_cell(cell, Some("again"), None).await.unwrap();
        })
        .await;
    store.audit_failure(&recorder, "500").await.unwrap();
    let rows = store
        .audit_rows(&AuditFilter {
            cell_id: Some(cell),
            limit: 100,
            ..AuditFilter::default()
        })
        .await
        .unwrap();
    let mine: Vec<_> = rows.iter().filter(|r| r.request_id == "req-two").collect();
    assert_eq!(mine.len(), 1, "{rows:?}");
    assert_eq!(
        (mine[0].token.as_str(), mine[0].outcome.as_str()),
        ("eng", "500")
    );
    // Outside a request, a write leaves no row.
    store.update_cell(cell, Some("quiet"), None).await.unwrap();
    let after = store
        .audit_rows(&AuditFilter {
            limit: 100,
            ..AuditFilter::default()
        })
        .await
        .unwrap();
    assert_eq!(after.len(), 6);
}
