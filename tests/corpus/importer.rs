//! The importer on the shared corpus (`../shared/corpus`, read only).
//!
//! - Every raw file parses, without error or panic (each repository is one upload, so RAPID
//!   targets resolve across its modules and KRL `.src` files find their `.dat`).
//! - Every program agrees with the corpus's JSON reading — same routines, same waypoint count,
//!   poses within 1e-6 mm and 1e-9 per quaternion component (q or −q) — except the routines
//!   listed, with the reasoning, in `tests/fixtures/import_disagreements.json`. The JSON prints
//!   positions to 4 decimals and quaternions to 7, so the importer's values are rounded the same
//!   way before that comparison (see the fixture's `note`).
//! - Replaying the agreeing programs from the raw files gives the scoreboard of the JSON files.
//! - Stored as a cell's programs, every upload imports except the one whose two files declare
//!   the same module, and that error names both files.
//! - Random and mutated inputs never panic the parsers (proptest).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

use nextpose::engine::{EngineConfig, Pose, Profile};
use nextpose::import::{ImportError, ImportReport, Imported, parse_files, parse_upload};
use nextpose::replay::corpus::{Program, Routine, parse_program};
use nextpose::replay::methods::EngineMethod;
use nextpose::replay::{Scores, replay_program};
use proptest::prelude::*;
use serde::Deserialize;

use crate::corpus::{self, uploads};

fn import(files: &[(String, String)]) -> ImportReport {
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_str()))
        .collect();
    parse_files(&refs).unwrap_or_else(|e| panic!("{e}"))
}

#[derive(Deserialize)]
struct JsonSource {
    repo: String,
    path: String,
}

#[derive(Deserialize)]
struct JsonHead {
    source: JsonSource,
    routines: Vec<JsonRoutine>,
}

#[derive(Deserialize)]
struct JsonRoutine {
    name: String,
    waypoints: Vec<JsonWaypoint>,
}

/// A waypoint's numbers exactly as printed (`Pose::new` would normalise the quaternion again).
#[derive(Deserialize)]
struct JsonWaypoint {
    x: f64,
    y: f64,
    z: f64,
    qw: f64,
    qx: f64,
    qy: f64,
    qz: f64,
}

impl JsonWaypoint {
    fn values(&self) -> [f64; 7] {
        [self.x, self.y, self.z, self.qw, self.qx, self.qy, self.qz]
    }
}

/// The JSON programs: (file stem, repository with `__`, source path, program, printed numbers).
fn reference() -> Vec<(String, String, String, Program, Vec<JsonRoutine>)> {
    let mut files: Vec<PathBuf> = fs::read_dir(corpus::json())
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let text = fs::read_to_string(&p).unwrap();
            let head: JsonHead = serde_json::from_str(&text).unwrap();
            let program = parse_program(&p, &text).unwrap();
            (
                program.name.clone(),
                head.source.repo.replace('/', "__"),
                head.source.path,
                program,
                head.routines,
            )
        })
        .collect()
}

#[derive(Deserialize)]
struct Fixture {
    disagreements: Vec<Disagreement>,
}

#[derive(Deserialize)]
struct Disagreement {
    program: String,
    routine: String,
    #[allow(dead_code)]
    reason: String,
}

fn listed() -> BTreeSet<(String, String)> {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/import_disagreements.json");
    let f: Fixture = serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap();
    f.disagreements
        .into_iter()
        .map(|d| (d.program, d.routine))
        .collect()
}

/// `v` printed with `decimals` digits, as the JSON was written (exact decimal rounding of the
/// binary value, like Python's `round`; `(v * 10^d).round()` differs on near-ties).
fn round(v: f64, decimals: usize) -> f64 {
    format!("{v:.decimals$}").parse().unwrap()
}

/// Our pose as the JSON prints it: position to 4 decimals, quaternion (`w ≥ 0`) to 7.
fn as_printed(p: &Pose) -> [f64; 7] {
    let v = p.values();
    let s = if v.qw < 0.0 { -1.0 } else { 1.0 };
    [
        round(v.x, 4),
        round(v.y, 4),
        round(v.z, 4),
        round(s * v.qw, 7),
        round(s * v.qx, 7),
        round(s * v.qy, 7),
        round(s * v.qz, 7),
    ]
}

fn agrees(ours: &Pose, reference: &JsonWaypoint) -> bool {
    let o = as_printed(ours);
    let r = reference.values();
    let pos = (0..3).all(|i| (o[i] - r[i]).abs() <= 1e-6);
    let q = [r[3], r[4], r[5], r[6]];
    let same = |sign: f64| {
        o[3..]
            .iter()
            .zip(q)
            .all(|(a, b)| (a - sign * b).abs() <= 1e-9)
    };
    pos && (same(1.0) || same(-1.0))
}

fn routine_agrees(ours: Option<&Routine>, reference: &JsonRoutine) -> bool {
    ours.is_some_and(|o| {
        o.waypoints.len() == reference.waypoints.len()
            && o.waypoints
                .iter()
                .zip(&reference.waypoints)
                .all(|(a, b)| agrees(a, b))
    })
}

struct Comparison {
    /// (program, routine) → (our waypoint count, reference count, max position difference).
    details: BTreeMap<(String, String), (usize, usize, f64)>,
    /// (program, routine) pairs that disagree, from either side.
    disagreements: BTreeSet<(String, String)>,
    programs_agreeing: Vec<(Program, Program)>,
    waypoints_agreeing: usize,
    programs: usize,
}

fn compare() -> Comparison {
    let mut ours: BTreeMap<(String, String), Imported> = BTreeMap::new();
    for (repo, files) in uploads() {
        for p in import(&files).programs {
            ours.insert((repo.clone(), p.source()), p);
        }
    }
    let mut c = Comparison {
        details: BTreeMap::new(),
        disagreements: BTreeSet::new(),
        programs_agreeing: Vec::new(),
        waypoints_agreeing: 0,
        programs: 0,
    };
    for (stem, repo, path, reference, printed) in reference() {
        c.programs += 1;
        let Some(imported) = ours.get(&(repo, path.clone())) else {
            c.disagreements.insert((stem, "*program missing*".into()));
            continue;
        };
        let mine = imported.program.to_poses();
        let mut all_agree = mine.routines.len() == reference.routines.len();
        for r in &printed {
            let o = mine.routines.iter().find(|o| o.name == r.name);
            if routine_agrees(o, r) {
                c.waypoints_agreeing += r.waypoints.len();
            } else {
                all_agree = false;
                if std::env::var_os("IMPORT_DEBUG").is_some() {
                    explain(&stem, o, r);
                }
                if let Some(o) = o {
                    let max = o
                        .waypoints
                        .iter()
                        .zip(&r.waypoints)
                        .map(|(a, b)| {
                            let (p, v) = (a.position(), b.values());
                            ((p.x - v[0]).powi(2) + (p.y - v[1]).powi(2) + (p.z - v[2]).powi(2))
                                .sqrt()
                        })
                        .fold(0.0, f64::max);
                    c.details.insert(
                        (stem.clone(), r.name.clone()),
                        (o.waypoints.len(), r.waypoints.len(), max),
                    );
                }
                c.disagreements.insert((stem.clone(), r.name.clone()));
            }
        }
        for o in &mine.routines {
            if !printed.iter().any(|r| r.name == o.name) {
                all_agree = false;
                c.disagreements.insert((stem.clone(), o.name.clone()));
            }
        }
        if all_agree {
            c.programs_agreeing.push((mine, reference));
        }
    }
    c
}

/// With `IMPORT_DEBUG` set: where a routine first differs.
fn explain(stem: &str, ours: Option<&Routine>, reference: &JsonRoutine) {
    let Some(o) = ours else {
        eprintln!("{stem} :: {}: routine missing", reference.name);
        return;
    };
    let first = o
        .waypoints
        .iter()
        .zip(&reference.waypoints)
        .position(|(a, b)| !agrees(a, b));
    eprintln!(
        "{stem} :: {}: ours {} reference {}; first differing index {:?}",
        reference.name,
        o.waypoints.len(),
        reference.waypoints.len(),
        first
    );
    if let Some(i) = first {
        eprintln!(
            "   ours {:?}\n   ref  {:?}",
            as_printed(&o.waypoints[i]),
            reference.waypoints[i].values()
        );
        eprintln!("   index {i} of {}", o.waypoints.len());
    }
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn every_raw_file_parses() {
    let mut files = 0;
    let mut programs = 0;
    let mut waypoints = 0;
    for (_, upload) in uploads() {
        files += upload.len();
        let report = import(&upload);
        programs += report.programs.len();
        waypoints += report.waypoint_count();
    }
    assert_eq!(files, 81);
    // 36 corpus programs; the 7 KRL .dat files pair with their .src.
    assert_eq!(programs, 36);
    assert!(waypoints > 3000, "{waypoints}");
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn stored_as_a_cell_every_upload_imports_but_the_one_declaring_main_module_twice() {
    // Two RAPID files of one repository both declare `MODULE MainModule`: replay reads them
    // apart, a cell cannot hold both, and the error names the two files.
    for (repo, upload) in uploads() {
        let refs: Vec<(&str, &str)> = upload
            .iter()
            .map(|(n, t)| (n.as_str(), t.as_str()))
            .collect();
        match parse_upload(&refs) {
            Ok(report) => assert_eq!(report, import(&upload), "{repo}"),
            Err(ImportError::DuplicateProgram {
                name,
                first,
                second,
            }) if repo == "EdgarIvanMM__PaletizadoCajasConFrascos" => {
                assert_eq!(name, "MainModule");
                assert_eq!(
                    (first.as_str(), second.as_str()),
                    (
                        "RAPID/TASK1/PROGMOD/MainModule.mod",
                        "RAPID/TASK1/PROGMOD/VConCartonPorGruposDeEntrada.mod"
                    )
                );
            }
            Err(e) => panic!("{repo}: {e}"),
        }
    }
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn the_raw_corpus_directory_replays_as_one_upload_per_repository() {
    // `nextpose replay ../shared/corpus/raw`: the folder holds one folder per repository.
    let programs = nextpose::replay::corpus::load_paths(&[corpus::raw()]).unwrap();
    let imported: usize = uploads()
        .iter()
        .map(|(_, upload)| import(upload).programs.len())
        .sum();
    assert_eq!(programs.len(), imported);
    assert_eq!(programs.len(), 36);
    let waypoints: usize = programs.iter().map(|p| p.waypoint_count()).sum();
    assert!(waypoints > 3000, "{waypoints}");
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn readings_agree_except_the_listed_ones() {
    let c = compare();
    let listed = listed();
    let unexpected: Vec<_> = c.disagreements.difference(&listed).collect();
    let stale: Vec<_> = listed.difference(&c.disagreements).collect();
    eprintln!(
        "{} programs, {} agree entirely; {} waypoints agree; {} routines disagree",
        c.programs,
        c.programs_agreeing.len(),
        c.waypoints_agreeing,
        c.disagreements.len()
    );
    assert!(
        unexpected.is_empty(),
        "disagreements not in the fixture: {unexpected:#?}"
    );
    assert!(
        stale.is_empty(),
        "fixture lists routines that now agree: {stale:#?}"
    );
}

fn comparable(mut m: Scores) -> Scores {
    m.us_per_waypoint = None;
    m
}

#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn scoreboard_from_raw_equals_scoreboard_from_json_where_readings_agree() {
    let c = compare();
    assert!(!c.programs_agreeing.is_empty());
    let config = EngineConfig::profile(Profile::Default);
    let run = |p: &Program| {
        let mut engine = EngineMethod::new(config.clone()).unwrap();
        replay_program(p, &mut engine)
    };
    let mut raw_records = Vec::new();
    let mut json_records = Vec::new();
    for (mine, reference) in &c.programs_agreeing {
        // Exactly the JSON's numbers: our poses as the JSON prints them.
        let printed = Program {
            routines: mine
                .routines
                .iter()
                .map(|r| Routine {
                    name: r.name.clone(),
                    waypoints: r
                        .waypoints
                        .iter()
                        .map(|w| {
                            let v = as_printed(w);
                            Pose::new([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]]).unwrap()
                        })
                        .collect(),
                })
                .collect(),
            ..mine.clone()
        };
        let (a, b) = (run(&printed), run(reference));
        assert_eq!(
            comparable(Scores::of_program(&a)),
            comparable(Scores::of_program(&b)),
            "{}",
            reference.name
        );
        raw_records.push(run(mine));
        json_records.push(b);
    }
    // Unrounded, the counts are the same and the medians differ by less than the JSON's rounding.
    let (a, b) = (
        Scores::of_programs(&raw_records),
        Scores::of_programs(&json_records),
    );
    assert_eq!(
        (a.n2.predictable, a.n2.offered, a.n2.useful),
        (b.n2.predictable, b.n2.offered, b.n2.useful)
    );
    let close = |x: Option<f64>, y: Option<f64>, tol: f64| match (x, y) {
        (Some(x), Some(y)) => (x - y).abs() <= tol,
        (None, None) => true,
        _ => false,
    };
    assert!(
        close(a.n2.median_cart_mm, b.n2.median_cart_mm, 1e-3),
        "{:?} {:?}",
        a.n2.median_cart_mm,
        b.n2.median_cart_mm
    );
    assert!(close(a.n2.median_angle_rad, b.n2.median_angle_rad, 1e-6));
    eprintln!(
        "agreeing programs: {} predictable, {} offered, {} useful",
        a.n2.predictable, a.n2.offered, a.n2.useful
    );
}

/// Real corpus files, for mutation.
fn corpus_files() -> Vec<(String, String)> {
    uploads().into_iter().flat_map(|(_, files)| files).collect()
}

fn mutate(text: &str, edits: &[(usize, u8, u8)]) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for &(pos, op, b) in edits {
        if bytes.is_empty() {
            bytes.push(b);
            continue;
        }
        let i = pos % bytes.len();
        match op % 4 {
            0 => bytes[i] = b,
            1 => {
                bytes.remove(i);
            }
            2 => bytes.insert(i, b),
            _ => {
                // Duplicate a chunk: repeats brackets, declarations, motion lines.
                let end = (i + (b as usize)).min(bytes.len());
                let chunk = bytes[i..end].to_vec();
                bytes.splice(i..i, chunk);
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

const EXTENSIONS: &[&str] = &["mod", "prg", "src", "dat", "ls", "sys"];

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_text_never_panics(text in "\\PC{0,400}", ext in 0..EXTENSIONS.len()) {
        let name = format!("x.{}", EXTENSIONS[ext]);
        let _ = parse_files(&[(name.as_str(), text.as_str())]);
    }

    #[test]
    fn tokens_soup_never_panics(
        parts in proptest::collection::vec(prop_oneof![
            Just("MODULE"), Just("PROC p()"), Just("ENDPROC"), Just("robtarget"), Just("CONST"),
            Just("MoveL"), Just("Offs("), Just("RelTool("), Just("\\Rx:="), Just("["), Just("]"),
            Just("("), Just(")"), Just("{"), Just("}"), Just(","), Just(";"), Just(":="), Just("1.5"),
            Just("-"), Just("p1"), Just("\n"), Just("DEF a()"), Just("END"), Just("PTP"), Just("LIN"),
            Just("CIRC"), Just("DECL E6POS"), Just("{X 1,Y 2,Z 3,A 0,B 0,C 0}"), Just("/PROG A"),
            Just("/MN"), Just("/POS"), Just("1:J P[1] 100% FINE ;"), Just("P[1]{"), Just("GP1:"),
            Just("X = 1 mm,"), Just("J1= 2 deg"), Just("ERROR"), Just("IF"), Just("THEN"),
        ], 0..80),
        ext in 0..EXTENSIONS.len(),
    ) {
        let text = parts.join(" ");
        let name = format!("x.{}", EXTENSIONS[ext]);
        let _ = parse_files(&[(name.as_str(), text.as_str())]);
    }

    #[test]
    #[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
    fn mutated_corpus_files_never_panic(
        pick in any::<prop::sample::Index>(),
        edits in proptest::collection::vec((any::<usize>(), any::<u8>(), any::<u8>()), 1..12),
    ) {
        thread_local! { static FILES: Vec<(String, String)> = corpus_files(); }
        FILES.with(|files| {
            let (name, text) = &files[pick.index(files.len())];
            let mutated = mutate(text, &edits);
            // Control characters make a file "not text"; with them blanked out the mutation
            // also reaches the parsers.
            let blanked: String = mutated
                .chars()
                .map(|c| if c < ' ' && !matches!(c, '\t' | '\n' | '\r') { ' ' } else { c })
                .collect();
            for mutated in [&mutated, &blanked] {
                // Alone, and with a partner so the cross-file paths run too.
                let _ = parse_files(&[(name.as_str(), mutated.as_str())]);
                let partner = if name.ends_with(".src") { name.replace(".src", ".dat") } else { format!("{name}.mod") };
                let _ = parse_files(&[(name.as_str(), mutated.as_str()), (partner.as_str(), text.as_str())]);
            }
        });
    }
}
