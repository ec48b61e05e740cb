//! Which arm stands where for a recorded program whose cell is not known. The corpus gives
//! poses in each instruction's work-object frame and never says where the robot stands; some
//! programs say which arm they were written for (a header comment, a serial number: see
//! [`super::designation`]), most do not. The replay's reach figures and the simulated arm use
//! what is chosen here:
//!
//! - [`ReachSetup::Fitted`] (the default): the arm the program names, if the library has its
//!   family; else the library's arms for the program's language (ABB for RAPID, KUKA for KRL,
//!   FANUC for TP), smallest data-sheet reach first, and the first whose layout search
//!   ([`super::layout`]) reaches every taught waypoint, else the one that reaches the most (the
//!   smaller on a tie). The arm stands where its layout search puts it, TCP at the flange.
//! - [`ReachSetup::Heuristic`]: one arm for the programs of its languages, its base put so that
//!   the program's per-axis median waypoint lies at a comfortable point in front of it
//!   ([`HeuristicSetup::centroid_in_base_mm`]), axes parallel to the work-object frame; what the
//!   replay and the simulation did before the library (an IRB 140 for RAPID).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::catalog::{ArmFacts, load_catalog};
use super::designation::catalog_arm;
use super::layout::{LayoutError, LayoutOptions, search_layout};
use super::{
    KinematicsError, Mounting, ReachConfig, Robot, bundled_robots_dir, check_reach, load_robot,
};
use crate::engine::{Pose, PoseValues};

/// How the arm of a recorded program is chosen and placed.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "placement", rename_all = "snake_case")]
pub enum ReachSetup {
    /// The program's own arm, else the best-fitting arm of the library for its language, placed
    /// by the layout search (module documentation).
    Fitted(FitSetup),
    /// One arm for the programs of its languages, placed by the median heuristic.
    Heuristic(HeuristicSetup),
}

impl Default for ReachSetup {
    fn default() -> ReachSetup {
        ReachSetup::Fitted(FitSetup::default())
    }
}

/// The layout search's settings for [`ReachSetup::Fitted`] (the rest are
/// [`LayoutOptions::default`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitSetup {
    /// Random seed of the search's coarse stage: the same program gets the same placement.
    pub seed: u64,
    /// Evaluations per arm tried ([`LayoutOptions::evaluations`]).
    pub evaluations: usize,
}

impl Default for FitSetup {
    fn default() -> FitSetup {
        FitSetup {
            seed: 0,
            evaluations: LayoutOptions::default().evaluations,
        }
    }
}

/// [`ReachSetup::Heuristic`]: which arm, for which programs, and where it stands.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeuristicSetup {
    /// Bundled robot model (`robots/<name>.urdf`).
    pub robot: String,
    /// Program languages the arm stands for (`rapid` for an ABB arm).
    pub languages: Vec<String>,
    /// Where the centre (per-axis median) of the program's waypoints sits in the robot base
    /// frame, mm.
    pub centroid_in_base_mm: [f64; 3],
}

impl Default for HeuristicSetup {
    /// An IRB 140 for the ABB (RAPID) programs, the centroid 450 mm in front of the base and
    /// 350 mm up (about the middle of its 810 mm reach, at shoulder height).
    fn default() -> HeuristicSetup {
        HeuristicSetup {
            robot: "abb_irb140".to_string(),
            languages: vec!["rapid".to_string()],
            centroid_in_base_mm: [450.0, 0.0, 350.0],
        }
    }
}

/// How a program's arm was chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArmChoice {
    /// The program names it (its family is in the library).
    Named,
    /// The smallest library arm for the language that reaches every waypoint.
    Fitted,
    /// No library arm for the language reaches every waypoint: the one that reaches the most.
    Partial,
    /// [`ReachSetup::Heuristic`]'s arm.
    Heuristic,
}

impl ArmChoice {
    /// The name in reports (as serialised: `named`, `fitted`, `partial`, `heuristic`).
    pub fn name(self) -> &'static str {
        match self {
            ArmChoice::Named => "named",
            ArmChoice::Fitted => "fitted",
            ArmChoice::Partial => "partial",
            ArmChoice::Heuristic => "heuristic",
        }
    }
}

/// A program's arm and placement, and how many of its taught waypoints it reaches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProgramArm {
    /// Robot model (`abb_irb6700`).
    pub robot: String,
    /// The maker's designation of the model, from the catalogue (`IRB 6700-205/2.80`).
    pub model: Option<String>,
    pub chosen: ArmChoice,
    /// The designation the program names, when it names one (also when the library has no arm
    /// of that family and another was fitted).
    pub named: Option<String>,
    /// Robot base in the work frame, mm.
    pub base: PoseValues,
    /// Taught waypoints the arm reaches from there ([`check_reach`], no previous joints).
    pub reached: usize,
    pub waypoints: usize,
}

/// A program's arm, loaded, where it stands.
#[derive(Debug, Clone)]
pub struct PlacedArm {
    pub arm: ProgramArm,
    pub robot: Robot,
    pub cell: Mounting,
}

/// A loaded [`ReachSetup`]: its arms, ready to place programs.
#[derive(Debug, Clone)]
pub struct ReachCheck {
    setup: ReachSetup,
    /// The library (fitted) or the one arm (heuristic), with its catalogue facts where known.
    arms: Vec<(Option<ArmFacts>, Robot)>,
    config: ReachConfig,
}

impl ReachCheck {
    /// Loads the setup's arms from the bundled models: every catalogued arm for
    /// [`ReachSetup::Fitted`], the named one for [`ReachSetup::Heuristic`].
    pub fn new(setup: ReachSetup) -> Result<ReachCheck, KinematicsError> {
        let dir = bundled_robots_dir();
        let catalog = load_catalog(&dir)?;
        let arms = match &setup {
            ReachSetup::Fitted(_) => catalog
                .into_iter()
                .map(|f| Ok((load_robot(&dir, &f.name)?, f)))
                .map(|r: Result<_, KinematicsError>| r.map(|(robot, f)| (Some(f), robot)))
                .collect::<Result<Vec<_>, _>>()?,
            ReachSetup::Heuristic(h) => {
                let facts = catalog.into_iter().find(|f| f.name == h.robot);
                vec![(facts, load_robot(&dir, &h.robot)?)]
            }
        };
        Ok(ReachCheck {
            setup,
            arms,
            config: ReachConfig::default(),
        })
    }

    /// The arm of a program in `language` taught at `poses`, naming the arm `named` (a
    /// designation, see [`super::designation`]) if it does, and where it stands; `None` when
    /// no arm of the setup is for that language and the program names none the library has, or
    /// there is no pose.
    pub fn place(
        &self,
        language: &str,
        named: Option<&str>,
        poses: &[Pose],
    ) -> Result<Option<PlacedArm>, LayoutError> {
        if poses.is_empty() {
            return Ok(None);
        }
        match &self.setup {
            ReachSetup::Heuristic(h) => {
                if !h.languages.iter().any(|l| l == language) {
                    return Ok(None);
                }
                let (facts, robot) = &self.arms[0];
                let cell = heuristic_cell(poses, h.centroid_in_base_mm);
                let reached = poses
                    .iter()
                    .filter(|p| self.reaches(robot, &cell, p))
                    .count();
                Ok(self.placed(ProgramArm {
                    robot: robot.name().to_string(),
                    model: facts.as_ref().map(|f| f.model.clone()),
                    chosen: ArmChoice::Heuristic,
                    named: named.map(str::to_string),
                    base: cell.base.values(),
                    reached,
                    waypoints: poses.len(),
                }))
            }
            ReachSetup::Fitted(fit) => Ok(self
                .fit(fit, language, named, poses)?
                .and_then(|arm| self.placed(arm))),
        }
    }

    /// The setup's arm `arm` names, standing where it says (its base as written there, TCP at
    /// the flange); `None` when the setup has no arm of that name or the base is no pose. What
    /// [`ReachCheck::place`] answers is this of what it chose, so a placement kept as its
    /// [`ProgramArm`] (the replay's cache) comes back equal.
    pub fn placed(&self, arm: ProgramArm) -> Option<PlacedArm> {
        let (_, robot) = self.arms.iter().find(|(_, r)| r.name() == arm.robot)?;
        let base = arm.base.to_pose().ok()?;
        Some(PlacedArm {
            robot: robot.clone(),
            cell: Mounting::new(base, Pose::identity()),
            arm,
        })
    }

    /// The setup the arms were loaded for.
    pub fn setup(&self) -> &ReachSetup {
        &self.setup
    }

    fn fit(
        &self,
        fit: &FitSetup,
        language: &str,
        named: Option<&str>,
        poses: &[Pose],
    ) -> Result<Option<ProgramArm>, LayoutError> {
        let facts: Vec<ArmFacts> = self.arms.iter().filter_map(|(f, _)| f.clone()).collect();
        let own = named.and_then(|d| catalog_arm(d, &facts)).map(|f| &f.name);
        let mut candidates: Vec<&(Option<ArmFacts>, Robot)> = match own {
            Some(name) => self
                .arms
                .iter()
                .filter(|(f, _)| f.as_ref().is_some_and(|f| &f.name == name))
                .collect(),
            None => self
                .arms
                .iter()
                .filter(|(f, _)| {
                    f.as_ref()
                        .is_some_and(|f| f.languages.iter().any(|l| l == language))
                })
                .collect(),
        };
        candidates.sort_by(|(a, _), (b, _)| {
            let reach = |f: &Option<ArmFacts>| f.as_ref().map_or(f64::INFINITY, |f| f.reach_mm);
            reach(a).total_cmp(&reach(b))
        });
        let options = LayoutOptions {
            seed: fit.seed,
            evaluations: fit.evaluations,
            keep: 1,
            ..LayoutOptions::default()
        };
        // An arm whose reach is well under half the program's span cannot reach it all: it is
        // not searched while a larger candidate is left.
        let span = span_mm(poses);
        let last = candidates.len().saturating_sub(1);
        let mut best: Option<ProgramArm> = None;
        for (i, (facts, robot)) in candidates.iter().enumerate() {
            let reach = facts.as_ref().map_or(f64::INFINITY, |f| f.reach_mm);
            if i < last && span > TOO_SMALL_SPAN_PER_REACH * reach {
                continue;
            }
            let Some(placement) = search_layout(robot, poses, &options)?.into_iter().next() else {
                continue;
            };
            let reached = placement.reached;
            let all = reached == poses.len();
            let chosen = match (own.is_some(), all) {
                (true, _) => ArmChoice::Named,
                (false, true) => ArmChoice::Fitted,
                (false, false) => ArmChoice::Partial,
            };
            let placed = ProgramArm {
                robot: robot.name().to_string(),
                model: facts.as_ref().map(|f| f.model.clone()),
                chosen,
                named: named.map(str::to_string),
                base: placement.base.values(),
                reached,
                waypoints: poses.len(),
            };
            if best.as_ref().is_none_or(|b| reached > b.reached) {
                best = Some(placed);
            }
            if all {
                break;
            }
        }
        Ok(best)
    }

    /// Whether `robot` standing in `cell` reaches `target` (the replay's check).
    pub fn reaches(&self, robot: &Robot, cell: &Mounting, target: &Pose) -> bool {
        check_reach(robot, cell, target, None, &self.config).is_reachable()
    }
}

/// An arm is too small for a program whose span (largest distance between two of its
/// waypoints) is more than this many times its data-sheet reach: the wrist centre stays within
/// the reach of the axis-1 line, and the flange within a tool length of it.
const TOO_SMALL_SPAN_PER_REACH: f64 = 2.5;

/// The largest distance between two of `poses`, mm.
fn span_mm(poses: &[Pose]) -> f64 {
    let positions: Vec<Vector3<f64>> = poses.iter().map(Pose::position).collect();
    positions
        .iter()
        .enumerate()
        .flat_map(|(i, a)| positions[i + 1..].iter().map(move |b| (a - b).norm()))
        .fold(0.0, f64::max)
}

/// The heuristic cell: the base put so that the per-axis median of `poses` lies at
/// `centroid_in_base_mm`, axes parallel to the work frame, TCP at the flange.
fn heuristic_cell(poses: &[Pose], centroid_in_base_mm: [f64; 3]) -> Mounting {
    let median = |axis: usize| {
        let mut v: Vec<f64> = poses.iter().map(|p| p.position()[axis]).collect();
        v.sort_by(f64::total_cmp);
        let m = v.len() / 2;
        if v.len().is_multiple_of(2) {
            0.5 * (v[m - 1] + v[m])
        } else {
            v[m]
        }
    };
    let centroid = Vector3::new(median(0), median(1), median(2));
    let [x, y, z] = centroid_in_base_mm;
    let base = centroid - Vector3::new(x, y, z);
    Mounting::new(
        Pose::from_isometry(Isometry3::from_parts(
            Translation3::from(base),
            UnitQuaternion::identity(),
        )),
        Pose::identity(),
    )
}
