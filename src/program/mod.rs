//! The program model every part shares: a program is ordered routines, a routine is the
//! waypoints visited, in order. The importer gives it, the exporter writes it, replay scores
//! it, the simulated operator teaches it, and the application maps the stored program and the
//! wire types to and from it. Pure, and a leaf: it needs only the engine's pose.
//!
//! - [`Program`], [`Routine`] ([`routines`]) and [`Waypoint`] ([`waypoints`]): a waypoint is a
//!   pose alone (`Program<Pose>`, what replay and the simulation read) or a pose with its name,
//!   motion, configuration and reach ([`Waypoint`], what the importer gives and the exporter
//!   writes); `Program<Waypoint>::to_poses` is the one from the other.
//! - [`Language`] ([`language`]): RAPID, KRL, FANUC TP. [`Motion`] ([`motion`]): joint,
//!   linear, circular. [`Configuration`] ([`configuration`]): RAPID `confdata`, KRL Status and
//!   Turn, FANUC `CONFIG`.
//! - A program's revisions, as the changes that take them back: [`revisions`].

pub mod configuration;
pub mod language;
pub mod motion;
pub mod revisions;
pub mod routines;
pub mod waypoints;

use std::path::PathBuf;

use crate::engine::Pose;

pub use configuration::{Configuration, KrlStatusTurn, RapidConfdata};
pub use language::{Language, UnknownLanguage};
pub use motion::Motion;
pub use routines::Routine;
pub use waypoints::{Posed, Waypoint};

/// The language name reports give a program whose language is not known: a cell's stored
/// program (the language of the files it was imported from is not kept).
pub const STORED_LANGUAGE: &str = "stored";

/// One program: its routines in program (file) order; a waypoint is a [`Pose`] or a
/// [`Waypoint`].
#[derive(Debug, Clone, PartialEq)]
pub struct Program<W = Pose> {
    /// The module, file stem or folder (`ravenorb__abb-robot-welder__RAPID__PROGMOD__ProgSide1`),
    /// or the stored program's name.
    pub name: String,
    /// Where the program was read from.
    pub source: PathBuf,
    /// The language it is written in; `None` for a cell's stored program.
    pub language: Option<Language>,
    /// The repository the program comes from, when its file says so (corpus JSON
    /// `source.repo`, e.g. `owner/name`); `None` for other readers.
    pub repo: Option<String>,
    /// The arm the program's sources name, when they name one (`kinematics::designation`):
    /// read by the corpus loader from the program file, its repository's other files and the
    /// corpus notes; `None` for other readers.
    pub arm: Option<NamedArm>,
    pub routines: Vec<Routine<W>>,
}

/// An arm model designation found in a program's sources, and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NamedArm {
    /// In the maker's spelling (`IRB 6700-205/2.80`).
    pub designation: String,
    /// Where it was found (`raw/…/FOUNDRY.mod:10`, `MANIFEST.tsv notes`, `repository name`).
    pub found_in: String,
}

impl Program {
    /// A constructed program (tests, examples): routines named `r0`, `r1`, … read from
    /// `<name>.json`, in RAPID, from no repository.
    pub fn of_routines(name: &str, routines: Vec<Vec<Pose>>) -> Program {
        Program {
            name: name.to_string(),
            source: PathBuf::from(format!("{name}.json")),
            language: Some(Language::Rapid),
            repo: None,
            arm: None,
            routines: routines
                .into_iter()
                .enumerate()
                .map(|(i, waypoints)| Routine {
                    name: format!("r{i}"),
                    waypoints,
                })
                .collect(),
        }
    }
}

impl<W> Program<W> {
    /// Program `name` of `routines`, read from a source of its name, in a language not known,
    /// from no repository and naming no arm.
    pub fn new(name: impl Into<String>, routines: Vec<Routine<W>>) -> Program<W> {
        let name = name.into();
        Program {
            source: PathBuf::from(&name),
            name,
            language: None,
            repo: None,
            arm: None,
            routines,
        }
    }

    /// A cell's stored program `name` (of cell `cell`): its language is not known.
    pub fn stored(name: String, cell: i64, routines: Vec<Routine<W>>) -> Program<W> {
        Program {
            source: PathBuf::from(format!("cell {cell}")),
            ..Program::new(name, routines)
        }
    }

    /// The language's name (`rapid`, `krl`, `fanuc`; [`STORED_LANGUAGE`] when not known).
    pub fn language_name(&self) -> &'static str {
        self.language.map_or(STORED_LANGUAGE, Language::as_str)
    }

    /// The designation of the arm the program names (`None`: it names none).
    pub fn arm_designation(&self) -> Option<&str> {
        self.arm.as_ref().map(|a| a.designation.as_str())
    }

    /// Number of waypoints over all routines.
    pub fn waypoint_count(&self) -> usize {
        self.routines.iter().map(|r| r.waypoints.len()).sum()
    }
}

impl<W: Posed> Program<W> {
    /// Every waypoint's pose, routine after routine.
    pub fn poses(&self) -> impl Iterator<Item = &Pose> {
        self.routines.iter().flat_map(Routine::poses)
    }

    /// The program with only its poses (what replay reads).
    pub fn to_poses(&self) -> Program {
        Program {
            name: self.name.clone(),
            source: self.source.clone(),
            language: self.language,
            repo: self.repo.clone(),
            arm: self.arm.clone(),
            routines: self.routines.iter().map(Routine::to_poses).collect(),
        }
    }
}
