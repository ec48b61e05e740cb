//! The simulated operator teaching real corpus programs against the real server (loopback
//! port, temporary SQLite file): the end-to-end test of cells, import, teaching, predictions,
//! reachability, feedback, stats and rebuild, over REST and over gRPC. Times are simulated, never measured; nothing
//! sleeps. The corpus is read from `../shared/corpus` and never written.

use std::collections::BTreeMap;
use std::sync::Mutex;

use nextpose::api::{CreateProgram, CreateRoutine, NewWaypoint, PredictQuery, Prediction};
use nextpose::client::{Client, RestClient, Transport};
use nextpose::kinematics::ReachPolicy;
use nextpose::kinematics::placement::{HeuristicSetup, PlacedArm, ReachCheck, ReachSetup};
use nextpose::replay::{Program, load_paths};
use nextpose::simulation::{
    Condition, Decision, History, JogLimits, OperatorModel, Plan, RoutineResult,
    table_4_1_conditions,
};
use nextpose::simulation_driver::{
    LocalServer, Session, SessionOutcome, Warmup, placements, run_session,
};

use crate::corpus;

const TEMPLATE: &str =
    "zwj12__AddInPackages__ZhongXun__Source__RAPID__TASK1__PROGMOD__Template_20023_Module.mod.json";
const PALLETIZING: &str = "djordjeristic04__Robotic-Palletizing-System__PlacePaths.mod.json";
const MODULE: &str = "jvalta__Robottijarjestelmaprojekti__Module1.mod.json";

fn program(name: &str) -> Program {
    let path = corpus::json().join(name);
    load_paths(&[path]).expect("corpus program").remove(0)
}

fn plan(operator: OperatorModel, policy: ReachPolicy) -> Plan {
    Plan {
        conditions: table_4_1_conditions(),
        seeds: vec![1],
        operator,
        limits: JogLimits::default(),
        history: History::None,
        reach_policy: policy,
        calibrate_sigma: true,
    }
}

fn precise() -> OperatorModel {
    OperatorModel::precise(JogLimits::default().tcp_mm_s)
}

fn online() -> OperatorModel {
    OperatorModel::online(JogLimits::default().tcp_mm_s)
}

fn condition(key: &str) -> Condition {
    table_4_1_conditions()
        .into_iter()
        .find(|c| c.key == key)
        .expect("condition")
}

/// The program's arm and placement, searched once per program (`simulation_driver::placements`).
fn arm(program: &Program) -> PlacedArm {
    static ARMS: Mutex<BTreeMap<String, PlacedArm>> = Mutex::new(BTreeMap::new());
    let mut arms = ARMS.lock().unwrap_or_else(|e| e.into_inner());
    arms.entry(program.name.clone())
        .or_insert_with(|| {
            placements(std::slice::from_ref(program))
                .expect("a placement")
                .remove(0)
        })
        .clone()
}

/// A session in its own, uniquely named cell.
fn session(plan: &Plan, key: &str, program: &Program, seed: u64, cell: &str) -> Session {
    Session {
        arm: arm(program),
        condition: condition(key),
        program: program.clone(),
        program_index: 0,
        seed,
        warmup: Warmup::None,
        reach_policy: plan.reach_policy,
        cell_name: cell.to_string(),
    }
}

fn total(o: &SessionOutcome, f: fn(&RoutineResult) -> usize) -> usize {
    o.routines.iter().map(f).sum()
}

fn time(o: &SessionOutcome) -> f64 {
    o.routines.iter().map(|r| r.time_s).sum()
}

/// A prediction without the id the server gave its record (a new record gets a new id).
fn without_ids(mut ps: Vec<Prediction>) -> Vec<Prediction> {
    for p in &mut ps {
        p.id = None;
    }
    ps
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn three_corpus_programs_end_to_end() {
    let server = LocalServer::start().await.expect("server");
    let client = RestClient::new(&server.base, None);
    let driver = Client::from(client.clone());
    let plan = plan(precise(), ReachPolicy::Withhold);
    for (i, name) in [TEMPLATE, PALLETIZING, MODULE].into_iter().enumerate() {
        let p = program(name);
        let o = run_session(&driver, &plan, &session(&plan, "default", &p, 1, name))
            .await
            .expect("session");
        let (offered, accepted, adjusted, rejected) = (
            total(&o, |r| r.offered),
            total(&o, |r| r.accepted),
            total(&o, |r| r.adjusted),
            total(&o, |r| r.rejected),
        );

        // Repeated patterns are predicted, and predicted right: an accepted suggestion is within
        // 1 mm and 0.1 rad of the waypoint the operator intended.
        assert!(
            accepted >= 1,
            "{name}: offered {offered}, accepted {accepted}"
        );
        let shown: Vec<_> = o.predictions.iter().filter(|p| p.offered).collect();
        assert_eq!(shown.len(), offered);
        assert!(
            shown.iter().all(|p| p.decision.is_some()),
            "{name}: every offered suggestion gets a decision"
        );

        // Under the default policy nothing out of the arm's reach is offered.
        assert!(
            shown.iter().all(|p| p.reachable == Some(true)),
            "{name}: an offered suggestion is not reachable"
        );
        assert_eq!(total(&o, |r| r.offered_unreachable), 0);
        // The arm fitted to the program (`simulation_driver::placements`) reaches all of it.
        assert_eq!(
            total(&o, |r| r.unreachable_waypoints),
            0,
            "{name}: taught waypoints out of the fitted arm's reach"
        );

        // The cell's statistics count exactly what the operator did.
        let f = &o.stats.feedback;
        assert_eq!(f.offered as usize, offered, "{name}");
        assert_eq!(f.accepted as usize, accepted, "{name}");
        assert_eq!(f.adjusted as usize, adjusted, "{name}");
        assert_eq!(f.rejected as usize, rejected, "{name}");
        assert_eq!(f.pending, 0, "{name}");
        assert_eq!(offered, accepted + adjusted + rejected);
        assert_eq!(o.stats.model.routines as usize, p.routines.len());

        // The model after the session is the one a rebuild from the database gives: the same
        // figures, and the same predictions for a routine that repeats the program's start.
        let program = CreateProgram {
            name: "rebuild check".into(),
        };
        let pid = client
            .create_program(o.stats.cell_id, &program)
            .await
            .expect("program")
            .id;
        let again = CreateRoutine {
            name: Some("again".into()),
        };
        let rid = client
            .create_routine(pid, &again)
            .await
            .expect("routine")
            .id;
        let first = &p.routines[0].waypoints;
        for w in first.iter().take(3.min(first.len())) {
            client
                .append(rid, &NewWaypoint::at(w))
                .await
                .expect("append");
        }
        let before_model = client.stats(o.stats.cell_id).await.expect("stats").model;
        let k3 = PredictQuery {
            k: Some(3),
            ..Default::default()
        };
        let before = client.predict(rid, &k3).await.expect("predict").predictions;
        let rebuilt = client.rebuild(o.stats.cell_id).await.expect("rebuild");
        let after = client.predict(rid, &k3).await.expect("predict").predictions;
        assert_eq!(rebuilt, before_model, "{name}: the rebuilt model differs");
        assert_eq!(without_ids(before), without_ids(after), "{name}");
        assert_eq!(o.stats.model.routines, before_model.routines, "{name}");
        eprintln!(
            "{i} {name}: {offered} offered, {accepted} accepted, {adjusted} adjusted, \
             {rejected} rejected"
        );
    }
    server.stop().await.expect("stop");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn the_reach_policy_withholds_exactly_what_it_would_flag() {
    let server = LocalServer::start().await.expect("server");
    let client = RestClient::new(&server.base, None);
    let driver = Client::from(client.clone());
    let p = program(TEMPLATE);
    let withhold = plan(precise(), ReachPolicy::Withhold);
    let flag = plan(precise(), ReachPolicy::Flag);
    let key = "seed_phi05_h2";
    // An arm too small for the program, so that some suggestions fall out of its reach: the
    // IRB 140 at the median heuristic (what the simulation used before the arm library), which
    // reaches 71 of the 82 taught waypoints.
    let small = ReachCheck::new(ReachSetup::Heuristic(HeuristicSetup::default()))
        .expect("the IRB 140 loads")
        .place("rapid", None, &p.poses().copied().collect::<Vec<_>>())
        .expect("placed")
        .expect("an arm for RAPID");
    assert!(small.arm.reached < small.arm.waypoints);
    let in_small = |plan: &Plan, cell: &str| Session {
        arm: small.clone(),
        ..session(plan, key, &p, 1, cell)
    };
    let w = run_session(&driver, &withhold, &in_small(&withhold, "withhold"))
        .await
        .expect("session");
    let f = run_session(&driver, &flag, &in_small(&flag, "flag"))
        .await
        .expect("session");
    // A flagged suggestion is rejected after a look, so the operator teaches the same poses
    // either way and the service makes the same predictions; only the offering differs.
    let withheld: Vec<(usize, usize)> = w
        .predictions
        .iter()
        .filter(|p| p.withheld.as_deref() == Some("unreachable"))
        .map(|p| (p.routine_index, p.after_waypoints))
        .collect();
    let flagged: Vec<(usize, usize)> = f
        .predictions
        .iter()
        .filter(|p| p.offered && p.reachable == Some(false))
        .map(|p| (p.routine_index, p.after_waypoints))
        .collect();
    assert!(
        !withheld.is_empty(),
        "this program has suggestions out of reach"
    );
    assert_eq!(withheld, flagged);
    assert!(
        w.predictions
            .iter()
            .filter(|p| p.offered)
            .all(|p| p.reachable == Some(true))
    );
    assert!(
        f.predictions
            .iter()
            .filter(|p| p.offered && p.reachable == Some(false))
            .all(|p| p.decision == Some(Decision::Reject) || p.decision == Some(Decision::Dismiss))
    );
    assert_eq!(total(&f, |r| r.offered_unreachable), flagged.len());
    assert_eq!(
        total(&f, |r| r.offered),
        total(&w, |r| r.offered) + flagged.len()
    );
    // Looking at a suggestion that cannot be reached costs time.
    assert!(time(&f) > time(&w));
    server.stop().await.expect("stop");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn sessions_are_deterministic_given_a_seed() {
    let server = LocalServer::start().await.expect("server");
    let client = RestClient::new(&server.base, None);
    let driver = Client::from(client.clone());
    let plan = plan(online(), ReachPolicy::Withhold);
    let p = program(MODULE);
    let key = "seed_phi05_h2";
    let a = run_session(&driver, &plan, &session(&plan, key, &p, 7, "a"))
        .await
        .expect("session");
    let b = run_session(&driver, &plan, &session(&plan, key, &p, 7, "b"))
        .await
        .expect("session");
    let c = run_session(&driver, &plan, &session(&plan, key, &p, 8, "c"))
        .await
        .expect("session");
    assert_eq!(a.routines, b.routines);
    assert_eq!(a.predictions, b.predictions);
    assert_eq!(a.stats.model, b.stats.model);
    assert_eq!(a.stats.feedback, b.stats.feedback);
    assert_ne!(
        time(&a),
        time(&c),
        "another seed places the waypoints differently"
    );
    assert!(total(&a, |r| r.offered) > 0);
    server.stop().await.expect("stop");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn suggestions_save_time_only_when_shown() {
    let server = LocalServer::start().await.expect("server");
    let client = RestClient::new(&server.base, None);
    let driver = Client::from(client.clone());
    let plan = plan(precise(), ReachPolicy::Withhold);
    let p = program(PALLETIZING);
    let none = run_session(&driver, &plan, &session(&plan, "none", &p, 1, "none"))
        .await
        .expect("session");
    let default = run_session(&driver, &plan, &session(&plan, "default", &p, 1, "default"))
        .await
        .expect("session");
    // Without suggestions the operator gives no feedback; the service's suggestions stay
    // pending, and every waypoint is taught by hand.
    assert_eq!(total(&none, |r| r.accepted + r.adjusted + r.rejected), 0);
    assert_eq!(none.stats.feedback.pending, none.stats.feedback.offered);
    assert!(none.predictions.iter().all(|p| p.decision.is_none()));
    assert!(none.routines.iter().all(|r| r.time.look_s == 0.0));
    // With them, accepted suggestions replace the aiming: the program takes less time.
    assert!(total(&default, |r| r.accepted) > 0);
    assert!(
        time(&default) < time(&none),
        "{} vs {}",
        time(&default),
        time(&none)
    );
    server.stop().await.expect("stop");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn an_imported_offline_program_warms_the_cell_up() {
    let server = LocalServer::start().await.expect("server");
    let client = RestClient::new(&server.base, None);
    let driver = Client::from(client.clone());
    let plan = plan(precise(), ReachPolicy::Withhold);
    let raw = corpus::raw().join(
        "zwj12__AddInPackages/ZhongXun__Source__RAPID__TASK1__PROGMOD__Template_20014_Module.mod",
    );
    let text = std::fs::read_to_string(&raw).expect("raw program");
    let p = program(TEMPLATE);
    let fresh = run_session(&driver, &plan, &session(&plan, "default", &p, 1, "fresh"))
        .await
        .expect("session");
    let mut s = session(&plan, "default", &p, 1, "warmed up");
    s.warmup = Warmup::Import(vec![("Template_20014_Module.mod".into(), text)]);
    let warmed = run_session(&driver, &plan, &s).await.expect("session");
    // The imported routines are learned before the operator starts.
    assert!(warmed.stats.model.routines > fresh.stats.model.routines);
    let first_routine = |o: &SessionOutcome| o.routines[0].offered;
    eprintln!(
        "first routine offered: fresh {}, warmed up {}; total fresh {}, warmed up {}",
        first_routine(&fresh),
        first_routine(&warmed),
        total(&fresh, |r| r.offered),
        total(&warmed, |r| r.offered)
    );
    assert!(warmed.stats.feedback.pending == 0);
    server.stop().await.expect("stop");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn rest_and_grpc_teach_the_same_session() {
    let server = LocalServer::start().await.expect("server");
    let rest = Client::connect(Transport::Rest, &server.base, None)
        .await
        .expect("rest");
    let grpc = Client::connect(Transport::Grpc, &server.base, None)
        .await
        .expect("grpc");
    assert_eq!(grpc.transport(), Transport::Grpc);
    // The flagging policy and the online operator give every kind of decision: accepted,
    // fine-tuned, rejected (out of reach too) and dismissed suggestions.
    let plan = plan(online(), ReachPolicy::Flag);
    let p = program(TEMPLATE);
    let key = "seed_phi05_h2";
    let r = run_session(&rest, &plan, &session(&plan, key, &p, 3, "over rest"))
        .await
        .expect("rest session");
    let g = run_session(&grpc, &plan, &session(&plan, key, &p, 3, "over grpc"))
        .await
        .expect("grpc session");
    assert_ne!(r.cell_id, g.cell_id, "two cells");

    // The same session, whichever way the pendant talks: the same predictions seen, the same
    // decisions, the same simulated times and counts, the same feedback recorded and model.
    assert_eq!(r.routines, g.routines);
    assert_eq!(r.predictions, g.predictions);
    assert_eq!(r.stats.feedback, g.stats.feedback);
    assert_eq!(r.stats.model, g.stats.model);
    assert_eq!(r.routine_ids.len(), g.routine_ids.len());

    // The session exercised the stream: waypoints taught, predictions offered and judged.
    let offered = total(&g, |x| x.offered);
    assert!(offered > 0, "nothing offered");
    assert!(total(&g, |x| x.accepted + x.adjusted) > 0);
    assert!(total(&g, |x| x.rejected) > 0);
    let f = &g.stats.feedback;
    assert_eq!(f.offered as usize, offered);
    assert_eq!(f.accepted as usize, total(&g, |x| x.accepted));
    assert_eq!(f.adjusted as usize, total(&g, |x| x.adjusted));
    assert_eq!(f.rejected as usize, total(&g, |x| x.rejected));
    assert_eq!(f.pending, 0);
    assert_eq!(g.stats.model.routines as usize, p.routines.len());

    // Each cell read over the other transport answers the same, and a rebuild over gRPC gives
    // the model the session left.
    assert_eq!(
        grpc.stats(r.cell_id).await.expect("stats"),
        rest.stats(r.cell_id).await.expect("stats")
    );
    assert_eq!(
        rest.stats(g.cell_id).await.expect("stats"),
        grpc.stats(g.cell_id).await.expect("stats")
    );
    let rebuilt = grpc.rebuild(g.cell_id).await.expect("rebuild");
    assert_eq!(rebuilt, g.stats.model);
    let rebuilt = rest.rebuild(r.cell_id).await.expect("rebuild");
    assert_eq!(rebuilt, r.stats.model);
    server.stop().await.expect("stop");
}

/// A refusal reaches the caller as the server gave it: the REST error body's status and code,
/// or the gRPC status, named by the call that failed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_typed_client_reports_a_refusal_with_the_servers_reason() {
    use nextpose::api::CreateCell;
    use nextpose::client::ClientError;

    let server = LocalServer::start().await.expect("server");
    let cell = CreateCell {
        name: "taken".into(),
        settings: Default::default(),
    };
    let rest = RestClient::new(&server.base, None);
    let created = rest.create_cell(&cell).await.expect("first create");
    assert_eq!(created.name, "taken");
    assert_eq!(rest.list_cells().await.expect("list")[0].id, created.id);
    match rest.create_cell(&cell).await {
        Err(ClientError::Refused {
            what,
            status,
            code,
            message,
        }) => {
            assert_eq!(
                (what.as_str(), status, code.as_str()),
                ("POST /v1/cells", 409, "conflict")
            );
            assert!(message.contains("taken"), "{message}");
        }
        other => panic!("a second cell of the same name: {other:?}"),
    }
    let grpc = Client::connect(Transport::Grpc, &server.base, None)
        .await
        .expect("grpc");
    match grpc.create_cell(&cell).await {
        Err(ClientError::Grpc { what, status }) => {
            assert_eq!(what, "CreateCell");
            assert_eq!(status.code(), tonic::Code::AlreadyExists, "{status:?}");
        }
        other => panic!("a second cell of the same name over gRPC: {other:?}"),
    }
    server.stop().await.expect("stop");
}
