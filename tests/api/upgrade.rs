//! Upgrades (docs/deployment.md, "Upgrading"): databases made by earlier releases, kept as
//! plain SQL dumps in tests/upgrade/ (written by those releases' own servers, driven over
//! their REST API by scripts/upgrade-dumps.sh), loaded into a real database (an SQLite file,
//! or a database of the PostgreSQL test cluster), read with plain SQL on their old schema, and
//! opened by today's server on a loopback port. Every row of every table is kept; every
//! program's routines and waypoints read back as they were, and export the same text before
//! and after a restart, text that reads back as the old values; history starts at revision 0,
//! the program as it was; tokens still authenticate with their secrets and keep their role and
//! cells; the audit rows survive; a routine being taught goes on, predicted as the old release
//! predicted it and as a rebuild does; ids are never reused. A migration that fails leaves the
//! database as it was, and start-up says which one failed.
//!
//! Each test takes the dumps of the database it runs on: SQLite by default, PostgreSQL with
//! `NEXTPOSE_TEST_DB=postgres` (scripts/with-postgres.sh).

use std::collections::BTreeMap;

use nextpose::export::{orientation_tolerance_rad, position_tolerance_mm};
use nextpose::import::parse_files;
use nextpose::program::{Language, Routine, Waypoint};
use nextpose::server::{Application, Database, ServerSettings};
use nextpose::storage::Durability;
use nextpose::transport::TransportOptions;
use reqwest::StatusCode;
use serde_json::{Value, json};
use sqlx::{AnyConnection, Connection, Row};

use crate::helpers::*;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Engine {
    Sqlite,
    Postgres,
}

/// A database made by an earlier release, as its dump.
struct Release {
    name: &'static str,
    engine: Engine,
    sql: &'static str,
    /// Its last migration.
    version: i64,
    /// Its tokens (name, secret): the dump holds only their hashes. scripts/upgrade-dumps.sh
    /// prints the secrets of the tokens it creates; "gone" is revoked.
    tokens: &'static [(&'static str, &'static str)],
}

/// Migrations 0001-0008 (the last release on main before tokens).
const SQLITE_0008: Release = Release {
    name: "sqlite-0008",
    engine: Engine::Sqlite,
    sql: include_str!("../upgrade/sqlite-0008.sql"),
    version: 8,
    tokens: &[],
};

/// 0001-0010: tokens and the audit trail, before program history.
const SQLITE_0010: Release = Release {
    name: "sqlite-0010",
    engine: Engine::Sqlite,
    sql: include_str!("../upgrade/sqlite-0010.sql"),
    version: 10,
    tokens: TOKENS_SQLITE_0010,
};

/// PostgreSQL 0001-0002, the release of SQLite's 0008.
const POSTGRES_0002: Release = Release {
    name: "postgres-0002",
    engine: Engine::Postgres,
    sql: include_str!("../upgrade/postgres-0002.sql"),
    version: 2,
    tokens: &[],
};

/// PostgreSQL 0001-0004, the release of SQLite's 0010.
const POSTGRES_0004: Release = Release {
    name: "postgres-0004",
    engine: Engine::Postgres,
    sql: include_str!("../upgrade/postgres-0004.sql"),
    version: 4,
    tokens: TOKENS_POSTGRES_0004,
};

const TOKENS_SQLITE_0010: &[(&str, &str)] = &[
    (
        "otto",
        "npt_67f5d80add04241e77d4db48836b0b436b111b548530c3a79dac17a4c7b1c450",
    ),
    (
        "erin",
        "npt_860b963ded51102c627f8abd0ad96d0d780c7fa4840979df9a227e3ce646922f",
    ),
    (
        "ada",
        "npt_4e82228ae686ea5851af0d7737e0398583a338415cf78326b0773b9977fa4664",
    ),
    (
        "gone",
        "npt_faefc6d47d7e32faa8b239a6ca3cd50428e31efab842bcaa141f2a39258279db",
    ),
];
const TOKENS_POSTGRES_0004: &[(&str, &str)] = &[
    (
        "otto",
        "npt_7ac58296042a22d56360f52431c3941b2cedfd7faab6d9e2596f2dc8dc29e188",
    ),
    (
        "erin",
        "npt_1932af131f43cfd617ff47f18127c30997b2632fc3bf37e92446d05898633b61",
    ),
    (
        "ada",
        "npt_daaf2a088f3225a5bbee6dca4562c53ca5c7a80b38112f56c7f4995b04b67dbe",
    ),
    (
        "gone",
        "npt_bb15d73f3e366706bbba4cb5e3e65d7e1eed8949c5a9a5c8cefc62e2fab7e34c",
    ),
];

/// The release before tokens, on the database the tests run on.
fn before_tokens() -> &'static Release {
    if on_postgres() {
        &POSTGRES_0002
    } else {
        &SQLITE_0008
    }
}

/// The release before program history, on the database the tests run on.
fn before_history() -> &'static Release {
    if on_postgres() {
        &POSTGRES_0004
    } else {
        &SQLITE_0010
    }
}

/// The last migration of today's schema, from the migration files.
fn latest_version(engine: Engine) -> i64 {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(match engine {
        Engine::Sqlite => "migrations/sqlite",
        Engine::Postgres => "migrations/postgres",
    });
    std::fs::read_dir(&dir)
        .expect("migrations")
        .filter_map(|e| {
            let name = e.expect("entry").file_name();
            name.to_str()?.split('_').next()?.parse::<i64>().ok()
        })
        .max()
        .expect("a migration")
}

/// An old release's database, loaded from its dump into a fresh database.
struct OldDatabase {
    engine: Engine,
    db: Database,
    url: String,
    _dir: Option<tempfile::TempDir>,
}

async fn load(release: &Release) -> OldDatabase {
    assert_eq!(
        release.engine == Engine::Postgres,
        on_postgres(),
        "{}: a dump of the database the tests run on",
        release.name
    );
    sqlx::any::install_default_drivers();
    let old = match release.engine {
        Engine::Sqlite => {
            let dir = tempfile::tempdir().expect("temp dir");
            let path = dir.path().join("nextpose.db");
            OldDatabase {
                engine: Engine::Sqlite,
                url: format!("sqlite://{}?mode=rwc", path.display()),
                db: Database::File(path),
                _dir: Some(dir),
            }
        }
        Engine::Postgres => {
            let url = postgres_database().await;
            OldDatabase {
                engine: Engine::Postgres,
                db: Database::Postgres(url.clone()),
                url,
                _dir: None,
            }
        }
    };
    // The dump on a connection of its own (a PostgreSQL dump empties the search path of the
    // session it runs in).
    let mut conn = AnyConnection::connect(&old.url).await.expect("connect");
    sqlx::raw_sql(release.sql)
        .execute(&mut conn)
        .await
        .unwrap_or_else(|e| panic!("{}: the dump loads: {e}", release.name));
    conn.close().await.expect("close");
    let mut sql = old.reader().await;
    assert_eq!(sql.version().await, release.version, "{}", release.name);
    old
}

impl OldDatabase {
    async fn reader(&self) -> Reader {
        Reader {
            conn: AnyConnection::connect(&self.url).await.expect("connect"),
            engine: self.engine,
        }
    }

    /// Today's server on it, answering as `token` (the dumps with tokens need one).
    async fn serve(&self, token: Option<&str>) -> TestApp {
        let mut app = spawn_on(self.db.clone()).await;
        app.token = token.map(str::to_string);
        app
    }
}

/// The pseudo-table of a PostgreSQL shape that lists its identity sequences.
const SEQUENCES: &str = "(sequences)";

/// The tables of the old schema, each with its columns (on PostgreSQL also its sequences).
type Shape = Vec<(String, Vec<String>)>;
/// Every row of those tables (each value as an SQL literal), by table.
type Snapshot = BTreeMap<String, Vec<Vec<String>>>;

/// Plain SQL on a database, old schema or new.
struct Reader {
    conn: AnyConnection,
    engine: Engine,
}

#[derive(Debug)]
struct OldWaypoint {
    id: i64,
    seq: i64,
    pose: [f64; 7],
    joints: Option<String>,
    motion: Option<String>,
    name: Option<String>,
    reachable: Option<i64>,
}

#[derive(Debug)]
struct OldRoutine {
    id: i64,
    position: i64,
    name: Option<String>,
    finish_seq: Option<i64>,
    imported: bool,
    waypoints: Vec<OldWaypoint>,
}

impl OldRoutine {
    fn open(&self) -> bool {
        self.finish_seq.is_none() && !self.imported
    }
}

#[derive(Debug)]
struct OldProgram {
    id: i64,
    cell_id: i64,
    name: String,
    routines: Vec<OldRoutine>,
}

impl Reader {
    /// Every column of every row of `sql` as text (`NULL` for null).
    async fn texts(&mut self, sql: &str) -> Vec<Vec<String>> {
        sqlx::query(sqlx::AssertSqlSafe(sql.to_string()))
            .fetch_all(&mut self.conn)
            .await
            .unwrap_or_else(|e| panic!("{sql}: {e}"))
            .iter()
            .map(|row| {
                (0..row.len())
                    .map(|i| {
                        row.try_get::<Option<String>, _>(i)
                            .expect("text")
                            .unwrap_or_else(|| "NULL".into())
                    })
                    .collect()
            })
            .collect()
    }

    async fn version(&mut self) -> i64 {
        let rows = self
            .texts("SELECT CAST(MAX(version) AS TEXT) FROM _sqlx_migrations")
            .await;
        rows[0][0].parse().expect("a version")
    }

    /// The tables (sqlx's own left out) and their columns.
    async fn shape(&mut self) -> Shape {
        let tables = match self.engine {
            Engine::Sqlite => {
                self.texts(
                    "SELECT name FROM sqlite_master WHERE type = 'table' \
                     AND name <> '_sqlx_migrations' ORDER BY name",
                )
                .await
            }
            Engine::Postgres => {
                self.texts(
                    "SELECT table_name::text FROM information_schema.tables \
                     WHERE table_schema = 'public' AND table_type = 'BASE TABLE' \
                     AND table_name <> '_sqlx_migrations' ORDER BY table_name",
                )
                .await
            }
        };
        let mut shape = Vec::new();
        for t in tables {
            let table = t[0].clone();
            let columns = match self.engine {
                Engine::Sqlite => {
                    self.texts(&format!(
                        "SELECT name FROM pragma_table_info('{table}') ORDER BY cid"
                    ))
                    .await
                }
                Engine::Postgres => {
                    self.texts(&format!(
                        "SELECT column_name::text FROM information_schema.columns \
                         WHERE table_schema = 'public' AND table_name = '{table}' \
                         ORDER BY ordinal_position"
                    ))
                    .await
                }
            };
            shape.push((table, columns.into_iter().map(|c| c[0].clone()).collect()));
        }
        if self.engine == Engine::Postgres {
            // The identity sequences, where ids go on from.
            let sequences = self
                .texts(
                    "SELECT sequencename::text FROM pg_sequences WHERE schemaname = 'public' \
                     ORDER BY sequencename",
                )
                .await;
            shape.push((
                SEQUENCES.into(),
                sequences.into_iter().map(|s| s[0].clone()).collect(),
            ));
        }
        shape
    }

    /// Every row of the tables of `shape`, only their columns of `shape`, each value as an
    /// SQL literal (full precision), and on PostgreSQL where each identity sequence stands.
    async fn snapshot(&mut self, shape: &Shape) -> Snapshot {
        let mut snapshot = Snapshot::new();
        for (table, columns) in shape {
            if table == SEQUENCES {
                let mut values = Vec::new();
                for sequence in columns {
                    values.extend(
                        self.texts(&format!(
                            "SELECT sequencename::text, quote_nullable(last_value) \
                             FROM pg_sequences WHERE schemaname = 'public' \
                             AND sequencename = '{sequence}'"
                        ))
                        .await,
                    );
                }
                snapshot.insert(table.clone(), values);
                continue;
            }
            let literal = |c: &String| match self.engine {
                Engine::Sqlite => format!("quote(\"{c}\")"),
                Engine::Postgres => format!("quote_nullable(\"{c}\")"),
            };
            let select: Vec<String> = columns.iter().map(literal).collect();
            let order: Vec<String> = columns.iter().map(|c| format!("\"{c}\"")).collect();
            let rows = self
                .texts(&format!(
                    "SELECT {} FROM \"{table}\" ORDER BY {}",
                    select.join(", "),
                    order.join(", ")
                ))
                .await;
            snapshot.insert(table.clone(), rows);
        }
        snapshot
    }

    /// Whether the schema has a table of this name.
    async fn has_table(&mut self, table: &str) -> bool {
        if table == SEQUENCES {
            return false;
        }
        self.shape().await.iter().any(|(t, _)| t == table)
    }

    /// Every program with its routines in order and their waypoints in order.
    async fn programs(&mut self) -> Vec<OldProgram> {
        let programs = sqlx::query("SELECT id, cell_id, name FROM programs ORDER BY id")
            .fetch_all(&mut self.conn)
            .await
            .expect("programs");
        let mut out = Vec::new();
        for p in programs {
            let id: i64 = p.get(0);
            let routines = sqlx::query(
                "SELECT id, position, name, finish_seq, imported FROM routines \
                 WHERE program_id = $1 ORDER BY position",
            )
            .bind(id)
            .fetch_all(&mut self.conn)
            .await
            .expect("routines");
            let mut old_routines = Vec::new();
            for r in routines {
                let routine: i64 = r.get(0);
                let waypoints = sqlx::query(
                    "SELECT id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, reachable \
                     FROM waypoints WHERE routine_id = $1 ORDER BY seq",
                )
                .bind(routine)
                .fetch_all(&mut self.conn)
                .await
                .expect("waypoints")
                .iter()
                .map(|w| OldWaypoint {
                    id: w.get(0),
                    seq: w.get(1),
                    pose: std::array::from_fn(|k| w.get::<f64, _>(2 + k)),
                    joints: w.get(9),
                    motion: w.get(10),
                    name: w.get(11),
                    reachable: w.get(12),
                })
                .collect();
                old_routines.push(OldRoutine {
                    id: routine,
                    position: r.get(1),
                    name: r.get(2),
                    finish_seq: r.get(3),
                    imported: r.get::<i64, _>(4) == 1,
                    waypoints,
                });
            }
            out.push(OldProgram {
                id,
                cell_id: p.get(1),
                name: p.get(2),
                routines: old_routines,
            });
        }
        out
    }

    /// The last offered prediction recorded for `routine` after its `after` waypoints: the
    /// pose the release answered with.
    async fn recorded_prediction(&mut self, routine: i64, after: usize) -> Option<[f64; 7]> {
        sqlx::query(
            "SELECT x, y, z, qw, qx, qy, qz FROM predictions \
             WHERE routine_id = $1 AND after_seq = $2 ORDER BY id DESC LIMIT 1",
        )
        .bind(routine)
        .bind(i64::try_from(after).expect("count"))
        .fetch_optional(&mut self.conn)
        .await
        .expect("predictions")
        .map(|p| std::array::from_fn(|k| p.get::<f64, _>(k)))
    }

    /// The largest id ever given to a cell (deleted ones included).
    async fn last_cell_id(&mut self) -> i64 {
        let sql = match self.engine {
            Engine::Sqlite => "SELECT CAST(seq AS TEXT) FROM sqlite_sequence WHERE name = 'cells'",
            Engine::Postgres => "SELECT last_value::text FROM cells_id_seq",
        };
        self.texts(sql).await[0][0].parse().expect("an id")
    }
}

const POSE_KEYS: [&str; 7] = ["x", "y", "z", "qw", "qx", "qy", "qz"];

/// A waypoint as the API shows it (`GET /v1/routines/{id}`, a revision) is the stored one:
/// the same id, number, pose (exactly), joints, motion, name and reach flag.
fn assert_waypoint(old: &OldWaypoint, api: &Value, at: &str) {
    assert_eq!(api["id"], old.id, "{at}");
    assert_eq!(api["seq"], old.seq, "{at}");
    for (k, v) in POSE_KEYS.iter().zip(old.pose) {
        assert_eq!(api["pose"][k].as_f64(), Some(v), "{at}: {k}");
    }
    let joints: Value = old
        .joints
        .as_deref()
        .map(|j| serde_json::from_str(j).expect("joints JSON"))
        .unwrap_or(Value::Null);
    assert_eq!(api["joints"], joints, "{at}");
    assert_eq!(api["motion"], json!(old.motion), "{at}");
    assert_eq!(api["name"], json!(old.name), "{at}");
    assert_eq!(
        api["reachable"],
        json!(old.reachable.map(|r| r == 1)),
        "{at}"
    );
}

/// A routine as the API shows it (a program's routine, or a revision's) is the stored one.
fn assert_routine(old: &OldRoutine, api: &Value, waypoints: &Value, at: &str) {
    assert_eq!(api["id"], old.id, "{at}");
    assert_eq!(api["position"], old.position, "{at}");
    assert_eq!(api["name"], json!(old.name), "{at}");
    assert_eq!(api["imported"], old.imported, "{at}");
    assert_eq!(api["learned"], old.finish_seq.is_some(), "{at}");
    assert_eq!(api["finished"], !old.open(), "{at}");
    let waypoints = waypoints.as_array().expect("waypoints");
    assert_eq!(waypoints.len(), old.waypoints.len(), "{at}");
    for (w, a) in old.waypoints.iter().zip(waypoints) {
        assert_waypoint(w, a, &format!("{at}, waypoint {}", w.id));
    }
}

/// Every program reads back through the API as it was stored: its routines in order, each
/// with its waypoints in order and their values.
async fn assert_programs_read_back(app: &TestApp, programs: &[OldProgram]) {
    for p in programs {
        let program = app.get_ok(&format!("/v1/programs/{}", p.id)).await;
        assert_eq!(program["name"], p.name.as_str());
        assert_eq!(program["cell_id"], p.cell_id);
        let routines = app.get_ok(&format!("/v1/programs/{}/routines", p.id)).await;
        let routines = routines.as_array().expect("routines");
        assert_eq!(routines.len(), p.routines.len(), "program {}", p.id);
        for (old, r) in p.routines.iter().zip(routines) {
            let detail = app.get_ok(&format!("/v1/routines/{}", old.id)).await;
            let at = format!("program {} routine {}", p.id, old.id);
            assert_routine(old, r, &detail["waypoints"], &at);
        }
    }
}

/// Each program's export in every format (`GET /v1/programs/{id}/export`), by program.
async fn exports(app: &TestApp, programs: &[OldProgram]) -> BTreeMap<(i64, &'static str), Value> {
    let mut out = BTreeMap::new();
    for p in programs {
        for format in Language::ALL {
            let export = app
                .get_ok(&format!(
                    "/v1/programs/{}/export?format={}",
                    p.id,
                    format.as_str()
                ))
                .await;
            out.insert((p.id, format.as_str()), export);
        }
    }
    out
}

/// An export, read back by our importer, gives the program's stored routines (their number
/// and, within the format's printed precision, every pose).
fn assert_export_reads_back(p: &OldProgram, format: Language, export: &Value) {
    let files: Vec<(String, String)> = export["files"]
        .as_array()
        .expect("files")
        .iter()
        .map(|f| {
            (
                f["file_name"].as_str().expect("name").to_string(),
                f["text"].as_str().expect("text").to_string(),
            )
        })
        .collect();
    let pairs: Vec<(&str, &str)> = files
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_str()))
        .collect();
    let back = parse_files(&pairs).expect("the export parses");
    assert_eq!(back.programs.len(), 1, "program {} {format:?}", p.id);
    let routines = &back.programs[0].program.routines;
    let stored: Vec<&OldRoutine> = p
        .routines
        .iter()
        .filter(|r| r.waypoints.len() >= 2)
        .collect();
    assert_eq!(routines.len(), stored.len(), "program {} {format:?}", p.id);
    let same = |r: &Routine<Waypoint>, s: &OldRoutine| {
        r.waypoints.len() == s.waypoints.len()
            && r.waypoints.iter().zip(&s.waypoints).all(|(w, sw)| {
                let old = nextpose::engine::Pose::new(
                    [sw.pose[0], sw.pose[1], sw.pose[2]],
                    [sw.pose[3], sw.pose[4], sw.pose[5], sw.pose[6]],
                )
                .expect("a stored pose");
                old.distance_to(&w.pose) <= position_tolerance_mm(format)
                    && old.angle_to(&w.pose) <= orientation_tolerance_rad(format)
            })
    };
    // RAPID and KRL keep the routines' order; FANUC's listings come back in file name order.
    let mut unmatched = stored.clone();
    for (k, r) in routines.iter().enumerate() {
        let at = match format {
            Language::Fanuc => unmatched.iter().position(|s| same(r, s)),
            _ => Some(k - (stored.len() - unmatched.len())).filter(|&i| same(r, unmatched[i])),
        };
        let at = at.unwrap_or_else(|| {
            panic!(
                "program {} {format:?}: routine {} does not read back as stored",
                p.id, r.name
            )
        });
        unmatched.remove(at);
    }
}

/// Two snapshots are equal, table by table; a difference names the table and its first
/// differing row.
fn assert_same(now: &Snapshot, before: &Snapshot, what: &str) {
    assert_eq!(
        now.keys().collect::<Vec<_>>(),
        before.keys().collect::<Vec<_>>(),
        "{what}: the tables"
    );
    for (table, rows) in before {
        let now = &now[table];
        let differs = rows.iter().zip(now).find(|(a, b)| a != b);
        assert!(
            differs.is_none() && rows.len() == now.len(),
            "{what}: table {table} ({} rows before, {} now), first difference {differs:?}",
            rows.len(),
            now.len()
        );
    }
}

/// Stops `app` and starts today's server again on the same database.
async fn restart(mut app: TestApp, old: &OldDatabase) -> TestApp {
    let token = app.token.clone();
    app.stop().await;
    old.serve(token.as_deref()).await
}

/// A prediction without its id (a GET records a new one each time).
fn without_id(mut p: Value) -> Value {
    p.as_object_mut().expect("prediction").remove("id");
    p
}

/// What every upgrade must keep, checked on `release`'s database.
async fn upgrade_keeps_everything(release: &Release) {
    let old = load(release).await;
    let mut sql = old.reader().await;
    let shape = sql.shape().await;
    let before = sql.snapshot(&shape).await;
    let programs = sql.programs().await;
    let last_cell = sql.last_cell_id().await;
    assert!(
        programs.len() >= 15,
        "{}: the dump's programs (15 imported, 2 taught)",
        release.name
    );
    let open: Vec<(i64, &OldRoutine)> = programs
        .iter()
        .flat_map(|p| p.routines.iter().map(move |r| (p.cell_id, r)))
        .filter(|(_, r)| r.open())
        .collect();
    assert!(!open.is_empty(), "{}: a routine being taught", release.name);
    let admin = release
        .tokens
        .iter()
        .find(|(name, _)| *name == "ada")
        .map(|(_, secret)| *secret);
    assert_eq!(admin.is_some(), !release.tokens.is_empty());

    // Today's server migrates it, and changes no row of the old tables by doing so.
    let app = old.serve(admin).await;
    let mut sql = old.reader().await;
    assert_eq!(sql.version().await, latest_version(old.engine));
    let failed = sql
        .texts("SELECT CAST(version AS TEXT) FROM _sqlx_migrations WHERE NOT success")
        .await;
    assert!(failed.is_empty(), "{failed:?}");
    assert_programs_read_back(&app, &programs).await;
    let exported = exports(&app, &programs).await;
    assert_same(
        &sql.snapshot(&shape).await,
        &before,
        &format!("{}: reading and exporting changed nothing", release.name),
    );

    // Each export reads back as the stored values, and a restarted server exports the same.
    for p in &programs {
        for format in Language::ALL {
            assert_export_reads_back(p, format, &exported[&(p.id, format.as_str())]);
        }
    }
    let app = restart(app, &old).await;
    assert_eq!(exports(&app, &programs).await, exported, "{}", release.name);
    assert_programs_read_back(&app, &programs).await;

    // History starts at revision 0, the program as it was.
    for p in &programs {
        let history = app.get_ok(&format!("/v1/programs/{}/history", p.id)).await;
        assert_eq!(history["revision"], 0, "program {}", p.id);
        assert_eq!(history["revisions"], json!([]), "program {}", p.id);
        assert_revision_zero_is(&app, p).await;
    }

    // Tokens authenticate with their secrets, with their role and cells; a revoked one not.
    // (A release before tokens had none: the service does not authenticate.)
    let had = |table: &str| shape.iter().any(|(t, _)| t == table);
    assert_eq!(
        had("tokens"),
        !release.tokens.is_empty(),
        "{}",
        release.name
    );
    assert_eq!(had("audit"), !release.tokens.is_empty(), "{}", release.name);
    let mut stored_tokens = 0;
    if release.tokens.is_empty() {
        let count = sql.texts("SELECT CAST(COUNT(*) AS TEXT) FROM tokens").await;
        assert_eq!(count[0][0], "0");
        assert_eq!(app.get_ok("/v1/whoami").await["name"], "anonymous");
    } else {
        let rows = sql
            .texts(
                "SELECT name, role, CAST(all_cells AS TEXT), \
                 CASE WHEN revoked_at IS NULL THEN 'active' ELSE 'revoked' END, \
                 CAST(id AS TEXT) FROM tokens ORDER BY tokens.id",
            )
            .await;
        for row in rows {
            let (name, role, all, state, id) = (&row[0], &row[1], &row[2], &row[3], &row[4]);
            let secret = release
                .tokens
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, s)| *s)
                .unwrap_or_else(|| panic!("{}: no secret kept for token {name}", release.name));
            let cells: Vec<i64> = sql
                .texts(&format!(
                    "SELECT CAST(cell_id AS TEXT) FROM token_cells WHERE token_id = {id} \
                     ORDER BY cell_id"
                ))
                .await
                .iter()
                .map(|c| c[0].parse().expect("cell"))
                .collect();
            let r = app
                .client
                .get(app.url("/v1/whoami"))
                .bearer_auth(secret)
                .send()
                .await
                .expect("request");
            if state == "revoked" {
                assert_eq!(r.status(), StatusCode::UNAUTHORIZED, "{name}");
                continue;
            }
            stored_tokens += 1;
            let me = expect(r, StatusCode::OK).await;
            assert_eq!(me["name"], name.as_str());
            assert_eq!(me["role"], role.as_str());
            assert_eq!(me["authenticated"], true);
            if all == "1" {
                assert_eq!(me["cells"], Value::Null, "{name}");
            } else {
                assert_eq!(me["cells"], json!(cells), "{name}");
            }
        }
        assert_eq!(stored_tokens, release.tokens.len() - 1, "{}", release.name);
    }

    // The audit rows survive, and the audit trail lists them (from the release before tokens,
    // an audit trail that starts empty).
    if release.tokens.is_empty() {
        let audit = app.get_ok("/v1/audit").await;
        assert_eq!(audit["entries"], json!([]), "{audit}");
    } else {
        let rows = sql
            .texts(
                "SELECT CAST(id AS TEXT), token, operation, COALESCE(target, ''), outcome \
                 FROM audit ORDER BY audit.id",
            )
            .await;
        assert!(
            rows.len() > 20,
            "{}: the session's audit rows",
            release.name
        );
        let mut listed = Vec::new();
        let mut before = None;
        loop {
            let page = app
                .get_ok(&match before {
                    Some(b) => format!("/v1/audit?limit=100&before={b}"),
                    None => "/v1/audit?limit=100".to_string(),
                })
                .await;
            for e in page["entries"].as_array().expect("entries") {
                listed.push(vec![
                    e["id"].as_i64().expect("id").to_string(),
                    e["token"].as_str().expect("token").to_string(),
                    e["operation"].as_str().expect("operation").to_string(),
                    e["target"].as_str().unwrap_or("").to_string(),
                    e["outcome"].as_str().expect("outcome").to_string(),
                ]);
            }
            match page["next"].as_i64() {
                Some(n) => before = Some(n),
                None => break,
            }
        }
        listed.sort_by_key(|row| row[0].parse::<i64>().expect("id"));
        assert_eq!(listed, rows, "{}", release.name);
        let names: Vec<&str> = rows.iter().map(|r| r[1].as_str()).collect();
        for who in ["bootstrap", "ada", "erin", "otto"] {
            assert!(names.contains(&who), "{}: {who}'s changes", release.name);
        }
    }

    // Predictions: each routine being taught is predicted as after a rebuild, and one the old
    // release offered a suggestion for (the dump's session made sure of one) as it did.
    let mut offered = Vec::new();
    for &(cell, r) in &open {
        let now = app
            .get_ok(&format!("/v1/routines/{}/prediction", r.id))
            .await["predictions"][0]
            .clone();
        if let Some(pose) = sql.recorded_prediction(r.id, r.waypoints.len()).await {
            assert_eq!(now["offered"], true, "routine {}: {now}", r.id);
            for (k, v) in POSE_KEYS.iter().zip(pose) {
                let got = now["pose"][k].as_f64().expect("pose");
                assert!(
                    (got - v).abs() <= 1e-9,
                    "routine {} {k}: {got} vs {v}",
                    r.id
                );
            }
            offered.push((cell, r));
        }
        app.rebuild(cell).await;
        let rebuilt = app
            .get_ok(&format!("/v1/routines/{}/prediction", r.id))
            .await["predictions"][0]
            .clone();
        assert_eq!(without_id(rebuilt), without_id(now), "routine {}", r.id);
    }

    // The routine being taught goes on: its next waypoint (the suggestion, accepted) is
    // numbered after the others, it finishes and is learned; its program's history now has
    // revisions, with revision 0 still the program as it was.
    let Some(&(cell, r)) = offered.first() else {
        panic!("{}: no offered prediction recorded", release.name);
    };
    let program = programs
        .iter()
        .find(|p| p.routines.iter().any(|x| x.id == r.id))
        .expect("its program");
    let next = app
        .get_ok(&format!("/v1/routines/{}/prediction", r.id))
        .await["predictions"][0]
        .clone();
    let taught = app.append(r.id, &next["pose"]).await;
    assert_eq!(
        taught["waypoint"]["seq"],
        json!(r.waypoints.len() + 1),
        "{taught}"
    );
    let model = app.get_ok(&format!("/v1/cells/{cell}/stats")).await["model"]["version"]
        .as_i64()
        .expect("model version");
    let finished = app.finish(r.id).await;
    assert!(
        finished["model"]["version"].as_i64().expect("version") > model,
        "{finished}"
    );
    let history = app
        .get_ok(&format!("/v1/programs/{}/history", program.id))
        .await;
    assert_eq!(history["revision"], 2, "{history}");
    assert_revision_zero_is(&app, program).await;

    // Ids are never reused: a new cell's id is after every cell's, deleted ones too.
    let cell = app.create_cell("after the upgrade").await;
    assert_eq!(cell, last_cell + 1);
}

/// `GET /v1/programs/{id}/history/0` is the program as the old release left it.
async fn assert_revision_zero_is(app: &TestApp, p: &OldProgram) {
    let zero = app
        .get_ok(&format!("/v1/programs/{}/history/0", p.id))
        .await;
    assert_eq!(zero["revision"], 0);
    let routines = zero["routines"].as_array().expect("routines");
    assert_eq!(routines.len(), p.routines.len(), "program {}", p.id);
    for (old, r) in p.routines.iter().zip(routines) {
        let at = format!("program {} revision 0, routine {}", p.id, old.id);
        assert_routine(old, r, &r["waypoints"], &at);
    }
}

#[tokio::test]
async fn a_database_of_the_release_before_tokens_upgrades_keeping_everything() {
    upgrade_keeps_everything(before_tokens()).await;
}

#[tokio::test]
async fn a_database_of_the_release_before_history_upgrades_keeping_everything() {
    upgrade_keeps_everything(before_history()).await;
}

/// Today's server's settings on `db`, as the test servers have them.
fn settings(db: &Database) -> ServerSettings {
    ServerSettings {
        database: db.clone(),
        durability: Durability::Process,
        addr: "127.0.0.1:0".into(),
        http: TransportOptions::default(),
        robots: None,
        backup_dir: None,
    }
}

/// sqlx's record of the migrations applied.
fn bookkeeping() -> Shape {
    vec![(
        "_sqlx_migrations".into(),
        vec!["version".into(), "checksum".into()],
    )]
}

/// The release before tokens, with something of the operator's in the way of an upgrade's
/// migration (`object`, created and given a row before the upgrade): start-up fails naming
/// that migration, and the database is as it was, schema, version and every row, the
/// migrations before it in the same upgrade included. Once it is out of the way, the upgrade
/// goes through.
async fn a_failed_migration_leaves_the_database_as_it_was(
    object: &str,
    migration: &str,
    undo: &str,
) {
    let release = before_tokens();
    let old = load(release).await;
    let mut sql = old.reader().await;
    sqlx::raw_sql(sqlx::AssertSqlSafe(object.to_string()))
        .execute(&mut sql.conn)
        .await
        .expect("the operator's object");
    let shape = sql.shape().await;
    let before = sql.snapshot(&shape).await;
    let migrations = sql.snapshot(&bookkeeping()).await;

    let Err(e) = Application::build(settings(&old.db)).await else {
        panic!("today's server started on a database whose migration {migration} fails");
    };
    let message = format!("{e:#}");
    assert_eq!(sql.version().await, release.version, "{message}");
    assert_eq!(
        sql.shape().await,
        shape,
        "the schema is as it was: {message}"
    );
    assert_same(
        &sql.snapshot(&shape).await,
        &before,
        "every row is as it was",
    );
    assert_eq!(sql.snapshot(&bookkeeping()).await, migrations);
    assert!(message.contains(migration), "{message}");
    assert!(
        message.contains(&format!("at migration {:04}", release.version)),
        "{message}"
    );

    sqlx::raw_sql(sqlx::AssertSqlSafe(undo.to_string()))
        .execute(&mut sql.conn)
        .await
        .expect("out of the way");
    let app = old.serve(None).await;
    assert_eq!(sql.version().await, latest_version(old.engine));
    assert!(sql.has_table("tokens").await && sql.has_table("audit").await);
    let programs = sql.programs().await;
    assert_programs_read_back(&app, &programs).await;
}

/// The first migration of the upgrade fails halfway: 0009 (tokens) has made its `tokens` table
/// and index when it finds a `token_cells` table there already.
#[tokio::test]
async fn a_migration_failing_halfway_leaves_the_database_as_it_was() {
    let (migration, table) = if on_postgres() {
        ("0003 (tokens)", "token_cells")
    } else {
        ("0009 (tokens)", "token_cells")
    };
    a_failed_migration_leaves_the_database_as_it_was(
        &format!(
            "CREATE TABLE {table} (note TEXT NOT NULL); \
             INSERT INTO {table} (note) VALUES ('the plant''s own table')"
        ),
        migration,
        &format!("DROP TABLE {table}"),
    )
    .await;
}

/// A later migration of the same upgrade fails halfway: 0010 (audit) has made its `audit`
/// table when its index's name is taken; 0009 (tokens), which went through, is not kept
/// either, so the release the database came from still opens it.
#[tokio::test]
async fn a_later_migration_failing_takes_the_whole_upgrade_back() {
    let migration = if on_postgres() {
        "0004 (audit)"
    } else {
        "0010 (audit)"
    };
    a_failed_migration_leaves_the_database_as_it_was(
        "CREATE INDEX audit_cell ON programs (name)",
        migration,
        "DROP INDEX audit_cell",
    )
    .await;
}
