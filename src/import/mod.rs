//! Importing offline robot programs: ABB RAPID, KUKA KRL and FANUC TP listings.
//!
//! Engineers have years of programs on controllers and in offline tools; importing them seeds a
//! cell's model before teaching starts and lets replay measure how well the service would have
//! predicted them. This module is pure: it turns the *text* of the files of one upload into
//! programs → routines → waypoints, and lists what it could not use and why. Reading files,
//! storing programs and HTTP belong to the callers.
//!
//! The files of one upload are parsed together, because real programs are split over files:
//! a RAPID module moves to targets declared in another module of the same task, a KRL `.src`
//! takes its positions from the `.dat` of the same name, and a FANUC backup folder is one
//! program whose TP files are its routines.
//!
//! Conventions (the same as the shared corpus's JSON reading, so the two can be compared):
//! positions in mm in the instruction's work-object / base / user frame; quaternions `w x y z`,
//! normalised, `w ≥ 0`; a circular move gives its via point, then its end point; joint-space
//! moves and targets only known at run time are skipped and counted; routines with fewer than
//! two waypoints are dropped (there is no move to learn from) and reported, and so is a file
//! (a FANUC folder) left with no routine: it gives no program. A file that is not text (NUL or
//! other control characters) is an error.
//!
//! - [`rapid`]: RAPID modules. [`krl`]: KRL `.src`/`.dat`. [`fanuc`]: FANUC `.ls` listings.
//!   [`trajectory`]: a recorded TCP trajectory as CSV (hand-guided teaching).
//! - [`parse_files`] is the entry point; [`ImportedProgram::to_replay`] feeds replay.
//!   [`parse_upload`] is the one for programs to be stored in a cell: it also refuses two
//!   programs of the same name.

pub mod error;
pub mod fanuc;
pub mod krl;
pub mod rapid;
mod tokens;
pub mod trajectory;

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::Serialize;

use crate::engine::Pose;
use crate::program::{Program, Routine};

pub use error::ImportError;

/// The source languages the importer reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Language {
    Rapid,
    Krl,
    Fanuc,
}

impl Language {
    /// The language a file name's extension says, if any (case-insensitive).
    pub fn from_file_name(name: &str) -> Option<Language> {
        let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
        match ext.as_str() {
            "mod" | "modx" | "prg" | "sys" => Some(Language::Rapid),
            "src" | "dat" => Some(Language::Krl),
            "ls" => Some(Language::Fanuc),
            _ => None,
        }
    }

    /// The name used in the corpus and in replay (`rapid`, `krl`, `fanuc`).
    pub fn as_str(self) -> &'static str {
        match self {
            Language::Rapid => "rapid",
            Language::Krl => "krl",
            Language::Fanuc => "fanuc",
        }
    }
}

/// One file of an upload: its name (a path; directories group FANUC files and pair KRL files)
/// and its text.
#[derive(Debug, Clone, Copy)]
pub struct SourceFile<'a> {
    pub name: &'a str,
    pub text: &'a str,
}

/// A 1-based position in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Location {
    pub line: usize,
    pub column: usize,
}

/// The robot configuration a target was taught with, kept so IK can prefer the matching solution.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Configuration {
    /// RAPID `confdata`: quadrants of axes 1, 4, 6 and the configuration number `cfx`.
    Rapid {
        cf1: i64,
        cf4: i64,
        cf6: i64,
        cfx: i64,
    },
    /// KRL `S` (Status) and `T` (Turn) bits, when given.
    Krl {
        status: Option<i64>,
        turn: Option<i64>,
    },
    /// FANUC `CONFIG : 'F U T, 0, 1, 0'` as written.
    Fanuc { config: String },
}

/// How a waypoint is used by a circular move.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CircleRole {
    Via,
    To,
}

/// One Cartesian waypoint as a motion instruction visits it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportedWaypoint {
    /// The target as written (`p10`, `Offs(p10,0,0,50)`, `P[3]`) or `literal@L<line>`.
    pub name: String,
    #[serde(serialize_with = "serialize_pose")]
    pub pose: Pose,
    /// The instruction (`MoveL`, `ArcLStart`, `LIN`, `J`, ...).
    pub motion: String,
    /// For circular moves: via point or end point.
    pub role: Option<CircleRole>,
    /// 1-based line of the instruction in its file.
    pub line: usize,
    pub configuration: Option<Configuration>,
    /// Work object (RAPID `\WObj`) or user frame (FANUC `UF`) the position is expressed in.
    pub frame: Option<String>,
}

/// One routine (RAPID `PROC`/`TRAP`/`FUNC`, KRL `DEF`, one FANUC TP file).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportedRoutine {
    pub name: String,
    /// File the routine is in.
    pub file: String,
    /// 1-based line of its header.
    pub line: usize,
    pub waypoints: Vec<ImportedWaypoint>,
}

/// One program: a RAPID module, a KRL `.src` (with its `.dat`), or a FANUC folder.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportedProgram {
    /// The module / file stem / folder name.
    pub name: String,
    /// The file (RAPID, KRL `.src`) or folder (FANUC) the program comes from.
    pub source: String,
    pub language: Language,
    pub routines: Vec<ImportedRoutine>,
}

/// Why something in the source was not imported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SkipReason {
    /// A joint-space move (`MoveAbsJ`, KRL `AXIS`/`E6AXIS`, FANUC joint representation).
    JointMove,
    /// The target names nothing declared in the upload.
    UnresolvedName,
    /// The target is computed at run time (function call, record field, a variable assigned from
    /// a value the importer cannot evaluate, offsets that are not constants).
    ComputedAtRunTime,
    /// A move inside a RAPID `ERROR` handler: recovery, not the taught path.
    InErrorHandler,
    /// A target whose orientation is not a rotation (e.g. an all-zero quaternion).
    InvalidTarget,
    /// A routine with fewer than two Cartesian waypoints: nothing to learn from.
    ShortRoutine,
    /// A file that is not a program on its own (a KRL `.dat` without its `.src`).
    DataOnly,
    /// A file (a FANUC folder) with no routine left to import — empty, only declarations, or
    /// only routines too short to keep: it gives no program.
    NoRoutines,
}

impl SkipReason {
    /// The reason's name on the wire and in reports (`joint-move`, `unresolved-name`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            SkipReason::JointMove => "joint-move",
            SkipReason::UnresolvedName => "unresolved-name",
            SkipReason::ComputedAtRunTime => "computed-at-run-time",
            SkipReason::InErrorHandler => "in-error-handler",
            SkipReason::InvalidTarget => "invalid-target",
            SkipReason::ShortRoutine => "short-routine",
            SkipReason::DataOnly => "data-only",
            SkipReason::NoRoutines => "no-routines",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            SkipReason::JointMove => "joint-space move",
            SkipReason::UnresolvedName => "target not declared in the upload",
            SkipReason::ComputedAtRunTime => "target computed at run time",
            SkipReason::InErrorHandler => "move in an ERROR handler",
            SkipReason::InvalidTarget => "target orientation is not a rotation",
            SkipReason::ShortRoutine => "routine with fewer than two waypoints",
            SkipReason::DataOnly => "data file without its program",
            SkipReason::NoRoutines => "no routine to import, so no program",
        }
    }
}

/// One thing not imported: where, what and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    pub file: String,
    pub line: usize,
    pub routine: Option<String>,
    pub reason: SkipReason,
    /// The target or routine as written (shortened to 120 characters).
    pub text: String,
}

/// What an upload yielded: programs (in upload order; a FANUC folder where its first file was)
/// and everything skipped.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ImportReport {
    pub programs: Vec<ImportedProgram>,
    pub skipped: Vec<Skipped>,
}

impl ImportReport {
    /// Number of skipped items per reason.
    pub fn skipped_counts(&self) -> BTreeMap<SkipReason, usize> {
        let mut counts = BTreeMap::new();
        for s in &self.skipped {
            *counts.entry(s.reason).or_insert(0) += 1;
        }
        counts
    }

    pub fn waypoint_count(&self) -> usize {
        self.programs
            .iter()
            .map(ImportedProgram::waypoint_count)
            .sum()
    }

    /// Refuses two programs of the same name (compared exactly, as a cell's program names are):
    /// a cell cannot store both, and the error says which files clash.
    pub fn check_unique_names(&self) -> Result<(), ImportError> {
        let mut first: HashMap<&str, &ImportedProgram> = HashMap::new();
        for p in &self.programs {
            if let Some(earlier) = first.insert(p.name.as_str(), p) {
                return Err(ImportError::DuplicateProgram {
                    name: p.name.clone(),
                    first: earlier.source.clone(),
                    second: p.source.clone(),
                });
            }
        }
        Ok(())
    }

    /// The programs as replay reads them.
    pub fn to_replay(&self) -> Vec<Program> {
        self.programs
            .iter()
            .map(ImportedProgram::to_replay)
            .collect()
    }
}

impl ImportedProgram {
    pub fn waypoint_count(&self) -> usize {
        self.routines.iter().map(|r| r.waypoints.len()).sum()
    }

    /// The program as the replay harness reads it (poses only, routines in order).
    pub fn to_replay(&self) -> Program {
        Program {
            name: self.name.clone(),
            source: PathBuf::from(&self.source),
            language: self.language.as_str().to_string(),
            repo: None,
            arm: None,
            routines: self
                .routines
                .iter()
                .map(|r| Routine {
                    name: r.name.clone(),
                    waypoints: r.waypoints.iter().map(|w| w.pose).collect(),
                })
                .collect(),
        }
    }
}

/// Parses the files of one upload together.
///
/// `files` are `(name, text)` pairs; the name's extension selects the language (see
/// [`Language::from_file_name`]) and its directory part groups files: KRL `.src` and `.dat`
/// pair by directory and stem, FANUC `.ls` files of one directory form one program. RAPID
/// targets resolve across all RAPID modules of the upload.
///
/// Never panics; an error names the file, line and column.
///
/// Two programs may have the same name (replay measures them apart; the corpus has two RAPID
/// files of one repository that both declare `MainModule`); [`parse_upload`] refuses that.
pub fn parse_files(files: &[(&str, &str)]) -> Result<ImportReport, ImportError> {
    let files: Vec<SourceFile<'_>> = files
        .iter()
        .map(|(name, text)| SourceFile { name, text })
        .collect();
    parse_sources(&files)
}

/// [`parse_files`] for an upload to be stored as a cell's programs: also refuses two programs
/// of the same name, naming both files ([`ImportError::DuplicateProgram`]).
pub fn parse_upload(files: &[(&str, &str)]) -> Result<ImportReport, ImportError> {
    let report = parse_files(files)?;
    report.check_unique_names()?;
    Ok(report)
}

/// [`parse_files`] over [`SourceFile`]s.
pub fn parse_sources(files: &[SourceFile<'_>]) -> Result<ImportReport, ImportError> {
    let mut rapid_files = Vec::new();
    let mut krl_files = Vec::new();
    let mut fanuc_files = Vec::new();
    for f in files {
        check_text(f)?;
        match Language::from_file_name(f.name) {
            Some(Language::Rapid) => rapid_files.push(*f),
            Some(Language::Krl) => krl_files.push(*f),
            Some(Language::Fanuc) => fanuc_files.push(*f),
            None => {
                return Err(ImportError::UnsupportedFile {
                    file: f.name.to_string(),
                });
            }
        }
    }
    let mut report = ImportReport::default();
    if !rapid_files.is_empty() {
        rapid::parse(&rapid_files, &mut report)?;
    }
    if !krl_files.is_empty() {
        krl::parse(&krl_files, &mut report)?;
    }
    if !fanuc_files.is_empty() {
        fanuc::parse(&fanuc_files, &mut report)?;
    }
    check_poses(&report)?;
    drop_empty_programs(&mut report);
    Ok(report)
}

/// Refuses a file that is not text: one with a NUL or another C0 control character other than
/// tab, line feed, vertical tab, form feed, carriage return and SUB (U+001A, the DOS
/// end-of-file mark). C1 characters stay allowed: they are what Windows-1252 bytes (`€`, `–`
/// in comments) become when [`decode_text`] reads a file as Latin-1.
fn check_text(f: &SourceFile<'_>) -> Result<(), ImportError> {
    let allowed = |c: char| matches!(c, '\t' | '\n' | '\u{0B}' | '\u{0C}' | '\r' | '\u{1A}');
    let Some((at, c)) = f.text.char_indices().find(|&(_, c)| c < ' ' && !allowed(c)) else {
        return Ok(());
    };
    let loc = LineIndex::new(f.text).locate(f.text, at);
    Err(ImportError::NotText {
        file: f.name.to_string(),
        line: loc.line,
        column: loc.column,
        code: u32::from(c),
    })
}

/// A file (or FANUC folder) that yielded no routine is not a program: it is reported instead.
fn drop_empty_programs(report: &mut ImportReport) {
    let (kept, empty): (Vec<_>, Vec<_>) = std::mem::take(&mut report.programs)
        .into_iter()
        .partition(|p| !p.routines.is_empty());
    report.programs = kept;
    report.skipped.extend(empty.into_iter().map(|p| Skipped {
        file: p.source,
        line: 1,
        routine: None,
        reason: SkipReason::NoRoutines,
        text: p.name,
    }));
}

/// Decodes a file's bytes: UTF-8 when valid, otherwise Latin-1 (controllers write Windows-1252
/// comments), so any file can be handed to [`parse_files`].
pub fn decode_text(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    }
}

/// The directory part of a file name (`a/b/c.ls` → `a/b`), `""` when none.
pub(crate) fn directory_of(name: &str) -> &str {
    name.rsplit_once(['/', '\\']).map(|(d, _)| d).unwrap_or("")
}

/// The file name without directory and extension (`a/b/Main.mod` → `Main`).
pub(crate) fn stem_of(name: &str) -> &str {
    let base = name
        .rsplit_once(['/', '\\'])
        .map(|(_, b)| b)
        .unwrap_or(name);
    base.rsplit_once('.').map(|(s, _)| s).unwrap_or(base)
}

/// Byte offset → line and column, for error messages and waypoint lines.
pub(crate) struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    pub(crate) fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    pub(crate) fn locate(&self, text: &str, offset: usize) -> Location {
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        let start = self.starts.get(line - 1).copied().unwrap_or(0);
        let column = text
            .get(start..offset.min(text.len()))
            .map(|s| s.chars().count())
            .unwrap_or(0)
            + 1;
        Location { line, column }
    }

    pub(crate) fn line(&self, offset: usize) -> usize {
        self.starts.partition_point(|&s| s <= offset).max(1)
    }
}

/// A position and orientation while a target is being resolved (before it becomes a [`Pose`]).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Frame {
    pub position: Vector3<f64>,
    pub rotation: UnitQuaternion<f64>,
}

impl Frame {
    fn isometry(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.position), self.rotation)
    }

    /// `self ∘ inner`: the frame `inner`, given relative to `self`, expressed where `self` is
    /// (KRL's geometric operator `self:inner`, the product of the two homogeneous transforms).
    pub(crate) fn compose(&self, inner: &Frame) -> Frame {
        let m = self.isometry() * inner.isometry();
        Frame {
            position: m.translation.vector,
            rotation: m.rotation,
        }
    }
}

/// Rotation from ZYX Euler angles in degrees: `Rz(a)·Ry(b)·Rx(c)` — KRL `A B C`, and FANUC
/// `W P R` (fixed XYZ, i.e. the same matrix with `a = R, b = P, c = W`).
pub(crate) fn rotation_zyx_deg(a: f64, b: f64, c: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(c.to_radians(), b.to_radians(), a.to_radians())
}

/// A unit quaternion from `w x y z` as written, if it is close enough to unit norm to be meant
/// as a rotation (the same tolerance [`Pose::new`] applies); `None` when it is not (a target
/// skipped as [`SkipReason::InvalidTarget`]). A quaternion with a non-finite number is kept as
/// written, so that [`check_poses`] refuses the upload naming the line that moves to it.
pub(crate) fn quaternion_wxyz(q: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    let [w, x, y, z] = q;
    if q.iter().any(|v| !v.is_finite()) {
        return Some(UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z)));
    }
    Pose::new([0.0; 3], q).ok().map(|p| p.rotation())
}

/// The pose of a resolved frame, with the quaternion's sign chosen so `w ≥ 0`. Not checked
/// here: a waypoint's pose is checked once, by [`check_poses`], when the upload is parsed.
pub(crate) fn pose_of(frame: &Frame) -> Pose {
    let q = frame.rotation.into_inner();
    let q = if q.w < 0.0 { -q } else { q };
    Pose::from_isometry(Isometry3::from_parts(
        Translation3::from(frame.position),
        UnitQuaternion::new_unchecked(q),
    ))
}

/// Every imported waypoint's pose passes the check of a pose entering the service
/// ([`crate::engine::PoseValues::to_pose`]: finite numbers, coordinates within ±100 m of the frame, a unit
/// quaternion); the first that does not refuses the upload, naming its file, line, target and
/// value. A corrupted number (`-1e308`, `1e999`) is refused, not skipped: the program is not
/// what its author wrote, and importing the rest of it would hide that.
fn check_poses(report: &ImportReport) -> Result<(), ImportError> {
    for r in report.programs.iter().flat_map(|p| &p.routines) {
        for w in &r.waypoints {
            let values = w.pose.values();
            values.to_pose().map_err(|source| ImportError::Pose {
                file: r.file.clone(),
                line: w.line,
                target: excerpt(&w.name),
                source,
            })?;
        }
    }
    Ok(())
}

/// Shortens source text for a skip record.
pub(crate) fn excerpt(text: &str) -> String {
    let t: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
    if t.chars().count() > 120 {
        t.chars().take(117).chain("...".chars()).collect()
    } else {
        t
    }
}

/// Drops routines with fewer than two waypoints, recording each.
pub(crate) fn drop_short_routines(
    routines: Vec<ImportedRoutine>,
    skipped: &mut Vec<Skipped>,
) -> Vec<ImportedRoutine> {
    let mut kept = Vec::with_capacity(routines.len());
    for r in routines {
        if r.waypoints.len() < 2 {
            skipped.push(Skipped {
                file: r.file.clone(),
                line: r.line,
                routine: Some(r.name.clone()),
                reason: SkipReason::ShortRoutine,
                text: format!("{} ({} waypoint(s))", r.name, r.waypoints.len()),
            });
        } else {
            kept.push(r);
        }
    }
    kept
}

fn serialize_pose<S: serde::Serializer>(pose: &Pose, s: S) -> Result<S::Ok, S::Error> {
    pose.values().serialize(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn languages_by_extension() {
        assert_eq!(Language::from_file_name("a/B.MOD"), Some(Language::Rapid));
        assert_eq!(Language::from_file_name("x.modx"), Some(Language::Rapid));
        assert_eq!(Language::from_file_name("x.dat"), Some(Language::Krl));
        assert_eq!(Language::from_file_name("UP001.LS"), Some(Language::Fanuc));
        assert_eq!(Language::from_file_name("x.json"), None);
        assert_eq!(Language::from_file_name("noext"), None);
    }

    #[test]
    fn names_are_what_serde_writes() {
        use SkipReason::*;
        let reasons = [
            JointMove,
            UnresolvedName,
            ComputedAtRunTime,
            InErrorHandler,
            InvalidTarget,
            ShortRoutine,
            DataOnly,
            NoRoutines,
        ];
        for r in reasons {
            assert_eq!(serde_json::to_value(r).unwrap(), r.as_str(), "{r:?}");
        }
        for l in [Language::Rapid, Language::Krl, Language::Fanuc] {
            assert_eq!(serde_json::to_value(l).unwrap(), l.as_str(), "{l:?}");
        }
    }

    #[test]
    fn unsupported_file_is_an_error_naming_it() {
        let err = parse_files(&[("notes.txt", "hello")]).unwrap_err();
        assert!(err.to_string().contains("notes.txt"), "{err}");
    }

    const MODULE: &str = "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n  MoveL p, v1, z1, tool0;\n  MoveL Offs(p,0,0,10), v1, z1, tool0;\n ENDPROC\nENDMODULE\n";

    #[test]
    fn binary_content_is_an_error_naming_file_line_and_column() {
        for name in ["a.mod", "a.prg", "a.sys", "a.src", "a.dat", "a.ls"] {
            for garbage in ["\0", "\u{1}", "\u{7}", "\u{1B}", "\u{1F}"] {
                let text = format!("MODULE M\n ! {garbage}\nENDMODULE\n");
                let err = parse_files(&[(name, &text)]).unwrap_err();
                assert_eq!(
                    err,
                    ImportError::NotText {
                        file: name.into(),
                        line: 2,
                        column: 4,
                        code: u32::from(garbage.chars().next().unwrap()),
                    }
                );
                assert!(
                    err.to_string().starts_with(&format!("{name}:2:4:")),
                    "{err}"
                );
            }
        }
        // One binary file refuses the whole upload.
        let err =
            parse_files(&[("M.mod", MODULE), ("x.mod", "\u{89}PNG\r\n\u{1A}\n\0\0")]).unwrap_err();
        assert!(
            matches!(err, ImportError::NotText { ref file, .. } if file == "x.mod"),
            "{err}"
        );
    }

    #[test]
    fn text_controls_and_latin1_are_text() {
        // Tab, CR LF, form feed, a DOS end-of-file mark, and Windows-1252 bytes read as Latin-1.
        let bytes = [
            MODULE.replace('\n', "\r\n").as_bytes(),
            b"\t! \x80 \x96 \xe9\x0c\x0b\x1a",
        ]
        .concat();
        let text = decode_text(&bytes);
        let report = parse_files(&[("M.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.programs.len(), 1);
        assert_eq!(report.programs[0].routines[0].waypoints.len(), 2);
    }

    #[test]
    fn a_file_with_no_routine_is_skipped_and_gives_no_program() {
        let cases = [
            ("empty.mod", ""),
            ("blank.prg", " \n\r\n\t"),
            ("comment.sys", "! nothing here\n"),
            ("data.mod", "MODULE Data\n CONST num n:=1;\nENDMODULE\n"),
            (
                "short.mod",
                "MODULE Short\n PROC a()\n  MoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n",
            ),
            ("empty.src", ""),
            ("nodef.src", "&ACCESS RVP\n; just a comment\n"),
        ];
        for (name, text) in cases {
            let report = parse_files(&[(name, text)]).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(report.programs.is_empty(), "{name}: {:?}", report.programs);
            let last = report.skipped.last().expect("a skip record");
            assert_eq!(
                (last.file.as_str(), last.reason, last.routine.as_deref()),
                (name, SkipReason::NoRoutines, None),
                "{name}"
            );
        }
        // With other files: only the empty ones are left out, each reported once.
        let report = parse_files(&[("empty.mod", ""), ("M.mod", MODULE), ("e.src", "")]).unwrap();
        let programs: Vec<_> = report.programs.iter().map(|p| p.source.as_str()).collect();
        assert_eq!(programs, ["M.mod"]);
        let skipped: Vec<_> = report
            .skipped
            .iter()
            .map(|s| (s.file.as_str(), s.reason))
            .collect();
        assert_eq!(
            skipped,
            [
                ("empty.mod", SkipReason::NoRoutines),
                ("e.src", SkipReason::NoRoutines)
            ]
        );
        // A FANUC folder whose listings are all too short gives no program either.
        let ls = "/PROG A\n/MN\n 1:J P[1] 100% FINE ;\n/POS\nP[1]{\n GP1:\n UF : 0, UT : 1,\n X = 1 mm, Y = 2 mm, Z = 3 mm,\n W = 0 deg, P = 0 deg, R = 0 deg\n};\n/END\n";
        let report = parse_files(&[("cell/prog/a.ls", ls)]).unwrap_or_else(|e| panic!("{e}"));
        assert!(report.programs.is_empty());
        let reasons: Vec<_> = report
            .skipped
            .iter()
            .map(|s| (s.file.as_str(), s.reason))
            .collect();
        assert_eq!(
            reasons,
            [
                ("cell/prog/a.ls", SkipReason::ShortRoutine),
                ("cell/prog", SkipReason::NoRoutines)
            ]
        );
    }

    #[test]
    fn ten_thousand_empty_files_make_no_program() {
        let names: Vec<String> = (0..10_000)
            .map(|i| format!("f{i}.{}", ["mod", "src", "prg", "sys"][i % 4]))
            .collect();
        let files: Vec<(&str, &str)> = names.iter().map(|n| (n.as_str(), "")).collect();
        let report = parse_upload(&files).unwrap_or_else(|e| panic!("{e}"));
        assert!(report.programs.is_empty());
        assert_eq!(report.skipped.len(), 10_000);
        assert!(
            report
                .skipped
                .iter()
                .all(|s| s.reason == SkipReason::NoRoutines)
        );
    }

    #[test]
    fn an_upload_with_two_programs_of_one_name_is_refused_naming_both_files() {
        let other = MODULE.replace("PROC main", "PROC other");
        let files = [
            ("A/Main.mod", MODULE),
            ("B/x.mod", "MODULE X\nENDMODULE"),
            ("B/M.mod", &other),
        ];
        // Replay reads both; a cell cannot store both.
        assert_eq!(parse_files(&files).unwrap().programs.len(), 2);
        let err = parse_upload(&files).unwrap_err();
        assert_eq!(
            err,
            ImportError::DuplicateProgram {
                name: "M".into(),
                first: "A/Main.mod".into(),
                second: "B/M.mod".into(),
            }
        );
        let message = err.to_string();
        assert!(
            message.contains("A/Main.mod") && message.contains("B/M.mod"),
            "{message}"
        );
        // KRL programs of one stem in two folders, FANUC folders of one name under two parents.
        let src = "DEF a()\nLIN {X 1,Y 2,Z 3,A 0,B 0,C 0}\nLIN {X 2,Y 2,Z 3,A 0,B 0,C 0}\nEND\n";
        let err = parse_upload(&[("r1/main.src", src), ("r2/main.src", src)]).unwrap_err();
        assert!(
            matches!(&err, ImportError::DuplicateProgram { first, second, .. } if first == "r1/main.src" && second == "r2/main.src"),
            "{err}"
        );
        let ls = "/PROG A\n/MN\n 1:J P[1] 100% FINE ;\n 2:L P[1] 100mm/sec FINE ;\n/POS\nP[1]{\n GP1:\n UF : 0, UT : 1,\n X = 1 mm, Y = 2 mm, Z = 3 mm,\n W = 0 deg, P = 0 deg, R = 0 deg\n};\n/END\n";
        let err = parse_upload(&[("x/prog/a.ls", ls), ("y/prog/a.ls", ls)]).unwrap_err();
        assert!(
            matches!(&err, ImportError::DuplicateProgram { name, first, second } if name == "prog" && first == "x/prog" && second == "y/prog"),
            "{err}"
        );
        // Names are compared exactly, as the cell stores them; distinct names pass.
        let lower = MODULE.replace("MODULE M", "MODULE m");
        assert_eq!(
            parse_upload(&[("a.mod", MODULE), ("b.mod", &lower)])
                .unwrap()
                .programs
                .len(),
            2
        );
        // A file that gives no program clashes with nothing.
        assert!(parse_upload(&[("a.mod", MODULE), ("b.mod", "MODULE M\nENDMODULE")]).is_ok());
    }

    /// Issue 46: an import let −1e308 through to the learner, whose k-d tree panicked. Every
    /// waypoint's pose is checked once the files are parsed: a number that is not finite or a
    /// coordinate beyond ±100 m refuses the upload, naming the file, the line of the move, the
    /// value and the target, in each language; a finite quaternion that is not a rotation is
    /// still only skipped.
    #[test]
    fn a_waypoint_out_of_range_or_not_finite_refuses_the_upload_naming_it() {
        let rapid = |p2: &str, q2: &str| {
            format!(
                "MODULE Weld
 CONST robtarget p1:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];
                  CONST robtarget p2:=[[{p2}],[{q2}],[0,0,0,0],[0,0,0,0,0,0]];
 PROC main()
                   MoveL p1, v1, z1, tool0;
  MoveL p2, v1, z1, tool0;
  MoveL p1, v1, z1, tool0;
                  ENDPROC
ENDMODULE
"
            )
        };
        let krl = |x: &str| {
            format!(
                "DEF a()
LIN {{X 1,Y 2,Z 3,A 0,B 0,C 0}}
LIN {{X {x},Y 2,Z 3,A 0,B 0,C 0}}
END
"
            )
        };
        let fanuc = |z: &str| {
            format!(
                "/PROG A
/MN
 1:L P[1] 100mm/sec FINE ;
 2:L P[2] 100mm/sec FINE ;
/POS
                 P[1]{{
 GP1:
 UF : 0, UT : 1,
 X = 1 mm, Y = 2 mm, Z = 3 mm,
 W = 0 deg, P = 0 deg, R = 0 deg
}};
                 P[2]{{
 GP1:
 UF : 0, UT : 1,
 X = 1 mm, Y = 2 mm, Z = {z} mm,
 W = 0 deg, P = 0 deg, R = 0 deg
}};
/END
"
            )
        };
        let cases = [
            (
                "weld.mod",
                rapid("-1e308,2,3", "1,0,0,0"),
                "weld.mod line 6: x = -1e308 is outside ±100000 mm (target p2)",
            ),
            (
                "weld.mod",
                rapid("1,2,1e999", "1,0,0,0"),
                "weld.mod line 6: z = inf is not a finite number (target p2)",
            ),
            (
                "weld.mod",
                rapid("1,2,3", "1e999,0,0,0"),
                "weld.mod line 6: qw = inf is not a finite number (target p2)",
            ),
            (
                "r/a.src",
                krl("1e308"),
                "r/a.src line 3: x = 1e308 is outside ±100000 mm",
            ),
            (
                "r/a.src",
                krl("-100000.5"),
                "r/a.src line 3: x = -100000.5 is outside ±100000 mm",
            ),
            (
                "c/a/A.LS",
                fanuc("-250000"),
                "c/a/A.LS line 4: z = -250000.0 is outside ±100000 mm (target P[2])",
            ),
        ];
        for (name, text, said) in &cases {
            let err = parse_upload(&[(name, text)]).unwrap_err();
            assert!(matches!(err, ImportError::Pose { .. }), "{err:?}");
            assert_eq!(
                err.to_string().split(" (target").next(),
                said.split(" (target").next(),
                "{err}"
            );
            assert!(err.to_string().starts_with(said), "{err}");
        }
        // At the bound: imported. A quaternion of norm 1e308: skipped as not a rotation.
        let report = parse_upload(&[("k.src", &krl("-100000"))]).unwrap();
        assert_eq!(
            report.programs[0].routines[0].waypoints[1]
                .pose
                .position()
                .x,
            -100_000.0
        );
        let report = parse_upload(&[("weld.mod", &rapid("1,2,3", "1e308,0,0,0"))]).unwrap();
        assert_eq!(report.programs[0].waypoint_count(), 2);
        assert_eq!(
            report.skipped_counts().get(&SkipReason::InvalidTarget),
            Some(&1)
        );
    }

    #[test]
    fn line_index_locates() {
        let text = "ab\ncdé\nf";
        let idx = LineIndex::new(text);
        assert_eq!(idx.locate(text, 0), Location { line: 1, column: 1 });
        assert_eq!(idx.locate(text, 4), Location { line: 2, column: 2 });
        assert_eq!(
            idx.locate(text, text.len()),
            Location { line: 3, column: 2 }
        );
    }

    #[test]
    fn zyx_matches_a_quarter_turn_about_z() {
        let q = rotation_zyx_deg(90.0, 0.0, 0.0);
        let v = q * Vector3::x();
        assert!((v - Vector3::y()).norm() < 1e-12);
    }
}
