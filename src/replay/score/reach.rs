//! Reachability of replayed guesses: would the arm of the program's cell reach what a method
//! offers? The arm is placed per program by [`crate::kinematics::placement`]. Two figures come
//! out: the share of offered guesses that are reachable, and the share of *taught* waypoints
//! that are. The second is the check on the first: where the taught program itself is mostly
//! unreachable (a large cell programmed for a bigger arm, a work object far from the base,
//! another tool), the placement is not meaningful for that program and neither is its guess
//! figure.

use crate::engine::Pose;
use crate::kinematics::placement::{PlacedArm, ReachCheck};

use crate::replay::method::{Guess, Method, ModelSummary, Proposal};

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

    /// Reachability of everything seen, for the program's arm where it stands.
    pub fn check(&self, check: &ReachCheck, arm: &PlacedArm) -> Vec<ReachRecord> {
        let reaches = |p: &Pose| check.reaches(&arm.robot, &arm.cell, p);
        self.seen
            .iter()
            .map(|s| ReachRecord {
                predecessors: s.predecessors,
                guess: s.guess.as_ref().map(reaches),
                taught: s.taught.as_ref().map(reaches),
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
        self.propose(taught).guess
    }

    fn propose(&mut self, taught: &[Pose]) -> Proposal {
        let proposal = self.inner.propose(taught);
        self.seen.push(Seen {
            predecessors: taught.len(),
            guess: proposal.guess.as_ref().map(|g| g.pose),
            taught: None,
        });
        proposal
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
