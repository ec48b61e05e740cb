//! A calibration routine: the operator records one point several times, and its scatter
//! becomes the cell's teaching noise (the dissertation's §4.5.1), for those who would rather say it
//! than let the cell learn it from repeats.

use super::error::AppError;
use super::{App, Result};
use crate::api::{CalibrationRoutine, Cell, CellPatch, CellSettingsInput};
use crate::engine::{Noise, Pose};

/// The fewest poses a calibration takes: two give one difference, three a scatter.
pub const MIN_CALIBRATION_POSES: usize = 3;

impl App {
    /// Sets the cell's noise to the scatter of `routine`'s poses, as a settings change
    /// ([`App::edit_cell`]: validated, the model learned again, its version advanced).
    pub async fn calibrate(&self, id: i64, routine: CalibrationRoutine) -> Result<Cell> {
        if routine.poses.len() < MIN_CALIBRATION_POSES {
            return Err(AppError::Invalid(format!(
                "poses: a calibration records one point at least {MIN_CALIBRATION_POSES} times, got {}",
                routine.poses.len()
            )));
        }
        let poses = routine
            .poses
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.to_pose()
                    .map_err(|e| AppError::Invalid(format!("poses[{i}]: {e}")))
            })
            .collect::<Result<Vec<Pose>>>()?;
        let noise = Noise::from_scatter(&poses)
            .filter(Noise::is_valid)
            .ok_or_else(|| AppError::Invalid("poses: no scatter can be computed".into()))?;
        let patch = CellPatch {
            name: None,
            settings: Some(CellSettingsInput {
                noise: Some(noise),
                ..CellSettingsInput::default()
            }),
        };
        self.edit_cell(id, patch).await
    }
}
