//! `map`: the dissertation's comparison learner under replay (dissertation §3.9, §4.4.1). The
//! structure is learned by best-first MAP state merging ([`MapLearner`]); predictions are the
//! engine's own ([`predict_move`] over the learned graph with the run's prediction settings: the
//! forward recursion, the next-state mixture's mode, the φ gate and whatever else the profile turns
//! on). Under the `seed` profile the only difference from the engine is therefore the learner.
//!
//! Like the dissertation's engine, it learns a routine when the routine is finished (never within
//! it), from its unscaled moves (`scale.learn_scaled` and `learn_within_routine` do not apply).

use super::merge::{MapLearner, MapSettings};
use crate::engine::metric::Metric;
use crate::engine::{ConfigError, EngineConfig, Move, Observation, Pose, PredictOptions};
use crate::replay::method::{Guess, Method, ModelSummary};

pub struct MapMethod {
    config: EngineConfig,
    settings: MapSettings,
    opts: PredictOptions,
    learner: MapLearner,
    /// The current routine's moves so far.
    moves: Vec<Observation>,
}

impl MapMethod {
    pub fn new(config: EngineConfig, settings: MapSettings) -> Result<MapMethod, ConfigError> {
        config.validate()?;
        let learner = Self::new_learner(&config, settings)?;
        Ok(MapMethod {
            opts: config.predict.clone(),
            config,
            settings,
            learner,
            moves: Vec::new(),
        })
    }

    fn new_learner(
        config: &EngineConfig,
        settings: MapSettings,
    ) -> Result<MapLearner, ConfigError> {
        let metric = Metric::diagonal(config.sigma_t, config.sigma_q)?;
        MapLearner::new(metric, config.delta, settings)
    }

    /// The learner (its merges and graph).
    pub fn learner(&self) -> &MapLearner {
        &self.learner
    }

    /// The moves between consecutive waypoints.
    fn moves_of(poses: &[Pose]) -> Vec<Observation> {
        poses
            .windows(2)
            .map(|w| Move::between(&w[0], &w[1]).observation())
            .collect()
    }
}

impl Method for MapMethod {
    fn name(&self) -> &str {
        "map"
    }

    fn reset(&mut self) {
        // The settings were validated when this method was built.
        if let Ok(l) = Self::new_learner(&self.config, self.settings) {
            self.learner = l;
        }
        self.moves.clear();
    }

    fn predict(&mut self, taught: &[Pose]) -> Option<Guess> {
        let last = taught.last()?;
        if self.moves.len() + 1 != taught.len() {
            self.moves = Self::moves_of(taught);
        }
        let p = crate::engine::cdhmm::predict::predict_move(
            self.learner.graph(),
            &self.moves,
            &self.opts,
        )
        .placed_after(last);
        if !p.offered() {
            return None;
        }
        // As the engine without an offer rule: the misfit when it gates, else φ.
        let confidence = match (self.config.predict.max_misfit, p.misfit) {
            (Some(_), Some(m)) => -m,
            _ => p.phi,
        };
        p.pose.map(|pose| Guess {
            pose,
            confidence: Some(confidence),
            phi: Some(p.phi),
            psi: Some(p.psi),
        })
    }

    fn observe(&mut self, taught: &[Pose]) {
        match taught {
            [] | [_] => self.moves.clear(),
            [.., a, b] if self.moves.len() + 2 == taught.len() => {
                self.moves.push(Move::between(a, b).observation());
            }
            _ => self.moves = Self::moves_of(taught),
        }
    }

    fn finish_routine(&mut self, routine: &[Pose]) {
        self.learner.assimilate_routine(&Self::moves_of(routine));
        self.moves.clear();
    }

    fn summary(&self) -> Option<ModelSummary> {
        let s = self.learner.stats();
        Some(ModelSummary {
            states: s.states,
            edges: s.edges,
            perplexity: s.perplexity,
            observations: s.observations,
        })
    }
}
