//! Where the engine's loss is, per half of the corpus: for every predictable waypoint (≥ 2
//! predecessors, the scoreboard's population), which kinds of candidate would have been right.
//!
//! `cargo run --release --example cover_analysis -- FILES…` prints, per program, the waypoints,
//! the engine's useful offers (default profile), the waypoints some sequence expert's candidate
//! is right on, and the union oracle's; then per half (by repository, the file-name prefix
//! before `__`: A = the first six repositories by name, case-blind; B the others) and per
//! candidate kind: how often it proposes something, how often that is right (its precision if
//! always offered), its share of the waypoints, and the share it is right on where no sequence
//! expert's candidate is (`gain %`, the opportunity). The kinds: returns to the pose k back, the
//! routine's first pose, the previous routine's first and last, the most visited pose, a move k
//! back repeated, contexts matched on position only, rotation only or a move's direction and
//! length, contexts with the last element skipped (`gap1`), the element at the same index of
//! the previous routine, unwinding, cross-frame agreement, and the union of them all.
//!
//! `COVER_DETAIL=<name part>` prints instead, per waypoint of the matching programs, the
//! work-frame move taught and, per frame, how many earlier elements cover it and how far back the
//! latest is (`r`: this routine, `h`: an earlier one). `COVER_CANDIDATES=<file.csv>` writes
//! every candidate (the model's, the sequence experts', the gapped contexts') for every waypoint
//! with ≥ 1 predecessor, with its evidence, whether it was right and which candidates agree with
//! it: enough to replay the offer rule outside the engine and try calibration variants.

use std::collections::BTreeMap;
use std::path::PathBuf;

use nextpose::engine::experts::Evidence;
use nextpose::engine::experts::frames::{Frame, Tolerance, angle, distance};
use nextpose::engine::experts::sequence::{Followers, SequenceExpert};
use nextpose::engine::{EngineConfig, Observation, Pose, Teacher};
use nextpose::replay::load_paths;

const A: [&str; 6] = [
    "aleynikovich",
    "djordjeristic04",
    "edgarivanmm",
    "fabio-coder",
    "juniornatalin",
    "jvalta",
];

fn half(name: &str) -> &'static str {
    let repo = name.split("__").next().unwrap_or("").to_lowercase();
    if A.contains(&repo.as_str()) { "A" } else { "B" }
}

fn right(c: &Pose, truth: &Pose) -> bool {
    c.distance_to(truth) <= 1.0 && c.angle_to(truth) <= 0.1
}

/// Per kind: proposed, right, right where no expert candidate is.
#[derive(Default, Clone, Copy)]
struct Tally {
    proposed: u32,
    right: u32,
    gain: u32,
}

/// The follower of the most recent place whose element matches `last` by `same`, in
/// `history` (earlier routines' element sequences) and `current[..current.len()-1]`, with
/// (places, agreeing) counts.
fn loose_context(
    history: &[Vec<Observation>],
    current: &[Observation],
    same: impl Fn(&Observation, &Observation) -> bool,
) -> Option<(Observation, usize, usize)> {
    let last = current.last()?;
    let mut followers = Vec::new();
    for seq in history {
        for i in 0..seq.len().saturating_sub(1) {
            if same(&seq[i], last) {
                followers.push(seq[i + 1]);
            }
        }
    }
    for i in 0..current.len().saturating_sub(1) {
        if same(&current[i], last) {
            followers.push(current[i + 1]);
        }
    }
    let latest = *followers.last()?;
    let agreeing = followers
        .iter()
        .filter(|f| Tolerance::USEFUL.holds(f, &latest))
        .count();
    Some((latest, followers.len(), agreeing))
}

/// The follower `gap + 1` elements after the most recent place where the `len` elements before
/// the last `gap` ones occurred (element by element within the tolerance), with (places,
/// agreeing).
fn gapped_context(
    history: &[Vec<Observation>],
    current: &[Observation],
    gap: usize,
    len: usize,
) -> Option<(Observation, usize, usize)> {
    let m = current.len();
    if m < gap + len {
        return None;
    }
    let tol = Tolerance::USEFUL;
    let ctx = &current[m - gap - len..m - gap];
    let mut followers = Vec::new();
    let mut scan = |seq: &[Observation], limit: usize| {
        // j: index of the first context element in seq; the follower at j + len + gap.
        for j in 0..seq.len() {
            let f = j + len + gap;
            if f >= limit {
                break;
            }
            if (0..len).all(|l| tol.holds(&seq[j + l], &ctx[l])) {
                followers.push(seq[f]);
            }
        }
    };
    for seq in history {
        scan(seq, seq.len());
    }
    scan(current, m);
    let latest = *followers.last()?;
    let agreeing = followers.iter().filter(|f| tol.holds(f, &latest)).count();
    Some((latest, followers.len(), agreeing))
}

fn direction_class(a: &Observation, b: &Observation) -> bool {
    let (la, lb) = (
        (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt(),
        (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt(),
    );
    if la < 1.0 || lb < 1.0 {
        return la < 1.0 && lb < 1.0;
    }
    let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb);
    cos.min(1.0).acos() <= 0.1 && (la - lb).abs() <= 0.1 * la.max(lb)
}

fn put(kinds: &mut Vec<(String, Option<bool>)>, truth: &Pose, name: &str, c: Option<Pose>) {
    kinds.push((name.to_string(), c.map(|c| right(&c, truth))));
}

fn main() -> anyhow::Result<()> {
    let paths: Vec<PathBuf> = std::env::args().skip(1).map(Into::into).collect();
    let programs = load_paths(&paths)?;
    if let Ok(path) = std::env::var("COVER_CANDIDATES") {
        std::fs::write(path, dump_csv(&programs)?)?;
        return Ok(());
    }
    if let Ok(which) = std::env::var("COVER_DETAIL") {
        for p in programs.iter().filter(|p| p.name.contains(&which)) {
            detail(p);
        }
        return Ok(());
    }
    let tol = Tolerance::USEFUL;
    // half → kind → tally; half → population.
    let mut tallies: BTreeMap<&str, BTreeMap<String, Tally>> = BTreeMap::new();
    let mut population: BTreeMap<&str, u32> = BTreeMap::new();
    let mut per_program: Vec<String> = Vec::new();
    let mut csv = String::from(
        "half,program,routine,n,expert,context,places,agreeing,in_routine,p_useful,right,exact_last,other_frames_agree,engine_offered,engine_useful\n",
    );
    for program in &programs {
        let mut row = [0u32; 4];
        let program_index = per_program.len();
        let h = half(&program.name);
        let mut experts = SequenceExpert::all();
        let mut teacher = Teacher::new(EngineConfig::default())?;
        // Elements of the finished routines, per frame.
        let frames = [Frame::Tool, Frame::Work, Frame::Absolute];
        let mut history: Vec<Vec<Vec<Observation>>> = vec![Vec::new(); 3];
        let mut earlier: Vec<Vec<Pose>> = Vec::new();
        for (routine_index, routine) in program.routines.iter().enumerate() {
            let w = &routine.waypoints;
            let elements: Vec<Vec<Observation>> = frames.iter().map(|f| f.elements(w)).collect();
            for n in 0..w.len() {
                if n >= 2 {
                    let (last, truth) = (&w[n - 1], &w[n]);
                    let taught = &w[..n];
                    let mut kinds: Vec<(String, Option<bool>)> = Vec::new();
                    // The engine (default profile) as it stands.
                    let p = teacher.predict();
                    put(
                        &mut kinds,
                        truth,
                        "engine_offered",
                        p.pose.filter(|_| p.offered()),
                    );
                    // The experts' candidates.
                    let proposals: Vec<_> = experts
                        .iter()
                        .flat_map(|e| e.proposals(taught, &tol, Followers::Newest))
                        .collect();
                    let any_expert = proposals.iter().any(|c| right(&c.pose, truth));
                    let engine_useful = p.offered() && p.pose.is_some_and(|q| right(&q, truth));
                    for c in &proposals {
                        let (context, places, agreeing, in_routine) =
                            sequence_evidence(&c.evidence);
                        let f = match c.proposer().name() {
                            "tool" => 0,
                            "work" => 1,
                            _ => 2,
                        };
                        let done = if frames[f].is_move() { n - 1 } else { n };
                        let cur = &elements[f][..done];
                        let exact = Tolerance {
                            mm: 0.01,
                            rad: 1e-4,
                        };
                        let last_e = cur[done - 1];
                        let exact_last = history[f]
                            .iter()
                            .flatten()
                            .chain(&cur[..done - 1])
                            .any(|e| exact.holds(e, &last_e));
                        let others = proposals
                            .iter()
                            .filter(|d| d.proposer() != c.proposer() && right(&d.pose, &c.pose))
                            .map(|d| d.proposer())
                            .collect::<std::collections::BTreeSet<_>>()
                            .len();
                        csv += &format!(
                            "{h},{program_index},{routine_index},{n},{},{},{},{},{},{:.4},{},{},{},{},{}\n",
                            c.proposer().name(),
                            context,
                            places,
                            agreeing,
                            u8::from(in_routine),
                            teacher.calibration().p_useful(&c.evidence),
                            u8::from(right(&c.pose, truth)),
                            u8::from(exact_last),
                            others,
                            u8::from(p.offered()),
                            u8::from(engine_useful),
                        );
                    }
                    if proposals.is_empty() {
                        csv += &format!(
                            "{h},{program_index},{routine_index},{n},none,0,0,0,0,0,0,0,0,{},{}\n",
                            u8::from(p.offered()),
                            u8::from(engine_useful),
                        );
                    }
                    kinds.push((
                        "experts_any".into(),
                        (!proposals.is_empty()).then_some(any_expert),
                    ));
                    let mut any_oracle = false;
                    for (f, frame) in frames.iter().enumerate() {
                        let done = if frame.is_move() { n - 1 } else { n };
                        let target = frame.target(last, truth);
                        let hit = history[f]
                            .iter()
                            .flatten()
                            .chain(&elements[f][..done])
                            .any(|e| tol.holds(e, &target));
                        kinds.push((format!("oracle_{}", frame.name()), Some(hit)));
                        any_oracle |= hit;
                    }
                    kinds.push(("oracle_any".into(), Some(any_oracle)));
                    // Returns to a pose k back in this routine (k = 1: stay).
                    for k in 1..=6 {
                        put(
                            &mut kinds,
                            truth,
                            &format!("back_{k}"),
                            (n >= k).then(|| w[n - k]),
                        );
                    }
                    put(&mut kinds, truth, "routine_first", Some(w[0]));
                    put(
                        &mut kinds,
                        truth,
                        "prev_routine_first",
                        earlier.last().and_then(|r| r.first().copied()),
                    );
                    put(
                        &mut kinds,
                        truth,
                        "prev_routine_last",
                        earlier.last().and_then(|r| r.last().copied()),
                    );
                    // The pose most often visited so far (ties: the most recent).
                    let visited: Vec<&Pose> = earlier.iter().flatten().chain(taught).collect();
                    let mut best: Option<(usize, &Pose)> = None;
                    for (i, v) in visited.iter().enumerate() {
                        let c = visited[..i].iter().filter(|u| right(u, v)).count() + 1;
                        if best.is_none_or(|(b, _)| c >= b) {
                            best = Some((c, v));
                        }
                    }
                    put(
                        &mut kinds,
                        truth,
                        "abs_most_visited",
                        best.filter(|b| b.0 >= 2).map(|b| *b.1),
                    );
                    // The same move again (a pitch continued), moves k back.
                    for k in 1..=3 {
                        for (f, frame) in frames.iter().enumerate().take(2) {
                            let e = (n > k).then(|| elements[f][n - 1 - k]);
                            put(
                                &mut kinds,
                                truth,
                                &format!("{}_repeat_{k}", frame.name()),
                                e.and_then(|e| frame.apply(last, &e)),
                            );
                        }
                    }
                    // Coarse contexts.
                    for (f, frame) in frames.iter().enumerate() {
                        let done = if frame.is_move() { n - 1 } else { n };
                        let cur = &elements[f][..done];
                        let pos_only = |a: &Observation, b: &Observation| distance(a, b) <= 1.0;
                        let rot_only = |a: &Observation, b: &Observation| angle(a, b) <= 0.1;
                        for (label, found) in [
                            ("pos", loose_context(&history[f], cur, pos_only)),
                            ("rot", loose_context(&history[f], cur, rot_only)),
                            ("dir", loose_context(&history[f], cur, direction_class)),
                        ] {
                            if label == "dir" && !frame.is_move() {
                                continue;
                            }
                            let name = format!("{}_ctx_{label}", frame.name());
                            let g = found.and_then(|(e, _, _)| frame.apply(last, &e));
                            put(&mut kinds, truth, &name, g);
                            let agreed = found
                                .filter(|(_, p, a)| p == a)
                                .and_then(|(e, _, _)| frame.apply(last, &e));
                            put(&mut kinds, truth, &format!("{name}_agree"), agreed);
                        }
                    }
                    // Gapped contexts: the last element skipped.
                    for (f, frame) in frames.iter().enumerate() {
                        let done = if frame.is_move() { n - 1 } else { n };
                        let cur = &elements[f][..done];
                        for len in 1..=2 {
                            let found = gapped_context(&history[f], cur, 1, len);
                            let name = format!("{}_gap1_len{len}", frame.name());
                            put(
                                &mut kinds,
                                truth,
                                &name,
                                found.and_then(|(e, _, _)| frame.apply(last, &e)),
                            );
                            let agreed = found
                                .filter(|(_, p, a)| p == a)
                                .and_then(|(e, _, _)| frame.apply(last, &e));
                            put(&mut kinds, truth, &format!("{name}_agree"), agreed);
                            let several = found
                                .filter(|(_, p, a)| p == a && *p >= 2)
                                .and_then(|(e, _, _)| frame.apply(last, &e));
                            put(&mut kinds, truth, &format!("{name}_agree2"), several);
                        }
                        // The element at the same index of the latest earlier routine long
                        // enough.
                        let i = done;
                        let same = history[f].iter().rev().find(|s| s.len() > i).map(|s| s[i]);
                        put(
                            &mut kinds,
                            truth,
                            &format!("{}_same_index", frame.name()),
                            same.and_then(|e| frame.apply(last, &e)),
                        );
                    }
                    // Unwinding: the pose before the latest earlier visit of the last pose.
                    let unwind = (1..n - 1)
                        .rev()
                        .find(|&j| right(&w[j], last))
                        .map(|j| w[j - 1]);
                    put(&mut kinds, truth, "unwind", unwind);
                    // Return to the pose k back, because the last visit of it was left and
                    // returned to after k steps too.
                    for k in 2..=4 {
                        let rel = (n >= k).then(|| w[n - k]).filter(|p| {
                            (0..n - k)
                                .rev()
                                .find(|&j| right(&w[j], p))
                                .is_some_and(|j| j + k < n - k + 1 && right(&w[j + k], p))
                        });
                        put(&mut kinds, truth, &format!("return_{k}_as_before"), rel);
                    }
                    // Cross-frame agreement among the experts' candidates.
                    let agree = proposals.iter().find(|c| {
                        proposals
                            .iter()
                            .any(|d| d.proposer() != c.proposer() && right(&d.pose, &c.pose))
                    });
                    put(
                        &mut kinds,
                        truth,
                        "experts_two_frames_agree",
                        agree.map(|c| c.pose),
                    );
                    // The union of every candidate kind above (the oracles, the engine and the
                    // rows for precision only left out): what a perfect selector could reach.
                    let union = kinds.iter().any(|(name, r)| {
                        !name.starts_with("oracle_") && name != "engine_offered" && *r == Some(true)
                    });
                    kinds.push(("union_of_kinds".into(), Some(union)));
                    *population.entry(h).or_default() += 1;
                    row[0] += 1;
                    for (name, r) in &kinds {
                        let i = match name.as_str() {
                            "engine_offered" => 1,
                            "experts_any" => 2,
                            "oracle_any" => 3,
                            _ => continue,
                        };
                        row[i] += u32::from(*r == Some(true));
                    }
                    let t = tallies.entry(h).or_default();
                    for (name, r) in kinds {
                        let e = t.entry(name).or_default();
                        if let Some(r) = r {
                            e.proposed += 1;
                            e.right += u32::from(r);
                            e.gain += u32::from(r && !any_expert);
                        }
                    }
                }
                teacher.teach(w[n]);
            }
            teacher.finish_routine();
            for e in &mut experts {
                e.learn(w);
            }
            for (h, e) in history.iter_mut().zip(elements) {
                h.push(e);
            }
            earlier.push(w.clone());
        }
        per_program.push(format!(
            "{h} {:<70} {:>5} engine {:>4} experts {:>4} oracle {:>4}",
            &program.name[..program.name.len().min(70)],
            row[0],
            row[1],
            row[2],
            row[3]
        ));
    }
    if let Ok(path) = std::env::var("COVER_CSV") {
        std::fs::write(path, &csv)?;
    }
    for line in &per_program {
        println!("{line}");
    }
    for (h, t) in &tallies {
        let pop = f64::from(population[h]);
        println!("half {h}: {} waypoints", population[h]);
        println!(
            "{:<32} {:>8} {:>8} {:>10} {:>8} {:>9}",
            "kind", "proposed", "right", "precision", "share %", "gain %"
        );
        for (name, c) in t {
            println!(
                "{:<32} {:>8} {:>8} {:>10.1} {:>8.1} {:>9.1}",
                name,
                c.proposed,
                c.right,
                100.0 * f64::from(c.right) / f64::from(c.proposed.max(1)),
                100.0 * f64::from(c.right) / pop,
                100.0 * f64::from(c.gain) / pop,
            );
        }
        println!();
    }
    Ok(())
}

/// Per waypoint of one program: the work-frame move taught, and for each frame the most recent
/// earlier element covering it (how far back, in elements of the whole history) and how many do.
fn detail(program: &nextpose::replay::Program) {
    let tol = Tolerance::USEFUL;
    let frames = [Frame::Tool, Frame::Work, Frame::Absolute];
    let mut history: Vec<Vec<Observation>> = vec![Vec::new(); 3];
    for (ri, routine) in program.routines.iter().enumerate() {
        let w = &routine.waypoints;
        let elements: Vec<Vec<Observation>> = frames.iter().map(|f| f.elements(w)).collect();
        for n in 2..w.len() {
            let (last, truth) = (&w[n - 1], &w[n]);
            let m = Frame::Work.target(last, truth);
            let mut line = format!(
                "r{ri:<2} n{n:<3} move [{:8.2} {:8.2} {:8.2}] {:5.3}rad",
                m[0],
                m[1],
                m[2],
                angle(&m, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0].into())
            );
            for (f, frame) in frames.iter().enumerate() {
                let done = if frame.is_move() { n - 1 } else { n };
                let all: Vec<&Observation> =
                    history[f].iter().chain(&elements[f][..done]).collect();
                let target = frame.target(last, truth);
                let hits: Vec<usize> = (0..all.len())
                    .filter(|&i| tol.holds(all[i], &target))
                    .collect();
                match hits.last() {
                    Some(&i) => {
                        line += &format!(
                            "  {}: {:>2}x back {:>4}{}",
                            &frame.name()[..1],
                            hits.len(),
                            all.len() - i,
                            if i >= history[f].len() { "r" } else { "h" }
                        )
                    }
                    None => line += &format!("  {}: {:>15}", &frame.name()[..1], "-"),
                }
            }
            println!("{line}");
        }
        for (h, e) in history.iter_mut().zip(elements) {
            h.extend(e);
        }
    }
}

/// Every candidate for every waypoint with ≥ 1 predecessor, in teaching order, as CSV: the
/// model's (from a cell without the offer rule: same model, its own gate), the sequence
/// experts', and the gapped-context candidates (`gap_<frame>`: the last element skipped), with
/// their evidence, whether each is right, and which candidates agree with it.
fn dump_csv(programs: &[nextpose::replay::Program]) -> anyhow::Result<String> {
    use std::fmt::Write;
    let tol = Tolerance::USEFUL;
    let frames = [Frame::Tool, Frame::Work, Frame::Absolute];
    let mut out = String::from(
        "half,program,routine,n,expert,context,places,agreeing,in_routine,gated_in,right,agree_with,exact_last\n",
    );
    for (pi, program) in programs.iter().enumerate() {
        let h = half(&program.name);
        let mut experts = SequenceExpert::all();
        let mut model = Teacher::new(EngineConfig {
            offer: None,
            ..EngineConfig::default()
        })?;
        let mut history: Vec<Vec<Vec<Observation>>> = vec![Vec::new(); 3];
        for (ri, routine) in program.routines.iter().enumerate() {
            let w = &routine.waypoints;
            let elements: Vec<Vec<Observation>> = frames.iter().map(|f| f.elements(w)).collect();
            for n in 0..w.len() {
                if n >= 1 {
                    let (last, truth) = (&w[n - 1], &w[n]);
                    let taught = &w[..n];
                    // (expert, context, places, agreeing, in_routine, gated_in, pose)
                    let mut cands: Vec<(String, usize, usize, usize, bool, bool, Pose)> =
                        Vec::new();
                    let p = model.predict();
                    if let Some(pose) = p.pose {
                        cands.push(("model".into(), p.window, 0, 0, false, p.offered(), pose));
                    }
                    for e in &experts {
                        for c in e.proposals(taught, &tol, Followers::Newest) {
                            let (context, places, agreeing, in_routine) =
                                sequence_evidence(&c.evidence);
                            cands.push((
                                c.proposer().name().into(),
                                context,
                                places,
                                agreeing,
                                in_routine,
                                false,
                                c.pose,
                            ));
                        }
                    }
                    for (f, frame) in frames.iter().enumerate() {
                        let done = if frame.is_move() { n - 1 } else { n };
                        let cur = &elements[f][..done];
                        for len in 1..=2 {
                            if let Some((e, places, agreeing)) =
                                gapped_context(&history[f], cur, 1, len)
                                && let Some(pose) = frame.apply(last, &e)
                            {
                                cands.push((
                                    format!("gap_{}", frame.name()),
                                    len,
                                    places,
                                    agreeing,
                                    false,
                                    false,
                                    pose,
                                ));
                            }
                        }
                    }
                    // Per frame: whether the last element repeats an earlier one exactly.
                    let exact = Tolerance {
                        mm: 0.01,
                        rad: 1e-4,
                    };
                    let exact_last: Vec<bool> = frames
                        .iter()
                        .enumerate()
                        .map(|(f, frame)| {
                            let done = if frame.is_move() { n - 1 } else { n };
                            let cur = &elements[f][..done];
                            cur.last().is_some_and(|l| {
                                history[f]
                                    .iter()
                                    .flatten()
                                    .chain(&cur[..done - 1])
                                    .any(|e| exact.holds(e, l))
                            })
                        })
                        .collect();
                    for (i, c) in cands.iter().enumerate() {
                        let f = if c.0.ends_with("work") {
                            1
                        } else if c.0.ends_with("absolute") {
                            2
                        } else {
                            0
                        };
                        let agree: Vec<String> = cands
                            .iter()
                            .enumerate()
                            .filter(|(j, d)| *j != i && right(&d.6, &c.6))
                            .map(|(_, d)| format!("{}{}", d.0, d.1))
                            .collect();
                        writeln!(
                            out,
                            "{h},{pi},{ri},{n},{},{},{},{},{},{},{},{},{}",
                            c.0,
                            c.1,
                            c.2,
                            c.3,
                            u8::from(c.4),
                            u8::from(c.5),
                            u8::from(right(&c.6, truth)),
                            agree.join(" "),
                            u8::from(exact_last[f])
                        )?;
                    }
                    if cands.is_empty() {
                        writeln!(out, "{h},{pi},{ri},{n},none,0,0,0,0,0,0,,0")?;
                    }
                }
                model.teach(w[n]);
            }
            model.finish_routine();
            for e in &mut experts {
                e.learn(w);
            }
            for (h, e) in history.iter_mut().zip(elements) {
                h.push(e);
            }
        }
    }
    Ok(out)
}

/// A sequence expert's evidence: context, places, agreeing places, in the routine.
fn sequence_evidence(e: &Evidence) -> (usize, usize, usize, bool) {
    match *e {
        Evidence::Sequence {
            context,
            places,
            agreeing,
            in_routine,
            ..
        } => (context, places, agreeing, in_routine),
        _ => (0, 0, 0, false),
    }
}
