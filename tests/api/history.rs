//! Program history (issue 31, item 3): every change to a program's routines or waypoints is a
//! revision; the program can be read as of any revision, two revisions diffed, and an earlier
//! one restored (as a new revision, the cell's model learned again).
//!
//! The property test drives a program through random teaching, edits and restores after an
//! import, snapshots the program (through the ordinary routes) after every step, and checks
//! that every step that changed it made exactly one revision, that each revision reads back as
//! its snapshot, that a restore gives its revision's waypoints exactly and leaves the cell's
//! model equal to a rebuild, and that a diff between any two revisions lists exactly what
//! differs between their snapshots.

use std::collections::{BTreeMap, BTreeSet};

use proptest::prelude::*;
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::helpers::*;

/// A waypoint as the routes show it: id, then the values a revision keeps.
type WaypointSnap = (i64, Value);

/// A routine: id, name, finished, waypoints in order.
#[derive(Debug, Clone, PartialEq)]
struct RoutineSnap {
    id: i64,
    name: Value,
    finished: bool,
    waypoints: Vec<WaypointSnap>,
}

/// The values of a waypoint that a revision keeps.
fn values(w: &Value) -> Value {
    json!([
        w["pose"],
        w["joints"],
        w["motion"],
        w["name"],
        w["reachable"]
    ])
}

/// The program as the ordinary routes show it now.
async fn snapshot(app: &TestApp, program: i64) -> Vec<RoutineSnap> {
    let list = app
        .get_ok(&format!("/v1/programs/{program}/routines"))
        .await;
    let mut out = Vec::new();
    for r in list.as_array().expect("routines") {
        let id = r["id"].as_i64().expect("id");
        let detail = app.get_ok(&format!("/v1/routines/{id}")).await;
        out.push(RoutineSnap {
            id,
            name: r["name"].clone(),
            finished: r["finished"].as_bool().expect("finished"),
            waypoints: detail["waypoints"]
                .as_array()
                .expect("waypoints")
                .iter()
                .map(|w| (w["id"].as_i64().expect("id"), values(w)))
                .collect(),
        });
    }
    out
}

/// The program as `GET /v1/programs/{id}/history/{revision}` shows it.
fn as_of(body: &Value) -> Vec<RoutineSnap> {
    body["routines"]
        .as_array()
        .expect("routines")
        .iter()
        .enumerate()
        .map(|(i, r)| {
            assert_eq!(r["position"], i + 1);
            let waypoints = r["waypoints"].as_array().expect("waypoints");
            for (j, w) in waypoints.iter().enumerate() {
                assert_eq!(w["seq"], j + 1);
            }
            RoutineSnap {
                id: r["id"].as_i64().expect("id"),
                name: r["name"].clone(),
                finished: r["finished"].as_bool().expect("finished"),
                waypoints: waypoints
                    .iter()
                    .map(|w| (w["id"].as_i64().expect("id"), values(w)))
                    .collect(),
            }
        })
        .collect()
}

/// Without whether each routine is finished (a restore keeps that as it is now).
fn content(s: &[RoutineSnap]) -> Vec<(i64, Value, Vec<WaypointSnap>)> {
    s.iter()
        .map(|r| (r.id, r.name.clone(), r.waypoints.clone()))
        .collect()
}

async fn last_revision(app: &TestApp, program: i64) -> i64 {
    app.get_ok(&format!("/v1/programs/{program}/history?limit=1"))
        .await["revision"]
        .as_i64()
        .expect("revision")
}

/// A RAPID module of two routines of `n` moves each, to import.
fn module(n: usize) -> String {
    let mut text = String::from("MODULE hist\n");
    let mut procs = String::new();
    for (r, proc) in ["pick", "place"].iter().enumerate() {
        procs.push_str(&format!("  PROC {proc}()\n"));
        for k in 0..n {
            let name = format!("p{r}{k}");
            text.push_str(&format!(
                "  CONST robtarget {name} := [[{},{},{}],[0,1,0,0],[0,0,0,0],\
                 [9E9,9E9,9E9,9E9,9E9,9E9]];\n",
                450 + 20 * k,
                -100 + 200 * r as i64,
                300 + 10 * (k % 2)
            ));
            procs.push_str(&format!("    MoveL {name}, v100, fine, tool0;\n"));
        }
        procs.push_str("  ENDPROC\n");
    }
    text.push_str(&procs);
    text.push_str("ENDMODULE\n");
    text
}

/// One step of a property-test sequence. Indices pick a routine and a waypoint modulo what
/// the program holds then; a step that does not apply is skipped (and must change nothing).
#[derive(Debug, Clone)]
enum Step {
    /// Starts a routine (when none is open) and teaches `n` waypoints; finishes it if asked.
    Teach {
        n: usize,
        finish: bool,
        by: [f64; 3],
    },
    Undo,
    Finish,
    Modify {
        routine: usize,
        waypoint: usize,
        by: [f64; 3],
    },
    Insert {
        routine: usize,
        waypoint: usize,
        after: bool,
        by: [f64; 3],
    },
    Delete {
        routine: usize,
        waypoint: usize,
    },
    Rename {
        routine: usize,
        name: Option<u8>,
    },
    /// Moves a routine, renaming it in the same request when `rename` (one revision).
    Move {
        routine: usize,
        to: usize,
        rename: bool,
    },
    DeleteRoutine {
        routine: usize,
    },
    /// Re-targets a routine: its moved copy is added at the end of the program.
    Retarget {
        routine: usize,
        by: [f64; 3],
    },
    /// Restores one of the revisions made so far.
    Restore {
        pick: usize,
    },
}

fn offset() -> impl Strategy<Value = [f64; 3]> {
    [-30.0..30.0f64, -30.0..30.0f64, -30.0..30.0f64]
}

fn step() -> impl Strategy<Value = Step> {
    let at = (0..8usize, 0..16usize);
    prop_oneof![
        3 => (1..5usize, any::<bool>(), offset()).prop_map(|(n, finish, by)| Step::Teach { n, finish, by }),
        1 => Just(Step::Undo),
        1 => Just(Step::Finish),
        3 => (at.clone(), offset()).prop_map(|((routine, waypoint), by)| Step::Modify { routine, waypoint, by }),
        2 => (at.clone(), any::<bool>(), offset())
            .prop_map(|((routine, waypoint), after, by)| Step::Insert { routine, waypoint, after, by }),
        2 => at.prop_map(|(routine, waypoint)| Step::Delete { routine, waypoint }),
        1 => (0..8usize, proptest::option::of(0..3u8)).prop_map(|(routine, name)| Step::Rename { routine, name }),
        1 => (0..8usize, 0..8usize, any::<bool>())
            .prop_map(|(routine, to, rename)| Step::Move { routine, to, rename }),
        1 => (0..8usize).prop_map(|routine| Step::DeleteRoutine { routine }),
        1 => (0..8usize, offset()).prop_map(|(routine, by)| Step::Retarget { routine, by }),
        3 => (0..64usize).prop_map(|pick| Step::Restore { pick }),
    ]
}

/// What a case knows: the program, its cell, and the snapshot of every revision made.
struct Case<'a> {
    app: &'a TestApp,
    cell: i64,
    program: i64,
    revisions: BTreeMap<i64, Vec<RoutineSnap>>,
}

impl Case<'_> {
    /// Applies a step through the API (nothing when it does not apply); returns how many
    /// revisions it makes (each waypoint taught is one, starting and finishing a routine one
    /// each).
    async fn apply(&mut self, step: &Step) -> i64 {
        let app = self.app;
        let now = snapshot(app, self.program).await;
        let open = now.iter().find(|r| !r.finished).cloned();
        let pick = |i: usize| now.get(i % now.len().max(1)).cloned();
        match *step {
            Step::Teach { n, finish, by } => {
                let (r, started) = match &open {
                    Some(r) => (r.id, 0),
                    None => (app.create_routine(self.program).await, 1),
                };
                for k in 0..n {
                    let shift = [by[0] + 15.0 * k as f64, by[1], by[2]];
                    app.append(
                        r,
                        &moved(&pose([500.0, 50.0, 320.0], [3.1, 0.0, 0.0]), shift),
                    )
                    .await;
                }
                if finish {
                    app.finish(r).await;
                }
                started + n as i64 + i64::from(finish)
            }
            Step::Undo => {
                let Some(r) = open.filter(|r| !r.waypoints.is_empty()) else {
                    return 0;
                };
                let path = format!("/v1/routines/{}/waypoints/last", r.id);
                expect(app.delete(&path).await, StatusCode::OK).await;
                1
            }
            Step::Finish => {
                let Some(r) = open.filter(|r| r.waypoints.len() >= 2) else {
                    return 0;
                };
                app.finish(r.id).await;
                1
            }
            Step::Modify {
                routine,
                waypoint,
                by,
            } => {
                let Some(r) = pick(routine).filter(|r| !r.waypoints.is_empty()) else {
                    return 0;
                };
                let (id, v) = &r.waypoints[waypoint % r.waypoints.len()];
                let body = json!({ "pose": moved(&v[0], by) });
                let path = format!("/v1/waypoints/{id}");
                expect(app.patch(&path, &body).await, StatusCode::OK).await;
                1
            }
            Step::Insert {
                routine,
                waypoint,
                after,
                by,
            } => {
                let Some(r) = pick(routine).filter(|r| !r.waypoints.is_empty()) else {
                    return 0;
                };
                let (id, v) = &r.waypoints[waypoint % r.waypoints.len()];
                let side = if after { "after" } else { "before" };
                let body = json!({ "side": side,
                    "waypoint": { "pose": moved(&v[0], by), "name": "ins", "motion": "joint" } });
                let path = format!("/v1/waypoints/{id}/insert");
                expect(app.post(&path, &body).await, StatusCode::CREATED).await;
                1
            }
            Step::Delete { routine, waypoint } => {
                let Some(r) = pick(routine).filter(|r| r.waypoints.len() > 2) else {
                    return 0;
                };
                let (id, _) = &r.waypoints[waypoint % r.waypoints.len()];
                expect(
                    app.delete(&format!("/v1/waypoints/{id}")).await,
                    StatusCode::OK,
                )
                .await;
                1
            }
            Step::Rename { routine, name } => {
                let Some(r) = pick(routine) else {
                    return 0;
                };
                let name = name.map(|k| format!("r{k}"));
                let path = format!("/v1/routines/{}", r.id);
                expect(
                    app.patch(&path, &json!({ "name": name })).await,
                    StatusCode::OK,
                )
                .await;
                i64::from(json!(name) != r.name)
            }
            Step::Move {
                routine,
                to,
                rename,
            } => {
                let Some(r) = pick(routine) else {
                    return 0;
                };
                let position = 1 + to % now.len();
                let mut body = json!({ "position": position });
                if rename {
                    body["name"] = json!(format!("m{to}"));
                }
                let path = format!("/v1/routines/{}", r.id);
                expect(app.patch(&path, &body).await, StatusCode::OK).await;
                let was = 1 + now.iter().position(|x| x.id == r.id).expect("there");
                let renamed = rename && body["name"] != r.name;
                i64::from(position != was || renamed)
            }
            Step::DeleteRoutine { routine } => {
                let Some(r) = pick(routine) else {
                    return 0;
                };
                let answer = app.delete(&format!("/v1/routines/{}", r.id)).await;
                assert_eq!(answer.status(), StatusCode::NO_CONTENT);
                1
            }
            Step::Retarget { routine, by } => {
                let Some(r) = pick(routine) else {
                    return 0;
                };
                let frame = moved(&pose([0.0; 3], [0.0; 3]), by);
                app.post_ok(
                    &format!("/v1/routines/{}/retarget", r.id),
                    &json!({ "frame": frame, "name": "moved" }),
                    StatusCode::CREATED,
                )
                .await;
                1
            }
            Step::Restore { pick } => {
                let keys: Vec<i64> = self.revisions.keys().copied().collect();
                let target = keys[pick % keys.len()];
                self.restore(target, &now).await
            }
        }
    }

    /// Restores `target` and checks the program, its history and the cell's model after;
    /// returns how many revisions it made.
    async fn restore(&mut self, target: i64, now: &[RoutineSnap]) -> i64 {
        let app = self.app;
        let want = self.revisions[&target].clone();
        let before = last_revision(app, self.program).await;
        let answer = app
            .post(
                &format!("/v1/programs/{}/restore", self.program),
                &json!({ "revision": target }),
            )
            .await;
        // A routine being taught then, gone now, cannot come back while another is taught.
        let back_open = want
            .iter()
            .any(|t| !t.finished && !now.iter().any(|r| r.id == t.id));
        let other_open = now
            .iter()
            .any(|r| !r.finished && want.iter().any(|t| t.id == r.id));
        if back_open && other_open {
            expect_error(answer, StatusCode::CONFLICT, "conflict").await;
            assert_eq!(snapshot(app, self.program).await, now, "a refused restore");
            return 0;
        }
        let done = expect(answer, StatusCode::OK).await;
        let after = snapshot(app, self.program).await;
        assert_eq!(content(&after), content(&want), "restored {target}");
        let changed = content(now) != content(&want);
        assert_eq!(done["changed"], changed, "{done}");
        assert_eq!(done["restored"], target);
        assert_eq!(done["revision"], before + i64::from(changed), "{done}");
        // The model is the one a rebuild from the database gives.
        let stats = app.get_ok(&format!("/v1/cells/{}/stats", self.cell)).await;
        let open = after
            .iter()
            .find(|r| !r.finished && !r.waypoints.is_empty());
        let predicted = match open {
            Some(r) => Some(
                app.get_ok(&format!("/v1/routines/{}/prediction", r.id))
                    .await,
            ),
            None => None,
        };
        let rebuilt = app.rebuild(self.cell).await;
        assert_eq!(rebuilt["version"], stats["model"]["version"]);
        let again = app.get_ok(&format!("/v1/cells/{}/stats", self.cell)).await;
        assert_eq!(model(&again), model(&stats), "after restoring {target}");
        if let (Some(r), Some(p)) = (open, predicted) {
            let q = app
                .get_ok(&format!("/v1/routines/{}/prediction", r.id))
                .await;
            for k in ["pose", "p_useful", "expert", "offered"] {
                assert_eq!(p["predictions"][0][k], q["predictions"][0][k], "{k}");
            }
        }
        i64::from(changed)
    }

    /// Records the program after a step that made `made` revisions: one that changed it made
    /// some, one that did not, none.
    async fn record(&mut self, step: &Step, made: i64) {
        let now = snapshot(self.app, self.program).await;
        let revision = last_revision(self.app, self.program).await;
        let (last, before) = self
            .revisions
            .last_key_value()
            .map(|(k, v)| (*k, v.clone()))
            .expect("revision 1, the import");
        assert_eq!(revision, last + made, "{step:?}");
        if made == 0 {
            assert_eq!(now, before, "{step:?} made no revision");
        } else {
            assert_ne!(now, before, "{step:?} made a revision");
            self.revisions.insert(revision, now);
        }
    }
}

fn model(stats: &Value) -> Value {
    let m = &stats["model"];
    json!([
        m["version"],
        m["states"],
        m["edges"],
        m["routines"],
        m["depth"],
        m["observations"]
    ])
}

/// The ids and values of every waypoint of a snapshot.
fn waypoints(s: &[RoutineSnap]) -> BTreeMap<i64, Value> {
    s.iter().flat_map(|r| r.waypoints.iter().cloned()).collect()
}

fn ids(list: &Value) -> BTreeSet<i64> {
    list.as_array()
        .expect("list")
        .iter()
        .map(|w| w["id"].as_i64().expect("id"))
        .collect()
}

async fn check_history(case: &Case<'_>) {
    let app = case.app;
    let p = case.program;
    // Each revision reads back as its snapshot (finished flags included), and revision 0 is
    // the program before the import made it.
    for (revision, snap) in &case.revisions {
        let body = app
            .get_ok(&format!("/v1/programs/{p}/history/{revision}"))
            .await;
        assert_eq!(&as_of(&body), snap, "revision {revision}");
    }
    let empty = app.get_ok(&format!("/v1/programs/{p}/history/0")).await;
    assert!(as_of(&empty).is_empty());
    // Every revision is listed once, newest first, in pages.
    let mut listed = Vec::new();
    let mut next = None::<i64>;
    loop {
        let page = match next {
            Some(b) => format!("/v1/programs/{p}/history?limit=3&before={b}"),
            None => format!("/v1/programs/{p}/history?limit=3"),
        };
        let body = app.get_ok(&page).await;
        for r in body["revisions"].as_array().expect("revisions") {
            assert!(!r["changes"].as_array().expect("changes").is_empty());
            listed.push(r["revision"].as_i64().expect("revision"));
        }
        match body["next"].as_i64() {
            Some(b) => next = Some(b),
            None => break,
        }
    }
    let last = *case.revisions.keys().last().expect("a revision");
    assert_eq!(listed, (1..=last).rev().collect::<Vec<_>>());
    // A diff between two revisions lists exactly what differs between their snapshots.
    let keys: Vec<i64> = case.revisions.keys().copied().collect();
    for (k, a) in keys.iter().enumerate() {
        let b = keys[(k * 7 + 3) % keys.len()];
        let d = app
            .get_ok(&format!("/v1/programs/{p}/diff?from={a}&to={b}"))
            .await;
        let (old, new) = (
            waypoints(&case.revisions[a]),
            waypoints(&case.revisions[&b]),
        );
        let added: BTreeSet<i64> = new
            .keys()
            .filter(|i| !old.contains_key(i))
            .copied()
            .collect();
        let removed: BTreeSet<i64> = old
            .keys()
            .filter(|i| !new.contains_key(i))
            .copied()
            .collect();
        let changed: BTreeSet<i64> = new
            .iter()
            .filter(|(i, v)| old.get(i).is_some_and(|o| o != *v))
            .map(|(i, _)| *i)
            .collect();
        assert_eq!(ids(&d["waypoints_added"]), added, "{a} → {b}");
        assert_eq!(ids(&d["waypoints_removed"]), removed, "{a} → {b}");
        assert_eq!(ids(&d["waypoints_changed"]), changed, "{a} → {b}");
        let routines = |s: &[RoutineSnap]| s.iter().map(|r| r.id).collect::<BTreeSet<i64>>();
        let (ra, rb) = (routines(&case.revisions[a]), routines(&case.revisions[&b]));
        assert_eq!(
            ids(&d["routines_added"]),
            rb.difference(&ra).copied().collect()
        );
        assert_eq!(
            ids(&d["routines_removed"]),
            ra.difference(&rb).copied().collect()
        );
        for c in d["waypoints_changed"].as_array().expect("changed") {
            let id = c["id"].as_i64().expect("id");
            let moved = old[&id][0] != new[&id][0];
            assert_eq!(c["moved_mm"].as_f64().expect("mm") > 0.0, moved, "{c}");
        }
    }
}

async fn run_case(app: &TestApp, n: usize, steps: &[Step]) {
    let cell = app.create_cell(&format!("history-{n}")).await;
    let imported = app
        .import(
            cell,
            &json!({ "files": [{ "name": "hist.mod", "content": module(4) }] }),
        )
        .await;
    let program = imported["programs"][0]["program"]["id"]
        .as_i64()
        .expect("program");
    let mut case = Case {
        app,
        cell,
        program,
        revisions: BTreeMap::new(),
    };
    assert_eq!(
        last_revision(app, program).await,
        1,
        "the import is revision 1"
    );
    case.revisions.insert(1, snapshot(app, program).await);
    for step in steps {
        let made = case.apply(step).await;
        case.record(step, made).await;
    }
    check_history(&case).await;
}

/// The property test of the module doc; each case is a new cell on one server.
#[test]
fn any_revision_reads_back_restores_exactly_and_diffs_exactly() {
    let rt = tokio::runtime::Runtime::new().expect("runtime");
    let app = rt.block_on(spawn_app());
    each_case(24, proptest::collection::vec(step(), 1..16), |n, steps| {
        rt.block_on(run_case(&app, n, &steps))
    });
}

/// Sends `method path body` as the token `secret` with the request id `id`.
async fn send_as(
    app: &TestApp,
    method: reqwest::Method,
    path: &str,
    body: &Value,
    secret: &str,
    id: &str,
) -> Value {
    let r = app
        .client
        .request(method, app.url(path))
        .bearer_auth(secret)
        .header("x-request-id", id)
        .json(body)
        .send()
        .await
        .expect("request");
    assert!(r.status().is_success(), "{path}: {}", r.status());
    r.json().await.expect("json")
}

/// The history says who changed what, in which request; an export and a read as of a
/// revision give the program then; a diff measures how far a waypoint moved and turned.
#[tokio::test]
async fn the_history_says_who_changed_what_and_reads_as_of_a_revision() {
    use reqwest::Method;
    let mut app = spawn_with(nextpose::transport::TransportOptions {
        token: Some(crate::roles::BOOTSTRAP.into()),
        ..Default::default()
    })
    .await;
    app.token = Some(crate::roles::BOOTSTRAP.into());
    let cell = app.create_cell("who").await;
    let program = app.create_program(cell, "weld").await;
    let otto = crate::roles::secret(&app, "otto", "operator", Some(vec![cell])).await;
    let erin = crate::roles::secret(&app, "erin", "engineer", None).await;
    assert_eq!(
        last_revision(&app, program).await,
        0,
        "a new program has none"
    );

    let r = send_as(
        &app,
        Method::POST,
        &format!("/v1/programs/{program}/routines"),
        &json!({ "name": "seam" }),
        &otto,
        "start-1",
    )
    .await["id"]
        .as_i64()
        .expect("id");
    let seam = u_seam([400.0, 0.0, 300.0], 0.0);
    let mut ids = Vec::new();
    for (k, p) in seam.iter().enumerate() {
        let t = send_as(
            &app,
            Method::POST,
            &format!("/v1/routines/{r}/waypoints"),
            &json!({ "pose": p }),
            &otto,
            &format!("teach-{k}"),
        )
        .await;
        ids.push(t["waypoint"]["id"].as_i64().expect("id"));
    }
    send_as(
        &app,
        Method::POST,
        &format!("/v1/routines/{r}/finish"),
        &json!({}),
        &otto,
        "done",
    )
    .await;
    let taught = last_revision(&app, program).await;
    assert_eq!(taught, 1 + seam.len() as i64 + 1);
    // Erin moves the third waypoint 30 mm along x and turns it 10° about z.
    let before = app.get_ok(&format!("/v1/routines/{r}")).await["waypoints"][2].clone();
    let p = &before["pose"];
    let turn = nextpose::engine::Pose::new(
        [0.0; 3],
        [
            (5.0f64.to_radians()).cos(),
            0.0,
            0.0,
            (5.0f64.to_radians()).sin(),
        ],
    )
    .expect("turn");
    let was = pose_of(p);
    let after = nextpose::engine::Pose::from_isometry(
        nextpose::engine::Pose::new(
            [was.position().x + 30.0, was.position().y, was.position().z],
            {
                let q = was.rotation() * turn.rotation();
                [q.w, q.i, q.j, q.k]
            },
        )
        .expect("pose")
        .isometry()
        .to_owned(),
    )
    .values();
    send_as(
        &app,
        Method::PATCH,
        &format!("/v1/waypoints/{}", ids[2]),
        &json!({ "pose": after }),
        &erin,
        "modify-1",
    )
    .await;

    let history = app.get_ok(&format!("/v1/programs/{program}/history")).await;
    assert_eq!(history["revision"], taught + 1);
    let revisions = history["revisions"].as_array().expect("revisions");
    let newest = &revisions[0];
    assert_eq!(newest["token"], "erin");
    assert_eq!(newest["request_id"], "modify-1");
    assert_eq!(newest["operation"], "PATCH /v1/waypoints/{waypoint_id}");
    assert_eq!(newest["changes"][0]["change"], "waypoint_modified");
    assert_eq!(newest["changes"][0]["waypoint_id"], ids[2]);
    let finish = &revisions[1];
    assert_eq!(
        (finish["token"].as_str(), finish["request_id"].as_str()),
        (Some("otto"), Some("done"))
    );
    assert_eq!(finish["changes"][0]["change"], "routine_finished");
    let third = &revisions[revisions.len() - 4];
    assert_eq!(third["request_id"], "teach-2");
    assert_eq!(
        third["changes"][0],
        json!({ "change": "waypoint_added", "routine_id": r,
        "waypoint_id": null, "place": 3, "waypoints": null })
    );
    let first = revisions.last().expect("first");
    assert_eq!(first["revision"], 1);
    assert_eq!(first["request_id"], "start-1");
    assert_eq!(first["changes"][0]["change"], "routine_added");

    // As of the revision before the edit: the pose then, in a read and in an export.
    let then = app
        .get_ok(&format!("/v1/programs/{program}/history/{taught}"))
        .await;
    assert_eq!(then["routines"][0]["waypoints"][2]["pose"], before["pose"]);
    assert_eq!(then["routines"][0]["name"], "seam");
    assert_eq!(then["routines"][0]["finished"], true);
    let x = |v: &Value| format!("{:.2}", v["x"].as_f64().expect("x"));
    let old = app
        .get_ok(&format!(
            "/v1/programs/{program}/export?format=rapid&revision={taught}"
        ))
        .await["files"][0]["text"]
        .as_str()
        .expect("text")
        .to_string();
    let new = app
        .get_ok(&format!("/v1/programs/{program}/export?format=rapid"))
        .await["files"][0]["text"]
        .as_str()
        .expect("text")
        .to_string();
    assert!(
        old.contains(&x(&before["pose"])) && !old.contains(&x(&json!(after))),
        "{old}"
    );
    assert!(new.contains(&x(&json!(after))), "{new}");
    // While it was taught: open, and only its first waypoints.
    let midway = app
        .get_ok(&format!("/v1/programs/{program}/history/4"))
        .await;
    assert_eq!(midway["routines"][0]["finished"], false);
    assert_eq!(
        midway["routines"][0]["waypoints"].as_array().map(Vec::len),
        Some(3)
    );

    let diff = app
        .get_ok(&format!("/v1/programs/{program}/diff?from={taught}"))
        .await;
    let changed = &diff["waypoints_changed"][0];
    assert_eq!(diff["waypoints_changed"].as_array().map(Vec::len), Some(1));
    assert_eq!(changed["id"], ids[2]);
    assert!(
        (changed["moved_mm"].as_f64().expect("mm") - 30.0).abs() < 1e-9,
        "{changed}"
    );
    assert!(
        (changed["turned_degrees"].as_f64().expect("deg") - 10.0).abs() < 1e-6,
        "{changed}"
    );
    assert_eq!(changed["fields"], json!(["pose"]));
    // Storage is proportional to the change: each revision's row is short, however long the
    // program (every row of the table as the database writes it as text).
    let rows: Vec<String> = crate::roles::dump(&app)
        .await
        .into_iter()
        .filter(|l| l.starts_with("program_history"))
        .collect();
    assert_eq!(rows.len() as i64, taught + 1);
    let longest = rows.iter().map(String::len).max().unwrap_or_default();
    assert!(longest < 700, "{longest} characters: {rows:?}");
    let whole = app
        .get_ok(&format!("/v1/programs/{program}/diff?from=0"))
        .await;
    assert_eq!(whole["routines_added"][0]["id"], r);
    assert_eq!(ids_of(&whole["waypoints_added"]), ids);
}

fn ids_of(list: &Value) -> Vec<i64> {
    list.as_array()
        .expect("list")
        .iter()
        .map(|w| w["id"].as_i64().expect("id"))
        .collect()
}

/// Bad history requests are refused with a 4xx naming the problem and change nothing; a
/// restore that would bring back a routine being taught while another is taught is a 409; a
/// deleted program's history goes with it.
#[tokio::test]
async fn bad_history_requests_are_refused_and_change_nothing() {
    let app = spawn_app().await;
    let cell = app.create_cell("bad-history").await;
    let program = app.create_program(cell, "p").await;
    let first = app.create_routine(program).await;
    for p in &u_seam([400.0, 0.0, 300.0], 0.0)[..3] {
        app.append(first, p).await;
    }
    let with_first_open = last_revision(&app, program).await;
    let r = app.delete(&format!("/v1/routines/{first}")).await;
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    app.teach_routine(program, &u_seam([450.0, 0.0, 300.0], 0.0))
        .await;
    // The cell's one routine being taught is now in another program.
    let other = app.create_program(cell, "other").await;
    let second = app.create_routine(other).await;
    app.append(second, &u_seam([500.0, 0.0, 300.0], 0.0)[0])
        .await;
    let before = (
        snapshot(&app, program).await,
        app.get_ok(&format!("/v1/programs/{program}/history")).await,
    );
    let p = format!("/v1/programs/{program}");
    for (path, status, says) in [
        (
            format!("{p}/history/99"),
            StatusCode::NOT_FOUND,
            "no revision 99",
        ),
        (
            format!("{p}/history/-1"),
            StatusCode::UNPROCESSABLE_ENTITY,
            "no revision -1",
        ),
        (
            format!("{p}/history?limit=0"),
            StatusCode::UNPROCESSABLE_ENTITY,
            "limit",
        ),
        (
            format!("{p}/history?before=0"),
            StatusCode::UNPROCESSABLE_ENTITY,
            "before",
        ),
        (
            format!("{p}/history?colour=red"),
            StatusCode::BAD_REQUEST,
            "colour",
        ),
        (
            format!("{p}/diff?from=99"),
            StatusCode::NOT_FOUND,
            "no revision 99",
        ),
        (format!("{p}/diff"), StatusCode::BAD_REQUEST, "from"),
        (
            format!("{p}/export?format=rapid&revision=99"),
            StatusCode::NOT_FOUND,
            "no revision 99",
        ),
        (
            "/v1/programs/9999/history".to_string(),
            StatusCode::NOT_FOUND,
            "program 9999",
        ),
        (
            "/v1/programs/9999/history/0".to_string(),
            StatusCode::NOT_FOUND,
            "program 9999",
        ),
    ] {
        let r = app.get(&path).await;
        assert_eq!(r.status(), status, "{path}");
        let body: Value = r.json().await.expect("json");
        let text = body.to_string();
        assert!(text.contains(says), "{path}: {text}");
    }
    for (body, status, says) in [
        (
            json!({ "revision": 99 }),
            StatusCode::NOT_FOUND,
            "no revision 99",
        ),
        (
            json!({ "revision": -3 }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "no revision -3",
        ),
        (
            json!({ "revision": 1, "force": true }),
            StatusCode::UNPROCESSABLE_ENTITY,
            "force",
        ),
        (
            json!({ "revision": with_first_open }),
            StatusCode::CONFLICT,
            "being taught",
        ),
    ] {
        let r = app.post(&format!("{p}/restore"), &body).await;
        assert_eq!(r.status(), status, "{body}");
        let text = r.text().await.expect("text");
        assert!(text.contains(says), "{body}: {text}");
    }
    let after = (
        snapshot(&app, program).await,
        app.get_ok(&format!("/v1/programs/{program}/history")).await,
    );
    assert_eq!(before, after);
    // Once the routine being taught now is finished, the other comes back, still open, and
    // the routine taught since it was goes.
    app.finish(second).await;
    let done = app
        .post_ok(
            &format!("{p}/restore"),
            &json!({ "revision": with_first_open }),
            StatusCode::OK,
        )
        .await;
    assert_eq!(done["changed"], true);
    let back = snapshot(&app, program).await;
    assert_eq!(
        back.iter().map(|r| (r.id, r.finished)).collect::<Vec<_>>(),
        vec![(first, false)]
    );
    assert_eq!(back[0].waypoints.len(), 3);
    // Restoring what it is already changes nothing.
    let same = app
        .post_ok(
            &format!("{p}/restore"),
            &json!({ "revision": with_first_open }),
            StatusCode::OK,
        )
        .await;
    assert_eq!(same["changed"], false);
    assert_eq!(same["revision"], done["revision"]);

    let r = app.delete(&p).await;
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    let r = app.get(&format!("{p}/history")).await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND);
}
