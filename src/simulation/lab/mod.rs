//! The dissertation's online lab (§4.5) as programs: a repertoire of four tasks taught again and
//! again by three users, each time with the work piece placed a little differently. `nextpose lab`
//! writes them as corpus JSON, and `nextpose simulate … --history repository-online --operator
//! online` then teaches each one with the earlier ones in the cell, as their users taught them
//! (each waypoint with the online operator's error): the analogue of the dissertation's Table 4.1
//! (§4.5.3), whose model was built from other users' online programs.
//!
//! **The repertoire**: the dissertation's four tasks (§4.5, Figure 4.17: 13, 6, 10 and 10
//! waypoints, a mean spacing of 186 mm), their shapes our assumption; the tasks and their
//! shapes are in `tasks` ([`Task`]).
//!
//! **The programs.** Program `i` is taught by user `i mod 3` and teaches task `i mod 4` (one
//! routine), so every (user, task) pair recurs, and the previous program of the same task is
//! always another user's. The work piece is placed by a rigid move drawn per program: an offset
//! on the table uniform within ±50 mm in x and y and a turn about the vertical uniform within
//! ±15° (our assumption of "a little differently": the dissertation does not say). A program's
//! waypoints are what its user meant: the placed task's poses. That is the simulated operator's
//! target when the program is taught, and the operator's error is added where it is made: when the
//! operator places a waypoint by hand, and when an earlier program becomes a cell's history
//! (`History::RepositoryOnline`), since the dissertation's users taught with a joystick and chose
//! their own "sufficiently close" (§4.5.1). [`LabConfig::as_taught_online`] writes the programs
//! with that error instead ([`super::operator::OperatorModel::place`]'s model: Gaussian, 20 mm 3-D
//! RMS and 0.035 rad RMS, the figures of [`OperatorModel::online`]).
//!
//! **Variants** ([`Repertoire::Variants`], `nextpose lab --repertoire variants`): a pick and
//! place, a pocket, weld stitches and a palletising grid (6, 7, 10 and 12 waypoints, mean
//! steps of 40 to 156 mm), so that what was chosen on the dissertation's four tasks can be checked
//! on shapes it was not chosen on. Placement, users and errors as above.
//!
//! **A welding cell** ([`Repertoire::Welding`], `nextpose lab --repertoire welding`): offline
//! programs of the shape real arc-welding modules have, for `nextpose replay` (the issue's
//! "synthetic welding-like set"): each program welds parts at 3–5 stations, one routine per
//! station from the arm's home ([`HOME_MM`], fixed in the world) back to it; two parts in three
//! are the program's main family (bracket, flange, gusset or frame: 8 to 16 waypoints of seams,
//! each approached and left [`WELD_STANDOFF_MM`] back along the torch), the others one other
//! family; a station's part stands within ±100 mm and ±30° of nominal, at 0.8–1.25 times its
//! nominal size. Written exact, as an offline program is. The dissertation's and the variant labs
//! are unchanged by it (its draws come after theirs).
//!
//! Deterministic given its random seed: program `i` draws from its own ChaCha8 stream, so a lab
//! of fewer programs is a prefix of the full one.

mod tasks;

use std::f64::consts::PI;
use std::path::PathBuf;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::arm::JogLimits;
use super::operator::{OperatorModel, normal};
use crate::engine::Pose;
use crate::program::{Language, NamedArm, Program, Routine};
pub use tasks::{Task, WELD_CLEARANCE_MM, WELD_STANDOFF_MM, mean_spacing_mm};
pub(super) use tasks::{pose, tool_down};

/// The repository every lab program names (`source.repo`): one for the whole lab, so that
/// `--history repository` gives each program the earlier programs of all users, the other
/// users' among them (the dissertation's model was built from other users' programs, §4.5.3).
pub const LAB_REPO: &str = "seed-lab/online-study";

/// The language the programs are recorded in: the dissertation's lab arm was an ABB IRB 140 (§4.5,
/// Figure 4.18), and `rapid` makes the simulation stand the bundled IRB 140 at them.
pub const LAB_LANGUAGE: Language = Language::Rapid;
/// The arm of the dissertation's lab, which its programs name.
pub const LAB_ARM: &str = "IRB 140";

/// Where the work piece's nominal frame is in the robot's world, mm (in front of and above
/// the base; the simulation places its arm per program anyway).
pub const NOMINAL_ORIGIN_MM: [f64; 3] = [500.0, 0.0, 300.0];

/// Offset of the work piece from nominal, each of x and y uniform within ± this, mm.
pub const PLACEMENT_OFFSET_MM: f64 = 50.0;
/// Turn of the work piece about the vertical, uniform within ± this, rad (15°).
pub const PLACEMENT_YAW_RAD: f64 = 15.0 * PI / 180.0;

/// First ChaCha8 stream of the lab (program `i` uses this + `i`): away from stream 0, which
/// the simulated operator's waypoint streams use, so a lab seed and an operator seed that are
/// equal still draw independent errors.
const LAB_STREAM: u64 = 0x5EED_1AB0_0000_0000;

/// Which repertoire a lab teaches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Repertoire {
    /// The dissertation's four tasks ([`Task::DISSERTATION`], what the engine's lab figures were
    /// chosen on).
    #[default]
    Dissertation,
    /// Four other task shapes and spacings (pick and place, pocket, stitches, grid): a lab
    /// the engine was not tuned on.
    Variants,
    /// A welding cell's offline programs ([`Task::WELDING`]): each starts and ends at the
    /// arm's home, welds its part's seams (approach and retract along the torch), and the parts
    /// come in sizes 0.8–1.25 of nominal. Written exact, as offline programs are: a synthetic
    /// welding-like set for `nextpose replay`, checked against the baselines.
    Welding,
}

impl Repertoire {
    pub fn tasks(self) -> &'static [Task] {
        match self {
            Repertoire::Dissertation => &Task::DISSERTATION,
            Repertoire::Variants => &Task::VARIANTS,
            Repertoire::Welding => &Task::WELDING,
        }
    }
}

/// The welding cell's home: the arm's parking pose, fixed in the world (not moved with the
/// part), tool down, mm.
pub const HOME_MM: [f64; 3] = [300.0, 0.0, 600.0];

/// The welding cell's parts are this many times their nominal size, uniform within.
pub const WELD_SIZE_RANGE: (f64, f64) = (0.8, 1.25);

/// A welding cell's program welds a part at each of this many stations (uniform within).
pub const WELD_STATIONS: (usize, usize) = (3, 5);
/// A station's part stands within ± this of nominal in x and y, mm …
pub const WELD_STATION_OFFSET_MM: f64 = 100.0;
/// … turned within ± this about the vertical, rad (30°).
pub const WELD_STATION_YAW_RAD: f64 = 30.0 * PI / 180.0;

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct LabConfig {
    /// Number of programs (the dissertation's: 44).
    pub programs: usize,
    /// Number of users (the dissertation's: 3).
    pub users: usize,
    /// Each user's placement error: 3-D RMS position error, mm …
    pub position_rms_mm: f64,
    /// … and RMS rotation error, rad.
    pub rotation_rms_rad: f64,
    /// Work-piece placement: ± offset in x and y, mm, and ± turn about the vertical, rad.
    pub offset_mm: f64,
    pub yaw_rad: f64,
    /// The tasks: program `i` teaches `tasks[i mod len]`.
    pub repertoire: Repertoire,
}

impl Default for LabConfig {
    /// The dissertation's lab (§4.5): 44 programs, 3 users, written as the users meant them (no
    /// error: `simulate --history repository-online` adds the operator's error to the history).
    fn default() -> LabConfig {
        LabConfig {
            programs: 44,
            users: 3,
            position_rms_mm: 0.0,
            rotation_rms_rad: 0.0,
            offset_mm: PLACEMENT_OFFSET_MM,
            yaw_rad: PLACEMENT_YAW_RAD,
            repertoire: Repertoire::Dissertation,
        }
    }
}

impl LabConfig {
    /// The lab as its users taught it: every waypoint with the simulated online operator's
    /// error.
    pub fn as_taught_online() -> LabConfig {
        let online = OperatorModel::online(JogLimits::default().tcp_mm_s);
        LabConfig {
            position_rms_mm: online.repeatability_mm,
            rotation_rms_rad: online.repeatability_rad,
            ..LabConfig::default()
        }
    }
}

/// One routine of a generated program and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct LabRoutine {
    pub task: Task,
    /// Where the work piece stood (world from work piece).
    pub placement: Isometry3<f64>,
    /// The part's size, times nominal (1 but for the welding cell's parts).
    pub size: f64,
    /// The placed task's waypoints without the user's error.
    pub nominal: Vec<Pose>,
}

/// One generated program and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct LabProgram {
    /// 0-based user.
    pub user: usize,
    /// How each routine was made (one per routine of `program`; the dissertation's and the variant
    /// labs have one).
    pub routines: Vec<LabRoutine>,
    /// The program as taught (each routine's `nominal` plus the error), with [`LAB_REPO`] as
    /// its repository.
    pub program: Program,
}

/// A lab of `config.programs` programs, deterministic given `seed`.
pub fn generate(config: &LabConfig, seed: u64) -> Vec<LabProgram> {
    let width = config.programs.saturating_sub(1).to_string().len().max(2);
    let users = config.users.max(1);
    (0..config.programs)
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(LAB_STREAM.wrapping_add(i as u64));
            let user = i % users;
            let tasks = config.repertoire.tasks();
            let main = tasks[i % tasks.len()];
            let routines = if config.repertoire == Repertoire::Welding {
                welding_cell(config, main, &mut rng)
            } else {
                let placement = draw_placement(
                    Vector3::from(NOMINAL_ORIGIN_MM),
                    config.offset_mm,
                    config.yaw_rad,
                    &mut rng,
                );
                vec![placed_task(config, main, placement, 1.0, &mut rng)]
            };
            let name = format!("lab{i:0width$}_user{}_{}", user + 1, main.name());
            let program = Program {
                source: PathBuf::from(format!("{name}.json")),
                name,
                language: Some(LAB_LANGUAGE),
                repo: Some(LAB_REPO.into()),
                arm: Some(NamedArm {
                    designation: LAB_ARM.into(),
                    found_in: "the seed's online lab (§4.5)".into(),
                }),
                routines: routines.iter().map(|(_, r)| r.clone()).collect(),
            };
            LabProgram {
                user,
                routines: routines.into_iter().map(|(part, _)| part).collect(),
                program,
            }
        })
        .collect()
}

/// A work piece placement as [`LabConfig`] draws it (and the pattern programs): an offset in x
/// and y within ± `offset_mm` of `origin` and a turn about the vertical within ± `yaw_rad`,
/// drawn in that order.
pub(super) fn draw_placement<R: Rng>(
    origin: Vector3<f64>,
    offset_mm: f64,
    yaw_rad: f64,
    rng: &mut R,
) -> Isometry3<f64> {
    let mut uniform = |half: f64| half * (2.0 * rng.random::<f64>() - 1.0);
    let offset = Vector3::new(uniform(offset_mm), uniform(offset_mm), 0.0);
    let yaw = uniform(yaw_rad);
    Isometry3::from_parts(
        Translation3::from(origin + offset),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
    )
}

/// `task` at `size` placed by `placement` (the welding cell's parts between two visits to
/// [`HOME_MM`]), and the routine that teaches it with the users' error.
fn placed_task<R: Rng>(
    config: &LabConfig,
    task: Task,
    placement: Isometry3<f64>,
    size: f64,
    rng: &mut R,
) -> (LabRoutine, Routine) {
    let mut nominal: Vec<Pose> = task
        .waypoints_sized(size)
        .iter()
        .map(|p| Pose::from_isometry(placement * p.isometry()))
        .collect();
    if task.is_welding_cell() {
        let home = pose(Vector3::from(HOME_MM), tool_down());
        nominal.insert(0, home);
        nominal.push(home);
    }
    let waypoints = nominal.iter().map(|p| perturb(p, config, rng)).collect();
    (
        LabRoutine {
            task,
            placement,
            size,
            nominal,
        },
        Routine {
            name: task.name().into(),
            waypoints,
        },
    )
}

/// A welding cell's program ([`Repertoire::Welding`]): [`WELD_STATIONS`] routines, one per
/// station, each welding a part placed there at its own size; two parts in three are the
/// program's `main` family, the others one other family drawn for the program.
fn welding_cell<R: Rng>(config: &LabConfig, main: Task, rng: &mut R) -> Vec<(LabRoutine, Routine)> {
    let (lo, hi) = WELD_STATIONS;
    let stations = rng.random_range(lo..=hi);
    let at = Task::WELDING.iter().position(|t| *t == main).unwrap_or(0);
    let other =
        Task::WELDING[(at + rng.random_range(1..Task::WELDING.len())) % Task::WELDING.len()];
    (0..stations)
        .map(|k| {
            let task = if rng.random::<f64>() < 2.0 / 3.0 {
                main
            } else {
                other
            };
            let placement = draw_placement(
                Vector3::from(NOMINAL_ORIGIN_MM),
                WELD_STATION_OFFSET_MM,
                WELD_STATION_YAW_RAD,
                rng,
            );
            let (s_lo, s_hi) = WELD_SIZE_RANGE;
            let size = s_lo + (s_hi - s_lo) * rng.random::<f64>();
            let (part, mut routine) = placed_task(config, task, placement, size, rng);
            routine.name = format!("station{}_{}", k + 1, task.name());
            (part, routine)
        })
        .collect()
}

/// `p` with a user's placement error: Gaussian in position (per axis RMS/√3) and a rotation
/// about a Gaussian axis in the tool frame, as [`OperatorModel::place`] draws it.
fn perturb<R: Rng>(p: &Pose, config: &LabConfig, rng: &mut R) -> Pose {
    let s = config.position_rms_mm / 3f64.sqrt();
    let sr = config.rotation_rms_rad / 3f64.sqrt();
    let dp = Vector3::new(normal(rng), normal(rng), normal(rng)) * s;
    let dr = Vector3::new(normal(rng), normal(rng), normal(rng)) * sr;
    pose(
        p.position() + dp,
        p.rotation() * UnitQuaternion::from_scaled_axis(dr),
    )
}

/// Where the work piece's origin stood, mm: handy to compare placements.
pub fn placement_origin(placement: &Isometry3<f64>) -> Point3<f64> {
    placement * Point3::origin()
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use super::*;

    #[test]
    fn the_dissertations_irb_140_reaches_nearly_every_waypoint_as_the_simulation_places_it() {
        use crate::kinematics::placement::{ArmChoice, ReachCheck, ReachSetup};
        let check = ReachCheck::new(ReachSetup::default()).unwrap();
        let lab = generate(&LabConfig::default(), 1);
        let mut missed = Vec::new();
        for p in &lab {
            let poses: Vec<Pose> = p.program.poses().copied().collect();
            let named = p.program.arm_designation();
            let arm = check
                .place(LAB_LANGUAGE.as_str(), named, &poses)
                .unwrap()
                .unwrap();
            assert_eq!(
                (arm.arm.robot.as_str(), arm.arm.chosen),
                ("abb_irb140", ArmChoice::Named)
            );
            for (i, w) in poses.iter().enumerate() {
                if !check.reaches(&arm.robot, &arm.cell, w) {
                    missed.push(format!("{} #{i}", p.program.name));
                }
            }
        }
        // The far side of the pipe seam (torch pointing back at the base) is at the edge of the
        // IRB 140's reach: an unlucky placement and error can put a waypoint just beyond it.
        let total: usize = lab.iter().map(|p| p.program.waypoint_count()).sum();
        assert!(
            missed.len() * 100 <= total,
            "{} of {total} out of reach: {missed:?}",
            missed.len()
        );
    }

    /// The variants are other shapes with other spacings (all under the dissertation's 186 mm), and
    /// the IRB 140 reaches them as the simulation places it.
    #[test]
    fn the_variant_repertoire_is_other_tasks_the_arm_reaches() {
        let counts: Vec<usize> = Task::VARIANTS.iter().map(|t| t.waypoints().len()).collect();
        assert_eq!(counts, [6, 7, 10, 12]);
        for t in Task::VARIANTS {
            let m = mean_spacing_mm(&t.waypoints());
            assert!((40.0..170.0).contains(&m), "{}: {m}", t.name());
        }
        let config = LabConfig {
            repertoire: Repertoire::Variants,
            ..LabConfig::default()
        };
        let lab = generate(&config, 1);
        assert_eq!(lab[2].routines[0].task, Task::Stitches);
        the_irb140_reaches_all_of(&lab);
    }

    /// The IRB 140 stands at each program (as the simulation places it) and reaches every
    /// waypoint.
    fn the_irb140_reaches_all_of(lab: &[LabProgram]) {
        use crate::kinematics::placement::{ReachCheck, ReachSetup};
        let check = ReachCheck::new(ReachSetup::default()).unwrap();
        for p in lab {
            let poses: Vec<Pose> = p.program.poses().copied().collect();
            let arm = check
                .place(LAB_LANGUAGE.as_str(), p.program.arm_designation(), &poses)
                .unwrap()
                .unwrap();
            assert_eq!(arm.arm.robot, "abb_irb140");
            assert_eq!(arm.arm.reached, poses.len(), "{}", p.program.name);
        }
    }

    /// The welding cell's programs: 3–5 routines, each from home to home around one part of
    /// the program's two families, at its own station and size, every seam approached and left
    /// along the torch; the IRB 140 reaches all of it as the simulation places it.
    #[test]
    fn a_welding_cell_welds_parts_of_two_families_at_stations_from_home() {
        let config = LabConfig {
            programs: 8,
            repertoire: Repertoire::Welding,
            ..LabConfig::default()
        };
        let lab = generate(&config, 1);
        let home = pose(Vector3::from(HOME_MM), tool_down());
        let mut sizes = Vec::new();
        for (i, p) in lab.iter().enumerate() {
            let (lo, hi) = WELD_STATIONS;
            assert!((lo..=hi).contains(&p.routines.len()), "{}", p.program.name);
            assert_eq!(p.program.routines.len(), p.routines.len());
            let families: HashSet<Task> = p.routines.iter().map(|r| r.task).collect();
            assert!(families.len() <= 2 && families.iter().all(|t| t.is_welding_cell()));
            assert!(p.program.name.ends_with(Task::WELDING[i % 4].name()));
            for (r, routine) in p.routines.iter().zip(&p.program.routines) {
                let w = &routine.waypoints;
                assert_eq!(w.len(), r.task.waypoints().len() + 2);
                for end in [&w[0], &w[w.len() - 1]] {
                    assert!(end.distance_to(&home) < 1e-9 && end.angle_to(&home) < 1e-9);
                }
                // Each seam: approach, points, retract; approach and retract stand back along
                // the torch by the standoff, whatever the size.
                let (a, s) = (&w[1], &w[2]);
                let back = s.position() - s.rotation() * Vector3::z() * WELD_STANDOFF_MM;
                assert!((a.position() - back).norm() < 1e-9);
                assert!((WELD_SIZE_RANGE.0..=WELD_SIZE_RANGE.1).contains(&r.size));
                sizes.push(r.size);
            }
        }
        the_irb140_reaches_all_of(&lab);
        // Parts come in sizes: a seam of a bigger part is longer.
        sizes.sort_by(f64::total_cmp);
        assert!(sizes[sizes.len() - 1] - sizes[0] > 0.2, "{sizes:?}");
        let bracket = |size: f64| Task::Bracket.waypoints_sized(size);
        let (small, big) = (bracket(0.8), bracket(1.25));
        assert!(
            (big[1].distance_to(&big[2]) / small[1].distance_to(&small[2]) - 1.25 / 0.8).abs()
                < 1e-9
        );
        assert!((big[0].distance_to(&big[1]) - WELD_STANDOFF_MM).abs() < 1e-9);
    }

    #[test]
    fn generation_is_deterministic_and_prefix_stable() {
        let small = LabConfig {
            programs: 5,
            ..LabConfig::default()
        };
        let a = generate(&small, 7);
        assert_eq!(a, generate(&small, 7));
        let full = generate(&LabConfig::default(), 7);
        assert_eq!(full.len(), 44);
        assert_eq!(&full[..5], &a[..]);
        assert_ne!(generate(&small, 8)[0].program, a[0].program);
    }
}
