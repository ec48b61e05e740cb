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
//! The cell learns online: every taught waypoint tells each candidate that was proposed for it
//! whether it would have been right ([`Calibration::record`]); undo takes that back
//! ([`Calibration::forget`]), so the calibration is a function of the taught routines in their
//! order, like the model. [`PRIOR`] holds the counts measured on half of the shared corpus's
//! repositories (`cargo run --release --example calibration_prior -- FILES…`;
//! docs/results/scoreboard.md, "Calibration of `p_useful`").
//!
//! An exact cell's offer rule reads these estimates as one feature among the agreement of the
//! candidates ([`super::agreement`]); a cell whose noise matters offers by them alone
//! (`engine::teach::offer_rule`).

use std::collections::HashMap;

use super::{Evidence, LatticeEvidence, Proposer};

/// Weight (in outcomes) of the prior in a cell's coarse class.
pub const COARSE_STRENGTH: f64 = 10.0;
/// Weight (in outcomes) of the coarse class in a fine one.
pub const FINE_STRENGTH: f64 = 3.0;

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
    /// The rate, shrunk towards `towards` with the weight of `strength` outcomes.
    pub fn shrunk(&self, towards: f64, strength: f64) -> f64 {
        (self.useful + strength * towards) / (self.n + strength)
    }

    /// Counts one outcome.
    pub fn add(&mut self, useful: f64) {
        self.n += 1.0;
        self.useful += useful;
    }

    /// Takes back one outcome [`Count::add`] counted.
    pub fn remove(&mut self, useful: f64) {
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

    /// The probability that a candidate with this evidence is right (its first-stage estimate,
    /// as the offer rule reads it).
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
}
