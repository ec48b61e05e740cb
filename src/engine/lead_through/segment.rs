//! A hand-guided trajectory cut into a sequence of LDSs whose attractors are the waypoints
//! (dissertation chapter 5, §5.7–5.8).
//!
//! **State.** A sample's state is six numbers in millimetres: the TCP position, and the
//! orientation as a rotation vector scaled by `rotation_mm_per_rad` (50 mm/rad by default: the
//! engine's metric weighs 1 mm like 0.01 of a quaternion component, about 0.02 rad). The
//! rotation vector is unwrapped along the trajectory: each sample adds the world-frame rotation
//! from the previous one, so the state has no jump at ±180° and a turn about a fixed axis is a
//! straight line. Segmentation and reproduction use the state; an attractor's waypoint is the
//! recorded sample itself (position, quaternion and joints as measured).
//!
//! **Thinning.** A sample is kept when its state is at least `min_step_mm` from the last kept
//! one (the last sample is always kept). A pause then leaves one sample, and steps below the
//! sensor's noise, whose directions are noise, never reach the criterion. `min_step_mm` should
//! be a few times the noise of one sample (1 mm by default).
//!
//! **Online segmentation (§5.7).** At sample `n` the open segment's steps up to `x_{n−1}` are
//! fitted with `x_n` as the attractor and `x_{n−1}` is predicted from `x_{n−2}`. Eq. 5.7 divides
//! the error by the step: `ε = ‖x_{n−1} − x̂_{n−1}‖ / ‖x_{n−1} − x_{n−2}‖`
//! ([`Criterion::ErrorOverStep`]). An LDS slows down as it nears its attractor, so on a stretch at
//! constant speed the least-squares step shrinks as the segment grows: a straight line of `m`
//! steps has `ε ≈ 1 − 3/m` and is cut every few samples, wherever `ε_max` lies. What we want of a
//! waypoint is that the motion heads for it, so by default ([`Criterion::Direction`]) ε compares
//! directions only: `ε = ‖ŝ − ŝ_pred‖` for the unit vectors of the observed and predicted step,
//! `2 sin(θ/2)` for the angle θ between them (0 when aligned, √2 at a right angle, 2 reversed;
//! 2 when the prediction does not move). A segment closes when ε exceeds `ε_max` (0.5 by default,
//! θ ≈ 29°) at `persistence` consecutive samples (2 by default; 1 is the dissertation's rule: one
//! noisy sample no longer cuts a line) and it has at least `min_segment_steps` steps. The
//! dissertation's attractor is the sample before the first one over `ε_max` (so it is with
//! [`Criterion::ErrorOverStep`]); since a direction change shows only a sample or two after the
//! corner, the direction criterion takes the sample among that one and its three predecessors
//! farthest from the chord across them (where the path turns). A new segment starts at the
//! attractor. The last sample ends the last segment.
//!
//! The fit of the open segment leaves out directions along which the samples spread less than
//! `min_step_mm` (RMS) from the attractor ([`super::lds::FitSettings::min_extent`]): a sample a
//! hair off a line would otherwise give the fit a sideways regressor made of noise.
//!
//! What it cannot see: a waypoint the path passes through without turning (a speed dip or a
//! pause on a straight line is not a waypoint to it).
//!
//! **Reproduction (§5.8).** From the first sample, each segment's control law runs until within
//! `zeta_mm` of its attractor, then the next takes over. The reproduction error is the
//! dissertation's (§5.7.1): the mean distance from each recorded position to the closest point of
//! the reproduced path, here the polyline of its own segment or one beside it.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::lds::{DIM, Fit, FitError, FitSettings, State, Sums};
use crate::engine::pose::Pose;

/// The most samples one trajectory may have.
pub const MAX_SAMPLES: usize = 100_000;

/// Largest coordinate of a sample's position (mm, either sign): a kilometre, far beyond any
/// arm, and far below where the fit's squared sums would overflow.
pub const MAX_COORDINATE_MM: f64 = 1e6;

/// Largest weight of rotation against position (mm per radian), for the same reason.
pub const MAX_ROTATION_MM_PER_RAD: f64 = 1e4;

/// A recorded sample: time in seconds and the TCP pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedPose {
    pub t: f64,
    pub pose: Pose,
}

/// How the prediction error of §5.7 is measured. Its name on the wire and on the command line
/// is [`Criterion::name`] (the serde names below are the same, checked by a test): the
/// dissertation's Eq. 5.7 keeps the name `seed` it was published under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Direction of the predicted step against the observed one (the default; see the module
    /// docs).
    Direction,
    /// Eq. 5.7 as written: error over step length.
    #[serde(rename = "seed")]
    ErrorOverStep,
}

impl Criterion {
    /// Every criterion.
    pub const ALL: [Criterion; 2] = [Criterion::Direction, Criterion::ErrorOverStep];

    /// The criterion's name on the wire (REST, reports) and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Criterion::Direction => "direction",
            Criterion::ErrorOverStep => "seed",
        }
    }
}

/// Settings of the segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SegmentSettings {
    pub epsilon_max: f64,
    pub criterion: Criterion,
    pub min_step_mm: f64,
    pub rotation_mm_per_rad: f64,
    pub zeta_mm: f64,
    pub min_segment_steps: usize,
    /// Consecutive samples over ε_max that close a segment (1 is the dissertation's rule).
    pub persistence: usize,
    /// Steps of one segment's reproduction before it gives up.
    pub max_reproduction_steps: usize,
    pub fit: FitSettings,
}

impl Default for SegmentSettings {
    fn default() -> Self {
        SegmentSettings {
            epsilon_max: 0.5,
            criterion: Criterion::Direction,
            min_step_mm: 1.0,
            rotation_mm_per_rad: 50.0,
            zeta_mm: 0.5,
            min_segment_steps: 2,
            persistence: 2,
            max_reproduction_steps: 10_000,
            fit: FitSettings::default(),
        }
    }
}

/// A trajectory or settings that cannot be segmented.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TrajectoryError {
    #[error("a trajectory needs at least 2 samples, got {0}")]
    TooFewSamples(usize),
    #[error("a trajectory may hold at most {MAX_SAMPLES} samples, got {0}")]
    TooManySamples(usize),
    #[error("sample {index}: time {t} is not finite")]
    TimeNotFinite { index: usize, t: f64 },
    #[error("sample {index}: time {t} s does not follow {previous} s (times must increase)")]
    TimeNotIncreasing { index: usize, t: f64, previous: f64 },
    #[error("sample {index}: a coordinate of the position is beyond ±{MAX_COORDINATE_MM} mm")]
    PositionOutOfRange { index: usize },
    #[error("{0}")]
    Settings(String),
    #[error(transparent)]
    Fit(#[from] FitError),
}

impl SegmentSettings {
    /// Checks every setting; the message names the one that is wrong.
    pub fn validate(&self) -> Result<(), TrajectoryError> {
        let positive = [
            ("epsilon_max", self.epsilon_max),
            ("min_step_mm", self.min_step_mm),
            ("zeta_mm", self.zeta_mm),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(TrajectoryError::Settings(format!(
                    "{name} must be finite and positive, got {v}"
                )));
            }
        }
        if !(self.rotation_mm_per_rad >= 0.0 && self.rotation_mm_per_rad <= MAX_ROTATION_MM_PER_RAD)
        {
            return Err(TrajectoryError::Settings(format!(
                "rotation_mm_per_rad must be in [0, {MAX_ROTATION_MM_PER_RAD}], got {}",
                self.rotation_mm_per_rad
            )));
        }
        if self.fit.kappa_max.is_nan() || self.fit.kappa_max < 1.0 {
            return Err(TrajectoryError::Settings(format!(
                "kappa_max must be at least 1, got {}",
                self.fit.kappa_max
            )));
        }
        if !(self.fit.rank_tolerance > 0.0 && self.fit.rank_tolerance < 1.0) {
            return Err(TrajectoryError::Settings(format!(
                "rank_tolerance must be in (0, 1), got {}",
                self.fit.rank_tolerance
            )));
        }
        if self.min_segment_steps == 0 || self.persistence == 0 || self.max_reproduction_steps == 0
        {
            return Err(TrajectoryError::Settings(
                "min_segment_steps, persistence and max_reproduction_steps must be at least 1"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// One segment: an LDS and its attractor.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Index of the sample the segment starts at.
    pub from: usize,
    /// Index of the sample that is its attractor.
    pub to: usize,
    /// Kept (thinned) steps the LDS was fitted to.
    pub steps: usize,
    pub fit: Fit,
    pub attractor: State,
    /// The ε that closed the segment (`None` for the last, closed by the trajectory's end).
    pub epsilon: Option<f64>,
}

/// A trajectory as a sequence of LDSs, and how well it is reproduced.
#[derive(Debug, Clone, PartialEq)]
pub struct Segmentation {
    /// Number of samples given.
    pub samples: usize,
    /// Samples kept by thinning.
    pub kept: usize,
    pub segments: Vec<Segment>,
    /// The reproduced states (Eq. 5.4 segment after segment), the first sample's state first.
    pub reproduction: Vec<State>,
    /// Every segment's reproduction came within ζ of its attractor.
    pub converged: bool,
    /// Mean distance (mm) of the recorded positions to the reproduced path.
    pub mean_error_mm: f64,
    /// Largest such distance (mm).
    pub max_error_mm: f64,
}

impl Segmentation {
    /// Sample indices of the attractors, in order.
    pub fn attractors(&self) -> impl Iterator<Item = usize> + '_ {
        self.segments.iter().map(|s| s.to)
    }

    /// Numbers that describe the trajectory as LDSs, `M(d² + d)` (§5.7).
    pub fn parameters(&self) -> usize {
        self.segments.len() * (DIM * DIM + DIM)
    }

    /// Numbers of the recorded trajectory, `N·d`.
    pub fn raw_parameters(&self) -> usize {
        self.samples * DIM
    }
}

/// The states of the samples (position, unwrapped scaled rotation vector; see the module docs).
pub fn states(samples: &[TimedPose], rotation_mm_per_rad: f64) -> Vec<State> {
    let mut out = Vec::with_capacity(samples.len());
    let mut rotation = nalgebra::Vector3::zeros();
    for (i, s) in samples.iter().enumerate() {
        if i > 0 {
            let step = s.pose.rotation() * samples[i - 1].pose.rotation().inverse();
            rotation += step.scaled_axis();
        }
        let p = s.pose.position();
        let r = rotation * rotation_mm_per_rad;
        out.push(State::from_column_slice(&[p.x, p.y, p.z, r.x, r.y, r.z]));
    }
    out
}

/// Indices of the samples kept: the first, each at least `min_step` from the last kept, and
/// the last (replacing the last kept when it is closer than `min_step` to it).
pub fn thin(states: &[State], min_step: f64) -> Vec<usize> {
    let mut kept: Vec<usize> = Vec::new();
    for (i, x) in states.iter().enumerate() {
        match kept.last() {
            None => kept.push(i),
            Some(&k) if (x - states[k]).norm() >= min_step => kept.push(i),
            Some(_) => {}
        }
    }
    let last = states.len().saturating_sub(1);
    if let Some(&k) = kept.last()
        && k != last
    {
        if kept.len() > 1 {
            kept.pop();
        }
        kept.push(last);
    }
    kept
}

/// Checks the samples (count and times).
pub fn validate(samples: &[TimedPose]) -> Result<(), TrajectoryError> {
    if samples.len() < 2 {
        return Err(TrajectoryError::TooFewSamples(samples.len()));
    }
    if samples.len() > MAX_SAMPLES {
        return Err(TrajectoryError::TooManySamples(samples.len()));
    }
    let mut previous = f64::NEG_INFINITY;
    for (index, s) in samples.iter().enumerate() {
        if !s.t.is_finite() {
            return Err(TrajectoryError::TimeNotFinite { index, t: s.t });
        }
        if s.pose
            .position()
            .iter()
            .any(|v| v.abs() > MAX_COORDINATE_MM)
        {
            return Err(TrajectoryError::PositionOutOfRange { index });
        }
        if s.t <= previous {
            return Err(TrajectoryError::TimeNotIncreasing {
                index,
                t: s.t,
                previous,
            });
        }
        previous = s.t;
    }
    Ok(())
}

/// Segments a trajectory online (§5.7) and reproduces it (§5.8).
pub fn segment(
    samples: &[TimedPose],
    settings: &SegmentSettings,
) -> Result<Segmentation, TrajectoryError> {
    settings.validate()?;
    validate(samples)?;
    let all = states(samples, settings.rotation_mm_per_rad);
    let fitting = FitSettings {
        min_extent: settings.min_step_mm,
        ..settings.fit
    };
    let kept = thin(&all, settings.min_step_mm);
    let y: Vec<State> = kept.iter().map(|&i| all[i]).collect();

    let mut segments = Vec::new();
    let mut start = 0;
    let mut sums = sums_of(&y, 0, 1.min(y.len() - 1));
    // Consecutive samples over ε_max, and the ε of the first of them.
    let mut over = 0;
    let mut first_epsilon = 0.0;
    for n in 2..y.len() {
        // `sums` holds the steps start..=n-2 → n-1.
        let fit = sums.fit(&y[n], &fitting);
        let predicted = y[n - 2] + fit.r * (y[n - 2] - y[n]);
        let epsilon = prediction_error(&y[n - 2], &y[n - 1], &predicted, settings.criterion);
        if epsilon > settings.epsilon_max {
            if over == 0 {
                first_epsilon = epsilon;
            }
            over += 1;
        } else {
            over = 0;
        }
        if over >= settings.persistence {
            // The dissertation's attractor is the sample before the first one over ε_max; the
            // corner is looked for among it and its neighbours.
            let dissertation_attractor = n - settings.persistence;
            let lo =
                (start + settings.min_segment_steps).max(dissertation_attractor.saturating_sub(3));
            if lo < n {
                let fallback = dissertation_attractor.clamp(lo, n - 1);
                let k = match settings.criterion {
                    Criterion::Direction => {
                        corner(&y, start.max(lo.saturating_sub(2)), lo, n).unwrap_or(fallback)
                    }
                    Criterion::ErrorOverStep => fallback,
                };
                let closing = sums_of(&y, start, k);
                segments.push(Segment {
                    from: kept[start],
                    to: kept[k],
                    steps: k - start,
                    fit: closing.fit(&y[k], &fitting),
                    attractor: y[k],
                    epsilon: Some(first_epsilon),
                });
                start = k;
                sums = sums_of(&y, start, n - 1);
                over = 0;
            }
        }
        sums.add(&y[n - 1], &y[n]);
    }
    let last = y.len() - 1;
    segments.push(Segment {
        from: kept[start],
        to: kept[last],
        steps: last - start,
        fit: sums.fit(&y[last], &fitting),
        attractor: y[last],
        epsilon: None,
    });

    let (paths, converged) = reproduce(&segments, &all[0], settings);
    let (mean_error_mm, max_error_mm) = reproduction_error(&all, &segments, &paths);
    Ok(Segmentation {
        samples: samples.len(),
        kept: kept.len(),
        segments,
        reproduction: paths.into_iter().flatten().collect(),
        converged,
        mean_error_mm,
        max_error_mm,
    })
}

/// The sums of the steps `from → from+1 … to−1 → to`.
fn sums_of(y: &[State], from: usize, to: usize) -> Sums {
    let mut sums = Sums::new(y[from]);
    sums.add_demo(&y[from..=to]);
    sums
}

/// The sample in `lo..end` farthest from the chord `y[anchor] → y[end]`: where the path turns
/// (`None` when all lie on the chord).
fn corner(y: &[State], anchor: usize, lo: usize, end: usize) -> Option<usize> {
    let (a, b) = (y[anchor], y[end]);
    let ab = b - a;
    let len2 = ab.norm_squared();
    let distance = |x: &State| {
        let t = if len2 > 0.0 {
            ((x - a).dot(&ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (x - (a + ab * t)).norm()
    };
    (lo..end)
        .map(|k| (k, distance(&y[k])))
        .filter(|(_, d)| *d > 1e-9)
        .max_by(|p, q| p.1.total_cmp(&q.1))
        .map(|(k, _)| k)
}

/// Eq. 5.7 or its direction form (see the module docs).
fn prediction_error(before: &State, observed: &State, predicted: &State, c: Criterion) -> f64 {
    let step = observed - before;
    let length = step.norm();
    if length == 0.0 {
        return 0.0;
    }
    match c {
        Criterion::ErrorOverStep => (observed - predicted).norm() / length,
        Criterion::Direction => {
            let guess = predicted - before;
            let g = guess.norm();
            if g.is_nan() || g <= length * 1e-9 {
                return 2.0;
            }
            (step / length - guess / g).norm()
        }
    }
}

/// Each segment's reproduced path (the first starts at `start`, each next where the last
/// stopped), and whether all converged.
fn reproduce(
    segments: &[Segment],
    start: &State,
    settings: &SegmentSettings,
) -> (Vec<Vec<State>>, bool) {
    let mut x = *start;
    let mut all = true;
    let mut paths = Vec::with_capacity(segments.len());
    for s in segments {
        let out = s.fit.reproduce(
            &x,
            &s.attractor,
            settings.zeta_mm,
            settings.max_reproduction_steps,
        );
        all &= out.converged;
        if let Some(last) = out.path.last() {
            x = *last;
        }
        paths.push(out.path);
    }
    (paths, all)
}

/// Mean and largest distance of each sample's position to the reproduced polyline of its
/// segment or one beside it.
fn reproduction_error(all: &[State], segments: &[Segment], paths: &[Vec<State>]) -> (f64, f64) {
    let mut total = 0.0;
    let mut max: f64 = 0.0;
    let mut count = 0usize;
    for (i, s) in segments.iter().enumerate() {
        let near = i.saturating_sub(1)..(i + 2).min(paths.len());
        // A boundary sample is counted once, with the segment it ends.
        let from = if i == 0 { s.from } else { s.from + 1 };
        for x in &all[from..=s.to] {
            let p = x.fixed_rows::<3>(0).into_owned();
            let d = paths[near.clone()]
                .iter()
                .map(|path| polyline_distance(&p, path))
                .fold(f64::INFINITY, f64::min);
            total += d;
            max = max.max(d);
            count += 1;
        }
    }
    if count == 0 {
        (0.0, 0.0)
    } else {
        (total / count as f64, max)
    }
}

fn polyline_distance(p: &nalgebra::Vector3<f64>, path: &[State]) -> f64 {
    let point = |x: &State| x.fixed_rows::<3>(0).into_owned();
    match path {
        [] => f64::INFINITY,
        [only] => (p - point(only)).norm(),
        _ => path
            .windows(2)
            .map(|w| {
                let (a, b) = (point(&w[0]), point(&w[1]));
                let ab = b - a;
                let len2 = ab.norm_squared();
                let t = if len2 > 0.0 {
                    ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (p - (a + ab * t)).norm()
            })
            .fold(f64::INFINITY, f64::min),
    }
}
