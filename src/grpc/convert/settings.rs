//! A cell's settings: the engine profile and parameters, the robot and its frames, the reach
//! policy, the tolerances and the export defaults; as set (every field optional) and as in force.
//! The field lists are the settings of [`crate::api::settings`]: a setting missing here or in
//! the proto does not compile.

use crate::api::{CellSettings, CellSettingsInput, ScaleSettings};
use crate::engine::Profile;
use crate::engine::config::{MergeRule, RecallGate};
use crate::export::ExportSettings;
use crate::grpc::pb;
use crate::kinematics::ReachPolicy;

use super::wire::{In, Wire, both_ways, enum_both_ways};

enum_both_ways!(Profile => Profile as "profile" { Dissertation = Seed, Default });
enum_both_ways!(ReachPolicy => ReachPolicy as "reach policy" { Withhold, Flag });
enum_both_ways!(MergeRule => MergeRule as "merge rule" { Total, Incremental });

both_ways!(plain ScaleSettings => ScaleSettings { enabled, psi_min, psi_max });
both_ways!(plain ExportSettings => ExportSettings { speed_mm_s, zone_mm, work_object, tool });
both_ways!(RecallGate => RecallGate { max_cost, min_window });

both_ways!(CellSettingsInput => CellSettingsInput {
    profile, delta, phi_min, horizon, sigma_t_mm, sigma_q, scale, robot, base, tool,
    reach_policy, noise, tolerance, offer_threshold, export, target_precision,
    merge, learn_within_routine, max_misfit, max_spread, max_end_prob, recall,
});
both_ways!(CellSettings => CellSettings {
    profile, delta, phi_min, horizon, sigma_t_mm, sigma_q, scale, robot, base, tool,
    reach_policy, noise, tolerance, offer_threshold, export, target_precision,
    merge, learn_within_routine, max_misfit, max_spread, max_end_prob, recall,
});

/// A gate as given: left out (the profile's), none, or a threshold.
impl Wire<Option<pb::GateSetting>> for Option<Option<f64>> {
    fn out(self) -> Option<pb::GateSetting> {
        self.map(|max| pb::GateSetting { max })
    }
    fn back(m: Option<pb::GateSetting>, _: &str) -> In<Option<Option<f64>>> {
        Ok(m.map(|g| g.max))
    }
}

/// Recall as given: left out (the profile's), off, or a gate.
impl Wire<Option<pb::RecallSetting>> for Option<Option<RecallGate>> {
    fn out(self) -> Option<pb::RecallSetting> {
        self.map(|gate| pb::RecallSetting {
            gate: gate.map(Into::into),
        })
    }
    fn back(m: Option<pb::RecallSetting>, what: &str) -> In<Option<Option<RecallGate>>> {
        m.map(|r| Wire::back(r.gate, what)).transpose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every setting of the one list travels on gRPC: a message carrying each changed setting
    /// reads back as what was sent, and the proto names them as the list does.
    #[test]
    fn every_setting_travels_under_its_name() {
        let input = CellSettingsInput {
            delta: Some(0.5),
            max_misfit: Some(None),
            max_spread: Some(Some(0.25)),
            recall: Some(Some(RecallGate {
                max_cost: 0.2,
                min_window: 3,
            })),
            merge: Some(MergeRule::Total),
            learn_within_routine: Some(false),
            ..CellSettingsInput::default()
        };
        let resolved = input.clone().over_profile();
        let message = pb::CellSettings::from(resolved.clone());
        assert_eq!(CellSettings::try_from(message).unwrap(), resolved);
        let message = pb::CellSettingsInput::from(input.clone());
        let back = CellSettingsInput::try_from(message).unwrap();
        assert_eq!(back.over_profile(), resolved);

        let proto = include_str!("../../../proto/nextpose/v1/nextpose.proto");
        for message in ["message CellSettings {", "message CellSettingsInput {"] {
            let body = &proto[proto.find(message).unwrap()..];
            let body = &body[..body.find("\n}").unwrap()];
            let mut names: Vec<&str> = body
                .lines()
                .skip(1)
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with("//"))
                .filter_map(|l| l.split('=').next()?.split_whitespace().last())
                .collect();
            let mut settings = crate::api::settings::SETTINGS.to_vec();
            names.sort_unstable();
            settings.sort_unstable();
            assert_eq!(names, settings, "{message}");
        }
    }
}
