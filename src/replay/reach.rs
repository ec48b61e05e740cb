//! Reachability of replayed guesses: would the arm of the program's cell reach what a method
//! offers?
//!
//! The corpus gives poses in each instruction's work-object frame and never says where the robot
//! stands or which tool it holds, so the check places the arm itself: per program, the robot
//! base is put so that the centre of the program's taught waypoints (the per-axis median, so a
//! few far-off points do not move it) lies at a comfortable point of the arm's workspace (in front of the base at [`ReachSetup::centroid_in_base_mm`]),
//! with the base axes parallel to the work-object frame and the TCP at the flange (`tool0`).
//! Two figures come out: the share of offered guesses that are reachable, and the share of
//! *taught* waypoints that are. The second is the check on the first: where the taught program
//! itself is mostly unreachable (a large cell programmed for a bigger arm, a work object far
//! from the base, another tool), the placement is not meaningful for that program and neither is
//! its guess figure.

use nalgebra::{Isometry3, Translation3, Vector3};
use serde::Serialize;

use crate::engine::Pose;
use crate::kinematics::{Cell, ReachConfig, Robot, bundled_robots_dir, check_reach, load_robot};

use super::corpus::Program;
use super::method::{Guess, Method, ModelSummary};

/// Which arm is checked, for which programs, and where it is placed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReachSetup {
    /// Bundled robot model (`robots/<name>.urdf`).
    pub robot: String,
    /// Program languages the arm stands for (`rapid` for an ABB arm).
    pub languages: Vec<String>,
    /// Where the centre (per-axis median) of the program's waypoints sits in the robot base
    /// frame, mm.
    pub centroid_in_base_mm: [f64; 3],
}

impl Default for ReachSetup {
    /// An IRB 140 for the ABB (RAPID) programs, the centroid 450 mm in front of the base and
    /// 350 mm up (about the middle of its 810 mm reach, at shoulder height).
    fn default() -> ReachSetup {
        ReachSetup {
            robot: "abb_irb140".to_string(),
            languages: vec!["rapid".to_string()],
            centroid_in_base_mm: [450.0, 0.0, 350.0],
        }
    }
}

/// A loaded [`ReachSetup`].
#[derive(Debug, Clone)]
pub struct ReachCheck {
    setup: ReachSetup,
    robot: Robot,
    config: ReachConfig,
}

impl ReachCheck {
    /// Loads the setup's robot from the bundled models.
    pub fn new(setup: ReachSetup) -> Result<ReachCheck, crate::kinematics::KinematicsError> {
        let robot = load_robot(&bundled_robots_dir(), &setup.robot)?;
        Ok(ReachCheck {
            setup,
            robot,
            config: ReachConfig::default(),
        })
    }

    /// The cell of one program, or `None` when the arm does not stand for its language.
    pub fn cell_for(&self, program: &Program) -> Option<Cell> {
        if !self.setup.languages.contains(&program.language) {
            return None;
        }
        let positions: Vec<Vector3<f64>> = program
            .routines
            .iter()
            .flat_map(|r| r.waypoints.iter().map(|w| w.position()))
            .collect();
        if positions.is_empty() {
            return None;
        }
        let median = |axis: usize| {
            let mut v: Vec<f64> = positions.iter().map(|p| p[axis]).collect();
            v.sort_by(f64::total_cmp);
            let m = v.len() / 2;
            if v.len().is_multiple_of(2) {
                0.5 * (v[m - 1] + v[m])
            } else {
                v[m]
            }
        };
        let centroid = Vector3::new(median(0), median(1), median(2));
        let [x, y, z] = self.setup.centroid_in_base_mm;
        let base = centroid - Vector3::new(x, y, z);
        Some(Cell::new(
            Pose::from_isometry(Isometry3::from_parts(
                Translation3::from(base),
                nalgebra::UnitQuaternion::identity(),
            )),
            Pose::identity(),
        ))
    }

    pub fn reachable(&self, cell: &Cell, target: &Pose) -> bool {
        check_reach(&self.robot, cell, target, None, &self.config).is_reachable()
    }
}

/// One predicted waypoint's reachability: `n` (predecessors), the guess's (offered only) and
/// the taught waypoint's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReachRecord {
    pub predecessors: usize,
    pub guess: Option<bool>,
    pub taught: Option<bool>,
}

/// What [`ReachRecorder`] saw for one predicted waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seen {
    predecessors: usize,
    guess: Option<Pose>,
    taught: Option<Pose>,
}

/// Wraps a method under replay and keeps its guesses and the taught waypoints, in the order
/// `replay_program` visits them; the method itself sees no difference. The poses are checked
/// afterwards ([`ReachRecorder::check`]), so the method's measured time does not include it.
pub struct ReachRecorder<'a> {
    inner: &'a mut dyn Method,
    seen: Vec<Seen>,
}

impl<'a> ReachRecorder<'a> {
    pub fn new(inner: &'a mut dyn Method) -> ReachRecorder<'a> {
        ReachRecorder {
            inner,
            seen: Vec::new(),
        }
    }

    /// Reachability of everything seen, for the arm in `cell`.
    pub fn check(&self, check: &ReachCheck, cell: &Cell) -> Vec<ReachRecord> {
        self.seen
            .iter()
            .map(|s| ReachRecord {
                predecessors: s.predecessors,
                guess: s.guess.map(|g| check.reachable(cell, &g)),
                taught: s.taught.map(|t| check.reachable(cell, &t)),
            })
            .collect()
    }
}

impl Method for ReachRecorder<'_> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn reset(&mut self) {
        self.inner.reset();
        self.seen.clear();
    }

    fn predict(&mut self, taught: &[Pose]) -> Option<Guess> {
        let guess = self.inner.predict(taught);
        self.seen.push(Seen {
            predecessors: taught.len(),
            guess: guess.as_ref().map(|g| g.pose),
            taught: None,
        });
        guess
    }

    fn observe(&mut self, taught: &[Pose]) {
        self.inner.observe(taught);
        if taught.len() >= 2
            && let (Some(last), Some(seen)) = (taught.last(), self.seen.last_mut())
            && seen.predecessors + 1 == taught.len()
        {
            seen.taught = Some(*last);
        }
    }

    fn finish_routine(&mut self, routine: &[Pose]) {
        self.inner.finish_routine(routine);
    }

    fn summary(&self) -> Option<ModelSummary> {
        self.inner.summary()
    }
}

/// `(reachable_pct, taught_reachable_pct)` over records with at least `min_predecessors`;
/// `None` where nothing was checked.
pub fn reach_figures<'a>(
    records: impl IntoIterator<Item = &'a ReachRecord>,
    min_predecessors: usize,
) -> (Option<f64>, Option<f64>) {
    let (mut guesses, mut guesses_ok, mut taught, mut taught_ok) = (0usize, 0usize, 0usize, 0usize);
    for r in records
        .into_iter()
        .filter(|r| r.predecessors >= min_predecessors)
    {
        if let Some(ok) = r.guess {
            guesses += 1;
            guesses_ok += usize::from(ok);
        }
        if let Some(ok) = r.taught {
            taught += 1;
            taught_ok += usize::from(ok);
        }
    }
    let pct = |k: usize, of: usize| (of > 0).then(|| 100.0 * k as f64 / of as f64);
    (pct(guesses_ok, guesses), pct(taught_ok, taught))
}
