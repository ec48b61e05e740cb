//! The data behind the offer rule's study (issue 48): every candidate every expert proposes,
//! for every waypoint taught after a routine's first, in a fresh default-profile cell per
//! program, as CSV on stdout. One row per candidate (a waypoint with none has one row with
//! `cand = -1`), with its evidence, its first-stage `p_useful` as the cell then had it, its
//! pose, and its distance and angle to the waypoint then taught; and whether the engine offered
//! a suggestion there and how far it was. Candidates do not depend on the offer rule, so any
//! rule can be replayed over these rows outside the engine, in the cell's order.
//!
//! `cargo run --release --example offer_dataset -- ../shared/corpus/json ../shared/corpus2/json > rows.csv`

use std::io::Write;

use nextpose::engine::experts::{Evidence, LatticeEvidence};
use nextpose::engine::{EngineConfig, Teacher};
use nextpose::replay::load_paths;

/// The evidence's fields, in the columns `kind,a,b,c,d` (see the header).
fn fields(e: &Evidence) -> (&'static str, usize, usize, usize, usize) {
    match *e {
        Evidence::Model { window, gated_in } => ("model", window, usize::from(gated_in), 0, 0),
        Evidence::Sequence {
            context,
            places,
            agreeing,
            in_routine,
            ..
        } => (
            "sequence",
            context,
            places,
            agreeing,
            usize::from(in_routine),
        ),
        Evidence::Template {
            steps,
            places,
            agreeing,
        } => ("template", steps, places, agreeing, 0),
        Evidence::Lattice(LatticeEvidence::Walk {
            points,
            grid,
            settled,
        }) => ("walk", points, usize::from(grid), usize::from(settled), 0),
        Evidence::Lattice(LatticeEvidence::Station { visits }) => ("station", visits, 0, 0, 0),
        Evidence::Lattice(LatticeEvidence::Follower { items }) => ("follower", items, 0, 0, 0),
    }
}

fn main() -> anyhow::Result<()> {
    let paths: Vec<std::path::PathBuf> = std::env::args().skip(1).map(Into::into).collect();
    let programs = load_paths(&paths)?;
    let out = std::io::stdout();
    let mut out = std::io::BufWriter::new(out.lock());
    writeln!(
        out,
        "corpus,repo,program,routine,n,cand,proposer,kind,a,b,c,d,p_first,x,y,z,qw,qx,qy,qz,mm,rad,offered,offered_mm,offered_rad,p_offer"
    )?;
    for p in &programs {
        let corpus = if p.source.to_string_lossy().contains("corpus2") {
            "corpus2"
        } else {
            "corpus"
        };
        let repo = p
            .repo
            .clone()
            .unwrap_or_else(|| p.name.split("__").next().unwrap_or("").to_string());
        let mut t = Teacher::new(EngineConfig::default())?;
        for (ri, r) in p.routines.iter().enumerate() {
            for (n, w) in r.waypoints.iter().enumerate() {
                if n >= 1 {
                    let pred = t.predict();
                    let offered = pred.pose.filter(|_| pred.offered());
                    let (o_mm, o_rad) =
                        offered.map_or((f64::NAN, f64::NAN), |o| (o.distance_to(w), o.angle_to(w)));
                    let head = format!("{corpus},{repo},{},{ri},{n}", p.name);
                    let tail = format!(
                        "{},{o_mm},{o_rad},{}",
                        u8::from(offered.is_some()),
                        pred.p_useful.unwrap_or(f64::NAN)
                    );
                    let candidates = t.candidates_ahead();
                    if candidates.is_empty() {
                        writeln!(out, "{head},-1,,,,,,,,,,,,,,,,,{tail}")?;
                    }
                    for (i, c) in candidates.iter().enumerate() {
                        let (kind, a, b, cc, d) = fields(&c.evidence);
                        let q = c.pose.values();
                        writeln!(
                            out,
                            "{head},{i},{},{kind},{a},{b},{cc},{d},{},{},{},{},{},{},{},{},{},{},{tail}",
                            c.proposer().name(),
                            t.calibration().p_useful(&c.evidence),
                            q.x,
                            q.y,
                            q.z,
                            q.qw,
                            q.qx,
                            q.qy,
                            q.qz,
                            c.pose.distance_to(w),
                            c.pose.angle_to(w),
                        )?;
                    }
                }
                t.teach(*w);
            }
            t.finish_routine();
        }
    }
    out.flush()?;
    Ok(())
}
