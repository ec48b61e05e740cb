//! The sequence experts: a [`SequenceExpert`] keeps the elements of every finished routine in
//! its frame (tool-frame moves, work-frame moves or absolute poses, [`super::frames`]). Asked
//! about the routine being taught, it finds the longest context (up to [`MAX_CONTEXT`] elements)
//! that ends the routine and occurred before, element by element within the cell's tolerance, in
//! an earlier routine or earlier in this one, and proposes what followed its most recent
//! occurrence, with the evidence: how long the context is, at how many places it occurred, how
//! many of those agree on what followed, and whether the most recent one is in the routine being
//! taught. It proposes once per context length that occurred, longest first.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::frames::{Frame, Tolerance};
use super::{Candidate, Cell, Evidence, Expert, Proposer};
use crate::engine::pose::{Observation, Pose};

/// Longest context a sequence expert matches.
pub const MAX_CONTEXT: usize = 4;

/// Which translation a sequence expert's candidate takes from the followers of its context.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Followers {
    /// The newest follower's (an exact program's moves that agree within the tolerance may
    /// still differ on purpose, and the newest is the one meant now).
    Newest,
    /// The mean of every follower, of any context length, that agrees with the newest: in a
    /// cell whose noise matters, a move taught by hand again and again averages out.
    Mean,
}

/// One frame's memory of the cell's finished routines, with a grid over the elements'
/// translation parts so a context's places are found without scanning the history.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceExpert {
    frame: Frame,
    history: Vec<Vec<Observation>>,
    /// Grid cell (of side `cell_mm`) → (routine, index) of the elements in it.
    grid: HashMap<[i64; 3], Vec<(u32, u32)>>,
    cell_mm: f64,
}

/// Side of the grid's cells when the tolerance gives none (mm).
const DEFAULT_CELL_MM: f64 = 1.0;

fn cell_of(e: &Observation, side: f64) -> [i64; 3] {
    // Saturating float-to-int casts: a far-away element lands in an edge cell, still correct.
    [0, 1, 2].map(|i| (e[i] / side).floor() as i64)
}

impl SequenceExpert {
    pub fn new(frame: Frame) -> SequenceExpert {
        SequenceExpert {
            frame,
            history: Vec::new(),
            grid: HashMap::new(),
            cell_mm: DEFAULT_CELL_MM,
        }
    }

    /// The three sequence experts, one per frame.
    pub fn all() -> [SequenceExpert; 3] {
        [Frame::Tool, Frame::Work, Frame::Absolute].map(SequenceExpert::new)
    }

    /// Its name in predictions.
    pub fn proposer(&self) -> Proposer {
        Proposer::of(self.frame)
    }

    /// The frame it reads routines in.
    pub fn frame(&self) -> Frame {
        self.frame
    }

    /// Remembers a finished routine.
    pub fn learn(&mut self, routine: &[Pose]) {
        let elements = self.frame.elements(routine);
        if elements.is_empty() {
            return;
        }
        let r = u32::try_from(self.history.len()).unwrap_or(u32::MAX);
        for (i, e) in elements.iter().enumerate() {
            let i = u32::try_from(i).unwrap_or(u32::MAX);
            self.grid
                .entry(cell_of(e, self.cell_mm))
                .or_default()
                .push((r, i));
        }
        self.history.push(elements);
    }

    /// The candidate for the waypoint after `routine` on its longest context (see the module
    /// doc), or `None` when no context of it occurred before.
    pub fn propose(&self, routine: &[Pose], tolerance: &Tolerance) -> Option<Candidate> {
        self.proposals(routine, tolerance, Followers::Newest)
            .into_iter()
            .next()
    }

    /// One candidate per context length that occurred before, longest first: for each length,
    /// what followed the most recent place it occurred at, with that length's evidence; its
    /// translation as `followers` says.
    pub fn proposals(
        &self,
        routine: &[Pose],
        tolerance: &Tolerance,
        followers: Followers,
    ) -> Vec<Candidate> {
        let Some(last) = routine.last() else {
            return Vec::new();
        };
        let current = self.frame.elements(routine);
        if current.is_empty() {
            return Vec::new();
        }
        let reach = MAX_CONTEXT.min(current.len());
        let matched = |seq: &[Observation], next: usize| {
            let mut k = 0;
            while k < reach.min(next)
                && tolerance.holds(&current[current.len() - 1 - k], &seq[next - 1 - k])
            {
                k += 1;
            }
            k
        };
        // Earlier routines: the elements near the last one (the grid's cells around it; a
        // tolerance wider than a cell falls back to every element), oldest first.
        let last_element = &current[current.len() - 1];
        let mut near: Vec<(u32, u32)> = if tolerance.mm <= self.cell_mm {
            let c = cell_of(last_element, self.cell_mm);
            let mut v = Vec::new();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        // Saturating: an element in an edge cell (a saturated cast) has no
                        // neighbour beyond it.
                        let key = [
                            c[0].saturating_add(dx),
                            c[1].saturating_add(dy),
                            c[2].saturating_add(dz),
                        ];
                        v.extend(self.grid.get(&key).into_iter().flatten().copied());
                    }
                }
            }
            v
        } else {
            self.grid.values().flatten().copied().collect()
        };
        near.sort_unstable();
        // (matched context length, in the routine, follower), oldest first.
        let mut places: Vec<(usize, bool, Observation)> = Vec::new();
        for (r, i) in near {
            let seq = &self.history[r as usize];
            let next = i as usize + 1;
            if next < seq.len() {
                let k = matched(seq, next);
                if k > 0 {
                    places.push((k, false, seq[next]));
                }
            }
        }
        for next in 1..current.len() {
            let k = matched(&current, next);
            if k > 0 {
                places.push((k, true, current[next]));
            }
        }
        let longest = places.iter().map(|p| p.0).max().unwrap_or(0);
        let mut out = Vec::new();
        for context in (1..=longest).rev() {
            let here: Vec<&(usize, bool, Observation)> =
                places.iter().filter(|p| p.0 >= context).collect();
            let Some(&&(_, in_routine, latest)) = here.last() else {
                continue;
            };
            let agreeing = here
                .iter()
                .filter(|(_, _, f)| tolerance.holds(f, &latest))
                .count();
            let mut guess = latest;
            if followers == Followers::Mean {
                let agree: Vec<Vector3<f64>> = places
                    .iter()
                    .filter(|(_, _, f)| tolerance.holds(f, &latest))
                    .map(|(_, _, f)| f.fixed_rows::<3>(0).into_owned())
                    .collect();
                let mean = agree.iter().sum::<Vector3<f64>>() / agree.len().max(1) as f64;
                guess.fixed_rows_mut::<3>(0).copy_from(&mean);
            }
            if let Some(pose) = self.frame.apply(last, &guess) {
                out.push(Candidate {
                    pose,
                    evidence: Evidence::Sequence {
                        frame: self.frame,
                        context,
                        places: here.len(),
                        agreeing,
                        in_routine,
                    },
                });
            }
        }
        out
    }
}

impl Expert for SequenceExpert {
    fn learn(&mut self, routine: &[Pose]) {
        SequenceExpert::learn(self, routine);
    }

    /// One candidate per context length, the followers' mean in a noisy cell.
    fn propose(&self, routine: &[Pose], cell: &Cell) -> Vec<Candidate> {
        let followers = if cell.noisy {
            Followers::Mean
        } else {
            Followers::Newest
        };
        self.proposals(routine, &cell.widened(self.frame), followers)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn pose(p: [f64; 3], yaw: f64) -> Pose {
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
        Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
    }

    /// A sequence candidate's context, places, agreeing places and whether it is in the routine.
    fn evidence(c: &Candidate) -> (usize, usize, usize, bool) {
        let Evidence::Sequence {
            context,
            places,
            agreeing,
            in_routine,
            ..
        } = c.evidence
        else {
            panic!("not a sequence expert's evidence: {:?}", c.evidence);
        };
        (context, places, agreeing, in_routine)
    }

    fn same_pose(a: &Pose, b: &Pose) -> bool {
        a.distance_to(b) < 1e-6 && a.angle_to(b) < 1e-6
    }

    /// Every routine works somewhere else, then retracts to one point and returns home: the
    /// absolute expert proposes home after the retract point, the tool-frame expert has no
    /// context for it (the move into the retract point is new every time).
    #[test]
    fn the_absolute_expert_returns_home() {
        let home = pose([0.0, 0.0, 800.0], 0.0);
        let above = pose([500.0, 0.0, 400.0], 0.5);
        let retract = pose([700.0, 50.0, 600.0], 0.1);
        let routine = |x: f64| {
            vec![
                home,
                above,
                pose([500.0 + x, 100.0, 300.0], 0.2),
                retract,
                home,
            ]
        };
        let mut abs = SequenceExpert::new(Frame::Absolute);
        let mut tool = SequenceExpert::new(Frame::Tool);
        for e in [&mut abs, &mut tool] {
            e.learn(&routine(0.0));
        }
        let taught = &routine(70.0)[..4];
        let c = abs
            .propose(taught, &Tolerance::USEFUL)
            .expect("a candidate");
        assert!(same_pose(&c.pose, &home), "{:?}", c.pose);
        assert_eq!(c.proposer(), Proposer::Absolute);
        assert_eq!(
            evidence(&c).0,
            1,
            "the pose before the retract point differs"
        );
        let t = tool.propose(taught, &Tolerance::USEFUL);
        assert!(t.is_none_or(|t| !same_pose(&t.pose, &home)));
    }

    /// A seam approached from 100 mm above, under a torch that turns from seam to seam: the
    /// work-frame expert continues it, the tool-frame one cannot.
    #[test]
    fn the_work_frame_expert_repeats_offsets_under_a_turning_tool() {
        let seam = |x: f64, yaw: f64| {
            vec![
                pose([x, 0.0, 500.0], yaw),
                pose([x, 0.0, 400.0], yaw),
                pose([x + 50.0, 0.0, 400.0], yaw),
                pose([x + 50.0, 0.0, 500.0], yaw),
            ]
        };
        let mut work = SequenceExpert::new(Frame::Work);
        let mut tool = SequenceExpert::new(Frame::Tool);
        for e in [&mut work, &mut tool] {
            e.learn(&seam(0.0, 0.0));
        }
        let next = seam(300.0, 1.2);
        let c = work
            .propose(&next[..2], &Tolerance::USEFUL)
            .expect("a candidate");
        assert!(same_pose(&c.pose, &next[2]), "{:?}", c.pose);
        let (_, places, agreeing, in_routine) = evidence(&c);
        assert_eq!((places, agreeing), (1, 1));
        assert!(!in_routine);
        let t = tool.propose(&next[..2], &Tolerance::USEFUL);
        assert!(t.is_none_or(|t| !same_pose(&t.pose, &next[2])));
    }

    /// A grid row: the same step again and again inside one routine is found in the routine
    /// itself, and every earlier place agrees.
    #[test]
    fn a_grid_is_continued_from_the_routine_itself() {
        let row: Vec<Pose> = (0..6)
            .map(|i| pose([40.0 * i as f64, 0.0, 0.0], 0.0))
            .collect();
        let e = SequenceExpert::new(Frame::Work);
        let c = e
            .propose(&row[..5], &Tolerance::USEFUL)
            .expect("a candidate");
        assert!(same_pose(&c.pose, &row[5]));
        let (context, places, agreeing, in_routine) = evidence(&c);
        assert!(in_routine);
        assert_eq!(context, 3, "the longest context with a follower");
        assert_eq!(places, agreeing);
        // Nothing taught before and one move: no context occurred before.
        assert!(e.propose(&row[..2], &Tolerance::USEFUL).is_none());
    }

    /// A row taught by hand, its steps 40 mm with a few millimetres' error each: the work-frame
    /// expert proposes the last point plus the newest step again, or, asked for the mean
    /// (a cell whose noise matters), plus the mean of the steps that agree.
    #[test]
    fn agreeing_noisy_moves_are_averaged() {
        let steps = [
            [41.5, -2.0, 1.0],
            [38.0, 1.5, -0.5],
            [40.5, 0.5, 2.0],
            [39.0, -1.0, -1.5],
        ];
        let mut at = Vector3::zeros();
        let mut row = vec![pose([0.0; 3], 0.0)];
        for s in steps {
            at += Vector3::from(s);
            row.push(pose([at.x, at.y, at.z], 0.0));
        }
        let tol = Tolerance { mm: 6.0, rad: 0.1 };
        let expert = SequenceExpert::new(Frame::Work);
        let newest = expert.propose(&row, &tol).expect("a candidate");
        assert!((newest.pose.position() - (at + Vector3::from(steps[3]))).norm() < 1e-9);
        let c = expert
            .proposals(&row, &tol, Followers::Mean)
            .into_iter()
            .next()
            .expect("a candidate");
        assert_eq!(evidence(&c).0, 3, "the longest context with a follower");
        // The followers of the matched contexts (of any length) are steps 2, 3 and 4; their
        // mean, after the last point.
        let mean = steps[1..]
            .iter()
            .map(|s| Vector3::from(*s))
            .sum::<Vector3<f64>>()
            / 3.0;
        let want = at + mean;
        assert!((c.pose.position() - want).norm() < 1e-9, "{:?}", c.pose);
    }
}
