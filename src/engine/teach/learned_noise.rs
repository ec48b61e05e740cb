//! The cell's teaching noise and tolerance as the [`Teacher`] learns them: set, or estimated
//! from the finished routines and, until those give an estimate, from the routine being taught
//! (its stretches' pairs, its exact revisits, its returns); tightened by the operator's
//! adjustments. A waypoint that changes them keeps what it replaced ([`Before`]), so its undo
//! restores it. Whether the noise matters decides the calibration's prior and what the experts
//! are told ([`crate::engine::experts::Cell::noisy`]).

use super::{Counted, Teacher};
use crate::engine::config::EngineConfig;
use crate::engine::experts::acceptance::Acceptance;
use crate::engine::experts::calibration::Calibration;
use crate::engine::experts::frames::Tolerance;
use crate::engine::experts::noise::Noise;
use crate::engine::experts::noise::estimate::{OpenRoutine, Pair};

/// What a waypoint's change of the noise replaced: the noise and tolerance, and (when the
/// noise began or stopped to matter) the calibration.
#[derive(Debug, Clone)]
pub(super) struct Before {
    pub(super) noise: Noise,
    pub(super) tolerance: Tolerance,
    pub(super) calibration: Option<Calibration>,
}

impl Teacher {
    /// The tolerance of a cell with this noise and these verdicts: the offer rule's, or the one
    /// the noise implies, tightened by the adjustments ([`Acceptance::tolerance`]).
    pub(super) fn tolerance_for(
        config: &EngineConfig,
        noise: &Noise,
        acceptance: &Acceptance,
    ) -> Tolerance {
        config
            .offer
            .and_then(|r| r.tolerance)
            .unwrap_or_else(|| acceptance.tolerance(noise.tolerance(), noise))
    }

    /// A cell whose noise matters (it widens the tolerance) gets a calibration learned from its
    /// own outcomes only: the prior's counts are exact programs'. A cell whose learned noise
    /// stops mattering (exact revisits showed an exact teacher, [`crate::engine::experts::noise::estimate::NoiseEstimator::is_exact`])
    /// goes back to the exact cell's prior. (The experts read whether it matters when asked,
    /// [`Cell::noisy`].)
    pub(super) fn become_noisy_if_it_matters(&mut self) {
        let noisy = self.noisy();
        if noisy == self.calibration.is_uninformed() {
            return;
        }
        self.calibration = if noisy {
            Calibration::uninformed()
        } else {
            Calibration::new()
        };
    }

    /// The routine being taught shows the noise too: its newest stretch's pairs and its exact
    /// revisits join the finished routines' ([`crate::engine::experts::noise::estimate::NoiseEstimator::estimate_with`]), so a cell
    /// whose first repeats come within a long routine learns its operator there and then, not
    /// when the routine is finished. Only until the finished routines give an estimate: after
    /// that a routine's repeats refine it when it is finished (a fit per waypoint would cost
    /// more than the prediction). `counted` (the newest waypoint's) keeps what changed, for
    /// undo; finishing the routine learns it for good.
    pub(super) fn learn_open_noise(&mut self, counted: &mut Counted) {
        let Some(e) = self.estimator.as_ref().filter(|e| e.estimate().is_none()) else {
            return;
        };
        let n = self.routine.len();
        counted.pairs = e.open_pairs(&self.routine);
        let (pose, before) = (&self.routine[n - 1], &self.routine[..n - 1]);
        counted.revisit = !counted.suggested && e.is_revisit(pose, before);
        counted.returned = e.return_gap(pose, before).filter(|_| !counted.suggested);
        // Only a pair that could be a repeat, an exact revisit or a return can change the
        // estimate much; the others wait for the routine's end (a fit costs more than a
        // prediction).
        if !counted.revisit
            && counted.returned.is_none()
            && !counted.pairs.iter().any(Pair::could_repeat)
        {
            return;
        }
        let pairs: Vec<Pair> = self
            .outcomes
            .iter()
            .chain(std::iter::once(&*counted))
            .flat_map(|c| c.pairs.iter().copied())
            .collect();
        let count = |f: fn(&Counted) -> bool| {
            self.outcomes.iter().filter(|c| f(c)).count() + usize::from(f(counted))
        };
        let open = OpenRoutine {
            pairs: &pairs,
            // Waypoints taught as suggested cannot be returns: the share is of those by hand.
            len: n - count(|c| c.suggested),
            revisits: count(|c| c.revisit),
            returns: count(|c| c.returned.is_some()),
            return_gaps: self
                .outcomes
                .iter()
                .chain(std::iter::once(&*counted))
                .filter_map(|c| c.returned)
                .fold((0.0, 0.0), |(m, r), (dm, dr)| (m + dm * dm, r + dr * dr)),
        };
        let noise = e
            .estimate_with(&open)
            .or_else(|| e.estimate())
            .unwrap_or(Noise::EXACT);
        let tolerance = Teacher::tolerance_for(&self.config, &noise, &self.acceptance);
        if noise == self.noise && tolerance == self.tolerance {
            return;
        }
        let mut before = Before {
            noise: self.noise,
            tolerance: self.tolerance,
            calibration: None,
        };
        self.noise = noise;
        self.tolerance = tolerance;
        if self.noisy() != self.calibration.is_uninformed() {
            before.calibration = Some(self.calibration.clone());
        }
        self.become_noisy_if_it_matters();
        counted.before = Some(Box::new(before));
    }

    /// Whether the cell's noise matters (it widens the tolerance).
    pub(super) fn noisy(&self) -> bool {
        self.config.offer.is_some() && !self.noise.is_negligible(&self.tolerance)
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::same_model;
    use crate::engine::config::{EngineConfig, Profile};
    use crate::engine::experts::frames::Tolerance;
    use crate::engine::experts::noise::Noise;
    use crate::engine::{Pose, Teacher};

    /// A cell created with its arm only, taught one task at new places by a joystick operator
    /// (11.5 mm and 0.02 rad per axis, the simulated online operator's 20 mm RMS) between
    /// routines of other work: it learns the noise without a calibration routine, takes the
    /// tolerance the noise implies, and offers the task's waypoints, most of them within what
    /// the operator takes as is of the waypoint they meant.
    #[test]
    fn a_zero_configuration_cell_learns_its_operator_and_offers_what_they_accept() {
        use crate::engine::experts::frames::pose_vector;
        use crate::engine::experts::noise::estimate::tests::{task, wander};
        use crate::engine::experts::noise::tests::noisy;
        use rand::{Rng, SeedableRng};
        use rand_chacha::ChaCha8Rng;
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        let (mut offered, mut accepted) = (0, 0);
        for seed in 1..=3 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut t = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
            assert!(t.learns_noise());
            assert_eq!(t.noise(), Noise::EXACT);
            for k in 0..10 {
                let meant = task(
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-1.0..1.0),
                );
                for (i, w) in noisy(&meant, &truth, &mut rng).iter().enumerate() {
                    let p = t.predict();
                    if k >= 3 && p.offered() {
                        offered += 1;
                        let got = pose_vector(&p.pose.unwrap());
                        if truth.tolerance().holds(&got, &pose_vector(&meant[i])) {
                            accepted += 1;
                        }
                    }
                    t.teach(*w);
                }
                t.finish_routine();
                noisy(&wander(8, &mut rng), &truth, &mut rng)
                    .iter()
                    .for_each(|w| t.teach(*w));
                t.finish_routine();
            }
            let n = t.noise();
            assert!((n.mm / truth.mm - 1.0).abs() < 0.2, "seed {seed}: {n:?}");
            assert_eq!(t.tolerance(), n.tolerance());
            assert!(t.threshold().is_some_and(|p| p < 1.0));
        }
        // 7 routines × 9 waypoints after the first × 3 seeds could be offered. Its head-start
        // threshold promises half of its offers taken as is; most are (measured 2026-12-05:
        // 102 of 133, 77 %).
        assert!(offered >= 60, "{offered} offers");
        assert!(
            f64::from(accepted) >= 0.7 * f64::from(offered),
            "{accepted} of {offered} accepted"
        );
    }

    /// A cell created with its arm only, whose first routine is a 3 × 4 pallet taught by a
    /// joystick operator: its returns to the pick station make the noise believed within that
    /// routine (three routines would otherwise be waited for), by the sixth item, at what the
    /// returns' gaps show before any stretches repeat, and the tolerance follows it. Taught the
    /// same pallet exactly, the cell stays exact throughout. Two layers of it, whose operator
    /// takes the suggestions within their tolerance as they are, keep it believed to the end.
    ///
    /// Measured 2026-12-05 (not asserted), before the returns' gaps were read: the noise showed
    /// at waypoint 48–63 of 72 and read 14–17 mm for 11.5.
    #[test]
    fn a_pallet_taught_by_hand_in_the_first_routine_shows_its_noise_within_it() {
        use crate::engine::experts::noise::estimate::tests::pallet;
        use crate::engine::experts::noise::tests::noisy;
        use rand::SeedableRng;
        use rand_chacha::ChaCha8Rng;
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        let meant = pallet();
        for seed in 1..=3 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut t = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
            let mut shown = None;
            for (i, w) in noisy(&meant, &truth, &mut rng).iter().enumerate() {
                t.teach(*w);
                if shown.is_none() && t.noise() != Noise::EXACT {
                    shown = Some(i + 1);
                }
            }
            let shown = shown.expect("the noise shows within the first routine");
            assert!(shown <= 36, "seed {seed}: at waypoint {shown}");
            let n = t.noise();
            assert!(
                (0.8..1.6).contains(&(n.mm / truth.mm)),
                "seed {seed}: {n:?}"
            );
            assert_eq!(t.tolerance(), n.tolerance());
            // Two layers of it (the second 120 mm up), the operator taking what is within
            // their 24 mm as offered.
            let layers: Vec<Pose> = meant
                .iter()
                .chain(&meant)
                .enumerate()
                .map(|(i, p)| {
                    let up = if i >= meant.len() && i % 6 >= 3 {
                        120.0
                    } else {
                        0.0
                    };
                    let at = p.position() + nalgebra::Vector3::new(0.0, 0.0, up);
                    Pose::from_isometry(nalgebra::Isometry3::from_parts(at.into(), p.rotation()))
                })
                .collect();
            let mut t = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
            let mut taken = 0;
            for (w, by_hand) in layers.iter().zip(noisy(&layers, &truth, &mut rng)) {
                let p = t.predict();
                match p.pose.filter(|s| p.offered() && s.distance_to(w) <= 24.0) {
                    Some(s) => {
                        t.teach(s);
                        taken += 1;
                    }
                    None => t.teach(by_hand),
                }
            }
            assert!(taken >= 40, "seed {seed}: {taken} taken");
            let n = t.noise();
            assert!(
                (0.8..1.6).contains(&(n.mm / truth.mm)),
                "seed {seed}: {n:?} after {taken} taken"
            );
        }
        let mut exact = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
        for w in &meant {
            exact.teach(*w);
            assert_eq!(exact.noise(), Noise::EXACT);
        }
    }

    /// A cell told nothing, whose first repeats come within one long routine (the same task
    /// four times over, after three routines that repeat nothing), learns its noise while that
    /// routine is taught, not when it is finished; undoing the waypoints back to before the
    /// noise showed gives the cell that was never taught them, and teaching them again and
    /// finishing gives the cell that never undid.
    #[test]
    fn noise_is_learned_within_a_long_routine_and_undo_takes_it_back() {
        use crate::engine::experts::noise::estimate::tests::{task, wander};
        use crate::engine::experts::noise::tests::noisy;
        use rand::SeedableRng;
        use rand_chacha::ChaCha8Rng;
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut t = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
        for _ in 0..3 {
            for w in noisy(&wander(8, &mut rng), &truth, &mut rng) {
                t.teach(w);
            }
            t.finish_routine();
        }
        let long: Vec<Pose> = (0..4)
            .flat_map(|k| {
                task(
                    150.0 * f64::from(k),
                    -80.0 * f64::from(k),
                    0.3 * f64::from(k),
                )
            })
            .collect();
        let long = noisy(&long, &truth, &mut rng);
        let mut shown = None;
        let mut states = vec![t.clone()];
        for (i, w) in long.iter().enumerate() {
            t.teach(*w);
            states.push(t.clone());
            if shown.is_none() && t.noise() != Noise::EXACT {
                shown = Some(i + 1);
            }
        }
        let shown = shown.expect("the noise shows before the routine is finished");
        assert!(shown < long.len(), "learned at waypoint {shown}");
        let n = t.noise();
        assert!((n.mm / truth.mm - 1.0).abs() < 0.35, "{n:?}");
        assert!(t.noisy());
        let whole = t.clone();
        // Back to two waypoints before the noise showed: the cell of that prefix.
        for _ in shown - 2..long.len() {
            t.undo();
        }
        let prefix = &states[shown - 2];
        assert_eq!(t.noise(), prefix.noise());
        assert_eq!(t.tolerance(), prefix.tolerance());
        assert_eq!(t.noisy(), prefix.noisy());
        assert_eq!(t.calibration(), prefix.calibration());
        same_model(&t, prefix);
        for w in &long[shown - 2..] {
            t.teach(*w);
        }
        assert_eq!(t.noise(), whole.noise());
        assert_eq!(t.calibration(), whole.calibration());
        same_model(&t, &whole);
        let mut finished = whole.clone();
        t.finish_routine();
        finished.finish_routine();
        assert_eq!(t.noise(), finished.noise());
        assert_eq!(t.calibration(), finished.calibration());
        same_model(&t, &finished);
    }

    /// Exact programs keep an exact cell: the learned noise stays negligible, the tolerance
    /// [`Tolerance::USEFUL`], and the calibration the prior's.
    #[test]
    fn exact_programs_keep_the_cell_exact() {
        use crate::engine::experts::noise::estimate::tests::{task, wander};
        use rand::SeedableRng;
        use rand_chacha::ChaCha8Rng;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut t = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
        for k in 0..6 {
            task(80.0 * f64::from(k), 10.0, 0.25 * f64::from(k))
                .iter()
                .for_each(|w| t.teach(*w));
            t.finish_routine();
            wander(9, &mut rng).iter().for_each(|w| t.teach(*w));
            t.finish_routine();
        }
        assert!(
            t.noise().is_negligible(&Tolerance::USEFUL),
            "{:?}",
            t.noise()
        );
        assert_eq!(t.tolerance(), Tolerance::USEFUL);
        assert!(!t.noisy());
    }

    /// A noise or tolerance set in the cell's settings is used as given: nothing is learned.
    #[test]
    fn a_set_noise_is_not_learned() {
        let mut config = EngineConfig::profile(Profile::Default);
        config.noise = Some(Noise { mm: 4.0, rad: 0.01 });
        let t = Teacher::new(config).unwrap();
        assert!(!t.learns_noise());
        assert_eq!(t.tolerance(), Noise { mm: 4.0, rad: 0.01 }.tolerance());
        assert!(t.noisy());
    }
}
