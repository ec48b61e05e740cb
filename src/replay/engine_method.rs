//! The engine under replay (placeholder until the engine lands: never offers anything).

use super::method::{Guess, Method, ModelSummary};
use crate::engine::{ConfigError, EngineConfig, Pose};

pub struct EngineMethod {
    config: EngineConfig,
}

impl EngineMethod {
    pub fn new(config: EngineConfig) -> Result<EngineMethod, ConfigError> {
        config.validate()?;
        Ok(EngineMethod { config })
    }

    pub fn config(&self) -> &EngineConfig {
        &self.config
    }
}

impl Method for EngineMethod {
    fn name(&self) -> &str {
        "engine"
    }
    fn reset(&mut self) {}
    fn predict(&mut self, _taught: &[Pose]) -> Option<Guess> {
        None
    }
    fn observe(&mut self, _taught: &[Pose]) {}
    fn finish_routine(&mut self, _routine: &[Pose]) {}
    fn summary(&self) -> Option<ModelSummary> {
        Some(ModelSummary::default())
    }
}
