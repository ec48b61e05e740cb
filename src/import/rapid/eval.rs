//! Values and the expression evaluator: robtarget aggregates, `Offs`, `RelTool`, constant
//! indices and `num` arithmetic over bound names. Anything else is only known at run time.

use std::collections::HashMap;
use std::rc::Rc;

use nalgebra::{UnitQuaternion, Vector3};

use super::lexer::{K, Tok, arguments, closing, split_top};
use super::structure::ModuleAst;
use crate::import::{Frame, SkipReason, quaternion_wxyz};
use crate::program::{Configuration, RapidConfdata};

/// Deepest expression nesting evaluated; deeper input is treated as computed at run time.
const MAX_DEPTH: usize = 64;

/// A resolved robtarget.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Target {
    pub(super) frame: Frame,
    pub(super) config: Option<Configuration>,
}

/// A value. Aggregates are shared, not copied: every use of a name clones its value, and a
/// robtarget array of n elements used n times (`ps{1}` … `ps{n}`) would otherwise cost n².
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Val {
    Num(f64),
    Agg(Rc<[Val]>),
    Target(Target),
    Str,
}

/// What a name is bound to.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Binding {
    Known(Val),
    /// Declared, but its value is only known at run time.
    RunTime,
}

pub(super) type Eval = Result<Val, SkipReason>;

/// A robtarget from an aggregate `[[x,y,z],[q1..q4],[cf1,cf4,cf6,cfx],...]`; `None` when the
/// shape is wrong, `Some(None)` when the quaternion is not a rotation.
pub(super) fn target_from_agg(items: &[Val]) -> Option<Option<Target>> {
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
    let config = nums(items.get(2), 4).map(|c| {
        Configuration::Rapid(RapidConfdata {
            cf1: c.first().copied().unwrap_or(0.0) as i32,
            cf4: c.get(1).copied().unwrap_or(0.0) as i32,
            cf6: c.get(2).copied().unwrap_or(0.0) as i32,
            cfx: c.get(3).copied().unwrap_or(0.0) as i32,
        })
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

pub(super) fn as_target(v: Val) -> Result<Target, SkipReason> {
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
pub(super) struct Evaluator<'a, 's> {
    pub(super) toks: &'a [Tok<'s>],
    pub(super) envs: &'a [&'a HashMap<String, Binding>],
    pub(super) locals: &'a HashMap<String, Binding>,
    pub(super) depth: usize,
}

impl<'a, 's> Evaluator<'a, 's> {
    pub(super) fn new(
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
    pub(super) fn expr(&mut self, start: usize, end: usize) -> Eval {
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

pub(super) fn num(v: &Val) -> Result<f64, SkipReason> {
    match v {
        Val::Num(x) if x.is_finite() => Ok(*x),
        _ => Err(SkipReason::ComputedAtRunTime),
    }
}

/// `v{idx}` with a 1-based constant index.
pub(super) fn index(v: Val, idx: f64) -> Eval {
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
