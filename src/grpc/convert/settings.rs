//! A cell's settings: the engine profile and parameters, the robot and its frames, the reach
//! policy, the tolerances and the export defaults; as set (every field optional) and as in force.

use crate::api::{CellSettings, CellSettingsInput, ScaleSettings};
use crate::engine::Profile;
use crate::export::ExportSettings;
use crate::kinematics::ReachPolicy;

use super::wire::{both_ways, enum_both_ways};

enum_both_ways!(Profile => Profile as "profile" { Seed, Default });
enum_both_ways!(ReachPolicy => ReachPolicy as "reach policy" { Withhold, Flag });

both_ways!(plain ScaleSettings => ScaleSettings { enabled, psi_min, psi_max });
both_ways!(plain ExportSettings => ExportSettings { speed_mm_s, zone_mm, work_object, tool });

both_ways!(CellSettingsInput => CellSettingsInput {
    profile, delta, phi_min, horizon, sigma_t_mm, sigma_q, scale, robot, base, tool,
    reach_policy, noise, tolerance, offer_threshold, export, target_precision,
});
both_ways!(CellSettings => CellSettings {
    profile, delta, phi_min, horizon, sigma_t_mm, sigma_q, scale, robot, base, tool,
    reach_policy, noise, tolerance, offer_threshold, export, target_precision,
});
