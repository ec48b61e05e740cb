//! The cell-layout search (`kinematics::layout`) on every program of the shared corpus
//! (`../shared/corpus/json`, read only), with today's arm per program: the search's best base
//! reaches at least as many taught waypoints as today's heuristic placement
//! (`kinematics::placement`, set up as `sim::plan::placement` does), and a per-program table is
//! printed (`cargo test --release --test layout -- --nocapture`).
//!
//! The arm and its heuristic cell per program come from [`arm_for`] alone, so a larger arm
//! library changes that one function.

use std::path::PathBuf;
use std::time::Instant;

use nextpose::engine::Pose;
use nextpose::kinematics::{
    LayoutOptions, Mounting, ReachConfig, Robot, bundled_robots_dir, check_reach,
    evaluate_placement, load_robot, search_layout,
};
use nextpose::replay::{Program, load_paths};

fn corpus() -> Vec<Program> {
    let corpus = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/corpus/json"
    ));
    load_paths(&[corpus]).expect("shared corpus loads")
}

/// Today's arm for a program and where today's heuristic stands it: the bundled robot for the
/// program's language (IRB 140 for RAPID, KR 16-2 for KRL and FANUC) with the program's
/// per-axis median waypoint at the arm's comfortable point, as the simulator places it.
fn arm_for(program: &Program) -> (Robot, Mounting) {
    let (name, cell) = nextpose::sim::plan::placement(program).expect("a placement per program");
    let robot = load_robot(&bundled_robots_dir(), &name).expect("bundled robot loads");
    (robot, cell)
}

/// The search's settings in this test: the defaults (1200 evaluations on a 64-target sample,
/// a 60-evaluation polish of the best distinct candidates on all targets; about 13 s for the
/// whole corpus in the debug build at opt-level 1, 10 s in release), with the heuristic cell's
/// base as one of the seeds.
fn options_for(cell: &Mounting) -> LayoutOptions {
    LayoutOptions {
        extra_seeds: vec![cell.base.values()],
        ..LayoutOptions::default()
    }
}

fn deg(rad: Option<f64>) -> String {
    rad.map_or("-".into(), |r| format!("{:.1}", r.to_degrees()))
}

fn num(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.3}"))
}

#[test]
fn the_search_reaches_at_least_as_many_waypoints_as_todays_heuristic_on_every_program() {
    let programs = corpus();
    assert_eq!(programs.len(), 36, "the shared corpus has 36 programs");
    let mut rows = Vec::new();
    let (mut total, mut before, mut after) = (0usize, 0usize, 0usize);
    let mut worse = Vec::new();
    let started = Instant::now();
    for program in &programs {
        let targets: Vec<Pose> = program.poses().copied().collect();
        let (robot, cell) = arm_for(program);
        let options = options_for(&cell);
        // Today's count, straight from the reachability check the replay uses.
        let config = ReachConfig::default();
        let heuristic_reached = targets
            .iter()
            .filter(|t| check_reach(&robot, &cell, t, None, &config).is_reachable())
            .count();
        let heuristic = evaluate_placement(&robot, &targets, &cell.base, &options)
            .expect("the heuristic base scores");
        assert_eq!(heuristic.reached, heuristic_reached, "{}", program.name);
        let t0 = Instant::now();
        let found = search_layout(&robot, &targets, &options).expect("the search runs");
        let seconds = t0.elapsed().as_secs_f64();
        let best = found.first().expect("at least one placement");
        assert_eq!(best.total, targets.len());
        if best.reached < heuristic_reached {
            worse.push(program.name.clone());
        }
        total += targets.len();
        before += heuristic_reached;
        after += best.reached;
        let b = best.base.values();
        let yaw = (best.base.rotation() * nalgebra::Vector3::x())
            .y
            .atan2((best.base.rotation() * nalgebra::Vector3::x()).x);
        rows.push(format!(
            "| {} | {} | {} | {} | {} | {} / {} | {} / {} | ({:.0}, {:.0}, {:.0}) {:.0}° | {} | {:.2} |",
            program.name,
            robot.name(),
            targets.len(),
            heuristic_reached,
            best.reached,
            deg(heuristic.min_joint_margin_rad),
            deg(best.min_joint_margin_rad),
            num(heuristic.min_sigma),
            num(best.min_sigma),
            b.x,
            b.y,
            b.z,
            yaw.to_degrees(),
            found.len(),
            seconds,
        ));
    }
    println!(
        "| program | arm | waypoints | heuristic reached | search reached | min joint margin ° (heuristic / search) | min σ (heuristic / search) | best base (x, y, z mm) yaw | kept | search s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        println!("{r}");
    }
    let pct = |n: usize| 100.0 * n as f64 / total.max(1) as f64;
    println!(
        "total: {total} waypoints; heuristic reaches {before} ({:.1} %), search {after} ({:.1} %); {:.1} s",
        pct(before),
        pct(after),
        started.elapsed().as_secs_f64()
    );
    assert!(
        worse.is_empty(),
        "the search reaches fewer waypoints than the heuristic on {worse:?}"
    );
}
