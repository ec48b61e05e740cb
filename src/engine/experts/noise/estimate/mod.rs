//! The teaching noise a cell learns from what it is taught, without a calibration routine.
//!
//! A task taught again somewhere else is an earlier stretch of waypoints moved by one rigid
//! transform, plus the operator's errors in both. So the misfit of the best rigid alignment of a
//! stretch of [`STRETCH`] waypoints onto an earlier one measures the noise: with a per-axis error
//! σ on every waypoint, the sum of the squared position residuals is `2σ²·χ²(ν)`, `ν = 3·STRETCH
//! − 6` (the transform takes six). The rotations between consecutive waypoints, which no rigid
//! transform changes, differ by four rotation errors each, so their squared angles sum to
//! `4σ_rad²·χ²(3·(STRETCH − 1))`.
//!
//! Not every earlier stretch with the same step lengths is a repeat. Each pair's misfit is read
//! as drawn from a mixture: a repeat (the χ² above) or not (spread evenly over the logarithm of
//! the misfit, between [`OTHER_MIN_MM2`] and [`OTHER_MAX_MM2`]); expectation-maximisation fits σ
//! and the share of repeats. An exact program's repeats have no misfit at all and give σ ≈ 0.
//! Until the pairs read as repeats count [`MIN_REPEATS`], there is no estimate.
//!
//! An operator placing by hand never comes back to exactly the same spot, so a cell taught a
//! waypoint exactly where an earlier one was ([`EXACT_REVISIT_MM`]) is taught exactly, however
//! its repeats look: after [`EXACT_REVISITS`] such waypoints (not counting suggestions taken as
//! offered, which are exact copies whoever teaches) the estimate is exact for good and no more
//! pairs are aligned. Offline programs return to their named targets all the time; their
//! stretches of about the same shape (welds of other pitches, a grid's rows) would otherwise
//! read as repeats of a noisy operator (on the shared corpus, four exact programs read as 3 to
//! 12 mm before this rule). For the same reason no noise is believed before [`MIN_ROUTINES`].
//!
//! **Returns.** A pallet, a tray or a grid is often taught as one long routine, and shows its
//! operator within itself, but [`MIN_ROUTINES`] would wait for two more. What tells a hand
//! that repeats from an exact program whose stretches merely look alike is how it comes back:
//! an operator palletising by hand returns to the pick station for every item and never lands
//! where they did before, so a waypoint near an earlier one (within [`RETURN_MM`] and
//! [`RETURN_RAD`]) after the arm had gone [`RETURN_AWAY_MM`] from it, but not exactly on it, is a
//! *return*. An exact program's returns are mostly exact revisits, and its near ones few: on
//! the shared corpus, the one program read as noisy in its first routines (a welding program,
//! 14 mm after its second routine of 271 waypoints) has 12 returns after 147 waypoints (8 %),
//! a pallet taught with a 20 mm joystick 12 after 26 (46 %). So the noise is believed before
//! [`MIN_ROUTINES`] once [`MIN_RETURNS`] returns are at least [`MIN_RETURN_SHARE`] of the
//! waypoints taught by hand (a suggestion taken as offered cannot be a return, so it does not
//! count against the share). Until the stretches' repeats give a fit, the returns' own gaps
//! give the estimate: two placements of one meant pose by a hand of σ per axis are `σ·√6` apart
//! (RMS). On a pallet taught with a 20 mm joystick that is believed at about its 25th waypoint
//! and reads 11–12 mm for 11.5 (the stretches' fit, which waited for its 48th–63rd, read
//! 14–17).
//!
//! A routine shorter than a stretch (a pick, a place, a tack weld of three to five waypoints)
//! is aligned whole with the earlier routines of its length ([`SHORT_ROUTINE`]); each pair's
//! misfit then has its own degrees of freedom (`3n − 6`), and the fit weighs them so.
//!
//! Pairs are found as the template expert finds its places ([`super::super::template`]): the
//! waypoints are kept sorted by the length of the move into them, and only stretches whose every
//! step is within [`STEP_GATE_MM`] of the new one's are aligned, at most [`MAX_PAIRS`] for each
//! new stretch, out of at most [`MAX_EXAMINED`] looked at (a long routine of equal steps costs
//! no more than a short one per waypoint). Finished routines are learned for good; the routine
//! being taught shows the noise too, its newest stretch aligned as each waypoint is taught
//! ([`NoiseEstimator::open_pairs`], [`NoiseEstimator::estimate_with`]: a cell whose first repeats
//! come within one long routine learns its operator there and then). The teacher keeps those
//! pairs with their waypoint, so undo takes them back, and a rebuild that learns the same
//! routines in the same order gets the same estimate.
//!
//! The estimator's parts: [`stretches`] aligns two stretches of waypoints and gives the pair's
//! misfits; [`mixture`] fits the noise to the pairs' misfits.

mod mixture;
mod stretches;

use super::Noise;
use crate::engine::pose::Pose;
pub use mixture::{MIN_REPEATS, OTHER_MAX_MM2, OTHER_MIN_MM2, Pair};
use mixture::{SIGMA_CAP_MM, SIGMA_FLOOR_MM, fit_mixture};
pub use stretches::{MIN_EXTENT_MM, STEP_GATE_MM, STRETCH, TURN_GATE_RAD};
use stretches::{compare, extent, moves_as_long_as, steps_match};

/// A waypoint this close to an earlier one, mm, is an exact revisit.
pub const EXACT_REVISIT_MM: f64 = 1e-3;
/// Exact revisits after which the cell is taught exactly (module doc).
pub const EXACT_REVISITS: usize = 2;
/// Routines a cell is taught before its noise is believed: the first routines of an offline
/// program may not return to a named target yet (on the shared corpus one welding program read
/// as 14 mm after its second routine and offered 26 wrong suggestions in its third, before its
/// exact revisits showed).
pub const MIN_ROUTINES: usize = 3;
/// Returns (module doc, "Returns") after which the noise is believed before [`MIN_ROUTINES`] …
pub const MIN_RETURNS: usize = 12;
/// … when they are at least this share of the waypoints taught.
pub const MIN_RETURN_SHARE: f64 = 0.25;
/// A return comes back within this of an earlier waypoint, mm …
pub const RETURN_MM: f64 = 60.0;
/// … and this, rad …
pub const RETURN_RAD: f64 = 0.2;
/// … after the arm went at least this far from it, mm (or in another routine).
pub const RETURN_AWAY_MM: f64 = 150.0;

/// Earlier stretches aligned with each new one, at the most.
pub const MAX_PAIRS: usize = 16;
/// Earlier stretches of about the same last step looked at for each new one, at the most.
pub const MAX_EXAMINED: usize = 256;
/// Pairs kept, the newest (a cell's operator may change; the estimate follows the recent ones).
pub const MAX_SAMPLES: usize = 4_000;

/// The fewest waypoints of a routine shorter than [`STRETCH`] that is aligned whole with the
/// earlier routines of its length: three fix a rigid transform and leave three degrees of
/// freedom of misfit.
pub const SHORT_ROUTINE: usize = 3;

/// What the routine being taught showed of the noise so far ([`NoiseEstimator::estimate_with`]):
/// the pairs its stretches made, its waypoints taught by hand, and the exact revisits and
/// returns among them.
#[derive(Debug, Clone, Copy)]
pub struct OpenRoutine<'a> {
    pub pairs: &'a [Pair],
    pub len: usize,
    pub revisits: usize,
    pub returns: usize,
    /// The returns' squared gaps to the poses they returned to, summed (mm², rad²).
    pub return_gaps: (f64, f64),
}

/// The cell's finished routines and the misfits of the repeats found in them (module doc).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NoiseEstimator {
    routines: Vec<Vec<Pose>>,
    /// (length of the move into waypoint `j`, routine, `j`) for every stretch end `j`, sorted by
    /// length.
    by_length: Vec<(f64, u32, u32)>,
    pairs: Vec<Pair>,
    /// The mixture fitted last (σ², share of repeats): the next fit starts from it.
    mixture: Option<(f64, f64)>,
    estimate: Option<Noise>,
    /// The positions taught so far, on a grid of [`EXACT_REVISIT_MM`].
    places: std::collections::HashSet<[i64; 3]>,
    /// Waypoints taught exactly where an earlier one was (not as suggested).
    exact_revisits: usize,
    /// Waypoints of the finished routines, and the returns among them (module doc, "Returns";
    /// counted while they are fewer than [`MIN_ROUTINES`]).
    taught: usize,
    returns: usize,
    /// Their squared gaps to the poses they returned to, summed (mm², rad²).
    return_gaps: (f64, f64),
    /// The routines shorter than [`STRETCH`] (at least [`SHORT_ROUTINE`] waypoints) by length:
    /// their indexes in `routines`, oldest first.
    short: std::collections::BTreeMap<usize, Vec<u32>>,
}

impl NoiseEstimator {
    pub fn new() -> NoiseEstimator {
        NoiseEstimator::default()
    }

    /// The noise learned so far; `None` until enough repeats were seen; exact once the cell
    /// was taught exact revisits (module doc).
    pub fn estimate(&self) -> Option<Noise> {
        if self.is_exact() {
            return Some(Noise::EXACT);
        }
        if !self.believed(0, 0) {
            return None;
        }
        self.estimate
            .or_else(|| from_returns(self.returns, self.return_gaps))
    }

    /// Whether the noise is believed yet, with `open` waypoints and `open_returns` returns of
    /// the routine being taught: after [`MIN_ROUTINES`] routines, or before when the returns
    /// say a hand repeats (module doc, "Returns").
    fn believed(&self, open: usize, open_returns: usize) -> bool {
        if self.routines.len() >= MIN_ROUTINES {
            return true;
        }
        let returns = self.returns + open_returns;
        let taught = self.taught + open;
        returns >= MIN_RETURNS && returns as f64 >= MIN_RETURN_SHARE * taught as f64
    }

    /// Whether `pose`, taught by hand after `before` in the routine being taught, is a return
    /// (module doc, "Returns"): near a waypoint of a finished routine, or near one of `before`
    /// that the arm went [`RETURN_AWAY_MM`] from since, and exactly on none. Only looked for
    /// while the finished routines are fewer than [`MIN_ROUTINES`] (false after).
    pub fn is_return(&self, pose: &Pose, before: &[Pose]) -> bool {
        self.return_gap(pose, before).is_some()
    }

    /// When `pose` is a return ([`NoiseEstimator::is_return`]): its distance and angle to the
    /// pose it returned to (the most recent one of `before`, else the nearest of a finished
    /// routine). Two placements of one meant pose by a hand of σ per axis are `σ·√6` apart
    /// (RMS), which [`from_returns`] reads.
    pub fn return_gap(&self, pose: &Pose, before: &[Pose]) -> Option<(f64, f64)> {
        if self.routines.len() >= MIN_ROUTINES || self.is_revisit(pose, before) {
            return None;
        }
        let near = |w: &Pose| w.distance_to(pose) <= RETURN_MM && w.angle_to(pose) <= RETURN_RAD;
        let gap = |w: &Pose| (w.distance_to(pose), w.angle_to(pose));
        // Walking back: the farthest the arm went from here since each earlier waypoint (from a
        // near one, that is within RETURN_MM of how far it went from it).
        let mut farthest: f64 = 0.0;
        for w in before.iter().rev() {
            if near(w) && farthest >= RETURN_AWAY_MM {
                return Some(gap(w));
            }
            farthest = farthest.max(w.distance_to(pose));
        }
        self.routines
            .iter()
            .flatten()
            .filter(|w| near(w))
            .map(gap)
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Whether the cell was taught [`EXACT_REVISITS`] waypoints exactly where earlier ones were.
    pub fn is_exact(&self) -> bool {
        self.exact_revisits >= EXACT_REVISITS
    }

    /// The routines learned, in order.
    pub fn routines(&self) -> &[Vec<Pose>] {
        &self.routines
    }

    /// Pairs of stretches compared so far (kept: at most [`MAX_SAMPLES`]).
    pub fn pairs(&self) -> usize {
        self.pairs.len()
    }

    /// The pairs the newest stretch of the routine being taught (ending at its last waypoint)
    /// makes with the earlier ones: exactly those [`NoiseEstimator::learn_taught`] finds for it
    /// when the routine is finished. None once the cell is exact.
    pub fn open_pairs(&self, routine: &[Pose]) -> Vec<Pair> {
        let Some(j) = routine.len().checked_sub(1) else {
            return Vec::new();
        };
        if self.is_exact()
            || j + 1 < STRETCH
            || extent(&routine[j + 1 - STRETCH..=j]) < MIN_EXTENT_MM
        {
            return Vec::new();
        }
        let r = u32::try_from(self.routines.len()).unwrap_or(u32::MAX);
        let mut own: Vec<(f64, u32, u32)> = (STRETCH - 1..j)
            .filter(|&e| extent(&routine[e + 1 - STRETCH..=e]) >= MIN_EXTENT_MM)
            .map(|e| {
                let len = routine[e].distance_to(&routine[e - 1]);
                (len, r, u32::try_from(e).unwrap_or(u32::MAX))
            })
            .collect();
        own.sort_by(|a, b| a.0.total_cmp(&b.0));
        let stretch = &routine[j + 1 - STRETCH..=j];
        self.earlier_ends(stretch, routine, j, &own)
            .into_iter()
            .filter_map(|(er, ej)| {
                let other: &[Pose] = if er == r {
                    &routine[ej + 1 - STRETCH..=ej]
                } else {
                    &self.routines[er as usize][ej + 1 - STRETCH..=ej]
                };
                compare(other, stretch)
            })
            .collect()
    }

    /// Whether `pose`, taught by hand after `before` in the routine being taught, is an exact
    /// revisit (module doc) of a finished routine's waypoint or of one of `before`.
    pub fn is_revisit(&self, pose: &Pose, before: &[Pose]) -> bool {
        let key = revisit_cell(pose);
        self.places.contains(&key) || before.iter().any(|w| revisit_cell(w) == key)
    }

    /// The noise the finished routines and the routine being taught show so far: with its
    /// stretches' pairs `open` and its exact revisits (module doc). The estimate the cell uses
    /// while it teaches; learning the routine when it is finished gives it for good.
    pub fn estimate_with(&self, open: &OpenRoutine<'_>) -> Option<Noise> {
        if self.exact_revisits + open.revisits >= EXACT_REVISITS {
            return Some(Noise::EXACT);
        }
        if !self.believed(open.len, open.returns) {
            return None;
        }
        let fitted = if open.pairs.is_empty() {
            self.estimate
        } else {
            let mut all = Vec::with_capacity(self.pairs.len() + open.pairs.len());
            all.extend_from_slice(&self.pairs);
            all.extend_from_slice(open.pairs);
            let over = all.len().saturating_sub(MAX_SAMPLES);
            fit_mixture(&all[over..], self.mixture).0
        };
        fitted.or_else(|| {
            let gaps = (
                self.return_gaps.0 + open.return_gaps.0,
                self.return_gaps.1 + open.return_gaps.1,
            );
            from_returns(self.returns + open.returns, gaps)
        })
    }

    /// Learns a finished routine taught by hand, no suggestion taken.
    pub fn learn(&mut self, routine: &[Pose]) {
        self.learn_taught(routine, &[]);
    }

    /// Learns a finished routine, `suggested[i]` telling whether waypoint `i` was taught as the
    /// cell offered it (missing: not): counts its exact revisits, aligns each of its stretches
    /// with the earlier ones of the same step lengths (in earlier routines, and earlier in this
    /// one without overlap), then fits the noise again.
    pub fn learn_taught(&mut self, routine: &[Pose], suggested: &[bool]) {
        if !self.is_exact() {
            for (i, w) in routine.iter().enumerate() {
                let by_hand = !suggested.get(i).copied().unwrap_or(false);
                if let Some((mm, rad)) = self.return_gap(w, &routine[..i]).filter(|_| by_hand) {
                    self.returns += 1;
                    self.return_gaps.0 += mm * mm;
                    self.return_gaps.1 += rad * rad;
                }
            }
        }
        for (i, w) in routine.iter().enumerate() {
            let fresh = self.places.insert(revisit_cell(w));
            if !fresh && !suggested.get(i).copied().unwrap_or(false) {
                self.exact_revisits += 1;
            }
        }
        // Waypoints taught as suggested cannot be returns: the share is of those by hand.
        self.taught += (0..routine.len())
            .filter(|&i| !suggested.get(i).copied().unwrap_or(false))
            .count();
        if self.is_exact() {
            // Nothing more to learn of the noise.
            self.routines.push(routine.to_vec());
            return;
        }
        let r = u32::try_from(self.routines.len()).unwrap_or(u32::MAX);
        // The ends of the stretches spread enough to fix a rotation, with the length of the
        // move into them, sorted by it (this routine's own index of its earlier stretches).
        let ends: Vec<(f64, u32, u32)> = (STRETCH - 1..routine.len())
            .filter(|&j| extent(&routine[j + 1 - STRETCH..=j]) >= MIN_EXTENT_MM)
            .map(|j| {
                let len = routine[j].distance_to(&routine[j - 1]);
                (len, r, u32::try_from(j).unwrap_or(u32::MAX))
            })
            .collect();
        let mut own = ends.clone();
        own.sort_by(|a, b| a.0.total_cmp(&b.0));
        let before = self.pairs.len();
        self.align_short(routine, r);
        for &(_, _, j) in &ends {
            let j = j as usize;
            let stretch = &routine[j + 1 - STRETCH..=j];
            for (er, ej) in self.earlier_ends(stretch, routine, j, &own) {
                let other: &[Pose] = if er == r {
                    &routine[ej + 1 - STRETCH..=ej]
                } else {
                    &self.routines[er as usize][ej + 1 - STRETCH..=ej]
                };
                if let Some(pair) = compare(other, stretch) {
                    self.pairs.push(pair);
                }
            }
        }
        let over = self.pairs.len().saturating_sub(MAX_SAMPLES);
        self.pairs.drain(..over);
        // Both runs are sorted: the stable sort merges them.
        self.by_length.append(&mut own);
        self.by_length.sort_by(|a, b| a.0.total_cmp(&b.0));
        self.routines.push(routine.to_vec());
        if self.pairs.len() != before || over > 0 {
            let (estimate, mixture) = fit_mixture(&self.pairs, self.mixture);
            self.estimate = estimate;
            self.mixture = mixture.or(self.mixture);
        }
    }

    /// A routine too short for a stretch ([`SHORT_ROUTINE`] to [`STRETCH`] − 1 waypoints,
    /// spread enough to fix a rotation) is aligned whole with the newest earlier routines of its
    /// length whose steps match, at most [`MAX_PAIRS`] of them: programs of many short routines
    /// (a pick, a place, a tack weld) show their operator's noise too.
    fn align_short(&mut self, routine: &[Pose], r: u32) {
        let n = routine.len();
        if !(SHORT_ROUTINE..STRETCH).contains(&n) || extent(routine) < MIN_EXTENT_MM {
            return;
        }
        let earlier = self.short.entry(n).or_default();
        for &e in earlier.iter().rev().take(MAX_EXAMINED) {
            let other = &self.routines[e as usize];
            if steps_match(other, routine)
                && let Some(pair) = compare(other, routine)
            {
                self.pairs.push(pair);
            }
        }
        earlier.push(r);
    }

    /// The ends of the earlier stretches whose every step is about as long as `stretch`'s:
    /// (routine, end), at most [`MAX_PAIRS`] out of at most [`MAX_EXAMINED`] of about the same
    /// last step in earlier routines and as many earlier in `routine`, before `j`'s stretch
    /// (`own` indexes `routine`'s stretch ends by length), those of earlier routines first.
    fn earlier_ends(
        &self,
        stretch: &[Pose],
        routine: &[Pose],
        j: usize,
        own: &[(f64, u32, u32)],
    ) -> Vec<(u32, usize)> {
        let last = stretch[STRETCH - 1].distance_to(&stretch[STRETCH - 2]);
        let earlier = moves_as_long_as(&self.by_length, last)
            .take(MAX_EXAMINED)
            .filter(|&(r, e)| {
                steps_match(&self.routines[r as usize][e + 1 - STRETCH..=e], stretch)
            });
        let within = moves_as_long_as(own, last)
            .filter(|&(_, e)| e + STRETCH <= j)
            .take(MAX_EXAMINED)
            .filter(|&(_, e)| steps_match(&routine[e + 1 - STRETCH..=e], stretch));
        earlier.chain(within).take(MAX_PAIRS).collect()
    }
}

/// A waypoint's place on the grid of [`EXACT_REVISIT_MM`]. Positions beyond i64's range are not
/// a robot's; they saturate and count as one.
fn revisit_cell(w: &Pose) -> [i64; 3] {
    let p = w.position() / EXACT_REVISIT_MM;
    [p.x.round() as i64, p.y.round() as i64, p.z.round() as i64]
}

/// The noise `returns` returns show by their summed squared gaps `(mm², rad²)`: two placements
/// of one meant pose differ by `σ·√2` per axis, so the mean squared gap is `6σ²`. Used while no
/// repeats were fitted (module doc, "Returns"); `None` before [`MIN_RETURNS`].
fn from_returns(returns: usize, (mm2, rad2): (f64, f64)) -> Option<Noise> {
    (returns >= MIN_RETURNS).then(|| {
        let n = 6.0 * returns as f64;
        Noise {
            mm: (mm2 / n).sqrt().clamp(SIGMA_FLOOR_MM, SIGMA_CAP_MM),
            rad: (rad2 / n).sqrt(),
        }
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::engine::experts::frames::Tolerance;
    use crate::engine::experts::noise::tests::noisy;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A task of 10 waypoints (a box seam with approach and retract, tool down, turning on the
    /// way), placed at `(dx, dy)` turned by `turn` about the vertical.
    pub(crate) fn task(dx: f64, dy: f64, turn: f64) -> Vec<Pose> {
        let g = Isometry3::from_parts(
            Translation3::new(600.0 + dx, dy, 150.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, turn),
        );
        let corners = [
            [0.0, 0.0, 120.0],
            [0.0, 0.0, 0.0],
            [180.0, 0.0, 0.0],
            [180.0, 90.0, 0.0],
            [60.0, 140.0, 0.0],
            [0.0, 90.0, 0.0],
            [0.0, 90.0, 120.0],
            [-150.0, 40.0, 200.0],
            [-150.0, -200.0, 260.0],
            [100.0, -240.0, 200.0],
        ];
        corners
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let down =
                    UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.2 * i as f64);
                Pose::from_isometry(
                    g * Isometry3::from_parts(Translation3::new(c[0], c[1], c[2]), down),
                )
            })
            .collect()
    }

    /// A routine of `n` waypoints wandering at random: no stretch of it repeats another.
    pub(crate) fn wander(n: usize, rng: &mut ChaCha8Rng) -> Vec<Pose> {
        let mut p = Vector3::new(500.0, 0.0, 300.0);
        (0..n)
            .map(|_| {
                p += Vector3::new(
                    rng.random_range(-250.0..250.0),
                    rng.random_range(-250.0..250.0),
                    rng.random_range(-150.0..150.0),
                );
                let q = UnitQuaternion::from_euler_angles(
                    std::f64::consts::PI,
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-3.0..3.0),
                );
                Pose::from_isometry(Isometry3::from_parts(Translation3::from(p), q))
            })
            .collect()
    }

    /// The task placed anew: within ±300 mm, turned by `k` rad and up to 1 rad more.
    fn placed_anew(k: i32, rng: &mut ChaCha8Rng) -> Vec<Pose> {
        task(
            rng.random_range(-300.0..300.0),
            rng.random_range(-300.0..300.0),
            rng.random_range(-1.0..1.0) + f64::from(k),
        )
    }

    /// An operator with 11.5 mm and 0.02 rad per axis (the simulated online operator's 20 mm
    /// RMS) teaches one task at six places, between routines of other work: the estimate is
    /// within 20 % of both, with no calibration routine.
    #[test]
    fn a_repeated_task_shows_the_noise_it_was_taught_with() {
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        for seed in 1..=8 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut e = NoiseEstimator::new();
            assert_eq!(e.estimate(), None);
            for k in 0..6 {
                let placed = placed_anew(k, &mut rng);
                e.learn(&noisy(&placed, &truth, &mut rng));
                e.learn(&noisy(&wander(12, &mut rng), &truth, &mut rng));
            }
            let n = e.estimate().expect("an estimate");
            eprintln!("seed {seed}: {n:?} from {} pairs", e.pairs());
            assert!((n.mm / truth.mm - 1.0).abs() < 0.2, "seed {seed}: {n:?}");
            assert!((n.rad / truth.rad - 1.0).abs() < 0.2, "seed {seed}: {n:?}");
        }
    }

    /// A program of short routines (a pick and a place of four waypoints each, at new places,
    /// between short moves of other work) shows its noise too: no routine holds a stretch, so
    /// whole routines are aligned with the earlier ones of their length.
    #[test]
    fn short_routines_show_the_noise_they_were_taught_with() {
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        for seed in 1..=8 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut e = NoiseEstimator::new();
            for k in 0..8 {
                let placed = placed_anew(k, &mut rng);
                // The task's approach, the two ends of its seam and the retract.
                let pick = [placed[0], placed[1], placed[2], placed[6]];
                assert!(pick.len() < STRETCH);
                e.learn(&noisy(&pick, &truth, &mut rng));
                e.learn(&noisy(&wander(3, &mut rng), &truth, &mut rng));
            }
            let n = e.estimate().expect("an estimate");
            eprintln!("seed {seed}: {n:?} from {} pairs", e.pairs());
            assert!((n.mm / truth.mm - 1.0).abs() < 0.25, "seed {seed}: {n:?}");
        }
    }

    /// The estimate converges within a few routines: after the task's third placement it is
    /// there, within 30 %.
    #[test]
    fn a_few_repeats_are_enough() {
        let truth = Noise { mm: 5.0, rad: 0.01 };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut e = NoiseEstimator::new();
        for k in 0..3 {
            let placed = task(
                100.0 * f64::from(k),
                -50.0 * f64::from(k),
                0.4 * f64::from(k),
            );
            e.learn(&noisy(&placed, &truth, &mut rng));
        }
        let n = e.estimate().expect("an estimate after three placements");
        assert!((n.mm / truth.mm - 1.0).abs() < 0.3, "{n:?}");
    }

    /// Offline programs are exact: their repeats fit perfectly, and the estimate is too small to
    /// widen any tolerance.
    #[test]
    fn exact_repeats_give_no_noise() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut e = NoiseEstimator::new();
        for k in 0..4 {
            e.learn(&task(90.0 * f64::from(k), 30.0, 0.3 * f64::from(k)));
            e.learn(&wander(10, &mut rng));
        }
        let n = e.estimate().expect("an estimate");
        assert!(n.is_negligible(&Tolerance::USEFUL), "{n:?}");
    }

    /// Without repeats there is nothing to learn from: no estimate, whatever the noise.
    #[test]
    fn no_repeats_no_estimate() {
        for seed in 1..=8 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut e = NoiseEstimator::new();
            let noise = Noise { mm: 8.0, rad: 0.02 };
            for _ in 0..8 {
                e.learn(&noisy(&wander(15, &mut rng), &noise, &mut rng));
            }
            assert_eq!(e.estimate(), None, "seed {seed}: {} pairs", e.pairs());
        }
    }

    /// A 3 × 4 pallet (pick station, then each slot approached, placed, left) as one routine.
    pub(crate) fn pallet() -> Vec<Pose> {
        let down = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
        let at = |x: f64, y: f64, z: f64| {
            Pose::from_isometry(Isometry3::from_parts(Translation3::new(x, y, z), down))
        };
        let mut out = Vec::new();
        for row in 0..4 {
            for col in 0..3 {
                let (x, y) = (
                    900.0 + 200.0 * f64::from(col),
                    -300.0 + 250.0 * f64::from(row),
                );
                out.extend([
                    at(600.0, -700.0, 550.0),
                    at(600.0, -700.0, 400.0),
                    at(600.0, -700.0, 550.0),
                    at(x, y, 350.0),
                    at(x, y, 200.0),
                    at(x, y, 350.0),
                ]);
            }
        }
        out
    }

    /// A pallet taught by hand as one routine comes back to its pick station for every item,
    /// never exactly: its returns make its noise believed after that one routine (not three),
    /// at about what it was taught with (read high by up to half: the stretches aligned hold
    /// the slots' shifts as well as the hand's error); taught exactly, its exact revisits make
    /// it exact.
    #[test]
    fn a_pallet_taught_by_hand_in_one_routine_shows_its_noise() {
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        for seed in 1..=4 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut e = NoiseEstimator::new();
            e.learn(&noisy(&pallet(), &truth, &mut rng));
            assert!(
                e.returns >= MIN_RETURNS,
                "seed {seed}: {} returns",
                e.returns
            );
            let n = e.estimate().expect("believed after one routine");
            assert!(
                (0.8..1.6).contains(&(n.mm / truth.mm)),
                "seed {seed}: {n:?}"
            );
        }
        let mut exact = NoiseEstimator::new();
        exact.learn(&pallet());
        assert_eq!(exact.estimate(), Some(Noise::EXACT));
    }

    /// An exact program's long routine of stretches that look alike (one seam shape at other
    /// places and sizes) but that never comes back near where it was is not read as noisy in
    /// its first routines, however its stretches fit (from the third on, [`MIN_ROUTINES`] holds
    /// as before).
    #[test]
    fn look_alike_stretches_without_returns_are_not_believed_early() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let routine: Vec<Pose> = (0..8)
            .flat_map(|k| {
                let size = rng.random_range(0.9..1.1);
                let placed = task(450.0 * f64::from(k), 0.0, 0.0);
                let start = placed[0].position();
                placed.into_iter().map(move |p| {
                    let scaled = start + (p.position() - start) * size;
                    Pose::from_isometry(Isometry3::from_parts(
                        Translation3::from(scaled),
                        p.rotation(),
                    ))
                })
            })
            .collect();
        let mut e = NoiseEstimator::new();
        e.learn(&routine);
        assert_eq!(e.returns, 0);
        // The stretches do read as a noisy hand …
        let misread = e.estimate.expect("a fit");
        assert!(misread.mm > 1.0, "{misread:?}");
        // … which is not believed.
        assert_eq!(e.estimate(), None, "{} pairs", e.pairs());
        let open = OpenRoutine {
            pairs: &[],
            len: 40,
            revisits: 0,
            returns: 0,
            return_gaps: (0.0, 0.0),
        };
        assert_eq!(e.estimate_with(&open), None);
    }

    /// A return: near an earlier waypoint after the arm went away from it, or near a waypoint
    /// of a finished routine; not a step along a seam, and not an exact revisit.
    #[test]
    fn a_return_comes_back_near_after_going_away() {
        let down = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
        let at = |x: f64| {
            Pose::from_isometry(Isometry3::from_parts(
                Translation3::new(x, 0.0, 300.0),
                down,
            ))
        };
        let e = NoiseEstimator::new();
        // Along a seam in 20 mm steps: near the previous ones, never gone away.
        let seam: Vec<Pose> = (0..6).map(|i| at(20.0 * f64::from(i))).collect();
        assert!(!e.is_return(&at(120.0), &seam));
        // Out 400 mm and back to 15 mm from the start: a return.
        let trip = [at(0.0), at(400.0)];
        assert!(e.is_return(&at(15.0), &trip));
        // Exactly back: an exact revisit, not a return.
        assert!(!e.is_return(&at(0.0), &trip));
        // Turned 0.5 rad: not the same pose.
        let turned = Pose::from_isometry(Isometry3::from_parts(
            Translation3::new(15.0, 0.0, 300.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 0.5) * down,
        ));
        assert!(!e.is_return(&turned, &trip));
        // Near a finished routine's waypoint.
        let mut finished = NoiseEstimator::new();
        finished.learn(&trip);
        assert!(finished.is_return(&at(15.0), &[]));
    }

    /// Learning the same routines in the same order gives the same estimate (a rebuild).
    #[test]
    fn the_estimate_depends_only_on_the_routines_in_order() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let noise = Noise { mm: 6.0, rad: 0.01 };
        let routines: Vec<Vec<Pose>> = (0..5)
            .map(|k| {
                noisy(
                    &task(50.0 * f64::from(k), 0.0, 0.2 * f64::from(k)),
                    &noise,
                    &mut rng,
                )
            })
            .collect();
        let (mut a, mut b) = (NoiseEstimator::new(), NoiseEstimator::new());
        for r in &routines {
            a.learn(r);
            b.learn(r);
        }
        assert_eq!(a, b);
        assert!(a.estimate().is_some());
    }

    /// Waypoints taught exactly where earlier ones were make the cell exact, however noisy its
    /// other repeats look; a suggestion taken as offered is no such evidence.
    #[test]
    fn exact_revisits_show_an_exact_teacher() {
        let noise = Noise { mm: 6.0, rad: 0.01 };
        let home = task(0.0, 0.0, 0.0)[0];
        let run = |suggested: bool| {
            let mut rng = ChaCha8Rng::seed_from_u64(13);
            let mut e = NoiseEstimator::new();
            for k in 0..4 {
                let mut r = vec![home];
                r.extend(noisy(
                    &task(70.0 * f64::from(k), 20.0, 0.3 * f64::from(k)),
                    &noise,
                    &mut rng,
                ));
                // Home again at the start of every routine: suggested or not.
                let flags: Vec<bool> = (0..r.len()).map(|i| i == 0 && suggested).collect();
                e.learn_taught(&r, &flags);
            }
            e
        };
        let by_hand = run(false);
        assert!(by_hand.is_exact());
        assert_eq!(by_hand.estimate(), Some(Noise::EXACT));
        let suggested = run(true);
        assert!(!suggested.is_exact());
        let n = suggested.estimate().expect("an estimate");
        assert!(n.mm > 3.0, "{n:?}");
    }
}
