//! A cell's settings filled in and checked: defaults from the profile, a change laid over the
//! settings a cell has, the engine configuration they describe. The wire form is
//! [`crate::api::settings`]; cells store it resolved, so a cell's behaviour does not change when
//! a default does.

use super::error::AppError;
use crate::api::{CellSettings, CellSettingsInput, PoseValues, ScaleSettings};
use crate::engine::{EngineConfig, Pose, Profile};
use crate::storage::CellRow;

/// Robot model a new cell uses when none is named.
pub const DEFAULT_ROBOT: &str = "abb_irb140";

/// Largest horizon a cell or a request may ask for.
pub const MAX_HORIZON: usize = 50;
/// Translation repeatability σ_t a cell may have (mm): a micrometre to a metre. Outside it the
/// precision matrix over- or underflows and the cell could not be used.
pub const SIGMA_T_MM: std::ops::RangeInclusive<f64> = 1e-3..=1e3;
/// Quaternion-component repeatability σ_q a cell may have (a component lies in [-1, 1]).
pub const SIGMA_Q: std::ops::RangeInclusive<f64> = 1e-6..=1.0;

/// Most teaching noise a cell may have: 100 mm and 0.5 rad per axis (beyond that nothing taught
/// is a repeat of anything).
pub const NOISE_MM_MAX: f64 = 100.0;
pub const NOISE_RAD_MAX: f64 = 0.5;

fn identity() -> PoseValues {
    (&Pose::identity()).into()
}

impl CellSettingsInput {
    /// Fills in defaults and checks everything.
    pub fn resolve(self) -> Result<CellSettings, AppError> {
        let profile = self.profile.unwrap_or(Profile::Default);
        let base = EngineConfig::profile(profile);
        let settings = CellSettings {
            profile,
            delta: self.delta.unwrap_or(base.delta),
            phi_min: self.phi_min.unwrap_or(base.predict.phi_min),
            horizon: self.horizon.unwrap_or(base.predict.horizon),
            sigma_t_mm: self.sigma_t_mm.unwrap_or(base.sigma_t),
            sigma_q: self.sigma_q.unwrap_or(base.sigma_q),
            scale: self.scale.unwrap_or(ScaleSettings {
                enabled: base.predict.scale.enabled,
                psi_min: base.predict.scale.psi_min,
                psi_max: base.predict.scale.psi_max,
            }),
            robot: self.robot.unwrap_or_else(|| DEFAULT_ROBOT.to_string()),
            base: self.base.unwrap_or_else(identity),
            tool: self.tool.unwrap_or_else(identity),
            reach_policy: self.reach_policy.unwrap_or_default(),
            noise: self.noise.or(base.noise),
            tolerance: self.tolerance.or(base.offer.and_then(|o| o.tolerance)),
            offer_threshold: self
                .offer_threshold
                .or(base.offer.and_then(|o| o.threshold)),
            target_precision: self
                .target_precision
                .or(base.offer.map(|o| o.target))
                .unwrap_or(crate::engine::OfferRule::TARGET),
            export: self.export.unwrap_or_default(),
        };
        if base.offer.is_none() {
            for (name, given) in [
                ("offer_threshold", self.offer_threshold.is_some()),
                ("target_precision", self.target_precision.is_some()),
            ] {
                if given {
                    return Err(AppError::Invalid(format!(
                        "{name}: the {} profile has no offer rule",
                        profile.name()
                    )));
                }
            }
        }
        settings.validate()?;
        Ok(settings)
    }
}

impl CellSettingsInput {
    /// `self`'s fields over `base`'s: a partial change of settings. A new profile brings its
    /// own engine values (δ, φ_min, horizon, σ, scale, offer threshold and target) for the fields not
    /// given; the robot, frames, reach policy, noise, tolerance and export keep theirs.
    pub fn over(self, base: CellSettingsInput) -> CellSettingsInput {
        let new_profile = self.profile.is_some_and(|p| Some(p) != base.profile);
        let keep = |v| if new_profile { None } else { v };
        CellSettingsInput {
            profile: self.profile.or(base.profile),
            delta: self.delta.or(keep(base.delta)),
            phi_min: self.phi_min.or(keep(base.phi_min)),
            horizon: self
                .horizon
                .or(if new_profile { None } else { base.horizon }),
            sigma_t_mm: self.sigma_t_mm.or(keep(base.sigma_t_mm)),
            sigma_q: self.sigma_q.or(keep(base.sigma_q)),
            scale: self.scale.or(if new_profile { None } else { base.scale }),
            robot: self.robot.or(base.robot),
            base: self.base.or(base.base),
            tool: self.tool.or(base.tool),
            reach_policy: self.reach_policy.or(base.reach_policy),
            noise: self.noise.or(base.noise),
            tolerance: self.tolerance.or(base.tolerance),
            offer_threshold: self.offer_threshold.or(keep(base.offer_threshold)),
            target_precision: self.target_precision.or(keep(base.target_precision)),
            export: self.export.or(base.export),
        }
    }
}

impl CellSettings {
    /// These settings as an input that gives every field (what a change is laid over).
    pub fn as_input(&self) -> CellSettingsInput {
        CellSettingsInput {
            profile: Some(self.profile),
            delta: Some(self.delta),
            phi_min: Some(self.phi_min),
            horizon: Some(self.horizon),
            sigma_t_mm: Some(self.sigma_t_mm),
            sigma_q: Some(self.sigma_q),
            scale: Some(self.scale),
            robot: Some(self.robot.clone()),
            base: Some(self.base),
            tool: Some(self.tool),
            reach_policy: Some(self.reach_policy),
            noise: self.noise,
            tolerance: self.tolerance,
            offer_threshold: self.offer_threshold,
            target_precision: Some(self.target_precision)
                .filter(|_| EngineConfig::profile(self.profile).offer.is_some()),
            export: Some(self.export.clone()),
        }
    }

    /// The engine configuration these settings describe.
    pub fn engine_config(&self) -> EngineConfig {
        let mut c = EngineConfig::profile(self.profile);
        c.delta = self.delta;
        c.predict.phi_min = self.phi_min;
        c.predict.horizon = self.horizon;
        c.sigma_t = self.sigma_t_mm;
        c.sigma_q = self.sigma_q;
        c.predict.scale.enabled = self.scale.enabled;
        c.predict.scale.psi_min = self.scale.psi_min;
        c.predict.scale.psi_max = self.scale.psi_max;
        c.noise = self.noise;
        if let Some(o) = c.offer.as_mut() {
            o.tolerance = self.tolerance;
            o.threshold = self.offer_threshold;
            o.target = self.target_precision;
        }
        c
    }

    pub fn validate(&self) -> Result<(), AppError> {
        self.export
            .validate()
            .map_err(|e| AppError::Invalid(format!("export: {e}")))?;
        let noise = self.noise.unwrap_or(crate::engine::Noise::EXACT);
        let tolerance = self.tolerance.unwrap_or(crate::engine::Tolerance::SEED);
        for (name, value) in [
            ("noise.mm", noise.mm),
            ("noise.rad", noise.rad),
            ("tolerance.mm", tolerance.mm),
            ("tolerance.rad", tolerance.rad),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(AppError::Invalid(format!(
                    "{name} = {value} must be finite and not negative"
                )));
            }
        }
        for (name, value) in [
            ("offer_threshold", self.offer_threshold),
            ("target_precision", Some(self.target_precision)),
        ] {
            if let Some(v) = value
                && !(0.0..=1.0).contains(&v)
            {
                return Err(AppError::Invalid(format!("{name} = {v} is outside 0 to 1")));
            }
        }
        if noise.mm > NOISE_MM_MAX || noise.rad > NOISE_RAD_MAX {
            return Err(AppError::Invalid(format!(
                "noise {} mm / {} rad is above the most a cell may have ({NOISE_MM_MAX} mm, {NOISE_RAD_MAX} rad)",
                noise.mm, noise.rad
            )));
        }
        self.engine_config().validate()?;
        for (name, value, range) in [
            ("sigma_t_mm", self.sigma_t_mm, SIGMA_T_MM),
            ("sigma_q", self.sigma_q, SIGMA_Q),
        ] {
            if !range.contains(&value) {
                return Err(AppError::Invalid(format!(
                    "{name} = {value} is outside {} to {}",
                    range.start(),
                    range.end()
                )));
            }
        }
        if self.horizon > MAX_HORIZON {
            return Err(AppError::Invalid(format!(
                "horizon {} is above the maximum of {MAX_HORIZON}",
                self.horizon
            )));
        }
        if self.robot.trim().is_empty() {
            return Err(AppError::Invalid("robot must not be empty".into()));
        }
        self.base.to_pose()?;
        self.tool.to_pose()?;
        // Whatever passes must give a working model (as creating a routine will build it).
        crate::engine::Teacher::new(self.engine_config())?;
        Ok(())
    }
}

/// The settings stored with a cell.
pub(crate) fn parse_settings(cell: &CellRow) -> Result<CellSettings, AppError> {
    serde_json::from_str(&cell.settings)
        .map_err(|e| AppError::Internal(format!("stored settings of cell {}: {e}", cell.id)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_come_from_the_profile_and_overrides_apply() {
        let s = CellSettingsInput::default().resolve().unwrap();
        assert_eq!(s.engine_config(), EngineConfig::profile(Profile::Default));
        let seed = CellSettingsInput {
            profile: Some(Profile::Seed),
            horizon: Some(2),
            ..Default::default()
        }
        .resolve()
        .unwrap();
        let mut want = EngineConfig::profile(Profile::Seed);
        want.predict.horizon = 2;
        assert_eq!(seed.engine_config(), want);
    }

    #[test]
    fn bad_settings_are_refused() {
        for input in [
            CellSettingsInput {
                delta: Some(1.5),
                ..Default::default()
            },
            CellSettingsInput {
                horizon: Some(0),
                ..Default::default()
            },
            CellSettingsInput {
                horizon: Some(500),
                ..Default::default()
            },
            CellSettingsInput {
                sigma_t_mm: Some(-1.0),
                ..Default::default()
            },
            CellSettingsInput {
                robot: Some(" ".into()),
                ..Default::default()
            },
            // Each made a cell that answered 422 to everything afterwards.
            CellSettingsInput {
                sigma_t_mm: Some(1e300),
                ..Default::default()
            },
            CellSettingsInput {
                sigma_t_mm: Some(1e-300),
                ..Default::default()
            },
            CellSettingsInput {
                sigma_q: Some(1e300),
                ..Default::default()
            },
            CellSettingsInput {
                sigma_q: Some(1e-300),
                ..Default::default()
            },
        ] {
            assert!(input.resolve().is_err());
        }
    }
}
