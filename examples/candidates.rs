//! Analysis aid (not part of the product): every candidate each frame's history offers for
//! each scored corpus waypoint, with its evidence and whether it would have been useful, as CSV.
//!
//! `cargo run --release --example candidates -- ../shared/corpus/json > candidates.csv`

use nextpose::engine::{EngineConfig, Pose, Teacher};
use nextpose::replay::frames::{Frame, close};
use nextpose::replay::load_paths;

const MAX_CONTEXT: usize = 6;

fn main() -> anyhow::Result<()> {
    let paths: Vec<std::path::PathBuf> = std::env::args().skip(1).map(Into::into).collect();
    let programs = load_paths(&paths)?;
    println!(
        "program,routine,n,frame,len,places,agree,current,recent_gap,useful,engine_offered,engine_useful,engine_misfit,engine_phi"
    );
    for p in &programs {
        let mut teacher = Teacher::new(EngineConfig::default())?;
        let mut history: Vec<Vec<Pose>> = Vec::new();
        for (ri, r) in p.routines.iter().enumerate() {
            let w = &r.waypoints;
            for n in 0..w.len() {
                if n >= 2 {
                    let taught = &w[..n];
                    let actual = &w[n];
                    let last = &taught[n - 1];
                    let ep = teacher.predict();
                    let e_useful = ep
                        .pose
                        .is_some_and(|q| q.distance_to(actual) <= 1.0 && q.angle_to(actual) <= 0.1);
                    println!(
                        "{},{ri},{n},engine,0,0,0,0,0,{},{},{},{},{}",
                        p.name.replace(',', ";"),
                        (ep.offered() && e_useful) as u8,
                        ep.offered() as u8,
                        e_useful as u8,
                        ep.misfit.unwrap_or(-1.0),
                        ep.phi
                    );
                    for frame in Frame::ALL {
                        let current = frame.elements(taught);
                        let target = frame.target(last, actual);
                        let seqs: Vec<(bool, Vec<_>)> = history
                            .iter()
                            .map(|h| (false, frame.elements(h)))
                            .chain(std::iter::once((true, current.clone())))
                            .collect();
                        // The oracle: the most recent earlier element equal to the target, how
                        // far back, and whether it repeats the last element.
                        {
                            let mut age = 0usize;
                            let total: usize = seqs.iter().map(|(_, s)| s.len()).sum();
                            let mut found: Option<(usize, bool, usize)> = None;
                            let mut count = 0;
                            for (_, seq) in &seqs {
                                for (i, e) in seq.iter().enumerate() {
                                    if close(e, &target) {
                                        count += 1;
                                        let ctx = i > 0
                                            && current
                                                .last()
                                                .is_some_and(|l| close(&seq[i - 1], l));
                                        found = Some((age + i, ctx, i));
                                    }
                                }
                                age += seq.len();
                            }
                            let repeat = current.last().is_some_and(|l| close(l, &target));
                            if let Some((pos, ctx, _)) = found {
                                println!(
                                    "{},{ri},{n},oracle_{},{},{count},{},{},{},1,0,0,0,0",
                                    p.name.replace(',', ";"),
                                    frame.name(),
                                    repeat as u8,
                                    ctx as u8,
                                    0,
                                    total - pos
                                );
                            }
                        }
                        for len in 1..=MAX_CONTEXT.min(current.len()) {
                            let window = &current[current.len() - len..];
                            // followers, oldest first: (is current, index from end of all, element)
                            let mut followers = Vec::new();
                            let mut age = 0usize;
                            let total: usize = seqs.iter().map(|(_, s)| s.len()).sum();
                            for (is_cur, seq) in &seqs {
                                for next in len..seq.len() {
                                    if window
                                        .iter()
                                        .zip(&seq[next - len..next])
                                        .all(|(a, b)| close(a, b))
                                    {
                                        followers.push((*is_cur, age + next, seq[next]));
                                    }
                                }
                                age += seq.len();
                            }
                            let Some(&(cur, pos, latest)) = followers.last() else {
                                break;
                            };
                            let agree = followers.iter().filter(|f| close(&f.2, &latest)).count();
                            let useful = close(&latest, &target);
                            println!(
                                "{},{ri},{n},{},{len},{},{agree},{},{},{},{},{},{},{}",
                                p.name.replace(',', ";"),
                                frame.name(),
                                followers.len(),
                                cur as u8,
                                total - pos,
                                useful as u8,
                                ep.offered() as u8,
                                e_useful as u8,
                                ep.misfit.unwrap_or(-1.0),
                                ep.phi
                            );
                        }
                    }
                }
                teacher.teach(w[n]);
            }
            teacher.finish_routine();
            history.push(w.clone());
        }
    }
    Ok(())
}
