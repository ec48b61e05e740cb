//! `p_useful`: the probability that a candidate ([`crate::engine::experts`]) is within the cell's
//! tolerance of the waypoint then taught, from the candidate's evidence.
//!
//! Candidates are grouped by their evidence at two levels: a coarse class (the model's own
//! gates passed or not; for a sequence expert: do all earlier places agree, is the latest one
//! in the routine being taught, a context of two or more, two or more places) and, inside it, a
//! fine one (the expert, context length up to 4, places up to 3). The estimate shrinks each
//! level towards the one above, Beta–binomial style:
//!
//! ```text
//! p_prior  = (u₀ + 1) / (n₀ + 2)                       from PRIOR (counts on other programs)
//! p_coarse = (u₁ + a·p_prior) / (n₁ + a)               the cell's own outcomes, coarse class
//! p_useful = (u₂ + b·p_coarse) / (n₂ + b)              the cell's own outcomes, fine class
//! ```
//!
//! **Second stage: the chosen candidate.** A class's rate counts every candidate of its kind,
//! but the one offered is the likeliest of several, and it is the likeliest mostly when no
//! stronger candidate stands beside it, which is when it is more often wrong (a mid-rate
//! candidate that another expert confirms is usually right; alone, much less). So the estimate
//! of the candidate chosen ([`Calibration::chosen`]) is mapped once more, by the outcomes of
//! chosen candidates per band of their first-stage estimate ([`BANDS`]), shrunk the same way:
//!
//! ```text
//! p_band   = (u₃ + c·p_first) / (n₃ + c)                 from CHOSEN_PRIOR
//! p_useful = (u₄ + d·p_band) / (n₄ + d)                  the cell's own chosen candidates
//! ```
//!
//! **The cell's threshold.** Every taught waypoint judges the candidate that was chosen for it,
//! offered or not, so the band counts say how often the cell's offers would have been right from
//! each band up. Without a fixed threshold, a cell offers from the lowest band whose offers,
//! counted from the top band down, are right at its target rate ([`Calibration::offer_band`]):
//! as many offers as that precision allows. Each band's rate is the cell's own shrunk towards
//! the prior's ([`BAND_STRENGTH`]), and its weight is the cell's own count plus
//! [`THRESHOLD_PRIOR_WEIGHT`] outcomes spread as the prior spreads them; so a new cell starts
//! where half A of the corpus put it, and its own offers take over as they are judged.
//!
//! The cell learns online: every taught waypoint tells each candidate that was proposed for it
//! whether it would have been right ([`Calibration::record`]), and the chosen one once more
//! ([`Calibration::record_chosen`]); undo takes that back ([`Calibration::forget`],
//! [`Calibration::forget_chosen`]), so the calibration is a function of the taught routines in
//! their order, like the model. [`PRIOR`] and [`CHOSEN_PRIOR`] hold the counts measured on half
//! of the shared corpus's repositories (`cargo run --release --example calibration_prior --
//! FILES…`; docs/results/scoreboard.md, "Calibration of `p_useful`").

use std::collections::HashMap;

use super::{Evidence, LatticeEvidence, Proposer};

/// Weight (in outcomes) of the prior in a cell's coarse class.
pub const COARSE_STRENGTH: f64 = 10.0;
/// Weight (in outcomes) of the coarse class in a fine one.
pub const FINE_STRENGTH: f64 = 3.0;

/// Weight (in outcomes) of the first-stage estimate in a band of [`CHOSEN_PRIOR`].
pub const BAND_PRIOR_STRENGTH: f64 = 5.0;
/// Weight (in outcomes) of the band's prior in a cell's own chosen candidates of that band.
pub const BAND_STRENGTH: f64 = 20.0;

/// Outcomes the prior's spread over the bands weighs in the cell's threshold (see the module
/// doc).
pub const THRESHOLD_PRIOR_WEIGHT: f64 = 20.0;

/// Standard deviations of the offered precision's estimate the cell keeps between it and its
/// target (module doc, "The cell's threshold").
pub const THRESHOLD_MARGIN_SD: f64 = 0.5;

/// Upper edges of the bands of the first-stage estimate that the second stage maps (the last is
/// closed); finer near 1, where the offers are.
pub const BANDS: [f64; 12] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98, 1.0];

/// The band of a first-stage estimate.
pub fn band(p: f64) -> usize {
    BANDS
        .iter()
        .position(|edge| p < *edge)
        .unwrap_or(BANDS.len() - 1)
}

/// The lower edge of band `b` (0 for the first).
fn band_floor(b: usize) -> f64 {
    b.checked_sub(1).map_or(0.0, |below| BANDS[below])
}

/// A coarse class of evidence (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Coarse {
    pub model: bool,
    /// Proposed by the template expert (its guesses average aligned repetitions, so they are
    /// right in other ways than one sequence expert's).
    pub template: bool,
    /// Proposed by the lattice expert (a walk's next point: right in its own way too).
    pub lattice: bool,
    /// … as the station its items keep returning to ([`LatticeEvidence::Station`]).
    pub station: bool,
    /// … as the move that followed the same role in the items before
    /// ([`LatticeEvidence::Follower`]).
    pub follower: bool,
    /// The model: its gates passed; a sequence expert: every earlier place agrees.
    pub agree: bool,
    pub in_routine: bool,
    pub long_context: bool,
    pub several_places: bool,
}

impl Coarse {
    pub fn of(e: &Evidence) -> Coarse {
        let none = Coarse {
            model: false,
            template: false,
            lattice: false,
            station: false,
            follower: false,
            agree: false,
            in_routine: false,
            long_context: false,
            several_places: false,
        };
        match *e {
            Evidence::Model { gated_in, .. } => Coarse {
                model: true,
                agree: gated_in,
                ..none
            },
            Evidence::Sequence {
                context,
                places,
                agreeing,
                in_routine,
                ..
            } => Coarse {
                agree: agreeing == places,
                in_routine,
                long_context: context >= 2,
                several_places: places >= 2,
                ..none
            },
            Evidence::Template {
                steps,
                places,
                agreeing,
            } => Coarse {
                template: true,
                agree: agreeing == places,
                long_context: steps >= 2,
                several_places: places >= 2,
                ..none
            },
            // A lattice walk has three points at least: long from four on (a station from
            // four visits, which a back-and-forth inside one item does not reach).
            Evidence::Lattice(l) => {
                let lattice = Coarse {
                    lattice: true,
                    agree: true,
                    in_routine: true,
                    several_places: true,
                    ..none
                };
                match l {
                    LatticeEvidence::Walk {
                        points,
                        grid,
                        settled,
                    } => Coarse {
                        agree: settled,
                        long_context: points >= 4,
                        several_places: grid,
                        ..lattice
                    },
                    LatticeEvidence::Station { visits } => Coarse {
                        station: true,
                        long_context: visits >= 4,
                        ..lattice
                    },
                    LatticeEvidence::Follower { items } => Coarse {
                        follower: true,
                        long_context: items >= 4,
                        ..lattice
                    },
                }
            }
        }
    }
}

/// A fine class: the coarse one, the expert, the context length (up to 4) and the places (up to
/// 3: a station's and a follower's are 3, a grid's 2, a row's 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Fine {
    coarse: Coarse,
    proposer: Proposer,
    context: u8,
    places: u8,
}

impl Fine {
    fn of(e: &Evidence) -> Fine {
        let (context, places) = match *e {
            Evidence::Model { .. } => (0, 0),
            Evidence::Sequence {
                context, places, ..
            } => (context, places),
            Evidence::Template { steps, places, .. } => (steps, places),
            Evidence::Lattice(LatticeEvidence::Walk { points, grid, .. }) => {
                (points, if grid { 2 } else { 1 })
            }
            Evidence::Lattice(LatticeEvidence::Station { visits }) => (visits, 3),
            Evidence::Lattice(LatticeEvidence::Follower { items }) => (items, 3),
        };
        Fine {
            coarse: Coarse::of(e),
            proposer: e.proposer(),
            context: context.min(4) as u8,
            places: places.min(3) as u8,
        }
    }
}

/// Outcomes counted: candidates, and the useful ones among them. An outcome is a probability
/// that the candidate was useful (0 or 1 in an exact cell; in a noisy one, how likely the meant
/// waypoint was within the tolerance, [`super::noise::Noise::outcome`]), so the counts are
/// sums of them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Count {
    pub n: f64,
    pub useful: f64,
}

impl Count {
    fn shrunk(&self, towards: f64, strength: f64) -> f64 {
        (self.useful + strength * towards) / (self.n + strength)
    }

    fn add(&mut self, useful: f64) {
        self.n += 1.0;
        self.useful += useful;
    }

    fn remove(&mut self, useful: f64) {
        self.n = (self.n - 1.0).max(0.0);
        self.useful = (self.useful - useful).clamp(0.0, self.n);
    }
}

/// The coarse classes' counts on the calibration half of the shared corpus: the 14 programs of
/// its first six repositories by name, case-blind (Aleynikovich … jvalta), taught through the
/// default profile; `(class, candidates, useful)`. The other half is the held-out check.
///
/// The template expert's classes are left out (it starts at 0.5 and learns from each cell's
/// outcomes): on exact programs it adds little (half A 26.8 → 27.0 % saved with its rows), and
/// with them the held-out half's precision fell below 90 % (7.5 % saved at 90.1 % → 7.6 % at
/// 89.2 %). Its worth is in noisy cells, where no exact-program prior would fit anyway.
#[rustfmt::skip]
pub const PRIOR: &[(Coarse, u32, u32)] = &[
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: false, in_routine: false, long_context: false, several_places: true }, 142, 20),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: false, in_routine: false, long_context: true, several_places: true }, 37, 4),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: false, in_routine: true, long_context: false, several_places: true }, 178, 43),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: false, in_routine: true, long_context: true, several_places: true }, 25, 12),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: false, long_context: false, several_places: false }, 585, 516),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: false, long_context: false, several_places: true }, 434, 408),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: false, long_context: true, several_places: false }, 1544, 1488),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: false, long_context: true, several_places: true }, 1204, 1140),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: true, long_context: false, several_places: false }, 245, 88),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: true, long_context: false, several_places: true }, 66, 59),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: true, long_context: true, several_places: false }, 220, 147),
    (Coarse { model: false, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: true, long_context: true, several_places: true }, 84, 84),
    (Coarse { model: true, template: false, lattice: false, station: false, follower: false, agree: false, in_routine: false, long_context: false, several_places: false }, 152, 41),
    (Coarse { model: true, template: false, lattice: false, station: false, follower: false, agree: true, in_routine: false, long_context: false, several_places: false }, 410, 376),
];

/// The chosen candidates' outcomes per band of their first-stage estimate on the same half and
/// profile as [`PRIOR`]: `(candidates, useful)` per band of [`BANDS`].
#[rustfmt::skip]
pub const CHOSEN_PRIOR: [(u32, u32); 12] = [
    (57, 3), (73, 6), (49, 5), (50, 9), (20, 7), (19, 10),
    (20, 10), (21, 13), (31, 20), (51, 38), (91, 81), (274, 264),
];

/// The lattice expert's coarse classes' counts on the pattern tuning set (`nextpose patterns
/// DIR --set tuning`, seeds 1, 2 and 3: 18 programs), taught through the default profile as for
/// [`PRIOR`]: a new row only the layer's own rows foretell (not agreeing); one row going on
/// (one place), short or long (from four points: rows of the tuning set are three or four
/// long, so a long row going on was always wrong); a grid's next point or a layer laid like one
/// before (several places); a station, from three visits or from four (three is what a
/// back-and-forth inside one item gives); a follower, from two or three items that moved alike
/// (right about half the time: a period that merely repeats) or from four. The held-out set is
/// never counted.
#[rustfmt::skip]
pub const LATTICE_PRIOR: &[(Coarse, u32, u32)] = &[
    (Coarse { model: false, template: false, lattice: true, station: false, follower: false, agree: false, in_routine: true, long_context: true, several_places: true }, 159, 144),
    (Coarse { model: false, template: false, lattice: true, station: false, follower: false, agree: true, in_routine: true, long_context: false, several_places: false }, 99, 54),
    (Coarse { model: false, template: false, lattice: true, station: false, follower: false, agree: true, in_routine: true, long_context: false, several_places: true }, 18, 18),
    (Coarse { model: false, template: false, lattice: true, station: false, follower: false, agree: true, in_routine: true, long_context: true, several_places: false }, 18, 0),
    (Coarse { model: false, template: false, lattice: true, station: false, follower: false, agree: true, in_routine: true, long_context: true, several_places: true }, 684, 684),
    (Coarse { model: false, template: false, lattice: true, station: false, follower: true, agree: true, in_routine: true, long_context: false, several_places: true }, 471, 261),
    (Coarse { model: false, template: false, lattice: true, station: false, follower: true, agree: true, in_routine: true, long_context: true, several_places: true }, 993, 960),
    (Coarse { model: false, template: false, lattice: true, station: true, follower: false, agree: true, in_routine: true, long_context: false, several_places: true }, 114, 51),
    (Coarse { model: false, template: false, lattice: true, station: true, follower: false, agree: true, in_routine: true, long_context: true, several_places: true }, 627, 624),
];

fn prior(c: &Coarse) -> f64 {
    PRIOR
        .iter()
        .chain(LATTICE_PRIOR)
        .find(|(k, _, _)| k == c)
        .map_or(0.5, |(_, n, u)| {
            (f64::from(*u) + 1.0) / (f64::from(*n) + 2.0)
        })
}

/// One cell's calibration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Calibration {
    coarse: HashMap<Coarse, Count>,
    fine: HashMap<Fine, Count>,
    /// The cell's chosen candidates per band of their first-stage estimate.
    chosen: [Count; BANDS.len()],
    /// Start from 0.5 in every class instead of [`PRIOR`] (a noisy cell: the prior's counts come
    /// from exact programs, whose repeats are right far more often than a noisy cell's).
    uninformed: bool,
}

impl Calibration {
    /// A cell's calibration starting from [`PRIOR`].
    pub fn new() -> Calibration {
        Calibration::default()
    }

    /// A calibration that starts from 0.5 in every class and learns only from the cell.
    pub fn uninformed() -> Calibration {
        Calibration {
            uninformed: true,
            ..Calibration::default()
        }
    }

    /// Whether it starts from 0.5 in every class (a noisy cell's, [`Calibration::uninformed`]).
    pub fn is_uninformed(&self) -> bool {
        self.uninformed
    }

    /// The estimated probability that the candidate chosen is right, from its first-stage
    /// estimate (the likeliest candidate's [`Calibration::p_useful`]).
    ///
    /// An uninformed calibration (a noisy cell) has no second stage: the first-stage estimate is
    /// returned as is. Tried with one (from the first-stage estimate, learning from the cell's
    /// own chosen candidates), the simulated lab's joystick operator at p ≥ 0.5 saved 28.3 %
    /// instead of 38.9 % (docs/engine.md, "Teaching noise").
    pub fn chosen(&self, first: f64) -> f64 {
        if self.uninformed {
            return first;
        }
        let b = band(first);
        let (n, u) = CHOSEN_PRIOR[b];
        let p_band = Count {
            n: f64::from(n),
            useful: f64::from(u),
        }
        .shrunk(first, BAND_PRIOR_STRENGTH);
        self.chosen[b].shrunk(p_band, BAND_STRENGTH)
    }

    /// The rate of a band's chosen candidates before the cell's own: the prior's, or (a noisy
    /// cell's) the middle of the band.
    fn band_prior_rate(&self, b: usize) -> f64 {
        if self.uninformed {
            return 0.5 * (band_floor(b) + BANDS[b]);
        }
        let (n, u) = CHOSEN_PRIOR[b];
        (f64::from(u) + 1.0) / (f64::from(n) + 2.0)
    }

    /// The share of chosen candidates in a band before the cell's own: the prior's, or (a noisy
    /// cell's) the same in every band.
    fn band_prior_share(&self, b: usize) -> f64 {
        if self.uninformed {
            return 1.0 / BANDS.len() as f64;
        }
        let total: u32 = CHOSEN_PRIOR.iter().map(|(n, _)| n).sum();
        f64::from(CHOSEN_PRIOR[b].0) / f64::from(total)
    }

    /// The lowest band the cell offers from for a `target` precision: the lowest from which
    /// the chosen candidates, counted from the top band down, are right at least at that rate
    /// (module doc, "The cell's threshold"). None when not even the top band is.
    pub fn offer_band(&self, target: f64) -> Option<usize> {
        let (mut weight, mut right) = (0.0, 0.0);
        let mut lowest = None;
        for b in (0..BANDS.len()).rev() {
            let own = self.chosen[b];
            let w = own.n + THRESHOLD_PRIOR_WEIGHT * self.band_prior_share(b);
            weight += w;
            right += w * own.shrunk(self.band_prior_rate(b), BAND_STRENGTH);
            let rate = right / weight;
            let sd = (rate * (1.0 - rate) / (weight + 1.0)).sqrt();
            if rate - THRESHOLD_MARGIN_SD * sd >= target {
                lowest = Some(b);
            }
        }
        lowest
    }

    /// Whether the cell offers a chosen candidate of this first-stage estimate at a `target`
    /// precision.
    pub fn offers(&self, first: f64, target: f64) -> bool {
        self.offer_band(target).is_some_and(|b| band(first) >= b)
    }

    /// The first-stage estimate from which the cell offers at a `target` precision: the lower
    /// edge of [`Calibration::offer_band`] (1 when it offers nothing).
    pub fn threshold(&self, target: f64) -> f64 {
        self.offer_band(target).map_or(1.0, band_floor)
    }

    /// Counts the outcome of a chosen candidate with this first-stage estimate.
    pub fn record_chosen(&mut self, first: f64, useful: f64) {
        self.chosen[band(first)].add(useful);
    }

    /// Takes back an outcome [`Calibration::record_chosen`] counted.
    pub fn forget_chosen(&mut self, first: f64, useful: f64) {
        self.chosen[band(first)].remove(useful);
    }

    /// The chosen candidates' counts per band (for the prior's example).
    pub fn chosen_counts(&self) -> [Count; BANDS.len()] {
        self.chosen
    }

    /// The first-stage estimate: the probability that a candidate with this evidence is right,
    /// whether chosen or not.
    pub fn p_useful(&self, evidence: &Evidence) -> f64 {
        let f = Fine::of(evidence);
        let p0 = if self.uninformed {
            0.5
        } else {
            prior(&f.coarse)
        };
        let p1 = self
            .coarse
            .get(&f.coarse)
            .copied()
            .unwrap_or_default()
            .shrunk(p0, COARSE_STRENGTH);
        self.fine
            .get(&f)
            .copied()
            .unwrap_or_default()
            .shrunk(p1, FINE_STRENGTH)
    }

    /// Counts one outcome: how likely a candidate with this evidence was right (0 or 1 when
    /// known).
    pub fn record(&mut self, evidence: &Evidence, useful: f64) {
        let f = Fine::of(evidence);
        self.coarse.entry(f.coarse).or_default().add(useful);
        self.fine.entry(f).or_default().add(useful);
    }

    /// Takes back an outcome [`Calibration::record`] counted. A class left with no outcome is
    /// dropped, so the calibration is equal to one that never counted it (what a rebuild gives).
    pub fn forget(&mut self, evidence: &Evidence, useful: f64) {
        let f = Fine::of(evidence);
        if let Some(c) = self.coarse.get_mut(&f.coarse) {
            c.remove(useful);
            if c.n == 0.0 {
                self.coarse.remove(&f.coarse);
            }
        }
        if let Some(c) = self.fine.get_mut(&f) {
            c.remove(useful);
            if c.n == 0.0 {
                self.fine.remove(&f);
            }
        }
    }

    /// Outcomes counted so far.
    pub fn outcomes(&self) -> f64 {
        self.coarse.values().map(|c| c.n).sum()
    }

    /// The cell's counts per coarse class, in a fixed order (for the prior's example and
    /// reports).
    pub fn coarse_counts(&self) -> Vec<(Coarse, Count)> {
        let mut v: Vec<(Coarse, Count)> = self.coarse.iter().map(|(k, c)| (*k, *c)).collect();
        v.sort_by_key(|(k, _)| *k);
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::experts::frames::Frame;

    fn evidence(frame: Frame, agree: bool) -> Evidence {
        Evidence::Sequence {
            frame,
            context: 2,
            places: 2,
            agreeing: if agree { 2 } else { 1 },
            in_routine: false,
        }
    }

    /// Synthetic truth: candidates whose places agree are right 95 % of the time, the others
    /// 20 %. After enough outcomes the estimates are within a few points of the truth, and they
    /// rank the two kinds apart from the start of the evidence on.
    #[test]
    fn estimates_converge_to_the_observed_rates() {
        let mut c = Calibration::new();
        for i in 0..400u32 {
            c.record(
                &evidence(Frame::Work, true),
                f64::from(u8::from(i % 20 != 0)),
            );
            c.record(
                &evidence(Frame::Work, false),
                f64::from(u8::from(i % 5 == 0)),
            );
        }
        let good = c.p_useful(&evidence(Frame::Work, true));
        let bad = c.p_useful(&evidence(Frame::Work, false));
        assert!((good - 0.95).abs() < 0.02, "{good}");
        assert!((bad - 0.20).abs() < 0.02, "{bad}");
        // Another expert with the same coarse class borrows it before it has its own outcomes.
        let tool = c.p_useful(&evidence(Frame::Tool, true));
        assert!((tool - good).abs() < 0.05, "{tool} vs {good}");
    }

    /// Synthetic truth for the second stage: the chosen candidates whose first-stage estimate is
    /// 0.8 are right 40 % of the time. The cell learns that band's rate and no other; undo of
    /// the outcomes restores the estimate.
    #[test]
    fn the_chosen_stage_learns_how_often_the_likeliest_candidate_is_right() {
        let mut c = Calibration::new();
        let (before_low, before) = (c.chosen(0.3), c.chosen(0.85));
        for i in 0..300u32 {
            c.record_chosen(0.85, f64::from(u8::from(i % 5 < 2)));
        }
        let learned = c.chosen(0.85);
        assert!((learned - 0.4).abs() < 0.03, "{learned}");
        assert_eq!(c.chosen(0.3), before_low);
        for i in 0..300u32 {
            c.forget_chosen(0.85, f64::from(u8::from(i % 5 < 2)));
        }
        assert!((c.chosen(0.85) - before).abs() < 1e-12);
        // From the prior, a first-stage 0.99 claims what half A's chosen candidates of that band
        // were: fewer than 99 % right.
        let from_prior = Calibration::new().chosen(0.99);
        assert!(from_prior < 0.98 && from_prior > 0.9, "{from_prior}");
        // A noisy cell's calibration has no second stage.
        assert_eq!(Calibration::uninformed().chosen(0.8), 0.8);
        assert_eq!(band(0.0), 0);
        assert_eq!(band(0.95), 10);
        assert_eq!(band(1.0), BANDS.len() - 1);
    }

    #[test]
    fn forget_takes_back_exactly_what_record_counted() {
        let mut c = Calibration::new();
        let model = Evidence::Model {
            window: 2,
            gated_in: false,
        };
        c.record(&evidence(Frame::Absolute, true), 1.0);
        let before = c.clone();
        c.record(&model, 0.0);
        c.record(&evidence(Frame::Absolute, true), 0.7);
        c.forget(&evidence(Frame::Absolute, true), 0.7);
        c.forget(&model, 0.0);
        let all = [Frame::Tool, Frame::Work, Frame::Absolute]
            .into_iter()
            .flat_map(|f| [evidence(f, true), evidence(f, false)])
            .chain([model]);
        for e in all {
            assert_eq!(c.p_useful(&e), before.p_useful(&e));
        }
        assert_eq!(c.outcomes(), 1.0);
    }

    /// Realised precision of a cell steering its own threshold to `target` over a stream of
    /// chosen candidates: first-stage estimates drawn as half A's chosen candidates fall
    /// ([`CHOSEN_PRIOR`]), each right with probability `truth(first)`. Offers after the first
    /// `warm_up` candidates are counted, pooled over 40 streams of `n`.
    fn realised_precision(
        mut c: Calibration,
        truth: impl Fn(f64) -> f64,
        target: f64,
        warm_up: usize,
        n: usize,
    ) -> (f64, usize) {
        use rand::{Rng, SeedableRng};
        use rand_chacha::ChaCha8Rng;
        let total: u32 = CHOSEN_PRIOR.iter().map(|(n, _)| n).sum();
        let (mut offered, mut right) = (0usize, 0.0);
        let start = c.clone();
        for seed in 0..40 {
            c = start.clone();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            for i in 0..n {
                let mut pick = rng.random_range(0..total);
                let b = CHOSEN_PRIOR
                    .iter()
                    .position(|(n, _)| {
                        let here = pick < *n;
                        pick = pick.saturating_sub(*n);
                        here
                    })
                    .unwrap();
                let first = rng.random_range(band_floor(b)..BANDS[b]);
                let useful = f64::from(u8::from(rng.random_bool(truth(first))));
                if i >= warm_up && c.offers(first, target) {
                    offered += 1;
                    right += useful;
                }
                c.record_chosen(first, useful);
            }
        }
        (right / offered as f64, offered)
    }

    /// The prior's own rate per band, as a function of the first-stage estimate.
    fn prior_truth(first: f64) -> f64 {
        let (n, u) = CHOSEN_PRIOR[band(first)];
        f64::from(u) / f64::from(n)
    }

    /// After five routines (100 candidates), a cell steering its threshold keeps its offers
    /// right at its target rate within 5 points where the prior is right, and no more than 5
    /// points under it where the cell's candidates are far worse than the prior says (`f⁸`: a
    /// candidate the prior puts at 0.9 is right 43 % of the time). A noisy cell's calibration
    /// starts uninformed and learns the far-worse case more slowly: up to 10 points under
    /// (measured 2026-12-05 at target 0.8: 71.7 %; the informed one 75.8 %). Where they
    /// are far better, it errs on the safe side: more right than promised, fewer offers than it
    /// could make, until its own outcomes outweigh the prior (measured here, not asserted: the
    /// shrinkage that keeps it safe on held-out programs is what holds it back).
    #[test]
    fn the_cells_threshold_keeps_its_target_precision() {
        let worse = |f: f64| f.powi(8);
        let better = |f: f64| f.sqrt();
        for target in [0.8, 0.85, 0.9] {
            for (name, c, truth, under, over) in [
                (
                    "prior right",
                    Calibration::new(),
                    &prior_truth as &dyn Fn(f64) -> f64,
                    0.05,
                    Some(0.05),
                ),
                ("far worse", Calibration::new(), &worse, 0.05, None),
                (
                    "uninformed, prior right",
                    Calibration::uninformed(),
                    &prior_truth,
                    0.05,
                    Some(0.05),
                ),
                (
                    "uninformed, far worse",
                    Calibration::uninformed(),
                    &worse,
                    0.10,
                    None,
                ),
            ] {
                let (p, offered) = realised_precision(c, truth, target, 100, 400);
                eprintln!("{name} at {target}: {:.1} % of {offered}", 100.0 * p);
                assert!(offered > 1000, "{name} at {target}: {offered} offers");
                assert!(p >= target - under, "{name} at {target}: {p}");
                if let Some(over) = over {
                    assert!(p <= target + over, "{name} at {target}: {p}");
                }
            }
            let (p, offered) = realised_precision(Calibration::new(), better, target, 100, 400);
            eprintln!("far better at {target}: {:.1} % of {offered}", 100.0 * p);
            assert!(p >= target && offered > 1000, "far better at {target}: {p}");
        }
        // Nothing reaches the target: nothing offered.
        let c = Calibration::new();
        assert_eq!(c.threshold(1.0), 1.0);
        assert_eq!(c.offer_band(1.0), None);
    }
}
