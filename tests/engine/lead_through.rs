//! Lead-through teaching (seed chapter 5): one LDS per simple trajectory, the online
//! segmentation of a hand-guided trajectory into LDSs whose attractors are the waypoints, and
//! the properties the seed proves. Synthetic trajectories pass through known waypoints with
//! straight and curved segments, bell-shaped speed, pauses, sensor noise and sampling jitter.

use nalgebra::{UnitQuaternion, Vector3};
use nextpose::engine::Pose;
use nextpose::engine::lead_through::lds::{Fit, FitSettings, State};
use nextpose::engine::lead_through::segment::{
    Criterion, SegmentSettings, Segmentation, TimedPose, TrajectoryError, segment,
};
use nextpose::simulation::operator::normal;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One leg of a synthetic demonstration: to `to`, straight or through `via` on a circular arc.
#[derive(Clone, Copy)]
struct Leg {
    to: Vector3<f64>,
    via: Option<Vector3<f64>>,
    /// Turn of the tool about its z axis over the leg (radians).
    turn: f64,
    /// Seconds the operator rests at `to`.
    pause: f64,
}

fn leg(x: f64, y: f64, z: f64) -> Leg {
    Leg {
        to: Vector3::new(x, y, z),
        via: None,
        turn: 0.0,
        pause: 0.0,
    }
}

/// How the operator's hand and the controller's sampling misbehave.
#[derive(Clone, Copy)]
struct Recording {
    /// mm per second at the middle of a leg.
    speed: f64,
    /// Nominal sample period (s).
    dt: f64,
    /// Sample period varies uniformly by ± this fraction.
    jitter: f64,
    /// Position noise per axis (mm, one sigma).
    noise_mm: f64,
    seed: u64,
}

const CLEAN: Recording = Recording {
    speed: 100.0,
    dt: 0.01,
    jitter: 0.0,
    noise_mm: 0.0,
    seed: 1,
};

/// A point on the arc from `a` through `v` to `b` at parameter `s ∈ [0, 1]`.
fn arc(a: Vector3<f64>, v: Vector3<f64>, b: Vector3<f64>, s: f64) -> Vector3<f64> {
    // Circle through three points: centre in their plane.
    let (ab, av) = (b - a, v - a);
    let n = ab.cross(&av);
    let centre = a
        + (av.norm_squared() * n.cross(&ab) + ab.norm_squared() * av.cross(&n))
            / (2.0 * n.norm_squared());
    let (ra, rb, rv) = (a - centre, b - centre, v - centre);
    let axis = n.normalize();
    let angle_to = |r: Vector3<f64>| {
        let mut t = ra.cross(&r).dot(&axis).atan2(ra.dot(&r));
        if t < 0.0 {
            t += std::f64::consts::TAU;
        }
        t
    };
    let (tv, tb) = (angle_to(rv), angle_to(rb));
    let total = if tv <= tb {
        tb
    } else {
        tb - std::f64::consts::TAU
    };
    let rotation = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), total * s);
    centre + rotation * ra
}

/// Length of a leg's path (mm), by fine sampling.
fn leg_length(from: Vector3<f64>, l: &Leg) -> f64 {
    let point = |s: f64| match l.via {
        None => from + (l.to - from) * s,
        Some(v) => arc(from, v, l.to, s),
    };
    let path: f64 = (0..200)
        .map(|i| (point((i + 1) as f64 / 200.0) - point(i as f64 / 200.0)).norm())
        .sum();
    // A turn in place takes as long as 50 mm per radian of travel.
    path.max(l.turn.abs() * 50.0)
}

/// Samples a demonstration from `start` through the legs: minimum-jerk timing on each leg (the
/// hand slows into every waypoint), pauses, jittered sample times and sensor noise.
fn record(start: Vector3<f64>, legs: &[Leg], rec: Recording) -> Vec<TimedPose> {
    let mut rng = ChaCha8Rng::seed_from_u64(rec.seed);
    let mut out = Vec::new();
    let mut t = 0.0;
    let mut from = start;
    let mut heading = 0.0;
    let mut push = |t: f64, p: Vector3<f64>, yaw: f64, rng: &mut ChaCha8Rng| {
        let noisy = p + Vector3::new(normal(rng), normal(rng), normal(rng)) * rec.noise_mm;
        let q = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, yaw);
        let pose = Pose::new([noisy.x, noisy.y, noisy.z], [q.w, q.i, q.j, q.k]).unwrap();
        out.push(TimedPose { t, pose });
    };
    push(t, from, heading, &mut rng);
    for l in legs {
        // Minimum-jerk: peak speed 1.875 × mean speed; choose the duration for `speed` at peak.
        let duration = 1.875 * leg_length(from, l) / rec.speed;
        let begin = t;
        loop {
            t += rec.dt * (1.0 + rec.jitter * (2.0 * rng.random::<f64>() - 1.0));
            let tau = ((t - begin) / duration).min(1.0);
            let s = tau.powi(3) * (10.0 - 15.0 * tau + 6.0 * tau * tau);
            let p = match l.via {
                None => from + (l.to - from) * s,
                Some(v) => arc(from, v, l.to, s),
            };
            push(t, p, heading + l.turn * s, &mut rng);
            if tau >= 1.0 {
                break;
            }
        }
        heading += l.turn;
        let rest_until = t + l.pause;
        while t + rec.dt < rest_until {
            t += rec.dt * (1.0 + rec.jitter * (2.0 * rng.random::<f64>() - 1.0));
            push(t, l.to, heading, &mut rng);
        }
        from = l.to;
    }
    out
}

/// Distance from each waypoint to the nearest attractor, and from each attractor to the
/// nearest waypoint.
fn matched(seg: &Segmentation, samples: &[TimedPose], waypoints: &[Vector3<f64>]) -> (f64, f64) {
    let attractors: Vec<Vector3<f64>> = seg
        .attractors()
        .map(|i| samples[i].pose.position())
        .collect();
    let nearest = |p: &Vector3<f64>, set: &[Vector3<f64>]| {
        set.iter()
            .map(|q| (p - q).norm())
            .fold(f64::INFINITY, f64::min)
    };
    let recall = waypoints
        .iter()
        .map(|w| nearest(w, &attractors))
        .fold(0.0, f64::max);
    let precision = attractors
        .iter()
        .map(|a| nearest(a, waypoints))
        .fold(0.0, f64::max);
    (recall, precision)
}

/// A cell-sized polyline: approach, a rectangle, a retract along the approach line.
fn polyline() -> (Vector3<f64>, Vec<Leg>) {
    let start = Vector3::new(400.0, -100.0, 300.0);
    let legs = vec![
        leg(400.0, -100.0, 150.0),
        leg(600.0, -100.0, 150.0),
        leg(600.0, 50.0, 150.0),
        leg(400.0, 50.0, 150.0),
        leg(400.0, -100.0, 150.0),
        leg(400.0, -100.0, 300.0),
    ];
    (start, legs)
}

fn waypoints(start: Vector3<f64>, legs: &[Leg]) -> Vec<Vector3<f64>> {
    std::iter::once(start)
        .chain(legs.iter().map(|l| l.to))
        .collect()
}

/// The waypoints other than the start (the start is the first sample, not an attractor).
fn targets(legs: &[Leg]) -> Vec<Vector3<f64>> {
    legs.iter().map(|l| l.to).collect()
}

#[test]
fn a_clean_polyline_gives_one_attractor_per_corner() {
    let (start, legs) = polyline();
    let samples = record(start, &legs, CLEAN);
    let seg = segment(&samples, &SegmentSettings::default()).unwrap();
    assert_eq!(
        seg.segments.len(),
        legs.len(),
        "{:?}",
        attractor_list(&seg, &samples)
    );
    let (recall, precision) = matched(&seg, &samples, &targets(&legs));
    assert!(recall < 1.5, "a corner is {recall} mm from its attractor");
    assert!(
        precision < 1.5,
        "an attractor is {precision} mm from any corner"
    );
    assert!(seg.converged);
    assert!(seg.mean_error_mm < 1.0, "mean error {}", seg.mean_error_mm);
    assert!(seg.parameters() < seg.raw_parameters());
}

fn attractor_list(seg: &Segmentation, samples: &[TimedPose]) -> Vec<[i64; 3]> {
    seg.attractors()
        .map(|i| {
            let p = samples[i].pose.position();
            [p.x.round() as i64, p.y.round() as i64, p.z.round() as i64]
        })
        .collect()
}

#[test]
fn noise_jitter_pauses_and_speed_do_not_move_the_attractors() {
    let (start, mut legs) = polyline();
    legs[1].pause = 1.5;
    legs[3].pause = 0.8;
    legs[0].turn = 0.6;
    let settings = SegmentSettings {
        min_step_mm: 2.0,
        ..SegmentSettings::default()
    };
    for (seed, speed, noise) in [(2, 60.0, 0.1), (3, 250.0, 0.2), (4, 120.0, 0.3)] {
        let rec = Recording {
            speed,
            dt: 0.008,
            jitter: 0.4,
            noise_mm: noise,
            seed,
        };
        let samples = record(start, &legs, rec);
        let seg = segment(&samples, &settings).unwrap();
        let (recall, precision) = matched(&seg, &samples, &targets(&legs));
        let found = attractor_list(&seg, &samples);
        assert!(
            recall < 4.0,
            "seed {seed}: a corner {recall} mm off: {found:?}"
        );
        assert!(
            precision < 4.0,
            "seed {seed}: a stray attractor {precision} mm off: {found:?}"
        );
        assert!(seg.converged, "seed {seed}");
        assert!(
            seg.mean_error_mm < 2.0,
            "seed {seed}: {}",
            seg.mean_error_mm
        );
    }
}

/// A recording with 0.1 mm of noise and ±30 % jitter, segmented with `min_step_mm` 2.
fn noisy(start: Vector3<f64>, legs: &[Leg]) -> (Vec<TimedPose>, Segmentation) {
    let rec = Recording {
        noise_mm: 0.1,
        jitter: 0.3,
        ..CLEAN
    };
    let samples = record(start, legs, rec);
    let settings = SegmentSettings {
        min_step_mm: 2.0,
        ..SegmentSettings::default()
    };
    let seg = segment(&samples, &settings).unwrap();
    (samples, seg)
}

#[test]
fn a_pause_in_the_middle_of_a_line_adds_no_waypoint() {
    let start = Vector3::new(0.0, 0.0, 0.0);
    let mut legs = vec![
        leg(150.0, 0.0, 0.0),
        leg(300.0, 0.0, 0.0),
        leg(300.0, 200.0, 0.0),
    ];
    legs[0].pause = 2.0;
    let (samples, seg) = noisy(start, &legs);
    let found = attractor_list(&seg, &samples);
    // The rest at 150 mm is on the line from 0 to 300: only the corner and the end remain.
    let corners = [legs[1].to, legs[2].to];
    let (recall, precision) = matched(&seg, &samples, &corners);
    assert!(recall < 4.0 && precision < 4.0, "{found:?}");
}

#[test]
fn curved_legs_keep_their_end_points() {
    let start = Vector3::new(500.0, 0.0, 200.0);
    let legs = vec![
        Leg {
            via: Some(Vector3::new(520.0, 70.0, 200.0)),
            ..leg(500.0, 140.0, 200.0)
        },
        leg(300.0, 140.0, 200.0),
        Leg {
            via: Some(Vector3::new(270.0, 50.0, 200.0)),
            ..leg(300.0, -40.0, 200.0)
        },
        leg(300.0, -40.0, 350.0),
    ];
    let (samples, seg) = noisy(start, &legs);
    let found = attractor_list(&seg, &samples);
    // Every end point (each a corner: the arcs meet the lines at 58° and 53°) is found; an
    // arc may need an attractor along it.
    let (recall, _) = matched(&seg, &samples, &targets(&legs));
    assert!(recall < 4.0, "{found:?}");
    assert!(seg.segments.len() <= 2 * legs.len(), "{found:?}");
    assert!(seg.converged);
    assert!(seg.mean_error_mm < 3.0, "mean error {}", seg.mean_error_mm);
}

#[test]
fn eq_5_7_as_written_cuts_a_steady_line_into_pieces_and_the_direction_form_does_not() {
    // A straight line at constant speed: the LDS slows into its attractor, the hand does not.
    let samples: Vec<TimedPose> = (0..=300)
        .map(|i| TimedPose {
            t: i as f64 * 0.01,
            pose: Pose::new([i as f64, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap(),
        })
        .collect();
    let direction = segment(&samples, &SegmentSettings::default()).unwrap();
    assert_eq!(direction.segments.len(), 1);
    let eq_5_7 = SegmentSettings {
        criterion: Criterion::ErrorOverStep,
        epsilon_max: 0.8,
        ..SegmentSettings::default()
    };
    let cut = segment(&samples, &eq_5_7).unwrap();
    assert!(cut.segments.len() >= 10, "{} segments", cut.segments.len());
}

#[test]
fn a_reorientation_in_place_is_a_waypoint() {
    // The arm moves, then only turns the tool 60° in place, then moves on.
    let start = Vector3::new(0.0, 0.0, 0.0);
    let legs = vec![
        leg(200.0, 0.0, 0.0),
        Leg {
            turn: 1.0,
            ..leg(200.0, 0.0, 0.0)
        },
        leg(200.0, 150.0, 0.0),
    ];
    let samples = record(start, &legs, CLEAN);
    let seg = segment(&samples, &SegmentSettings::default()).unwrap();
    let turned = seg
        .attractors()
        .filter(|&i| samples[i].pose.rotation().angle() > 0.9)
        .count();
    assert_eq!(
        seg.segments.len(),
        3,
        "{:?}",
        attractor_list(&seg, &samples)
    );
    assert!(turned >= 2);
}

#[test]
fn bad_trajectories_are_refused_with_the_reason() {
    let p = Pose::new([0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
    let s = SegmentSettings::default();
    assert_eq!(
        segment(&[TimedPose { t: 0.0, pose: p }], &s),
        Err(TrajectoryError::TooFewSamples(1))
    );
    let backwards = [TimedPose { t: 1.0, pose: p }, TimedPose { t: 0.5, pose: p }];
    assert!(matches!(
        segment(&backwards, &s),
        Err(TrajectoryError::TimeNotIncreasing { index: 1, .. })
    ));
    let nan = [
        TimedPose { t: 0.0, pose: p },
        TimedPose {
            t: f64::NAN,
            pose: p,
        },
    ];
    assert!(matches!(
        segment(&nan, &s),
        Err(TrajectoryError::TimeNotFinite { index: 1, .. })
    ));
    let far = Pose::new([2e6, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]).unwrap();
    let beyond = [
        TimedPose { t: 0.0, pose: p },
        TimedPose { t: 1.0, pose: far },
    ];
    assert_eq!(
        segment(&beyond, &s),
        Err(TrajectoryError::PositionOutOfRange { index: 1 })
    );
    let bad = SegmentSettings {
        epsilon_max: -1.0,
        ..s
    };
    let two = [TimedPose { t: 0.0, pose: p }, TimedPose { t: 1.0, pose: p }];
    let err = segment(&two, &bad).unwrap_err();
    assert!(err.to_string().contains("epsilon_max"), "{err}");
    // Standing still is a trajectory of one point: one segment, nothing to reproduce.
    let still = segment(&two, &s).unwrap();
    assert_eq!(still.segments.len(), 1);
    assert!(still.converged);
}

fn state2(x: f64, y: f64) -> State {
    State::from_column_slice(&[x, y, 0.0, 0.0, 0.0, 0.0])
}

/// Rank of the stacked `δ_n = x_n − x_N` (singular values above 1e-6 of the largest).
fn delta_rank(demo: &[State]) -> usize {
    let a = demo[demo.len() - 1];
    let m = nalgebra::DMatrix::from_fn(6, demo.len() - 1, |r, c| demo[c][r] - a[r]);
    let s = m.singular_values();
    let largest = s.max();
    s.iter().filter(|v| **v > largest * 1e-6).count()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Theorem 5.2: when Δ has full row rank the control law converges to the attractor, from
    /// the demonstration's start and from anywhere else.
    #[test]
    fn theorem_5_2_reproduction_converges_when_delta_has_full_row_rank(
        points in prop::collection::vec(prop::array::uniform6(-500.0f64..500.0), 7..40),
        other in prop::array::uniform6(-1000.0f64..1000.0),
    ) {
        let demo: Vec<State> = points.iter().map(|p| State::from_column_slice(p)).collect();
        prop_assume!(delta_rank(&demo) == 6);
        let settings = FitSettings { kappa_max: f64::INFINITY, rank_tolerance: 1e-9, min_extent: 0.0 };
        let fit = Fit::demonstrations(&[&demo], &settings).unwrap();
        prop_assert!(!fit.identity);
        prop_assert_eq!(fit.rank, 6);
        prop_assert!(fit.spectral_radius() < 1.0, "ρ(I+R) = {}", fit.spectral_radius());
        let attractor = demo[demo.len() - 1];
        // Slow modes near ρ = 1 may need many steps: the bound is geometric in ρ.
        let steps = ((1e-9f64).ln() / fit.spectral_radius().ln()).ceil().min(1e7) as usize + 100;
        for start in [demo[0], State::from_column_slice(&other)] {
            let out = fit.reproduce(&start, &attractor, 1e-3, steps);
            prop_assert!(out.converged, "from {:?}: {} steps", start, out.path.len());
        }
    }

    /// Whatever the trajectory (lines, planes, noise), the fitted law converges: the fit in the
    /// spanned subspace is Theorem 5.2's, the rest is a scaled identity.
    #[test]
    fn every_fit_converges(
        points in prop::collection::vec(prop::array::uniform2(-300.0f64..300.0), 3..30),
        kappa in prop::sample::select(vec![10.0, 1e4, f64::INFINITY]),
    ) {
        let demo: Vec<State> = points.iter().map(|p| state2(p[0], p[1])).collect();
        let settings = FitSettings { kappa_max: kappa, ..FitSettings::default() };
        let fit = Fit::demonstrations(&[&demo], &settings).unwrap();
        prop_assert!(fit.spectral_radius() < 1.0 + 1e-12);
        let out = fit.reproduce(&demo[0], &demo[demo.len() - 1], 1e-2, 2_000_000);
        prop_assert!(out.converged);
    }
}

/// A slow counter-clockwise spiral into `a`: the "intended" LDS of the seed's Figure 5.3.
fn spiral(start: State, a: State, steps: usize) -> Vec<State> {
    let (c, s) = (0.01f64.cos(), 0.01f64.sin());
    let mut out = vec![start];
    for _ in 0..steps {
        let x = *out.last().unwrap() - a;
        let turned = state2(c * x[0] - s * x[1], s * x[0] + c * x[1]);
        out.push(a + turned * 0.9);
    }
    out
}

/// Mean distance between the reproduction from `start` and the intended path from there.
fn generalisation_error(fit: &Fit, start: State, a: State) -> f64 {
    let intended = spiral(start, a, 200);
    let got = fit.reproduce(&start, &a, 0.05, 100_000).path;
    let point_to_path = |p: &State, path: &[State]| {
        path.iter()
            .map(|q| (p - q).norm())
            .fold(f64::INFINITY, f64::min)
    };
    intended.iter().map(|p| point_to_path(p, &got)).sum::<f64>() / intended.len() as f64
}

#[test]
fn two_demonstrations_generalise_better_than_either_alone() {
    // Figure 5.3: two noisy demonstrations of a slight counter-clockwise curve, from different
    // sides. Each is nearly straight, so alone its sideways law is fitted to noise; together
    // they give the curve's law.
    let a = state2(0.0, 0.0);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut noisy = |demo: Vec<State>| -> Vec<State> {
        let last = demo.len() - 1;
        demo.into_iter()
            .enumerate()
            .map(|(i, x)| {
                if i == last {
                    x
                } else {
                    x + state2(normal(&mut rng), normal(&mut rng)) * 0.3
                }
            })
            .collect()
    };
    // Each demonstration ends at the attractor (the seed's simple trajectory).
    let mut demo = |start| {
        let mut d = spiral(start, a, 40);
        d.push(a);
        noisy(d)
    };
    let one = demo(state2(100.0, 0.0));
    let two = demo(state2(0.0, 100.0));
    let settings = FitSettings::default();
    let fit_one = Fit::demonstrations(&[&one], &settings).unwrap();
    let fit_two = Fit::demonstrations(&[&two], &settings).unwrap();
    let both = Fit::demonstrations(&[&one, &two], &settings).unwrap();
    // Novel starts all around the attractor.
    let starts: Vec<State> = (0..12)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / 12.0 + 0.1;
            state2(120.0 * t.cos(), 120.0 * t.sin())
        })
        .collect();
    let error = |f: &Fit| {
        starts
            .iter()
            .map(|s| generalisation_error(f, *s, a))
            .sum::<f64>()
            / starts.len() as f64
    };
    let (e1, e2, e12) = (error(&fit_one), error(&fit_two), error(&both));
    eprintln!("generalisation error: alone {e1:.3} and {e2:.3} mm, together {e12:.3} mm");
    assert!(
        e12 < e1 && e12 < e2,
        "alone {e1:.2} and {e2:.2} mm, together {e12:.2} mm"
    );
    // The combined law turns the intended way (counter-clockwise: R₂₁ − R₁₂ > 0) at about the
    // intended rate; at least one demonstration alone does not.
    let turn = |f: &Fit| f.r[(1, 0)] - f.r[(0, 1)];
    let intended = 2.0 * 0.9 * 0.01f64.sin();
    assert!(
        (turn(&both) - intended).abs() < 0.3 * intended,
        "{}",
        turn(&both)
    );
    assert!(
        (turn(&fit_one) - intended)
            .abs()
            .max((turn(&fit_two) - intended).abs())
            > 0.5 * intended
    );
}

#[test]
fn parameter_count_is_m_times_d_squared_plus_d() {
    let (start, legs) = polyline();
    let samples = record(start, &legs, CLEAN);
    let seg = segment(&samples, &SegmentSettings::default()).unwrap();
    assert_eq!(seg.parameters(), seg.segments.len() * (36 + 6));
    assert_eq!(seg.raw_parameters(), samples.len() * 6);
    eprintln!(
        "polyline: {} samples, {} LDSs, {} numbers against {} ({:.1} %)",
        samples.len(),
        seg.segments.len(),
        seg.parameters(),
        seg.raw_parameters(),
        100.0 * seg.parameters() as f64 / seg.raw_parameters() as f64
    );
    let _ = waypoints(start, &legs);
}

/// The LASA handwriting set (real demonstrations: 30 shapes × 7, drawn on a tablet), as
/// `scripts/lasa.sh` writes it into `target/lasa/` from the Python package that ships it.
/// Ignored by plain `cargo test` (it needs that export); `scripts/test.sh` exports and runs it.
#[test]
#[ignore = "needs target/lasa/ from scripts/lasa.sh (scripts/test.sh runs it)"]
fn lasa_handwriting_is_segmented_and_reproduced() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/lasa");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e} (run scripts/lasa.sh first)", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 210, "30 shapes × 7 demonstrations");
    let settings = SegmentSettings::default();
    let (mut ldss, mut error) = (0usize, 0.0);
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let samples: Vec<TimedPose> = nextpose::import::trajectory::parse_trajectory(&text)
            .unwrap()
            .into_iter()
            .map(|s| s.sample)
            .collect();
        let seg = segment(&samples, &settings).unwrap();
        assert!(seg.converged, "{}", f.display());
        // Every demonstration ends at the shape's target; its last sample is the last attractor.
        assert_eq!(seg.attractors().last(), Some(samples.len() - 1));
        assert!(
            seg.mean_error_mm < 2.0,
            "{}: {} mm",
            f.display(),
            seg.mean_error_mm
        );
        assert!(seg.parameters() < seg.raw_parameters() / 10);
        ldss += seg.segments.len();
        error += seg.mean_error_mm;
    }
    let n = files.len() as f64;
    eprintln!(
        "LASA: {:.1} LDSs per demonstration, mean reproduction error {:.3} mm",
        ldss as f64 / n,
        error / n
    );
    assert!(error / n < 1.0);
}

/// `nextpose segment` reads a CSV (with joints), prints and writes the attractors, and names
/// what is wrong with a bad file.
#[test]
fn the_segment_command_reads_a_csv_and_writes_the_attractors() {
    let (start, legs) = polyline();
    let samples = record(start, &legs, CLEAN);
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rectangle.csv");
    let mut text = String::from("t,x,y,z,qw,qx,qy,qz,j1,j2\n");
    for (i, s) in samples.iter().enumerate() {
        let v = s.pose.values();
        text += &format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            s.t,
            v.x,
            v.y,
            v.z,
            v.qw,
            v.qx,
            v.qy,
            v.qz,
            i,
            -(i as f64)
        );
    }
    std::fs::write(&csv, text).unwrap();
    let json = dir.path().join("out.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nextpose"))
        .arg("segment")
        .arg(&csv)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("6 LDSs"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let attractors = report[0]["attractors"].as_array().unwrap();
    assert_eq!(attractors.len(), legs.len());
    for (a, l) in attractors.iter().zip(&legs) {
        let p = Vector3::new(
            a["pose"]["x"].as_f64().unwrap(),
            a["pose"]["y"].as_f64().unwrap(),
            a["pose"]["z"].as_f64().unwrap(),
        );
        assert!((p - l.to).norm() < 1.5, "{p} for {}", l.to);
        // The attractor's joints are the sample's own.
        let i = a["sample"].as_u64().unwrap() as f64;
        assert_eq!(a["joints"][0].as_f64(), Some(i));
    }

    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "t,x,y\n0,0,0\n1,abc,0\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nextpose"))
        .arg("segment")
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("line 3") && stderr.contains("\"abc\""),
        "{stderr}"
    );
}
