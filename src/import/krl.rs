//! KUKA KRL programs: a `.src` (code) with the `.dat` of the same name (its data list).
//!
//! KRL is line-oriented: each line (minus its `;` comment) is tokenised with a `logos` lexer
//! and matched on its leading tokens. Declarations (`DECL [GLOBAL] E6POS|POS|FRAME name={…}`,
//! in the `.dat` or at the top of a `DEF`) bind names; `E6AXIS`/`AXIS` ones are remembered as
//! joint-space so moves to them are counted as such. Motions are `PTP`, `LIN`, `CIRC aux, end`
//! and their `_REL` forms, with a named target or an inline aggregate `{X …, Y …, …}`.
//!
//! `A B C` are ZYX Euler angles in degrees (`R = Rz(A)·Ry(B)·Rx(C)`); `S` (Status) and `T`
//! (Turn) are kept. Names are case-insensitive. An inline aggregate missing any of `X Y Z A B C`
//! takes the rest from the robot's position at run time and is skipped; `_REL` moves resolve
//! against the previous waypoint of the routine (`#BASE` unless `#TOOL` is given).

use std::collections::{HashMap, HashSet};

use logos::Logos;
use nalgebra::Vector3;

use super::tokens::{Cursor, Kind, tokens};
use super::{
    CircleRole, Configuration, Frame, ImportError, ImportReport, ImportedProgram, ImportedRoutine,
    ImportedWaypoint, Language, LineIndex, SkipReason, Skipped, SourceFile, directory_of,
    drop_short_routines, excerpt, pose_of, rotation_zyx_deg, stem_of,
};

#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
#[logos(skip r"[ \t\r\f]+")]
enum K {
    #[regex(r"[$#A-Za-z_][A-Za-z0-9_$]*")]
    Ident,
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?")]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?")]
    Num,
    #[regex(r#""[^"\n]*""#)]
    Str,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("[")]
    LBrack,
    #[token("]")]
    RBrack,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token(",")]
    Comma,
    #[token("=")]
    Eq,
    #[token("-")]
    Minus,
    #[token("+")]
    Plus,
    Other,
}

impl Kind for K {
    const IDENT: K = K::Ident;
}

type Tok<'s> = super::tokens::Tok<'s, K>;

fn lex_line(line: &str, offset: usize) -> Vec<Tok<'_>> {
    let mut in_str = false;
    let mut cut = line.len();
    for (i, c) in line.char_indices() {
        match c {
            '"' => in_str = !in_str,
            ';' if !in_str => {
                cut = i;
                break;
            }
            _ => {}
        }
    }
    let code = line.get(..cut).unwrap_or("");
    tokens(code, offset, K::Other)
}

/// A declared or inline position.
#[derive(Debug, Clone)]
enum Value {
    Cartesian {
        frame: Frame,
        status: Option<i64>,
        turn: Option<i64>,
    },
    /// An aggregate missing some of `X Y Z A B C`: completed at run time.
    Partial(HashMap<String, f64>),
    Joint,
}

struct Line<'s> {
    no: usize,
    toks: Vec<Tok<'s>>,
}

fn lines_of<'s>(f: &SourceFile<'s>) -> Vec<Line<'s>> {
    let mut out = Vec::new();
    let mut offset = 0;
    for (n, raw) in f.text.split('\n').enumerate() {
        let toks = lex_line(raw, offset);
        offset += raw.len() + 1;
        if !toks.is_empty() {
            out.push(Line { no: n + 1, toks });
        }
    }
    out
}

/// What pairs a `.src` with its `.dat`: the directory and the stem, case-insensitive.
fn key<'s>(f: &SourceFile<'s>) -> (&'s str, String) {
    (directory_of(f.name), stem_of(f.name).to_ascii_lowercase())
}

/// Parses the KRL files of an upload: one program per `.src`, with its `.dat`.
pub(crate) fn parse(
    files: &[SourceFile<'_>],
    report: &mut ImportReport,
) -> Result<(), ImportError> {
    // A `.src` and a `.dat` pair when directory and stem (case-insensitive) agree; keyed once,
    // so an upload of many files pairs in linear time.
    let is_ext = |f: &SourceFile<'_>, e: &str| f.name.to_ascii_lowercase().ends_with(e);
    let (srcs, dats): (Vec<&SourceFile<'_>>, Vec<&SourceFile<'_>>) = files
        .iter()
        .filter(|f| is_ext(f, ".src") || is_ext(f, ".dat"))
        .partition(|f| is_ext(f, ".src"));
    let mut dat_of: HashMap<(&str, String), &SourceFile<'_>> = HashMap::new();
    for d in &dats {
        dat_of.entry(key(d)).or_insert(d);
    }
    let src_keys: HashSet<(&str, String)> = srcs.iter().map(|s| key(s)).collect();
    for src in srcs {
        let dat = dat_of.get(&key(src)).copied();
        let mut names: HashMap<String, Value> = HashMap::new();
        if let Some(dat) = dat {
            let idx = LineIndex::new(dat.text);
            for line in lines_of(dat) {
                declaration(dat, &idx, &line.toks, &mut names)?;
            }
        }
        let routines = routines(src, &names, &mut report.skipped)?;
        let routines = drop_short_routines(routines, &mut report.skipped);
        report.programs.push(ImportedProgram {
            name: stem_of(src.name).to_string(),
            source: src.name.to_string(),
            language: Language::Krl,
            routines,
        });
    }
    for dat in dats {
        if !src_keys.contains(&key(dat)) {
            report.skipped.push(Skipped {
                file: dat.name.to_string(),
                line: 1,
                routine: None,
                reason: SkipReason::DataOnly,
                text: dat.name.to_string(),
            });
        }
    }
    Ok(())
}

/// `[DECL] [GLOBAL] [CONST] TYPE name = value` for position types; other lines are ignored.
fn declaration(
    f: &SourceFile<'_>,
    idx: &LineIndex,
    toks: &[Tok<'_>],
    names: &mut HashMap<String, Value>,
) -> Result<bool, ImportError> {
    let mut c = Cursor::new(toks);
    while matches!(c.word(0).as_deref(), Some("DECL" | "GLOBAL" | "CONST")) {
        c.skip(1);
    }
    let Some(ty) = c.word(0) else {
        return Ok(false);
    };
    let joint = matches!(ty.as_str(), "E6AXIS" | "AXIS");
    if !joint && !matches!(ty.as_str(), "E6POS" | "POS" | "FRAME") {
        return Ok(false);
    }
    // Several names may share one declaration line without values (`DECL E6POS a, b`).
    let Some(name) = c.expect(1, K::Ident) else {
        return Ok(false);
    };
    let key = name.s.to_ascii_uppercase();
    match c.peek(2).map(|t| t.k) {
        Some(K::Eq) => {
            let agg = c.rest(3);
            let value = if joint {
                Value::Joint
            } else {
                aggregate(agg).ok_or_else(|| {
                    let at = agg.first().map(|t| t.at).unwrap_or(name.at);
                    ImportError::syntax(
                        f.name,
                        idx.locate(f.text, at),
                        format!("{ty} {}: expected {{X …, Y …, …}}", name.s),
                    )
                })?
            };
            names.insert(key, value);
        }
        _ if joint => {
            names.insert(key, Value::Joint);
        }
        _ => {}
    }
    Ok(true)
}

/// An aggregate `{X 1, Y 2, …}` (the whole token slice): its components by upper-case name.
fn aggregate(toks: &[Tok<'_>]) -> Option<Value> {
    if toks.first()?.k != K::LBrace || toks.last()?.k != K::RBrace {
        return None;
    }
    let inner = toks.get(1..toks.len() - 1)?;
    let mut values = HashMap::new();
    if !inner.is_empty() {
        for part in inner.split(|t| t.k == K::Comma) {
            let key = part.first().and_then(Tok::word)?;
            let (neg, rest) = match part.get(1) {
                Some(t) if t.k == K::Minus => (true, part.get(2..)?),
                Some(t) if t.k == K::Plus => (false, part.get(2..)?),
                _ => (false, part.get(1..)?),
            };
            match rest {
                [n] if n.k == K::Num => {
                    let v: f64 = n.s.parse().ok()?;
                    values.insert(key, if neg { -v } else { v });
                }
                // `$TYPE …` fields or enum values (`#BASE`) carry no position.
                [t] if t.k == K::Ident => {}
                _ => return None,
            }
        }
    }
    if values.contains_key("A1") {
        return Some(Value::Joint);
    }
    let get = |k: &str| values.get(k).copied();
    match (get("X"), get("Y"), get("Z"), get("A"), get("B"), get("C")) {
        (Some(x), Some(y), Some(z), Some(a), Some(b), Some(c)) => Some(Value::Cartesian {
            frame: Frame {
                position: Vector3::new(x, y, z),
                rotation: rotation_zyx_deg(a, b, c),
            },
            status: get("S").map(|v| v as i64),
            turn: get("T").map(|v| v as i64),
        }),
        _ => Some(Value::Partial(values)),
    }
}

fn routines(
    src: &SourceFile<'_>,
    dat: &HashMap<String, Value>,
    skipped: &mut Vec<Skipped>,
) -> Result<Vec<ImportedRoutine>, ImportError> {
    let idx = LineIndex::new(src.text);
    let mut out = Vec::new();
    let mut current: Option<(ImportedRoutine, HashMap<String, Value>)> = None;
    for line in lines_of(src) {
        let toks = &line.toks;
        let mut c = Cursor::new(toks);
        if c.is_kw(0, "GLOBAL") {
            c.skip(1);
        }
        match c.word(0).as_deref() {
            Some("DEF") | Some("DEFFCT") => {
                let name_at = if c.is_kw(0, "DEFFCT") { 2 } else { 1 };
                let Some(name) = c.expect(name_at, K::Ident) else {
                    return Err(ImportError::syntax(
                        src.name,
                        idx.locate(src.text, c.offset(0, 0)),
                        "DEF must be followed by the routine name",
                    ));
                };
                if let Some((r, _)) = current.take() {
                    out.push(r);
                }
                current = Some((
                    ImportedRoutine {
                        name: name.s.to_string(),
                        file: src.name.to_string(),
                        line: line.no,
                        waypoints: Vec::new(),
                    },
                    HashMap::new(),
                ));
                continue;
            }
            Some("END") | Some("ENDFCT") => {
                if let Some((r, _)) = current.take() {
                    out.push(r);
                }
                continue;
            }
            _ => {}
        }
        let Some((routine, locals)) = current.as_mut() else {
            continue;
        };
        if declaration(src, &idx, toks, locals)? {
            continue;
        }
        motion(src, &line, routine, locals, dat, skipped);
    }
    if let Some((r, _)) = current.take() {
        out.push(r);
    }
    Ok(out)
}

fn motion(
    src: &SourceFile<'_>,
    line: &Line<'_>,
    routine: &mut ImportedRoutine,
    locals: &HashMap<String, Value>,
    dat: &HashMap<String, Value>,
    skipped: &mut Vec<Skipped>,
) {
    let toks = &line.toks;
    let Some(kw) = toks.first().and_then(Tok::word) else {
        return;
    };
    let (motion, relative) = match kw.as_str() {
        "PTP" | "SPTP" => ("PTP", false),
        "LIN" | "SLIN" => ("LIN", false),
        "CIRC" | "SCIRC" => ("CIRC", false),
        "PTP_REL" | "SPTP_REL" => ("PTP_REL", true),
        "LIN_REL" | "SLIN_REL" => ("LIN_REL", true),
        "CIRC_REL" | "SCIRC_REL" => ("CIRC_REL", true),
        _ => return,
    };
    let rest = toks.get(1..).unwrap_or(&[]);
    // Targets: a name or an aggregate, separated by a comma for CIRC.
    let mut targets: Vec<&[Tok<'_>]> = Vec::new();
    let mut c = Cursor::new(rest);
    while targets.len() < if motion.starts_with("CIRC") { 2 } else { 1 } {
        let Some(t) = c.peek(0) else { break };
        match t.k {
            K::LBrace => {
                let end = c.find(K::RBrace).map_or(rest.len(), |e| e + 1);
                targets.push(c.take_to(end));
            }
            K::Ident => targets.push(c.take_to(c.pos() + 1)),
            K::Comma => c.skip(1),
            _ => break,
        }
    }
    let tool_frame = rest.iter().any(|t| t.s.eq_ignore_ascii_case("#TOOL"));
    let text_of = |t: &[Tok<'_>]| -> String {
        match (t.first(), t.last()) {
            (Some(a), Some(b)) => src
                .text
                .get(a.at..b.at + b.s.len())
                .unwrap_or("")
                .to_string(),
            _ => String::new(),
        }
    };
    let n = targets.len();
    let skip = |skipped: &mut Vec<Skipped>, reason, text: String| {
        skipped.push(Skipped {
            file: src.name.to_string(),
            line: line.no,
            routine: Some(routine.name.clone()),
            reason,
            text: excerpt(&text),
        })
    };
    if n == 0 {
        skip(skipped, SkipReason::ComputedAtRunTime, text_of(toks));
        return;
    }
    for (k, t) in targets.into_iter().enumerate() {
        let role = (n == 2).then_some(if k == 0 {
            CircleRole::Via
        } else {
            CircleRole::To
        });
        let text = text_of(t);
        let value = if t.first().is_some_and(|x| x.k == K::LBrace) {
            aggregate(t).ok_or(SkipReason::ComputedAtRunTime)
        } else {
            let key = text.to_ascii_uppercase();
            match locals.get(&key).or_else(|| dat.get(&key)) {
                Some(v) => Ok(v.clone()),
                // XHOME is the E6AXIS home position of $config.dat.
                None if key.starts_with("XHOME") || key.starts_with("HOME") => Ok(Value::Joint),
                None => Err(SkipReason::UnresolvedName),
            }
        };
        let frame = match value {
            Ok(Value::Joint) => Err(SkipReason::JointMove),
            Ok(Value::Cartesian {
                frame,
                status,
                turn,
            }) if !relative => Ok((frame, status, turn)),
            Ok(Value::Cartesian { frame: d, .. }) => {
                relative_to(routine.waypoints.last(), &d, tool_frame)
            }
            Ok(Value::Partial(v)) if relative => {
                let g = |k: &str| v.get(k).copied().unwrap_or(0.0);
                let d = Frame {
                    position: Vector3::new(g("X"), g("Y"), g("Z")),
                    rotation: rotation_zyx_deg(g("A"), g("B"), g("C")),
                };
                relative_to(routine.waypoints.last(), &d, tool_frame)
            }
            Ok(Value::Partial(_)) => Err(SkipReason::ComputedAtRunTime),
            Err(e) => Err(e),
        };
        match frame.and_then(|(f, s, tu)| {
            pose_of(&f)
                .map(|p| (p, s, tu))
                .ok_or(SkipReason::InvalidTarget)
        }) {
            Ok((pose, status, turn)) => routine.waypoints.push(ImportedWaypoint {
                name: text,
                pose,
                motion: motion.to_string(),
                role,
                line: line.no,
                configuration: Some(Configuration::Krl { status, turn }),
                frame: None,
            }),
            Err(reason) => skip(skipped, reason, text),
        }
    }
}

type Resolved = (Frame, Option<i64>, Option<i64>);

/// A `_REL` displacement applied to the previous waypoint (in the base or the tool frame).
fn relative_to(
    previous: Option<&ImportedWaypoint>,
    d: &Frame,
    tool: bool,
) -> Result<Resolved, SkipReason> {
    let Some(prev) = previous else {
        return Err(SkipReason::ComputedAtRunTime);
    };
    let (p, r) = (prev.pose.position(), prev.pose.rotation());
    let frame = if tool {
        Frame {
            position: p + r * d.position,
            rotation: r * d.rotation,
        }
    } else {
        Frame {
            position: p + d.position,
            rotation: d.rotation * r,
        }
    };
    Ok((frame, None, None))
}

#[cfg(test)]
mod tests {
    use super::super::parse_files;
    use super::*;

    const SRC: &str = "&ACCESS RVP\nDEF demo( )\n;FOLD PTP HOME\nPTP XHOME C_PTP\n;ENDFOLD\nPTP XP1 C_PTP\nLIN xp2 ; comment\nCIRC XP1, {X 10, Y 0, Z 0, A 0, B 0, C 0} C_DIS\nLIN_REL {Z 5}\nLIN {X 1}\nPTP XJ\nEND\n";
    const DAT: &str = "DEFDAT demo\nDECL E6POS XP1={x 100.0,y 0.0,z 50.0,a 90.0,b 0.0,c 180.0,s 2,t 35,e1 0.0}\nDECL E6POS XP2={x 1,y 2,z 3,a 0,b 0,c 0,s 6,t 50}\nDECL E6AXIS XJ={a1 0,a2 -90,a3 90,a4 0,a5 0,a6 0}\nENDDAT\n";

    #[test]
    fn reads_src_with_its_dat() {
        let report = parse_files(&[("R1/demo.src", SRC), ("R1/DEMO.dat", DAT)]).unwrap();
        let r = &report.programs[0].routines[0];
        let names: Vec<_> = r
            .waypoints
            .iter()
            .map(|w| (w.name.as_str(), w.motion.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("XP1", "PTP"),
                ("xp2", "LIN"),
                ("XP1", "CIRC"),
                ("{X 10, Y 0, Z 0, A 0, B 0, C 0}", "CIRC"),
                ("{Z 5}", "LIN_REL")
            ]
        );
        assert!((r.waypoints[4].pose.position().z - 5.0).abs() < 1e-12);
        assert_eq!(
            r.waypoints[0].configuration,
            Some(Configuration::Krl {
                status: Some(2),
                turn: Some(35)
            })
        );
        let rot = r.waypoints[0].pose.rotation();
        // A=90 about z, C=180 about x: tool x along base y, tool z down.
        assert!((rot * Vector3::x() - Vector3::y()).norm() < 1e-12);
        assert!((rot * Vector3::z() + Vector3::z()).norm() < 1e-12);
        let reasons: Vec<_> = report.skipped.iter().map(|s| s.reason).collect();
        assert_eq!(
            reasons,
            [
                SkipReason::JointMove,
                SkipReason::ComputedAtRunTime,
                SkipReason::JointMove
            ]
        );
    }

    #[test]
    fn a_src_pairs_with_the_dat_of_its_folder_and_stem() {
        // Stems compare case-insensitively, folders exactly; a `.dat` with no `.src` is skipped.
        let report = parse_files(&[
            ("R2/demo.dat", DAT),
            ("R1/Demo.SRC", SRC),
            ("R1/other.dat", DAT),
            ("R1/demo.DAT", DAT),
        ])
        .unwrap();
        assert_eq!(report.programs.len(), 1);
        assert_eq!(report.programs[0].routines[0].waypoints.len(), 5);
        let data_only: Vec<_> = report
            .skipped
            .iter()
            .filter(|s| s.reason == SkipReason::DataOnly)
            .map(|s| s.file.as_str())
            .collect();
        assert_eq!(data_only, ["R2/demo.dat", "R1/other.dat"]);
        // In another folder the `.dat` does not pair: XP1 is then unresolved.
        let report = parse_files(&[("R1/demo.src", SRC), ("R2/demo.dat", DAT)]).unwrap();
        assert!(
            report
                .skipped
                .iter()
                .any(|s| s.reason == SkipReason::UnresolvedName)
        );
    }

    #[test]
    fn broken_aggregate_is_an_error() {
        let dat = DAT.replace("y 2,", "y ,");
        let err = parse_files(&[("demo.src", SRC), ("demo.dat", &dat)]).unwrap_err();
        assert!(err.to_string().starts_with("demo.dat:3:"), "{err}");
    }
}
