//! Oracle bounds (issue 13): how much of the scoreboard is within reach of a predictor that
//! draws on one kind of repeat, if it always knew which candidate to offer.
//!
//! An oracle is **not a method**: it looks at the true next waypoint. For each waypoint the
//! methods are scored on (`w[n]`, `n ≥ 1`; the headline population `n ≥ 2`) it asks whether the
//! program's history holds a candidate of its kind within the scoreboard's useful tolerance
//! ([`USEFUL_MAX_MM`] and [`USEFUL_MAX_RAD`], both for the same candidate) of `w[n]`.
//!
//! *History* is exactly what a [`crate::replay::Method`] has been shown when it is asked for `w[n]`
//! (its call order: `finish_routine` of every earlier routine of the program, `observe` of the
//! current routine's `w[0] … w[n−1]`): every waypoint of the earlier routines and the current
//! routine's taught waypoints, `w[n−1]` included. Moves are between consecutive waypoints of one
//! routine, never across routines.
//!
//! | oracle | candidates after the last pose `w[n−1]` |
//! |---|---|
//! | `oracle_tool` | `w[n−1] · T` for every earlier SRHCT move `T` ([`Frame::Tool`]) |
//! | `oracle_absolute` | every earlier pose, `w[n−1]` itself included ([`Frame::Absolute`]) |
//! | `oracle_work` | `(p_{n−1} + Δp, Δq · q_{n−1})` for every earlier work-frame move ([`Frame::Work`]) |
//! | `oracle_any` | any of the three |
//!
//! The check is done in element space ([`crate::replay::frames`]: there, distance and angle are those of
//! the guesses), one linear scan of the history per waypoint and frame; the whole corpus takes a
//! few milliseconds.
//!
//! In the report an oracle is a perfect selector over its candidates: it "offers" exactly where
//! a candidate is within tolerance, so `offered = useful = covered`, precision 100 %,
//! `useful_pct` is the share covered and `saved_pct = 0.9 · share` is the most that any method
//! offering only such candidates could save. Its median errors are those of the closest covering
//! candidate; it has no confidence, model or timing (`null`).

use crate::engine::{Observation, Pose};

use crate::replay::corpus::Program;
use crate::replay::frames::{Frame, angle, close, distance};
use crate::replay::playback::{ProgramRecord, WaypointRecord};
#[cfg(doc)]
use crate::replay::playback::{USEFUL_MAX_MM, USEFUL_MAX_RAD};

/// One oracle: its report name, the frames whose candidates it considers, and what they are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oracle {
    pub name: &'static str,
    pub frames: &'static [Frame],
    /// The candidates, in words (the report's `oracles` section carries it).
    pub candidates: &'static str,
}

/// The oracles in report order.
pub const ORACLES: [Oracle; 4] = [
    Oracle {
        name: "oracle_tool",
        frames: &[Frame::Tool],
        candidates: "an earlier tool-frame move (SRHCT, W_{k-1}^-1 W_k) applied to the last pose",
    },
    Oracle {
        name: "oracle_absolute",
        frames: &[Frame::Absolute],
        candidates: "an earlier absolute pose (the last one included)",
    },
    Oracle {
        name: "oracle_work",
        frames: &[Frame::Work],
        candidates: "an earlier work-frame move (p_k - p_{k-1}, q_k q_{k-1}*) applied to the last pose",
    },
    Oracle {
        name: "oracle_any",
        frames: &Frame::ALL,
        candidates: "any candidate of the three kinds above",
    },
];

/// Whether a name is an oracle's (`oracle_…`), not a method's.
pub fn is_oracle(name: &str) -> bool {
    name.starts_with("oracle_")
}

/// The closest covering candidate of one frame: (distance mm, angle rad), or `None` when no
/// candidate in `history` is within tolerance of `target`.
fn best_cover<'a>(
    target: &Observation,
    history: impl IntoIterator<Item = &'a Observation>,
) -> Option<(f64, f64)> {
    history
        .into_iter()
        .filter(|c| close(target, c))
        .map(|c| (distance(target, c), angle(target, c)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// The oracles' records on one program, one [`ProgramRecord`] per entry of [`ORACLES`], with
/// the same waypoints (and order) as [`crate::replay::replay_program`] gives a method.
pub fn oracle_records(program: &Program) -> Vec<ProgramRecord> {
    // Elements of the finished routines, per frame (in `Frame::ALL` order).
    let mut history: Vec<Vec<Observation>> = vec![Vec::new(); Frame::ALL.len()];
    let mut records: Vec<Vec<WaypointRecord>> = vec![Vec::new(); ORACLES.len()];
    for (routine_index, routine) in program.routines.iter().enumerate() {
        let w: &[Pose] = &routine.waypoints;
        let current: Vec<Vec<Observation>> = Frame::ALL.iter().map(|f| f.elements(w)).collect();
        for n in 1..w.len() {
            let (last, truth) = (&w[n - 1], &w[n]);
            // Per frame, the closest covering candidate. Taught so far: w[..n], i.e. the first
            // n − 1 moves of the move frames, the first n poses of the absolute one.
            let cover: Vec<Option<(f64, f64)>> = Frame::ALL
                .iter()
                .enumerate()
                .map(|(f, frame)| {
                    let taught = if frame.is_move() { n - 1 } else { n };
                    let target = frame.target(last, truth);
                    best_cover(&target, history[f].iter().chain(&current[f][..taught]))
                })
                .collect();
            for (o, oracle) in ORACLES.iter().enumerate() {
                let best = oracle
                    .frames
                    .iter()
                    .filter_map(|frame| {
                        let f = Frame::ALL.iter().position(|g| g == frame)?;
                        cover[f]
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                records[o].push(WaypointRecord {
                    routine: routine_index,
                    predecessors: n,
                    offered: best.is_some(),
                    cart_mm: best.map(|b| b.0),
                    angle_rad: best.map(|b| b.1),
                    travel_mm: last.distance_to(truth),
                    travel_rad: last.angle_to(truth),
                    confidence: None,
                    phi: None,
                    psi: None,
                    assimilated: None,
                    micros: 0.0,
                    candidate: None,
                });
            }
        }
        for (h, c) in history.iter_mut().zip(current) {
            h.extend(c);
        }
    }
    ORACLES
        .iter()
        .zip(records)
        .map(|(oracle, waypoints)| ProgramRecord {
            program: program.name.clone(),
            language: program.language_name().to_string(),
            method: oracle.name.to_string(),
            waypoints,
            summary: None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Pose {
        Pose::new([x, y, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap()
    }

    fn program(routines: Vec<Vec<Pose>>) -> Program {
        Program::of_routines("t", routines)
    }

    fn covered(records: &[ProgramRecord], name: &str) -> Vec<bool> {
        let o = ORACLES.iter().position(|o| o.name == name).unwrap();
        records[o].waypoints.iter().map(|r| r.offered).collect()
    }

    /// The history is what a method has seen: the current routine up to the last pose, never
    /// the waypoint being guessed, and moves never span two routines.
    #[test]
    fn history_is_what_a_method_has_seen() {
        // r0: a move of +10 x. r1 starts 500 away (no cross-routine move of +490), goes +10 y,
        // back to its start, then +10 x twice.
        let prog = program(vec![
            vec![p(0.0, 0.0), p(10.0, 0.0)],
            vec![
                p(500.0, 0.0),
                p(500.0, 10.0),
                p(500.0, 0.0),
                p(510.0, 0.0),
                p(520.0, 0.0),
            ],
        ]);
        let r = oracle_records(&prog);
        // Waypoints: r0 n=1; r1 n=1..4.
        assert_eq!(
            covered(&r, "oracle_tool"),
            [false, false, false, true, true]
        );
        // r1 n=2 returns to r1's first pose; nothing else repeats a pose.
        assert_eq!(
            covered(&r, "oracle_absolute"),
            [false, false, true, false, false]
        );
        // Identity orientations: work-frame and tool-frame moves coincide.
        assert_eq!(covered(&r, "oracle_work"), covered(&r, "oracle_tool"));
        assert_eq!(covered(&r, "oracle_any"), [false, false, true, true, true]);
        let any = &r[3].waypoints[2];
        assert_eq!((any.cart_mm, any.angle_rad), (Some(0.0), Some(0.0)));
    }

    /// A repeated waypoint (zero move) is a return to the last pose.
    #[test]
    fn the_last_pose_is_a_candidate() {
        let prog = program(vec![vec![p(0.0, 0.0), p(7.0, 3.0), p(7.0, 3.0)]]);
        assert_eq!(
            covered(&oracle_records(&prog), "oracle_absolute"),
            [false, true]
        );
    }
}
