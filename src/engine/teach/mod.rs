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
//! closed; nothing is counted twice. Without it (the dissertation's engine), a routine is
//! learned when finished.
//!
//! **Undo.** The operator may delete the last waypoint of the routine being taught. When that
//! takes back a move that was already assimilated, the model is rolled back to where it was
//! before the routine's first move was assimilated (the graph's journal, whose cost is that of
//! the routine's moves, not of the model) and the remaining settled moves are learned again, so
//! the model after an undo is exactly the model a rebuild from the stored waypoints gives. Each
//! part of the cell undoes its own: the experts theirs ([`super::experts::Expert::undo`]), the
//! offer rule the outcomes a waypoint counted ([`offer_rule`]), the learned noise what the
//! waypoint showed of it ([`learned_noise`]).
//!
//! Here: the [`Teacher`] (teach, predict, complete, undo, finish; the routine being taught and
//! the CDHMM learning within it), which holds the settings, the graph, the routine, the experts,
//! the offer rule and the noise, each of the last three with its own state and undo;
//! [`offer_rule`]: the candidates' outcomes, the likeliest candidate and whether it is offered,
//! the operator's verdicts; [`learned_noise`]: the cell's noise and tolerance learned while it
//! is taught.

mod learned_noise;
mod offer_rule;

use super::cdhmm::hmm::Hmm;
use super::cdhmm::learner::{ModelStats, ObservationGraph};
use super::cdhmm::predict::scale;
use super::cdhmm::predict::{Prediction, Withheld, predict_move};
use super::config::{EngineConfig, PredictOptions};
use super::error::ConfigError;
use super::experts::acceptance::Verdict;
use super::experts::calibration::Calibration;
use super::experts::frames::Tolerance;
use super::experts::noise::Noise;
use super::experts::{Candidate, Evidence, Expert};
use super::metric::Metric;
use super::pose::{Move, Observation, Pose, scale_translation};
use learned_noise::LearnedNoise;
use offer_rule::OfferRuleState;

/// The engine for one work cell.
#[derive(Debug, Clone)]
pub struct Teacher {
    /// The cell's settings.
    config: EngineConfig,
    /// The model: the observation graph of every move assimilated.
    graph: ObservationGraph,
    /// The routine being taught.
    routine: CurrentRoutine,
    /// The experts besides the model ([`super::experts::experts`]), asked in turn.
    experts: Vec<Box<dyn Expert>>,
    /// The offer rule: its calibration of the candidates, and what each taught waypoint counted.
    offer_rule: OfferRuleState,
    /// The cell's teaching noise and tolerance: set, or learned while it is taught.
    noise: LearnedNoise,
}

/// The routine being taught: its waypoints, the moves between them, how many of those the graph
/// has assimilated, and what follows it.
#[derive(Debug, Clone)]
struct CurrentRoutine {
    waypoints: Vec<Pose>,
    moves: Vec<Observation>,
    /// Moves already assimilated (within-routine learning only).
    assimilated: usize,
    /// What follows the routine with the cell's settings: computed once when the routine or the
    /// model changes, answered by [`Teacher::predict`] and judged by the next [`Teacher::teach`].
    ahead: Ahead,
}

/// The candidates after a routine and the prediction they give.
#[derive(Debug, Clone)]
struct Ahead {
    candidates: Vec<Candidate>,
    prediction: Prediction,
}

impl Teacher {
    pub fn new(config: EngineConfig) -> Result<Teacher, ConfigError> {
        config.validate()?;
        let metric = Metric::diagonal(config.sigma_t, config.sigma_q)?;
        let graph = ObservationGraph::new(metric, config.delta, config.merge)?
            .with_recency(config.recency)?;
        let routine = CurrentRoutine {
            waypoints: Vec::new(),
            moves: Vec::new(),
            assimilated: 0,
            ahead: Ahead {
                candidates: Vec::new(),
                prediction: Prediction::withheld(Withheld::NothingTaught, 0),
            },
        };
        let noise = LearnedNoise::new(&config);
        let mut offer_rule = OfferRuleState::new();
        offer_rule.follow_noise(noise.matters(), false);
        Ok(Teacher {
            config,
            graph,
            routine,
            experts: super::experts::experts(),
            offer_rule,
            noise,
        })
    }

    /// The cell's teaching noise: set, or learned so far (exact until its repeats show some).
    pub fn noise(&self) -> Noise {
        self.noise.noise()
    }

    /// Whether the noise is learned (not set).
    pub fn learns_noise(&self) -> bool {
        self.noise.learns()
    }

    /// What counts as right: the tolerance set, or the one the noise implies.
    pub fn tolerance(&self) -> Tolerance {
        self.noise.tolerance()
    }

    /// Whether the cell's noise matters (it widens the tolerance).
    fn noisy(&self) -> bool {
        self.noise.matters()
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    pub fn graph(&self) -> &ObservationGraph {
        &self.graph
    }

    /// The waypoints of the routine being taught.
    pub fn routine(&self) -> &[Pose] {
        &self.routine.waypoints
    }

    pub fn stats(&self) -> ModelStats {
        self.graph.stats()
    }

    /// Every expert's candidates for the next waypoint, in the order the offer rule met them
    /// (none without an offer rule, or before a routine's first waypoint).
    pub fn candidates_ahead(&self) -> &[Candidate] {
        &self.routine.ahead.candidates
    }

    /// The cell's calibration of its experts' candidates.
    pub fn calibration(&self) -> &Calibration {
        self.offer_rule.calibration()
    }

    /// The threshold on `p_useful` the cell offers at now: set; or its own, for the target
    /// precision (an exact cell, on its calibration's first-stage estimate) or
    /// [`crate::engine::OfferRule::HEAD_START`] (a cell whose noise matters). None without an
    /// offer rule.
    pub fn threshold(&self) -> Option<f64> {
        let rule = self.config.offer?;
        Some(self.offer_rule.threshold(&rule, self.noisy()))
    }

    /// Appends a taught waypoint to the current routine. With an offer rule, the waypoint first
    /// tells every candidate proposed for it whether it was right ([`Calibration::record`]),
    /// and the routine may show the cell's noise.
    pub fn teach(&mut self, pose: Pose) {
        let judged = self.config.offer.is_some() && !self.routine.waypoints.is_empty();
        let noise = &self.noise;
        let outcome = judged.then_some(|proposed: &Pose| noise.outcome(proposed, &pose));
        let suggested = self.offer_rule.count(&pose, &self.routine.ahead, outcome);
        if let Some(last) = self.routine.waypoints.last() {
            self.routine
                .moves
                .push(Move::between(last, &pose).observation());
        }
        self.routine.waypoints.push(pose);
        for e in &mut self.experts {
            e.taught(&self.routine.waypoints);
        }
        if self.noise.learn_open(&self.routine.waypoints, suggested) {
            self.offer_rule.follow_noise(self.noise.matters(), true);
        }
        self.settle();
        self.look_ahead();
    }

    /// The operator's verdict on the suggestion offered for waypoint `index` of the current
    /// routine ([`offer_rule`], see [`super::experts::acceptance`]): `offered` is the
    /// suggestion's pose, and an adjusted one comes with the pose finally taught. Returns
    /// whether it was taken (a verdict that is not about what this cell offered there is not).
    pub fn feedback(
        &mut self,
        index: usize,
        offered: &Pose,
        verdict: Verdict,
        taught_as: Option<&Pose>,
    ) -> bool {
        let (taken, changed) =
            self.offer_rule
                .feedback(&self.routine.waypoints, index, offered, verdict, taught_as);
        if changed {
            self.look_ahead();
        }
        taken
    }

    /// Recomputes what follows the routine after the routine or the model changed.
    fn look_ahead(&mut self) {
        self.routine.ahead = self.ahead_of(
            &self.routine.waypoints,
            &self.routine.moves,
            &self.config.predict,
        );
    }

    /// Within-routine learning: assimilates the moves older than the lag (`within_lag`).
    fn settle(&mut self) {
        if !self.config.learn_within_routine {
            return;
        }
        let r = &mut self.routine;
        let settled = r.moves.len().saturating_sub(self.config.within_lag());
        if r.assimilated < settled {
            // Undo may take these moves back (`restore_routine_start`).
            self.graph.begin_journal();
        }
        while r.assimilated < settled {
            self.graph.push(&r.moves[r.assimilated]);
            r.assimilated += 1;
        }
    }

    /// Removes the last waypoint of the current routine and returns it (None when the routine
    /// is empty). The model goes back to what it was before that waypoint was taught.
    pub fn undo(&mut self) -> Option<Pose> {
        let pose = self.routine.waypoints.pop()?;
        self.forget_last_waypoint();
        let r = &mut self.routine;
        r.moves.truncate(r.waypoints.len().saturating_sub(1));
        let settled = r.moves.len().saturating_sub(self.config.within_lag());
        if self.config.learn_within_routine && settled < r.assimilated {
            self.restore_routine_start();
            self.settle();
        }
        self.look_ahead();
        Some(pose)
    }

    /// Each part of the cell takes back what the newest waypoint of the routine changed of it.
    fn forget_last_waypoint(&mut self) {
        for e in &mut self.experts {
            e.undo();
        }
        self.noise.undo();
        self.offer_rule.undo();
    }

    /// Drops the current routine without learning it; the model is as it was before.
    pub fn abandon_routine(&mut self) {
        for _ in 0..self.routine.waypoints.len() {
            self.forget_last_waypoint();
        }
        self.routine.waypoints.clear();
        self.routine.moves.clear();
        self.restore_routine_start();
        self.look_ahead();
    }

    /// The model's (the CDHMM's) own prediction after `routine` (not empty).
    fn model_prediction(
        &self,
        routine: &[Pose],
        moves: &[Observation],
        opts: &PredictOptions,
    ) -> Prediction {
        match routine.last() {
            Some(last) => predict_move(&self.graph, moves, opts).placed_after(last),
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
        let cell = self.noise.cell();
        for e in &self.experts {
            out.extend(e.propose(routine, &cell));
        }
        out
    }

    /// The prediction after `routine`: the model's alone without an offer rule (the
    /// dissertation's); with one, the likeliest candidate, offered when its `p_useful` reaches
    /// the threshold.
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
        let prediction = self
            .offer_rule
            .decide(model, &candidates, &rule, last, self.noisy());
        Ahead {
            candidates,
            prediction,
        }
    }

    /// The model as it was before the current routine's first move was assimilated.
    fn restore_routine_start(&mut self) {
        self.graph.rollback();
        self.routine.assimilated = 0;
    }

    /// Predicts the next waypoint of the current routine with the cell's settings (computed
    /// when the routine last changed).
    pub fn predict(&self) -> Prediction {
        self.routine.ahead.prediction.clone()
    }

    /// Predicts with per-request settings.
    pub fn predict_with(&self, opts: &PredictOptions) -> Prediction {
        if *opts == self.config.predict {
            return self.predict();
        }
        self.choose(&self.routine.waypoints, &self.routine.moves, opts)
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
        if self.routine.waypoints.is_empty() {
            if k > 0 {
                let nothing =
                    Prediction::withheld(Withheld::NothingTaught, self.graph.nodes().len());
                out.push(gate(nothing).0);
            }
            return out;
        }
        let mut routine = self.routine.waypoints.clone();
        let mut moves = self.routine.moves.clone();
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
            e.learn(&self.routine.waypoints);
        }
        let adjusted = self.offer_rule.adjusted_mm();
        if self.noise.learn_routine(&self.routine.waypoints, adjusted) {
            self.offer_rule.follow_noise(self.noise.matters(), false);
        }
        self.offer_rule.finish_routine();
        self.graph.commit();
        let r = &self.routine;
        if self.config.learn_within_routine {
            for x in &r.moves[r.assimilated..] {
                self.graph.push(x);
            }
        } else if !r.moves.is_empty() {
            let psi = if self.config.predict.scale.learn_scaled {
                self.routine_scale_estimate()
            } else {
                1.0
            };
            for x in &self.routine.moves {
                self.graph.push(&scale_translation(x, psi));
            }
        }
        self.graph.end_routine();
        self.routine.waypoints.clear();
        self.routine.moves.clear();
        self.routine.assimilated = 0;
        self.look_ahead();
    }

    /// Learn-Scaled-HMM: ψ of the finished routine against the current model, when the routine is
    /// no longer than the model's depth; 1 unless the gain is material.
    fn routine_scale_estimate(&self) -> f64 {
        let moves = &self.routine.moves;
        let stats = self.graph.stats();
        if stats.states < 2 || moves.len() > stats.depth {
            return 1.0;
        }
        let hmm = Hmm::new(&self.graph);
        let sc = &self.config.predict.scale;
        let opts = PredictOptions {
            horizon: moves.len(),
            ..self.config.predict.clone()
        };
        let objective = |psi: f64| {
            let scaled: Vec<Observation> =
                moves.iter().map(|x| scale_translation(x, psi)).collect();
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
pub(super) mod tests {
    use super::*;
    use crate::engine::config::Profile;
    use nalgebra::UnitQuaternion;

    pub(super) fn pose(p: [f64; 3], yaw: f64) -> Pose {
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw);
        Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
    }

    /// A stitch pattern repeated along x: the same three moves again and again.
    pub(super) fn stitches(n: usize, at: f64) -> Vec<Pose> {
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

    pub(super) fn same_model(a: &Teacher, b: &Teacher) {
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
        for profile in [Profile::Dissertation, Profile::Default] {
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
        for profile in [Profile::Default, Profile::Dissertation] {
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
}
