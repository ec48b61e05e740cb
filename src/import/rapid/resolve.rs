//! From statements to what the importer keeps: declarations bound to values, assignments
//! tracked in text order, and motion instructions turned into waypoints or skip records.

use std::collections::HashMap;

use super::eval::{Binding, Evaluator, Val, as_target, target_from_agg};
use super::lexer::{K, Tok, arguments};
use super::structure::{ModuleAst, RoutineAst, Stmt, text_of};
use crate::import::{
    CircleRole, ImportError, ReadRoutine, SkipReason, Skipped, WaypointOrigin, excerpt, pose_of,
};
use crate::program::{Motion, Waypoint};

/// What a motion instruction does with its positional arguments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum MotionKind {
    /// The target is positional argument `n`, moved to as `Motion`.
    Target(usize, Motion),
    /// Via point and end point are positional arguments `n` and `n + 1`, moved to as `Motion`.
    Circle(usize, Motion),
    /// A joint-space move: skipped and counted.
    Joint,
}

/// The motion instructions the importer reads, each with the motion class its waypoints get.
/// `TriggJ`, `TriggJIOs` and `SpotJ` (joint moves) and `CapC`, `PaintC` and `SearchC`
/// (circular ones) are classed linear, as the service has stored them since imports began: a
/// change to what an import stores, left for an issue of its own.
pub(super) fn motion_kind(name: &str) -> Option<(&'static str, MotionKind)> {
    use Motion::{Circular as C, Joint as J, Linear as L};
    const TABLE: &[(&str, MotionKind)] = &[
        ("MoveL", MotionKind::Target(0, L)),
        ("MoveJ", MotionKind::Target(0, J)),
        ("MoveC", MotionKind::Circle(0, C)),
        ("MoveLDO", MotionKind::Target(0, L)),
        ("MoveJDO", MotionKind::Target(0, J)),
        ("MoveCDO", MotionKind::Circle(0, C)),
        ("MoveLSync", MotionKind::Target(0, L)),
        ("MoveJSync", MotionKind::Target(0, J)),
        ("MoveCSync", MotionKind::Circle(0, C)),
        ("MoveLGO", MotionKind::Target(0, L)),
        ("MoveJGO", MotionKind::Target(0, J)),
        ("MoveCGO", MotionKind::Circle(0, C)),
        ("MoveLAO", MotionKind::Target(0, L)),
        ("MoveJAO", MotionKind::Target(0, J)),
        ("MoveCAO", MotionKind::Circle(0, C)),
        ("TriggL", MotionKind::Target(0, L)),
        ("TriggJ", MotionKind::Target(0, L)),
        ("TriggC", MotionKind::Circle(0, C)),
        ("TriggLIOs", MotionKind::Target(0, L)),
        ("TriggJIOs", MotionKind::Target(0, L)),
        ("ArcL", MotionKind::Target(0, L)),
        ("ArcLStart", MotionKind::Target(0, L)),
        ("ArcLEnd", MotionKind::Target(0, L)),
        ("ArcC", MotionKind::Circle(0, C)),
        ("ArcCStart", MotionKind::Circle(0, C)),
        ("ArcCEnd", MotionKind::Circle(0, C)),
        ("CapL", MotionKind::Target(0, L)),
        ("CapC", MotionKind::Circle(0, L)),
        ("SpotL", MotionKind::Target(0, L)),
        ("SpotJ", MotionKind::Target(0, L)),
        ("PaintL", MotionKind::Target(0, L)),
        ("PaintC", MotionKind::Circle(0, L)),
        ("SearchL", MotionKind::Target(2, L)),
        ("SearchC", MotionKind::Circle(2, L)),
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

/// Whether a statement is a motion instruction (one [`motion_kind`] knows).
pub(super) fn is_motion(m: &ModuleAst<'_>, st: &Stmt) -> bool {
    m.toks
        .get(st.start)
        .is_some_and(|t| t.k == K::Ident && motion_kind(t.s).is_some())
}

/// A declaration `[CONST|PERS|VAR] type name[{dims}] [:= value]`: its lower-case name and value.
pub(super) fn eval_decl(
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
pub(super) fn check_robtarget_shape(
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

#[allow(clippy::too_many_arguments)]
pub(super) fn routine_stmt(
    m: &ModuleAst<'_>,
    r: &RoutineAst,
    st: &Stmt,
    locals: &mut HashMap<String, Binding>,
    envs: &[&HashMap<String, Binding>],
    routine: &mut ReadRoutine,
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
    let Some((instruction, kind)) = motion_kind(first.s) else {
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
    let (targets, motion): (Vec<(usize, Option<CircleRole>)>, Motion) = match kind {
        MotionKind::Joint => {
            skip(skipped, SkipReason::JointMove, stmt_text);
            return Ok(());
        }
        MotionKind::Target(n, motion) => (vec![(n, None)], motion),
        MotionKind::Circle(n, motion) => (
            vec![(n, Some(CircleRole::Via)), (n + 1, Some(CircleRole::To))],
            motion,
        ),
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
        let resolved = ev.map(|t| (pose_of(&t.frame), t.config));
        match resolved {
            Ok((pose, configuration)) => {
                let name = if toks.get(a).is_some_and(|t| t.k == K::LBrack) {
                    format!("literal@L{line}")
                } else {
                    text.to_string()
                };
                routine.push(
                    Waypoint {
                        name: Some(name),
                        pose,
                        motion: Some(motion),
                        configuration,
                        reachable: None,
                    },
                    WaypointOrigin {
                        line,
                        instruction,
                        role,
                        frame: frame.clone(),
                    },
                );
            }
            Err(reason) => skip(skipped, reason, text),
        }
    }
    Ok(())
}
