//! Engine settings and the named profiles.
//!
//! Two profiles exist. `seed` is the dissertation's engine as specified in ALGORITHM.md: the
//! total-scatter merge test, learning from finished routines only, and φ as the only gate. It is
//! kept so the comparison with the improved engine stays reproducible. `default` is the
//! combination that measured best on the shared corpus (README, "Which options won").

use std::str::FromStr;

use serde::{Deserialize, Serialize};

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

/// Every setting of the engine for one work cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EngineConfig {
    /// Complexity δ ∈ (0, 1]: ε = F⁻¹_{χ²(7)}(1 − δ). Larger δ → stricter merging, more states.
    pub delta: f64,
    /// Translation repeatability σ_t (mm); precision `1/σ_t²` on translation components.
    pub sigma_t: f64,
    /// Quaternion-component repeatability σ_q; precision `1/σ_q²` on quaternion components.
    pub sigma_q: f64,
    pub merge: MergeRule,
    /// Assimilate each taught move as it arrives (the finished routine is then not counted
    /// twice). When false, a routine is learned only once it is finished (the seed).
    pub learn_within_routine: bool,
    /// Within-routine learning assimilates a taught move once this many newer moves exist
    /// (None: `horizon`). With a lag shorter than the window, the predictor discounts the
    /// window's own transitions, so a window never counts as evidence for itself.
    pub within_lag: Option<usize>,
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
    /// k-d tree). None: every state takes part (the seed).
    pub match_radius: Option<f64>,
    /// When the window matches nothing learned, retry with its last `h − 1` moves, down to one.
    pub backoff: bool,
    /// A backed-off window's proposal is offered only when the shortened context was followed by
    /// it at least this many times (`support`); one repetition of a one-move context is a guess.
    pub backoff_min_support: f64,
    /// Recency weighting of transitions λ ∈ (0, 1]: each new outcome of a state multiplies the
    /// weight of its older outcomes by λ. 1 = plain counts (the seed).
    pub recency: f64,
    /// Recall of the most recent occurrence: when the HMM's proposal is withheld as ambiguous
    /// (low φ, wide spread) or as little evidence, look up where the window's context (its states,
    /// all `k` moves) was seen before; if the most recent such place fits the window with a mean
    /// squared distance of at most `max_cost`, the window has at least `min_window` moves, and
    /// every earlier place found was followed by the same move, offer that move.
    /// None: off (the seed).
    pub recall: Option<RecallGate>,
    pub scale: ScaleConfig,
    /// The experts' offer rule: every expert (the model above, and the tool-frame, work-frame
    /// and absolute-pose sequence experts) proposes a candidate, each gets `p_useful` from the
    /// cell's calibration, and the likeliest is offered when it reaches the threshold. None:
    /// the model alone with its own gates (the seed).
    #[serde(default)]
    pub offer: Option<OfferRule>,
    /// The cell's teaching noise (one sigma per axis of a taught waypoint; exact by default).
    /// The experts match contexts within the offer rule's tolerance widened by it
    /// ([`super::experts::noise`]).
    #[serde(default)]
    pub noise: Noise,
}

/// Per-prediction settings (a cell's configuration, possibly overridden per request).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictOptions {
    pub horizon: usize,
    pub phi_min: f64,
    pub max_misfit: Option<f64>,
    pub max_spread: Option<f64>,
    pub max_end_prob: Option<f64>,
    pub match_radius: Option<f64>,
    pub backoff: bool,
    pub backoff_min_support: f64,
    pub recall: Option<RecallGate>,
    pub window_prior: WindowPrior,
    pub scale: ScaleConfig,
}

impl PredictOptions {
    pub fn from_config(c: &EngineConfig) -> PredictOptions {
        PredictOptions {
            horizon: c.horizon,
            phi_min: c.phi_min,
            max_misfit: c.max_misfit,
            max_spread: c.max_spread,
            max_end_prob: c.max_end_prob,
            match_radius: c.match_radius,
            backoff: c.backoff,
            backoff_min_support: c.backoff_min_support,
            recall: c.recall,
            window_prior: c.window_prior,
            scale: c.scale,
        }
    }
}

/// When the experts' best candidate is offered (see [`EngineConfig::offer`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OfferRule {
    /// Offer when `p_useful` is at least this (0–1).
    pub threshold: f64,
    /// What counts as right: within this of the waypoint then taught (the calibration learns
    /// from it, and the sequence experts match contexts with it).
    pub tolerance: Tolerance,
}

impl Default for OfferRule {
    /// Threshold 0.7 (≥ 90 % precision on the half of the corpus it was chosen on, with a
    /// margin; README), the seed's 1 mm / 0.1 rad.
    fn default() -> OfferRule {
        OfferRule {
            threshold: 0.7,
            tolerance: Tolerance::SEED,
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

/// Engine profile: a named configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// The dissertation's engine as specified in ALGORITHM.md.
    Seed,
    /// The best combination measured on the shared corpus.
    Default,
}

impl FromStr for Profile {
    type Err = ConfigError;
    fn from_str(s: &str) -> Result<Profile, ConfigError> {
        match s {
            "seed" => Ok(Profile::Seed),
            "default" => Ok(Profile::Default),
            other => Err(ConfigError::Profile(other.to_string())),
        }
    }
}

impl Profile {
    pub fn name(self) -> &'static str {
        match self {
            Profile::Seed => "seed",
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
        let seed = EngineConfig {
            delta: 0.7,
            sigma_t: 1.0,
            sigma_q: 0.01,
            merge: MergeRule::Total,
            learn_within_routine: false,
            within_lag: None,
            horizon: 3,
            window_prior: WindowPrior::Occupancy,
            phi_min: 0.7,
            max_misfit: None,
            max_spread: None,
            max_end_prob: None,
            match_radius: None,
            backoff: false,
            backoff_min_support: 2.0,
            recency: 1.0,
            recall: None,
            offer: None,
            noise: Noise::EXACT,
            scale: ScaleConfig {
                enabled: true,
                psi_min: 0.2,
                psi_max: 5.0,
                min_gain: 2.0,
                learn_scaled: false,
            },
        };
        match profile {
            Profile::Seed => seed,
            Profile::Default => EngineConfig {
                merge: MergeRule::Incremental,
                learn_within_routine: true,
                within_lag: Some(0),
                max_misfit: Some(1.0),
                max_spread: Some(0.5),
                max_end_prob: Some(0.5),
                match_radius: Some(6.0),
                backoff: true,
                recall: Some(RecallGate {
                    max_cost: 0.1,
                    min_window: 2,
                }),
                offer: Some(OfferRule::default()),
                ..seed
            },
        }
    }

    /// Moves of the routine being taught that are not assimilated yet (within-routine learning).
    pub fn within_lag(&self) -> usize {
        self.within_lag.unwrap_or(self.horizon)
    }

    /// Checks every setting; the engine is only built from a validated configuration.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.delta > 0.0 && self.delta <= 1.0) {
            return Err(ConfigError::Delta(self.delta));
        }
        if !(0.0..=1.0).contains(&self.phi_min) {
            return Err(ConfigError::PhiMin(self.phi_min));
        }
        if !(self.recency > 0.0 && self.recency <= 1.0) {
            return Err(ConfigError::Threshold {
                name: "recency",
                value: self.recency,
            });
        }
        if self.horizon == 0 {
            return Err(ConfigError::Horizon(self.horizon));
        }
        if let Some(o) = &self.offer {
            for (name, value) in [
                ("offer.threshold", o.threshold),
                ("offer.tolerance.mm", o.tolerance.mm),
                ("offer.tolerance.rad", o.tolerance.rad),
            ] {
                if !(value.is_finite() && value >= 0.0)
                    || (name == "offer.threshold" && value > 1.0)
                {
                    return Err(ConfigError::Threshold { name, value });
                }
            }
        }
        if !self.noise.is_valid() {
            let (name, value) = if self.noise.mm.is_finite() && self.noise.mm >= 0.0 {
                ("noise.rad", self.noise.rad)
            } else {
                ("noise.mm", self.noise.mm)
            };
            return Err(ConfigError::Threshold { name, value });
        }
        for s in [self.sigma_t, self.sigma_q] {
            if !(s.is_finite() && s > 0.0) {
                return Err(ConfigError::Sigma(s));
            }
        }
        let sc = &self.scale;
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
            ("max_misfit", self.max_misfit),
            ("max_spread", self.max_spread),
            ("max_end_prob", self.max_end_prob),
            ("match_radius", self.match_radius),
            ("backoff_min_support", Some(self.backoff_min_support)),
            ("scale.min_gain", Some(sc.min_gain)),
            ("recall.max_cost", self.recall.map(|r| r.max_cost)),
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
        for p in [Profile::Seed, Profile::Default] {
            EngineConfig::profile(p).validate().unwrap();
            assert_eq!(p.name().parse::<Profile>().unwrap(), p);
        }
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
                    phi_min: 1.5,
                    ..base.clone()
                },
                |e| matches!(e, ConfigError::PhiMin(_)),
            ),
            (
                EngineConfig {
                    horizon: 0,
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
                    max_misfit: Some(f64::INFINITY),
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
        bad_scale.scale.psi_min = 2.0;
        assert!(matches!(
            bad_scale.validate(),
            Err(ConfigError::ScaleBracket { .. })
        ));
    }
}
