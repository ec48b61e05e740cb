//! Engine settings and the named profiles.
//!
//! Two profiles exist. `seed` ([`Profile::Dissertation`]) is the dissertation's engine as
//! specified in ALGORITHM.md: the total-scatter merge test, learning from finished routines
//! only, and φ as the only gate. It is kept so the comparison with the improved engine stays
//! reproducible. `default` is the combination that measured best on the shared corpus
//! (docs/results/scoreboard.md, "What each option is worth").

use std::str::FromStr;

use serde::ser::SerializeStruct;
use serde::{Deserialize, Serialize, Serializer};

use super::error::ConfigError;
use super::experts::frames::Tolerance;
use super::experts::noise::Noise;

/// How the learner decides that a move joins an existing node (ALGORITHM §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MergeRule {
    /// Seed: join the node minimising `μ(V ∪ {x})` when that total scatter is `≤ ε`.
    /// Large nodes stop accepting points because their scatter only grows.
    Total,
    /// Join the node minimising the scatter increase `μ(V ∪ {x}) − μ(V)` when it is `≤ ε`.
    Incremental,
}

/// Prior over states for a window that does not start at the routine's first move.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowPrior {
    /// `ξ_i / Σ ξ`: states weighted by how often they were seen.
    Occupancy,
    /// Every state equally likely.
    Uniform,
}

/// Scale estimation (ALGORITHM §4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScaleConfig {
    /// Estimate ψ at prediction time.
    pub enabled: bool,
    /// Bracket for ψ (ψ maps the taught window onto the model: a 2× copy gives ψ = 0.5).
    pub psi_min: f64,
    pub psi_max: f64,
    /// Minimum gain in window log-likelihood (nats) before ψ ≠ 1 is accepted.
    pub min_gain: f64,
    /// Learn-Scaled-HMM: estimate a finished routine's ψ and assimilate the scaled moves.
    /// Only applies when routines are learned as a whole (`learn_within_routine = false`).
    pub learn_scaled: bool,
}

/// Every setting of the engine for one work cell: the learner's, the prediction options
/// ([`PredictOptions`], which a request may change for itself), and the experts' offer rule.
///
/// Serialised flat, in the order reports have always printed it (see the `Serialize` impl).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EngineConfig {
    /// Complexity δ ∈ (0, 1]: ε = F⁻¹_{χ²(7)}(1 − δ). Larger δ → stricter merging, more states.
    pub delta: f64,
    /// Translation repeatability σ_t (mm); precision `1/σ_t²` on translation components.
    pub sigma_t: f64,
    /// Quaternion-component repeatability σ_q; precision `1/σ_q²` on quaternion components.
    pub sigma_q: f64,
    pub merge: MergeRule,
    /// Assimilate each taught move as it arrives (the finished routine is then not counted
    /// twice). When false, a routine is learned only once it is finished (the dissertation's).
    pub learn_within_routine: bool,
    /// Within-routine learning assimilates a taught move once this many newer moves exist
    /// (None: `horizon`). With a lag shorter than the window, the predictor discounts the
    /// window's own transitions, so a window never counts as evidence for itself.
    pub within_lag: Option<usize>,
    /// What a prediction conditions on and the gates it must pass.
    #[serde(flatten)]
    pub predict: PredictOptions,
    /// Recency weighting of transitions λ ∈ (0, 1]: each new outcome of a state multiplies the
    /// weight of its older outcomes by λ. 1 = plain counts (the dissertation's).
    pub recency: f64,
    /// The experts' offer rule: every expert (the model above, and the tool-frame, work-frame
    /// and absolute-pose sequence experts) proposes a candidate, each gets `p_useful` from the
    /// cell's calibration, and the likeliest is offered when it reaches the threshold. None:
    /// the model alone with its own gates (the dissertation's).
    #[serde(default)]
    pub offer: Option<OfferRule>,
    /// The cell's teaching noise (one sigma per axis of a taught waypoint). The experts match
    /// contexts within the offer rule's tolerance widened by it ([`super::experts::noise`]).
    /// None: learned from the repeats in what the cell is taught
    /// ([`super::experts::noise::estimate`]); exact until they show otherwise.
    #[serde(default)]
    pub noise: Option<Noise>,
}

/// By hand, to keep the one flat JSON object that replay reports have always echoed, key for key
/// and in the same order: `recency`, a learning setting, sits between `backoff_min_support` and
/// `recall`, where `#[serde(flatten)]` of [`PredictOptions`] cannot put it. (Reading back is
/// derived, with `flatten`: key order does not matter there, and unknown keys are ignored as
/// before.)
impl Serialize for EngineConfig {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let p = &self.predict;
        let mut s = serializer.serialize_struct("EngineConfig", 20)?;
        s.serialize_field("delta", &self.delta)?;
        s.serialize_field("sigma_t", &self.sigma_t)?;
        s.serialize_field("sigma_q", &self.sigma_q)?;
        s.serialize_field("merge", &self.merge)?;
        s.serialize_field("learn_within_routine", &self.learn_within_routine)?;
        s.serialize_field("within_lag", &self.within_lag)?;
        s.serialize_field("horizon", &p.horizon)?;
        s.serialize_field("window_prior", &p.window_prior)?;
        s.serialize_field("phi_min", &p.phi_min)?;
        s.serialize_field("max_misfit", &p.max_misfit)?;
        s.serialize_field("max_spread", &p.max_spread)?;
        s.serialize_field("max_end_prob", &p.max_end_prob)?;
        s.serialize_field("match_radius", &p.match_radius)?;
        s.serialize_field("backoff", &p.backoff)?;
        s.serialize_field("backoff_min_support", &p.backoff_min_support)?;
        s.serialize_field("recency", &self.recency)?;
        s.serialize_field("recall", &p.recall)?;
        s.serialize_field("scale", &p.scale)?;
        s.serialize_field("offer", &self.offer)?;
        s.serialize_field("noise", &self.noise)?;
        s.end()
    }
}

/// The settings of one prediction: the cell's ([`EngineConfig::predict`]), or a copy a request
/// changed (a horizon or φ_min of its own).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct PredictOptions {
    /// Number of most recent moves the prediction conditions on (h).
    pub horizon: usize,
    pub window_prior: WindowPrior,
    /// Minimum confidence φ for a prediction to be offered.
    pub phi_min: f64,
    /// Match-quality gate: withhold when the window's mean squared Mahalanobis misfit to its
    /// most likely states exceeds this (None: no gate).
    pub max_misfit: Option<f64>,
    /// Spread gate: withhold when the expected squared Mahalanobis distance between the
    /// prediction and the moves that followed the matched states exceeds this (None: no gate).
    pub max_spread: Option<f64>,
    /// End-of-routine gate: withhold when the probability that the routine ends here (or that
    /// nothing is known about what follows) exceeds this (None: no gate).
    pub max_end_prob: Option<f64>,
    /// States farther than this (Mahalanobis distance, i.e. in σ units) from a window move are
    /// treated as not explaining it, which bounds the forward pass to nearby states (found with a
    /// k-d tree). None: every state takes part (the dissertation's).
    pub match_radius: Option<f64>,
    /// When the window matches nothing learned, retry with its last `h − 1` moves, down to one.
    pub backoff: bool,
    /// A backed-off window's proposal is offered only when the shortened context was followed by
    /// it at least this many times (`support`); one repetition of a one-move context is a guess.
    pub backoff_min_support: f64,
    /// Recall of the most recent occurrence: when the HMM's proposal is withheld as ambiguous
    /// (low φ, wide spread) or as little evidence, look up where the window's context (its states,
    /// all `k` moves) was seen before; if the most recent such place fits the window with a mean
    /// squared distance of at most `max_cost`, the window has at least `min_window` moves, and
    /// every earlier place found was followed by the same move, offer that move.
    /// None: off (the dissertation's).
    pub recall: Option<RecallGate>,
    pub scale: ScaleConfig,
}

/// When the experts' best candidate is offered (see [`EngineConfig::offer`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OfferRule {
    /// Offer when `p_useful` is at least this (0–1). None: an exact cell steers its own
    /// threshold so that its offers are right at the `target` rate
    /// ([`super::experts::calibration`], "The cell's threshold"); a cell whose noise matters
    /// offers from [`OfferRule::HEAD_START`].
    #[serde(default)]
    pub threshold: Option<f64>,
    /// The share of offers that should be right (0–1), when an exact cell steers its threshold.
    #[serde(default = "OfferRule::default_target")]
    pub target: f64,
    /// What counts as right: within this of the waypoint then taught (the calibration learns
    /// from it, and the sequence experts match contexts with it). None: learned, the dissertation's
    /// 1 mm / 0.1 rad until the cell's noise says its operator places less precisely
    /// ([`super::experts::noise::Noise::tolerance`]).
    #[serde(default)]
    pub tolerance: Option<Tolerance>,
}

impl OfferRule {
    /// The precision a cell's offers aim for by default.
    pub const TARGET: f64 = 0.85;

    /// The threshold of a cell whose noise matters (a joystick operator's), when none is set:
    /// a suggestion more likely right than not. Such a cell is not held to `target`: its near
    /// misses are head starts (fine-tuning from one is quicker than jogging the whole way, and a
    /// wrong one costs a look), so it offers by the time its operator saves. On the simulated
    /// lab (`nextpose lab --seed 1`, online operator, told the noise) p ≥ 0.5 cut programming
    /// time by 40.1 % with 68 % of offers taken as they were, where the 0.85 target offered 3
    /// suggestions in 88 sessions (docs/results/simulation.md).
    pub const HEAD_START: f64 = 0.5;

    fn default_target() -> f64 {
        OfferRule::TARGET
    }
}

impl Default for OfferRule {
    /// The cell's own threshold for 85 % right offers, and a learned tolerance.
    fn default() -> OfferRule {
        OfferRule {
            threshold: None,
            target: OfferRule::TARGET,
            tolerance: None,
        }
    }
}

/// When a recalled continuation is offered (see [`EngineConfig::recall`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RecallGate {
    /// Mean squared Mahalanobis distance of the window to the recalled context's states.
    pub max_cost: f64,
    /// Fewest window moves (after backoff) a recall may condition on.
    pub min_window: usize,
}

/// Engine profile: a named configuration. Its name on every wire and on the command line is
/// [`Profile::name`] (the serde names below are the same, checked by a test): the dissertation's
/// engine keeps the name `seed` it was published under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// The dissertation's engine (K. Dixon, 2004) as specified in ALGORITHM.md.
    #[serde(rename = "seed")]
    Dissertation,
    /// The best combination measured on the shared corpus.
    Default,
}

impl FromStr for Profile {
    type Err = ConfigError;
    fn from_str(s: &str) -> Result<Profile, ConfigError> {
        Profile::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| ConfigError::Profile(s.to_string()))
    }
}

impl Profile {
    /// Every profile.
    pub const ALL: [Profile; 2] = [Profile::Dissertation, Profile::Default];

    /// The profile's name on the wire (REST, gRPC's settings, stored cells, reports) and on the
    /// command line.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Dissertation => "seed",
            Profile::Default => "default",
        }
    }
}

impl Default for EngineConfig {
    fn default() -> Self {
        EngineConfig::profile(Profile::Default)
    }
}

impl EngineConfig {
    /// The settings of a named profile.
    pub fn profile(profile: Profile) -> EngineConfig {
        let dissertation = EngineConfig {
            delta: 0.7,
            sigma_t: 1.0,
            sigma_q: 0.01,
            merge: MergeRule::Total,
            learn_within_routine: false,
            within_lag: None,
            predict: PredictOptions {
                horizon: 3,
                window_prior: WindowPrior::Occupancy,
                phi_min: 0.7,
                max_misfit: None,
                max_spread: None,
                max_end_prob: None,
                match_radius: None,
                backoff: false,
                backoff_min_support: 2.0,
                recall: None,
                scale: ScaleConfig {
                    enabled: true,
                    psi_min: 0.2,
                    psi_max: 5.0,
                    min_gain: 2.0,
                    learn_scaled: false,
                },
            },
            recency: 1.0,
            offer: None,
            noise: Some(Noise::EXACT),
        };
        match profile {
            Profile::Dissertation => dissertation,
            Profile::Default => EngineConfig {
                merge: MergeRule::Incremental,
                learn_within_routine: true,
                within_lag: Some(0),
                predict: PredictOptions {
                    max_misfit: Some(1.0),
                    max_spread: Some(0.5),
                    max_end_prob: Some(0.5),
                    match_radius: Some(6.0),
                    backoff: true,
                    recall: Some(RecallGate {
                        max_cost: 0.1,
                        min_window: 2,
                    }),
                    ..dissertation.predict
                },
                offer: Some(OfferRule::default()),
                noise: None,
                ..dissertation
            },
        }
    }

    /// Moves of the routine being taught that are not assimilated yet (within-routine learning).
    pub fn within_lag(&self) -> usize {
        self.within_lag.unwrap_or(self.predict.horizon)
    }

    /// Checks every setting; the engine is only built from a validated configuration.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.delta > 0.0 && self.delta <= 1.0) {
            return Err(ConfigError::Delta(self.delta));
        }
        if !(0.0..=1.0).contains(&self.predict.phi_min) {
            return Err(ConfigError::PhiMin(self.predict.phi_min));
        }
        if !(self.recency > 0.0 && self.recency <= 1.0) {
            return Err(ConfigError::Threshold {
                name: "recency",
                value: self.recency,
            });
        }
        if self.predict.horizon == 0 {
            return Err(ConfigError::Horizon(self.predict.horizon));
        }
        if let Some(o) = &self.offer {
            // (name, value, largest allowed)
            for (name, value, max) in [
                ("offer.threshold", o.threshold, 1.0),
                ("offer.target", Some(o.target), 1.0),
                ("offer.tolerance.mm", o.tolerance.map(|t| t.mm), f64::MAX),
                ("offer.tolerance.rad", o.tolerance.map(|t| t.rad), f64::MAX),
            ] {
                if let Some(value) = value
                    && !(value.is_finite() && (0.0..=max).contains(&value))
                {
                    return Err(ConfigError::Threshold { name, value });
                }
            }
        }
        if let Some(noise) = self.noise
            && !noise.is_valid()
        {
            let (name, value) = if noise.mm.is_finite() && noise.mm >= 0.0 {
                ("noise.rad", noise.rad)
            } else {
                ("noise.mm", noise.mm)
            };
            return Err(ConfigError::Threshold { name, value });
        }
        for s in [self.sigma_t, self.sigma_q] {
            if !(s.is_finite() && s > 0.0) {
                return Err(ConfigError::Sigma(s));
            }
        }
        let sc = &self.predict.scale;
        if !(sc.psi_min.is_finite()
            && sc.psi_max.is_finite()
            && 0.0 < sc.psi_min
            && sc.psi_min < 1.0
            && sc.psi_max > 1.0)
        {
            return Err(ConfigError::ScaleBracket {
                min: sc.psi_min,
                max: sc.psi_max,
            });
        }
        let thresholds = [
            ("max_misfit", self.predict.max_misfit),
            ("max_spread", self.predict.max_spread),
            ("max_end_prob", self.predict.max_end_prob),
            ("match_radius", self.predict.match_radius),
            (
                "backoff_min_support",
                Some(self.predict.backoff_min_support),
            ),
            ("scale.min_gain", Some(sc.min_gain)),
            ("recall.max_cost", self.predict.recall.map(|r| r.max_cost)),
        ];
        for (name, value) in thresholds {
            if let Some(v) = value
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(ConfigError::Threshold { name, value: v });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_validate_and_parse() {
        for p in Profile::ALL {
            EngineConfig::profile(p).validate().unwrap();
            assert_eq!(p.name().parse::<Profile>().unwrap(), p);
            assert_eq!(serde_json::to_value(p).unwrap(), p.name());
        }
        assert_eq!(Profile::Dissertation.name(), "seed");
        assert!(matches!(
            "fast".parse::<Profile>(),
            Err(ConfigError::Profile(_))
        ));
    }

    #[test]
    fn invalid_settings_are_typed_errors() {
        let base = EngineConfig::default();
        type Check = fn(&ConfigError) -> bool;
        let cases: Vec<(EngineConfig, Check)> = vec![
            (
                EngineConfig {
                    delta: 0.0,
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::Delta(_)),
            ),
            (
                EngineConfig {
                    delta: f64::NAN,
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::Delta(_)),
            ),
            (
                EngineConfig {
                    predict: PredictOptions {
                        phi_min: 1.5,
                        ..base.predict.clone()
                    },
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::PhiMin(_)),
            ),
            (
                EngineConfig {
                    predict: PredictOptions {
                        horizon: 0,
                        ..base.predict.clone()
                    },
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::Horizon(_)),
            ),
            (
                EngineConfig {
                    sigma_t: -1.0,
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::Sigma(_)),
            ),
            (
                EngineConfig {
                    predict: PredictOptions {
                        max_misfit: Some(f64::INFINITY),
                        ..base.predict.clone()
                    },
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::Threshold { .. }),
            ),
        ];
        for (cfg, is_expected) in cases {
            let err = cfg.validate().unwrap_err();
            assert!(is_expected(&err), "{err}");
        }
        let mut bad_scale = base;
        bad_scale.predict.scale.psi_min = 2.0;
        assert!(matches!(
            bad_scale.validate(),
            Err(ConfigError::ScaleBracket { .. })
        ));
    }

    #[test]
    fn serialises_flat_in_the_reports_order_and_reads_back() {
        let keys = [
            "delta",
            "sigma_t",
            "sigma_q",
            "merge",
            "learn_within_routine",
            "within_lag",
            "horizon",
            "window_prior",
            "phi_min",
            "max_misfit",
            "max_spread",
            "max_end_prob",
            "match_radius",
            "backoff",
            "backoff_min_support",
            "recency",
            "recall",
            "scale",
            "offer",
            "noise",
        ];
        for p in Profile::ALL {
            let c = EngineConfig::profile(p);
            let json = serde_json::to_string(&c).unwrap();
            let at: Vec<usize> = keys
                .iter()
                .map(|k| json.find(&format!("\"{k}\":")).unwrap())
                .collect();
            assert!(at.windows(2).all(|w| w[0] < w[1]), "{json}");
            let top = serde_json::from_str::<serde_json::Map<String, serde_json::Value>>(&json);
            assert_eq!(top.unwrap().len(), keys.len());
            assert_eq!(serde_json::from_str::<EngineConfig>(&json).unwrap(), c);
        }
    }
}
