//! KUKA KRL: a `.src` with one `DEF` per routine and the `.dat` of the same name holding the
//! positions.
//!
//! ```text
//! demo.src                               demo.dat
//! DEF demo( )                            DEFDAT demo
//!   main( )                                DECL E6POS XP1={X 500.000,Y 0.000,Z 400.000,A 0.0000,B 90.0000,C 0.0000,S 2,T 2,E1 0.0,…}
//! END                                    ENDDAT
//! DEF main( )
//!   BAS(#INITMOV, 0)
//!   $BASE = $NULLFRAME
//!   $TOOL = $NULLFRAME
//!   $VEL.CP = 0.1
//!   $APO.CDIS = 10.000
//!   $APO.CPTP = 10
//!   PTP XP1 C_PTP
//!   LIN XP2 C_DIS
//!   CIRC XP3, XP4 C_DIS
//! END
//! ```
//!
//! Why two files: KRL allows a declaration with an initial value (`DECL E6POS XP1={…}`) only
//! in a data list, so taught positions live in the `.dat` of the same name, as the controller
//! itself keeps them; our importer pairs `.src` and `.dat` by folder and stem. The first `DEF`
//! of a `.src` must carry the file's name: when the first routine has the program's name it is
//! that `DEF`, otherwise a `DEF` of the program's name calls the routines in order (it has no
//! moves, so an import of the files drops it as a routine too short to keep).
//!
//! Every routine starts with `BAS(#INITMOV, 0)` (the standard initialisation of velocities and
//! accelerations, from the `BAS` package every KSS has), then `$BASE` and `$TOOL` (the settings'
//! work object and tool numbers: `BASE_DATA[n]` / `TOOL_DATA[n]`, `$NULLFRAME` for 0),
//! `$VEL.CP` in m/s and `$APO.CDIS` in mm. Linear and circular moves approximate with `C_DIS`
//! and PTP moves with `C_PTP`, whose `$APO.CPTP` is a percentage: it gets the zone's number
//! clamped to 1–100. A zone of 0 gives exact stops (no approximation flag). `A B C` are ZYX
//! Euler angles in degrees (`R = Rz(A)·Ry(B)·Rx(C)`); `S` and `T` are written when the waypoint's
//! configuration is known (see [`crate::kinematics::configuration`]) and left out otherwise,
//! which makes a PTP move keep the current configuration. Sources: KUKA, *KUKA System Software
//! 8 — Operating and Programming Instructions for System Integrators* (data lists, E6POS,
//! `$VEL.CP`, `$APO`, approximate positioning).

use super::names::{self, Namespace, name_routines, name_targets};
use super::{
    ExportError, ExportSettings, ExportWarning, ExportedFile, KRL_ANGLE_DECIMALS, Step,
    configuration, euler_zyx_deg, fixed, frame_index, position_text, steps, unreachable_targets,
};
use crate::program::{Configuration, Language, Motion, Program, Waypoint};

/// `BASE_DATA` has 32 entries and `TOOL_DATA` 16 on a KRC.
const MAX_BASE: u32 = 32;
const MAX_TOOL: u32 = 16;

/// The `E6POS` aggregate of a waypoint.
fn e6pos(w: &Waypoint) -> String {
    let [x, y, z] = position_text(&w.pose);
    let [a, b, c] = euler_zyx_deg(&w.pose.rotation()).map(|v| fixed(v, KRL_ANGLE_DECIMALS));
    let st = match configuration(w, Language::Krl) {
        Some(Configuration::Krl(k)) => {
            let s = k.status.map_or(String::new(), |s| format!(",S {s}"));
            let t = k.turn.map_or(String::new(), |t| format!(",T {t}"));
            s + &t
        }
        _ => String::new(),
    };
    format!("{{X {x},Y {y},Z {z},A {a},B {b},C {c}{st},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}")
}

/// The frame numbers the settings name, checked against the KRC's tables.
pub(crate) fn frames(settings: &ExportSettings) -> Result<(u32, u32), ExportError> {
    Ok((
        frame_index("work object", &settings.work_object, MAX_BASE)?,
        frame_index("tool", &settings.tool, MAX_TOOL)?,
    ))
}

fn frame(table: &str, n: u32) -> String {
    if n == 0 {
        "$NULLFRAME".to_string()
    } else {
        format!("{table}[{n}]")
    }
}

/// The `.src` and `.dat` files.
pub(crate) fn write(
    program: &Program<Waypoint>,
    settings: &ExportSettings,
    warnings: &mut Vec<ExportWarning>,
) -> Result<Vec<ExportedFile>, ExportError> {
    let (base, tool) = frames(settings)?;
    let mut ns = Namespace::new(names::KRL);
    let module = ns.claim(&program.name);
    if module != program.name {
        warnings.push(ExportWarning::RenamedProgram {
            from: program.name.clone(),
            to: module.clone(),
        });
    }
    // The first routine is the file's main DEF when it has the program's name.
    let first_is_main = program
        .routines
        .first()
        .is_some_and(|r| r.name.eq_ignore_ascii_case(&module) && names::KRL.is_valid(&r.name));
    let routines: Vec<String> = if first_is_main {
        let rest = program.routines.get(1..).unwrap_or(&[]);
        let mut renamed = Vec::new();
        let mut all = vec![program.routines[0].name.clone()];
        all.extend(name_routines(&mut ns, rest, &mut renamed));
        warnings.extend(renamed.into_iter().map(|w| match w {
            ExportWarning::RenamedRoutine { position, from, to } => ExportWarning::RenamedRoutine {
                position: position + 1,
                from,
                to,
            },
            other => other,
        }));
        all
    } else {
        name_routines(&mut ns, &program.routines, warnings)
    };
    let targets = name_targets(&mut ns, program, &routines, "XP", e6pos, warnings);

    let mut src = String::from("&ACCESS RVP\n&REL 1\n");
    if !first_is_main {
        src.push_str(&format!("DEF {module}( )\n"));
        for r in &routines {
            src.push_str(&format!("  {r}( )\n"));
        }
        src.push_str("END\n\n");
    }
    let cdis = fixed(settings.zone_mm, 3);
    let cptp = settings.zone_mm.round().clamp(1.0, 100.0);
    let approximate = settings.zone_mm > 0.0;
    for (r, routine) in program.routines.iter().enumerate() {
        let name = routines
            .get(r)
            .map_or(routine.name.as_str(), String::as_str);
        src.push_str(&format!("DEF {name}( )\n"));
        src.push_str(";FOLD settings (exported by nextpose)\n");
        src.push_str("  BAS(#INITMOV, 0)\n");
        src.push_str(&format!("  $BASE = {}\n", frame("BASE_DATA", base)));
        src.push_str(&format!("  $TOOL = {}\n", frame("TOOL_DATA", tool)));
        src.push_str(&format!(
            "  $VEL.CP = {}\n",
            fixed(settings.speed_mm_s / 1000.0, 4)
        ));
        if approximate {
            src.push_str(&format!("  $APO.CDIS = {cdis}\n  $APO.CPTP = {cptp}\n"));
        }
        src.push_str(";ENDFOLD\n");
        let target = |i: usize| targets.name(r, i);
        for step in steps(routine, warnings) {
            for t in unreachable_targets(routine, name, &step, |i| target(i).to_string(), warnings)
            {
                src.push_str(&format!("  ; {t}: out of the arm's reach\n"));
            }
            let (line, flag) = match step {
                Step::Single {
                    index,
                    motion: Motion::Joint,
                } => (format!("PTP {}", target(index)), " C_PTP"),
                Step::Single { index, .. } => (format!("LIN {}", target(index)), " C_DIS"),
                Step::Circle { via, to } => {
                    (format!("CIRC {}, {}", target(via), target(to)), " C_DIS")
                }
            };
            let flag = if approximate { flag } else { "" };
            src.push_str(&format!("  {line}{flag}\n"));
        }
        src.push_str("END\n\n");
    }
    let mut dat = format!("&ACCESS RVP\n&REL 1\nDEFDAT {module}\n");
    dat.push_str("; positions exported by nextpose: mm, A B C ZYX Euler angles in degrees\n");
    for (name, value) in &targets.decls {
        dat.push_str(&format!("  DECL E6POS {name}={value}\n"));
    }
    dat.push_str("ENDDAT\n");
    Ok(vec![
        ExportedFile {
            file_name: format!("{module}.src"),
            text: src,
        },
        ExportedFile {
            file_name: format!("{module}.dat"),
            text: dat,
        },
    ])
}
