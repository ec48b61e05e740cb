//! The positions a program names: declarations (`DECL E6POS p={…}`, in the data list or a
//! routine), the elements of declared arrays the data list initialises, and the aggregates
//! `{X …, Y …, …}` they hold.

use std::collections::HashMap;

use super::lexer::{K, Tok};
use crate::import::tokens::Cursor;
use crate::import::{Frame, ImportError, LineIndex, SourceFile, rotation_zyx_deg};
use crate::program::KrlStatusTurn;
use nalgebra::Vector3;

/// A declared or inline position.
#[derive(Debug, Clone)]
pub(super) enum Value {
    /// A complete position, with its Status and Turn when it gives them.
    Cartesian {
        frame: Frame,
        st: KrlStatusTurn,
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

/// `[DECL] [GLOBAL] [CONST] TYPE name = value` for position types; other lines are ignored.
pub(super) fn declaration(
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
pub(super) fn bound_value(
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
pub(super) fn element_key(name: &str, index: &[Tok<'_>]) -> Option<String> {
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
pub(super) fn element(
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
pub(super) fn aggregate(toks: &[Tok<'_>]) -> Option<Value> {
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
            st: KrlStatusTurn {
                status: get("S").map(|v| v as i32),
                turn: get("T").map(|v| v as i32),
            },
        }),
        _ => Some(Value::Partial(values)),
    }
}
