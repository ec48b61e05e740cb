//! A cell's settings as clients give and see them: the engine's (a named profile with
//! overrides), the robot model and its frames, the teaching noise and tolerance, and what exported
//! programs carry. The service fills in and checks them (`app::settings`) and stores them
//! resolved, so a cell's behaviour does not change when a default does.
//!
//! Every setting is declared once, in the list of [`settings!`] below: its name (the same on
//! REST, gRPC, the command line and in the stored cell), its type as set and as resolved, its
//! docs and declared range, the profile's value it defaults to, whether a new profile brings its
//! own, and where it goes in the [`EngineConfig`]. From that one list come both wire types
//! ([`CellSettings`], resolved, and [`CellSettingsInput`], every field optional) and the four
//! mappings between them and the engine: filling in the profile's values
//! ([`CellSettingsInput::over_profile`]), a change laid over a cell's settings
//! ([`CellSettingsInput::over`]), settings as the change that gives all of them
//! ([`CellSettings::as_input`]), and the engine configuration they describe
//! ([`CellSettings::engine_config`], and [`CellSettingsInput::apply`] for overrides alone, which
//! the command line and a replay use).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::PoseValues;
use super::present;
use crate::engine::Noise;
use crate::engine::Tolerance;
use crate::engine::config::{MergeRule, RecallGate};
use crate::engine::{EngineConfig, OfferRule, Pose, Profile};
use crate::export::ExportSettings;
use crate::kinematics::ReachPolicy;

/// Robot model a new cell uses when none is named.
pub const DEFAULT_ROBOT: &str = "abb_irb140";

/// Scale estimation settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ScaleSettings {
    pub enabled: bool,
    /// Bracket for ψ (0 < psi_min < 1 < psi_max).
    #[schema(exclusive_minimum = 0.0, exclusive_maximum = 1.0)]
    pub psi_min: f64,
    #[schema(exclusive_minimum = 1.0)]
    pub psi_max: f64,
}

impl ScaleSettings {
    /// The profile's bracket with estimation switched on or off (what the command line's and a
    /// replay's `scale` say).
    pub fn switched(profile: Profile, enabled: bool) -> ScaleSettings {
        let scale = EngineConfig::profile(profile).predict.scale;
        ScaleSettings {
            enabled,
            psi_min: scale.psi_min,
            psi_max: scale.psi_max,
        }
    }
}

/// How a field of [`CellSettingsInput`] (`Self`) stands for a resolved value `T`: given, or
/// left to the profile.
pub trait Given<T> {
    /// The value given, else `profile`'s.
    fn or_profile(self, profile: T) -> T;
    /// `value` given (what [`CellSettings::as_input`] writes).
    fn of(value: T) -> Self;
}

/// A setting given or left out (`null` or absent). A setting that is itself optional
/// (`max_misfit`: `null` is no gate) is `Option<Option<_>>` here, read with `present`, so that
/// `null` gives "none" and only an absent field is left to the profile.
impl<T> Given<T> for Option<T> {
    fn or_profile(self, profile: T) -> T {
        self.unwrap_or(profile)
    }
    fn of(value: T) -> Option<T> {
        Some(value)
    }
}

/// A setting whose `null` is left to the profile both as given and as resolved (`noise`,
/// `tolerance`, `offer_threshold`: null is "learned" or "steered", which a profile may also
/// choose): given or not, the two read the same.
impl<T> Given<Option<T>> for Option<T> {
    fn or_profile(self, profile: Option<T>) -> Option<T> {
        self.or(profile)
    }
    fn of(value: Option<T>) -> Option<T> {
        value
    }
}

/// Declares every setting once and derives the two wire types and the mappings from the list.
///
/// Each entry: the resolved field's docs; `given(…)`, the attributes of the field as given
/// (its docs and declared range; each becomes the OpenAPI schema's); `stored(…)`, the resolved
/// field's serde attributes (what a cell stored before the setting existed reads as); then
/// `name: Resolved as Given`, `profile` when a new profile brings its own value (else `kept`),
/// `default`: the value when not given, from the profile's engine configuration `$p`, and
/// `engine`: where the value `$v` goes in the engine configuration `$c` (left out for settings
/// outside the engine).
macro_rules! settings {
    (@keep profile, $new_profile:expr, $v:expr) => {
        if $new_profile { None } else { $v }
    };
    (@keep kept, $new_profile:expr, $v:expr) => {
        $v
    };
    ($(
        $(#[doc = $doc:literal])*
        given($($given:meta),* $(,)?)
        stored($($stored:meta),* $(,)?)
        $name:ident: $ty:ty as $input:ty, $keep:ident,
            default |$p:ident| $default:expr
            $(, engine |$c:ident, $v:ident| $engine:expr)?;
    )*) => {
        /// A cell's settings, resolved.
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
        #[serde(deny_unknown_fields)]
        pub struct CellSettings {
            pub profile: Profile,
            $(
                $(#[doc = $doc])*
                $(#[$stored])*
                pub $name: $ty,
            )*
        }

        /// Settings given when a cell is created; anything left out takes the profile's value.
        #[derive(Debug, Clone, Default, Serialize, Deserialize, ToSchema)]
        #[serde(deny_unknown_fields)]
        pub struct CellSettingsInput {
            pub profile: Option<Profile>,
            $(
                $(#[$given])*
                pub $name: $input,
            )*
        }

        impl CellSettingsInput {
            /// The settings given over the profile's (the default profile when none is named),
            /// unchecked (`app::settings` checks them).
            pub fn over_profile(self) -> CellSettings {
                let profile = self.profile.unwrap_or(Profile::Default);
                let config = EngineConfig::profile(profile);
                CellSettings {
                    profile,
                    $($name: {
                        let $p = &config;
                        <$input as Given<$ty>>::or_profile(self.$name, $default)
                    },)*
                }
            }

            /// `self`'s fields over `base`'s: a partial change of settings. A new profile
            /// brings its own engine values for the fields not given; the robot, frames, reach
            /// policy, noise, tolerance and export keep theirs.
            pub fn over(self, base: CellSettingsInput) -> CellSettingsInput {
                let new_profile = self.profile.is_some_and(|p| Some(p) != base.profile);
                CellSettingsInput {
                    profile: self.profile.or(base.profile),
                    $($name: self.$name.or(settings!(@keep $keep, new_profile, base.$name)),)*
                }
            }

            /// The settings given, applied to `config` (the command line's and a replay's
            /// overrides; nothing is checked).
            pub fn apply(&self, config: &mut EngineConfig) {
                $($(if self.$name.is_some() {
                    let value: $ty = {
                        let $p = &*config;
                        <$input as Given<$ty>>::or_profile(self.$name.clone(), $default)
                    };
                    let ($c, $v) = (&mut *config, &value);
                    $engine;
                })?)*
            }
        }

        impl CellSettings {
            /// These settings as an input that gives every field (what a change is laid over).
            pub fn as_input(&self) -> CellSettingsInput {
                let mut input = CellSettingsInput {
                    profile: Some(self.profile),
                    $($name: <$input as Given<$ty>>::of(self.$name.clone()),)*
                };
                // Not a setting of a profile without an offer rule.
                if EngineConfig::profile(self.profile).offer.is_none() {
                    input.target_precision = None;
                }
                input
            }

            /// The engine configuration these settings describe.
            pub fn engine_config(&self) -> EngineConfig {
                let mut config = EngineConfig::profile(self.profile);
                $($({
                    let $c: &mut EngineConfig = &mut config;
                    let $v: &$ty = &self.$name;
                    $engine;
                })?)*
                config
            }
        }

        /// The name of every setting, as on every wire and in the stored cell.
        pub const SETTINGS: &[&str] = &["profile", $(stringify!($name)),*];
    };
}

settings! {
    /// Complexity δ ∈ (0, 1]: larger → stricter merging, more states.
    given(doc = "Complexity δ ∈ (0, 1].", schema(exclusive_minimum = 0.0, maximum = 1.0))
    stored()
    delta: f64 as Option<f64>, profile,
        default |p| p.delta,
        engine |c, v| c.delta = *v;

    /// Minimum confidence φ ∈ [0, 1] for a prediction to be offered.
    given(doc = "Minimum confidence φ ∈ [0, 1].", schema(minimum = 0.0, maximum = 1.0))
    stored()
    phi_min: f64 as Option<f64>, profile,
        default |p| p.predict.phi_min,
        engine |c, v| c.predict.phi_min = *v;

    /// Moves a prediction conditions on (h, 1–50).
    given(doc = "Moves a prediction conditions on, 1 to 50.", schema(minimum = 1, maximum = 50))
    stored()
    horizon: usize as Option<usize>, profile,
        default |p| p.predict.horizon,
        engine |c, v| c.predict.horizon = *v;

    /// Translation repeatability σ_t (mm) of the precision matrix.
    given(
        doc = "Translation repeatability σ_t, 0.001 to 1000 mm.",
        schema(minimum = 0.001, maximum = 1000.0),
    )
    stored()
    sigma_t_mm: f64 as Option<f64>, profile,
        default |p| p.sigma_t,
        engine |c, v| c.sigma_t = *v;

    /// Quaternion-component repeatability σ_q of the precision matrix.
    given(
        doc = "Quaternion-component repeatability σ_q, 0.000001 to 1.",
        schema(minimum = 0.000001, maximum = 1.0),
    )
    stored()
    sigma_q: f64 as Option<f64>, profile,
        default |p| p.sigma_q,
        engine |c, v| c.sigma_q = *v;

    given()
    stored()
    scale: ScaleSettings as Option<ScaleSettings>, profile,
        default |p| ScaleSettings {
            enabled: p.predict.scale.enabled,
            psi_min: p.predict.scale.psi_min,
            psi_max: p.predict.scale.psi_max,
        },
        engine |c, v| {
            c.predict.scale.enabled = v.enabled;
            c.predict.scale.psi_min = v.psi_min;
            c.predict.scale.psi_max = v.psi_max;
        };

    /// Robot model (a URDF in `robots/`; `GET /v1/robots` lists them).
    given(
        doc = "A robot model's name (`GET /v1/robots` lists them).",
        schema(pattern = r"^[A-Za-z0-9_-]{1,64}$"),
    )
    stored()
    robot: String as Option<String>, kept,
        default |_p| DEFAULT_ROBOT.to_string();

    /// The robot base in the cell's work frame.
    given()
    stored()
    base: PoseValues as Option<PoseValues>, kept,
        default |_p| identity();

    /// The tool centre point in the flange frame.
    given()
    stored()
    tool: PoseValues as Option<PoseValues>, kept,
        default |_p| identity();

    /// Predictions the arm cannot reach: withheld (default) or offered flagged.
    given()
    stored()
    reach_policy: ReachPolicy as Option<ReachPolicy>, kept,
        default |_p| ReachPolicy::default();

    /// Teaching noise, one sigma per axis of a taught waypoint. Null (a new cell's default):
    /// learned from the repeats in what the cell is taught, exact until they show otherwise
    /// (the cell's stats give the estimate). Given: fixed (0 for exact, offline programs; for
    /// a joystick operator, the scatter of a calibration routine: one point recorded several
    /// times). The experts match within the tolerance widened by it. A cell stored before noise
    /// was a setting reads as exact.
    given()
    stored(serde(default = "exact_noise"))
    noise: Option<Noise> as Option<Noise>, kept,
        default |p| p.noise,
        engine |c, v| c.noise = *v;

    /// Acceptance tolerance: a suggestion this close to what is then taught counts as right.
    /// Null (a new cell's default): learned, the seed's 1 mm / 0.1 rad until the cell's noise
    /// says its operator places less precisely (half their effective target width). Given:
    /// fixed (a joystick cell's is the operator's "close enough"). The offer rule's
    /// calibration learns from it. A cell stored before tolerance was a setting reads as 1 mm /
    /// 0.1 rad.
    given()
    stored(serde(default = "useful_tolerance"))
    tolerance: Option<Tolerance> as Option<Tolerance>, kept,
        default |p| p.offer.and_then(|o| o.tolerance),
        engine |c, v| if let Some(o) = c.offer.as_mut() {
            o.tolerance = *v;
        };

    /// A fixed offer threshold: a suggestion is offered when its `p_useful` reaches it (0–1).
    /// Null: the cell steers its own threshold so that `target_precision` of its offers are
    /// right (the default profile), or the profile has no offer rule (seed).
    given(
        doc = "The cell's offer threshold on `p_useful`, 0 to 1 (left out: steered).",
        schema(minimum = 0.0, maximum = 1.0),
    )
    stored(serde(default))
    offer_threshold: Option<f64> as Option<f64>, profile,
        default |p| p.offer.and_then(|o| o.threshold),
        engine |c, v| if let Some(o) = c.offer.as_mut() {
            o.threshold = *v;
        };

    /// The share of offers that should be right (0–1, default 0.85) when the cell steers its
    /// own threshold. Unused with a fixed `offer_threshold` or without an offer rule.
    given(
        doc = "The precision the cell steers its threshold to, 0 to 1.",
        schema(minimum = 0.0, maximum = 1.0),
    )
    stored(serde(default = "target_precision"))
    target_precision: f64 as Option<f64>, profile,
        default |p| p.offer.map_or(OfferRule::TARGET, |o| o.target),
        engine |c, v| if let Some(o) = c.offer.as_mut() {
            o.target = *v;
        };

    /// Speed, zone, work object and tool written into exported controller programs.
    given()
    stored(serde(default))
    export: ExportSettings as Option<ExportSettings>, kept,
        default |_p| ExportSettings::default();

    /// The learner's merge test: `total` (the seed's: join the state whose total scatter with
    /// the move stays within ε) or `incremental` (join the one whose scatter grows least).
    given(doc = "The learner's merge test, `total` or `incremental`.")
    stored()
    merge: MergeRule as Option<MergeRule>, profile,
        default |p| p.merge,
        engine |c, v| c.merge = *v;

    /// Learn each move as it is taught (true) or only finished routines (false, the seed).
    given(doc = "Learn each move as it is taught (true) or only finished routines (false).")
    stored()
    learn_within_routine: bool as Option<bool>, profile,
        default |p| p.learn_within_routine,
        engine |c, v| c.learn_within_routine = *v;

    /// Match-quality gate: a prediction is withheld (`poor_match`) when the taught window's
    /// mean squared misfit to its likeliest states exceeds this. Null: no gate (the seed).
    given(
        doc = "The match-quality gate, at least 0; null: no gate (left out: the profile's).",
        serde(default, deserialize_with = "present", skip_serializing_if = "Option::is_none"),
        schema(value_type = Option<f64>, nullable, minimum = 0.0),
    )
    stored()
    max_misfit: Option<f64> as Option<Option<f64>>, profile,
        default |p| p.predict.max_misfit,
        engine |c, v| c.predict.max_misfit = *v;

    /// Spread gate: a prediction is withheld (`wide_spread`) when the expected squared distance
    /// between it and the moves that followed the matched states exceeds this. Null: no gate.
    given(
        doc = "The spread gate, at least 0; null: no gate (left out: the profile's).",
        serde(default, deserialize_with = "present", skip_serializing_if = "Option::is_none"),
        schema(value_type = Option<f64>, nullable, minimum = 0.0),
    )
    stored()
    max_spread: Option<f64> as Option<Option<f64>>, profile,
        default |p| p.predict.max_spread,
        engine |c, v| c.predict.max_spread = *v;

    /// End-of-routine gate: a prediction is withheld (`likely_end`) when the probability that
    /// the routine ends here exceeds this. Null: no gate.
    given(
        doc = "The end-of-routine gate, at least 0; null: no gate (left out: the profile's).",
        serde(default, deserialize_with = "present", skip_serializing_if = "Option::is_none"),
        schema(value_type = Option<f64>, nullable, minimum = 0.0),
    )
    stored()
    max_end_prob: Option<f64> as Option<Option<f64>>, profile,
        default |p| p.predict.max_end_prob,
        engine |c, v| c.predict.max_end_prob = *v;

    /// Recall of the most recent occurrence of the taught context, when the model's own
    /// proposal is withheld as ambiguous: offered when the window has at least `min_window`
    /// moves and fits that occurrence within `max_cost`. Null: off (the seed).
    given(
        doc = "Recall of the most recent occurrence; null: off (left out: the profile's).",
        serde(default, deserialize_with = "present", skip_serializing_if = "Option::is_none"),
        schema(value_type = Option<RecallGate>, nullable),
    )
    stored()
    recall: Option<RecallGate> as Option<Option<RecallGate>>, profile,
        default |p| p.predict.recall,
        engine |c, v| c.predict.recall = *v;
}

/// Settings added after cells were first stored: a cell stored before them reads its profile's
/// values, which its engine used.
pub const ADDED_LATER: [&str; 6] = [
    "merge",
    "learn_within_routine",
    "max_misfit",
    "max_spread",
    "max_end_prob",
    "recall",
];

fn identity() -> PoseValues {
    (&Pose::identity()).into()
}

fn exact_noise() -> Option<Noise> {
    Some(Noise::EXACT)
}

fn useful_tolerance() -> Option<Tolerance> {
    Some(Tolerance::USEFUL)
}

fn target_precision() -> f64 {
    OfferRule::TARGET
}
