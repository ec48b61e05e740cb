//! The recorded-program type every part shares: a program is ordered routines, a routine is
//! the waypoints visited, in order. Import produces it, replay scores it, the simulated
//! operator teaches it and the application stores it. A leaf: it needs only the engine's pose.
//! A program's revisions (what each change takes back) are [`revisions`].

pub mod revisions;

use std::path::PathBuf;

use crate::engine::Pose;

/// One recorded program: its routines in program (file) order.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// The file stem (`ravenorb__abb-robot-welder__RAPID__PROGMOD__ProgSide1.mod`).
    pub name: String,
    /// Where the program was read from.
    pub source: PathBuf,
    /// Source language as recorded in the corpus: `rapid`, `krl` or `fanuc`.
    pub language: String,
    /// The repository the program comes from, when its file says so (corpus JSON
    /// `source.repo`, e.g. `owner/name`); `None` for other readers.
    pub repo: Option<String>,
    /// The arm the program's sources name, when they name one (`kinematics::designation`):
    /// read by the corpus loader from the program file, its repository's other files and the
    /// corpus notes; `None` for other readers.
    pub arm: Option<NamedArm>,
    pub routines: Vec<Routine>,
}

/// An arm model designation found in a program's sources, and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NamedArm {
    /// In the maker's spelling (`IRB 6700-205/2.80`).
    pub designation: String,
    /// Where it was found (`raw/…/FOUNDRY.mod:10`, `MANIFEST.tsv notes`, `repository name`).
    pub found_in: String,
}

/// One routine (RAPID `PROC`, KRL `DEF`, a FANUC TP file): waypoints in the order visited.
#[derive(Debug, Clone, PartialEq)]
pub struct Routine {
    pub name: String,
    pub waypoints: Vec<Pose>,
}

impl Program {
    /// A constructed program (tests, examples): routines named `r0`, `r1`, … read from
    /// `<name>.json`, in the RAPID dialect, from no repository.
    pub fn of_routines(name: &str, routines: Vec<Vec<Pose>>) -> Program {
        Program {
            name: name.to_string(),
            source: PathBuf::from(format!("{name}.json")),
            language: "rapid".into(),
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

    /// Every waypoint, routine after routine.
    pub fn poses(&self) -> impl Iterator<Item = &Pose> {
        self.routines.iter().flat_map(|r| &r.waypoints)
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
