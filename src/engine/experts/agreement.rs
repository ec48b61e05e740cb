//! Where the candidates agree (issue 48): the candidates every expert proposes for one waypoint,
//! grouped by the pose they propose, and what each group rests on — how many candidates and how
//! many kinds of expert stand at it, the longest context among them and the share of the
//! longest-context candidates it holds, the best first-stage `p_useful` in it, and how strong
//! the other groups are. A study over the shared corpora (docs/results/scoreboard.md, "The
//! offer rule by agreement") found agreement, more than any one candidate's own evidence, to
//! tell right from wrong; [`Scorer`] turns a group's [`Features`] into the probability that its
//! pose is right, by a logistic model fitted offline (`examples/fit_offer_rule.rs`) and held in
//! [`super::agreement_weights`].
//!
//! A group is led by the candidate with the highest first-stage estimate not yet grouped (the
//! first of equals), and takes every ungrouped candidate within the tolerance of it; the lead's
//! pose is the group's.

use super::agreement_weights::{INTERCEPT, WEIGHTS};
use super::frames::Tolerance;
use super::{Candidate, Evidence, LatticeEvidence, Proposer};

/// The number of features of a group.
pub const FEATURES: usize = 21;

/// The features' names, in the order of [`Features::vector`] (the weights file's order).
pub const NAMES: [&str; FEATURES] = [
    "log_size",
    "kinds",
    "p_first",
    "context",
    "long_share",
    "longest",
    "log_groups",
    "places",
    "all_agree",
    "in_routine",
    "model",
    "gated",
    "tool",
    "work",
    "absolute",
    "template",
    "station",
    "walk",
    "follower",
    "share",
    "log_competitor",
];

/// Candidates that propose one pose, and what they rest on together.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// The candidate whose pose the group proposes (the highest first-stage estimate in it).
    pub lead: usize,
    /// Every candidate in the group, the lead first.
    pub members: Vec<usize>,
    pub features: Features,
}

/// What a group rests on (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Features {
    /// Candidates in the group.
    pub size: usize,
    /// Kinds of expert among them (model, tool, work, absolute, template, lattice).
    pub kinds: usize,
    /// The highest first-stage `p_useful` among them.
    pub p_first: f64,
    /// The longest sequence context among them (0 without a sequence candidate).
    pub context: usize,
    /// The longest sequence context among all the waypoint's candidates.
    pub longest_context: usize,
    /// The share of the sequence candidates of that longest context that are in this group.
    pub long_share: f64,
    /// Groups at the waypoint.
    pub groups: usize,
    /// The most places a sequence candidate in it found its context at.
    pub places: usize,
    /// A sequence candidate in it whose places all agree.
    pub all_agree: bool,
    /// A sequence candidate in it whose latest place is in the routine being taught.
    pub in_routine: bool,
    /// The kinds of candidate in it.
    pub model: bool,
    /// The model's candidate is in it and its own gates pass.
    pub gated: bool,
    pub tool: bool,
    pub work: bool,
    pub absolute: bool,
    pub template: bool,
    pub station: bool,
    pub walk: bool,
    pub follower: bool,
    /// Candidates at the waypoint.
    pub total: usize,
    /// The size of the largest other group.
    pub competitor: usize,
}

impl Features {
    /// The features as the logistic model reads them (in [`NAMES`]' order).
    pub fn vector(&self) -> [f64; FEATURES] {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        [
            (self.size as f64).ln_1p(),
            self.kinds as f64,
            self.p_first,
            self.context.min(4) as f64,
            self.long_share,
            flag(self.longest_context > 0 && self.context == self.longest_context),
            (self.groups.max(1) as f64).ln(),
            self.places.min(5) as f64,
            flag(self.all_agree),
            flag(self.in_routine),
            flag(self.model),
            flag(self.gated),
            flag(self.tool),
            flag(self.work),
            flag(self.absolute),
            flag(self.template),
            flag(self.station),
            flag(self.walk),
            flag(self.follower),
            self.size as f64 / self.total.max(1) as f64,
            (self.competitor as f64).ln_1p(),
        ]
    }
}

/// The candidates grouped by pose (see the module doc), with each candidate's first-stage
/// estimate `p_first` (same length as `candidates`). Groups come in the order they were formed:
/// by their lead's estimate, highest first.
pub fn groups(candidates: &[Candidate], p_first: &[f64], tolerance: Tolerance) -> Vec<Group> {
    debug_assert_eq!(candidates.len(), p_first.len());
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    // Stable: equal estimates keep the candidates' order.
    order.sort_by(|&a, &b| p_first[b].total_cmp(&p_first[a]));
    let mut group_of: Vec<Option<usize>> = vec![None; candidates.len()];
    let mut members: Vec<Vec<usize>> = Vec::new();
    for &lead in &order {
        if group_of[lead].is_some() {
            continue;
        }
        let at = candidates[lead].pose;
        let mut m = vec![lead];
        group_of[lead] = Some(members.len());
        for &i in &order {
            if group_of[i].is_none()
                && candidates[i].pose.distance_to(&at) <= tolerance.mm
                && candidates[i].pose.angle_to(&at) <= tolerance.rad
            {
                group_of[i] = Some(members.len());
                m.push(i);
            }
        }
        members.push(m);
    }
    let context = |c: &Candidate| match c.evidence {
        Evidence::Sequence { context, .. } => context,
        _ => 0,
    };
    let longest = candidates.iter().map(context).max().unwrap_or(0);
    let long: Vec<usize> = (0..candidates.len())
        .filter(|&i| longest > 0 && context(&candidates[i]) == longest)
        .collect();
    let sizes: Vec<usize> = members.iter().map(Vec::len).collect();
    members
        .iter()
        .enumerate()
        .map(|(g, m)| {
            let mut f = Features {
                size: m.len(),
                groups: members.len(),
                total: candidates.len(),
                longest_context: longest,
                competitor: sizes
                    .iter()
                    .enumerate()
                    .filter(|(other, _)| *other != g)
                    .map(|(_, s)| *s)
                    .max()
                    .unwrap_or(0),
                long_share: if long.is_empty() {
                    0.0
                } else {
                    long.iter().filter(|&&i| group_of[i] == Some(g)).count() as f64
                        / long.len() as f64
                },
                ..Features::default()
            };
            let mut kinds: Vec<Proposer> = Vec::new();
            for &i in m {
                let c = &candidates[i];
                f.p_first = f.p_first.max(p_first[i]);
                if !kinds.contains(&c.proposer()) {
                    kinds.push(c.proposer());
                }
                match c.evidence {
                    Evidence::Model { gated_in, .. } => {
                        f.model = true;
                        f.gated |= gated_in;
                    }
                    Evidence::Sequence {
                        context,
                        places,
                        agreeing,
                        in_routine,
                        ..
                    } => {
                        f.context = f.context.max(context);
                        f.places = f.places.max(places);
                        f.all_agree |= agreeing == places;
                        f.in_routine |= in_routine;
                        match c.proposer() {
                            Proposer::Tool => f.tool = true,
                            Proposer::Work => f.work = true,
                            _ => f.absolute = true,
                        }
                    }
                    Evidence::Template { .. } => f.template = true,
                    Evidence::Lattice(LatticeEvidence::Walk { .. }) => f.walk = true,
                    Evidence::Lattice(LatticeEvidence::Station { .. }) => f.station = true,
                    Evidence::Lattice(LatticeEvidence::Follower { .. }) => f.follower = true,
                }
            }
            f.kinds = kinds.len();
            Group {
                lead: m[0],
                members: m.clone(),
                features: f,
            }
        })
        .collect()
}

/// A logistic model of a group's features: the probability its pose is right.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scorer {
    pub intercept: f64,
    pub weights: [f64; FEATURES],
}

impl Scorer {
    /// The model fitted on the shared corpora ([`super::agreement_weights`]).
    pub const FITTED: Scorer = Scorer {
        intercept: INTERCEPT,
        weights: WEIGHTS,
    };

    /// The log-odds that the group is right.
    pub fn logit(&self, f: &Features) -> f64 {
        self.intercept
            + self
                .weights
                .iter()
                .zip(f.vector())
                .map(|(w, x)| w * x)
                .sum::<f64>()
    }

    /// The probability that the group is right.
    pub fn p(&self, f: &Features) -> f64 {
        sigmoid(self.logit(f))
    }
}

/// The logistic function.
pub fn sigmoid(z: f64) -> f64 {
    1.0 / (1.0 + (-z).exp())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::experts::frames::Frame;
    use crate::engine::pose::Pose;

    fn at(x: f64) -> Pose {
        Pose::new([x, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).expect("a unit quaternion")
    }

    fn sequence(frame: Frame, x: f64, context: usize, places: usize) -> Candidate {
        Candidate {
            pose: at(x),
            evidence: Evidence::Sequence {
                frame,
                context,
                places,
                agreeing: places,
                in_routine: false,
            },
        }
    }

    /// Three candidates at one pose and one elsewhere: two groups, the larger holding every
    /// longest-context candidate and three kinds, the lead the highest estimate.
    #[test]
    fn candidates_at_one_pose_are_one_group() {
        let candidates = [
            sequence(Frame::Tool, 100.0, 3, 2),
            sequence(Frame::Work, 100.4, 3, 1),
            sequence(Frame::Absolute, 250.0, 1, 4),
            Candidate {
                pose: at(99.8),
                evidence: Evidence::Model {
                    window: 2,
                    gated_in: true,
                },
            },
        ];
        let p = [0.6, 0.7, 0.9, 0.2];
        let g = groups(&candidates, &p, Tolerance::USEFUL);
        assert_eq!(g.len(), 2);
        // Seeded by the absolute candidate (0.9), then the work one (0.7).
        assert_eq!(g[0].members, vec![2]);
        assert_eq!(g[1].lead, 1);
        assert_eq!(g[1].members, vec![1, 0, 3]);
        let f = g[1].features;
        assert_eq!((f.size, f.kinds, f.context, f.places), (3, 3, 3, 2));
        assert_eq!((f.competitor, f.total, f.groups), (1, 4, 2));
        assert!((f.long_share - 1.0).abs() < 1e-12 && f.gated && f.tool && f.work);
        assert!(!f.absolute && (f.p_first - 0.7).abs() < 1e-12);
        assert_eq!(g[0].features.long_share, 0.0);
        assert_eq!(g[0].features.competitor, 3);
    }

    /// The fitted model says more for more agreement, all else equal.
    #[test]
    fn agreement_raises_the_fitted_probability() {
        let one = [
            sequence(Frame::Tool, 0.0, 2, 2),
            sequence(Frame::Work, 50.0, 2, 2),
        ];
        let both = [
            sequence(Frame::Tool, 0.0, 2, 2),
            sequence(Frame::Work, 0.2, 2, 2),
        ];
        let p = [0.5, 0.5];
        let alone = groups(&one, &p, Tolerance::USEFUL)[0].features;
        let agreed = groups(&both, &p, Tolerance::USEFUL)[0].features;
        let s = Scorer::FITTED;
        assert!(
            s.p(&agreed) > s.p(&alone),
            "{} vs {}",
            s.p(&agreed),
            s.p(&alone)
        );
    }
}
