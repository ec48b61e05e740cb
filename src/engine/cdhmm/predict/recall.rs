//! Recall: where the window's exact context was seen last in the trace and what followed it
//! (`EngineConfig::recall`). The HMM merges contexts into states, so a next state it leaves
//! ambiguous may still be settled by the most recent occurrence of this context.

use crate::engine::cdhmm::learner::{ObservationGraph, TRACE_END};
use crate::engine::pose::Observation;

/// Most recent occurrences of a node looked at when searching for the window's context.
const RECENT_OCCURRENCES: usize = 256;

/// Where the window's context was seen before and what followed it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Recall {
    /// The node that followed the most recent occurrence.
    pub(super) next: usize,
    /// Mean squared distance of the window to that occurrence's states.
    pub(super) cost: f64,
    /// Occurrences of the context (with a known continuation) found.
    pub(super) seen: usize,
    /// Of those, how many were followed by (a node within one σ of) `next`.
    pub(super) agree: usize,
}

/// The continuation of the most recent place in the trace whose last `k` states fit the
/// window `zs` (whitened, `k` moves) with mean squared distance at most `limit`.
/// Contexts do not cross routine boundaries.
pub(super) fn recall(graph: &ObservationGraph, zs: &[Observation], limit: f64) -> Option<Recall> {
    let trace = graph.trace();
    let nodes = graph.nodes();
    let k = zs.len();
    let last = zs.last()?;
    let budget = limit * k as f64;
    let mut candidates = Vec::new();
    graph.candidates(last, budget, &mut candidates);
    // (position, next, cost) of every matching occurrence
    let mut found: Vec<(usize, usize, f64)> = Vec::new();
    for i in candidates {
        if (last - nodes[i].mean()).norm_squared() > budget {
            continue;
        }
        for &t in nodes[i].occurrences().iter().rev().take(RECENT_OCCURRENCES) {
            let t = t as usize;
            let Some(&next) = trace.get(t + 1) else {
                continue;
            };
            if next == TRACE_END || t + 1 < k {
                continue;
            }
            let context = &trace[t + 1 - k..=t];
            let mut cost = 0.0;
            for (z, &s) in zs.iter().zip(context) {
                if s == TRACE_END {
                    cost = f64::INFINITY;
                    break;
                }
                cost += (z - nodes[s as usize].mean()).norm_squared();
            }
            if cost <= budget {
                found.push((t, next as usize, cost / k as f64));
            }
        }
    }
    let &(_, next, cost) = found.iter().max_by_key(|e| e.0)?;
    let target = nodes[next].mean();
    let agree = found
        .iter()
        .filter(|e| (nodes[e.1].mean() - target).norm_squared() <= 1.0)
        .count();
    Some(Recall {
        next,
        cost,
        seen: found.len(),
        agree,
    })
}
