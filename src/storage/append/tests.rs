//! The append writer of each dialect, below the queue: what a batch writes, a stale cell left
//! out, an append longer than a statement, a failing batch that writes nothing. On a real
//! SQLite file, and on PostgreSQL when a test cluster is given (`NEXTPOSE_TEST_POSTGRES`, as
//! `bash scripts/with-postgres.sh cargo test --lib storage::append` sets it; otherwise the
//! PostgreSQL pass is skipped with a notice).

use super::*;
use crate::engine::PoseValues;
use crate::storage::{AuditFilter, Durability, Location, RevisionFilter, Store};

/// A store on each dialect at hand, each with its name (the SQLite file's directory is kept).
async fn stores() -> Vec<(&'static str, Store, Option<tempfile::TempDir>)> {
    let dir = tempfile::tempdir().expect("temp dir");
    let sqlite = Store::open(&dir.path().join("append.db"), Durability::Process)
        .await
        .expect("open sqlite");
    let mut out = vec![("sqlite", sqlite, Some(dir))];
    match std::env::var("NEXTPOSE_TEST_POSTGRES") {
        Ok(cluster) => {
            let url = postgres_database(&cluster).await;
            let pg = Store::connect(&Location::Postgres(url), Durability::Process)
                .await
                .expect("open postgres");
            out.push(("postgres", pg, None));
        }
        Err(_) => eprintln!(
            "storage::append: NEXTPOSE_TEST_POSTGRES is unset, so the PostgreSQL writer is not \
             tested here (bash scripts/with-postgres.sh cargo test --lib storage::append)"
        ),
    }
    out
}

/// A new database in the test cluster at `cluster`; its URL.
async fn postgres_database(cluster: &str) -> String {
    use sqlx::Connection;
    let name = format!("unit_{}", uuid::Uuid::now_v7().simple());
    let create = format!("CREATE DATABASE {name}");
    let mut conn = sqlx::PgConnection::connect(cluster)
        .await
        .expect("connect to the test cluster");
    sqlx::query(sqlx::AssertSqlSafe(create))
        .execute(&mut conn)
        .await
        .expect("create a test database");
    let mut url = url::Url::parse(cluster).expect("cluster URL");
    url.set_path(&name);
    url.to_string()
}

/// A cell with a program and an open routine: (cell, program, routine, revision).
async fn cell(store: &Store, name: &str) -> (i64, i64, i64, i64) {
    let cell = store.insert_cell(name, "{}").await.expect("cell");
    let program = store.insert_program(cell.id, "p").await.expect("program");
    let (routine, state) = store
        .insert_routine(&program, None, cell.revision)
        .await
        .expect("routine");
    (cell.id, program.id, routine, state.revision)
}

/// Waypoint `seq` of `routine`, with values that do not round-trip through decimal text
/// unless exactly, and (when `predict`) the prediction offered after it.
fn taught(cell: i64, routine: i64, seq: i64, predict: bool) -> Taught {
    let pose = PoseValues {
        x: 0.1 + seq as f64 / 3.0,
        y: -1e-7 * cell as f64,
        z: 1.0 / 7.0,
        qw: 1.0,
        qx: 0.0,
        qy: 0.0,
        qz: 0.0,
    };
    Taught {
        waypoint: NewWaypoint {
            routine_id: routine,
            seq,
            pose,
            joints: (seq % 2 == 0).then(|| "[0.5,-1.25]".to_string()),
            motion: Some("LIN".into()),
            name: Some(format!("w{seq}")),
            reachable: (seq % 3 != 0).then_some(seq % 2 == 0),
        },
        prediction: predict.then(|| NewPrediction {
            cell_id: cell,
            routine_id: routine,
            after_seq: seq,
            pose: PoseValues {
                x: pose.x + 2.0,
                ..pose
            },
            phi: 0.9,
            psi: 1.0,
            misfit: (seq % 2 == 0).then_some(0.5),
            end_probability: 0.1,
            model_version: 0,
        }),
    }
}

fn writes(cell: i64, revision: i64, taught: Vec<Taught>, audit: Option<Recorder>) -> Writes {
    Writes {
        cell_id: cell,
        expected_revision: revision,
        taught,
        audit,
    }
}

/// Each waypoint of `w` stored as given, with its prediction after it; `done` its answer.
async fn check_stored(store: &Store, w: &Writes, done: &[Appended], revision: i64) {
    assert_eq!(done.len(), w.taught.len());
    for (t, d) in w.taught.iter().zip(done) {
        let row = store.waypoint(d.row.id).await.unwrap().expect("stored");
        let n = &t.waypoint;
        assert_eq!((row.routine_id, row.seq), (n.routine_id, n.seq));
        assert_eq!(row.pose, n.pose, "bit for bit");
        assert_eq!(
            (&row.joints, &row.motion, &row.name, row.reachable),
            (&n.joints, &n.motion, &n.name, n.reachable)
        );
        assert_eq!(d.revision, revision);
        match (&t.prediction, d.prediction_id) {
            (Some(pr), Some(id)) => {
                let p = store.prediction(id).await.unwrap().expect("prediction");
                assert_eq!(p.after_waypoint_id, Some(row.id));
                assert_eq!((p.cell_id, p.after_seq), (pr.cell_id, pr.after_seq));
                assert_eq!(p.pose, pr.pose);
                assert_eq!(p.misfit, pr.misfit);
            }
            (None, None) => {}
            (want, got) => panic!("prediction {want:?}, stored {got:?}"),
        }
    }
}

/// The changes of a program's revisions, oldest first, with who made each.
async fn revisions(store: &Store, program: i64) -> Vec<(Vec<Change>, Option<String>)> {
    let filter = RevisionFilter {
        before: None,
        limit: 100,
    };
    let mut rows = store.revisions(program, filter).await.unwrap();
    rows.reverse();
    rows.iter()
        .map(|r| (r.changes().unwrap(), r.request_id.clone()))
        .collect()
}

fn added(routine: i64, seqs: std::ops::RangeInclusive<i64>) -> Vec<Change> {
    seqs.map(|seq| Change::WaypointAdded { routine, seq })
        .collect()
}

#[tokio::test]
async fn a_batch_writes_each_appends_rows_and_leaves_a_stale_one_out() {
    for (dialect, store, _dir) in stores().await {
        let (a, pa, ra, reva) = cell(&store, "a").await;
        let (b, pb, rb, revb) = cell(&store, "b").await;
        let (c, pc, rc, revc) = cell(&store, "c").await;
        let before_a = revisions(&store, pa).await.len();
        let before_c = revisions(&store, pc).await.len();
        let batch = [
            // One taught waypoint, in a request.
            writes(
                a,
                reva,
                vec![taught(a, ra, 1, true)],
                Some(Recorder::new("op", "req-a", "POST /test")),
            ),
            // A trajectory's three, outside a request.
            writes(
                b,
                revb,
                (1..=3).map(|s| taught(b, rb, s, s != 2)).collect(),
                None,
            ),
            // Made from a revision the cell has left.
            writes(
                c,
                revc - 1,
                vec![taught(c, rc, 1, true)],
                Some(Recorder::new("op", "req-c", "POST /test")),
            ),
        ];
        let refs: Vec<&Writes> = batch.iter().collect();
        let answers = write(&store.pool, store.backend, &refs).await.unwrap();
        assert_eq!(answers.len(), 3, "{dialect}");
        let done_a = answers[0].as_ref().expect("a stored");
        let done_b = answers[1].as_ref().expect("b stored");
        assert!(
            matches!(answers[2], Err(StorageError::Stale { cell, expected })
                if cell == c && expected == revc - 1),
            "{dialect}: {:?}",
            answers[2]
        );
        assert!(
            done_a.iter().chain(done_b).all(|d| d.batch == 3),
            "{dialect}"
        );
        check_stored(&store, &batch[0], done_a, reva + 1).await;
        check_stored(&store, &batch[1], done_b, revb + 1).await;

        // The cells: each fresh one advanced once, the stale one as it was.
        for (cell, revision) in [(a, reva + 1), (b, revb + 1), (c, revc)] {
            let state = store.cell_state(cell).await.unwrap().unwrap();
            assert_eq!(state.revision, revision, "{dialect}: cell {cell}");
        }
        assert!(store.waypoints(rc).await.unwrap().is_empty(), "{dialect}");

        // One revision of each fresh append's program, with its waypoints added.
        let got_a = revisions(&store, pa).await;
        assert_eq!(got_a.len(), before_a + 1, "{dialect}");
        assert_eq!(
            got_a.last().unwrap(),
            &(added(ra, 1..=1), Some("req-a".to_string())),
            "{dialect}"
        );
        let got_b = revisions(&store, pb).await;
        assert_eq!(
            got_b.last().unwrap(),
            &(added(rb, 1..=3), None),
            "{dialect}"
        );
        assert_eq!(revisions(&store, pc).await.len(), before_c, "{dialect}");

        // The audit row of the fresh append's request, on its cell; none for the stale one.
        let every = AuditFilter {
            limit: 100,
            ..AuditFilter::default()
        };
        let rows = store.audit_rows(&every).await.unwrap();
        let got: Vec<(&str, Option<i64>, &str)> = rows
            .iter()
            .map(|r| (r.request_id.as_str(), r.cell_id, r.outcome.as_str()))
            .collect();
        assert_eq!(got, vec![("req-a", Some(a), "ok")], "{dialect}");
        assert!(batch[0].audit.as_ref().unwrap().recorded(), "{dialect}");
        assert!(!batch[2].audit.as_ref().unwrap().recorded(), "{dialect}");
    }
}

#[tokio::test]
async fn an_append_longer_than_a_statement_is_written_whole() {
    let n = 2 * MAX_ROWS as i64 + 5;
    for (dialect, store, _dir) in stores().await {
        let (cell_id, program, routine, revision) = cell(&store, "long").await;
        let w = writes(
            cell_id,
            revision,
            (1..=n)
                .map(|s| taught(cell_id, routine, s, s % 4 != 0))
                .collect(),
            Some(Recorder::new("op", "req-long", "POST /test")),
        );
        let mut answers = write(&store.pool, store.backend, &[&w]).await.unwrap();
        let done = answers.pop().unwrap().expect("stored");
        check_stored(&store, &w, &done, revision + 1).await;
        assert_eq!(store.waypoints(routine).await.unwrap().len(), n as usize);
        let state = store.cell_state(cell_id).await.unwrap().unwrap();
        assert_eq!(state.revision, revision + 1, "{dialect}: advanced once");
        assert_eq!(
            revisions(&store, program).await.last().unwrap(),
            &(added(routine, 1..=n), Some("req-long".to_string())),
            "{dialect}"
        );
    }
}

#[tokio::test]
async fn a_failing_batch_writes_nothing() {
    for (dialect, store, _dir) in stores().await {
        let (a, pa, ra, reva) = cell(&store, "a").await;
        let (b, _, rb, revb) = cell(&store, "b").await;
        let first = writes(a, reva, vec![taught(a, ra, 1, false)], None);
        write(&store.pool, store.backend, &[&first])
            .await
            .unwrap()
            .pop()
            .unwrap()
            .expect("first stored");
        let before = revisions(&store, pa).await.len();
        let batch = [
            writes(b, revb, vec![taught(b, rb, 1, true)], None),
            // Place 1 of routine a is taken: a unique violation.
            writes(a, reva + 1, vec![taught(a, ra, 1, true)], None),
        ];
        let refs: Vec<&Writes> = batch.iter().collect();
        let e = write(&store.pool, store.backend, &refs).await.unwrap_err();
        assert!(matches!(e, StorageError::Conflict(_)), "{dialect}: {e:?}");
        assert!(store.waypoints(rb).await.unwrap().is_empty(), "{dialect}");
        assert_eq!(store.waypoints(ra).await.unwrap().len(), 1, "{dialect}");
        for (cell, revision) in [(a, reva + 1), (b, revb)] {
            let state = store.cell_state(cell).await.unwrap().unwrap();
            assert_eq!(state.revision, revision, "{dialect}: cell {cell} as it was");
        }
        assert_eq!(revisions(&store, pa).await.len(), before, "{dialect}");
        // The connection is usable again: the next batch commits.
        let next = writes(b, revb, vec![taught(b, rb, 1, true)], None);
        let done = write(&store.pool, store.backend, &[&next]).await.unwrap();
        assert!(done[0].is_ok(), "{dialect}: {:?}", done[0]);
    }
}
