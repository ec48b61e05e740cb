//! Behaviour of the engine through its public API: repeated, moved, rotated and scaled
//! patterns, numerical stability, and bad input.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use nextpose::engine::config::MergeRule;
use nextpose::engine::{EngineConfig, Pose, PoseError, Profile, Teacher, Withheld};

/// The default profile's model (the CDHMM) alone, without the experts' offer rule: these tests
/// are about the model's own behaviour (its gates, recall, scale, within-routine learning).
fn model_only() -> EngineConfig {
    EngineConfig {
        offer: None,
        ..EngineConfig::profile(Profile::Default)
    }
}

fn pose(p: [f64; 3], rpy: [f64; 3]) -> Pose {
    let q = UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    Pose::new(p, [q.w, q.i, q.j, q.k]).unwrap()
}

/// A U-shaped seam with approach and retract: 8 waypoints, mixed translations and rotations.
fn u_seam() -> Vec<Pose> {
    vec![
        pose([0.0, 0.0, 100.0], [0.0, 0.0, 0.0]),
        pose([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        pose([120.0, 0.0, 0.0], [0.0, 0.2, 0.0]),
        pose([120.0, 60.0, 0.0], [0.0, 0.2, 0.5]),
        pose([0.0, 60.0, 0.0], [0.0, 0.0, 0.5]),
        pose([0.0, 60.0, 40.0], [0.1, 0.0, 0.5]),
        pose([-30.0, 60.0, 90.0], [0.1, 0.0, 0.0]),
        pose([-30.0, 0.0, 150.0], [0.0, 0.0, 0.0]),
    ]
}

fn transformed(routine: &[Pose], g: &Isometry3<f64>, scale: f64) -> Vec<Pose> {
    routine
        .iter()
        .map(|w| {
            let mut iso = *w.isometry();
            iso.translation.vector *= scale;
            Pose::from_isometry(g * iso)
        })
        .collect()
}

fn somewhere_else() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(812.0, -455.5, 230.25),
        UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(0.3, -1.0, 0.4)),
            1.1,
        ),
    )
}

fn teach_routine(t: &mut Teacher, routine: &[Pose]) {
    for w in routine {
        t.teach(*w);
    }
    t.finish_routine();
}

/// Teaches `copy` waypoint by waypoint and returns, for each waypoint after the second, the
/// prediction made just before it was taught.
fn predictions_on(t: &mut Teacher, copy: &[Pose]) -> Vec<nextpose::engine::Prediction> {
    let mut out = Vec::new();
    for (n, w) in copy.iter().enumerate() {
        if n >= 2 {
            out.push(t.predict());
        }
        t.teach(*w);
    }
    t.finish_routine();
    out
}

#[test]
fn second_copy_at_another_place_and_orientation_is_predicted_exactly() {
    for profile in [Profile::Dissertation, Profile::Default] {
        let mut t = Teacher::new(EngineConfig::profile(profile)).unwrap();
        teach_routine(&mut t, &u_seam());
        let copy = transformed(&u_seam(), &somewhere_else(), 1.0);
        let preds = predictions_on(&mut t, &copy);
        for (k, p) in preds.iter().enumerate() {
            let truth = copy[k + 2];
            assert!(
                p.offered(),
                "{profile:?} waypoint {}: withheld {:?}",
                k + 2,
                p.withheld
            );
            let guess = p.pose.unwrap();
            assert!(
                guess.distance_to(&truth) < 1e-6,
                "{profile:?} waypoint {}: {} mm",
                k + 2,
                guess.distance_to(&truth)
            );
            assert!(guess.angle_to(&truth) < 1e-9);
            assert_eq!(p.psi, 1.0);
        }
    }
}

#[test]
fn scaled_copies_are_recognised_with_the_right_scale() {
    for factor in [2.0, 0.5] {
        let mut cfg = model_only();
        cfg.predict.horizon = 3;
        let mut t = Teacher::new(cfg).unwrap();
        teach_routine(&mut t, &u_seam());
        let copy = transformed(&u_seam(), &somewhere_else(), factor);
        let preds = predictions_on(&mut t, &copy);
        // From the fourth waypoint on, the window holds enough translation to fix the scale.
        for (k, p) in preds.iter().enumerate().skip(1) {
            let truth = copy[k + 2];
            assert!(
                p.offered(),
                "×{factor} waypoint {}: withheld {:?}",
                k + 2,
                p.withheld
            );
            assert!(
                (p.routine_scale() - factor).abs() < 1e-4 * factor,
                "×{factor}: routine scale {}",
                p.routine_scale()
            );
            assert!((p.psi - 1.0 / factor).abs() < 1e-4, "ψ = {}", p.psi);
            let guess = p.pose.unwrap();
            assert!(
                guess.distance_to(&truth) < 0.05,
                "×{factor} waypoint {}: {} mm",
                k + 2,
                guess.distance_to(&truth)
            );
        }
    }
}

#[test]
fn scale_off_does_not_recognise_a_scaled_copy() {
    let mut cfg = EngineConfig::profile(Profile::Default);
    cfg.predict.scale.enabled = false;
    let mut t = Teacher::new(cfg).unwrap();
    teach_routine(&mut t, &u_seam());
    let copy = transformed(&u_seam(), &somewhere_else(), 2.0);
    let preds = predictions_on(&mut t, &copy);
    assert!(preds.iter().all(|p| !p.offered()));
}

#[test]
fn learn_scaled_hmm_merges_a_scaled_copy_into_the_same_states() {
    let mut cfg = EngineConfig::profile(Profile::Dissertation);
    cfg.predict.scale.learn_scaled = true;
    let mut t = Teacher::new(cfg.clone()).unwrap();
    teach_routine(&mut t, &u_seam());
    let states = t.stats().states;
    teach_routine(&mut t, &transformed(&u_seam(), &somewhere_else(), 2.0));
    assert_eq!(
        t.stats().states,
        states,
        "a 2× copy learned scaled reuses every state"
    );

    cfg.predict.scale.learn_scaled = false;
    let mut plain = Teacher::new(cfg).unwrap();
    teach_routine(&mut plain, &u_seam());
    teach_routine(&mut plain, &transformed(&u_seam(), &somewhere_else(), 2.0));
    assert!(plain.stats().states > states);
}

#[test]
fn repeats_inside_one_routine_are_predicted_when_learning_within_the_routine() {
    // A stitch: the same 4-move pattern repeated 6 times along a line, in one routine.
    let mut routine = vec![pose([0.0, 0.0, 50.0], [0.0, 0.0, 0.0])];
    for k in 0..6 {
        let x = 40.0 * f64::from(k);
        routine.push(pose([x, 0.0, 0.0], [0.0, 0.0, 0.0]));
        routine.push(pose([x + 20.0, 0.0, 0.0], [0.0, 0.3, 0.0]));
        routine.push(pose([x + 20.0, 0.0, 30.0], [0.0, 0.0, 0.0]));
        routine.push(pose([x + 40.0, 0.0, 50.0], [0.0, 0.0, 0.0]));
    }
    let offered_exact = |within: bool| {
        let mut cfg = model_only();
        cfg.learn_within_routine = within;
        let mut t = Teacher::new(cfg).unwrap();
        predictions_on(&mut t, &routine)
            .iter()
            .enumerate()
            .filter(|(k, p)| p.offered() && p.pose.unwrap().distance_to(&routine[k + 2]) < 1e-6)
            .count()
    };
    assert_eq!(
        offered_exact(false),
        0,
        "nothing learned before the routine ends"
    );
    assert!(
        offered_exact(true) >= 12,
        "later stitches are predicted from earlier ones: {}",
        offered_exact(true)
    );
}

/// Waypoints from a start and a list of translations.
fn walk(moves: &[[f64; 3]]) -> Vec<Pose> {
    let mut p = [0.0, 0.0, 0.0];
    let mut out = vec![pose(p, [0.0; 3])];
    for m in moves {
        for k in 0..3 {
            p[k] += m[k];
        }
        out.push(pose(p, [0.0; 3]));
    }
    out
}

#[test]
fn recall_settles_a_next_state_the_first_order_model_finds_ambiguous() {
    // Two routines share the moves b, c and differ before (a / x) and after (d / e): after c the
    // HMM's state has two equally likely successors, the full window a, b, c has one.
    let (a, x, b, c) = (
        [100.0, 0.0, 0.0],
        [0.0, 100.0, 0.0],
        [0.0, 0.0, 50.0],
        [30.0, 30.0, 0.0],
    );
    let (d, e) = ([-80.0, 0.0, 0.0], [0.0, -80.0, 0.0]);
    let first = walk(&[a, b, c, d]);
    let second = walk(&[x, b, c, e]);
    let probe = walk(&[a, b, c, d]);
    let predict = |recall: bool| {
        let mut cfg = model_only();
        if !recall {
            cfg.predict.recall = None;
        }
        let mut t = Teacher::new(cfg).unwrap();
        teach_routine(&mut t, &first);
        teach_routine(&mut t, &second);
        for w in &probe[..4] {
            t.teach(*w);
        }
        t.predict()
    };
    let without = predict(false);
    assert!(
        matches!(
            without.withheld,
            Some(Withheld::LowConfidence { .. } | Withheld::WideSpread { .. })
        ),
        "{without:?}"
    );
    let with = predict(true);
    assert!(with.offered(), "{with:?}");
    assert!(with.recalled.is_some());
    assert!(with.pose.unwrap().distance_to(&probe[4]) < 1e-6);
}

#[test]
fn finished_routine_is_not_counted_twice_when_learning_within() {
    let mut within = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
    let mut cfg = EngineConfig::profile(Profile::Default);
    cfg.learn_within_routine = false;
    let mut after = Teacher::new(cfg).unwrap();
    for _ in 0..3 {
        teach_routine(&mut within, &u_seam());
        teach_routine(&mut after, &u_seam());
    }
    assert_eq!(within.stats(), after.stats());
    assert_eq!(within.stats().observations, 21);
    assert_eq!(within.stats().routines, 3);
}

#[test]
fn forward_recursion_is_stable_over_long_windows() {
    // 1,000-move windows over a model of a long random walk: no NaN, no infinity.
    let mut rng_state = 12345u64;
    let mut next = || {
        rng_state = rng_state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((rng_state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let walk: Vec<Pose> = (0..1001)
        .map(|i| {
            pose(
                [
                    f64::from(i) * 3.0 + next() * 5.0,
                    next() * 200.0,
                    next() * 50.0,
                ],
                [next(), next(), next()],
            )
        })
        .collect();
    for profile in [Profile::Dissertation, Profile::Default] {
        let mut cfg = EngineConfig::profile(profile);
        cfg.predict.horizon = 1000;
        cfg.learn_within_routine = false;
        let mut t = Teacher::new(cfg).unwrap();
        teach_routine(&mut t, &walk);
        // The same walk again (matches) and a reversed one (matches nothing).
        for w in [walk.clone(), walk.iter().rev().copied().collect::<Vec<_>>()] {
            for p in &w {
                t.teach(*p);
            }
            let pred = t.predict();
            for v in [pred.phi, pred.psi, pred.end_probability] {
                assert!(v.is_finite(), "{profile:?}: {pred:?}");
            }
            assert!(pred.misfit.is_none_or(f64::is_finite));
            assert!(pred.spread.is_none_or(f64::is_finite));
            if let Some(x) = pred.relative {
                assert!(x.iter().all(|v| v.is_finite()));
            }
            t.finish_routine();
        }
    }
}

#[test]
fn withheld_reasons_are_reported() {
    let mut t = Teacher::new(model_only()).unwrap();
    assert_eq!(t.predict().withheld, Some(Withheld::NothingTaught));
    t.teach(pose([0.0; 3], [0.0; 3]));
    assert_eq!(t.predict().withheld, Some(Withheld::EmptyModel));
    t.teach(pose([10.0, 0.0, 0.0], [0.0; 3]));
    t.finish_routine();
    t.teach(pose([0.0; 3], [0.0; 3]));
    assert!(matches!(
        t.predict().withheld,
        Some(Withheld::TooFewStates { states: 1 })
    ));
    teach_routine(&mut t, &u_seam()[1..]);
    teach_routine(&mut t, &u_seam());
    // After the seam's last move the routine always ended: likely end.
    for w in u_seam() {
        t.teach(w);
    }
    assert!(
        matches!(t.predict().withheld, Some(Withheld::LikelyEnd { .. })),
        "{:?}",
        t.predict()
    );
    t.finish_routine();
    // A window of moves never seen: poor match or no match, never offered.
    t.teach(pose([0.0; 3], [0.0; 3]));
    t.teach(pose([333.0, 1.0, 7.0], [0.9, 0.0, 0.0]));
    t.teach(pose([500.0, -80.0, 7.0], [0.0, 0.7, 0.0]));
    let p = t.predict();
    assert!(
        matches!(
            p.withheld,
            Some(Withheld::NoMatch | Withheld::PoorMatch { .. })
        ),
        "{p:?}"
    );
}

#[test]
fn bad_input_gives_typed_errors() {
    assert!(matches!(
        Pose::new([0.0, f64::NAN, 0.0], [1.0, 0.0, 0.0, 0.0]),
        Err(PoseError::NonFinite { field: "y", .. })
    ));
    assert!(matches!(
        Pose::new([0.0; 3], [0.7, 0.0, 0.0, 0.0]),
        Err(PoseError::NotUnitQuaternion { .. })
    ));
    let mut cfg = EngineConfig::profile(Profile::Default);
    cfg.delta = 1.5;
    assert!(Teacher::new(cfg).is_err());
    let mut cfg = EngineConfig::profile(Profile::Default);
    cfg.merge = MergeRule::Total;
    cfg.sigma_q = 0.0;
    assert!(Teacher::new(cfg).is_err());
}
