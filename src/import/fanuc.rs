//! FANUC TP listings (`.ls`, the ASCII form of `.tp` programs).
//!
//! A listing has a header (`/PROG name`, `/ATTR`), the program (`/MN`, one numbered instruction a
//! line) and its position data (`/POS`, `P[n]{ GP1: UF, UT, CONFIG, X Y Z W P R }`). Each line is
//! tokenised with a `logos` lexer; motion lines are matched on their leading tokens
//! (`J P[n]`, `L P[n]`, `C P[n]` with the end point on the following `: P[m]` line), and the
//! position data is read by a small state machine over the tokens of the `/POS` section.
//!
//! `W P R` are fixed angles about X, Y, Z in degrees (`R = Rz(r)·Ry(p)·Rx(w)`); only motion
//! group 1 (the arm) is read. Positions stored in joint representation (`J1= …`), position
//! registers (`PR[n]`, known only at run time) and undefined positions are skipped and counted.
//! The TP files of one folder are one program whose routines are the files, in name order.

use std::collections::HashMap;

use logos::Logos;
use nalgebra::Vector3;

use super::tokens::{Cursor, Kind, tokens};
use super::{
    CircleRole, Frame, ImportError, ImportReport, Imported, LineIndex, Location, ReadRoutine,
    SkipReason, Skipped, SourceFile, WaypointOrigin, directory_of, drop_short_routines, pose_of,
    rotation_zyx_deg,
};
use crate::program::{Configuration, Language, Motion, Waypoint};

#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
#[logos(skip r"[ \t\r\f]+")]
enum K {
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident,
    #[regex(r"[0-9]+(\.[0-9]*)?")]
    #[regex(r"\.[0-9]+")]
    Num,
    #[regex(r"'[^'\n]*'")]
    #[regex(r#""[^"\n]*""#)]
    Str,
    #[token("[")]
    LBrack,
    #[token("]")]
    RBrack,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token(":")]
    Colon,
    #[token("=")]
    Eq,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token("-")]
    Minus,
    #[token("/")]
    Slash,
    Other,
}

impl Kind for K {
    const IDENT: K = K::Ident;
}

type Tok<'s> = super::tokens::Tok<'s, K>;

fn lex_line(line: &str, offset: usize) -> Vec<Tok<'_>> {
    tokens(line, offset, K::Other)
}

/// A position of the `/POS` section.
#[derive(Debug, Clone)]
enum Position {
    Cartesian {
        frame: Frame,
        config: Option<String>,
        uframe: Option<String>,
    },
    Joint,
}

/// A motion instruction of `/MN`.
struct Move {
    /// `J`, `L`, `C` or `A`.
    instruction: &'static str,
    motion: Motion,
    /// `P[n]` index, or `None` for a position register / indirect reference.
    index: Option<u64>,
    text: String,
    line: usize,
    role: Option<CircleRole>,
}

/// Parses the FANUC listings of an upload: one program per folder.
pub(crate) fn parse(
    files: &[SourceFile<'_>],
    report: &mut ImportReport,
) -> Result<(), ImportError> {
    // Folders in the order their first file comes.
    let mut groups: Vec<(&str, Vec<SourceFile<'_>>)> = Vec::new();
    let mut group_of: HashMap<&str, usize> = HashMap::new();
    for f in files {
        let dir = directory_of(f.name);
        let g = *group_of.entry(dir).or_insert_with(|| {
            groups.push((dir, Vec::new()));
            groups.len() - 1
        });
        if let Some((_, group)) = groups.get_mut(g) {
            group.push(*f);
        }
    }
    for (dir, mut group) in groups {
        group.sort_by(|a, b| a.name.cmp(b.name));
        let mut routines = Vec::new();
        for f in group {
            routines.push(parse_file(f, &mut report.skipped)?);
        }
        let routines = drop_short_routines(routines, &mut report.skipped);
        let name = dir
            .rsplit(['/', '\\'])
            .next()
            .filter(|s| !s.is_empty())
            .unwrap_or("fanuc");
        report
            .programs
            .push(Imported::of(name, dir, Language::Fanuc, routines));
    }
    Ok(())
}

fn parse_file(f: SourceFile<'_>, skipped: &mut Vec<Skipped>) -> Result<ReadRoutine, ImportError> {
    let index = LineIndex::new(f.text);
    let err = |at: usize, msg: &str| ImportError::syntax(f.name, index.locate(f.text, at), msg);
    let mut name: Option<String> = None;
    let mut section = "";
    let mut moves: Vec<Move> = Vec::new();
    let mut pos_tokens: Vec<Tok<'_>> = Vec::new();
    let mut pending_circle = false;
    let mut offset = 0;
    for (n, raw) in f.text.split('\n').enumerate() {
        let line_no = n + 1;
        let line_offset = offset;
        offset += raw.len() + 1;
        let trimmed = raw.trim();
        if let Some(rest) = trimmed.strip_prefix('/') {
            let mut words = rest.split_whitespace();
            let head = words.next().unwrap_or("").to_ascii_uppercase();
            match head.as_str() {
                "PROG" => match words.next() {
                    Some(w) => name = Some(w.to_string()),
                    None => {
                        return Err(err(
                            line_offset,
                            "/PROG must be followed by the program name",
                        ));
                    }
                },
                "ATTR" | "APPL" | "MN" | "POS" | "END" => {
                    section = if head == "MN" {
                        "MN"
                    } else if head == "POS" {
                        "POS"
                    } else {
                        ""
                    }
                }
                _ => {}
            }
            continue;
        }
        let toks = lex_line(raw, line_offset);
        match section {
            "MN" => {
                if std::mem::take(&mut pending_circle)
                    && toks.first().is_some_and(|t| t.k == K::Colon)
                {
                    // The end point of `C P[n]` is on the next line: `: P[m] speed term ;`.
                    let (index, text) = position_ref(toks.get(1..).unwrap_or(&[]));
                    let role = Some(CircleRole::To);
                    moves.push(Move {
                        instruction: "C",
                        motion: Motion::Circular,
                        index,
                        text,
                        line: line_no,
                        role,
                    });
                    continue;
                }
                // `n:J P[1] ...` — the instruction number, then the motion.
                let (Some(num), Some(colon), Some(kind)) = (toks.first(), toks.get(1), toks.get(2))
                else {
                    continue;
                };
                if num.k != K::Num || colon.k != K::Colon || kind.k != K::Ident {
                    continue;
                }
                // `A` (a circular arc through the following points) is moved to as a
                // linear target, as the service has stored it since imports began.
                let (instruction, motion) = match kind.s {
                    "J" => ("J", Motion::Joint),
                    "L" => ("L", Motion::Linear),
                    "C" => ("C", Motion::Circular),
                    "A" => ("A", Motion::Linear),
                    _ => continue,
                };
                let (index, text) = position_ref(toks.get(3..).unwrap_or(&[]));
                if text.is_empty() {
                    continue;
                }
                pending_circle = instruction == "C";
                let role = pending_circle.then_some(CircleRole::Via);
                moves.push(Move {
                    instruction,
                    motion,
                    index,
                    text,
                    line: line_no,
                    role,
                });
            }
            "POS" => pos_tokens.extend(toks),
            _ => {}
        }
    }
    let Some(name) = name else {
        return Err(ImportError::syntax(
            f.name,
            Location { line: 1, column: 1 },
            "expected a /PROG header",
        ));
    };
    let positions = positions(&pos_tokens, &err)?;
    let mut routine = ReadRoutine::new(name.clone(), f.name, 1);
    for m in moves {
        let skip = |skipped: &mut Vec<Skipped>, reason| {
            skipped.push(Skipped {
                file: f.name.to_string(),
                line: m.line,
                routine: Some(name.clone()),
                reason,
                text: m.text.clone(),
            })
        };
        let Some(i) = m.index else {
            skip(skipped, SkipReason::ComputedAtRunTime);
            continue;
        };
        match positions.get(&i) {
            None => skip(skipped, SkipReason::UnresolvedName),
            Some(Position::Joint) => skip(skipped, SkipReason::JointMove),
            Some(Position::Cartesian {
                frame,
                config,
                uframe,
            }) => routine.push(
                Waypoint {
                    name: Some(format!("P[{i}]")),
                    pose: pose_of(frame),
                    motion: Some(m.motion),
                    configuration: config.clone().map(Configuration::Fanuc),
                    reachable: None,
                },
                WaypointOrigin {
                    line: m.line,
                    instruction: m.instruction,
                    role: m.role,
                    frame: uframe.clone(),
                },
            ),
        }
    }
    Ok(routine)
}

/// `P[n]`, `P[n:comment]`, `PR[n]` at the start of `toks`: the index (None for registers and
/// indirect references) and the reference as written.
fn position_ref(toks: &[Tok<'_>]) -> (Option<u64>, String) {
    let (Some(p), Some(open)) = (toks.first(), toks.get(1)) else {
        return (None, String::new());
    };
    if p.k != K::Ident || open.k != K::LBrack || !(p.s == "P" || p.s == "PR") {
        return (None, String::new());
    }
    let close = toks.iter().position(|t| t.k == K::RBrack);
    let text: String = toks
        .get(..close.map(|c| c + 1).unwrap_or(toks.len()))
        .unwrap_or(&[])
        .iter()
        .map(|t| t.s)
        .collect();
    if p.s == "PR" {
        return (None, text);
    }
    let index = toks
        .get(2)
        .filter(|t| t.k == K::Num)
        .and_then(|t| t.s.parse::<u64>().ok())
        .filter(|_| {
            toks.get(3)
                .is_some_and(|t| t.k == K::RBrack || t.k == K::Colon)
        });
    (index, text)
}

/// Reads the `/POS` section.
fn positions(
    toks: &[Tok<'_>],
    err: &dyn Fn(usize, &str) -> ImportError,
) -> Result<HashMap<u64, Position>, ImportError> {
    let mut out = HashMap::new();
    let mut c = Cursor::new(toks);
    while !c.at_end() {
        // P [ n ( : comment )? ] {
        let is_start =
            c.peek(0).is_some_and(|t| t.k == K::Ident && t.s == "P") && c.is(1, K::LBrack);
        if !is_start {
            c.skip(1);
            continue;
        }
        let start_at = c.offset(0, 0);
        let Some(index) = c.expect(2, K::Num).and_then(|t| t.s.parse::<u64>().ok()) else {
            return Err(err(start_at, "position data: expected P[number]"));
        };
        let Some(open) = c.find(K::LBrace) else {
            return Err(err(start_at, "position data: expected '{'"));
        };
        c.seek(open);
        let Some(close) = c.find(K::RBrace) else {
            return Err(err(start_at, "position data: P[n]{ without closing '}'"));
        };
        c.skip(1);
        let body = c.take_to(close);
        out.insert(index, group1(body, start_at, err)?);
        c.skip(1);
    }
    Ok(out)
}

/// Reads group 1 of a position's body.
fn group1(
    body: &[Tok<'_>],
    at: usize,
    err: &dyn Fn(usize, &str) -> ImportError,
) -> Result<Position, ImportError> {
    let mut group = 1;
    let mut values: HashMap<String, f64> = HashMap::new();
    let mut config = None;
    let mut uframe = None;
    let mut c = Cursor::new(body);
    while let Some(t) = c.peek(0) {
        if t.k == K::Ident && t.s.starts_with("GP") && c.is(1, K::Colon) {
            group = t.s.get(2..).and_then(|g| g.parse().ok()).unwrap_or(0);
            c.skip(2);
            continue;
        }
        if group != 1 || t.k != K::Ident {
            c.skip(1);
            continue;
        }
        let key = t.s.to_ascii_uppercase();
        match c.peek(1).map(|n| n.k) {
            Some(K::Colon) if key == "CONFIG" => {
                config = c
                    .expect(2, K::Str)
                    .map(|s| s.s.trim_matches('\'').to_string());
                c.skip(3);
            }
            Some(K::Colon) if key == "UF" => {
                uframe = c.peek(2).map(|s| format!("UF{}", s.s));
                c.skip(3);
            }
            Some(K::Eq) => {
                let neg = c.is(2, K::Minus);
                let k = if neg { 3 } else { 2 };
                let Some(v) = c.expect(k, K::Num).and_then(|n| n.s.parse::<f64>().ok()) else {
                    return Err(err(
                        t.at,
                        &format!("position data: {key} = must be followed by a number"),
                    ));
                };
                values.insert(key, if neg { -v } else { v });
                c.skip(k + 1);
            }
            _ => c.skip(1),
        }
    }
    if values.contains_key("J1") {
        return Ok(Position::Joint);
    }
    let get = |k: &str| values.get(k).copied();
    let (Some(x), Some(y), Some(z), Some(w), Some(p), Some(r)) =
        (get("X"), get("Y"), get("Z"), get("W"), get("P"), get("R"))
    else {
        return Err(err(
            at,
            "position data: group 1 needs X, Y, Z, W, P, R (or J1..)",
        ));
    };
    Ok(Position::Cartesian {
        frame: Frame {
            position: Vector3::new(x, y, z),
            rotation: rotation_zyx_deg(r, p, w),
        },
        config,
        uframe,
    })
}

#[cfg(test)]
mod tests {
    use super::super::parse_files;
    use super::*;

    const LS: &str = "/PROG  DEMO\n/ATTR\nOWNER = MNEDITOR;\n/MN\n   1:J P[1] 100% FINE    ;\n   2:L P[2:approach] 500mm/sec CNT50    ;\n   3:J P[3] 100% FINE ;\n   4:C P[1]    \n    :  P[2] 100mm/sec FINE    ;\n   5:L PR[4] 100mm/sec FINE ;\n/POS\nP[1]{\n   GP1:\n\tUF : 1, UT : 1,\t\tCONFIG : 'F U T, 0, 1, 0',\n\tX =  100.000  mm,\tY =  -.500  mm,\tZ =   0  mm,\n\tW =    180.000 deg,\tP =    0 deg,\tR =   90.000 deg\n   GP2:\n\tUF : 1, UT : 1,\n\tJ1=   300.000  mm\n};\nP[2:\"approach\"]{\n   GP1:\n\tUF : 1, UT : 1,\t\tCONFIG : 'N U T, 0, 0, 0',\n\tX =  1  mm,\tY =  2  mm,\tZ =   3  mm,\n\tW =    0 deg,\tP =    0 deg,\tR =   0 deg\n};\nP[3]{\n   GP1:\n\tUF : 0, UT : 1,\n\tJ1=      .041 deg,\tJ2=   -43.490 deg,\tJ3=      .440 deg,\n\tJ4=   180.033 deg,\tJ5=    57.086 deg,\tJ6=     5.947 deg\n};\n/END\n";

    #[test]
    fn reads_positions_moves_and_skips() {
        let report = parse_files(&[("backup/DEMO.LS", LS)]).unwrap();
        let prog = &report.programs[0];
        assert_eq!(prog.program.name, "backup");
        assert_eq!(prog.source(), "backup");
        let (r, at) = (&prog.program.routines[0], &prog.origins[0]);
        assert_eq!(r.name, "DEMO");
        let names: Vec<_> = r
            .waypoints
            .iter()
            .zip(&at.waypoints)
            .map(|(w, o)| (w.name.as_deref().unwrap_or(""), o.instruction, w.motion))
            .collect();
        let (j, l, c) = (Motion::Joint, Motion::Linear, Motion::Circular);
        assert_eq!(
            names,
            [
                ("P[1]", "J", Some(j)),
                ("P[2]", "L", Some(l)),
                ("P[1]", "C", Some(c)),
                ("P[2]", "C", Some(c))
            ]
        );
        let roles: Vec<_> = at.waypoints.iter().map(|o| o.role).collect();
        assert_eq!(
            roles,
            [None, None, Some(CircleRole::Via), Some(CircleRole::To)]
        );
        assert_eq!(at.waypoints[0].frame.as_deref(), Some("UF1"));
        assert_eq!(
            r.waypoints[0].configuration,
            Some(Configuration::Fanuc("F U T, 0, 1, 0".into()))
        );
        assert!((r.waypoints[0].pose.position().y + 0.5).abs() < 1e-12);
        // W=180, R=90: tool z points down, tool x along base y.
        let rot = r.waypoints[0].pose.rotation();
        assert!((rot * Vector3::z() + Vector3::z()).norm() < 1e-12);
        assert!((rot * Vector3::x() - Vector3::y()).norm() < 1e-12);
        let reasons: Vec<_> = report.skipped.iter().map(|s| s.reason).collect();
        assert_eq!(
            reasons,
            [SkipReason::JointMove, SkipReason::ComputedAtRunTime]
        );
    }

    #[test]
    fn missing_coordinate_is_an_error_naming_the_line() {
        let text = LS.replace("\tX =  1  mm,", "\tX =  mm,");
        let err = parse_files(&[("DEMO.LS", &text)]).unwrap_err();
        assert!(err.to_string().starts_with("DEMO.LS:24:"), "{err}");
    }
}
