//! The arms of the corpus programs (`../shared/corpus`, read only), as the replay's reach
//! figures and the simulation choose and place them (`kinematics::placement`,
//! `ReachSetup::default()`: the program's own arm where its sources name one, else the smallest
//! library arm for its language that reaches every taught waypoint, placed by the layout
//! search), against the arm and placement used before the library (an IRB 140 for RAPID, a
//! KR 16-2 for KRL and FANUC, the median heuristic). A per-program table is printed
//! (`cargo test --release --test corpus layout:: -- --nocapture`).

use std::collections::BTreeSet;
use std::path::Path;
use std::time::Instant;

use nextpose::engine::Pose;
use nextpose::import;
use nextpose::kinematics::placement::{ArmChoice, HeuristicSetup, ReachCheck, ReachSetup};
use nextpose::kinematics::{LayoutOptions, Robot, bundled_robots_dir, load_catalog, search_layout};
use nextpose::replay::{Program, load_paths};

use crate::corpus;

fn programs() -> Vec<Program> {
    load_paths(&[corpus::json()]).expect("shared corpus loads")
}

/// The arm and placement before the library, as the simulator had them.
fn before(program: &Program) -> HeuristicSetup {
    let (robot, centroid) = match program.language_name() {
        "rapid" => ("abb_irb140", [450.0, 0.0, 350.0]),
        _ => ("kuka_kr16_2", [900.0, 0.0, 500.0]),
    };
    HeuristicSetup {
        robot: robot.into(),
        languages: vec![program.language_name().to_string()],
        centroid_in_base_mm: centroid,
    }
}

/// The work objects (RAPID `\WObj`, FANUC user frames; `(default)` for moves without one:
/// `wobj0`, the current user frame) the program's moves are written in, from
/// its raw files (`raw/<owner>__<repo>/<path with __>…`), as the importer reads them.
fn work_objects(program: &Program) -> BTreeSet<String> {
    #[derive(serde::Deserialize)]
    struct File {
        source: Source,
    }
    #[derive(serde::Deserialize)]
    struct Source {
        repo: String,
        path: String,
    }
    let text = std::fs::read_to_string(&program.source).expect("the corpus file");
    let source = serde_json::from_str::<File>(&text)
        .expect("a source")
        .source;
    let dir = corpus::dir()
        .join("raw")
        .join(source.repo.replace('/', "__"));
    // The program's file with any extension (a KRL `.src` and its `.dat`), or the files of its
    // folder (a FANUC program).
    let flat = source.path.replace('/', "__");
    let prefix = match Path::new(&source.path).extension() {
        Some(ext) => format!("{}.", &flat[..flat.len() - ext.len() - 1]),
        None => format!("{flat}__"),
    };
    let files: Vec<(String, String)> = std::fs::read_dir(&dir)
        .expect("the raw files of the repository")
        .map(|e| e.expect("an entry").path())
        .filter(|p| file_name(p).starts_with(&prefix))
        .map(|p| {
            let bytes = std::fs::read(&p).expect("a raw file");
            (
                file_name(&p).replace("__", "/"),
                import::decode_text(&bytes),
            )
        })
        .collect();
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_str()))
        .collect();
    let report = import::parse_files(&refs).expect("the raw files import");
    report
        .programs
        .iter()
        .flat_map(|p| &p.origins)
        .flat_map(|r| &r.waypoints)
        .map(|w| w.frame.clone().unwrap_or_else(|| "(default)".into()))
        .collect()
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// A typical length of a gripper or torch, mm: the corpus never gives a program's tool, so
/// the TCP is taken at the flange, and a program taught with a long tool can reach farther than
/// the flange does.
const TOOL_MM: f64 = 400.0;

/// Whether the layout search finds a base from which `robot`, holding a tool [`TOOL_MM`] long
/// along the flange's z axis, reaches every one of `poses`.
fn reaches_all_with_a_tool(robot: &Robot, poses: &[Pose]) -> bool {
    let options = LayoutOptions {
        tool: Pose::new([0.0, 0.0, TOOL_MM], [1.0, 0.0, 0.0, 0.0])
            .expect("a pose")
            .values(),
        keep: 1,
        ..LayoutOptions::default()
    };
    search_layout(robot, poses, &options)
        .expect("the search runs")
        .first()
        .is_some_and(|p| p.reached == poses.len())
}

fn span_mm(poses: &[Pose]) -> f64 {
    let mut span: f64 = 0.0;
    for (i, a) in poses.iter().enumerate() {
        for b in &poses[i + 1..] {
            span = span.max(a.distance_to(b));
        }
    }
    span
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn every_program_gets_an_arm_that_reaches_at_least_as_much_as_before_and_all_where_it_fits() {
    let programs = programs();
    assert_eq!(programs.len(), 36, "the shared corpus has 36 programs");
    let catalog = load_catalog(&bundled_robots_dir()).expect("the catalogue");
    let fitted = ReachCheck::new(ReachSetup::default()).expect("the library loads");
    let started = Instant::now();
    let mut rows = Vec::new();
    let (mut total, mut reached_before, mut reached_after) = (0, 0, 0);
    let mut worse = Vec::new();
    let mut unexplained = Vec::new();
    for program in &programs {
        let poses: Vec<Pose> = program.poses().copied().collect();
        let old = ReachCheck::new(ReachSetup::Heuristic(before(program))).expect("old arm");
        let old = old
            .place(program.language_name(), None, &poses)
            .expect("the heuristic places")
            .expect("an arm for the language");
        let named = program.arm.as_ref().map(|a| a.designation.as_str());
        let t0 = Instant::now();
        let new = fitted
            .place(program.language_name(), named, &poses)
            .expect("the search runs")
            .expect("an arm for every corpus program");
        let seconds = t0.elapsed().as_secs_f64();
        let a = &new.arm;
        assert_eq!(a.waypoints, poses.len());
        // The placement's count is the replay's check.
        let checked = poses
            .iter()
            .filter(|p| fitted.reaches(&new.robot, &new.cell, p))
            .count();
        assert_eq!(checked, a.reached, "{}", program.name);
        if a.reached < old.arm.reached {
            worse.push(program.name.clone());
        }
        // A program no arm reaches whole is one that spans more than its named arm, or the
        // largest arm of its language, reaches across, or one written in several work objects
        // (poses in different frames, which no one placement serves).
        let span = span_mm(&poses);
        let largest = catalog
            .iter()
            .filter(|f| match a.chosen {
                ArmChoice::Named => Some(&f.model) == a.model.as_ref(),
                _ => f.languages.iter().any(|l| l == program.language_name()),
            })
            .map(|f| f.reach_mm)
            .fold(0.0, f64::max);
        let frames = work_objects(program);
        let why = if a.reached == a.waypoints {
            String::new()
        } else if span > 2.0 * largest {
            format!("spans {span:.0} mm > 2 × {largest:.0} mm reach")
        } else if frames.len() > 1 {
            format!("{} work objects", frames.len())
        } else if reaches_all_with_a_tool(&new.robot, &poses) {
            format!("needs a {TOOL_MM:.0} mm tool (the corpus has none)")
        } else {
            unexplained.push(program.name.clone());
            "?".into()
        };
        if a.chosen == ArmChoice::Named {
            assert!(named.is_some());
        }
        total += a.waypoints;
        reached_before += old.arm.reached;
        reached_after += a.reached;
        rows.push(format!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} % | {span:.0} | {} | {why} | {seconds:.2} |",
            program.name,
            named.unwrap_or("-"),
            a.model.as_deref().unwrap_or(&a.robot),
            a.chosen.name(),
            a.waypoints,
            old.arm.reached,
            a.reached,
            100.0 * (a.waypoints - a.reached) as f64 / a.waypoints as f64,
            frames.len(),
        ));
    }
    println!(
        "| program | named | arm | chosen | waypoints | before reached | reached | out of reach | span mm | work objects | not all because | search s |"
    );
    println!("|---|---|---|---|--:|--:|--:|--:|--:|--:|---|--:|");
    for r in &rows {
        println!("{r}");
    }
    let pct = |n: usize| 100.0 * n as f64 / total as f64;
    println!(
        "total: {total} waypoints; before {reached_before} reached ({:.1} % out of reach), now {reached_after} ({:.1} % out of reach); {:.1} s",
        pct(total - reached_before),
        pct(total - reached_after),
        started.elapsed().as_secs_f64()
    );
    assert!(
        worse.is_empty(),
        "the fitted arm reaches fewer waypoints than before on {worse:?}"
    );
    assert!(
        unexplained.is_empty(),
        "no arm reaches all of {unexplained:?}, though they fit an arm's workspace and one work object"
    );
}

/// The programs whose sources name their arm get it: FOUNDRY's header (IRB 6700-205/2.80),
/// the welding cell's serial number (IRB 2600, for all of that repository's programs), the
/// corpus note and the repository name of the IRB 140 lab program.
#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn the_arms_the_corpus_names_are_found() {
    let programs = programs();
    let named = |prefix: &str| -> Vec<(String, String)> {
        programs
            .iter()
            .filter(|p| p.name.starts_with(prefix))
            .map(|p| {
                let a = p
                    .arm
                    .as_ref()
                    .unwrap_or_else(|| panic!("{} names an arm", p.name));
                (a.designation.clone(), a.found_in.clone())
            })
            .collect()
    };
    let foundry = named("Fabio-Coder__");
    assert_eq!(foundry.len(), 1);
    assert_eq!(foundry[0].0, "IRB 6700-205/2.80");
    assert!(foundry[0].1.ends_with("FOUNDRY.mod:10"), "{}", foundry[0].1);
    let welder = named("ravenorb__");
    assert_eq!(welder.len(), 7);
    assert!(welder.iter().all(|(d, _)| d == "IRB 2600"));
    let lab = named("Theyloramaya__");
    assert_eq!(lab[0].0, "IRB 140");
    // Nothing else in the corpus names an arm.
    let others = programs
        .iter()
        .filter(|p| {
            !["Fabio-Coder__", "ravenorb__", "Theyloramaya__"]
                .iter()
                .any(|prefix| p.name.starts_with(prefix))
        })
        .filter(|p| p.arm.is_some())
        .map(|p| p.name.clone())
        .collect::<Vec<_>>();
    assert!(others.is_empty(), "{others:?}");
}

/// `nextpose layout`: the search over program files, locally; best first, as JSON; an arm
/// that is not in the library is refused by name.
#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn the_layout_command_places_an_arm_for_program_files() {
    let file = corpus::dir()
        .join("json")
        .join("panin-anan__abb_SAMXL_Grinding_RAPID__RAPID__TASK1__PROGMOD__Training.mod.json");
    let run = |robot: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_nextpose"))
            .arg("layout")
            .arg(&file)
            .args(["--robot", robot, "--keep", "2", "--json"])
            .output()
            .expect("nextpose runs")
    };
    let out = run("abb_irb1200");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let placements: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let placements = placements.as_array().expect("a list of placements");
    assert!((1..=2).contains(&placements.len()));
    // The replay's fitted IRB 1200 reaches all 20 waypoints of this program (first test).
    assert_eq!(placements[0]["total"], 20);
    assert_eq!(placements[0]["reached"], 20);
    let scores: Vec<f64> = placements
        .iter()
        .map(|p| p["score"].as_f64().unwrap())
        .collect();
    assert!(
        scores.windows(2).all(|w| w[0] >= w[1]),
        "best first: {scores:?}"
    );

    let out = run("abb_irb9999");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("abb_irb9999"), "{stderr}");
}
