//! Cell layout (pure): where to stand an arm so that it reaches a program's taught TCP poses.
//!
//! Given a robot and the targets (TCP poses in the work-object frame, mm), [`search_layout`]
//! looks for robot base poses from which the arm reaches every target, or as many as it can,
//! with room to spare from the joint limits and from singularities. A target counts as reached
//! exactly when [`check_reach`] (no previous joints, the options' singularity threshold) says so,
//! the check the replay and the simulated arm use.
//!
//! The base stands on the floor (z up) or hangs from the ceiling (z down), its axes otherwise
//! parallel to the work frame up to a yaw about the vertical: four numbers `(x, y, z, yaw)`.
//!
//! # Method
//!
//! The reached count is a step function of the base, so the optimiser works on a smooth
//! surrogate as well: every target gets a value in `(0, 1)`:
//!
//! - reached: `0.5 + 0.5·comfort`, where `comfort ∈ [0, 1]` is the mean of the chosen solution's
//!   joint margin over [`LayoutOptions::comfort_joint_margin_rad`] and its smallest Jacobian
//!   singular value above the threshold over [`LayoutOptions::comfort_sigma`], each capped at 1;
//! - not reached: `0.5 / (1 + p)`, where the penalty `p` grows with how far out of reach it is:
//!   the distance of the flange target's wrist centre from the arm's workspace shell (in tenths
//!   of the arm's reach), the joint-limit excess of the best IK solution (in units of the comfort
//!   margin), or how far below the singularity threshold the chosen solution is.
//!
//! A placement's [`Placement::score`] is `reached + mean value`, so comparing scores compares
//! reached counts first and the surrogate second (lexicographic), and the surrogate leads the
//! optimiser towards unreached targets on a plateau of equal counts.
//!
//! The search: (1) coarse bases, scored on a subsample of the targets
//! ([`LayoutOptions::sample_targets`], spread out in space): today's heuristic
//! ([`super::placement`]: the per-axis median of the targets at a comfortable point in front of
//! the base), the caller's [`LayoutOptions::extra_bases`], a grid of bases around the median
//! facing it, and random bases facing random targets (drawn from [`LayoutOptions::seed`], so
//! results are deterministic); (2) Nelder–Mead (`argmin`) from the heuristic, the extra bases
//! and the best distinct coarse bases (`keep + 5` of them); (3) every refined candidate, the
//! heuristic, the extra bases and the best `4 · keep` distinct coarse bases evaluated on all
//! targets, a last Nelder–Mead polish on all targets of the best `keep` distinct ones, and the
//! best distinct [`LayoutOptions::keep`] returned. The heuristic and the extra bases are always
//! among the candidates scored on all targets, so the best placement never reaches fewer
//! targets than they do.

use std::f64::consts::{FRAC_PI_4, PI};

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize, Serializer};

use super::reach::DEFAULT_MIN_SINGULAR_VALUE;
use super::{Robot, wrap_angle};
use crate::engine::{Pose, PoseValues};
use refine::{Candidate, nelder_mead};
use surrogate::Evaluator;

mod refine;
mod surrogate;

/// How the robot base is mounted.
// The schema derive describes the wire form for the API's description; it does no I/O.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum BaseMounting {
    /// On the floor: base z along the work frame's z (up).
    #[default]
    Floor,
    /// Hanging from the ceiling: base z along the work frame's −z (the base is turned half a
    /// turn about its x axis).
    Ceiling,
}

/// Settings of [`search_layout`] and [`evaluate_placement`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LayoutOptions {
    /// Floor (default) or ceiling mounting; the search varies x, y, z and the yaw about the
    /// vertical.
    pub mounting: BaseMounting,
    /// TCP in the flange (`tool0`) frame, mm; default identity (TCP at the flange).
    pub tool: PoseValues,
    /// Random seed of the coarse stage's random bases: the same inputs and seed give the same
    /// placements.
    pub seed: u64,
    /// Placement evaluations on the target subsample for the coarse stage and refinement
    /// (default 1200; 40 % coarse, 60 % Nelder–Mead). At least 20.
    pub evaluations: usize,
    /// Evaluations of the final Nelder–Mead polish on all targets, for each of the best
    /// [`LayoutOptions::keep`] distinct candidates (default 60; 0 skips it). Only used when there are more targets than
    /// [`LayoutOptions::sample_targets`].
    pub polish_evaluations: usize,
    /// How many targets the coarse and refinement stages look at (default 64): half evenly
    /// spaced in program order, half the farthest from those (so outliers are seen). All targets
    /// are evaluated at the end.
    pub sample_targets: usize,
    /// How many distinct placements to return, best first (default 3). Fewer come back when the
    /// search found fewer distinct ones.
    pub keep: usize,
    /// Two placements are distinct when their base origins are at least this far apart (mm,
    /// default 200) …
    pub distinct_mm: f64,
    /// … or their yaws differ by at least this (rad, default π/6 = 30°).
    pub distinct_yaw_rad: f64,
    /// How far beyond the targets' bounding box the base origin may stand (mm); default (`None`):
    /// the arm's reach plus its shoulder height.
    pub bound_margin_mm: Option<f64>,
    /// Where the heuristic base puts the targets' per-axis median in the base frame (mm);
    /// default (`None`): half the arm's reach in front of the base at shoulder height.
    pub median_in_base_mm: Option<[f64; 3]>,
    /// Further bases (work frame, mm) to start from and to score as given, e.g. the cell's
    /// current placement; the result is never worse than any of them.
    pub extra_bases: Vec<PoseValues>,
    /// A chosen solution whose smallest Jacobian singular value (in reach units,
    /// [`crate::kinematics::Robot::sigma_min`]) is below this is singular (default
    /// [`DEFAULT_MIN_SINGULAR_VALUE`], as [`ReachConfig`]).
    pub min_singular_value: f64,
    /// Joint margin (rad) at which a reached target counts as fully comfortable (default 0.35,
    /// about 20°).
    pub comfort_joint_margin_rad: f64,
    /// Smallest singular value at which a reached target counts as fully clear of singularities
    /// (default 0.05, about J5 = 10° on any arm). Above `min_singular_value`.
    pub comfort_sigma: f64,
}

impl Default for LayoutOptions {
    fn default() -> LayoutOptions {
        LayoutOptions {
            mounting: BaseMounting::Floor,
            tool: Pose::identity().values(),
            seed: 0,
            evaluations: 1200,
            polish_evaluations: 60,
            sample_targets: 64,
            keep: 3,
            distinct_mm: 200.0,
            distinct_yaw_rad: PI / 6.0,
            bound_margin_mm: None,
            median_in_base_mm: None,
            extra_bases: Vec::new(),
            min_singular_value: DEFAULT_MIN_SINGULAR_VALUE,
            comfort_joint_margin_rad: 0.35,
            comfort_sigma: 0.05,
        }
    }
}

/// Why no layout search was run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayoutError {
    #[error("no target poses to place the arm for")]
    NoTargets,
    #[error("target {index} is not a finite pose")]
    NonFiniteTarget { index: usize },
    #[error("bad layout options: {0}")]
    BadOptions(String),
}

/// One robot base placement and how well the arm reaches the targets from it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Placement {
    /// Robot base frame in the work frame, mm.
    #[serde(serialize_with = "serialize_pose")]
    pub base: Pose,
    /// Targets reached ([`check_reach`] without previous joints).
    pub reached: usize,
    /// Targets given.
    pub total: usize,
    /// Indices of the targets not reached, ascending.
    pub unreached: Vec<usize>,
    /// Smallest distance to a joint limit over the reached targets' chosen solutions (rad);
    /// `None` when nothing is reached.
    pub min_joint_margin_rad: Option<f64>,
    /// Smallest Jacobian singular value over the reached targets' chosen solutions (the
    /// singularity margin; metres and radians at the flange); `None` when nothing is reached.
    pub min_sigma: Option<f64>,
    /// `reached + mean surrogate value` (module docs): in `[reached, reached + 1)`, so a higher
    /// score means more targets reached or, at equal counts, more margin (or, for unreached
    /// targets, nearer misses).
    pub score: f64,
}

fn serialize_pose<S: Serializer>(pose: &Pose, s: S) -> Result<S::Ok, S::Error> {
    pose.values().serialize(s)
}

/// Scores one given base (work frame, mm) for `targets` (TCP poses, work frame, mm), e.g. a
/// user's placement or today's heuristic.
pub fn evaluate_placement(
    robot: &Robot,
    targets: &[Pose],
    base: &Pose,
    options: &LayoutOptions,
) -> Result<Placement, LayoutError> {
    let eval = Evaluator::new(robot, targets, options)?;
    if !pose_is_finite(base) {
        return Err(LayoutError::BadOptions(
            "the base pose is not finite".into(),
        ));
    }
    Ok(eval.placement(base))
}

/// Searches base poses for `robot` that reach every target (TCP poses in the work frame, mm),
/// or the most, with margins from joint limits and singularities: up to
/// [`LayoutOptions::keep`] distinct placements, best (highest [`Placement::score`]) first.
pub fn search_layout(
    robot: &Robot,
    targets: &[Pose],
    options: &LayoutOptions,
) -> Result<Vec<Placement>, LayoutError> {
    let eval = Evaluator::new(robot, targets, options)?;
    let n = targets.len();
    let sample = subsample(targets, options.sample_targets);
    let full: Vec<usize> = (0..n).collect();
    let bounds = eval.bounds(options.bound_margin_mm);

    // (1) Coarse bases, scored on the sample.
    let median = median_position(targets);
    let comfort = options
        .median_in_base_mm
        .map(Vector3::from)
        .unwrap_or_else(|| eval.shell.comfort_point_mm());
    let heuristic = eval.base_facing(&median, 0.0, &comfort);
    let extras: Vec<Pose> = options
        .extra_bases
        .iter()
        .filter_map(|v| v.to_pose().ok())
        .collect();
    let mut coarse_bases: Vec<Params> = vec![heuristic];
    coarse_bases.extend(extras.iter().map(|p| eval.params_of(p)));
    let reach = eval.shell.reach_mm;
    let shoulder = eval.shell.shoulder_height_mm;
    'grid: for d in [0.3, 0.5, 0.7] {
        for h in [shoulder - 0.3 * reach, shoulder, shoulder + 0.3 * reach] {
            for k in 0..8 {
                let yaw = k as f64 * FRAC_PI_4;
                coarse_bases.push(eval.base_facing(&median, yaw, &Vector3::new(d * reach, 0.0, h)));
                if coarse_bases.len() >= options.evaluations / 4 {
                    break 'grid;
                }
            }
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let coarse_budget = (options.evaluations * 2 / 5).max(coarse_bases.len());
    while coarse_bases.len() < coarse_budget {
        let anchor = targets[sample[rng.random_range(0..sample.len())]].position();
        let yaw = rng.random_range(-PI..PI);
        let d = rng.random_range(0.2..0.8) * reach;
        let h = shoulder + rng.random_range(-0.5..0.5) * reach;
        let mut p = eval.base_facing(&anchor, yaw, &Vector3::new(d, 0.0, h));
        p[3] = wrap_angle(p[3] + rng.random_range(-0.4..0.4));
        coarse_bases.push(p);
    }
    let mut coarse: Vec<(Params, f64)> = coarse_bases
        .iter()
        .map(|p| {
            let p = bounds.clamp(p);
            (p, eval.score(&eval.base_pose(&p), &sample))
        })
        .collect();
    let used = coarse.len();
    // Best first; the sort is stable, so ties keep their order (the heuristic first).
    coarse.sort_by(|a, b| b.1.total_cmp(&a.1));

    // (2) Nelder–Mead from the heuristic, the extra bases and the best distinct coarse ones.
    let mut starts: Vec<Params> = vec![bounds.clamp(&heuristic)];
    starts.extend(extras.iter().map(|p| bounds.clamp(&eval.params_of(p))));
    let wanted = starts.len() + options.keep + 5;
    for (p, _) in &coarse {
        if starts.len() >= wanted {
            break;
        }
        if starts.iter().all(|s| options.distinct(s, p)) {
            starts.push(*p);
        }
    }
    let refine_budget = options.evaluations.saturating_sub(used);
    let per_start = refine_budget / starts.len().max(1);
    let mut pool: Vec<Candidate> = Vec::new();
    for s in &starts {
        let p = nelder_mead(&eval, &bounds, &sample, s, per_start);
        pool.push(Candidate::of(&eval, &eval.base_pose(&p)));
    }
    // (3) Candidates on all targets: the refined ones, the heuristic, the extra bases as given,
    // and the best distinct coarse ones.
    pool.push(Candidate::of(&eval, &eval.base_pose(&heuristic)));
    pool.extend(extras.iter().map(|p| Candidate::of(&eval, p)));
    let mut added = 0;
    for (p, _) in &coarse {
        if added >= 4 * options.keep {
            break;
        }
        if pool.iter().all(|c| options.distinct(&c.params, p)) {
            pool.push(Candidate::of(&eval, &eval.base_pose(p)));
            added += 1;
        }
    }
    let mut scored: Vec<(Candidate, Placement)> = pool
        .into_iter()
        .map(|c| {
            let placement = eval.placement(&c.base);
            (c, placement)
        })
        .collect();
    sort_best_first(&mut scored);
    if n > sample.len() && options.polish_evaluations > 0 {
        // Polish the best distinct candidates (as many as are kept) on all targets.
        let mut tops: Vec<Params> = Vec::with_capacity(options.keep);
        for (c, _) in &scored {
            if tops.len() >= options.keep {
                break;
            }
            if tops.iter().all(|t| options.distinct(t, &c.params)) {
                tops.push(c.params);
            }
        }
        for t in &tops {
            let start = bounds.clamp(t);
            let p = nelder_mead(&eval, &bounds, &full, &start, options.polish_evaluations);
            let c = Candidate::of(&eval, &eval.base_pose(&p));
            let placement = eval.placement(&c.base);
            scored.push((c, placement));
        }
        sort_best_first(&mut scored);
    }
    let mut kept: Vec<(Candidate, Placement)> = Vec::with_capacity(options.keep);
    for (c, placement) in scored {
        if kept.len() >= options.keep {
            break;
        }
        if kept
            .iter()
            .all(|(k, _)| options.distinct(&k.params, &c.params))
        {
            kept.push((c, placement));
        }
    }
    Ok(kept.into_iter().map(|(_, p)| p).collect())
}

fn sort_best_first(scored: &mut [(Candidate, Placement)]) {
    scored.sort_by(|a, b| b.1.score.total_cmp(&a.1.score));
}

/// `(x, y, z, yaw)` of a base: origin in mm, yaw about the vertical in rad.
type Params = [f64; 4];

impl LayoutOptions {
    fn validate(&self) -> Result<Pose, LayoutError> {
        let bad = |m: &str| Err(LayoutError::BadOptions(m.to_string()));
        let tool = self
            .tool
            .to_pose()
            .map_err(|e| LayoutError::BadOptions(format!("tool: {e}")))?;
        if self.evaluations < 20 {
            return bad("evaluations must be at least 20");
        }
        if self.sample_targets == 0 {
            return bad("sample_targets must be at least 1");
        }
        if self.keep == 0 {
            return bad("keep must be at least 1");
        }
        if !(self.distinct_mm.is_finite() && self.distinct_mm >= 0.0) {
            return bad("distinct_mm must be finite and not negative");
        }
        if !(self.distinct_yaw_rad.is_finite() && self.distinct_yaw_rad >= 0.0) {
            return bad("distinct_yaw_rad must be finite and not negative");
        }
        if self
            .bound_margin_mm
            .is_some_and(|m| !(m.is_finite() && m >= 0.0))
        {
            return bad("bound_margin_mm must be finite and not negative");
        }
        if self
            .median_in_base_mm
            .is_some_and(|m| m.iter().any(|v| !v.is_finite()))
        {
            return bad("median_in_base_mm must be finite");
        }
        if let Some(i) = self.extra_bases.iter().position(|s| s.to_pose().is_err()) {
            return Err(LayoutError::BadOptions(format!(
                "extra_bases[{i}] is not a valid pose"
            )));
        }
        if !(self.min_singular_value.is_finite() && self.min_singular_value >= 0.0) {
            return bad("min_singular_value must be finite and not negative");
        }
        if !(self.comfort_joint_margin_rad.is_finite() && self.comfort_joint_margin_rad > 0.0) {
            return bad("comfort_joint_margin_rad must be positive");
        }
        if !(self.comfort_sigma.is_finite() && self.comfort_sigma > self.min_singular_value) {
            return bad("comfort_sigma must be finite and above min_singular_value");
        }
        Ok(tool)
    }

    /// Whether two bases count as different placements.
    fn distinct(&self, a: &Params, b: &Params) -> bool {
        let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        d >= self.distinct_mm || wrap_angle(a[3] - b[3]).abs() >= self.distinct_yaw_rad
    }
}

fn pose_is_finite(p: &Pose) -> bool {
    let q = p.rotation();
    p.position().iter().all(|v| v.is_finite()) && q.coords.iter().all(|v| v.is_finite())
}

/// Per-axis median of the target positions (today's heuristic's centre).
fn median_position(targets: &[Pose]) -> Vector3<f64> {
    let median = |axis: usize| {
        let mut v: Vec<f64> = targets.iter().map(|t| t.position()[axis]).collect();
        v.sort_by(f64::total_cmp);
        let m = v.len() / 2;
        if v.is_empty() {
            0.0
        } else if v.len().is_multiple_of(2) {
            0.5 * (v[m - 1] + v[m])
        } else {
            v[m]
        }
    };
    Vector3::new(median(0), median(1), median(2))
}

/// Up to `m` target indices, ascending: half evenly spaced in program order, the rest by
/// farthest-point sampling from those.
fn subsample(targets: &[Pose], m: usize) -> Vec<usize> {
    let n = targets.len();
    if n <= m {
        return (0..n).collect();
    }
    let even = m.div_ceil(2);
    let mut chosen: Vec<usize> = (0..even).map(|k| k * n / even).collect();
    let mut nearest = vec![f64::INFINITY; n];
    let update = |nearest: &mut [f64], c: usize| {
        let pc = targets[c].position();
        for (d, t) in nearest.iter_mut().zip(targets) {
            *d = d.min((t.position() - pc).norm());
        }
    };
    for &c in &chosen {
        update(&mut nearest, c);
    }
    while chosen.len() < m {
        let far = nearest.iter().enumerate().fold(
            (0, -1.0),
            |acc, (i, &d)| if d > acc.1 { (i, d) } else { acc },
        );
        if far.1 <= 0.0 {
            break;
        }
        chosen.push(far.0);
        update(&mut nearest, far.0);
    }
    chosen.sort_unstable();
    chosen.dedup();
    chosen
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    use super::*;
    use crate::kinematics::{
        DOF, Joints, Mounting, ReachConfig, bundled_robots_dir, check_reach, load_robot,
    };

    fn robot(name: &str) -> Robot {
        load_robot(&bundled_robots_dir(), name).expect("bundled robot loads")
    }

    /// Joint vectors well inside the limits and away from the wrist singularity.
    fn comfortable_joints(robot: &Robot, rng: &mut ChaCha8Rng) -> Joints {
        let mut q = [0.0; DOF];
        for (i, (v, j)) in q.iter_mut().zip(robot.joints()).enumerate() {
            let (lo, hi) = (j.lower.max(-PI), j.upper.min(PI));
            let pad = 0.25 * (hi - lo);
            *v = rng.random_range(lo + pad..hi - pad);
            if i == 4 && v.abs() < 0.3 {
                *v = 0.3_f64.copysign(*v);
            }
        }
        q
    }

    /// A program taught with the arm at `base` (work frame): FK of random joint vectors, each
    /// kept when [`check_reach`] accepts it from `base` (the solution it picks may be another
    /// one than the generating vector, nearer a singularity).
    fn synthetic_program(robot: &Robot, base: &Pose, n: usize, seed: u64) -> Vec<Pose> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cell = Mounting::new(*base, Pose::identity());
        let mut out = Vec::with_capacity(n);
        while out.len() < n {
            let q = comfortable_joints(robot, &mut rng);
            let target = Pose::from_isometry(base.isometry() * robot.fk(&q).isometry());
            if check_reach(robot, &cell, &target, None, &ReachConfig::default()).is_reachable() {
                out.push(target);
            }
        }
        out
    }

    fn base_at(x: f64, y: f64, z: f64, yaw: f64) -> Pose {
        Pose::from_isometry(Isometry3::from_parts(
            Translation3::new(x, y, z),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        ))
    }

    #[test]
    fn the_search_finds_a_base_that_reaches_a_synthetic_program() {
        // 40 targets: all in the search's sample; 150: subsampled, then polished on all.
        for (name, seed, n) in [
            ("abb_irb140", 1, 40),
            ("kuka_kr16_2", 2, 40),
            ("abb_irb140", 3, 150),
        ] {
            let robot = robot(name);
            let truth = base_at(1500.0, -700.0, -200.0, 2.2);
            let targets = synthetic_program(&robot, &truth, n, seed);
            let options = LayoutOptions::default();
            let found = search_layout(&robot, &targets, &options).unwrap();
            assert!(!found.is_empty() && found.len() <= options.keep);
            let best = &found[0];
            assert_eq!(best.total, n);
            assert_eq!(best.reached, n, "{name}: {best:?}");
            assert!(best.unreached.is_empty());
            assert!(best.min_joint_margin_rad.is_some_and(|m| m >= 0.0));
            assert!(
                best.min_sigma
                    .is_some_and(|s| s >= DEFAULT_MIN_SINGULAR_VALUE)
            );
            // Best first, and distinct.
            for w in found.windows(2) {
                assert!(w[0].score >= w[1].score);
            }
            // The true base reaches everything too, and scoring it agrees with check_reach.
            let at_truth = evaluate_placement(&robot, &targets, &truth, &options).unwrap();
            assert_eq!(at_truth.reached, n);
            assert!((n as f64..n as f64 + 1.0).contains(&at_truth.score));
            // Deterministic.
            let again = search_layout(&robot, &targets, &options).unwrap();
            assert_eq!(found, again);
        }
    }

    #[test]
    fn far_off_targets_leave_the_score_below_the_count_and_list_the_misses() {
        let robot = robot("abb_irb140");
        let base = Pose::identity();
        let mut targets = synthetic_program(&robot, &base, 10, 7);
        let far = base_at(10_000.0, 0.0, 0.0, 0.0);
        targets.push(far);
        let p = evaluate_placement(&robot, &targets, &base, &LayoutOptions::default()).unwrap();
        assert_eq!((p.reached, p.total), (10, 11));
        assert_eq!(p.unreached, vec![10]);
        assert!((10.0..11.0).contains(&p.score));
        // Nearer misses score higher than far ones.
        let mut nearer = targets.clone();
        nearer[10] = base_at(1_500.0, 0.0, 0.0, 0.0);
        let q = evaluate_placement(&robot, &nearer, &base, &LayoutOptions::default()).unwrap();
        assert_eq!(q.reached, 10);
        assert!(q.score > p.score);
    }

    #[test]
    fn the_search_beats_or_matches_the_heuristic_on_a_split_program() {
        // Two clusters far apart: the heuristic centres on the median, the search should find a
        // base that reaches at least as many.
        let robot = robot("abb_irb140");
        let mut targets = synthetic_program(&robot, &base_at(0.0, 0.0, 0.0, 0.0), 30, 3);
        targets.extend(synthetic_program(
            &robot,
            &base_at(3000.0, 0.0, 0.0, 0.0),
            20,
            4,
        ));
        let options = LayoutOptions::default();
        let median = median_position(&targets);
        let heuristic = Pose::from_isometry(Isometry3::from_parts(
            Translation3::from(median - Vector3::new(450.0, 0.0, 350.0)),
            UnitQuaternion::identity(),
        ));
        let h = evaluate_placement(&robot, &targets, &heuristic, &options).unwrap();
        let found = search_layout(
            &robot,
            &targets,
            &LayoutOptions {
                extra_bases: vec![heuristic.values()],
                ..options
            },
        )
        .unwrap();
        assert!(found[0].reached >= h.reached);
        assert!(found[0].reached >= 30, "{:?}", found[0]);
    }

    #[test]
    fn ceiling_mounting_hangs_the_base_upside_down() {
        let robot = robot("abb_irb140");
        let hanging = Pose::from_isometry(Isometry3::from_parts(
            Translation3::new(200.0, 100.0, 2000.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5)
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI),
        ));
        let targets = synthetic_program(&robot, &hanging, 30, 5);
        let options = LayoutOptions {
            mounting: BaseMounting::Ceiling,
            ..LayoutOptions::default()
        };
        let found = search_layout(&robot, &targets, &options).unwrap();
        let best = &found[0];
        assert_eq!(best.reached, 30, "{best:?}");
        let z = best.base.rotation() * Vector3::z();
        assert!(z.z < -0.999, "base z axis {z:?}");
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let robot = robot("abb_irb140");
        let ok = LayoutOptions::default();
        assert_eq!(search_layout(&robot, &[], &ok), Err(LayoutError::NoTargets));
        let nan = Pose::from_isometry(Isometry3::translation(f64::NAN, 0.0, 0.0));
        assert_eq!(
            search_layout(&robot, &[Pose::identity(), nan], &ok),
            Err(LayoutError::NonFiniteTarget { index: 1 })
        );
        let targets = [Pose::identity()];
        let bad_options = [
            LayoutOptions {
                keep: 0,
                ..ok.clone()
            },
            LayoutOptions {
                evaluations: 5,
                ..ok.clone()
            },
            LayoutOptions {
                sample_targets: 0,
                ..ok.clone()
            },
            LayoutOptions {
                distinct_mm: f64::NAN,
                ..ok.clone()
            },
            LayoutOptions {
                comfort_sigma: 0.001,
                ..ok.clone()
            },
            LayoutOptions {
                bound_margin_mm: Some(-1.0),
                ..ok.clone()
            },
            LayoutOptions {
                tool: PoseValues {
                    qw: 2.0,
                    ..Pose::identity().values()
                },
                ..ok.clone()
            },
            LayoutOptions {
                extra_bases: vec![PoseValues {
                    x: f64::INFINITY,
                    ..Pose::identity().values()
                }],
                ..ok.clone()
            },
        ];
        for o in &bad_options {
            assert!(
                matches!(
                    search_layout(&robot, &targets, o),
                    Err(LayoutError::BadOptions(_))
                ),
                "{o:?}"
            );
        }
        assert!(matches!(
            evaluate_placement(&robot, &targets, &nan, &ok),
            Err(LayoutError::BadOptions(_))
        ));
    }

    #[test]
    fn options_round_trip_and_default_missing_fields() {
        let o: LayoutOptions = serde_json::from_str(r#"{"keep": 5, "mounting": "ceiling"}"#)
            .expect("partial options parse");
        assert_eq!(o.keep, 5);
        assert_eq!(o.mounting, BaseMounting::Ceiling);
        assert_eq!(o.evaluations, LayoutOptions::default().evaluations);
        let back: LayoutOptions =
            serde_json::from_str(&serde_json::to_string(&o).unwrap()).unwrap();
        assert_eq!(back, o);
        assert!(serde_json::from_str::<LayoutOptions>(r#"{"kep": 5}"#).is_err());
    }

    #[test]
    fn subsample_spreads_and_keeps_outliers() {
        let mut targets: Vec<Pose> = (0..100).map(|i| base_at(i as f64, 0.0, 0.0, 0.0)).collect();
        targets.push(base_at(5000.0, 0.0, 0.0, 0.0));
        let s = subsample(&targets, 10);
        assert_eq!(s.len(), 10);
        assert!(s.contains(&100));
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(subsample(&targets[..5], 10), vec![0, 1, 2, 3, 4]);
    }
}
