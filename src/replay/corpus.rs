//! Loading recorded programs from the shared corpus's JSON reading (`corpus/README.md`).
//!
//! Replay needs real programs as ordered waypoint lists. The corpus ships each program as one
//! JSON file (`source`, `language`, `routines[].waypoints[]` with `x y z qw qx qy qz`); this module
//! reads exactly that and turns every waypoint into a validated [`Pose`]. Fields the harness does
//! not use (`role`, `motion`, `line`, `stats`, `units`, ...) are ignored, so the corpus may grow
//! fields without breaking replay.
//!
//! Raw robot source (RAPID `.mod/.modx/.prg/.sys`, KRL `.src/.dat`, FANUC `.ls`) is handed to
//! the importer ([`crate::import`]): all raw files named in one call (or found in one directory)
//! are parsed as one upload, so RAPID targets resolve across modules and a KRL `.src` finds its
//! `.dat`. The JSON path is unchanged.
//!
//! Every failure names the file it came from, and a bad waypoint also names its routine and
//! index, because the person reading the message has 36 files and 3,587 waypoints to look at.

use std::fs;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use thiserror::Error;

use crate::engine::{Pose, PoseError};
use crate::import::{self, ImportError};
use crate::kinematics::designation::find_designation;
use crate::program::{Language, NamedArm};

pub use crate::program::{Program, Routine};

/// Why a corpus file could not be loaded. Every variant names the file; the underlying cause
/// (I/O error, pose error) is the error's `source()`, so print the chain (`{:#}` with anyhow).
#[derive(Debug, Error)]
pub enum CorpusError {
    #[error("{}: cannot read", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}:{column}: not a corpus program: {message}", path.display())]
    Json {
        path: PathBuf,
        /// 1-based line of the error, as reported by serde_json (0 when unknown).
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{}: routine {routine:?}, waypoint {index}: invalid pose", path.display())]
    InvalidPose {
        path: PathBuf,
        routine: String,
        /// 0-based index of the waypoint in its routine.
        index: usize,
        #[source]
        source: PoseError,
    },
    #[error(
        "{}: not a program file: expected corpus JSON (*.json, see corpus/README.md) or raw \
         RAPID (.mod .modx .prg .sys), KRL (.src .dat) or FANUC (.ls) source",
        path.display()
    )]
    Unsupported { path: PathBuf },
    #[error(
        "{}: directory holds no *.json corpus files and no raw RAPID/KRL/FANUC program files",
        path.display()
    )]
    EmptyDirectory { path: PathBuf },
    /// A raw program file that the importer rejected (the message names file, line, column).
    #[error(transparent)]
    Import(#[from] ImportError),
}

/// The corpus file format, as far as replay needs it (unknown fields are ignored).
#[derive(Deserialize)]
struct RawProgram {
    /// Where the program came from: the simulation groups programs by `repo`, and the paths
    /// lead to the raw files that may name the arm ([`named_arm`]).
    #[serde(default)]
    source: Option<RawSource>,
    /// `rapid`, `krl` or `fanuc`: another is an error naming the file.
    language: Language,
    routines: Vec<RawRoutine>,
}

#[derive(Deserialize)]
struct RawSource {
    #[serde(default)]
    repo: Option<String>,
    /// The program's file in its repository, and the KRL `.dat` beside it.
    #[serde(default)]
    path: Option<String>,
    #[serde(default)]
    dat_path: Option<String>,
    /// The arm the program was written for, as its maker designates it (`IRB 140`), when the
    /// file says so (`nextpose lab` writes it).
    #[serde(default)]
    arm: Option<String>,
}

#[derive(Deserialize)]
struct RawRoutine {
    name: String,
    waypoints: Vec<RawWaypoint>,
}

#[derive(Deserialize)]
struct RawWaypoint {
    x: f64,
    y: f64,
    z: f64,
    qw: f64,
    qx: f64,
    qy: f64,
    qz: f64,
}

/// Loads programs from files and directories, in the order given; a directory contributes all
/// its `*.json` files sorted by file name (see [`load_dir`]), so replay order is reproducible.
///
/// Raw program files (see [`is_raw_program`]) named here are imported together as one upload,
/// their programs taking the place of the first of them; a directory without `*.json` files
/// contributes its raw program files, as one upload, sorted by file name.
pub fn load_paths<P: AsRef<Path>>(paths: &[P]) -> Result<Vec<Program>, CorpusError> {
    let mut programs = Vec::new();
    let mut raw = Vec::new();
    let mut raw_at = None;
    for path in paths {
        let path = path.as_ref();
        if path.is_dir() {
            programs.extend(load_dir(path)?);
        } else if is_raw_program(path) {
            raw_at.get_or_insert(programs.len());
            raw.push(path.to_path_buf());
        } else {
            programs.push(load_file(path)?);
        }
    }
    if let Some(at) = raw_at {
        let imported = load_raw(&raw)?;
        programs.splice(at..at, imported);
    }
    Ok(programs)
}

/// Loads every `*.json` file of a directory, sorted by file name; without any, imports the
/// directory's raw program files as one upload; without those either, loads each
/// subdirectory in name order (so `corpus/raw/` gives one upload per repository folder).
pub fn load_dir(dir: &Path) -> Result<Vec<Program>, CorpusError> {
    let io_error = |source| CorpusError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    let mut raw = Vec::new();
    let mut dirs = Vec::new();
    for entry in fs::read_dir(dir).map_err(io_error)? {
        let path = entry.map_err(io_error)?.path();
        if path.is_file() && has_json_extension(&path) {
            files.push(path);
        } else if path.is_file() && is_raw_program(&path) {
            raw.push(path);
        } else if path.is_dir() {
            dirs.push(path);
        }
    }
    if files.is_empty() && !raw.is_empty() {
        raw.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
        return load_raw(&raw);
    }
    if files.is_empty() && !dirs.is_empty() {
        dirs.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
        let mut programs = Vec::new();
        for d in &dirs {
            programs.extend(load_dir(d)?);
        }
        return Ok(programs);
    }
    if files.is_empty() {
        return Err(CorpusError::EmptyDirectory {
            path: dir.to_path_buf(),
        });
    }
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    files.iter().map(|f| load_file(f)).collect()
}

/// Whether the file's extension is one the importer reads (RAPID, KRL, FANUC).
pub fn is_raw_program(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .and_then(Language::from_file_name)
        .is_some()
}

/// Imports raw program files as one upload (see [`crate::import::parse_files`]).
///
/// A `__` in a file name stands for a directory separator, as in the shared corpus's flattened
/// layout (`raw/<owner>__<repo>/<dir>__<file>`): the importer groups FANUC listings and pairs
/// KRL files by directory, so `a__FOLGE011.LS` and `b__FOLGE020.LS` are two programs, as they
/// were in their repository.
pub fn load_raw(paths: &[PathBuf]) -> Result<Vec<Program>, CorpusError> {
    let mut files = Vec::with_capacity(paths.len());
    for path in paths {
        let bytes = fs::read(path).map_err(|source| CorpusError::Io {
            path: path.clone(),
            source,
        })?;
        files.push((upload_name(path), import::decode_text(&bytes)));
    }
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_str()))
        .collect();
    Ok(import_upload(&refs)?)
}

/// Imports the files `(name, text)` of one upload ([`import::parse_files`]) as replay programs.
/// One upload is one cell's files: an arm designation in any of them (the first, in file order;
/// [`find_designation`]) is the named arm of all its programs.
pub fn import_upload(files: &[(&str, &str)]) -> Result<Vec<Program>, ImportError> {
    let mut programs = import::parse_files(files)?.to_replay();
    let arm = files.iter().find_map(|(name, text)| {
        find_designation(text).map(|f| NamedArm {
            designation: f.designation,
            found_in: format!("{name}:{}", f.line),
        })
    });
    for p in &mut programs {
        p.arm = arm.clone();
    }
    Ok(programs)
}

/// The name a raw file has in its upload: its path, with `__` in the file name read as `/`.
fn upload_name(path: &Path) -> String {
    let file = path
        .file_name()
        .map(|n| n.to_string_lossy().replace("__", "/"))
        .unwrap_or_default();
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) => format!("{}/{file}", dir.display()),
        None => file,
    }
}

/// Loads one corpus JSON file.
pub fn load_file(path: &Path) -> Result<Program, CorpusError> {
    // A missing file is reported as missing, whatever its extension.
    fs::metadata(path).map_err(|source| CorpusError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if !has_json_extension(path) {
        return Err(CorpusError::Unsupported {
            path: path.to_path_buf(),
        });
    }
    let text = fs::read_to_string(path).map_err(|source| CorpusError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut program = parse_program(path, &text)?;
    program.arm = named_arm(path, &text);
    Ok(program)
}

/// The arm a corpus program's sources name ([`find_designation`]), looked for in the shared
/// corpus's layout (`<corpus>/json/<file>.json`, `<corpus>/raw/<owner>__<repo>/…`,
/// `<corpus>/MANIFEST.tsv`), in this order: the file's own `source.arm`, the program's raw files (`source.path`,
/// `source.dat_path`), the corpus notes on its repository (its own row first), the repository's
/// other raw files (a repository of the corpus is one cell's programs), the repository's name.
/// `None` when none names one, or the file is not laid out so.
pub fn named_arm(path: &Path, text: &str) -> Option<NamedArm> {
    #[derive(Deserialize)]
    struct Header {
        source: Option<RawSource>,
    }
    let source = serde_json::from_str::<Header>(text).ok()?.source?;
    if let Some(designation) = source.arm.as_deref().and_then(find_designation) {
        return Some(NamedArm {
            designation: designation.designation,
            found_in: "source.arm".into(),
        });
    }
    let repo = source.repo.filter(|r| !r.is_empty())?;
    let json_dir = path.parent()?;
    let corpus = json_dir.parent().filter(|_| json_dir.ends_with("json"))?;
    let raw_dir = corpus.join("raw").join(repo.replace('/', "__"));
    let found = |text: &str, place: &dyn Fn(usize) -> String| {
        find_designation(text).map(|f| NamedArm {
            designation: f.designation,
            found_in: place(f.line),
        })
    };
    let in_file = |file: &Path| {
        let bytes = fs::read(file).ok()?;
        let shown = file
            .strip_prefix(corpus)
            .unwrap_or(file)
            .display()
            .to_string();
        found(&import::decode_text(&bytes), &|line| {
            format!("{shown}:{line}")
        })
    };
    let own: Vec<PathBuf> = [&source.path, &source.dat_path]
        .into_iter()
        .flatten()
        .map(|p| raw_dir.join(p.replace('/', "__")))
        .collect();
    if let Some(arm) = own.iter().find_map(|f| in_file(f)) {
        return Some(arm);
    }
    if let Ok(manifest) = fs::read_to_string(corpus.join("MANIFEST.tsv")) {
        // repo, path, commit, licence, language, targets, routines, notes
        let rows: Vec<Vec<&str>> = manifest
            .lines()
            .map(|l| l.split('\t').collect::<Vec<_>>())
            .filter(|r| r.len() >= 8 && r[0] == repo)
            .collect();
        let own_row = |r: &&Vec<&str>| source.path.as_deref() == Some(r[1]);
        let ordered = rows
            .iter()
            .filter(own_row)
            .chain(rows.iter().filter(|r| !own_row(r)));
        for r in ordered {
            let place = |_| format!("MANIFEST.tsv notes on {}", r[1]);
            if let Some(arm) = found(r[7], &place) {
                return Some(arm);
            }
        }
    }
    let mut others: Vec<PathBuf> = fs::read_dir(&raw_dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && !own.contains(p))
        .collect();
    others.sort();
    others
        .iter()
        .find_map(|f| in_file(f))
        .or_else(|| found(&repo, &|_| "repository name".to_string()))
}

/// Parses the text of a corpus file; `path` names the program and appears in errors.
pub fn parse_program(path: &Path, text: &str) -> Result<Program, CorpusError> {
    let raw: RawProgram = serde_json::from_str(text).map_err(|e| CorpusError::Json {
        path: path.to_path_buf(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    let mut routines = Vec::with_capacity(raw.routines.len());
    for r in raw.routines {
        let mut waypoints = Vec::with_capacity(r.waypoints.len());
        for (index, w) in r.waypoints.iter().enumerate() {
            let pose = Pose::new([w.x, w.y, w.z], [w.qw, w.qx, w.qy, w.qz]).map_err(|source| {
                CorpusError::InvalidPose {
                    path: path.to_path_buf(),
                    routine: r.name.clone(),
                    index,
                    source,
                }
            })?;
            waypoints.push(pose);
        }
        routines.push(Routine {
            name: r.name,
            waypoints,
        });
    }
    Ok(Program {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        source: path.to_path_buf(),
        language: Some(raw.language),
        repo: raw.source.and_then(|s| s.repo),
        arm: None,
        routines,
    })
}

fn has_json_extension(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const ONE: &str = r#"{"source": {"repo": "r"}, "language": "rapid", "stats": {"waypoints": 2},
        "routines": [{"name": "main", "kind": "PROC", "waypoints": [
          {"name": "p10", "x": 0, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0, "motion": "MoveL"},
          {"name": "p20", "x": 10, "y": 0, "z": 0, "qw": 1, "qx": 0, "qy": 0, "qz": 0, "role": "via"}]}]}"#;

    #[test]
    fn parses_and_ignores_unknown_fields() {
        let p = parse_program(Path::new("dir/prog.mod.json"), ONE).unwrap();
        assert_eq!(p.name, "prog.mod");
        assert_eq!(p.language, Some(Language::Rapid));
        assert_eq!(p.repo.as_deref(), Some("r"));
        assert_eq!(p.routines.len(), 1);
        assert_eq!(p.routines[0].name, "main");
        assert_eq!(p.waypoint_count(), 2);
        assert!((p.routines[0].waypoints[1].position().x - 10.0).abs() < 1e-12);
    }

    #[test]
    fn source_and_its_repo_are_optional() {
        let without = ONE.replace(r#""source": {"repo": "r"}, "#, "");
        assert_eq!(
            parse_program(Path::new("p.json"), &without).unwrap().repo,
            None
        );
        let no_repo = ONE.replace(r#"{"repo": "r"}"#, r#"{"path": "a/b.mod"}"#);
        assert_eq!(
            parse_program(Path::new("p.json"), &no_repo).unwrap().repo,
            None
        );
    }

    #[test]
    fn bad_quaternion_names_routine_and_index() {
        let text = ONE.replace(
            r#""x": 10, "y": 0, "z": 0, "qw": 1"#,
            r#""x": 10, "y": 0, "z": 0, "qw": 2"#,
        );
        let err = parse_program(Path::new("prog.json"), &text).unwrap_err();
        match &err {
            CorpusError::InvalidPose { routine, index, .. } => {
                assert_eq!(routine, "main");
                assert_eq!(*index, 1);
            }
            other => panic!("unexpected {other:?}"),
        }
        let msg = err.to_string();
        assert!(
            msg.contains("prog.json") && msg.contains("\"main\"") && msg.contains("waypoint 1"),
            "{msg}"
        );
    }

    #[test]
    fn json_error_has_line_and_column() {
        let err = parse_program(
            Path::new("broken.json"),
            "{\n  \"language\": \"rapid\",\n  \"routines\": [\n",
        )
        .unwrap_err();
        match err {
            CorpusError::Json { line, .. } => assert!(line >= 3),
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn non_json_file_is_refused_clearly_and_missing_file_is_missing() {
        let err = load_file(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/Cargo.toml"
        )))
        .unwrap_err();
        assert!(matches!(err, CorpusError::Unsupported { .. }));
        assert!(err.to_string().contains("expected corpus JSON"));
        let err = load_file(Path::new("no/such/MainModule.mod")).unwrap_err();
        assert!(matches!(err, CorpusError::Io { .. }));
        let err = load_paths(&["no/such/MainModule.mod"]).unwrap_err();
        assert!(matches!(err, CorpusError::Io { .. }));
    }

    #[test]
    fn raw_program_files_are_imported_as_one_upload() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("A.mod");
        let b = dir.path().join("B.mod");
        fs::write(
            &a,
            "MODULE A\n PROC r()\n  MoveL p1, v1, z1, tool0;\n  MoveL Offs(p1,0,0,10), v1, z1, tool0;\n ENDPROC\nENDMODULE\n",
        )
        .unwrap();
        fs::write(
            &b,
            "MODULE B\n CONST robtarget p1:=[[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n",
        )
        .unwrap();
        let programs = load_paths(&[&a, &b]).unwrap();
        // B only declares A's target: it resolves it, and (with no routine) is no program.
        assert_eq!(programs.len(), 1);
        assert_eq!(programs[0].name, "A");
        assert_eq!(programs[0].language, Some(Language::Rapid));
        assert_eq!(programs[0].waypoint_count(), 2);
        let from_dir = load_paths(&[dir.path()]).unwrap();
        assert_eq!(from_dir, programs);
        fs::write(
            &b,
            "MODULE B\n CONST robtarget p1:=[[1,2],[1,0,0,0]];\nENDMODULE\n",
        )
        .unwrap();
        let err = load_paths(&[&a, &b]).unwrap_err();
        assert!(matches!(err, CorpusError::Import(_)), "{err}");
        assert!(err.to_string().contains("B.mod:2:"), "{err}");
    }

    #[test]
    fn an_arm_named_in_any_file_of_an_upload_is_the_arm_of_its_programs() {
        let a = "MODULE A\n PROC r()\n  MoveL p1, v1, z1, tool0;\n  MoveL Offs(p1,0,0,10), v1, z1, tool0;\n ENDPROC\nENDMODULE\n";
        let b = "MODULE B\n ! cell: IRB 4600-60/2.05 on a riser\n CONST robtarget p1:=[[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n";
        let programs = import_upload(&[("A.mod", a), ("B.mod", b)]).unwrap();
        assert_eq!(programs.len(), 1);
        assert_eq!(
            programs[0].arm,
            Some(NamedArm {
                designation: "IRB 4600-60/2.05".into(),
                found_in: "B.mod:2".into(),
            })
        );
        let unnamed = b.replace("IRB 4600-60/2.05", "the big arm");
        let programs = import_upload(&[("A.mod", a), ("B.mod", &unnamed)]).unwrap();
        assert_eq!(programs[0].arm, None);
    }

    /// In the corpus layout a JSON program's arm is looked for in its raw file, the MANIFEST
    /// notes, the repository's other raw files and its name, in that order.
    #[test]
    fn the_corpus_layout_is_searched_for_the_named_arm() {
        let dir = tempfile::tempdir().unwrap();
        let json = dir.path().join("json");
        let raw = dir.path().join("raw").join("o__r");
        fs::create_dir_all(&json).unwrap();
        fs::create_dir_all(&raw).unwrap();
        let program = json.join("o__r__a__p.mod.json");
        let text = ONE.replace(r#"{"repo": "r"}"#, r#"{"repo": "o/r", "path": "a/p.mod"}"#);
        fs::write(&program, &text).unwrap();
        assert_eq!(load_file(&program).unwrap().arm, None);
        // Another file of the repository names it …
        fs::write(raw.join("a__other.mod"), "! Robot Ser# 1600-123456\n").unwrap();
        let arm = load_file(&program).unwrap().arm.unwrap();
        assert_eq!(arm.designation, "IRB 1600");
        assert_eq!(arm.found_in, "raw/o__r/a__other.mod:1");
        // … the notes come first …
        let manifest = "repo\tpath\tcommit\tlicense\tlanguage\tcartesian_targets\troutines\tnotes\n\
                        o/r\ta/p.mod\tc\tunknown\trapid\t2\t1\twelding (IRB 2600)\n";
        fs::write(dir.path().join("MANIFEST.tsv"), manifest).unwrap();
        let arm = load_file(&program).unwrap().arm.unwrap();
        assert_eq!(arm.designation, "IRB 2600");
        assert_eq!(arm.found_in, "MANIFEST.tsv notes on a/p.mod");
        // … and the program's own file before them.
        fs::write(raw.join("a__p.mod"), "MODULE p\n! IRB 140\nENDMODULE\n").unwrap();
        let arm = load_file(&program).unwrap().arm.unwrap();
        assert_eq!(
            (arm.designation.as_str(), arm.found_in.as_str()),
            ("IRB 140", "raw/o__r/a__p.mod:2")
        );
    }
}
