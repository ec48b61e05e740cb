//! ABB RAPID: one module (`<name>.mod`) with a `CONST robtarget` per target and a `PROC` per
//! routine.
//!
//! ```text
//! MODULE Demo
//!     CONST robtarget p10:=[[500.000,0.000,400.000],[0.00000000,0.00000000,1.00000000,0.00000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
//!     PROC main()
//!         MoveJ p10, v100, z10, tool0\WObj:=wobj0;
//!         MoveC p20, p30, v100, z10, tool0\WObj:=wobj0;
//!     ENDPROC
//! ENDMODULE
//! ```
//!
//! A robtarget is `[trans, rot, robconf, extax]`: position in mm in the work object, the
//! quaternion `q1..q4` = `w x y z` (normalised, `w ≥ 0`), `confdata` `[cf1, cf4, cf6, cfx]`
//! and six unused external axes `9E+09`. The speed is a standard `speeddata` (`v5` … `v7000`)
//! when the setting is one, otherwise `v_export := [speed, 500, 5000, 1000]` (the orientation
//! and external-axis speeds of the standard ones); the zone is `fine` for 0, a standard
//! `zonedata` (`z0` … `z200`) when it is one, otherwise `z_export := [FALSE, z, 1.5z, 1.5z,
//! 0.15z, 1.5z, 0.15z]` (the proportions of `z10`). Source for the data types: ABB, *Technical
//! reference manual — RAPID Instructions, Functions and Data types* (`robtarget`, `confdata`,
//! `speeddata`, `zonedata`, `MoveJ`, `MoveL`, `MoveC`). The tool and work object named in the
//! settings must exist on the controller (`tool0` and `wobj0` always do).

use super::names::{self, Namespace, name_routines, name_targets};
use super::{
    ExportSettings, ExportWarning, ExportedFile, QUATERNION_DECIMALS, Step, configuration, fixed,
    position_text, steps, unreachable_targets,
};
use crate::program::{Configuration, Language, Motion, Program, Waypoint};

/// Standard `speeddata` TCP speeds, mm/s.
const SPEEDS: [u32; 25] = [
    5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800, 1000, 1500, 2000, 2500,
    3000, 4000, 5000, 6000, 7000,
];
/// Standard `zonedata` radii, mm.
const ZONES: [u32; 14] = [0, 1, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 150, 200];
/// Names of the custom speed and zone data, when the settings are not standard ones.
const CUSTOM_SPEED: &str = "v_export";
const CUSTOM_ZONE: &str = "z_export";

/// The standard value `v` is, if any.
fn standard(v: f64, table: &[u32]) -> Option<u32> {
    table.iter().copied().find(|&s| f64::from(s) == v)
}

/// The robtarget aggregate of a waypoint.
fn robtarget(w: &Waypoint) -> String {
    let [x, y, z] = position_text(&w.pose);
    let q = w.pose.values();
    let [qw, qx, qy, qz] = [q.qw, q.qx, q.qy, q.qz].map(|v| fixed(v, QUATERNION_DECIMALS));
    let [cf1, cf4, cf6, cfx] = match configuration(w, Language::Rapid) {
        Some(Configuration::Rapid(c)) => [c.cf1, c.cf4, c.cf6, c.cfx],
        _ => [0; 4],
    };
    format!(
        "[[{x},{y},{z}],[{qw},{qx},{qy},{qz}],[{cf1},{cf4},{cf6},{cfx}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
    )
}

/// The module file.
pub(crate) fn write(
    program: &Program<Waypoint>,
    settings: &ExportSettings,
    warnings: &mut Vec<ExportWarning>,
) -> Vec<ExportedFile> {
    let mut ns = Namespace::new(names::RAPID);
    for n in [
        settings.tool.as_str(),
        settings.work_object.as_str(),
        CUSTOM_SPEED,
        CUSTOM_ZONE,
        "fine",
        "vmax",
        "load0",
        "tool0",
        "wobj0",
    ] {
        ns.reserve(n);
    }
    for s in SPEEDS {
        ns.reserve(&format!("v{s}"));
    }
    for z in ZONES {
        ns.reserve(&format!("z{z}"));
    }
    let module = ns.claim(&program.name);
    if module != program.name {
        warnings.push(ExportWarning::RenamedProgram {
            from: program.name.clone(),
            to: module.clone(),
        });
    }
    let routines = name_routines(&mut ns, &program.routines, warnings);
    let targets = name_targets(&mut ns, program, &routines, "p", robtarget, warnings);

    let speed = match standard(settings.speed_mm_s, &SPEEDS) {
        Some(s) => format!("v{s}"),
        None => CUSTOM_SPEED.to_string(),
    };
    let zone = if settings.zone_mm == 0.0 {
        "fine".to_string()
    } else {
        match standard(settings.zone_mm, &ZONES) {
            Some(z) => format!("z{z}"),
            None => CUSTOM_ZONE.to_string(),
        }
    };
    let mut out = String::new();
    out.push_str(&format!("MODULE {module}\n"));
    out.push_str(&format!(
        "    ! Exported by nextpose: positions in mm in work object {}, orientations as quaternions.\n",
        settings.work_object
    ));
    for (name, value) in &targets.decls {
        out.push_str(&format!("    CONST robtarget {name}:={value};\n"));
    }
    if speed == CUSTOM_SPEED {
        let v = fixed(settings.speed_mm_s, 3);
        out.push_str(&format!(
            "    CONST speeddata {CUSTOM_SPEED}:=[{v},500,5000,1000];\n"
        ));
    }
    if zone == CUSTOM_ZONE {
        let z = settings.zone_mm;
        let [a, b, c] = [z, 1.5 * z, 0.15 * z].map(|v| fixed(v, 3));
        out.push_str(&format!(
            "    CONST zonedata {CUSTOM_ZONE}:=[FALSE,{a},{b},{b},{c},{b},{c}];\n"
        ));
    }
    let tail = format!(
        "{speed}, {zone}, {}\\WObj:={};",
        settings.tool, settings.work_object
    );
    for (r, routine) in program.routines.iter().enumerate() {
        let name = routines
            .get(r)
            .map_or(routine.name.as_str(), String::as_str);
        out.push_str(&format!("\n    PROC {name}()\n"));
        let target = |i: usize| targets.name(r, i);
        for step in steps(routine, warnings) {
            for t in unreachable_targets(routine, name, &step, |i| target(i).to_string(), warnings)
            {
                out.push_str(&format!("        ! {t}: out of the arm's reach\n"));
            }
            let line = match step {
                Step::Single { index, motion } => {
                    let instr = if motion == Motion::Joint {
                        "MoveJ"
                    } else {
                        "MoveL"
                    };
                    format!("{instr} {}, {tail}", target(index))
                }
                Step::Circle { via, to } => {
                    format!("MoveC {}, {}, {tail}", target(via), target(to))
                }
            };
            out.push_str(&format!("        {line}\n"));
        }
        out.push_str("    ENDPROC\n");
    }
    out.push_str("ENDMODULE\n");
    vec![ExportedFile {
        file_name: format!("{module}.mod"),
        text: out,
    }]
}
