//! Engine settings on the command line: a named profile, then one flag per overridden field.
//! The flags are a cell's settings ([`crate::api::settings`], the same names and the same
//! mapping onto the engine), as the command line spells them.

use anyhow::{Context, Result};
use clap::builder::PossibleValue;
use clap::{Args, ValueEnum};

use crate::api::{CellSettingsInput, ScaleSettings};
use crate::engine::config::{MergeRule, RecallGate};
use crate::engine::{EngineConfig, OfferRule, Profile};

/// Engine settings on the command line: a profile, then per-field overrides.
#[derive(Debug, Clone, Args)]
pub struct EngineArgs {
    /// Settings to start from.
    #[arg(long, value_enum, default_value_t = ProfileArg(Profile::Default))]
    pub profile: ProfileArg,
    /// Complexity δ in (0, 1]: larger = stricter merging, more states.
    #[arg(long)]
    pub delta: Option<f64>,
    /// Minimum confidence φ for a guess to be offered.
    #[arg(long)]
    pub phi_min: Option<f64>,
    /// Number of most recent moves a guess conditions on (h).
    #[arg(long)]
    pub horizon: Option<usize>,
    /// Estimate the scale ψ at prediction time.
    #[arg(long, value_enum)]
    pub scale: Option<Switch>,
    /// Merge test of the learner.
    #[arg(long, value_enum)]
    pub merge: Option<MergeArg>,
    /// Learn each move as it is taught (on) or only finished routines (off).
    #[arg(long, value_enum, visible_alias = "within")]
    pub learn_within_routine: Option<Switch>,
    /// Misfit gate (number, or "none" for no gate).
    #[arg(long, value_name = "F|none", value_parser = parse_limit)]
    pub max_misfit: Option<Limit>,
    /// Spread gate (number, or "none" for no gate).
    #[arg(long, value_name = "F|none", value_parser = parse_limit)]
    pub max_spread: Option<Limit>,
    /// End-of-routine probability gate (number, or "none" for no gate).
    #[arg(long, value_name = "F|none", value_parser = parse_limit)]
    pub max_end_prob: Option<Limit>,
    /// Recall of the most recent occurrence: "K" or "K:COST" (fewest window moves, mean squared
    /// distance allowed), or "none".
    #[arg(long, value_name = "K[:COST]|none", value_parser = parse_gate)]
    pub recall: Option<GateArg>,
    /// The experts' offer rule: a fixed p_useful a candidate needs to be offered (0–1), or
    /// "none" for the model alone with its own gates (the seed). Left out, the default profile's
    /// cell steers its own threshold to `--target-precision`. ("none" is not a cell setting:
    /// there the profile decides whether there is an offer rule, and the seed has none.)
    #[arg(long, value_name = "P|none", value_parser = parse_limit)]
    pub offer_threshold: Option<Limit>,
    /// The share of offers that should be right when the cell steers its own threshold (0–1;
    /// default 0.85).
    #[arg(long, value_name = "P")]
    pub target_precision: Option<f64>,
}

/// A recall gate given on the command line, `None` meaning "off".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateArg(pub Option<RecallGate>);

fn parse_gate(s: &str) -> Result<GateArg, String> {
    if s.eq_ignore_ascii_case("none") {
        return Ok(GateArg(None));
    }
    let bad = || format!("expected K, K:COST or \"none\", got {s:?}");
    let (k, cost) = s.split_once(':').unwrap_or((s, "0.1"));
    let min_window = k.parse::<usize>().map_err(|_| bad())?;
    let max_cost = cost.parse::<f64>().map_err(|_| bad())?;
    Ok(GateArg(Some(RecallGate {
        max_cost,
        min_window,
    })))
}

/// A profile on the command line, spelled as on the wire ([`Profile::name`]: the
/// dissertation's engine is `seed`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProfileArg(pub Profile);

impl ValueEnum for ProfileArg {
    fn value_variants<'a>() -> &'a [ProfileArg] {
        const ALL: [ProfileArg; Profile::ALL.len()] =
            [ProfileArg(Profile::ALL[0]), ProfileArg(Profile::ALL[1])];
        &ALL
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.0.name()))
    }
}

impl From<ProfileArg> for Profile {
    fn from(p: ProfileArg) -> Profile {
        p.0
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    On,
    Off,
}

impl Switch {
    fn on(self) -> bool {
        self == Switch::On
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MergeArg {
    Total,
    Incremental,
}

/// A gate threshold, `None` meaning "no gate".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit(pub Option<f64>);

fn parse_limit(s: &str) -> Result<Limit, String> {
    if s.eq_ignore_ascii_case("none") {
        return Ok(Limit(None));
    }
    s.parse::<f64>()
        .map(|v| Limit(Some(v)))
        .map_err(|_| format!("expected a number or \"none\", got {s:?}"))
}

impl EngineArgs {
    /// The overrides given, as a cell's settings (all but `--offer-threshold`, whose "none"
    /// only the command line has).
    pub fn overrides(&self) -> CellSettingsInput {
        let profile = Profile::from(self.profile);
        CellSettingsInput {
            profile: Some(profile),
            delta: self.delta,
            phi_min: self.phi_min,
            horizon: self.horizon,
            scale: self.scale.map(|v| ScaleSettings::switched(profile, v.on())),
            merge: self.merge.map(|v| match v {
                MergeArg::Total => MergeRule::Total,
                MergeArg::Incremental => MergeRule::Incremental,
            }),
            learn_within_routine: self.learn_within_routine.map(Switch::on),
            max_misfit: self.max_misfit.map(|Limit(v)| v),
            max_spread: self.max_spread.map(|Limit(v)| v),
            max_end_prob: self.max_end_prob.map(|Limit(v)| v),
            recall: self.recall.map(|GateArg(v)| v),
            target_precision: self.target_precision,
            ..CellSettingsInput::default()
        }
    }

    /// The profile's settings with the given overrides, validated.
    pub fn config(&self) -> Result<EngineConfig> {
        let mut c = EngineConfig::profile(self.profile.into());
        if let Some(Limit(v)) = self.offer_threshold {
            c.offer = v.map(|threshold| OfferRule {
                threshold: Some(threshold),
                ..c.offer.unwrap_or_default()
            });
        }
        if self.target_precision.is_some() && c.offer.is_none() {
            anyhow::bail!("--target-precision: these settings have no offer rule");
        }
        self.overrides().apply(&mut c);
        c.validate().context("invalid engine settings")?;
        Ok(c)
    }

    pub fn profile_name(&self) -> &'static str {
        Profile::from(self.profile).name()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command, run_cli};
    use clap::Parser;

    fn parse(args: &[&str]) -> Cli {
        Cli::try_parse_from(args).unwrap()
    }

    #[test]
    fn overrides_apply_on_top_of_the_profile() {
        let cli = parse(&[
            "nextpose",
            "replay",
            "x.json",
            "--profile",
            "seed",
            "--delta",
            "0.5",
            "--within",
            "on",
            "--max-misfit",
            "2.5",
            "--max-end-prob",
            "none",
            "--scale",
            "off",
        ]);
        let Command::Replay(args) = cli.command else {
            panic!("not replay")
        };
        let c = args.engine.config().unwrap();
        assert_eq!(c.delta, 0.5);
        assert!(c.learn_within_routine);
        assert_eq!(c.predict.max_misfit, Some(2.5));
        assert_eq!(c.predict.max_end_prob, None);
        assert!(!c.predict.scale.enabled);
        assert_eq!(c.merge, MergeRule::Total);
    }

    #[test]
    fn invalid_values_are_errors_not_panics() {
        let cli = parse(&["nextpose", "replay", "x.json", "--delta", "1.5"]);
        let err = run_cli(cli).unwrap_err();
        assert!(format!("{err:#}").contains("delta"), "{err:#}");
        assert!(
            Cli::try_parse_from(["nextpose", "replay", "x.json", "--max-spread", "lots"]).is_err()
        );
        let cli = parse(&["nextpose", "sweep", "x.json", "--horizons", "1,0"]);
        let err = run_cli(cli).unwrap_err();
        assert!(format!("{err:#}").contains("x.json"), "{err:#}");
    }
}
