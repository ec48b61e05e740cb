//! Nelder–Mead refinement of a base (`argmin`, on its plain `Vec<f64>` backend): the cost is
//! minus the surrogate score on some targets, with the base clamped into the bounds and a
//! penalty for leaving them.

use argmin::core::{CostFunction, Error as ArgminError, Executor, State};
use argmin::solver::neldermead::NelderMead;

use super::Params;
use super::surrogate::{Bounds, Evaluator};
use crate::engine::Pose;

/// A candidate base: its parameters (for distinctness) and its pose.
pub(super) struct Candidate {
    pub(super) params: Params,
    pub(super) base: Pose,
}

impl Candidate {
    pub(super) fn of(eval: &Evaluator, base: &Pose) -> Candidate {
        Candidate {
            params: eval.params_of(base),
            base: *base,
        }
    }
}

/// The Nelder–Mead cost: minus the score on `indices`, the base clamped into the bounds, plus a
/// penalty for leaving them.
struct LayoutCost<'e, 'a> {
    eval: &'e Evaluator<'a>,
    bounds: &'e Bounds,
    indices: &'e [usize],
}

impl CostFunction for LayoutCost<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, p: &Vec<f64>) -> Result<f64, ArgminError> {
        if p.len() != 4 || p.iter().any(|v| !v.is_finite()) {
            return Ok(f64::MAX);
        }
        let params = [p[0], p[1], p[2], p[3]];
        let clamped = self.bounds.clamp(&params);
        let score = self
            .eval
            .score(&self.eval.base_pose(&clamped), self.indices);
        Ok(-score + self.bounds.excess(p))
    }
}

/// Nelder–Mead from `start` for about `evaluations` cost evaluations; the best base found
/// (clamped into the bounds), or `start` when the solver fails.
pub(super) fn nelder_mead(
    eval: &Evaluator,
    bounds: &Bounds,
    indices: &[usize],
    start: &Params,
    evaluations: usize,
) -> Params {
    // The initial simplex: 5 vertices; an iteration costs about 1–2 evaluations (a shrink 5).
    let iters = (evaluations.saturating_sub(5) as f64 / 1.6) as u64;
    if iters == 0 {
        return *start;
    }
    let step = 0.1 * eval.shell.reach_mm;
    let steps = [step, step, step, 0.35];
    let mut simplex = vec![start.to_vec()];
    for (i, s) in steps.iter().enumerate() {
        let mut v = start.to_vec();
        v[i] += s;
        simplex.push(v);
    }
    let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(1e-9) else {
        return *start;
    };
    let problem = LayoutCost {
        eval,
        bounds,
        indices,
    };
    let result = Executor::new(problem, solver)
        .configure(|state| state.max_iters(iters))
        .run();
    match result {
        Ok(r) => match r.state().get_best_param() {
            Some(p) if p.len() == 4 => bounds.clamp(&[p[0], p[1], p[2], p[3]]),
            _ => *start,
        },
        Err(_) => *start,
    }
}
