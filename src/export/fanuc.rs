//! FANUC TP listings: one `.ls` per routine, in a folder named after the program.
//!
//! ```text
//! /PROG  MAIN
//! /ATTR
//! …
//! /MN
//!    1:  UFRAME_NUM=0 ;
//!    2:  UTOOL_NUM=0 ;
//!    3:J P[1] 100% FINE    ;
//!    4:L P[2] 100mm/sec CNT10    ;
//!    5:C P[3]
//!     :  P[4] 100mm/sec CNT10    ;
//! /POS
//! P[1]{
//!    GP1:
//!     UF : 0, UT : 0,     CONFIG : 'N U T, 0, 0, 0',
//!     X =   500.000  mm,  Y =     0.000  mm,  Z =   400.000  mm,
//!     W =     0.000 deg,  P =    90.000 deg,  R =     0.000 deg
//! };
//! /END
//! ```
//!
//! The layout is the ASCII listing a controller prints and (with the ASCII upload option) loads:
//! header `/PROG`, attributes `/ATTR` (sizes left 0 for the controller to fill in, no dates: the
//! export is deterministic), the numbered instructions `/MN` and the positions `/POS` in motion
//! group 1. Joint moves run at `100%`, linear and circular ones at the settings' speed in whole
//! `mm/sec` (at most 2000); the zone becomes `CNT` 1–100 (its number, rounded and clamped; `CNT`
//! is a rounding level, not mm) and a zone of 0 `FINE`. `UF`/`UT` are the numbers the work
//! object and tool names end in (`wobj0` → 0, at most 9 user frames and 10 tools). `W P R` are
//! fixed angles about X, Y, Z in degrees (`R = Rz(R)·Ry(P)·Rx(W)`). Positions are `P[n]`: a
//! waypoint named `P[n]` keeps its number, the others get the smallest free ones. Sources:
//! FANUC listings as controllers write them (the corpus's backups), and the `/POS` format our
//! importer documents.

use std::collections::{BTreeMap, HashMap, HashSet};

use super::names::{self, Namespace, name_routines};
use super::{
    ExportError, ExportSettings, ExportWarning, ExportedFile, FANUC_ANGLE_DECIMALS, Step,
    configuration, euler_zyx_deg, fixed, frame_index, position_text, steps, unreachable_targets,
};
use crate::program::{Configuration, Language, Motion, Program, Routine, Waypoint};

const MAX_USER_FRAME: u32 = 9;
const MAX_USER_TOOL: u32 = 10;
/// Fastest linear speed a TP `L` move takes, mm/sec.
const MAX_LINEAR_SPEED: f64 = 2000.0;
/// Highest position number.
const MAX_POSITION: u64 = 9999;

/// The configuration string written when a waypoint has none.
pub const DEFAULT_CONFIG: &str = "N U T, 0, 0, 0";

/// The number of a name `P[n]`, if it is one.
fn position_number(name: &str) -> Option<u64> {
    let n = name.strip_prefix("P[")?.strip_suffix(']')?;
    if n.is_empty() || !n.chars().all(|c| c.is_ascii_digit()) {
        return None;
    }
    n.parse().ok().filter(|n| (1..=MAX_POSITION).contains(n))
}

/// A folder name for the program: its name with path separators and other characters file
/// systems refuse replaced by `_`.
fn folder_name(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_control() || "/\\:*?\"<>|".contains(c) {
                '_'
            } else {
                c
            }
        })
        .collect();
    let s = s.trim().to_string();
    if s.is_empty() || s == "." || s == ".." {
        "fanuc".to_string()
    } else {
        s
    }
}

/// The `/POS` body of group 1 for a waypoint (without the `P[n]{` line).
fn position(w: &Waypoint, uf: u32, ut: u32) -> String {
    let [x, y, z] = position_text(&w.pose).map(|v| format!("{v:>9}"));
    let [a, b, c] =
        euler_zyx_deg(&w.pose.rotation()).map(|v| format!("{:>9}", fixed(v, FANUC_ANGLE_DECIMALS)));
    let config = match configuration(w, Language::Fanuc) {
        Some(Configuration::Fanuc(c)) => c.as_str(),
        _ => DEFAULT_CONFIG,
    };
    format!(
        "   GP1:\n\tUF : {uf}, UT : {ut},\t\tCONFIG : '{config}',\n\tX = {x}  mm,\tY = {y}  mm,\tZ = {z}  mm,\n\tW = {c} deg,\tP = {b} deg,\tR = {a} deg\n"
    )
}

/// Position numbers for a routine's waypoints.
fn numbers(
    routine: &Routine<Waypoint>,
    name: &str,
    value: impl Fn(&Waypoint) -> String,
    warnings: &mut Vec<ExportWarning>,
) -> Vec<u64> {
    let owned: HashSet<u64> = routine
        .waypoints
        .iter()
        .filter_map(|w| w.name.as_deref().and_then(position_number))
        .collect();
    let mut used: HashSet<u64> = HashSet::new();
    let mut by_original: HashMap<(Option<String>, String), u64> = HashMap::new();
    let mut next = 1;
    let mut out = Vec::with_capacity(routine.waypoints.len());
    for (index, w) in routine.waypoints.iter().enumerate() {
        let key = (w.name.clone(), value(w));
        let n = match by_original.get(&key) {
            Some(&n) => n,
            None => {
                let n = match w.name.as_deref().and_then(position_number) {
                    Some(n) if used.insert(n) => n,
                    _ => {
                        while owned.contains(&next) || used.contains(&next) {
                            next += 1;
                        }
                        used.insert(next);
                        next
                    }
                };
                by_original.insert(key, n);
                n
            }
        };
        let written = format!("P[{n}]");
        if w.name.as_deref() != Some(written.as_str()) {
            warnings.push(ExportWarning::RenamedTarget {
                routine: name.to_string(),
                seq: index + 1,
                from: w.name.clone(),
                to: written,
            });
        }
        out.push(n);
    }
    out
}

/// One listing per routine.
pub(crate) fn write(
    program: &Program<Waypoint>,
    settings: &ExportSettings,
    warnings: &mut Vec<ExportWarning>,
) -> Result<Vec<ExportedFile>, ExportError> {
    let uf = frame_index("work object", &settings.work_object, MAX_USER_FRAME)?;
    let ut = frame_index("tool", &settings.tool, MAX_USER_TOOL)?;
    let folder = folder_name(&program.name);
    if folder != program.name {
        warnings.push(ExportWarning::RenamedProgram {
            from: program.name.clone(),
            to: folder.clone(),
        });
    }
    let speed = settings.speed_mm_s.round().clamp(1.0, MAX_LINEAR_SPEED);
    if speed != settings.speed_mm_s {
        warnings.push(ExportWarning::SettingAdjusted {
            setting: "speed_mm_s",
            from: settings.speed_mm_s,
            to: speed,
        });
    }
    let termination = if settings.zone_mm == 0.0 {
        "FINE".to_string()
    } else {
        let cnt = settings.zone_mm.round().clamp(1.0, 100.0);
        if cnt != settings.zone_mm {
            warnings.push(ExportWarning::SettingAdjusted {
                setting: "zone_mm",
                from: settings.zone_mm,
                to: cnt,
            });
        }
        format!("CNT{cnt}")
    };
    let mut ns = Namespace::new(names::FANUC_PROGRAM);
    let routines = name_routines(&mut ns, &program.routines, warnings);
    let mut files = Vec::with_capacity(program.routines.len());
    for (r, routine) in program.routines.iter().enumerate() {
        let name = routines
            .get(r)
            .map_or(routine.name.as_str(), String::as_str);
        let value = |w: &Waypoint| position(w, uf, ut);
        let numbers = numbers(routine, name, value, warnings);
        let number = |i: usize| numbers.get(i).copied().unwrap_or(0);
        let mut mn: Vec<String> = vec![format!("UFRAME_NUM={uf} ;"), format!("UTOOL_NUM={ut} ;")];
        let mut positions: BTreeMap<u64, String> = BTreeMap::new();
        for (i, w) in routine.waypoints.iter().enumerate() {
            positions
                .entry(number(i))
                .or_insert_with(|| position(w, uf, ut));
        }
        for step in steps(routine, warnings) {
            let position = |i| format!("P[{}]", number(i));
            for t in unreachable_targets(routine, name, &step, position, warnings) {
                mn.push(format!("!{t} OUT OF REACH ;"));
            }
            match step {
                Step::Single { index, motion } => {
                    let (kind, v) = if motion == Motion::Joint {
                        ("J", "100%".to_string())
                    } else {
                        ("L", format!("{speed}mm/sec"))
                    };
                    mn.push(format!(
                        "{kind} P[{}] {v} {termination}    ;",
                        number(index)
                    ));
                }
                Step::Circle { via, to } => mn.push(format!(
                    "C P[{}]    \n    :  P[{}] {speed}mm/sec {termination}    ;",
                    number(via),
                    number(to)
                )),
            }
        }
        let mut text = format!("/PROG  {name}\n/ATTR\n");
        text.push_str("OWNER\t\t= MNEDITOR;\n");
        text.push_str("COMMENT\t\t= \"nextpose export\";\n");
        text.push_str("PROG_SIZE\t= 0;\n");
        text.push_str("FILE_NAME\t= ;\n");
        text.push_str("VERSION\t\t= 0;\n");
        text.push_str(&format!("LINE_COUNT\t= {};\n", mn.len()));
        text.push_str("MEMORY_SIZE\t= 0;\n");
        text.push_str("PROTECT\t\t= READ_WRITE;\n");
        text.push_str(
            "TCD:  STACK_SIZE\t= 0,\n      TASK_PRIORITY\t= 50,\n      TIME_SLICE\t= 0,\n      BUSY_LAMP_OFF\t= 0,\n      ABORT_REQUEST\t= 0,\n      PAUSE_REQUEST\t= 0;\n",
        );
        text.push_str("DEFAULT_GROUP\t= 1,*,*,*,*;\n");
        text.push_str("CONTROL_CODE\t= 00000000 00000000;\n");
        text.push_str("/MN\n");
        for (k, line) in mn.iter().enumerate() {
            let sep = if line.starts_with(['J', 'L', 'C']) {
                ""
            } else {
                "  "
            };
            text.push_str(&format!("{:>4}:{sep}{line}\n", k + 1));
        }
        text.push_str("/POS\n");
        for (n, body) in &positions {
            text.push_str(&format!("P[{n}]{{\n{body}}};\n"));
        }
        text.push_str("/END\n");
        files.push(ExportedFile {
            file_name: format!("{folder}/{name}.ls"),
            text,
        });
    }
    Ok(files)
}
