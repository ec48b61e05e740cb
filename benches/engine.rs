//! Engine cost: learn + predict per taught waypoint at ~1,000 and ~10,000 states (synthetic
//! programs), and the whole shared corpus replayed through the default profile.
//!
//! Run: `cargo bench --bench engine` (figures in docs/results/performance.md).

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::UnitQuaternion;
use nextpose::engine::{EngineConfig, Pose, Profile, Teacher};
use nextpose::replay::methods::EngineMethod;
use nextpose::replay::{load_paths, replay_program};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// A pool of `moves` distinct relative moves and routines walking a sparse random Markov chain
/// over them, so the learned model has about `moves` states with structure to match.
fn synthetic_routines(moves: usize, routines: usize, len: usize, seed: u64) -> Vec<Vec<Pose>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let pool: Vec<([f64; 3], [f64; 3])> = (0..moves)
        .map(|_| {
            (
                [
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-100.0..100.0),
                ],
                [
                    rng.random_range(-0.3..0.3),
                    rng.random_range(-0.3..0.3),
                    rng.random_range(-0.3..0.3),
                ],
            )
        })
        .collect();
    let successors: Vec<[usize; 2]> = (0..moves)
        .map(|_| [rng.random_range(0..moves), rng.random_range(0..moves)])
        .collect();
    (0..routines)
        .map(|_| {
            let mut pose = *Pose::identity().isometry();
            let mut m = rng.random_range(0..moves);
            let mut out = vec![Pose::from_isometry(pose)];
            for _ in 0..len {
                let (t, r) = pool[m];
                let step = nalgebra::Isometry3::from_parts(
                    nalgebra::Translation3::new(t[0], t[1], t[2]),
                    UnitQuaternion::from_euler_angles(r[0], r[1], r[2]),
                );
                pose *= step;
                out.push(Pose::from_isometry(pose));
                m = successors[m][rng.random_range(0..2)];
            }
            out
        })
        .collect()
}

fn learn_and_predict(c: &mut Criterion) {
    let mut group = c.benchmark_group("learn_predict_per_waypoint");
    for (moves, routines) in [(1_300usize, 300usize), (13_000, 2_600)] {
        let mut teacher = Teacher::new(EngineConfig::profile(Profile::Default)).unwrap();
        for r in synthetic_routines(moves, routines, 20, 1) {
            for w in r {
                teacher.teach(w);
            }
            teacher.finish_routine();
        }
        let states = teacher.stats().states;
        let workload: Vec<Pose> = synthetic_routines(moves, 50, 20, 2).concat();
        // Tail latency, printed (criterion reports the mean): one timed call per waypoint.
        let mut probe = teacher.clone();
        let mut micros: Vec<f64> = workload
            .iter()
            .enumerate()
            .map(|(k, w)| {
                let t0 = std::time::Instant::now();
                if k % 21 == 20 {
                    probe.finish_routine();
                }
                probe.teach(*w);
                black_box(probe.predict());
                t0.elapsed().as_secs_f64() * 1e6
            })
            .collect();
        micros.sort_by(f64::total_cmp);
        let pct = |q: f64| micros[((micros.len() - 1) as f64 * q) as usize];
        eprintln!(
            "{states} states: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs over {} waypoints",
            pct(0.5),
            pct(0.99),
            pct(1.0),
            micros.len()
        );
        // Criterion runs ~100k iterations: finishing routines would grow the model far beyond
        // the size measured, so each routine is abandoned instead (within-routine learning and
        // its rollback are still paid; the timed calls above include finishing).
        let mut k = 0;
        group.bench_function(format!("{states}_states"), |b| {
            b.iter(|| {
                let w = workload[k % workload.len()];
                k += 1;
                if k % 21 == 0 {
                    teacher.abandon_routine();
                }
                teacher.teach(w);
                black_box(teacher.predict())
            })
        });
    }
    group.finish();
}

fn corpus_replay(c: &mut Criterion) {
    let corpus = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/corpus/json"
    ));
    let Ok(programs) = load_paths(&[corpus]) else {
        eprintln!("shared corpus not found; skipping corpus_replay");
        return;
    };
    let mut engine = EngineMethod::new(EngineConfig::profile(Profile::Default)).unwrap();
    c.bench_function("corpus_replay_default", |b| {
        b.iter(|| {
            for p in &programs {
                black_box(replay_program(p, &mut engine));
            }
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(5));
    targets = learn_and_predict, corpus_replay
}
criterion_main!(benches);
