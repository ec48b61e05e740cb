//! One work cell's engine while an operator teaches: routines arrive one waypoint at a time,
//! predictions are asked for between waypoints, and finished routines are learned.
//!
//! **Learning within the routine.** With `learn_within_routine`, each taught move is assimilated
//! as the routine grows, so a pattern repeated *inside* a long routine (a palletising grid, weld
//! stitches) is predicted from its earlier repetitions. Moves are assimilated with a lag of
//! `within_lag` moves (default `horizon`). The window a prediction conditions on must only match
//! *earlier* evidence (otherwise every window would match its own fresh path perfectly and the
//! match-quality gate would mean nothing): with a lag shorter than the window, the predictor
//! discounts the window's own transitions (`predict`). The newest assimilated move is
//! *pending*: what follows it is not known yet, which is not the same as the routine ending
//! there. When the routine finishes, the remaining moves are assimilated and the routine is
//! closed; nothing is counted twice. Without it (the seed), a routine is learned when finished.
//!
//! **Undo.** The operator may delete the last waypoint of the routine being taught. When that
//! takes back a move that was already assimilated, the model is rolled back to where it was
//! before the routine's first move was assimilated (the graph's journal, whose cost is that of
//! the routine's moves, not of the model) and the remaining settled moves are learned again, so
//! the model after an undo is exactly the model a rebuild from the stored waypoints gives.

use super::cdhmm::hmm::Hmm;
use super::cdhmm::learner::{ModelStats, ObservationGraph};
use super::cdhmm::predict::scale;
use super::cdhmm::predict::{Prediction, Withheld, predict_move};
use super::config::{EngineConfig, OfferRule, PredictOptions};
use super::error::ConfigError;
use super::experts::acceptance::{Acceptance, Verdict};
use super::experts::calibration::Calibration;
use super::experts::frames::Tolerance;
use super::experts::noise::Noise;
use super::experts::noise::estimate::{NoiseEstimator, OpenRoutine, Pair};
use super::experts::{Candidate, Cell, Evidence, Expert, Proposer};
use super::metric::Metric;
use super::pose::{Move, Observation, Pose, scale_translation};

/// The engine for one work cell.
#[derive(Debug, Clone)]
pub struct Teacher {
    config: EngineConfig,
    graph: ObservationGraph,
    routine: Vec<Pose>,
    moves: Vec<Observation>,
    /// Moves of the current routine already assimilated (within-routine learning only).
    assimilated: usize,
    /// The experts besides the model ([`super::experts::experts`]), asked in turn.
    experts: Vec<Box<dyn Expert>>,
    /// What the cell learned of its candidates' outcomes (with an offer rule).
    calibration: Calibration,
    /// What the finished routines show of the teaching noise (a cell whose noise is not set).
    estimator: Option<NoiseEstimator>,
    /// The cell's teaching noise: set, or learned so far.
    noise: Noise,
    /// What counts as right (with an offer rule): set, or what the noise and the operator's
    /// verdicts imply.
    tolerance: Tolerance,
    /// The verdicts of the finished routines' suggestions (with an offer rule).
    acceptance: Acceptance,
    /// Per waypoint of the current routine: the outcomes its teaching counted, for undo.
    outcomes: Vec<Counted>,
    /// What follows the current routine with the cell's settings: computed once when the routine
    /// or the model changes, answered by [`Teacher::predict`] and judged by the next
    /// [`Teacher::teach`].
    ahead: Ahead,
}

/// The candidates after a routine and the prediction they give.
#[derive(Debug, Clone)]
struct Ahead {
    candidates: Vec<Candidate>,
    prediction: Prediction,
}

/// The outcomes one taught waypoint counted: every candidate's, and the chosen one's by its
/// first-stage estimate; and the suggestion offered for it, with the operator's verdict.
#[derive(Debug, Clone, Default)]
struct Counted {
    candidates: Vec<(Evidence, f64)>,
    chosen: Option<(f64, f64)>,
    /// The waypoint was taught as the cell offered it (a suggestion taken as is).
    suggested: bool,
    /// The pose the cell offered for this waypoint, if it offered one, and which of
    /// `candidates` stand at it (the chosen one is the offered one).
    offered: Option<(Pose, Vec<usize>)>,
    /// The operator's verdict on that suggestion ([`Teacher::feedback`]).
    verdict: Option<Verdict>,
    /// An adjusted suggestion's distance to this waypoint (mm).
    adjusted_mm: Option<f64>,
    /// What the waypoint showed of the noise while the routine is taught: the pairs its stretch
    /// made, and whether it was an exact revisit ([`NoiseEstimator::estimate_with`]).
    pairs: Vec<Pair>,
    revisit: bool,
    /// … and whether it was a return, with its gap to the pose it returned to
    /// ([`NoiseEstimator::return_gap`]).
    returned: Option<(f64, f64)>,
    /// The cell as it was before the waypoint changed its noise, for undo.
    before: Option<Box<Before>>,
}

/// What a waypoint's change of the noise replaced: the noise and tolerance, and (when the
/// noise began or stopped to matter) the calibration.
#[derive(Debug, Clone)]
struct Before {
    noise: Noise,
    tolerance: Tolerance,
    calibration: Option<Calibration>,
}

/// Two poses are the same suggestion: equal to what storing them leaves.
fn same_pose(a: &Pose, b: &Pose) -> bool {
    a.distance_to(b) < 1e-6 && a.angle_to(b) < 1e-6
}

impl Teacher {
    pub fn new(config: EngineConfig) -> Result<Teacher, ConfigError> {
        config.validate()?;
        let metric = Metric::diagonal(config.sigma_t, config.sigma_q)?;
        let graph = ObservationGraph::new(metric, config.delta, config.merge)?
            .with_recency(config.recency)?;
        let ahead = Ahead {
            candidates: Vec::new(),
            prediction: Prediction::withheld(Withheld::NothingTaught, 0),
        };
        let noise = config.noise.unwrap_or(Noise::EXACT);
        let mut t = Teacher {
            estimator: (config.noise.is_none() && config.offer.is_some()).then(NoiseEstimator::new),
            tolerance: Teacher::tolerance_for(&config, &noise, &Acceptance::default()),
            acceptance: Acceptance::default(),
            noise,
            config,
            graph,
            routine: Vec::new(),
            moves: Vec::new(),
            assimilated: 0,
            experts: super::experts::experts(),
            calibration: Calibration::new(),
            outcomes: Vec::new(),
            ahead,
        };
        t.become_noisy_if_it_matters();
        Ok(t)
    }

    /// The tolerance of a cell with this noise and these verdicts: the offer rule's, or the one
    /// the noise implies, tightened by the adjustments ([`Acceptance::tolerance`]).
    fn tolerance_for(config: &EngineConfig, noise: &Noise, acceptance: &Acceptance) -> Tolerance {
        config
            .offer
            .and_then(|r| r.tolerance)
            .unwrap_or_else(|| acceptance.tolerance(noise.tolerance(), noise))
    }

    /// A cell whose noise matters (it widens the tolerance) gets a calibration learned from its
    /// own outcomes only: the prior's counts are exact programs'. A cell whose learned noise
    /// stops mattering (exact revisits showed an exact teacher, [`NoiseEstimator::is_exact`])
    /// goes back to the exact cell's prior. (The experts read whether it matters when asked,
    /// [`Cell::noisy`].)
    fn become_noisy_if_it_matters(&mut self) {
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

    /// The cell's teaching noise: set, or learned so far (exact until its repeats show some).
    pub fn noise(&self) -> Noise {
        self.noise
    }

    /// Whether the noise is learned (not set).
    pub fn learns_noise(&self) -> bool {
        self.estimator.is_some()
    }

    /// What counts as right: the tolerance set, or the one the noise implies.
    pub fn tolerance(&self) -> Tolerance {
        self.tolerance
    }

    /// The threshold on `p_useful` the cell offers at now: set; or its own, for the target
    /// precision (an exact cell, on its calibration's first-stage estimate) or
    /// [`OfferRule::HEAD_START`] (a cell whose noise matters). None without an offer rule.
    pub fn threshold(&self) -> Option<f64> {
        let rule = self.config.offer?;
        Some(rule.threshold.unwrap_or_else(|| {
            if self.noisy() {
                OfferRule::HEAD_START
            } else {
                self.calibration.threshold(rule.target)
            }
        }))
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    pub fn graph(&self) -> &ObservationGraph {
        &self.graph
    }

    /// The waypoints of the routine being taught.
    pub fn routine(&self) -> &[Pose] {
        &self.routine
    }

    pub fn stats(&self) -> ModelStats {
        self.graph.stats()
    }

    /// The cell's calibration of its experts' candidates.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// Appends a taught waypoint to the current routine. With an offer rule, the waypoint first
    /// tells every candidate proposed for it whether it was right ([`Calibration::record`]).
    pub fn teach(&mut self, pose: Pose) {
        let offered = &self.ahead.prediction;
        let offered = offered.pose.filter(|_| offered.offered());
        let suggested = offered.is_some_and(|p| same_pose(&p, &pose));
        let mut counted = match self.config.offer {
            Some(_) if !self.routine.is_empty() => {
                let candidates = &self.ahead.candidates;
                let outcome = |c: &Candidate| self.noise.outcome(&self.tolerance, &c.pose, &pose);
                let chosen = self
                    .likeliest(candidates)
                    .map(|(first, c)| (first, outcome(c)));
                Counted {
                    candidates: candidates
                        .iter()
                        .map(|c| (c.evidence, outcome(c)))
                        .collect(),
                    chosen,
                    offered: offered.map(|o| {
                        let at = candidates.iter().enumerate();
                        (
                            o,
                            at.filter(|(_, c)| same_pose(&c.pose, &o))
                                .map(|(i, _)| i)
                                .collect(),
                        )
                    }),
                    ..Counted::default()
                }
            }
            _ => Counted::default(),
        };
        counted.suggested = suggested;
        for (evidence, right) in &counted.candidates {
            self.calibration.record(evidence, *right);
        }
        if let Some((first, right)) = counted.chosen {
            self.calibration.record_chosen(first, right);
        }
        if let Some(last) = self.routine.last() {
            self.moves.push(Move::between(last, &pose).observation());
        }
        self.routine.push(pose);
        for e in &mut self.experts {
            e.taught(&self.routine);
        }
        self.learn_open_noise(&mut counted);
        self.outcomes.push(counted);
        self.settle();
        self.look_ahead();
    }

    /// The routine being taught shows the noise too: its newest stretch's pairs and its exact
    /// revisits join the finished routines' ([`NoiseEstimator::estimate_with`]), so a cell
    /// whose first repeats come within a long routine learns its operator there and then, not
    /// when the routine is finished. Only until the finished routines give an estimate: after
    /// that a routine's repeats refine it when it is finished (a fit per waypoint would cost
    /// more than the prediction). `counted` (the newest waypoint's) keeps what changed, for
    /// undo; finishing the routine learns it for good.
    fn learn_open_noise(&mut self, counted: &mut Counted) {
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
    fn noisy(&self) -> bool {
        self.config.offer.is_some() && !self.noise.is_negligible(&self.tolerance)
    }

    /// Recomputes [`Teacher::ahead`] after the routine or the model changed.
    fn look_ahead(&mut self) {
        self.ahead = self.ahead_of(&self.routine, &self.moves, &self.config.predict);
    }

    /// Within-routine learning: assimilates the moves older than the lag (`within_lag`).
    fn settle(&mut self) {
        if !self.config.learn_within_routine {
            return;
        }
        let settled = self.moves.len().saturating_sub(self.config.within_lag());
        if self.assimilated < settled {
            // Undo may take these moves back (`restore_routine_start`).
            self.graph.begin_journal();
        }
        while self.assimilated < settled {
            self.graph.push(&self.moves[self.assimilated]);
            self.assimilated += 1;
        }
    }

    /// Removes the last waypoint of the current routine and returns it (None when the routine
    /// is empty). The model goes back to what it was before that waypoint was taught.
    pub fn undo(&mut self) -> Option<Pose> {
        let pose = self.routine.pop()?;
        self.forget_last_outcomes();
        self.moves.truncate(self.routine.len().saturating_sub(1));
        let settled = self.moves.len().saturating_sub(self.config.within_lag());
        if self.config.learn_within_routine && settled < self.assimilated {
            self.restore_routine_start();
            self.settle();
        }
        self.look_ahead();
        Some(pose)
    }

    /// Drops the current routine without learning it; the model is as it was before.
    pub fn abandon_routine(&mut self) {
        while !self.outcomes.is_empty() {
            self.forget_last_outcomes();
        }
        self.routine.clear();
        self.moves.clear();
        self.restore_routine_start();
        self.look_ahead();
    }

    /// The operator's verdict on the suggestion offered for waypoint `index` of the current
    /// routine (see [`super::experts::acceptance`]): `offered` is the suggestion's pose, and an
    /// adjusted one comes with the pose finally taught. A verdict that is not about what this
    /// cell offered there is ignored: no offer, another pose, a waypoint that is not the one
    /// accepted or adjusted to, or one already judged. Returns whether it was taken.
    ///
    /// A suggestion rejected counts as wrong (its candidates' outcomes with it); an adjusted
    /// one's distance joins the verdicts the tolerance is learned from when the routine is
    /// finished. Undoing the waypoint takes the verdict back.
    pub fn feedback(
        &mut self,
        index: usize,
        offered: &Pose,
        verdict: Verdict,
        taught_as: Option<&Pose>,
    ) -> bool {
        let (Some(taught), Some(counted)) = (self.routine.get(index), self.outcomes.get(index))
        else {
            return false;
        };
        let Some((pose, at)) = counted.offered.as_ref() else {
            return false;
        };
        let about_this = counted.verdict.is_none()
            && same_pose(pose, offered)
            && match verdict {
                Verdict::Accepted => counted.suggested,
                Verdict::Adjusted => taught_as.is_some_and(|t| same_pose(t, taught)),
                Verdict::Rejected => true,
            };
        if !about_this {
            return false;
        }
        let (taught, at) = (*taught, at.clone());
        let counted = &mut self.outcomes[index];
        counted.verdict = Some(verdict);
        if verdict == Verdict::Adjusted {
            counted.adjusted_mm = Some(offered.distance_to(&taught));
        }
        let mut changed = false;
        if verdict == Verdict::Rejected {
            // The calibration the waypoint's outcomes were counted in: the cell's, and the one
            // an undo restores when the waypoint changed the cell's experts.
            let mut snapshot = counted.before.as_mut().and_then(|b| b.calibration.as_mut());
            for i in at {
                let (evidence, right) = &mut counted.candidates[i];
                if *right > 0.0 {
                    for c in std::iter::once(&mut self.calibration).chain(snapshot.as_deref_mut()) {
                        c.forget(evidence, *right);
                        c.record(evidence, 0.0);
                    }
                    *right = 0.0;
                    changed = true;
                }
            }
            if let Some((first, right)) = counted.chosen.as_mut()
                && *right > 0.0
            {
                for c in std::iter::once(&mut self.calibration).chain(snapshot) {
                    c.forget_chosen(*first, *right);
                    c.record_chosen(*first, 0.0);
                }
                *right = 0.0;
                changed = true;
            }
        }
        if changed {
            self.look_ahead();
        }
        true
    }

    fn forget_last_outcomes(&mut self) {
        let counted = self.outcomes.pop().unwrap_or_default();
        for e in &mut self.experts {
            e.undo();
        }
        if let Some(before) = counted.before {
            self.noise = before.noise;
            self.tolerance = before.tolerance;
            if let Some(calibration) = before.calibration {
                self.calibration = calibration;
            }
        }
        for (evidence, right) in counted.candidates {
            self.calibration.forget(&evidence, right);
        }
        if let Some((first, right)) = counted.chosen {
            self.calibration.forget_chosen(first, right);
        }
    }

    /// The model's (the CDHMM's) own prediction after `routine` (not empty).
    fn model_prediction(
        &self,
        routine: &[Pose],
        moves: &[Observation],
        opts: &PredictOptions,
    ) -> Prediction {
        match routine.last() {
            Some(last) => predict_move(&self.graph, moves, opts).place(last),
            None => Prediction::withheld(Withheld::NothingTaught, self.graph.nodes().len()),
        }
    }

    /// Every expert's candidates after `routine`: the model's proposal (whatever its gates
    /// said), then each expert's in turn.
    fn candidates(&self, routine: &[Pose], model: &Prediction) -> Vec<Candidate> {
        let mut out = Vec::with_capacity(8);
        if let Some(pose) = model.pose {
            out.push(Candidate {
                pose,
                evidence: Evidence::Model {
                    window: model.window,
                    gated_in: model.offered(),
                },
            });
        }
        let cell = Cell {
            noise: self.noise,
            tolerance: self.tolerance,
            noisy: self.noisy(),
        };
        for e in &self.experts {
            out.extend(e.propose(routine, &cell));
        }
        out
    }

    /// The prediction after `routine`: the model's alone without an offer rule (the seed);
    /// with one, the likeliest candidate, offered when its `p_useful` reaches the threshold.
    fn choose(&self, routine: &[Pose], moves: &[Observation], opts: &PredictOptions) -> Prediction {
        self.ahead_of(routine, moves, opts).prediction
    }

    /// The candidates after `routine` (none without an offer rule) and the prediction they give.
    fn ahead_of(&self, routine: &[Pose], moves: &[Observation], opts: &PredictOptions) -> Ahead {
        let model = self.model_prediction(routine, moves, opts);
        let (Some(rule), Some(last)) = (self.config.offer, routine.last()) else {
            return Ahead {
                candidates: Vec::new(),
                prediction: model,
            };
        };
        let candidates = self.candidates(routine, &model);
        let prediction = self.decide(model, &candidates, &rule, last);
        Ahead {
            candidates,
            prediction,
        }
    }

    /// The offer rule's prediction from the candidates: the likeliest one, offered when its
    /// `p_useful` reaches the threshold (the model's own prediction when there is none).
    fn decide(
        &self,
        model: Prediction,
        candidates: &[Candidate],
        rule: &OfferRule,
        last: &Pose,
    ) -> Prediction {
        let Some((first, c)) = self.likeliest(candidates) else {
            return model;
        };
        let p = self.calibration.chosen(first);
        let offered = match rule.threshold {
            Some(t) => p >= t,
            None if self.noisy() => p >= OfferRule::HEAD_START,
            None => self.calibration.offers(first, rule.target),
        };
        let c = *c;
        let mut out = model;
        let by_model = c.proposer() == Proposer::Model;
        if !by_model {
            out.pose = Some(c.pose);
            out.relative = Some(Move::between(last, &c.pose).observation());
        }
        out.p_useful = Some(p);
        out.expert = Some(c.proposer());
        // The model's own proposal keeps the reason its gate gave, if one did.
        let own_reason = out.withheld.filter(|_| by_model);
        out.withheld = (!offered).then(|| own_reason.unwrap_or(Withheld::Unlikely { p_useful: p }));
        out
    }

    /// The candidate with the highest first-stage `p_useful` (the first of equals), with it.
    fn likeliest<'a>(&self, candidates: &'a [Candidate]) -> Option<(f64, &'a Candidate)> {
        let mut best: Option<(f64, &Candidate)> = None;
        for c in candidates {
            let p = self.calibration.p_useful(&c.evidence);
            if best.is_none_or(|(b, _)| p > b) {
                best = Some((p, c));
            }
        }
        best
    }

    /// The model as it was before the current routine's first move was assimilated.
    fn restore_routine_start(&mut self) {
        self.graph.rollback();
        self.assimilated = 0;
    }

    /// Predicts the next waypoint of the current routine with the cell's settings (computed
    /// when the routine last changed).
    pub fn predict(&self) -> Prediction {
        self.ahead.prediction.clone()
    }

    /// Predicts with per-request settings.
    pub fn predict_with(&self, opts: &PredictOptions) -> Prediction {
        if *opts == self.config.predict {
            return self.predict();
        }
        self.choose(&self.routine, &self.moves, opts)
    }

    /// Open-loop completion: predicts the next waypoint, assumes it is taught as predicted,
    /// predicts again, and so on, up to `k` predictions. Stops after the first prediction that
    /// is not offered (it is included, so the caller sees why the completion stopped). The
    /// model is not changed: proposed moves are conditioned on, never learned.
    pub fn complete(&self, k: usize, opts: &PredictOptions) -> Vec<Prediction> {
        self.complete_with(k, opts, |p| (p, true))
    }

    /// [`Teacher::complete`] with a further gate of the caller's (e.g. the arm reaches it):
    /// `gate` gets every prediction in turn, and returns what to keep of it and whether the
    /// completion may go on from it. It goes on only from a prediction that is offered and that
    /// the gate lets pass; the one it stops at is the last one kept.
    pub fn complete_with<T>(
        &self,
        k: usize,
        opts: &PredictOptions,
        mut gate: impl FnMut(Prediction) -> (T, bool),
    ) -> Vec<T> {
        let mut out = Vec::with_capacity(k.min(64));
        if self.routine.is_empty() {
            if k > 0 {
                let nothing =
                    Prediction::withheld(Withheld::NothingTaught, self.graph.nodes().len());
                out.push(gate(nothing).0);
            }
            return out;
        }
        let mut routine = self.routine.clone();
        let mut moves = self.moves.clone();
        for _ in 0..k {
            let p = self.choose(&routine, &moves, opts);
            let next = match (&p.pose, &p.relative) {
                (Some(pose), Some(x)) if p.offered() => Some((*pose, *x)),
                _ => None,
            };
            let (kept, go_on) = gate(p);
            out.push(kept);
            let Some((pose, x)) = next.filter(|_| go_on) else {
                break;
            };
            moves.push(x);
            routine.push(pose);
        }
        out
    }

    /// Teaches a whole routine, waypoint by waypoint, and finishes it (an imported routine).
    pub fn learn_routine(&mut self, waypoints: &[Pose]) {
        for pose in waypoints {
            self.teach(*pose);
        }
        self.finish_routine();
    }

    /// Finishes the current routine and learns it. A routine of fewer than two waypoints has no
    /// move and teaches nothing.
    pub fn finish_routine(&mut self) {
        for e in &mut self.experts {
            e.learn(&self.routine);
        }
        for mm in self.outcomes.iter().filter_map(|c| c.adjusted_mm) {
            self.acceptance.add(mm);
        }
        let noise = match self.estimator.as_mut() {
            Some(e) => {
                let suggested: Vec<bool> = self.outcomes.iter().map(|c| c.suggested).collect();
                e.learn_taught(&self.routine, &suggested);
                e.estimate().unwrap_or(Noise::EXACT)
            }
            None => self.noise,
        };
        let tolerance = Teacher::tolerance_for(&self.config, &noise, &self.acceptance);
        if noise != self.noise || tolerance != self.tolerance {
            self.noise = noise;
            self.tolerance = tolerance;
            self.become_noisy_if_it_matters();
        }
        self.outcomes.clear();
        self.graph.commit();
        if self.config.learn_within_routine {
            for x in &self.moves[self.assimilated..] {
                self.graph.push(x);
            }
        } else if !self.moves.is_empty() {
            let psi = if self.config.predict.scale.learn_scaled {
                self.routine_scale_estimate()
            } else {
                1.0
            };
            for x in &self.moves {
                self.graph.push(&scale_translation(x, psi));
            }
        }
        self.graph.end_routine();
        self.routine.clear();
        self.moves.clear();
        self.assimilated = 0;
        self.look_ahead();
    }

    /// Learn-Scaled-HMM: ψ of the finished routine against the current model, when the routine is
    /// no longer than the model's depth; 1 unless the gain is material.
    fn routine_scale_estimate(&self) -> f64 {
        let stats = self.graph.stats();
        if stats.states < 2 || self.moves.len() > stats.depth {
            return 1.0;
        }
        let hmm = Hmm::new(&self.graph);
        let sc = &self.config.predict.scale;
        let opts = PredictOptions {
            horizon: self.moves.len(),
            ..self.config.predict.clone()
        };
        let objective = |psi: f64| {
            let scaled: Vec<Observation> = self
                .moves
                .iter()
                .map(|x| scale_translation(x, psi))
                .collect();
            super::cdhmm::predict::forward::window_log_likelihood(&hmm, &scaled, &opts)
        };
        let base = objective(1.0);
        match scale::maximise(sc.psi_min, sc.psi_max, objective) {
            Some(est) if est.objective - base >= sc.min_gain => est.psi,
            _ => 1.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::config::Profile;
    use crate::engine::experts::acceptance::MIN_ADJUSTMENTS;
    use nalgebra::UnitQuaternion;

    fn pose(p: [f64; 3], yaw: f64) -> Pose {
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
        Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
    }

    /// A stitch pattern repeated along x: the same three moves again and again.
    fn stitches(n: usize, at: f64) -> Vec<Pose> {
        (0..n)
            .map(|i| {
                let k = (i / 3) as f64;
                match i % 3 {
                    0 => pose([at + 50.0 * k, 0.0, 0.0], 0.0),
                    1 => pose([at + 50.0 * k + 20.0, 10.0, 0.0], 0.3),
                    _ => pose([at + 50.0 * k + 30.0, 0.0, 15.0], 0.1),
                }
            })
            .collect()
    }

    fn same_model(a: &Teacher, b: &Teacher) {
        assert_eq!(a.graph().nodes(), b.graph().nodes());
        assert_eq!(a.graph().pending(), b.graph().pending());
        assert_eq!(a.stats(), b.stats());
        assert_eq!(a.routine(), b.routine());
        assert_eq!(a.predict(), b.predict());
    }

    /// The engine taught poses at the ends of the floats, which the service refuses where poses
    /// enter (issue 46: −1e308 reached the k-d tree, whose leaf sort panicked on the NaN of a
    /// move between two such poses): no panic, nothing non-finite offered, and the cell still
    /// learns and predicts an ordinary pattern afterwards.
    #[test]
    fn poses_at_the_ends_of_the_floats_are_taught_without_a_panic() {
        let extreme: Vec<Vec<Pose>> = vec![
            vec![
                pose([-1e308, 0.0, 0.0], 0.0),
                pose([1e308, 0.0, 0.0], 0.3),
                pose([1e308, 1e308, -1e308], 1.2),
                pose([0.0, 0.0, 0.0], 0.0),
            ],
            vec![
                pose([f64::MAX, -f64::MAX, f64::MAX], 0.7),
                pose([-f64::MAX, f64::MAX, -f64::MAX], 2.0),
                pose([1e154, 1e154, 1e154], 0.1),
                pose([-1e154, 0.0, 1e154], 0.2),
            ],
            vec![pose([1e308, 0.0, 0.0], 0.0); 5],
            vec![
                pose([1e300, -1e300, 5.0], 0.4),
                pose([1e300, -1e300, 6.0], 0.4),
            ],
        ];
        for profile in [Profile::Seed, Profile::Default] {
            let mut t = Teacher::new(EngineConfig::profile(profile)).unwrap();
            let finite = |p: &Prediction| {
                p.pose.is_none_or(|q| {
                    let v = q.values();
                    [v.x, v.y, v.z, v.qw, v.qx, v.qy, v.qz]
                        .iter()
                        .all(|x| x.is_finite())
                })
            };
            for _ in 0..3 {
                for routine in &extreme {
                    for w in routine {
                        t.teach(*w);
                        let p = t.predict();
                        assert!(!p.offered() || finite(&p), "{profile:?}: {p:?}");
                    }
                    t.finish_routine();
                }
            }
            // Undo over the extreme poses, then a routine of them abandoned.
            extreme[0].iter().for_each(|w| t.teach(*w));
            while t.undo().is_some() {}
            extreme[1].iter().for_each(|w| t.teach(*w));
            t.abandon_routine();
            assert_eq!(t.stats().routines, 12, "{profile:?}");
            // An ordinary pattern is still learned and predicted.
            t.learn_routine(&stitches(15, 0.0));
            t.learn_routine(&stitches(15, 700.0));
            let copy = stitches(15, 2000.0);
            copy[..8].iter().for_each(|w| t.teach(*w));
            let p = t.predict();
            assert!(p.offered(), "{profile:?}: {:?}", p.withheld);
            let got = p.pose.unwrap();
            assert!(
                got.distance_to(&copy[8]) < 1e-6,
                "{profile:?}: {} mm off",
                got.distance_to(&copy[8])
            );
        }
    }

    #[test]
    fn undo_gives_the_model_of_the_shorter_routine() {
        for profile in [Profile::Default, Profile::Seed] {
            let config = EngineConfig::profile(profile);
            let first = stitches(12, 0.0);
            let second = stitches(14, 1000.0);
            let mut a = Teacher::new(config.clone()).unwrap();
            let mut b = Teacher::new(config).unwrap();
            for t in [&mut a, &mut b] {
                first.iter().for_each(|w| t.teach(*w));
                t.finish_routine();
            }
            second.iter().for_each(|w| a.teach(*w));
            for _ in 0..5 {
                assert!(a.undo().is_some());
            }
            second[..9].iter().for_each(|w| b.teach(*w));
            same_model(&a, &b);
            // Teaching on after the undo keeps them identical.
            second[9..].iter().for_each(|w| {
                a.teach(*w);
                b.teach(*w);
            });
            same_model(&a, &b);
            a.finish_routine();
            b.finish_routine();
            same_model(&a, &b);
        }
    }

    /// Every routine works somewhere new, then retracts to one point and goes home: with the
    /// experts' offer rule home is offered after the retract point, with its p_useful and the
    /// expert that proposed it; the undo of that routine's waypoints restores the calibration.
    #[test]
    fn the_offer_rule_returns_home_and_reports_p_useful() {
        let config = EngineConfig::profile(Profile::Default);
        let home = pose([0.0, 0.0, 800.0], 0.0);
        let retract = pose([700.0, 50.0, 600.0], 0.1);
        let routine = |i: f64| {
            vec![
                home,
                pose([300.0 + 37.0 * i, 20.0 * i, 400.0], 0.3 * i),
                pose([350.0 + 41.0 * i, -15.0 * i, 380.0], 0.2 * i),
                retract,
                home,
            ]
        };
        let mut t = Teacher::new(config).unwrap();
        for i in 0..6 {
            routine(f64::from(i)).iter().for_each(|w| t.teach(*w));
            t.finish_routine();
        }
        let before = t.calibration().clone();
        let next = routine(9.0);
        next[..4].iter().for_each(|w| t.teach(*w));
        let p = t.predict();
        assert!(p.offered(), "{:?}", p.withheld);
        let got = p.pose.unwrap();
        assert!(got.distance_to(&home) < 1e-6 && got.angle_to(&home) < 1e-6);
        assert!(p.p_useful.unwrap() >= 0.9, "{:?}", p.p_useful);
        assert!(p.expert.is_some());
        assert_ne!(
            t.calibration(),
            &before,
            "the taught waypoints counted outcomes"
        );
        while t.undo().is_some() {}
        assert_eq!(t.calibration(), &before);
    }

    #[test]
    fn undo_of_an_empty_routine_is_none_and_abandon_restores_the_model() {
        let mut t = Teacher::new(EngineConfig::default()).unwrap();
        assert!(t.undo().is_none());
        stitches(12, 0.0).iter().for_each(|w| t.teach(*w));
        t.finish_routine();
        let before = t.clone();
        stitches(15, 500.0).iter().for_each(|w| t.teach(*w));
        assert_ne!(t.graph().nodes(), before.graph().nodes());
        t.abandon_routine();
        same_model(&t, &before);
        while t.undo().is_some() {}
        same_model(&t, &before);
    }

    #[test]
    fn completion_continues_a_known_pattern_without_learning() {
        let mut t = Teacher::new(EngineConfig::default()).unwrap();
        let routine = stitches(15, 0.0);
        routine.iter().for_each(|w| t.teach(*w));
        t.finish_routine();
        let copy = stitches(15, 2000.0);
        copy[..5].iter().for_each(|w| t.teach(*w));
        let nodes = t.graph().nodes().to_vec();
        let opts = t.config().predict.clone();
        let completion = t.complete(4, &opts);
        assert_eq!(t.graph().nodes(), &nodes[..]);
        assert!(!completion.is_empty());
        assert_eq!(completion[0], t.predict());
        for (i, p) in completion.iter().enumerate().filter(|(_, p)| p.offered()) {
            let got = p.pose.unwrap();
            let want = &copy[5 + i];
            assert!(
                got.distance_to(want) < 1e-6,
                "step {i}: {} mm",
                got.distance_to(want)
            );
        }
        assert!(completion[0].offered(), "{:?}", completion[0].withheld);
        // Nothing taught: one prediction saying why.
        let empty = Teacher::new(EngineConfig::default()).unwrap();
        let c = empty.complete(3, &opts);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].withheld, Some(Withheld::NothingTaught));
        assert!(t.complete(0, &opts).is_empty());
    }

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

    /// A picky operator (accepts within half the tolerance their noise implies, fine-tunes
    /// within twice that, rejects the rest) teaches a repeated noisy task with no settings,
    /// judging every suggestion: their adjustments tighten the cell's tolerance, their rejections
    /// count as wrong, and it offers fewer suggestions the operator does not take as is than a
    /// cell that is told nothing. Undoing judged waypoints and teaching them again (the verdict given again,
    /// as the service replays it from the database) leaves the cell equal to one that never
    /// undid: the verdicts go with their waypoints.
    #[test]
    fn verdicts_tighten_the_tolerance_and_undo_takes_them_back() {
        use crate::engine::experts::noise::estimate::tests::{task, wander};
        use crate::engine::experts::noise::tests::noisy;
        use rand::{Rng, SeedableRng};
        use rand_chacha::ChaCha8Rng;
        let truth = Noise {
            mm: 11.5,
            rad: 0.02,
        };
        let picky = 0.5 * truth.tolerance().mm;
        // (offered, accepted) in the last five tasks, with and without verdicts.
        let mut taken = [(0u32, 0u32); 2];
        for (run, judged) in [(0, true), (1, false)] {
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let mut t = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
            let mut replayed = t.clone();
            for k in 0..12 {
                let meant = task(
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-1.0..1.0),
                );
                for (i, placed) in noisy(&meant, &truth, &mut rng).iter().enumerate() {
                    let p = t.predict();
                    let offer = p.pose.filter(|_| p.offered());
                    let step = offer.map(|o| match o.distance_to(&meant[i]) {
                        d if d <= picky => (o, Verdict::Accepted, None),
                        d if d <= 2.0 * picky => (*placed, Verdict::Adjusted, Some(*placed)),
                        _ => (*placed, Verdict::Rejected, None),
                    });
                    if k >= 7
                        && let Some((_, v, _)) = step
                    {
                        taken[run].0 += 1;
                        taken[run].1 += u32::from(v.right());
                    }
                    let pose = step.map_or(*placed, |s| s.0);
                    let judge = |t: &mut Teacher| match (offer, step) {
                        (Some(o), Some((_, v, f))) if judged => {
                            assert!(t.feedback(i, &o, v, f.as_ref()));
                            assert!(!t.feedback(i, &o, v, f.as_ref()), "judged twice");
                        }
                        _ => {}
                    };
                    t.teach(pose);
                    judge(&mut t);
                    replayed.teach(pose);
                    judge(&mut replayed);
                    if i % 4 == 3 {
                        t.undo();
                        t.teach(pose);
                        judge(&mut t);
                    }
                }
                t.finish_routine();
                replayed.finish_routine();
                let other = noisy(&wander(8, &mut rng), &truth, &mut rng);
                for w in &other {
                    t.teach(*w);
                    replayed.teach(*w);
                }
                t.finish_routine();
                replayed.finish_routine();
            }
            assert_eq!(t.noise(), replayed.noise());
            assert_eq!(t.tolerance(), replayed.tolerance());
            assert_eq!(t.acceptance, replayed.acceptance);
            assert_eq!(t.calibration(), replayed.calibration());
            same_model(&t, &replayed);
            let prior = t.noise().tolerance();
            if judged {
                assert!(t.acceptance.adjustments() >= MIN_ADJUSTMENTS);
                assert!(t.tolerance().mm < 0.85 * prior.mm, "{:?}", t.tolerance());
                assert!(t.tolerance().mm >= t.noise().mm);
            } else {
                assert_eq!(t.tolerance(), prior);
            }
        }
        // Told nothing, the cell offers what the noise implies the operator takes, and most of
        // it is not taken as is; judged, it offers less of what is not (measured 2026-12-05:
        // 18 of 25 offers not taken as is, against 29 of 40).
        let not_taken = |(n, a): (u32, u32)| n - a;
        assert!(taken[1].0 >= 20, "{taken:?}");
        assert!(
            4 * not_taken(taken[0]) <= 3 * not_taken(taken[1]),
            "{taken:?}"
        );
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

    /// Exact programs keep an exact cell: the learned noise stays negligible, the tolerance the
    /// seed's, and the calibration the prior's.
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
        assert!(t.noise().is_negligible(&Tolerance::SEED), "{:?}", t.noise());
        assert_eq!(t.tolerance(), Tolerance::SEED);
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
