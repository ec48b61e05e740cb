//! The target of a motion: a name, an array element with constant indices, an aggregate, or
//! such operands joined by the geometric operator; and a `_REL` move from the previous waypoint.

use std::collections::HashMap;

use super::data::{Value, aggregate, element_key};
use super::lexer::{K, Tok};
use crate::engine::Pose;
use crate::import::{Frame, SkipReason};
use crate::program::KrlStatusTurn;

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
pub(super) fn target_end(toks: &[Tok<'_>], i: usize) -> Option<usize> {
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
pub(super) fn target_value(
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
        (Value::Cartesian { frame: outer, .. }, Value::Cartesian { frame: inner, st }) => {
            Ok(Value::Cartesian {
                frame: outer.compose(&inner),
                st,
            })
        }
        _ => Err(SkipReason::ComputedAtRunTime),
    }
}

/// A target resolved: its frame, with the Status and Turn it gives.
pub(super) type Resolved = (Frame, KrlStatusTurn);

/// A `_REL` displacement applied to the previous waypoint (in the base or the tool frame).
pub(super) fn relative_to(
    previous: Option<&Pose>,
    d: &Frame,
    tool: bool,
) -> Result<Resolved, SkipReason> {
    let Some(prev) = previous else {
        return Err(SkipReason::ComputedAtRunTime);
    };
    let (p, r) = (prev.position(), prev.rotation());
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
    Ok((
        frame,
        KrlStatusTurn {
            status: None,
            turn: None,
        },
    ))
}
