//! Replaying uploaded files or a cell's stored programs through the engine and the baselines:
//! the scoreboard of `nextpose replay` (the same function), served.

use super::cell_model;
use super::error::AppError;
use super::registry::blocking;
use super::settings::MAX_HORIZON;
use super::{App, Result};
use crate::api::{CellSettingsInput, ReplayRequest, ScaleSettings};

impl App {
    /// Replays programs (uploaded files or a cell's stored programs) through the engine and
    /// every baseline, each program learned from scratch, with the oracle bounds and the
    /// engine's calibration: the scoreboard of `nextpose replay` (the same function,
    /// [`crate::replay::report::scoreboard`]; serialised, the JSON form of `nextpose replay
    /// --json`).
    pub async fn replay(&self, input: ReplayRequest) -> Result<crate::replay::report::Report> {
        use crate::replay::corpus::{Program as ReplayProgram, Routine as ReplayRoutine};
        use crate::replay::methods::baselines;
        use crate::replay::report::{ScoreboardError, scoreboard};

        let profile = input.profile.unwrap_or(crate::engine::Profile::Default);
        if input.horizon.is_some_and(|v| v > MAX_HORIZON) {
            return Err(AppError::Invalid(format!(
                "horizon must be between 1 and {MAX_HORIZON}"
            )));
        }
        let mut config = crate::engine::EngineConfig::profile(profile);
        CellSettingsInput {
            profile: Some(profile),
            delta: input.delta,
            phi_min: input.phi_min,
            horizon: input.horizon,
            scale: input.scale.map(|on| ScaleSettings::switched(profile, on)),
            ..CellSettingsInput::default()
        }
        .apply(&mut config);
        config.validate()?;
        let programs: Vec<ReplayProgram> = match (&input.files, input.cell_id) {
            (Some(files), None) if !files.is_empty() => {
                let files: Vec<(&str, &str)> = files
                    .iter()
                    .map(|f| (f.name.as_str(), f.content.as_str()))
                    .collect();
                crate::replay::corpus::import_upload(&files)?
            }
            (None, Some(cell)) => {
                self.cell_row(cell).await?;
                let mut out = Vec::new();
                for p in self.store.programs(cell).await? {
                    let mut routines = Vec::new();
                    for r in self.store.routines(p.id).await? {
                        let mut waypoints = Vec::new();
                        for w in self.store.waypoints(r.id).await? {
                            waypoints.push(cell_model::stored_pose(&w)?);
                        }
                        routines.push(ReplayRoutine {
                            name: r.name.unwrap_or_else(|| format!("routine {}", r.position)),
                            waypoints,
                        });
                    }
                    out.push(ReplayProgram::stored(p.name, cell, routines));
                }
                out
            }
            _ => {
                return Err(AppError::Invalid(
                    "give either non-empty `files` or `cell_id`".into(),
                ));
            }
        };
        let gate = baselines::DEFAULT_NEAREST_SEQ_GATE;
        let profile_name = profile.name();
        // The replay is CPU work (seconds for a large corpus): off the async workers. The
        // scoreboard is `nextpose replay`'s, from the same function.
        blocking(move || -> Result<_> {
            scoreboard(&programs, profile_name, &config, gate).map_err(|e| match e {
                ScoreboardError::Settings(e) => AppError::from(e),
                ScoreboardError::Arm(e) => {
                    AppError::Internal(format!("the replay's arm model: {e}"))
                }
            })
        })
        .await?
    }
}
