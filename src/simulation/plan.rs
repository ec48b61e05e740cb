//! The experiment: conditions (the dissertation's Table 4.1 rows and our default profile), seeds,
//! the arm's placement per program, the random stream per waypoint, and what one taught routine
//! yields.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::SimulationError;
use super::operator::{OperatorModel, Time};
use crate::engine::Noise;
use crate::engine::Tolerance;
use crate::engine::{Pose, Profile};
use crate::kinematics::ReachPolicy;
use crate::kinematics::placement::{PlacedArm, ReachCheck, ReachSetup};
use crate::program::Program;

/// One row of the dissertation's Table 4.1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DissertationFigure {
    pub mean_s: f64,
    pub std_s: f64,
    /// Change of the mean against the baseline, %.
    pub change_pct: Option<f64>,
    /// The dissertation's "Wilcoxon confidence", % (1 − p).
    pub confidence_pct: Option<f64>,
}

/// How the service is set up for one arm of the experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Condition {
    /// Short name used in cell names and JSON (`none`, `seed_phi08_h3`, …).
    pub key: String,
    /// What the table shows.
    pub label: String,
    /// Whether the operator sees suggestions. Without, the service still runs; its suggestions
    /// are ignored and get no feedback.
    pub predictions: bool,
    pub profile: Profile,
    /// Overrides of the profile's δ, φ_min and h.
    pub delta: Option<f64>,
    pub phi_min: Option<f64>,
    pub horizon: Option<usize>,
    /// Override of the default profile's offer threshold on `p_useful`.
    pub offer_threshold: Option<f64>,
    /// Whether the cell is told about its operator: σ_t and σ_q, teaching noise and tolerance
    /// as the plan has them ([`Plan::sigmas`], [`Plan::noise`]: a calibration routine and the
    /// operator's "close enough"). Without, the cell is the one a pendant creates: its arm and
    /// where it stands, nothing else.
    pub operator_known: bool,
    /// The dissertation's figure for this row, for reference (`seed` in the JSON).
    #[serde(rename = "seed")]
    pub dissertation: Option<DissertationFigure>,
}

/// δ of the dissertation's lab study (§4.5.3).
pub const DISSERTATION_LAB_DELTA: f64 = 0.8;

/// The dissertation's Table 4.1 rows (seed profile, δ = 0.8) and the default profile.
pub fn table_4_1_conditions() -> Vec<Condition> {
    let dissertation_row =
        |key: &str, label: &str, phi: f64, h: usize, fig: DissertationFigure| Condition {
            key: key.into(),
            label: label.into(),
            predictions: true,
            profile: Profile::Dissertation,
            delta: Some(DISSERTATION_LAB_DELTA),
            phi_min: Some(phi),
            horizon: Some(h),
            offer_threshold: None,
            operator_known: true,
            dissertation: Some(fig),
        };
    vec![
        Condition {
            key: "none".into(),
            label: "none".into(),
            predictions: false,
            profile: Profile::Default,
            delta: None,
            phi_min: None,
            horizon: None,
            offer_threshold: None,
            operator_known: false,
            dissertation: Some(DissertationFigure {
                mean_s: 292.2,
                std_s: 78.61,
                change_pct: None,
                confidence_pct: None,
            }),
        },
        dissertation_row(
            "seed_phi08_h3",
            "seed profile, φ ≥ 0.8, h = 3",
            0.8,
            3,
            DissertationFigure {
                mean_s: 193.2,
                std_s: 32.07,
                change_pct: Some(-33.88),
                confidence_pct: Some(99.95),
            },
        ),
        dissertation_row(
            "seed_phi05_h2",
            "seed profile, φ ≥ 0.5, h = 2",
            0.5,
            2,
            DissertationFigure {
                mean_s: 178.0,
                std_s: 33.39,
                change_pct: Some(-39.08),
                confidence_pct: Some(99.99),
            },
        ),
        default_row("default", "default profile, arm only", false, None),
        default_row(
            "default_calibrated",
            "default profile, calibrated",
            true,
            None,
        ),
        default_row(
            "default_calibrated_p05",
            "default profile, calibrated, p ≥ 0.5",
            true,
            Some(JOYSTICK_OFFER_THRESHOLD),
        ),
    ]
}

/// A row of the default profile: the cell as a pendant creates it (`operator_known` false), or
/// told about its operator, at the profile's offer threshold or another.
fn default_row(
    key: &str,
    label: &str,
    operator_known: bool,
    offer_threshold: Option<f64>,
) -> Condition {
    Condition {
        key: key.into(),
        label: label.into(),
        predictions: true,
        profile: Profile::Default,
        delta: None,
        phi_min: None,
        horizon: None,
        offer_threshold,
        operator_known,
        dissertation: None,
    }
}

/// The offer threshold of the default profile's calibrated row: a suggestion more likely right than
/// not (as the dissertation's second row lowers φ to 0.5). For a joystick operator a near miss is
/// still a head start: fine-tuning from it is quicker than jogging the whole way.
pub const JOYSTICK_OFFER_THRESHOLD: f64 = 0.5;

/// What the cell already knows when the operator starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum History {
    /// An empty model: the program is new to the cell.
    None,
    /// The programs of the same repository that come before it (in the order given) were
    /// taught exactly, as offline programs, in the same cell: like the dissertation's lab study,
    /// whose model was built from earlier programs of the same tasks.
    Repository,
    /// As [`History::Repository`], but the earlier programs were taught online: each of their
    /// waypoints carries the plan's operator's placement error ([`Plan::as_taught_online`]), as
    /// the dissertation's lab model was built from other users' joystick-taught programs (§4.5.3).
    RepositoryOnline,
}

/// Everything that defines a run, besides the programs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub conditions: Vec<Condition>,
    pub seeds: Vec<u64>,
    pub operator: OperatorModel,
    pub limits: super::arm::JogLimits,
    pub history: History,
    /// What the service does with suggestions the arm cannot reach.
    pub reach_policy: ReachPolicy,
    /// Set the cell's σ_t and σ_q to the operator's repeatability (as the dissertation set its
    /// precision matrix from the users' scatter, §4.5.1) when larger than the profile's.
    pub calibrate_sigma: bool,
}

impl Plan {
    /// The cell's teaching noise and acceptance tolerance under this plan. With calibrated σs:
    /// the noise the operator's calibration routine shows (the dissertation's §4.5.1: one
    /// unreferenced point recorded [`CALIBRATION_POSES`] times, [`Noise::from_scatter`]) and the
    /// operator's "close enough"; otherwise an exact cell with the dissertation's tolerance.
    pub fn noise(&self) -> (Noise, Tolerance) {
        if !self.calibrate_sigma {
            return (Noise::EXACT, Tolerance::USEFUL);
        }
        let o = &self.operator;
        let point = Pose::identity();
        let recorded: Vec<Pose> = (0..CALIBRATION_POSES)
            .map(|i| o.place(&point, &mut waypoint_rng(CALIBRATION_STREAM, 0, 0, i)))
            .collect();
        (
            Noise::from_scatter(&recorded).unwrap_or(Noise::EXACT),
            Tolerance {
                mm: o.accept_mm,
                rad: o.accept_rad,
            },
        )
    }

    /// An earlier program as the plan's operator would have taught it online: every waypoint
    /// placed with the operator's error, drawn from its own stream (the same for every
    /// condition of one seed, so conditions are compared on one history).
    pub fn as_taught_online(&self, program: &Program, index: usize, seed: u64) -> Program {
        let mut p = program.clone();
        for (r, routine) in p.routines.iter_mut().enumerate() {
            for (w, pose) in routine.waypoints.iter_mut().enumerate() {
                let mut rng = waypoint_rng(seed ^ HISTORY_STREAM, index, r, w);
                *pose = self.operator.place(pose, &mut rng);
            }
        }
        p
    }

    /// The cell's σ_t (mm) and σ_q for `profile` under this plan.
    pub fn sigmas(&self, profile: Profile) -> (f64, f64) {
        let base = crate::engine::EngineConfig::profile(profile);
        if !self.calibrate_sigma {
            return (base.sigma_t, base.sigma_q);
        }
        // A rotation by a small angle θ about an axis changes the quaternion's vector part by θ/2.
        (
            base.sigma_t.max(self.operator.sigma_axis_mm()),
            base.sigma_q.max(0.5 * self.operator.sigma_axis_rad()),
        )
    }
}

/// The arm of each program and where it stands, as the replay's reach figures choose them
/// ([`ReachSetup::default`]: the arm the program names, else the smallest library arm for its
/// language that reaches every taught waypoint, placed by the layout search). Searched once
/// per program; every session of the program uses it.
pub fn placements(programs: &[Program]) -> Result<Vec<PlacedArm>, SimulationError> {
    let check = ReachCheck::new(ReachSetup::default())?;
    programs
        .iter()
        .map(|p| {
            let poses: Vec<Pose> = p.poses().copied().collect();
            check
                .place(p.language_name(), p.arm_designation(), &poses)
                .map_err(|e| SimulationError::Layout(p.name.clone(), e))?
                .ok_or_else(|| SimulationError::NoPlacement(p.name.clone()))
        })
        .collect()
}

/// The repository a corpus program comes from: its file's `source.repo` when it names one,
/// else `owner__repo`, the start of its file name. `source.repo` is written with `/` as `__`,
/// as the corpus's file names write it, so a corpus program has the same repository either way.
pub fn repository(program: &Program) -> String {
    if let Some(repo) = program.repo.as_deref().filter(|r| !r.is_empty()) {
        return repo.replace('/', "__");
    }
    program
        .name
        .splitn(3, "__")
        .take(2)
        .collect::<Vec<_>>()
        .join("__")
}

/// How many times the operator records the calibration routine's point ([`Plan::noise`]).
pub const CALIBRATION_POSES: usize = 12;
/// Salt of the calibration routine's stream.
const CALIBRATION_STREAM: u64 = 0x6361_6c69_6272_6174;

/// Salt of the streams of an online-taught history ([`Plan::as_taught_online`]).
const HISTORY_STREAM: u64 = 0x6869_7374_6f72_7921;

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one waypoint. It depends only on the seed and the waypoint's place in
/// the corpus, not on the condition, so the operator's hand placement of a waypoint is the
/// same in every condition (common random numbers: the conditions differ only by what the
/// suggestions change).
pub fn waypoint_rng(seed: u64, program: usize, routine: usize, waypoint: usize) -> ChaCha8Rng {
    let mut h = splitmix(seed);
    for v in [program, routine, waypoint] {
        h = splitmix(h ^ v as u64);
    }
    ChaCha8Rng::seed_from_u64(h)
}

/// What teaching one routine took, in one condition, for one seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RoutineResult {
    pub condition: String,
    pub seed: u64,
    pub program: String,
    pub program_index: usize,
    pub routine: String,
    pub routine_index: usize,
    pub waypoints: usize,
    /// Simulated programming time, s.
    pub time_s: f64,
    pub time: Time,
    /// Suggestions offered for waypoints of the routine (and after its last one).
    pub offered: usize,
    pub accepted: usize,
    pub adjusted: usize,
    pub rejected: usize,
    /// Suggestions after the last waypoint, dismissed (counted in `rejected` too).
    pub dismissed: usize,
    /// Offered suggestions the service marked unreachable (only with `reach_policy: flag`).
    pub offered_unreachable: usize,
    /// Taught waypoints outside the arm's reach.
    pub unreachable_waypoints: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn waypoint_streams_are_reproducible_and_distinct() {
        let a: f64 = waypoint_rng(1, 2, 3, 4).random();
        let b: f64 = waypoint_rng(1, 2, 3, 4).random();
        let c: f64 = waypoint_rng(1, 2, 3, 5).random();
        let d: f64 = waypoint_rng(2, 2, 3, 4).random();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
    }

    /// The simulated calibration routine finds about the operator's scatter (twelve poses: a
    /// standard error of about 12 %), and its "close enough" is the cell's tolerance.
    #[test]
    fn the_calibration_routine_estimates_the_operators_noise() {
        let limits = super::super::arm::JogLimits::default();
        let plan = Plan {
            conditions: table_4_1_conditions(),
            seeds: vec![1],
            operator: OperatorModel::online(limits.tcp_mm_s),
            limits,
            history: History::None,
            reach_policy: ReachPolicy::Withhold,
            calibrate_sigma: true,
        };
        let (noise, tolerance) = plan.noise();
        let o = &plan.operator;
        assert!(
            (noise.mm / o.sigma_axis_mm() - 1.0).abs() < 0.3,
            "{noise:?}"
        );
        assert!(
            (noise.rad / o.sigma_axis_rad() - 1.0).abs() < 0.3,
            "{noise:?}"
        );
        assert_eq!((tolerance.mm, tolerance.rad), (o.accept_mm, o.accept_rad));
        let exact = Plan {
            calibrate_sigma: false,
            ..plan
        };
        assert_eq!(exact.noise(), (Noise::EXACT, Tolerance::USEFUL));
    }

    #[test]
    fn the_table_has_the_dissertation_rows() {
        let c = table_4_1_conditions();
        assert_eq!(c.len(), 6);
        assert!(!c[0].predictions);
        // The default row is the cell a pendant creates; the calibrated rows are told the
        // operator's noise and tolerance, the last also a lower threshold.
        assert_eq!(c[3].key, "default");
        assert!(!c[3].operator_known);
        assert!(c[4].operator_known && c[5].operator_known);
        assert_eq!(c[5].offer_threshold, Some(JOYSTICK_OFFER_THRESHOLD));
        assert_eq!(c[3].offer_threshold, None);
        assert_eq!(c[4].offer_threshold, None);
        assert!(
            c[1].operator_known,
            "the seed set its σs from the users' scatter"
        );
        assert_eq!(c[1].phi_min, Some(0.8));
        assert_eq!(c[2].horizon, Some(2));
        assert_eq!(c[1].dissertation.and_then(|s| s.change_pct), Some(-33.88));
    }

    #[test]
    fn repository_is_owner_and_repo() {
        let p = Program {
            name: "zwj12__AddInPackages__ZhongXun__Source__X.mod".into(),
            source: "x".into(),
            language: Some(crate::program::Language::Rapid),
            repo: None,
            arm: None,
            routines: vec![],
        };
        assert_eq!(repository(&p), "zwj12__AddInPackages");
        let named = Program {
            repo: Some("seed/prp-lab".into()),
            ..p
        };
        assert_eq!(repository(&named), "seed__prp-lab");
    }
}
