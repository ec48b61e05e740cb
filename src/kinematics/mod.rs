//! Robot models, forward kinematics, all inverse-kinematics solutions, and reachability of a
//! predicted pose. Pure computation: the only I/O is reading URDF files (and listing the
//! `robots/` directory) when a model is loaded.
//!
//! - [`urdf`]: loads a serial six-revolute chain from URDF ([`Chain`]), FK and Jacobian.
//! - [`opw`]: closed-form IK of ortho-parallel arms with a spherical wrist (`rs-opw-kinematics`).
//! - [`ur`]: closed-form IK of the Universal Robots family (ours).
//! - [`configuration`]: arm configuration (shoulder, elbow, wrist flip, turns) of a joint
//!   vector as RAPID `confdata`, KRL Status/Turn and FANUC `CONFIG`; the IK solution it names.
//! - [`reach`]: reachability of a target in a cell (base and tool frames, limits, singularity).
//! - [`units`]: the one conversion between the crate's millimetres and URDF metres.
//! - [`catalog`]: the bundled arms' data sheets (`robots/catalog.json`) and computed reach.
//! - [`designation`]: arm model designations in text (`IRB 6700-205/2.80`) and their library arm.
//! - [`layout`]: the cell-layout search: robot bases that reach a program's waypoints.
//! - [`placement`]: which arm stands where for a recorded program whose cell is not known.
//!
//! Both solvers derive their parameters from the URDF chain and are checked against its FK when
//! the model is built, so a [`Robot`] is always self-consistent. The solvers return principal
//! angles; [`Robot::ik`] maps each joint into its real range and enumerates the multi-turn
//! variants of joints whose range exceeds 360° (IRB 140 J6 ±400°, UR joints ±360°), and keeps
//! only solutions that the chain's FK confirms.
//!
//! For the service (all types `Send + Sync`; results `Serialize`):
//!
//! ```text
//! list_robots(&bundled_robots_dir())?            -> Vec<RobotModel>   GET /v1/robots
//! load_robot(&dir, "abb_irb140")?                 -> Robot             once per cell, then shared
//! Mounting::new(base, tool)                           base: robot base in the work frame; tool: TCP on tool0
//! check_reach(&robot, &cell, &target, prev, &cfg) -> Reachability      per predicted pose (mm)
//! reachability.offer(cfg.policy)                  -> Offer::{Offer, Flag, Withhold}
//! robot.ik(&flange) / robot.fk(&q)                 all solutions / tool0 pose, base frame, mm
//! ```

pub mod bundled;
pub mod catalog;
pub mod configuration;
pub mod designation;
pub mod error;
pub mod fixture;
pub mod layout;
pub mod opw;
pub mod placement;
pub mod reach;
pub mod units;
pub mod ur;
pub mod urdf;

use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Matrix6};
use serde::Serialize;

use crate::engine::Pose;

pub use bundled::{bundled_catalog, bundled_files, bundled_robot, bundled_robots};
pub use catalog::{ArmFacts, computed_reach_mm, load_catalog, parse_catalog};
pub use configuration::{
    ArmConfiguration, ConfigurationError, Elbow, Shoulder, Wrist, configuration, pick_solution,
};
pub use error::KinematicsError;
pub use layout::{
    BaseMounting, LayoutError, LayoutOptions, Placement, evaluate_placement, search_layout,
};
pub use opw::OpwSolver;
pub use reach::{
    JointMargin, Mounting, Offer, ReachConfig, ReachPolicy, Reachability, Unreachable, check_reach,
    ready_joints,
};
pub use units::{MM_PER_M, metres_to_pose, pose_to_metres};
pub use ur::UrSolver;
pub use urdf::{Chain, DOF, JointSpec, Joints};

/// A solution is kept only when the chain's FK puts the tip this close to the target (metres).
pub const SOLUTION_TOL_M: f64 = 1e-9;
/// … and this close in orientation (radians).
pub const SOLUTION_TOL_RAD: f64 = 1e-9;

/// How far (radians) a joint value may lie beyond a limit and still count as on it. The solvers
/// recover a joint to about 1e-12 rad, so a pose taught exactly at a limit comes back on either
/// side of it by round-off, and an exact comparison kept or dropped it (and its multi-turn
/// variants) by chance. 1e-9 rad is the FK check's own tolerance ([`SOLUTION_TOL_RAD`]) and a
/// nanometre a metre out; a value within it is clamped onto the limit, so every solution
/// [`Robot::ik`] returns is within the limits exactly.
pub const LIMIT_TOL_RAD: f64 = 1e-9;

/// Angle wrapped into `(-π, π]`.
pub fn wrap_angle(a: f64) -> f64 {
    let r = a.rem_euclid(TAU);
    if r > PI { r - TAU } else { r }
}

/// Translation (m) and rotation (rad) difference of two poses.
pub fn pose_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        a.rotation.angle_to(&b.rotation),
    )
}

/// Compares a derived analytic model with the chain at a fixed set of joint vectors; the error
/// is the largest translation (m) or rotation (rad) difference.
pub(crate) fn check_against_chain(
    chain: &Chain,
    model: impl Fn(&Joints) -> Option<Isometry3<f64>>,
) -> Result<(), f64> {
    const PROBES: [Joints; 5] = [
        [0.0; DOF],
        [0.3, -0.7, 1.1, -2.0, 0.9, 2.5],
        [-2.2, 0.4, -0.3, 1.3, -1.7, -0.6],
        [1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        [3.0, -1.4, 2.6, -3.1, 0.2, -2.9],
    ];
    let mut worst = 0.0f64;
    for q in &PROBES {
        let Some(m) = model(q) else {
            return Err(f64::INFINITY);
        };
        let (dt, dr) = pose_error(&m, &chain.fk(q));
        worst = worst.max(dt).max(dr);
    }
    if worst <= 1e-10 { Ok(()) } else { Err(worst) }
}

/// Which closed-form solver a robot uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// Ortho-parallel basis with a spherical wrist (`rs-opw-kinematics`).
    Opw,
    /// Universal Robots geometry (our analytic solver).
    Ur,
}

#[derive(Debug, Clone)]
enum Solver {
    Opw(Box<OpwSolver>),
    Ur(UrSolver),
}

/// A robot's description for listing (`GET /v1/robots`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotModel {
    /// Model name: the URDF file's stem (`abb_irb140`).
    pub name: String,
    pub solver: SolverKind,
    /// Root and tip links of the chain; poses are tip (`tool0`) poses in the root frame.
    pub root: String,
    pub tip: String,
    pub joints: Vec<JointSpec>,
}

/// A loaded arm: its chain, limits and closed-form solver.
#[derive(Debug, Clone)]
pub struct Robot {
    name: String,
    chain: Chain,
    solver: Solver,
    /// See [`Robot::characteristic_length_m`].
    length_m: f64,
}

impl Robot {
    /// Builds a robot from URDF text; `name` is how the service refers to it.
    pub fn from_urdf_str(name: &str, urdf: &str) -> Result<Robot, KinematicsError> {
        Robot::from_chain(name, Chain::from_urdf_str(urdf, None)?)
    }

    /// Reads a URDF file; the model is named after the file stem.
    pub fn from_urdf_file(path: &Path) -> Result<Robot, KinematicsError> {
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Robot::from_chain(&name, Chain::from_urdf_file(path, None)?)
    }

    /// Picks the solver that fits the chain: OPW first, then UR.
    pub fn from_chain(name: &str, chain: Chain) -> Result<Robot, KinematicsError> {
        let solver = match OpwSolver::from_chain(&chain) {
            Ok(s) => Solver::Opw(Box::new(s)),
            Err(opw_err) => match UrSolver::from_chain(&chain) {
                Ok(s) => Solver::Ur(s),
                Err(ur_err) => {
                    return Err(KinematicsError::UnsupportedGeometry(format!(
                        "{opw_err}; {ur_err}"
                    )));
                }
            },
        };
        let opw = match &solver {
            Solver::Opw(s) => Some(s.as_ref()),
            Solver::Ur(_) => None,
        };
        let length_m = catalog::reach_mm(&chain, opw) / MM_PER_M;
        if !(length_m.is_finite() && length_m > 0.0) {
            return Err(KinematicsError::UnsupportedGeometry(format!(
                "the arm's reach is {length_m} m"
            )));
        }
        Ok(Robot {
            name: name.to_string(),
            chain,
            solver,
            length_m,
        })
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    pub fn joints(&self) -> &[JointSpec] {
        self.chain.joints()
    }

    pub fn solver_kind(&self) -> SolverKind {
        match self.solver {
            Solver::Opw(_) => SolverKind::Opw,
            Solver::Ur(_) => SolverKind::Ur,
        }
    }

    /// The OPW model, when the robot uses it.
    pub fn opw(&self) -> Option<&OpwSolver> {
        match &self.solver {
            Solver::Opw(s) => Some(s),
            Solver::Ur(_) => None,
        }
    }

    /// The UR model, when the robot uses it.
    pub fn ur(&self) -> Option<&UrSolver> {
        match &self.solver {
            Solver::Ur(s) => Some(s),
            Solver::Opw(_) => None,
        }
    }

    pub fn model(&self) -> RobotModel {
        RobotModel {
            name: self.name.clone(),
            solver: self.solver_kind(),
            root: self.chain.root().to_string(),
            tip: self.chain.tip().to_string(),
            joints: self.chain.joints().to_vec(),
        }
    }

    /// Whether every joint is within its limits (up to [`LIMIT_TOL_RAD`]).
    pub fn within_limits(&self, q: &Joints) -> bool {
        q.iter()
            .zip(self.joints())
            .all(|(v, j)| *v >= j.lower - LIMIT_TOL_RAD && *v <= j.upper + LIMIT_TOL_RAD)
    }

    /// Checks that the arm can be at `q`: every value finite and within its joint's range (up
    /// to [`LIMIT_TOL_RAD`]). For joints a client says the arm is at, such as the `near` of a
    /// reach question: the solution nearest a vector it cannot take means nothing, and values
    /// like 1e308 overflow the distance and made the choice arbitrary.
    pub fn check_joints(&self, q: &Joints) -> Result<(), KinematicsError> {
        if !q.iter().all(|v| v.is_finite()) {
            return Err(KinematicsError::NonFiniteJoints);
        }
        let outside = q
            .iter()
            .zip(self.joints())
            .enumerate()
            .find(|(_, (v, j))| **v < j.lower - LIMIT_TOL_RAD || **v > j.upper + LIMIT_TOL_RAD);
        match outside {
            None => Ok(()),
            Some((joint, (value, j))) => Err(KinematicsError::JointOutOfRange {
                joint: joint + 1,
                name: j.name.clone(),
                value: *value,
                lower: j.lower,
                upper: j.upper,
            }),
        }
    }

    /// The length (m) that makes the Jacobian's linear rows commensurate with its angular ones:
    /// the arm's reach ([`computed_reach_mm`]). See [`Robot::sigma_min`].
    pub fn characteristic_length_m(&self) -> f64 {
        self.length_m
    }

    /// How far `q` is from a singularity: the smallest singular value of the flange Jacobian
    /// with its linear rows divided by [`Robot::characteristic_length_m`].
    ///
    /// The plain Jacobian mixes metres (linear rows) and radians (angular rows), so its singular
    /// values depend on the unit of length and the arm's size: on a small arm every position
    /// direction looks weak, and the UR3e (0.5 m) was called singular twice as often as the
    /// UR10e at random poses. In reach units the measure is dimensionless and the same for an
    /// arm and a scaled copy of it; on every bundled arm it is about 0.25 × the angle (rad) of
    /// J5 from zero near the wrist singularity and 0.18 × the angle from the stretched elbow
    /// (medians over random poses), so one threshold means the same for all of them
    /// ([`ReachConfig::min_singular_value`]).
    pub fn sigma_min(&self, q: &Joints) -> f64 {
        let mut jac = self.jacobian(q);
        jac.fixed_view_mut::<3, DOF>(0, 0)
            .scale_mut(1.0 / self.length_m);
        jac.singular_values().min()
    }

    /// Tip pose in the robot base frame, mm.
    pub fn fk(&self, q: &Joints) -> Pose {
        metres_to_pose(&self.chain.fk(q))
    }

    /// Each joint's frame after its rotation, in the robot base frame, mm (see
    /// [`Chain::joint_frames`]); the last one carries the flange, [`Robot::fk`].
    pub fn joint_frames(&self, q: &Joints) -> [Pose; DOF] {
        self.chain.joint_frames(q).map(|f| metres_to_pose(&f))
    }

    /// Geometric Jacobian at the tip (metres, radians), from the URDF chain.
    pub fn jacobian(&self, q: &Joints) -> Matrix6<f64> {
        self.chain.jacobian(q)
    }

    /// Every IK solution for a tip pose in the base frame (mm) that lies within the joint
    /// limits, multi-turn variants included. Empty when the pose is out of reach or every
    /// solution violates a limit ([`check_reach`] says which).
    pub fn ik(&self, tip: &Pose) -> Vec<Joints> {
        self.ik_metres(&pose_to_metres(tip), None)
    }

    /// As [`Robot::ik`], tip in metres; `hint` picks the free joints at a wrist singularity.
    pub fn ik_metres(&self, tip: &Isometry3<f64>, hint: Option<&Joints>) -> Vec<Joints> {
        let principal = self.ik_principal(tip, hint);
        let mut out = Vec::with_capacity(principal.len() * self.max_variants());
        for q in principal {
            self.push_variants(&q, &mut out);
        }
        out
    }

    /// The distinct solutions with each joint in `(-π, π]`, limits ignored, each confirmed by
    /// the chain's FK within [`SOLUTION_TOL_M`] / [`SOLUTION_TOL_RAD`].
    pub fn ik_principal(&self, tip: &Isometry3<f64>, hint: Option<&Joints>) -> Vec<Joints> {
        let mut raw = Vec::with_capacity(8);
        match &self.solver {
            Solver::Opw(s) => s.solve(tip, hint, &mut raw),
            Solver::Ur(s) => s.solve(tip, hint, &mut raw),
        }
        let mut out: Vec<Joints> = Vec::with_capacity(raw.len());
        for q in raw {
            let duplicate = out.iter().any(|o| {
                o.iter()
                    .zip(&q)
                    .all(|(a, b)| wrap_angle(a - b).abs() < 1e-9)
            });
            if duplicate {
                continue;
            }
            let (dt, dr) = pose_error(&self.chain.fk(&q), tip);
            if dt <= SOLUTION_TOL_M && dr <= SOLUTION_TOL_RAD {
                out.push(q);
            }
        }
        out
    }

    /// Appends every `q + 2πk` (per joint) that lies within the limits, up to [`LIMIT_TOL_RAD`],
    /// clamped onto them.
    pub(crate) fn push_variants(&self, q: &Joints, out: &mut Vec<Joints>) {
        // Per joint at most ceil(range / 2π) + 1 values; 4 covers ranges up to 1080°.
        let mut values = [[0.0f64; 4]; DOF];
        let mut counts = [0usize; DOF];
        for (i, j) in self.joints().iter().enumerate() {
            let kmin = ((j.lower - LIMIT_TOL_RAD - q[i]) / TAU).ceil() as i64;
            let kmax = ((j.upper + LIMIT_TOL_RAD - q[i]) / TAU).floor() as i64;
            for k in kmin..=kmax {
                if counts[i] < 4 {
                    values[i][counts[i]] = (q[i] + TAU * k as f64).clamp(j.lower, j.upper);
                    counts[i] += 1;
                }
            }
            if counts[i] == 0 {
                return;
            }
        }
        let mut idx = [0usize; DOF];
        loop {
            let mut v = [0.0; DOF];
            for i in 0..DOF {
                v[i] = values[i][idx[i]];
            }
            out.push(v);
            let mut i = 0;
            loop {
                idx[i] += 1;
                if idx[i] < counts[i] {
                    break;
                }
                idx[i] = 0;
                i += 1;
                if i == DOF {
                    return;
                }
            }
        }
    }

    /// The most multi-turn variants one principal solution can have (product over joints of the
    /// values `q + 2πk` a range can hold), for sizing buffers.
    pub fn max_variants(&self) -> usize {
        self.joints()
            .iter()
            .map(|j| ((j.upper - j.lower + 2.0 * LIMIT_TOL_RAD) / TAU).floor() as usize + 1)
            .product()
    }

    /// For a principal solution, the smallest distance (rad) by which each joint misses its
    /// range over all multi-turn variants; zero where a variant fits (up to [`LIMIT_TOL_RAD`]).
    pub fn limit_excess(&self, q: &Joints) -> [f64; DOF] {
        let mut excess = [0.0; DOF];
        for (i, j) in self.joints().iter().enumerate() {
            let centre = 0.5 * (j.lower + j.upper);
            // The variant nearest the range centre misses the range by the least.
            let v = q[i] + TAU * ((centre - q[i]) / TAU).round();
            let miss = (j.lower - v).max(v - j.upper);
            excess[i] = if miss > LIMIT_TOL_RAD { miss } else { 0.0 };
        }
        excess
    }
}

/// The folder the bundled models are built from, in the checkout the crate was compiled in
/// (`robots/`): for tests and benches that read the files themselves. The service never reads
/// it: it carries the models ([`bundled`]), so a binary copied elsewhere works alone.
pub fn bundled_robots_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("robots")
}

/// Loads every `*.urdf` in `dir`, sorted by name. A file that does not load is an error: a
/// model directory is configuration and should be fixed, not skipped.
pub fn load_robots(dir: &Path) -> Result<Vec<Robot>, KinematicsError> {
    let entries = std::fs::read_dir(dir).map_err(|e| KinematicsError::io(dir, &e))?;
    let mut paths: Vec<PathBuf> = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| KinematicsError::io(dir, &e))?.path();
        if path.extension().is_some_and(|e| e == "urdf") {
            paths.push(path);
        }
    }
    paths.sort();
    paths.iter().map(|p| Robot::from_urdf_file(p)).collect()
}

/// The descriptions of every model in `dir` (for `GET /v1/robots`).
pub fn list_robots(dir: &Path) -> Result<Vec<RobotModel>, KinematicsError> {
    Ok(load_robots(dir)?.iter().map(Robot::model).collect())
}

/// Loads one model by name (`abb_irb140` → `dir/abb_irb140.urdf`). Names are restricted to
/// letters, digits, `_` and `-`, so a name cannot reach outside `dir`.
pub fn load_robot(dir: &Path, name: &str) -> Result<Robot, KinematicsError> {
    let valid = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    let path = dir.join(format!("{name}.urdf"));
    if !valid || !path.is_file() {
        return Err(KinematicsError::UnknownRobot(name.to_string()));
    }
    Robot::from_urdf_file(&path)
}
