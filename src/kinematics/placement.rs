//! Where an arm stands for a recorded program whose cell is not known: the corpus gives poses in
//! each instruction's work-object frame and never says where the robot stands or which tool it
//! holds, so the arm is placed per program: the robot base is put so that the centre of the
//! program's taught waypoints (the per-axis median, so a few far-off points do not move it) lies
//! at a comfortable point of the arm's workspace (in front of the base at
//! [`ReachSetup::centroid_in_base_mm`]), with the base axes parallel to the work-object frame and
//! the TCP at the flange (`tool0`). The replay's reach figures and the simulated arm use it.

use nalgebra::{Isometry3, Translation3, Vector3};
use serde::Serialize;

use super::{
    KinematicsError, Mounting, ReachConfig, Robot, bundled_robots_dir, check_reach, load_robot,
};
use crate::engine::Pose;

/// Which arm is checked, for which programs, and where it is placed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReachSetup {
    /// Bundled robot model (`robots/<name>.urdf`).
    pub robot: String,
    /// Program languages the arm stands for (`rapid` for an ABB arm).
    pub languages: Vec<String>,
    /// Where the centre (per-axis median) of the program's waypoints sits in the robot base
    /// frame, mm.
    pub centroid_in_base_mm: [f64; 3],
}

impl Default for ReachSetup {
    /// An IRB 140 for the ABB (RAPID) programs, the centroid 450 mm in front of the base and
    /// 350 mm up (about the middle of its 810 mm reach, at shoulder height).
    fn default() -> ReachSetup {
        ReachSetup {
            robot: "abb_irb140".to_string(),
            languages: vec!["rapid".to_string()],
            centroid_in_base_mm: [450.0, 0.0, 350.0],
        }
    }
}

/// A loaded [`ReachSetup`].
#[derive(Debug, Clone)]
pub struct ReachCheck {
    setup: ReachSetup,
    robot: Robot,
    config: ReachConfig,
}

impl ReachCheck {
    /// Loads the setup's robot from the bundled models.
    pub fn new(setup: ReachSetup) -> Result<ReachCheck, KinematicsError> {
        let robot = load_robot(&bundled_robots_dir(), &setup.robot)?;
        Ok(ReachCheck {
            setup,
            robot,
            config: ReachConfig::default(),
        })
    }

    /// The cell of a program in `language` taught at `poses`, or `None` when the arm does not
    /// stand for that language (or there is no pose).
    pub fn cell_for<'a>(
        &self,
        language: &str,
        poses: impl IntoIterator<Item = &'a Pose>,
    ) -> Option<Mounting> {
        if !self.setup.languages.iter().any(|l| l == language) {
            return None;
        }
        let positions: Vec<Vector3<f64>> = poses.into_iter().map(|w| w.position()).collect();
        if positions.is_empty() {
            return None;
        }
        let median = |axis: usize| {
            let mut v: Vec<f64> = positions.iter().map(|p| p[axis]).collect();
            v.sort_by(f64::total_cmp);
            let m = v.len() / 2;
            if v.len().is_multiple_of(2) {
                0.5 * (v[m - 1] + v[m])
            } else {
                v[m]
            }
        };
        let centroid = Vector3::new(median(0), median(1), median(2));
        let [x, y, z] = self.setup.centroid_in_base_mm;
        let base = centroid - Vector3::new(x, y, z);
        Some(Mounting::new(
            Pose::from_isometry(Isometry3::from_parts(
                Translation3::from(base),
                nalgebra::UnitQuaternion::identity(),
            )),
            Pose::identity(),
        ))
    }

    pub fn reachable(&self, cell: &Mounting, target: &Pose) -> bool {
        check_reach(&self.robot, cell, target, None, &self.config).is_reachable()
    }
}
