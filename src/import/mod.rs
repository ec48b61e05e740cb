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
//! - [`parse_files`] is the entry point: each program it reads is the program model
//!   ([`crate::program::Program`] of [`crate::program::Waypoint`]s: names, poses, motion
//!   classes, configurations), with where it was read beside it ([`origin`]); what it could not
//!   use is a [`Skipped`] ([`skipped`]). [`ImportReport::to_replay`] feeds replay.
//!   [`parse_upload`] is the one for programs to be stored in a cell: it also refuses two
//!   programs of the same name.
//! - The files' text ([`text`]: decoding, line and column) and the frames targets resolve to
//!   ([`frames`]) are shared by the three readers.

pub mod error;
pub mod fanuc;
mod frames;
pub mod krl;
pub mod origin;
pub mod rapid;
pub mod skipped;
pub mod text;
mod tokens;
pub mod trajectory;

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

use crate::program::{Language, Program, Waypoint};

pub use error::ImportError;
pub(crate) use frames::{Frame, pose_of, quaternion_wxyz, rotation_zyx_deg};
pub use origin::{CircleRole, RoutineOrigin, WaypointOrigin};
pub(crate) use origin::{ReadRoutine, drop_short_routines};
pub(crate) use skipped::excerpt;
pub use skipped::{SkipReason, Skipped};
pub(crate) use text::{LineIndex, directory_of, stem_of};
pub use text::{Location, SourceFile, decode_text};

/// One program of an upload (a RAPID module, a KRL `.src` with its `.dat`, a FANUC folder) and
/// where its routines were read.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The program: its name (the module, file stem or folder), its source (the file, or the
    /// FANUC folder), its language and its routines.
    pub program: Program<Waypoint>,
    /// Where each of the program's routines was read, in the same order.
    pub origins: Vec<RoutineOrigin>,
}

impl Imported {
    /// The program `name` read from `source` in `language`, of the routines read.
    pub(crate) fn of(
        name: &str,
        source: &str,
        language: Language,
        routines: Vec<ReadRoutine>,
    ) -> Imported {
        let (routines, origins) = routines.into_iter().map(|r| (r.routine, r.origin)).unzip();
        Imported {
            program: Program {
                name: name.to_string(),
                source: PathBuf::from(source),
                language: Some(language),
                repo: None,
                arm: None,
                routines,
            },
            origins,
        }
    }

    /// The file (RAPID, KRL `.src`) or folder (FANUC) the program comes from.
    pub fn source(&self) -> String {
        self.program.source.to_string_lossy().into_owned()
    }
}

/// What an upload yielded: programs (in upload order; a FANUC folder where its first file was)
/// and everything skipped.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ImportReport {
    pub programs: Vec<Imported>,
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
            .map(|p| p.program.waypoint_count())
            .sum()
    }

    /// Refuses two programs of the same name (compared exactly, as a cell's program names are):
    /// a cell cannot store both, and the error says which files clash.
    pub fn check_unique_names(&self) -> Result<(), ImportError> {
        let mut first: HashMap<&str, &Imported> = HashMap::new();
        for p in &self.programs {
            if let Some(earlier) = first.insert(p.program.name.as_str(), p) {
                return Err(ImportError::DuplicateProgram {
                    name: p.program.name.clone(),
                    first: earlier.source(),
                    second: p.source(),
                });
            }
        }
        Ok(())
    }

    /// The programs as replay reads them (poses only, routines in order).
    pub fn to_replay(&self) -> Vec<Program> {
        self.programs.iter().map(|p| p.program.to_poses()).collect()
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
        .partition(|p| !p.program.routines.is_empty());
    report.programs = kept;
    report.skipped.extend(empty.into_iter().map(|p| Skipped {
        file: p.source(),
        line: 1,
        routine: None,
        reason: SkipReason::NoRoutines,
        text: p.program.name,
    }));
}

/// Every imported waypoint's pose passes the check of a pose entering the service
/// ([`crate::engine::PoseValues::to_pose`]: finite numbers, coordinates within ±100 m of the frame, a unit
/// quaternion); the first that does not refuses the upload, naming its file, line, target and
/// value. A corrupted number (`-1e308`, `1e999`) is refused, not skipped: the program is not
/// what its author wrote, and importing the rest of it would hide that.
fn check_poses(report: &ImportReport) -> Result<(), ImportError> {
    for p in &report.programs {
        for (r, origin) in p.program.routines.iter().zip(&p.origins) {
            for (w, at) in r.waypoints.iter().zip(&origin.waypoints) {
                let values = w.pose.values();
                values.to_pose().map_err(|source| ImportError::Pose {
                    file: origin.file.clone(),
                    line: at.line,
                    target: excerpt(w.name.as_deref().unwrap_or("")),
                    source,
                })?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
