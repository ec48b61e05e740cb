//! A `.src`'s routines (`DEF` … `END`) and their motion instructions (`PTP`, `LIN`, `CIRC`, the
//! spline and `_REL` forms): waypoints, or skip records saying why not.

use std::collections::HashMap;

use super::data::{Value, declaration};
use super::lexer::{K, Line, Tok, lines_of};
use super::targets::{relative_to, target_end, target_value};
use crate::import::tokens::Cursor;
use crate::import::{
    CircleRole, Frame, ImportError, LineIndex, ReadRoutine, SkipReason, Skipped, SourceFile,
    WaypointOrigin, excerpt, pose_of, rotation_zyx_deg,
};
use crate::program::{Configuration, Motion, Waypoint};
use nalgebra::Vector3;

pub(super) fn routines(
    src: &SourceFile<'_>,
    dat: &HashMap<String, Value>,
    skipped: &mut Vec<Skipped>,
) -> Result<Vec<ReadRoutine>, ImportError> {
    let idx = LineIndex::new(src.text);
    let mut out = Vec::new();
    let mut current: Option<(ReadRoutine, HashMap<String, Value>)> = None;
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
                    ReadRoutine::new(name.s.to_string(), src.name, line.no),
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
    routine: &mut ReadRoutine,
    locals: &HashMap<String, Value>,
    dat: &HashMap<String, Value>,
    skipped: &mut Vec<Skipped>,
) {
    let toks = &line.toks;
    let Some(kw) = toks.first().and_then(Tok::word) else {
        return;
    };
    // The instruction (a spline one read as its plain form), its motion class and whether it
    // moves relative to the previous waypoint.
    let (instruction, motion, relative) = match kw.as_str() {
        "PTP" | "SPTP" => ("PTP", Motion::Joint, false),
        "LIN" | "SLIN" => ("LIN", Motion::Linear, false),
        "CIRC" | "SCIRC" => ("CIRC", Motion::Circular, false),
        "PTP_REL" | "SPTP_REL" => ("PTP_REL", Motion::Joint, true),
        "LIN_REL" | "SLIN_REL" => ("LIN_REL", Motion::Linear, true),
        "CIRC_REL" | "SCIRC_REL" => ("CIRC_REL", Motion::Circular, true),
        _ => return,
    };
    let rest = toks.get(1..).unwrap_or(&[]);
    // Targets: names, array elements or aggregates, maybe joined by the geometric operator;
    // separated by a comma for CIRC.
    let mut targets: Vec<&[Tok<'_>]> = Vec::new();
    let mut at = 0;
    while targets.len() < if motion == Motion::Circular { 2 } else { 1 } {
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
    let routine_name = routine.routine.name.clone();
    let skip = |skipped: &mut Vec<Skipped>, reason, text: String| {
        skipped.push(Skipped {
            file: src.name.to_string(),
            line: line.no,
            routine: Some(routine_name.clone()),
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
            Ok(Value::Cartesian { frame, st }) if !relative => Ok((frame, st)),
            Ok(Value::Cartesian { frame: d, .. }) => {
                relative_to(routine.last_pose(), &d, tool_frame)
            }
            Ok(Value::Partial(v)) if relative => {
                let g = |k: &str| v.get(k).copied().unwrap_or(0.0);
                let d = Frame {
                    position: Vector3::new(g("X"), g("Y"), g("Z")),
                    rotation: rotation_zyx_deg(g("A"), g("B"), g("C")),
                };
                relative_to(routine.last_pose(), &d, tool_frame)
            }
            Ok(Value::Partial(_) | Value::Array { .. }) => Err(SkipReason::ComputedAtRunTime),
            Err(e) => Err(e),
        };
        match frame {
            Ok((frame, st)) => routine.push(
                Waypoint {
                    name: Some(text),
                    pose: pose_of(&frame),
                    motion: Some(motion),
                    configuration: (st.status.is_some() || st.turn.is_some())
                        .then_some(Configuration::Krl(st)),
                    reachable: None,
                },
                WaypointOrigin {
                    line: line.no,
                    instruction,
                    role,
                    frame: None,
                },
            ),
            Err(reason) => skip(skipped, reason, text),
        }
    }
}
