//! The engine under replay: a [`Teacher`] per program, driven waypoint by waypoint.

use crate::engine::{ConfigError, EngineConfig, Pose, Teacher};
use crate::replay::method::{Candidate, Guess, Method, ModelSummary, Proposal};

pub struct EngineMethod {
    config: EngineConfig,
    teacher: Teacher,
}

impl EngineMethod {
    pub fn new(config: EngineConfig) -> Result<EngineMethod, ConfigError> {
        let teacher = Teacher::new(config.clone())?;
        Ok(EngineMethod { config, teacher })
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }
}

impl Method for EngineMethod {
    fn name(&self) -> &str {
        "engine"
    }

    fn reset(&mut self) {
        // The configuration was validated when this method was built.
        if let Ok(t) = Teacher::new(self.config.clone()) {
            self.teacher = t;
        }
    }

    fn predict(&mut self, taught: &[Pose]) -> Option<Guess> {
        self.propose(taught).guess
    }

    /// The offered guess, and with the experts' offer rule the best candidate with its
    /// `p_useful` whether offered or not (withheld, the prediction's pose is that candidate's).
    fn propose(&mut self, taught: &[Pose]) -> Proposal {
        debug_assert_eq!(taught.len(), self.teacher.routine().len());
        let p = self.teacher.predict();
        let candidate = match (p.pose, p.p_useful) {
            (Some(pose), Some(p_useful)) => Some(Candidate { pose, p_useful }),
            _ => None,
        };
        if !p.offered() {
            return Proposal {
                guess: None,
                candidate,
            };
        }
        // With the experts' offer rule the confidence is p_useful; otherwise the gate that
        // decides most often: the match misfit (negated: higher = more sure), else φ.
        let confidence = match (p.p_useful, self.config.predict.max_misfit, p.misfit) {
            (Some(u), _, _) => u,
            (None, Some(_), Some(m)) => -m,
            _ => p.phi,
        };
        let guess = p.pose.map(|pose| Guess {
            pose,
            confidence: Some(confidence),
            phi: Some(p.phi),
            psi: Some(p.psi),
        });
        Proposal { guess, candidate }
    }

    fn observe(&mut self, taught: &[Pose]) {
        if let Some(last) = taught.last() {
            self.teacher.teach(*last);
        }
    }

    fn finish_routine(&mut self, _routine: &[Pose]) {
        self.teacher.finish_routine();
    }

    fn summary(&self) -> Option<ModelSummary> {
        let s = self.teacher.stats();
        Some(ModelSummary {
            states: s.states,
            edges: s.edges,
            perplexity: s.perplexity,
            observations: s.observations,
        })
    }
}
