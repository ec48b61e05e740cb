//! ABB RAPID modules (`.mod`, `.modx`, `.prg`, `.sys`).
//!
//! A module is tokenised with a `logos` lexer (comments `!` to end of line, strings with `""`
//! escapes); the token stream is then split into the module's declarations and its routines'
//! statements. Targets are evaluated by a small expression evaluator that knows robtarget
//! aggregates, `Offs`, `RelTool` (`\Rx \Ry \Rz`), constant array indices and `num` arithmetic
//! over declared values. Control flow is not followed: statements are read in text order, and an
//! assignment to a target variable holds until the next one — a reading of the program as
//! written, which is what the operator taught.
//!
//! Names resolve first in the routine (its `VAR`s and assignments so far), then in the module,
//! then in the other modules of the upload (RAPID names are case-insensitive). A target that
//! can only be known at run time (function results, record fields, loop-dependent offsets, a
//! variable assigned from those) is skipped and reported.

use std::collections::HashMap;
use std::rc::Rc;

use logos::Logos;
use nalgebra::{UnitQuaternion, Vector3};

use super::{
    CircleRole, Configuration, Frame, ImportError, ImportReport, ImportedProgram, ImportedRoutine,
    Language, LineIndex, SkipReason, Skipped, SourceFile, Waypoint, drop_short_routines, excerpt,
    pose_of, quaternion_wxyz,
};

/// Deepest expression nesting evaluated; deeper input is treated as computed at run time.
const MAX_DEPTH: usize = 64;

/// Deepest nesting of blocks (`IF … THEN`, `WHILE`, `FOR`, `TEST`) in a routine that is read;
/// a file nested deeper is refused with [`ImportError::NestingTooDeep`]. Taught programs nest a
/// handful of levels; the limit bounds what an upload can ask of the parser.
pub const MAX_BLOCK_NESTING: usize = 256;

#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
#[logos(skip r"[ \t\r\n\f]+")]
#[logos(skip(r"![^\n]*", allow_greedy = true))]
enum K {
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident,
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?")]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?")]
    Num,
    #[regex(r#""([^"\n]|"")*""#)]
    Str,
    #[token(":=")]
    Assign,
    #[token("[")]
    LBrack,
    #[token("]")]
    RBrack,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token(":")]
    Colon,
    #[token("\\")]
    Backslash,
    #[token(".")]
    Dot,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    /// Anything else (operators the importer does not evaluate, stray characters).
    Other,
}

#[derive(Debug, Clone, Copy)]
struct Tok<'s> {
    k: K,
    s: &'s str,
    at: usize,
}

fn lex(text: &str) -> Vec<Tok<'_>> {
    // A `%%% VERSION:1 LANGUAGE:ENGLISH %%%` header (RobotWare 5 files) is not RAPID.
    let start = text
        .trim_start()
        .strip_prefix("%%%")
        .and_then(|rest| rest.find("%%%").map(|i| text.len() - rest.len() + i + 3))
        .unwrap_or(0);
    let body = text.get(start..).unwrap_or("");
    let mut lexer = K::lexer(body);
    let mut out = Vec::new();
    while let Some(r) = lexer.next() {
        out.push(Tok {
            k: r.unwrap_or(K::Other),
            s: lexer.slice(),
            at: start + lexer.span().start,
        });
    }
    out
}

fn is_kw(t: Option<&Tok<'_>>, kw: &str) -> bool {
    t.is_some_and(|t| t.k == K::Ident && t.s.eq_ignore_ascii_case(kw))
}

/// What a motion instruction does with its positional arguments.
#[derive(Debug, Clone, Copy, PartialEq)]
enum MotionKind {
    /// The target is positional argument `n`.
    Target(usize),
    /// Via point and end point are positional arguments `n` and `n + 1`.
    Circle(usize),
    /// A joint-space move: skipped and counted.
    Joint,
}

fn motion_kind(name: &str) -> Option<(&'static str, MotionKind)> {
    const TABLE: &[(&str, MotionKind)] = &[
        ("MoveL", MotionKind::Target(0)),
        ("MoveJ", MotionKind::Target(0)),
        ("MoveC", MotionKind::Circle(0)),
        ("MoveLDO", MotionKind::Target(0)),
        ("MoveJDO", MotionKind::Target(0)),
        ("MoveCDO", MotionKind::Circle(0)),
        ("MoveLSync", MotionKind::Target(0)),
        ("MoveJSync", MotionKind::Target(0)),
        ("MoveCSync", MotionKind::Circle(0)),
        ("MoveLGO", MotionKind::Target(0)),
        ("MoveJGO", MotionKind::Target(0)),
        ("MoveCGO", MotionKind::Circle(0)),
        ("MoveLAO", MotionKind::Target(0)),
        ("MoveJAO", MotionKind::Target(0)),
        ("MoveCAO", MotionKind::Circle(0)),
        ("TriggL", MotionKind::Target(0)),
        ("TriggJ", MotionKind::Target(0)),
        ("TriggC", MotionKind::Circle(0)),
        ("TriggLIOs", MotionKind::Target(0)),
        ("TriggJIOs", MotionKind::Target(0)),
        ("ArcL", MotionKind::Target(0)),
        ("ArcLStart", MotionKind::Target(0)),
        ("ArcLEnd", MotionKind::Target(0)),
        ("ArcC", MotionKind::Circle(0)),
        ("ArcCStart", MotionKind::Circle(0)),
        ("ArcCEnd", MotionKind::Circle(0)),
        ("CapL", MotionKind::Target(0)),
        ("CapC", MotionKind::Circle(0)),
        ("SpotL", MotionKind::Target(0)),
        ("SpotJ", MotionKind::Target(0)),
        ("PaintL", MotionKind::Target(0)),
        ("PaintC", MotionKind::Circle(0)),
        ("SearchL", MotionKind::Target(2)),
        ("SearchC", MotionKind::Circle(2)),
        ("MoveAbsJ", MotionKind::Joint),
        ("MoveAbsJDO", MotionKind::Joint),
        ("MoveAbsJSync", MotionKind::Joint),
        ("MoveExtJ", MotionKind::Joint),
        ("ArcMoveAbsJ", MotionKind::Joint),
        ("ArcMoveExtJ", MotionKind::Joint),
        ("SearchExtJ", MotionKind::Joint),
    ];
    TABLE
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|&(n, k)| (n, k))
}

/// A resolved robtarget.
#[derive(Debug, Clone, PartialEq)]
struct Target {
    frame: Frame,
    config: Option<Configuration>,
}

/// A value. Aggregates are shared, not copied: every use of a name clones its value, and a
/// robtarget array of n elements used n times (`ps{1}` … `ps{n}`) would otherwise cost n².
#[derive(Debug, Clone, PartialEq)]
enum Val {
    Num(f64),
    Agg(Rc<[Val]>),
    Target(Target),
    Str,
}

/// What a name is bound to.
#[derive(Debug, Clone, PartialEq)]
enum Binding {
    Known(Val),
    /// Declared, but its value is only known at run time.
    RunTime,
}

type Eval = Result<Val, SkipReason>;

/// A statement: a token range, its routine part.
#[derive(Debug, Clone)]
struct Stmt {
    start: usize,
    end: usize,
    in_error_handler: bool,
    local: bool,
    /// A `FOR` loop's variable: from here on its value is only known at run time.
    loop_var: Option<String>,
}

#[derive(Debug)]
struct RoutineAst {
    name: String,
    line: usize,
    collect: bool,
    stmts: Vec<Stmt>,
}

struct ModuleAst<'s> {
    file: SourceFile<'s>,
    name: String,
    toks: Vec<Tok<'s>>,
    lines: LineIndex,
    decls: Vec<Stmt>,
    routines: Vec<RoutineAst>,
}

/// Parses the RAPID modules of an upload, resolving targets across them.
pub(crate) fn parse(
    files: &[SourceFile<'_>],
    report: &mut ImportReport,
) -> Result<(), ImportError> {
    let modules = files
        .iter()
        .map(|f| structure(*f))
        .collect::<Result<Vec<_>, _>>()?;

    // Module-level declarations, twice so that forward references across modules resolve.
    let mut module_envs: Vec<HashMap<String, Binding>> = vec![HashMap::new(); modules.len()];
    let mut global: HashMap<String, Binding> = HashMap::new();
    for _ in 0..2 {
        for (mi, m) in modules.iter().enumerate() {
            for d in &m.decls {
                let Some((name, binding)) = eval_decl(m, d, &[&module_envs[mi], &global])? else {
                    continue;
                };
                if !d.local {
                    global
                        .entry(name.clone())
                        .or_insert_with(|| binding.clone());
                    if let Some(b) = global.get_mut(&name)
                        && *b == Binding::RunTime
                    {
                        *b = binding.clone();
                    }
                }
                module_envs[mi].insert(name, binding);
            }
        }
    }

    for (mi, m) in modules.iter().enumerate() {
        let mut routines = Vec::new();
        for r in &m.routines {
            if !r.collect {
                continue;
            }
            let mut locals: HashMap<String, Binding> = HashMap::new();
            let mut waypoints = Vec::new();
            for st in &r.stmts {
                let envs = [&module_envs[mi], &global];
                routine_stmt(
                    m,
                    r,
                    st,
                    &mut locals,
                    &envs,
                    &mut waypoints,
                    &mut report.skipped,
                )?;
            }
            routines.push(ImportedRoutine {
                name: r.name.clone(),
                file: m.file.name.to_string(),
                line: r.line,
                waypoints,
            });
        }
        let routines = drop_short_routines(routines, &mut report.skipped);
        report.programs.push(ImportedProgram {
            name: m.name.clone(),
            source: m.file.name.to_string(),
            language: Language::Rapid,
            routines,
        });
    }
    Ok(())
}

/// Splits a module into declarations and routines.
fn structure(file: SourceFile<'_>) -> Result<ModuleAst<'_>, ImportError> {
    let toks = lex(file.text);
    let lines = LineIndex::new(file.text);
    let mut m = ModuleAst {
        file,
        name: super::stem_of(file.name).to_string(),
        toks,
        lines,
        decls: Vec::new(),
        routines: Vec::new(),
    };
    let toks = &m.toks;
    let n = toks.len();
    let err = |i: usize, msg: &str| {
        let at = toks.get(i).map(|t| t.at).unwrap_or(file.text.len());
        ImportError::syntax(file.name, m.lines.locate(file.text, at), msg)
    };
    let mut routine: Option<RoutineAst> = None;
    let mut in_error = false;
    let mut local = false;
    // Blocks open in the current routine (a routine, module or file boundary closes them all,
    // so a missing ENDIF in one routine does not count against the next).
    let mut blocks: usize = 0;
    let open_block = |blocks: &mut usize, at: usize| {
        *blocks += 1;
        if *blocks > MAX_BLOCK_NESTING {
            let loc = m.lines.locate(file.text, at);
            return Err(ImportError::NestingTooDeep {
                file: file.name.to_string(),
                line: loc.line,
                column: loc.column,
                limit: MAX_BLOCK_NESTING,
            });
        }
        Ok(())
    };
    let mut i = 0;
    while i < n {
        let t = toks[i];
        if t.k == K::Semi {
            i += 1;
            continue;
        }
        let word = if t.k == K::Ident {
            t.s.to_ascii_uppercase()
        } else {
            String::new()
        };
        match word.as_str() {
            "MODULE" => {
                blocks = 0;
                match toks.get(i + 1) {
                    Some(name) if name.k == K::Ident => m.name = name.s.to_string(),
                    _ => return Err(err(i + 1, "MODULE must be followed by its name")),
                }
                i += 2;
                if toks.get(i).is_some_and(|t| t.k == K::LParen) {
                    i = closing(toks, i, n).ok_or_else(|| err(i, "unclosed module attributes"))?
                        + 1;
                }
            }
            "LOCAL" | "TASK" | "SYSMODULE" | "NOSTEPIN" | "VIEWONLY" | "READONLY" | "NOVIEW" => {
                local |= word == "LOCAL";
                i += 1;
            }
            "PROC" | "TRAP" | "FUNC" => {
                if let Some(r) = routine.take() {
                    m.routines.push(r);
                }
                let name_at = if word == "FUNC" { i + 2 } else { i + 1 };
                let name = match toks.get(name_at) {
                    Some(t) if t.k == K::Ident => t.s.to_string(),
                    _ => {
                        return Err(err(
                            name_at,
                            &format!("{word} must be followed by its name"),
                        ));
                    }
                };
                i = name_at + 1;
                if word != "TRAP" {
                    if !toks.get(i).is_some_and(|t| t.k == K::LParen) {
                        return Err(err(
                            i,
                            &format!("{word} {name}: expected '(' and parameters"),
                        ));
                    }
                    i = closing(toks, i, n).ok_or_else(|| err(i, "unclosed parameter list"))? + 1;
                }
                routine = Some(RoutineAst {
                    name,
                    line: m.lines.line(t.at),
                    collect: word != "FUNC",
                    stmts: Vec::new(),
                });
                in_error = false;
                local = false;
                blocks = 0;
            }
            "ENDPROC" | "ENDTRAP" | "ENDFUNC" => {
                if let Some(r) = routine.take() {
                    m.routines.push(r);
                }
                in_error = false;
                blocks = 0;
                i += 1;
            }
            "ENDMODULE" => {
                blocks = 0;
                i += 1;
            }
            "ENDIF" | "ENDWHILE" | "ENDFOR" | "ENDTEST" => {
                blocks = blocks.saturating_sub(1);
                i += 1;
            }
            "ELSE" => i += 1,
            "ERROR" | "BACKWARD" | "UNDO" if routine.is_some() => {
                in_error = true;
                i += 1;
                if toks.get(i).is_some_and(|t| t.k == K::LParen) {
                    i = closing(toks, i, n).ok_or_else(|| err(i, "unclosed error number list"))?
                        + 1;
                }
            }
            "RECORD" => {
                while i < n && !is_kw(toks.get(i), "ENDRECORD") {
                    i += 1;
                }
                i += 1;
            }
            "IF" | "ELSEIF" | "WHILE" | "FOR" => {
                if let (Some(r), true) = (routine.as_mut(), word == "FOR") {
                    r.stmts.push(Stmt {
                        start: i,
                        end: i,
                        in_error_handler: in_error,
                        local: false,
                        loop_var: toks.get(i + 1).map(|t| t.s.to_ascii_lowercase()),
                    });
                }
                // Skip the condition up to THEN/DO; a compact IF (no THEN) is one statement.
                let head =
                    scan_statement(toks, i, |t| is_kw(Some(t), "THEN") || is_kw(Some(t), "DO"));
                match head {
                    Ok(j) => {
                        if word != "ELSEIF" {
                            open_block(&mut blocks, t.at)?;
                        }
                        i = j + 1;
                    }
                    Err(end) => i = end + 1,
                }
            }
            "TEST" => {
                open_block(&mut blocks, t.at)?;
                i += 1;
                while i < n && !is_kw(toks.get(i), "CASE") && !is_kw(toks.get(i), "DEFAULT") {
                    i += 1;
                }
            }
            "CASE" | "DEFAULT" => match scan_statement(toks, i, |t| t.k == K::Colon) {
                Ok(j) | Err(j) => i = j + 1,
            },
            _ if t.k == K::Ident && toks.get(i + 1).is_some_and(|t| t.k == K::Colon) => {
                i += 2; // label
            }
            _ => {
                let end = statement_end(toks, i);
                let st = Stmt {
                    start: i,
                    end,
                    in_error_handler: in_error,
                    local,
                    loop_var: None,
                };
                match routine.as_mut() {
                    Some(r) => r.stmts.push(st),
                    None => m.decls.push(st),
                }
                local = false;
                i = end + 1;
            }
        }
    }
    if let Some(r) = routine.take() {
        m.routines.push(r);
    }
    Ok(m)
}

/// Index of the `;` ending the statement starting at `i` (or of the block keyword that cuts a
/// statement missing its `;`, or the end of input), at bracket depth 0.
fn statement_end(toks: &[Tok<'_>], i: usize) -> usize {
    match scan_statement(toks, i, |_| false) {
        Ok(j) | Err(j) => j,
    }
}

/// Scans the statement starting at `i` up to its first token that `stop` accepts: `Ok` with
/// that token's index, or `Err` with the statement's end (see [`statement_end`]) when there is
/// none. It stops *at* the match, so reading a block header (`IF c THEN`, `CASE 1:`) costs the
/// tokens of the header, not those of the nested body up to the first `;` — which, read from
/// every opener of a deeply nested file, made parsing time grow with the square of the depth.
fn scan_statement(
    toks: &[Tok<'_>],
    i: usize,
    mut stop: impl FnMut(&Tok<'_>) -> bool,
) -> Result<usize, usize> {
    let mut depth: usize = 0;
    let mut j = i;
    while let Some(t) = toks.get(j) {
        match t.k {
            K::LBrack | K::LParen | K::LBrace => depth += 1,
            K::RBrack | K::RParen | K::RBrace => depth = depth.saturating_sub(1),
            K::Semi if depth == 0 => return Err(j),
            K::Ident if j > i && depth == 0 => {
                const CUT: &[&str] = &[
                    "ENDPROC",
                    "ENDFUNC",
                    "ENDTRAP",
                    "ENDMODULE",
                    "PROC",
                    "FUNC",
                    "TRAP",
                ];
                if CUT.iter().any(|c| t.s.eq_ignore_ascii_case(c)) {
                    return Err(j.saturating_sub(1).max(i));
                }
            }
            _ => {}
        }
        if stop(t) {
            return Ok(j);
        }
        j += 1;
    }
    Err(toks.len())
}

/// Index of the bracket closing the one at `i`, if it is before `end`.
fn closing(toks: &[Tok<'_>], i: usize, end: usize) -> Option<usize> {
    let mut depth: usize = 0;
    let within = toks.get(..end.min(toks.len())).unwrap_or(toks);
    for (j, t) in within.iter().enumerate().skip(i) {
        match t.k {
            K::LBrack | K::LParen | K::LBrace => depth += 1,
            K::RBrack | K::RParen | K::RBrace => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return Some(j);
                }
            }
            _ => {}
        }
    }
    None
}

/// Splits `toks[start..end]` at depth-0 `sep` tokens.
fn split_top(toks: &[Tok<'_>], start: usize, end: usize, sep: K) -> Vec<(usize, usize)> {
    let mut parts = Vec::new();
    let mut depth: usize = 0;
    let mut from = start;
    for j in start..end {
        let Some(t) = toks.get(j) else { break };
        match t.k {
            K::LBrack | K::LParen | K::LBrace => depth += 1,
            K::RBrack | K::RParen | K::RBrace => depth = depth.saturating_sub(1),
            k if k == sep && depth == 0 => {
                parts.push((from, j));
                from = j + 1;
            }
            _ => {}
        }
    }
    parts.push((from, end));
    parts
}

/// A declaration `[CONST|PERS|VAR] type name[{dims}] [:= value]`: its lower-case name and value.
fn eval_decl(
    m: &ModuleAst<'_>,
    d: &Stmt,
    envs: &[&HashMap<String, Binding>],
) -> Result<Option<(String, Binding)>, ImportError> {
    let toks = &m.toks;
    let Some(first) = toks.get(d.start) else {
        return Ok(None);
    };
    if !["CONST", "PERS", "VAR"]
        .iter()
        .any(|k| first.s.eq_ignore_ascii_case(k))
    {
        return Ok(None);
    }
    let (Some(ty), Some(name)) = (toks.get(d.start + 1), toks.get(d.start + 2)) else {
        return Err(ImportError::syntax(
            m.file.name,
            m.lines.locate(m.file.text, first.at),
            "declaration must give a type and a name",
        ));
    };
    if ty.k != K::Ident || name.k != K::Ident {
        return Err(ImportError::syntax(
            m.file.name,
            m.lines.locate(m.file.text, name.at),
            "declaration must give a type and a name",
        ));
    }
    let key = name.s.to_ascii_lowercase();
    let Some(eq) = (d.start..d.end).find(|&j| toks.get(j).is_some_and(|t| t.k == K::Assign)) else {
        return Ok(Some((key, Binding::RunTime)));
    };
    let empty = HashMap::new();
    let binding = match Evaluator::new(m, envs, &empty).expr(eq + 1, d.end) {
        Ok(v) => {
            if ty.s.eq_ignore_ascii_case("robtarget") {
                check_robtarget_shape(m, &v, toks.get(eq + 1))?;
            }
            Binding::Known(v)
        }
        Err(_) => Binding::RunTime,
    };
    Ok(Some((key, binding)))
}

/// A robtarget literal (or array of them) must have the robtarget shape; a misplaced bracket in
/// a taught position is worth an error rather than a silent skip.
fn check_robtarget_shape(
    m: &ModuleAst<'_>,
    v: &Val,
    at: Option<&Tok<'_>>,
) -> Result<(), ImportError> {
    let ok = match v {
        Val::Agg(items) if items.first().is_some_and(|f| matches!(f, Val::Agg(_))) => {
            match items.first() {
                Some(Val::Agg(inner))
                    if inner.first().is_some_and(|x| matches!(x, Val::Num(_))) =>
                {
                    target_from_agg(items).is_some()
                }
                // An array of robtargets.
                _ => items.iter().all(|e| match e {
                    Val::Agg(it) => {
                        target_from_agg(it).is_some() || it.iter().all(|x| matches!(x, Val::Agg(_)))
                    }
                    _ => false,
                }),
            }
        }
        Val::Target(_) => true,
        _ => false,
    };
    if ok {
        return Ok(());
    }
    let offset = at.map(|t| t.at).unwrap_or(0);
    Err(ImportError::syntax(
        m.file.name,
        m.lines.locate(m.file.text, offset),
        "robtarget value must be [[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,...]]",
    ))
}

/// A robtarget from an aggregate `[[x,y,z],[q1..q4],[cf1,cf4,cf6,cfx],...]`; `None` when the
/// shape is wrong, `Some(None)` when the quaternion is not a rotation.
fn target_from_agg(items: &[Val]) -> Option<Option<Target>> {
    let nums = |v: Option<&Val>, n: usize| -> Option<Vec<f64>> {
        match v {
            Some(Val::Agg(xs)) if xs.len() == n => xs
                .iter()
                .map(|x| match x {
                    Val::Num(f) => Some(*f),
                    _ => None,
                })
                .collect(),
            _ => None,
        }
    };
    let p = nums(items.first(), 3)?;
    let q = nums(items.get(1), 4)?;
    let config = nums(items.get(2), 4).map(|c| Configuration::Rapid {
        cf1: c.first().copied().unwrap_or(0.0) as i64,
        cf4: c.get(1).copied().unwrap_or(0.0) as i64,
        cf6: c.get(2).copied().unwrap_or(0.0) as i64,
        cfx: c.get(3).copied().unwrap_or(0.0) as i64,
    });
    let (&[x, y, z], &[qw, qx, qy, qz]) = (p.as_slice(), q.as_slice()) else {
        return None;
    };
    Some(quaternion_wxyz([qw, qx, qy, qz]).map(|rotation| Target {
        frame: Frame {
            position: Vector3::new(x, y, z),
            rotation,
        },
        config,
    }))
}

fn as_target(v: Val) -> Result<Target, SkipReason> {
    match v {
        Val::Target(t) => Ok(t),
        Val::Agg(items) => match target_from_agg(&items) {
            Some(Some(t)) => Ok(t),
            Some(None) => Err(SkipReason::InvalidTarget),
            None => Err(SkipReason::ComputedAtRunTime),
        },
        _ => Err(SkipReason::ComputedAtRunTime),
    }
}

/// Evaluates expressions over a module's tokens.
struct Evaluator<'a, 's> {
    toks: &'a [Tok<'s>],
    envs: &'a [&'a HashMap<String, Binding>],
    locals: &'a HashMap<String, Binding>,
    depth: usize,
}

impl<'a, 's> Evaluator<'a, 's> {
    fn new(
        m: &'a ModuleAst<'s>,
        envs: &'a [&'a HashMap<String, Binding>],
        locals: &'a HashMap<String, Binding>,
    ) -> Self {
        Evaluator {
            toks: &m.toks,
            envs,
            locals,
            depth: 0,
        }
    }

    fn lookup(&self, name: &str) -> Eval {
        let key = name.to_ascii_lowercase();
        let found = self
            .locals
            .get(&key)
            .or_else(|| self.envs.iter().find_map(|e| e.get(&key)));
        match found {
            Some(Binding::Known(v)) => Ok(v.clone()),
            Some(Binding::RunTime) => Err(SkipReason::ComputedAtRunTime),
            None => Err(SkipReason::UnresolvedName),
        }
    }

    /// The whole range must be one expression.
    fn expr(&mut self, start: usize, end: usize) -> Eval {
        let (v, next) = self.sum(start, end)?;
        if next == end {
            Ok(v)
        } else {
            Err(SkipReason::ComputedAtRunTime)
        }
    }

    fn tok(&self, i: usize, end: usize) -> Option<Tok<'s>> {
        if i < end {
            self.toks.get(i).copied()
        } else {
            None
        }
    }

    fn sum(&mut self, start: usize, end: usize) -> Result<(Val, usize), SkipReason> {
        let (mut v, mut i) = self.product(start, end)?;
        while let Some(t) = self.tok(i, end) {
            let sign = match t.k {
                K::Plus => 1.0,
                K::Minus => -1.0,
                _ => break,
            };
            let (w, j) = self.product(i + 1, end)?;
            v = Val::Num(num(&v)? + sign * num(&w)?);
            i = j;
        }
        Ok((v, i))
    }

    fn product(&mut self, start: usize, end: usize) -> Result<(Val, usize), SkipReason> {
        let (mut v, mut i) = self.unary(start, end)?;
        while let Some(t) = self.tok(i, end) {
            let op = match t.k {
                K::Star => '*',
                K::Slash => '/',
                K::Ident if t.s.eq_ignore_ascii_case("DIV") => 'd',
                K::Ident if t.s.eq_ignore_ascii_case("MOD") => 'm',
                _ => break,
            };
            let (w, j) = self.unary(i + 1, end)?;
            let (a, b) = (num(&v)?, num(&w)?);
            let r = match op {
                '*' => a * b,
                '/' => a / b,
                'd' => (a / b).trunc(),
                _ => a % b,
            };
            if !r.is_finite() {
                return Err(SkipReason::ComputedAtRunTime);
            }
            v = Val::Num(r);
            i = j;
        }
        Ok((v, i))
    }

    fn unary(&mut self, start: usize, end: usize) -> Result<(Val, usize), SkipReason> {
        match self.tok(start, end).map(|t| t.k) {
            Some(K::Minus) => {
                let (v, i) = self.nested(|e| e.unary(start + 1, end))?;
                Ok((Val::Num(-num(&v)?), i))
            }
            Some(K::Plus) => self.nested(|e| e.unary(start + 1, end)),
            _ => self.primary(start, end),
        }
    }

    fn nested<T>(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<T, SkipReason>,
    ) -> Result<T, SkipReason> {
        if self.depth >= MAX_DEPTH {
            return Err(SkipReason::ComputedAtRunTime);
        }
        self.depth += 1;
        let r = f(self);
        self.depth -= 1;
        r
    }

    fn primary(&mut self, start: usize, end: usize) -> Result<(Val, usize), SkipReason> {
        let Some(t) = self.tok(start, end) else {
            return Err(SkipReason::ComputedAtRunTime);
        };
        match t.k {
            K::Num => {
                let v: f64 = t.s.parse().map_err(|_| SkipReason::ComputedAtRunTime)?;
                Ok((Val::Num(v), start + 1))
            }
            K::Str => Ok((Val::Str, start + 1)),
            K::LParen => {
                let close = self.closing_within(start, end)?;
                let v = self.nested(|e| e.expr(start + 1, close))?;
                Ok((v, close + 1))
            }
            K::LBrack => {
                let close = self.closing_within(start, end)?;
                let mut items = Vec::new();
                if close > start + 1 {
                    for (a, b) in split_top(self.toks, start + 1, close, K::Comma) {
                        items.push(self.nested(|e| e.expr(a, b))?);
                    }
                }
                Ok((Val::Agg(items.into()), close + 1))
            }
            K::Ident => {
                if self.tok(start + 1, end).is_some_and(|n| n.k == K::LParen) {
                    let close = self.closing_within(start + 1, end)?;
                    let v = self.nested(|e| e.call(t.s, start + 2, close))?;
                    return Ok((v, close + 1));
                }
                let mut i = start + 1;
                let mut v = match t.s.to_ascii_uppercase().as_str() {
                    "TRUE" | "FALSE" => Val::Num(0.0),
                    _ => self.lookup(t.s)?,
                };
                if self.tok(i, end).is_some_and(|n| n.k == K::LBrace) {
                    let close = self.closing_within(i, end)?;
                    for (a, b) in split_top(self.toks, i + 1, close, K::Comma) {
                        let idx = num(&self.nested(|e| e.expr(a, b))?)?;
                        v = index(v, idx)?;
                    }
                    i = close + 1;
                }
                if self.tok(i, end).is_some_and(|n| n.k == K::Dot) {
                    // A record field: a value the importer does not take apart.
                    return Err(SkipReason::ComputedAtRunTime);
                }
                Ok((v, i))
            }
            _ => Err(SkipReason::ComputedAtRunTime),
        }
    }

    fn closing_within(&self, i: usize, end: usize) -> Result<usize, SkipReason> {
        closing(self.toks, i, end).ok_or(SkipReason::ComputedAtRunTime)
    }

    /// `Offs(p, dx, dy, dz)` and `RelTool(p, dx, dy, dz [\Rx:=a] [\Ry:=b] [\Rz:=c])`; any other
    /// function's result is only known at run time.
    fn call(&mut self, name: &str, start: usize, end: usize) -> Eval {
        let is_offs = name.eq_ignore_ascii_case("Offs");
        let is_reltool = name.eq_ignore_ascii_case("RelTool");
        if !is_offs && !is_reltool {
            return Err(SkipReason::ComputedAtRunTime);
        }
        let args = arguments(self.toks, start, end);
        let [p, dx, dy, dz] = args.positional.as_slice() else {
            return Err(SkipReason::ComputedAtRunTime);
        };
        let base = as_target(self.expr(p.0, p.1)?)?;
        let mut d = [0.0; 3];
        for (slot, r) in d.iter_mut().zip([dx, dy, dz]) {
            *slot = num(&self.expr(r.0, r.1)?)?;
        }
        let d = Vector3::new(d[0], d[1], d[2]);
        let mut frame = base.frame;
        if is_offs {
            if !args.optional.is_empty() {
                return Err(SkipReason::ComputedAtRunTime);
            }
            frame.position += d;
        } else {
            frame.position += frame.rotation * d;
            let mut rot = [0.0; 3];
            for (opt, range) in &args.optional {
                let axis = match opt.to_ascii_uppercase().as_str() {
                    "RX" => 0,
                    "RY" => 1,
                    "RZ" => 2,
                    _ => return Err(SkipReason::ComputedAtRunTime),
                };
                let Some((a, b)) = range else {
                    return Err(SkipReason::ComputedAtRunTime);
                };
                if let Some(slot) = rot.get_mut(axis) {
                    *slot = num(&self.expr(*a, *b)?)?;
                }
            }
            let [rx, ry, rz] = rot.map(f64::to_radians);
            frame.rotation = frame.rotation
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), rx)
                * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), ry)
                * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rz);
        }
        Ok(Val::Target(Target {
            frame,
            config: base.config,
        }))
    }
}

fn num(v: &Val) -> Result<f64, SkipReason> {
    match v {
        Val::Num(x) if x.is_finite() => Ok(*x),
        _ => Err(SkipReason::ComputedAtRunTime),
    }
}

/// `v{idx}` with a 1-based constant index.
fn index(v: Val, idx: f64) -> Eval {
    let Val::Agg(items) = v else {
        return Err(SkipReason::ComputedAtRunTime);
    };
    if idx.fract() != 0.0 || idx < 1.0 {
        return Err(SkipReason::ComputedAtRunTime);
    }
    items
        .get(idx as usize - 1)
        .cloned()
        .ok_or(SkipReason::ComputedAtRunTime)
}

/// Arguments of a procedure or function call: positional ranges, and optional `\Name[:=value]`.
struct Args {
    positional: Vec<(usize, usize)>,
    optional: Vec<(String, Option<(usize, usize)>)>,
}

fn arguments(toks: &[Tok<'_>], start: usize, end: usize) -> Args {
    let mut args = Args {
        positional: Vec::new(),
        optional: Vec::new(),
    };
    if start >= end {
        return args;
    }
    for (a, b) in split_top(toks, start, end, K::Comma) {
        let pieces = split_top(toks, a, b, K::Backslash);
        for (n, (pa, pb)) in pieces.into_iter().enumerate() {
            if n == 0 {
                if pb > pa {
                    args.positional.push((pa, pb));
                }
                continue;
            }
            let Some(name) = toks.get(pa).filter(|t| t.k == K::Ident) else {
                continue;
            };
            let value = toks
                .get(pa + 1)
                .filter(|t| t.k == K::Assign)
                .map(|_| (pa + 2, pb));
            args.optional.push((name.s.to_string(), value));
        }
    }
    args
}

/// Source text of a token range.
fn text_of<'s>(m: &ModuleAst<'s>, a: usize, b: usize) -> &'s str {
    let (Some(first), Some(last)) = (m.toks.get(a), b.checked_sub(1).and_then(|l| m.toks.get(l)))
    else {
        return "";
    };
    m.file
        .text
        .get(first.at..last.at + last.s.len())
        .unwrap_or("")
}

#[allow(clippy::too_many_arguments)]
fn routine_stmt(
    m: &ModuleAst<'_>,
    r: &RoutineAst,
    st: &Stmt,
    locals: &mut HashMap<String, Binding>,
    envs: &[&HashMap<String, Binding>],
    waypoints: &mut Vec<Waypoint>,
    skipped: &mut Vec<Skipped>,
) -> Result<(), ImportError> {
    let toks = &m.toks;
    if let Some(var) = &st.loop_var {
        locals.insert(var.clone(), Binding::RunTime);
        return Ok(());
    }
    let Some(first) = toks.get(st.start) else {
        return Ok(());
    };
    if first.k != K::Ident {
        return Ok(());
    }
    // Local declaration.
    if ["CONST", "PERS", "VAR"]
        .iter()
        .any(|k| first.s.eq_ignore_ascii_case(k))
    {
        let all: Vec<&HashMap<String, Binding>> = std::iter::once(&*locals)
            .chain(envs.iter().copied())
            .collect();
        if let Some((name, binding)) = eval_decl(m, st, &all)? {
            locals.insert(name, binding);
        }
        return Ok(());
    }
    // Assignment `name[{..}][.field] := value`.
    let assign_at = (st.start..st.end)
        .find(|&j| toks.get(j).is_some_and(|t| t.k == K::Assign))
        .filter(|&eq| {
            // Not an optional argument (`MoveL p, v, z, t\WObj:=w`): only a name, indices and
            // fields may stand before the `:=` of an assignment.
            toks.get(st.start..eq).is_some_and(|lhs| {
                !lhs.iter()
                    .any(|t| matches!(t.k, K::Backslash | K::Comma | K::LParen))
            })
        });
    if let Some(eq) = assign_at {
        let key = first.s.to_ascii_lowercase();
        let whole = eq == st.start + 1;
        let binding = if whole {
            let mut ev = Evaluator {
                toks,
                envs,
                locals,
                depth: 0,
            };
            match ev.expr(eq + 1, st.end) {
                Ok(v) => Binding::Known(v),
                Err(_) => Binding::RunTime,
            }
        } else {
            Binding::RunTime
        };
        locals.insert(key, binding);
        return Ok(());
    }
    let Some((motion, kind)) = motion_kind(first.s) else {
        return Ok(());
    };
    let line = m.lines.line(first.at);
    let args = arguments(toks, st.start + 1, st.end);
    let skip = |skipped: &mut Vec<Skipped>, reason, text: &str| {
        skipped.push(Skipped {
            file: m.file.name.to_string(),
            line,
            routine: Some(r.name.clone()),
            reason,
            text: excerpt(text),
        })
    };
    let stmt_text = text_of(m, st.start, st.end);
    if st.in_error_handler {
        skip(skipped, SkipReason::InErrorHandler, stmt_text);
        return Ok(());
    }
    let targets: Vec<(usize, Option<CircleRole>)> = match kind {
        MotionKind::Joint => {
            skip(skipped, SkipReason::JointMove, stmt_text);
            return Ok(());
        }
        MotionKind::Target(n) => vec![(n, None)],
        MotionKind::Circle(n) => vec![(n, Some(CircleRole::Via)), (n + 1, Some(CircleRole::To))],
    };
    let frame = args
        .optional
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case("WObj"))
        .and_then(|(_, v)| *v)
        .map(|(a, b)| text_of(m, a, b).to_string());
    for (n, role) in targets {
        let Some(&(a, b)) = args.positional.get(n) else {
            skip(skipped, SkipReason::ComputedAtRunTime, stmt_text);
            continue;
        };
        let text = text_of(m, a, b);
        let ev = Evaluator {
            toks,
            envs,
            locals,
            depth: 0,
        }
        .expr(a, b)
        .and_then(as_target);
        let resolved = ev.and_then(|t| match pose_of(&t.frame) {
            Some(pose) => Ok((pose, t.config)),
            None => Err(SkipReason::InvalidTarget),
        });
        match resolved {
            Ok((pose, configuration)) => {
                let name = if toks.get(a).is_some_and(|t| t.k == K::LBrack) {
                    format!("literal@L{line}")
                } else {
                    text.to_string()
                };
                waypoints.push(Waypoint {
                    name,
                    pose,
                    motion: motion.to_string(),
                    role,
                    line,
                    configuration,
                    frame: frame.clone(),
                });
            }
            Err(reason) => skip(skipped, reason, text),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::parse_files;
    use super::*;

    const MODULE: &str = r#"MODULE Demo
    CONST robtarget p10:=[[100,0,50],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget ps{2}:=[[[1,2,3],[1,0,0,0],[0,-1,2,1],[9E9,9E9,9E9,9E9,9E9,9E9]],
                            [[4,5,6],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]];
    CONST num dz:=25;
    PROC main()
        MoveJ p10, v100, z10, tool0;
        MoveL Offs(p10, 0, 0, dz*2), v100, fine, tool0\WObj:=wobj1;
        MoveL RelTool(p10, 10, 0, 0 \Rz:=90), v100, fine, tool0;
        MoveC ps{1}, ps{2}, v100, z10, tool0;
        MoveAbsJ jHome, v100, fine, tool0;
        MoveL CRobT(), v100, fine, tool0;
    ERROR
        MoveL p10, v100, fine, tool0;
    ENDPROC
ENDMODULE
"#;

    #[test]
    fn reads_targets_offsets_reltool_circles_and_skips() {
        let report = parse_files(&[("Demo.mod", MODULE)]).unwrap();
        let r = &report.programs[0].routines[0];
        assert_eq!(r.name, "main");
        let names: Vec<_> = r.waypoints.iter().map(|w| w.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "p10",
                "Offs(p10, 0, 0, dz*2)",
                "RelTool(p10, 10, 0, 0 \\Rz:=90)",
                "ps{1}",
                "ps{2}"
            ]
        );
        let p = |i: usize| r.waypoints[i].pose.position();
        assert!((p(1).z - 100.0).abs() < 1e-12);
        // The target is rotated 180° about y: tool x points along base −x.
        assert!((p(2).x - 90.0).abs() < 1e-9, "{}", p(2));
        assert_eq!(r.waypoints[3].role, Some(CircleRole::Via));
        assert_eq!(r.waypoints[1].frame.as_deref(), Some("wobj1"));
        assert_eq!(
            r.waypoints[3].configuration,
            Some(Configuration::Rapid {
                cf1: 0,
                cf4: -1,
                cf6: 2,
                cfx: 1
            })
        );
        let reasons: Vec<_> = report.skipped.iter().map(|s| s.reason).collect();
        assert_eq!(
            reasons,
            [
                SkipReason::JointMove,
                SkipReason::ComputedAtRunTime,
                SkipReason::InErrorHandler
            ]
        );
    }

    #[test]
    fn resolves_across_modules_and_tracks_assignments() {
        let a = "MODULE A\n PROC r()\n  VAR robtarget t;\n  MoveL pB, v1, z1, tool0;\n  t := Offs(pB,1,0,0);\n  MoveL t, v1, z1, tool0;\n  t := CRobT();\n  MoveL t, v1, z1, tool0;\n ENDPROC\nENDMODULE";
        let b =
            "MODULE B\n PERS robtarget pB:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\nENDMODULE";
        let report = parse_files(&[("A.mod", a), ("B.sys", b)]).unwrap();
        let r = &report.programs[0].routines[0];
        assert_eq!(r.waypoints.len(), 2);
        assert!((r.waypoints[1].pose.position().x - 2.0).abs() < 1e-12);
        assert_eq!(report.skipped[0].reason, SkipReason::ComputedAtRunTime);
        assert_eq!(report.skipped[0].line, 8);
    }

    /// `depth` nested blocks of the given opener/closer around one move pair, in one routine.
    fn nested(depth: usize, open: &str, close: &str) -> String {
        let mut s = String::from(
            "MODULE Deep\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n",
        );
        for _ in 0..depth {
            s.push_str(open);
            s.push('\n');
        }
        s.push_str("MoveL p, v1, z1, tool0;\nMoveL Offs(p,1,0,0), v1, z1, tool0;\n");
        for _ in 0..depth {
            s.push_str(close);
            s.push('\n');
        }
        s.push_str(" ENDPROC\nENDMODULE\n");
        s
    }

    #[test]
    fn blocks_nested_up_to_the_limit_are_read() {
        for (open, close) in [
            ("IF a THEN", "ENDIF"),
            ("WHILE a DO", "ENDWHILE"),
            ("FOR i FROM 1 TO 2 DO", "ENDFOR"),
            ("TEST a CASE 1:", "ENDTEST"),
        ] {
            let text = nested(MAX_BLOCK_NESTING, open, close);
            let report = parse_files(&[("Deep.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
            let r = &report.programs[0].routines[0];
            assert_eq!(r.waypoints.len(), 2, "{open}");
            assert_eq!(r.waypoints[0].line, 4 + MAX_BLOCK_NESTING, "{open}");
        }
    }

    #[test]
    fn blocks_nested_past_the_limit_are_refused_naming_file_line_and_limit() {
        for (open, close) in [
            ("IF a THEN", "ENDIF"),
            ("WHILE a DO", "ENDWHILE"),
            ("TEST a CASE 1:", "ENDTEST"),
        ] {
            let text = nested(MAX_BLOCK_NESTING + 1, open, close);
            let err = parse_files(&[("Deep.mod", &text)]).unwrap_err();
            assert_eq!(
                err,
                ImportError::NestingTooDeep {
                    file: "Deep.mod".into(),
                    // Line 4 holds the first block; the one past the limit is the last opener.
                    line: 4 + MAX_BLOCK_NESTING,
                    column: 1,
                    limit: MAX_BLOCK_NESTING,
                },
                "{open}"
            );
            let message = err.to_string();
            assert!(
                message.starts_with(&format!("Deep.mod:{}:1:", 4 + MAX_BLOCK_NESTING))
                    && message.contains(&MAX_BLOCK_NESTING.to_string()),
                "{message}"
            );
        }
    }

    #[test]
    fn a_huge_nested_file_is_refused() {
        // 40,000 levels (about 0.9 MB): the parse stops at the limit, 256 lines in.
        let text = nested(40_000, "IF a THEN", "ENDIF");
        let err = parse_files(&[("Deep.mod", &text)]).unwrap_err();
        assert!(
            matches!(err, ImportError::NestingTooDeep { line, .. } if line == 4 + MAX_BLOCK_NESTING),
            "{err}"
        );
    }

    #[test]
    fn nesting_counts_open_blocks_not_blocks_seen() {
        // Many blocks one after another, compact IFs and ELSEIF branches do not add up.
        let mut body = String::new();
        for _ in 0..(3 * MAX_BLOCK_NESTING) {
            body.push_str("IF a THEN\n x := 1;\nELSEIF b THEN\n x := 2;\nELSE\n x := 3;\nENDIF\n");
            body.push_str("IF a x := 1;\nWHILE a DO\n x := 1;\nENDWHILE\n");
            body.push_str("TEST a\nCASE 1:\n x := 1;\nDEFAULT:\n x := 2;\nENDTEST\n");
        }
        let text = format!(
            "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n{body}MoveL p, v1, z1, tool0;\nMoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n"
        );
        let report = parse_files(&[("M.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.programs[0].routines[0].waypoints.len(), 2);
        // A routine that leaves blocks open (a missing ENDIF) does not count against the next.
        let open = "IF a THEN\n".repeat(MAX_BLOCK_NESTING - 1);
        let text = format!(
            "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC a()\n{open} ENDPROC\n PROC b()\n{open}MoveL p, v1, z1, tool0;\nMoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n"
        );
        let report = parse_files(&[("M.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.programs[0].routines.len(), 1);
        assert_eq!(report.programs[0].routines[0].name, "b");
    }

    #[test]
    fn a_block_header_ends_at_then_or_where_its_statement_ends() {
        // THEN found: the body follows; no THEN (compact IF): the whole statement is skipped,
        // also when a routine keyword cuts a statement missing its `;`.
        let text = "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC a()\n  IF x MoveL p, v1, z1, tool0;\n  IF (x) THEN MoveL p, v1, z1, tool0; MoveL p, v1, z1, tool0; ENDIF\n  IF x THEN\n ENDPROC\n PROC b()\n  WHILE [x DO;\n  MoveL p, v1, z1, tool0;\n  MoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n";
        let report = parse_files(&[("M.mod", text)]).unwrap_or_else(|e| panic!("{e}"));
        let routines = &report.programs[0].routines;
        let lines: Vec<Vec<usize>> = routines
            .iter()
            .map(|r| r.waypoints.iter().map(|w| w.line).collect())
            .collect();
        assert_eq!(lines, [vec![5, 5], vec![10, 11]]);
    }

    #[test]
    fn malformed_robtarget_is_an_error_with_line_and_column() {
        let text = "MODULE M\n  CONST robtarget p:=[[1,2],[1,0,0,0]];\nENDMODULE";
        let err = parse_files(&[("M.mod", text)]).unwrap_err();
        match err {
            ImportError::Syntax {
                line, column, file, ..
            } => {
                assert_eq!((file.as_str(), line, column), ("M.mod", 2, 22));
            }
            other => panic!("{other:?}"),
        }
        let err = parse_files(&[("M.mod", "MODULE M\nPROC\nENDMODULE")]).unwrap_err();
        assert!(err.to_string().starts_with("M.mod:3:"), "{err}");
    }
}
