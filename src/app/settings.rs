//! A cell's settings filled in and checked: defaults from the profile, the ranges and the
//! rules between settings, the settings stored with a cell. The wire form and the one list of
//! settings (with how each maps onto the engine) is [`crate::api::settings`]; cells store it
//! resolved, so a cell's behaviour does not change when a default does.

use super::error::AppError;
use crate::api::settings::ADDED_LATER;
use crate::api::{CellSettings, CellSettingsInput};
use crate::engine::{EngineConfig, Profile};
use crate::storage::CellRow;

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

impl CellSettingsInput {
    /// Fills in defaults and checks everything.
    pub fn resolve(self) -> Result<CellSettings, AppError> {
        let profile = self.profile.unwrap_or(Profile::Default);
        if EngineConfig::profile(profile).offer.is_none() {
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
        let settings = self.over_profile();
        settings.validate()?;
        Ok(settings)
    }
}

impl CellSettings {
    pub fn validate(&self) -> Result<(), AppError> {
        self.export
            .validate()
            .map_err(|e| AppError::Invalid(format!("export: {e}")))?;
        let noise = self.noise.unwrap_or(crate::engine::Noise::EXACT);
        let tolerance = self.tolerance.unwrap_or(crate::engine::Tolerance::USEFUL);
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
        if let Some(recall) = &self.recall
            && recall.min_window > MAX_HORIZON
        {
            return Err(AppError::Invalid(format!(
                "recall.min_window {} is above the largest horizon, {MAX_HORIZON}",
                recall.min_window
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

/// The settings stored with a cell. A cell stored before a setting existed reads the value its
/// engine used: its profile's ([`ADDED_LATER`]), or what the field's `serde` default says.
pub(crate) fn parse_settings(cell: &CellRow) -> Result<CellSettings, AppError> {
    let bad = |e: serde_json::Error| {
        AppError::Internal(format!("stored settings of cell {}: {e}", cell.id))
    };
    let mut stored: serde_json::Value = serde_json::from_str(&cell.settings).map_err(bad)?;
    if let Some(fields) = stored.as_object_mut()
        && ADDED_LATER.iter().any(|key| !fields.contains_key(*key))
    {
        let profile = match fields.get("profile") {
            Some(p) => Some(serde_json::from_value::<Profile>(p.clone()).map_err(bad)?),
            None => None,
        };
        let defaults = CellSettingsInput {
            profile,
            ..CellSettingsInput::default()
        }
        .over_profile();
        let defaults = serde_json::to_value(defaults).map_err(bad)?;
        for key in ADDED_LATER {
            if !fields.contains_key(key) {
                fields.insert(key.to_string(), defaults[key].clone());
            }
        }
    }
    serde_json::from_value(stored).map_err(bad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_come_from_the_profile_and_overrides_apply() {
        let s = CellSettingsInput::default().resolve().unwrap();
        assert_eq!(s.engine_config(), EngineConfig::profile(Profile::Default));
        let seed = CellSettingsInput {
            profile: Some(Profile::Dissertation),
            horizon: Some(2),
            ..Default::default()
        }
        .resolve()
        .unwrap();
        let mut want = EngineConfig::profile(Profile::Dissertation);
        want.predict.horizon = 2;
        assert_eq!(seed.engine_config(), want);
    }

    /// A cell stored before the command line's overrides were settings reads its profile's
    /// values for them (what its engine used), and its engine is the one it had.
    #[test]
    fn a_cell_stored_before_the_added_settings_reads_its_profiles() {
        let old = |profile: &str| CellRow {
            id: 1,
            name: "old".into(),
            settings: format!(
                r#"{{"profile":"{profile}","delta":0.7,"phi_min":0.7,"horizon":3,"sigma_t_mm":1.0,"sigma_q":0.01,"scale":{{"enabled":true,"psi_min":0.2,"psi_max":5.0}},"robot":"abb_irb140","base":{{"x":0.0,"y":0.0,"z":0.0,"qw":1.0,"qx":0.0,"qy":0.0,"qz":0.0}},"tool":{{"x":0.0,"y":0.0,"z":0.0,"qw":1.0,"qx":0.0,"qy":0.0,"qz":0.0}},"reach_policy":"flag","noise":null,"tolerance":null,"offer_threshold":null}}"#
            ),
            created_at: String::new(),
            model_version: 0,
            settings_changed_at: None,
            revision: 0,
            reload_revision: 0,
        };
        for profile in [Profile::Default, Profile::Dissertation] {
            let stored = parse_settings(&old(profile.name())).unwrap();
            let want = EngineConfig::profile(profile);
            let got = stored.engine_config();
            assert_eq!(got.merge, want.merge);
            assert_eq!(got.learn_within_routine, want.learn_within_routine);
            assert_eq!(got.predict, want.predict);
            // Stored as read, it reads back the same.
            let row = CellRow {
                settings: serde_json::to_string(&stored).unwrap(),
                ..old(profile.name())
            };
            assert_eq!(parse_settings(&row).unwrap(), stored);
        }
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
