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

use super::config::EngineConfig;
use super::error::ConfigError;
use super::hmm::Hmm;
use super::learner::{ModelStats, ObservationGraph};
use super::metric::Metric;
use super::pose::{Move, Observation, Pose, scale_translation};
use super::predict::{PredictOptions, Prediction, Withheld, predict_move};
use super::scale;

/// The engine for one work cell.
#[derive(Debug, Clone)]
pub struct Teacher {
    config: EngineConfig,
    graph: ObservationGraph,
    routine: Vec<Pose>,
    moves: Vec<Observation>,
    /// Moves of the current routine already assimilated (within-routine learning only).
    assimilated: usize,
}

impl Teacher {
    pub fn new(config: EngineConfig) -> Result<Teacher, ConfigError> {
        config.validate()?;
        let metric = Metric::diagonal(config.sigma_t, config.sigma_q)?;
        let graph = ObservationGraph::new(metric, config.delta, config.merge)?
            .with_recency(config.recency)?;
        Ok(Teacher {
            config,
            graph,
            routine: Vec::new(),
            moves: Vec::new(),
            assimilated: 0,
        })
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

    /// Appends a taught waypoint to the current routine.
    pub fn teach(&mut self, pose: Pose) {
        if let Some(last) = self.routine.last() {
            self.moves.push(Move::between(last, &pose).observation());
        }
        self.routine.push(pose);
        if self.config.learn_within_routine {
            let settled = self.moves.len().saturating_sub(self.config.within_lag());
            while self.assimilated < settled {
                self.graph.push(&self.moves[self.assimilated]);
                self.assimilated += 1;
            }
        }
    }

    /// Predicts the next waypoint of the current routine with the cell's settings.
    pub fn predict(&self) -> Prediction {
        self.predict_with(&PredictOptions::from_config(&self.config))
    }

    /// Predicts with per-request settings.
    pub fn predict_with(&self, opts: &PredictOptions) -> Prediction {
        let Some(last) = self.routine.last() else {
            return Prediction::withheld(Withheld::NothingTaught, self.graph.nodes().len());
        };
        predict_move(&self.graph, &self.moves, opts).place(last)
    }

    /// Finishes the current routine and learns it. A routine of fewer than two waypoints has no
    /// move and teaches nothing.
    pub fn finish_routine(&mut self) {
        if self.config.learn_within_routine {
            for x in &self.moves[self.assimilated..] {
                self.graph.push(x);
            }
        } else if !self.moves.is_empty() {
            let psi = if self.config.scale.learn_scaled {
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
    }

    /// Learn-Scaled-HMM: ψ of the finished routine against the current model, when the routine is
    /// no longer than the model's depth; 1 unless the gain is material.
    fn routine_scale_estimate(&self) -> f64 {
        let stats = self.graph.stats();
        if stats.states < 2 || self.moves.len() > stats.depth {
            return 1.0;
        }
        let hmm = Hmm::new(&self.graph);
        let sc = &self.config.scale;
        let opts = PredictOptions {
            horizon: self.moves.len(),
            ..PredictOptions::from_config(&self.config)
        };
        let objective = |psi: f64| {
            let scaled: Vec<Observation> = self
                .moves
                .iter()
                .map(|x| scale_translation(x, psi))
                .collect();
            super::predict::window_log_likelihood(&hmm, &scaled, &opts)
        };
        let base = objective(1.0);
        match scale::maximise(sc.psi_min, sc.psi_max, objective) {
            Some(est) if est.objective - base >= sc.min_gain => est.psi,
            _ => 1.0,
        }
    }
}
