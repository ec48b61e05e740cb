//! KUKA KRL programs: a `.src` (code) with the `.dat` of the same name (its data list).
//!
//! KRL is line-oriented: each line (minus its `;` comment) is tokenised with a `logos` lexer
//! and matched on its leading tokens. Declarations (`DECL [GLOBAL] E6POS|POS|FRAME name={…}`,
//! in the `.dat` or at the top of a `DEF`) bind names; `E6AXIS`/`AXIS` ones are remembered as
//! joint-space so moves to them are counted as such. Arrays of positions (`DECL FRAME f[12]`)
//! bind each element the data list initialises (`f[1]={X 10,…}`). Motions are `PTP`, `LIN`,
//! `CIRC aux, end` and their `_REL` forms, with a named target, an array element with constant
//! indices (`f[2]`), an inline aggregate `{X …, Y …, …}`, or such operands joined by the
//! geometric operator (`f[2]:{X 0,Y 4,…}`: the right frame given in the left one, the product of
//! their transforms, with the right operand's Status and Turn). An element indexed by a variable,
//! or never initialised in the data list, is only known at run time and is skipped as such.
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
    /// The geometric operator (`base:pos`).
    #[token(":")]
    Colon,
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
    /// A declared array of positions (`DECL FRAME f[12]`); its elements are bound on their own
    /// (`F[1]`, see [`element_key`]) as the data list initialises them.
    Array {
        joint: bool,
    },
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
                if !declaration(dat, &idx, &line.toks, &mut names)? {
                    element(dat, &idx, &line.toks, &mut names)?;
                }
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
    if c.is(2, K::LBrack) {
        // Arrays (`DECL FRAME f[12], g[2,3]`): their elements are initialised on lines of their
        // own in the data list.
        c.skip(1);
        while let Some(name) = c.expect(0, K::Ident) {
            names.insert(name.s.to_ascii_uppercase(), Value::Array { joint });
            c.skip(1);
            if c.is(0, K::LBrack) {
                match c.find(K::RBrack) {
                    Some(close) => c.seek(close + 1),
                    None => break,
                }
            }
            if !c.is(0, K::Comma) {
                break;
            }
            c.skip(1);
        }
        return Ok(true);
    }
    match c.peek(2).map(|t| t.k) {
        Some(K::Eq) => {
            let what = format!("{ty} {}", name.s);
            let value = bound_value(f, idx, c.rest(3), joint, name.at, &what)?;
            names.insert(key, value);
        }
        _ if joint => {
            names.insert(key, Value::Joint);
        }
        _ => {}
    }
    Ok(true)
}

/// The value a name or an array element is bound to: a joint position, or the position
/// aggregate `agg` (`{X …, Y …, …}`); a malformed aggregate is an error naming `what`, at the
/// aggregate (or at `fallback` when it is empty).
fn bound_value(
    f: &SourceFile<'_>,
    idx: &LineIndex,
    agg: &[Tok<'_>],
    joint: bool,
    fallback: usize,
    what: &str,
) -> Result<Value, ImportError> {
    if joint {
        return Ok(Value::Joint);
    }
    aggregate(agg).ok_or_else(|| {
        let at = agg.first().map(|t| t.at).unwrap_or(fallback);
        ImportError::syntax(
            f.name,
            idx.locate(f.text, at),
            format!("{what}: expected {{X …, Y …, …}}"),
        )
    })
}

/// The key an array element is bound under: `F[1]`, `G[2,3]` (the name in upper case, the
/// indices as integers); `None` unless every index is an integer constant (`F[i]` is only known
/// at run time).
fn element_key(name: &str, index: &[Tok<'_>]) -> Option<String> {
    let mut indices = Vec::new();
    for part in index.split(|t| t.k == K::Comma) {
        match part {
            [n] if n.k == K::Num => indices.push(n.s.parse::<u64>().ok()?.to_string()),
            _ => return None,
        }
    }
    Some(format!(
        "{}[{}]",
        name.to_ascii_uppercase(),
        indices.join(",")
    ))
}

/// An element of a declared position array initialised in the data list
/// (`lfWorkPos[1]={X 10,Y -5.0,…}`); other lines are ignored. A malformed aggregate is an error,
/// as in a declaration.
fn element(
    f: &SourceFile<'_>,
    idx: &LineIndex,
    toks: &[Tok<'_>],
    names: &mut HashMap<String, Value>,
) -> Result<(), ImportError> {
    let c = Cursor::new(toks);
    let (Some(name), true) = (c.expect(0, K::Ident), c.is(1, K::LBrack)) else {
        return Ok(());
    };
    let Some(&Value::Array { joint }) = names.get(&name.s.to_ascii_uppercase()) else {
        return Ok(());
    };
    let Some(close) = c.find(K::RBrack) else {
        return Ok(());
    };
    let (Some(key), true) = (
        element_key(name.s, toks.get(2..close).unwrap_or(&[])),
        c.is(close + 1, K::Eq),
    ) else {
        return Ok(());
    };
    let value = bound_value(f, idx, c.rest(close + 2), joint, name.at, &key)?;
    names.insert(key, value);
    Ok(())
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
    // Targets: names, array elements or aggregates, maybe joined by the geometric operator;
    // separated by a comma for CIRC.
    let mut targets: Vec<&[Tok<'_>]> = Vec::new();
    let mut at = 0;
    while targets.len() < if motion.starts_with("CIRC") { 2 } else { 1 } {
        if rest.get(at).is_some_and(|t| t.k == K::Comma) {
            at += 1;
            continue;
        }
        let Some(end) = target_end(rest, at) else {
            break;
        };
        targets.push(rest.get(at..end).unwrap_or(&[]));
        at = end;
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
        let value = target_value(t, locals, dat);
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
            Ok(Value::Partial(_) | Value::Array { .. }) => Err(SkipReason::ComputedAtRunTime),
            Err(e) => Err(e),
        };
        match frame.map(|(f, s, tu)| (pose_of(&f), s, tu)) {
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

/// Where the operand starting at `toks[i]` ends (exclusive): an aggregate `{…}`, or a name with
/// an optional index `[…]`; `None` when no operand starts there.
fn operand_end(toks: &[Tok<'_>], i: usize) -> Option<usize> {
    let past = |open: usize, k: K| {
        toks.iter()
            .skip(open)
            .position(|t| t.k == k)
            .map_or(toks.len(), |j| open + j + 1)
    };
    match toks.get(i)?.k {
        K::LBrace => Some(past(i, K::RBrace)),
        K::Ident if toks.get(i + 1).is_some_and(|t| t.k == K::LBrack) => {
            Some(past(i + 1, K::RBrack))
        }
        K::Ident => Some(i + 1),
        _ => None,
    }
}

/// Where the target starting at `toks[i]` ends: operands joined by the geometric operator `:`.
fn target_end(toks: &[Tok<'_>], i: usize) -> Option<usize> {
    let mut end = operand_end(toks, i)?;
    while toks.get(end).is_some_and(|t| t.k == K::Colon) {
        match operand_end(toks, end + 1) {
            Some(next) => end = next,
            None => break,
        }
    }
    Some(end)
}

/// The value of a target: its operands, joined left to right by the geometric operator.
fn target_value(
    target: &[Tok<'_>],
    locals: &HashMap<String, Value>,
    dat: &HashMap<String, Value>,
) -> Result<Value, SkipReason> {
    let mut value: Option<Value> = None;
    for operand in target.split(|t| t.k == K::Colon) {
        let right = operand_value(operand, locals, dat)?;
        value = Some(match value {
            None => right,
            Some(left) => geometric(left, right)?,
        });
    }
    value.ok_or(SkipReason::ComputedAtRunTime)
}

/// One operand: an aggregate, a name, or an element of a declared array (`f[2]`).
fn operand_value(
    operand: &[Tok<'_>],
    locals: &HashMap<String, Value>,
    dat: &HashMap<String, Value>,
) -> Result<Value, SkipReason> {
    let lookup = |key: &str| locals.get(key).or_else(|| dat.get(key)).cloned();
    match operand {
        [first, ..] if first.k == K::LBrace => {
            aggregate(operand).ok_or(SkipReason::ComputedAtRunTime)
        }
        [name] if name.k == K::Ident => {
            let key = name.s.to_ascii_uppercase();
            match lookup(&key) {
                Some(v) => Ok(v),
                // XHOME is the E6AXIS home position of $config.dat.
                None if key.starts_with("XHOME") || key.starts_with("HOME") => Ok(Value::Joint),
                None => Err(SkipReason::UnresolvedName),
            }
        }
        [name, open, index @ .., close]
            if name.k == K::Ident && open.k == K::LBrack && close.k == K::RBrack =>
        {
            let element = element_key(name.s, index).and_then(|key| lookup(&key));
            match (element, lookup(&name.s.to_ascii_uppercase())) {
                (Some(v), _) => Ok(v),
                // Declared, but the element is only set at run time, or the index is a variable.
                (None, Some(Value::Array { .. })) => Err(SkipReason::ComputedAtRunTime),
                (None, _) => Err(SkipReason::UnresolvedName),
            }
        }
        _ => Err(SkipReason::ComputedAtRunTime),
    }
}

/// KRL's geometric operator `left:right`: `right` taken relative to `left`
/// (`T = T_left · T_right`); the result has the right operand's type, so its Status and Turn.
/// Both operands must be complete positions: KRL refuses an aggregate missing components here.
fn geometric(left: Value, right: Value) -> Result<Value, SkipReason> {
    match (left, right) {
        (
            Value::Cartesian { frame: outer, .. },
            Value::Cartesian {
                frame: inner,
                status,
                turn,
            },
        ) => Ok(Value::Cartesian {
            frame: outer.compose(&inner),
            status,
            turn,
        }),
        _ => Err(SkipReason::ComputedAtRunTime),
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
    use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion};

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

    /// A KRL position `[X, Y, Z, A, B, C]` as an isometry, built here from KUKA's definition
    /// (`Rz(A)·Ry(B)·Rx(C)`, degrees) rather than by the importer's code.
    fn krl_frame(v: [f64; 6]) -> Isometry3<f64> {
        let [x, y, z, a, b, c] = v;
        let turn = |axis: Unit<Vector3<f64>>, deg: f64| {
            UnitQuaternion::from_axis_angle(&axis, deg.to_radians())
        };
        Isometry3::from_parts(
            Translation3::new(x, y, z),
            turn(Vector3::z_axis(), a) * turn(Vector3::y_axis(), b) * turn(Vector3::x_axis(), c),
        )
    }

    const MILL_SRC: &str = include_str!("../../tests/fixtures/import/krl/mill_pocket.src");
    const MILL_DAT: &str = include_str!("../../tests/fixtures/import/krl/mill_pocket.dat");

    #[test]
    fn a_milling_cell_moves_to_frame_array_elements_and_their_geometric_products() {
        // The numbers of mill_pocket.dat, composed with nalgebra: `a:b` is `T_a · T_b`.
        let work = [
            [10.0, -5.0, 5.0, 0.0, 0.0, 0.0],
            [130.0, -5.0, 5.0, 0.0, 0.0, 0.0],
            [250.0, -5.0, 5.0, 0.0, 0.0, 0.0],
            [370.0, -5.0, 5.0, 0.0, 0.0, 0.0],
            [10.0, 245.0, 5.0, 180.0, 0.0, 0.0],
            [130.0, 245.0, 5.0, 180.0, 0.0, 0.0],
            [250.0, 245.0, 5.2, 179.5, 0.3, -0.4],
            [370.0, 245.0, 4.8, -178.0, -0.2, 0.6],
            [190.0, 120.0, 80.0, 90.0, 0.0, 0.0],
        ]
        .map(krl_frame);
        let w = |i: usize| work[i - 1];
        let down = krl_frame([0.0, 0.0, 0.0, 0.0, 0.0, 180.0]);
        let slot = krl_frame([0.0, 4.0, 0.0, 0.0, 0.0, 0.0]);
        let cut = [
            [0.0, 4.0, 0.0, 0.0, 0.0, 180.0],
            [20.0, 24.0, -1.5, 0.0, 0.0, 180.0],
            [40.0, 4.0, -1.5, 0.0, 0.0, 180.0],
        ]
        .map(krl_frame);
        let home = krl_frame([400.0, 0.0, 650.0, 0.0, 90.0, 0.0]);
        let st = |s, t| Configuration::Krl {
            status: Some(s),
            turn: Some(t),
        };
        let frame = Configuration::Krl {
            status: None,
            turn: None,
        };
        let (via, to) = (Some(CircleRole::Via), Some(CircleRole::To));
        let expected = [
            ("xHome", "PTP", None, home, st(2, 35)),
            ("lfWorkPos[1]", "LIN", None, w(1), frame.clone()),
            (
                "lfWorkPos[1]:{X 0.0,Y 4.0,Z 0,A 0.0,B 0.0,C 0.0}",
                "LIN",
                None,
                w(1) * slot,
                frame.clone(),
            ),
            ("lfWorkPos[2]", "LIN", None, w(2), frame.clone()),
            (
                "lfWorkPos[2]:{X 0.0,Y 4.0,Z 0,A 0.0,B 0.0,C 0.0}",
                "LIN",
                None,
                w(2) * slot,
                frame.clone(),
            ),
            (
                "lfWorkPos[3]:fToolDown",
                "LIN",
                None,
                w(3) * down,
                frame.clone(),
            ),
            (
                "lfWorkPos[4]:fToolDown:{X 20.0,Y 0.0,Z -1.5,A 0.0,B 0.0,C 0.0}",
                "LIN",
                None,
                w(4) * down * krl_frame([20.0, 0.0, -1.5, 0.0, 0.0, 0.0]),
                frame.clone(),
            ),
            (
                "lfWorkPos[5]:xCut[1]",
                "CIRC",
                via,
                w(5) * cut[0],
                st(6, 50),
            ),
            ("lfWorkPos[5]:xCut[2]", "CIRC", to, w(5) * cut[1], st(6, 50)),
            (
                "lfWorkPos[ 6 ]:xCut[3]",
                "LIN",
                None,
                w(6) * cut[2],
                st(6, 18),
            ),
            ("lfWorkPos[7]", "LIN", None, w(7), frame.clone()),
            ("lfWorkPos[8]", "LIN", None, w(8), frame.clone()),
            (
                "lfWorkPos[9]:fToolDown",
                "PTP",
                None,
                w(9) * down,
                frame.clone(),
            ),
            ("xHome", "PTP", None, home, st(2, 35)),
        ];
        let report = parse_files(&[
            ("cell/mill_pocket.src", MILL_SRC),
            ("cell/mill_pocket.dat", MILL_DAT),
        ])
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(report.skipped.is_empty(), "{:?}", report.skipped);
        let r = &report.programs[0].routines[0];
        assert_eq!(r.waypoints.len(), expected.len());
        for (got, (name, motion, role, pose, config)) in r.waypoints.iter().zip(&expected) {
            assert_eq!(
                (got.name.as_str(), got.motion.as_str(), got.role),
                (*name, *motion, *role)
            );
            assert_eq!(got.configuration.as_ref(), Some(config), "{name}");
            let iso = got.pose.isometry();
            let mm = (iso.translation.vector - pose.translation.vector).norm();
            let rad = iso.rotation.angle_to(&pose.rotation);
            assert!(mm < 1e-9 && rad < 1e-9, "{name}: {mm:e} mm, {rad:e} rad");
        }
    }

    #[test]
    fn array_elements_known_only_at_run_time_are_skipped_with_the_reason() {
        let dat = "DEFDAT cell\nDECL FRAME f[4], g[2,2]\nf[1]={X 1,Y 2,Z 3,A 0,B 0,C 0}\nf[2]={X 4,Y 5,Z 6,A 0,B 0,C 0}\ng[2,1]={X 7,Y 8,Z 9,A 90,B 0,C 0}\nDECL E6AXIS ax[2]\nax[1]={A1 0,A2 -90,A3 90,A4 0,A5 0,A6 0}\nENDDAT\n";
        let src = "DEF cell( )\nDECL INT i\nLIN f[1]\nLIN g[2,1]\nLIN f[i]\nLIN f[3]\nLIN h[1]\nLIN f[2]:{X 5}\nPTP ax[1]\nLIN f[1]:ax[1]\nLIN_REL f[2]\nEND\n";
        let report = parse_files(&[("cell.src", src), ("cell.dat", dat)]).unwrap();
        let r = &report.programs[0].routines[0];
        let names: Vec<_> = r.waypoints.iter().map(|w| w.name.as_str()).collect();
        assert_eq!(names, ["f[1]", "g[2,1]", "f[2]"]);
        // `LIN_REL f[2]` moves by f[2] from the previous waypoint, g[2,1].
        let p = r.waypoints[2].pose.position();
        assert!((p - Vector3::new(11.0, 13.0, 15.0)).norm() < 1e-12, "{p}");
        let skipped: Vec<_> = report
            .skipped
            .iter()
            .map(|s| (s.text.as_str(), s.reason))
            .collect();
        assert_eq!(
            skipped,
            [
                ("f[i]", SkipReason::ComputedAtRunTime),
                ("f[3]", SkipReason::ComputedAtRunTime),
                ("h[1]", SkipReason::UnresolvedName),
                ("f[2]:{X 5}", SkipReason::ComputedAtRunTime),
                ("ax[1]", SkipReason::JointMove),
                ("f[1]:ax[1]", SkipReason::ComputedAtRunTime),
            ]
        );
        // A malformed element in the data list is an error naming its line, as a declaration.
        let broken = dat.replace("f[2]={X 4,Y 5,", "f[2]={X 4,Y ,");
        let err = parse_files(&[("cell.src", src), ("cell.dat", &broken)]).unwrap_err();
        assert!(err.to_string().starts_with("cell.dat:4:"), "{err}");
    }

    #[test]
    fn broken_aggregate_is_an_error() {
        let dat = DAT.replace("y 2,", "y ,");
        let err = parse_files(&[("demo.src", SRC), ("demo.dat", &dat)]).unwrap_err();
        assert!(err.to_string().starts_with("demo.dat:3:"), "{err}");
    }
}
