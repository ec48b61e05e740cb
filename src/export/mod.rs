//! Exporting programs as controller programs: ABB RAPID, KUKA KRL and FANUC TP listings.
//!
//! The converse of [`crate::import`]: a program of the program model ([`Program`] →
//! [`Routine`]s → [`Waypoint`]s: poses in the work frame, mm, with a motion class, an optional
//! arm configuration and whether the arm can reach it) becomes the text of the files a
//! controller loads, in a [`Language`]. Pure: it builds strings; writing files,
//! choosing the robot and checking reach belong to the callers.
//!
//! - [`rapid`]: one `.mod` module, `CONST robtarget` declarations and one `PROC` per routine.
//! - [`krl`]: a `.src` with one `DEF` per routine and the `.dat` of the same name holding the
//!   `E6POS` positions (KRL allows initialised declarations only in a data list, so the
//!   positions cannot live in the `.src`; our importer pairs the two by folder and stem).
//! - [`fanuc`]: one `.ls` listing per routine, in a folder named after the program (a FANUC
//!   program is a folder of TP programs to our importer).
//! - [`names`]: which names are kept and how the others are made valid.
//!
//! **Names.** A waypoint or routine name that is an identifier of the target language is kept
//! exactly; anything else — `Offs(p10,0,0,50)`, `literal@L12`, no name, a reserved word, too
//! long, or a name already used for another position — gets a deterministic valid name and an
//! [`ExportWarning::RenamedTarget`] / [`ExportWarning::RenamedRoutine`]. A waypoint that visits a
//! target already declared with the same printed value reuses its declaration (as a taught
//! program visits `p10` twice). FANUC positions are `P[n]`: a name `P[n]` keeps its number,
//! every other one gets the smallest free number.
//!
//! **Precision.** Positions are printed in mm with 3 decimals; RAPID quaternions with 8
//! decimals; KRL `A B C` with 4 decimals and FANUC `W P R` with 3 (the FANUC listing format), in
//! degrees. [`position_tolerance_mm`] and [`orientation_tolerance_rad`] give the
//! round-trip error these allow. Angles are ZYX Euler angles (`R = Rz(A)·Ry(B)·Rx(C)`; FANUC
//! `A = R, B = P, C = W`) in `(−180°, 180°]`; the extraction keeps the composed rotation exact
//! also at gimbal lock (`B = ±90°`), where only `A ∓ C` is determined.
//!
//! **Configuration.** A waypoint's [`Configuration`] in the language's notation is written as
//! RAPID `confdata`, KRL `S`/`T` and FANUC `CONFIG` (the service computes it from the joints
//! it chose: [`crate::kinematics::ArmConfiguration::written`]); without one (or with one in
//! another language's notation), RAPID gets `[0,0,0,0]`, KRL no `S`/`T` and FANUC
//! `'N U T, 0, 0, 0'`, with one [`ExportWarning::UnknownConfiguration`] per file set.
//!
//! **Motion.** A waypoint without a motion class is moved to linearly.

pub mod fanuc;
pub mod krl;
pub mod names;
pub mod rapid;

use std::fmt;

use nalgebra::{UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::engine::Pose;
use crate::program::{
    Configuration, Language, Motion, Program, Routine, UnknownLanguage, Waypoint,
};

/// Decimals of positions (mm) in all three formats.
pub const POSITION_DECIMALS: usize = 3;
/// Decimals of RAPID quaternion components.
pub const QUATERNION_DECIMALS: usize = 8;
/// Decimals of KRL `A B C` (degrees).
pub const KRL_ANGLE_DECIMALS: usize = 4;
/// Decimals of FANUC `W P R` (degrees), as FANUC listings print them.
pub const FANUC_ANGLE_DECIMALS: usize = 3;

/// Largest accepted |coordinate| of a waypoint, mm (a kilometre: nothing an arm reaches).
pub const MAX_COORDINATE_MM: f64 = 1.0e6;
/// Largest accepted TCP speed, mm/s (RAPID's `vmax` is 7000 mm/s).
pub const MAX_SPEED_MM_S: f64 = 7000.0;
/// Largest accepted zone (approximation distance), mm.
pub const MAX_ZONE_MM: f64 = 1000.0;

/// The motion parameters written into every move (a cell's settings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(default, deny_unknown_fields)]
pub struct ExportSettings {
    /// TCP speed of linear and circular moves, mm/s (`v100`, `$VEL.CP`, `100mm/sec`).
    #[schema(exclusive_minimum = 0.0, maximum = 7000.0)]
    pub speed_mm_s: f64,
    /// Zone (approximation distance), mm; 0 is an exact stop (`fine`, no `C_DIS`, `FINE`).
    #[schema(minimum = 0.0, maximum = 1000.0)]
    pub zone_mm: f64,
    /// Work object (RAPID `\WObj`); its trailing number is the KRL base and FANUC user frame.
    /// A RAPID identifier (not a reserved word).
    #[schema(pattern = r"^[A-Za-z][A-Za-z0-9_]{0,31}$")]
    pub work_object: String,
    /// Tool (RAPID tooldata); its trailing number is the KRL tool and FANUC user tool. A RAPID
    /// identifier (not a reserved word).
    #[schema(pattern = r"^[A-Za-z][A-Za-z0-9_]{0,31}$")]
    pub tool: String,
}

impl Default for ExportSettings {
    fn default() -> Self {
        ExportSettings {
            speed_mm_s: 100.0,
            zone_mm: 10.0,
            work_object: "wobj0".to_string(),
            tool: "tool0".to_string(),
        }
    }
}

impl ExportSettings {
    /// Checks the values every format needs: a finite speed in `(0, 7000]` mm/s, a finite
    /// zone in `[0, 1000]` mm, and work object and tool names that are RAPID identifiers.
    pub fn validate(&self) -> Result<(), ExportError> {
        if !(self.speed_mm_s.is_finite()
            && self.speed_mm_s > 0.0
            && self.speed_mm_s <= MAX_SPEED_MM_S)
        {
            return Err(ExportError::Speed(self.speed_mm_s));
        }
        if !(self.zone_mm.is_finite() && self.zone_mm >= 0.0 && self.zone_mm <= MAX_ZONE_MM) {
            return Err(ExportError::Zone(self.zone_mm));
        }
        for (what, name) in [("work object", &self.work_object), ("tool", &self.tool)] {
            if !names::RAPID.is_valid(name) {
                return Err(ExportError::FrameName {
                    what,
                    name: name.clone(),
                });
            }
        }
        Ok(())
    }
}

/// Largest position error (mm) a round trip through the printed text of `language` can give:
/// half a unit of the last printed decimal on each axis.
pub fn position_tolerance_mm(_language: Language) -> f64 {
    3f64.sqrt() * 0.5 * 10f64.powi(-(POSITION_DECIMALS as i32)) * (1.0 + 1e-6)
}

/// Largest rotation error (rad) a round trip through the printed text of `language` can give:
/// for quaternions, half a unit of the last decimal on each of the four components (the angle
/// error is at most twice the component error's norm, normalisation included, rounded up to
/// 4·|δq|); for Euler angles half a unit on each of the three angles.
pub fn orientation_tolerance_rad(language: Language) -> f64 {
    match language {
        Language::Rapid => 4.0 * 2.0 * 0.5 * 10f64.powi(-(QUATERNION_DECIMALS as i32)),
        Language::Krl => 3.0 * 0.5 * 10f64.powi(-(KRL_ANGLE_DECIMALS as i32)).to_radians(),
        Language::Fanuc => 3.0 * 0.5 * 10f64.powi(-(FANUC_ANGLE_DECIMALS as i32)).to_radians(),
    }
}

/// The language an export asks for by name (`rapid`, `krl` or `fanuc`, in any case).
pub fn language_named(name: &str) -> Result<Language, ExportError> {
    name.parse()
        .map_err(|e: UnknownLanguage| ExportError::UnknownFormat(e.0))
}

/// One file of an export: its name (a relative path) and its text.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ExportedFile {
    /// `Name.mod`; `name.src` and `name.dat`; `program/ROUTINE.ls`.
    pub file_name: String,
    pub text: String,
}

/// What an export gave: the files (RAPID one, KRL two, FANUC one per routine) and the warnings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Exported {
    pub files: Vec<ExportedFile>,
    pub warnings: Vec<ExportWarning>,
}

impl Exported {
    /// The files as `(name, text)` pairs, as [`crate::import::parse_files`] takes them.
    pub fn as_pairs(&self) -> Vec<(&str, &str)> {
        self.files
            .iter()
            .map(|f| (f.file_name.as_str(), f.text.as_str()))
            .collect()
    }
}

/// Something the export changed or could not express, for the operator to know.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ExportWarning {
    /// The waypoint is out of the arm's reach; the file says so in a comment before the move.
    Unreachable {
        routine: String,
        /// The waypoint's place in its routine, from 1 (its `seq`).
        seq: usize,
        target: String,
    },
    /// The waypoint's name was not a valid (or free) name of the language.
    RenamedTarget {
        routine: String,
        /// The waypoint's place in its routine, from 1 (its `seq`).
        seq: usize,
        from: Option<String>,
        to: String,
    },
    /// The routine's name was not a valid (or free) name of the language.
    RenamedRoutine {
        /// The routine's place in its program, from 1 (its `position`).
        position: usize,
        from: String,
        to: String,
    },
    /// The program's name was not a valid name (RAPID module, KRL file) or folder name.
    RenamedProgram { from: String, to: String },
    /// A circular waypoint without a partner (circular moves pair as via, end): moved to
    /// linearly instead.
    UnpairedCircular {
        routine: String,
        /// The waypoint's place in its routine, from 1 (its `seq`).
        seq: usize,
    },
    /// Waypoints without a configuration got the default one.
    UnknownConfiguration { count: usize },
    /// A setting the format cannot express exactly was rounded or clamped (FANUC speeds are
    /// whole mm/sec, `CNT` is 0–100).
    SettingAdjusted {
        setting: &'static str,
        from: f64,
        to: f64,
    },
}

impl fmt::Display for ExportWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExportWarning::Unreachable {
                routine,
                seq,
                target,
            } => write!(
                f,
                "{routine}: waypoint {seq} ({target}) is out of the arm's reach"
            ),
            ExportWarning::RenamedTarget {
                routine,
                seq,
                from,
                to,
            } => match from {
                Some(from) => write!(f, "{routine}: waypoint {seq} {from:?} renamed {to}"),
                None => write!(f, "{routine}: waypoint {seq} has no name: named {to}"),
            },
            ExportWarning::RenamedRoutine { position, from, to } => {
                write!(f, "routine {position} {from:?} renamed {to}")
            }
            ExportWarning::RenamedProgram { from, to } => {
                write!(f, "program {from:?} renamed {to}")
            }
            ExportWarning::UnpairedCircular { routine, seq } => write!(
                f,
                "{routine}: circular waypoint {seq} has no partner: moved to linearly"
            ),
            ExportWarning::UnknownConfiguration { count } => write!(
                f,
                "{count} waypoint(s) without an arm configuration: the default one is written"
            ),
            ExportWarning::SettingAdjusted { setting, from, to } => {
                write!(f, "{setting} {from} written as {to}")
            }
        }
    }
}

/// Why a program cannot be exported.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExportError {
    #[error("speed must be a number in (0, {MAX_SPEED_MM_S}] mm/s, not {0}")]
    Speed(f64),
    #[error("zone must be a number in [0, {MAX_ZONE_MM}] mm, not {0}")]
    Zone(f64),
    #[error("{what} name {name:?} is not an identifier (letters, digits, _; up to 32)")]
    FrameName { what: &'static str, name: String },
    #[error("{what} {name:?} must end in a frame number of 0–{max} for FANUC")]
    FrameNumber {
        what: &'static str,
        name: String,
        max: u32,
    },
    #[error("{routine}: waypoint {seq} has a coordinate beyond ±{MAX_COORDINATE_MM} mm")]
    PoseOutOfRange { routine: String, seq: usize },
    #[error("unknown export format {0:?} (rapid, krl or fanuc)")]
    UnknownFormat(String),
}

/// Writes `program` in `format` with `settings`.
///
/// Deterministic: the same input gives the same text. Errors for invalid settings
/// ([`ExportSettings::validate`]) and poses too far away to print; everything the format can
/// express differently (names, unpaired circles, unknown configurations) is a warning.
pub fn export(
    program: &Program<Waypoint>,
    format: Language,
    settings: &ExportSettings,
) -> Result<Exported, ExportError> {
    settings.validate()?;
    for r in &program.routines {
        for (index, w) in r.waypoints.iter().enumerate() {
            let p = w.pose.position();
            if !p
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_COORDINATE_MM)
            {
                return Err(ExportError::PoseOutOfRange {
                    routine: r.name.clone(),
                    seq: index + 1,
                });
            }
        }
    }
    let mut warnings = Vec::new();
    let files = match format {
        Language::Rapid => rapid::write(program, settings, &mut warnings),
        Language::Krl => krl::write(program, settings, &mut warnings)?,
        Language::Fanuc => fanuc::write(program, settings, &mut warnings)?,
    };
    let unknown = program
        .routines
        .iter()
        .flat_map(|r| &r.waypoints)
        .filter(|w| configuration(w, format).is_none())
        .count();
    if unknown > 0 {
        warnings.push(ExportWarning::UnknownConfiguration { count: unknown });
    }
    Ok(Exported { files, warnings })
}

/// The waypoint's configuration when it is in `language`'s notation (one in another notation
/// cannot be written: the default is, as for none).
pub(crate) fn configuration(w: &Waypoint, language: Language) -> Option<&Configuration> {
    w.configuration
        .as_ref()
        .filter(|c| c.language() == language)
}

/// How the arm moves to the waypoint: a waypoint without a motion class is moved to linearly.
fn motion(w: &Waypoint) -> Motion {
    w.motion.unwrap_or(Motion::Linear)
}

/// One move of a routine: a single target, or a circle's via and end point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Step {
    Single { index: usize, motion: Motion },
    Circle { via: usize, to: usize },
}

/// The moves of a routine: consecutive circular waypoints pair as (via, end); a circular one
/// left without a partner becomes a linear move, with a warning.
pub(crate) fn steps(routine: &Routine<Waypoint>, warnings: &mut Vec<ExportWarning>) -> Vec<Step> {
    let w = &routine.waypoints;
    let mut out = Vec::with_capacity(w.len());
    let mut i = 0;
    while i < w.len() {
        let motion = w.get(i).map(motion);
        if motion == Some(Motion::Circular) {
            if w.get(i + 1).map(self::motion) == Some(Motion::Circular) {
                out.push(Step::Circle { via: i, to: i + 1 });
                i += 2;
                continue;
            }
            warnings.push(ExportWarning::UnpairedCircular {
                routine: routine.name.clone(),
                seq: i + 1,
            });
            out.push(Step::Single {
                index: i,
                motion: Motion::Linear,
            });
        } else if let Some(motion) = motion {
            out.push(Step::Single { index: i, motion });
        }
        i += 1;
    }
    out
}

/// `v` with `decimals` decimals, never `-0.000`.
pub(crate) fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// ZYX Euler angles in degrees `(A, B, C)` with `R = Rz(A)·Ry(B)·Rx(C)`, each in
/// `(−180°, 180°]`. `B` comes from the full third row (`atan2`, exact also near ±90°) and `C`
/// from it; `A` is then read from `R·Rx(C)⁻¹·Ry(B)⁻¹`, so the three compose back to `R` to
/// rounding even at gimbal lock, where `A` and `C` alone are not determined.
pub(crate) fn euler_zyx_deg(rotation: &UnitQuaternion<f64>) -> [f64; 3] {
    let m = rotation.to_rotation_matrix();
    let m = m.matrix();
    let b = (-m[(2, 0)]).atan2(m[(2, 1)].hypot(m[(2, 2)]));
    let c = if m[(2, 1)].hypot(m[(2, 2)]) < 1e-12 {
        0.0
    } else {
        m[(2, 1)].atan2(m[(2, 2)])
    };
    let rest = rotation
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -c)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -b);
    let r = rest.to_rotation_matrix();
    let a = r.matrix()[(1, 0)].atan2(r.matrix()[(0, 0)]);
    [a, b, c].map(|v| {
        let d = v.to_degrees();
        if d <= -180.0 { d + 360.0 } else { d }
    })
}

/// The number a frame name ends in, as a controller table index at most `max` (KRL base and
/// tool, FANUC user frame and tool); `what` names the setting in the error.
pub(crate) fn frame_index(what: &'static str, name: &str, max: u32) -> Result<u32, ExportError> {
    frame_number(name)
        .filter(|n| *n <= max)
        .ok_or(ExportError::FrameNumber {
            what,
            name: name.to_string(),
            max,
        })
}

/// The waypoints of a move that the arm does not reach, as `(index, target)`, each with its
/// [`ExportWarning::Unreachable`]; the writer puts its language's comment before the move.
pub(crate) fn unreachable_targets(
    routine: &Routine<Waypoint>,
    name: &str,
    step: &Step,
    target: impl Fn(usize) -> String,
    warnings: &mut Vec<ExportWarning>,
) -> Vec<String> {
    let indices = match *step {
        Step::Single { index, .. } => vec![index],
        Step::Circle { via, to } => vec![via, to],
    };
    let mut out = Vec::new();
    for i in indices {
        if routine.waypoints.get(i).and_then(|w| w.reachable) == Some(false) {
            let t = target(i);
            warnings.push(ExportWarning::Unreachable {
                routine: name.to_string(),
                seq: i + 1,
                target: t.clone(),
            });
            out.push(t);
        }
    }
    out
}

/// The number a frame name ends in (`wobj0` → 0, `tool12` → 12), if any.
pub(crate) fn frame_number(name: &str) -> Option<u32> {
    let digits: String = name
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    digits.parse().ok()
}

/// The pose's position in mm, `x, y, z` printed with [`POSITION_DECIMALS`].
pub(crate) fn position_text(pose: &Pose) -> [String; 3] {
    let p = pose.position();
    [p.x, p.y, p.z].map(|v| fixed(v, POSITION_DECIMALS))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotation_zyx_deg(a: f64, b: f64, c: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_euler_angles(c.to_radians(), b.to_radians(), a.to_radians())
    }

    #[test]
    fn languages_are_asked_for_by_name() {
        for l in Language::ALL {
            assert_eq!(language_named(l.as_str()), Ok(l));
        }
        assert_eq!(language_named("RAPID"), Ok(Language::Rapid));
        let err = language_named("gcode").unwrap_err();
        assert_eq!(err, ExportError::UnknownFormat("gcode".into()));
        assert_eq!(
            err.to_string(),
            "unknown export format \"gcode\" (rapid, krl or fanuc)"
        );
    }

    #[test]
    fn settings_default_validate_and_deserialize() {
        let s = ExportSettings::default();
        assert_eq!(s.validate(), Ok(()));
        let s: ExportSettings = serde_json::from_str(r#"{"speed_mm_s": 250}"#).unwrap();
        assert_eq!(
            (s.speed_mm_s, s.zone_mm, s.tool.as_str()),
            (250.0, 10.0, "tool0")
        );
        assert!(serde_json::from_str::<ExportSettings>(r#"{"speed": 1}"#).is_err());
        for speed in [0.0, -1.0, f64::NAN, f64::INFINITY, 7000.5] {
            let s = ExportSettings {
                speed_mm_s: speed,
                ..ExportSettings::default()
            };
            assert!(
                matches!(s.validate(), Err(ExportError::Speed(_))),
                "{speed}"
            );
        }
        for zone in [-0.1, f64::NAN, 1e4] {
            let s = ExportSettings {
                zone_mm: zone,
                ..ExportSettings::default()
            };
            assert!(matches!(s.validate(), Err(ExportError::Zone(_))), "{zone}");
        }
        let s = ExportSettings {
            tool: "my tool".into(),
            ..ExportSettings::default()
        };
        assert!(matches!(s.validate(), Err(ExportError::FrameName { .. })));
    }

    #[test]
    fn euler_angles_compose_back_also_at_gimbal_lock() {
        let cases = [
            [10.0, 20.0, 30.0],
            [-170.0, 89.9999999, 45.0],
            [30.0, 90.0, -20.0],
            [30.0, -90.0, 60.0],
            [0.0, 0.0, 180.0],
            [179.9, -45.0, -179.9],
        ];
        for [a, b, c] in cases {
            let q = rotation_zyx_deg(a, b, c);
            let [a2, b2, c2] = euler_zyx_deg(&q);
            let back = rotation_zyx_deg(a2, b2, c2);
            assert!(q.angle_to(&back) < 1e-12, "{a} {b} {c} → {a2} {b2} {c2}");
            for v in [a2, b2, c2] {
                assert!(v > -180.0 && v <= 180.0);
            }
        }
    }

    #[test]
    fn numbers_print_without_negative_zero() {
        assert_eq!(fixed(-0.0001, 3), "0.000");
        assert_eq!(fixed(-0.0006, 3), "-0.001");
        assert_eq!(fixed(12.5, 3), "12.500");
        assert_eq!(frame_number("wobj0"), Some(0));
        assert_eq!(frame_number("tool12"), Some(12));
        assert_eq!(frame_number("gun"), None);
    }
}
