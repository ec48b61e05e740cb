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
//! two waypoints are dropped (there is no move to learn from) and reported.
//!
//! - [`rapid`]: RAPID modules. [`krl`]: KRL `.src`/`.dat`. [`fanuc`]: FANUC `.ls` listings.
//! - [`parse_files`] is the entry point; [`ImportedProgram::to_replay`] feeds replay.

pub mod error;
pub mod fanuc;
pub mod krl;
pub mod rapid;

use std::collections::BTreeMap;
use std::path::PathBuf;

use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

use crate::engine::Pose;
use crate::replay::corpus::{Program, Routine};

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
pub struct Waypoint {
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

/// One routine (RAPID `PROC`/`TRAP`, KRL `DEF`, one FANUC TP file).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportedRoutine {
    pub name: String,
    /// File the routine is in.
    pub file: String,
    /// 1-based line of its header.
    pub line: usize,
    pub waypoints: Vec<Waypoint>,
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
}

impl SkipReason {
    pub fn describe(self) -> &'static str {
        match self {
            SkipReason::JointMove => "joint-space move",
            SkipReason::UnresolvedName => "target not declared in the upload",
            SkipReason::ComputedAtRunTime => "target computed at run time",
            SkipReason::InErrorHandler => "move in an ERROR handler",
            SkipReason::InvalidTarget => "target orientation is not a rotation",
            SkipReason::ShortRoutine => "routine with fewer than two waypoints",
            SkipReason::DataOnly => "data file without its program",
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
pub fn parse_files(files: &[(&str, &str)]) -> Result<ImportReport, ImportError> {
    let files: Vec<SourceFile<'_>> = files
        .iter()
        .map(|(name, text)| SourceFile { name, text })
        .collect();
    parse_sources(&files)
}

/// [`parse_files`] over [`SourceFile`]s.
pub fn parse_sources(files: &[SourceFile<'_>]) -> Result<ImportReport, ImportError> {
    let mut rapid_files = Vec::new();
    let mut krl_files = Vec::new();
    let mut fanuc_files = Vec::new();
    for f in files {
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
    Ok(report)
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

/// Rotation from ZYX Euler angles in degrees: `Rz(a)·Ry(b)·Rx(c)` — KRL `A B C`, and FANUC
/// `W P R` (fixed XYZ, i.e. the same matrix with `a = R, b = P, c = W`).
pub(crate) fn rotation_zyx_deg(a: f64, b: f64, c: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(c.to_radians(), b.to_radians(), a.to_radians())
}

/// A unit quaternion from `w x y z` as written, if it is close enough to unit norm to be meant
/// as a rotation (the same tolerance [`Pose::new`] applies).
pub(crate) fn quaternion_wxyz(q: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    Pose::new([0.0; 3], q).ok().map(|p| p.rotation())
}

/// The pose of a resolved frame, with the quaternion's sign chosen so `w ≥ 0`.
pub(crate) fn pose_of(frame: &Frame) -> Option<Pose> {
    let q = frame.rotation.quaternion();
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    Pose::new(
        [frame.position.x, frame.position.y, frame.position.z],
        [s * q.w, s * q.i, s * q.j, s * q.k],
    )
    .ok()
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
    fn unsupported_file_is_an_error_naming_it() {
        let err = parse_files(&[("notes.txt", "hello")]).unwrap_err();
        assert!(err.to_string().contains("notes.txt"), "{err}");
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
