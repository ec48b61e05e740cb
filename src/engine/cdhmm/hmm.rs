//! graph-to-HMM: the observation graph read as a continuous-density HMM (ALGORITHM §2).
//!
//! The conversion is a view, not a copy: parameters are derived from the graph's counts when
//! asked for, so the model is usable after every assimilated move at no conversion cost
//! (a dense `|Q|×|Q|` matrix would cost O(|Q|²) per update).
//!
//! - `π_i = g_i / Σ g` (with `M` routines, `Σ g = M` in the dissertation's setting).
//! - `a(j|i) = f(i→j) / ξ'_i`, where `ξ'_i` is ξ_i less the pending move (see [`super::learner`]).
//!   Rows sum to at most 1; the rest is the probability that the routine ends in state i.
//! - `b_i = N(mean_i, C⁻¹)`, the emission the merging criterion implies (Theorem 3.9).

use super::learner::{Node, ObservationGraph};
use crate::engine::pose::Observation;

#[derive(Debug, Clone, Copy)]
pub struct Hmm<'g> {
    graph: &'g ObservationGraph,
    initial_total: f64,
    occupancy_total: f64,
}

impl<'g> Hmm<'g> {
    pub fn new(graph: &'g ObservationGraph) -> Hmm<'g> {
        let (mut initial_total, mut occupancy_total) = (0.0, 0.0);
        for n in graph.nodes() {
            initial_total += f64::from(n.initial());
            occupancy_total += f64::from(n.count());
        }
        Hmm {
            graph,
            initial_total,
            occupancy_total,
        }
    }

    pub fn graph(&self) -> &'g ObservationGraph {
        self.graph
    }

    pub fn states(&self) -> usize {
        self.graph.nodes().len()
    }

    pub fn node(&self, i: usize) -> &'g Node {
        &self.graph.nodes()[i]
    }

    /// π_i: probability that a routine starts in state i.
    pub fn initial(&self, i: usize) -> f64 {
        if self.initial_total > 0.0 {
            f64::from(self.node(i).initial()) / self.initial_total
        } else {
            0.0
        }
    }

    /// ξ_i / Σ ξ: how often state i was seen.
    pub fn occupancy(&self, i: usize) -> f64 {
        if self.occupancy_total > 0.0 {
            f64::from(self.node(i).count()) / self.occupancy_total
        } else {
            0.0
        }
    }

    /// a(j|i) for each successor j of i: the successor's share of the state's known outcomes
    /// (successors and routine ends; the pending move has none yet). With recency λ = 1 this is
    /// `f(i→j) / ξ'_i`; with λ < 1 recent outcomes weigh more.
    pub fn transitions(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + 'g {
        let node = self.node(i);
        let total = node.outcome_weight();
        node.weighted_successors().map(move |(j, w)| (j, w / total))
    }

    /// Σ_j a(j|i): probability that a routine in state i continues (0 when nothing is known).
    pub fn continue_probability(&self, i: usize) -> f64 {
        let node = self.node(i);
        let total = node.outcome_weight();
        if total > 0.0 {
            node.weighted_successors().map(|(_, w)| w).sum::<f64>() / total
        } else {
            0.0
        }
    }

    /// log b_i(z) for a whitened observation z.
    pub fn log_emission(&self, i: usize, z: &Observation) -> f64 {
        self.graph
            .metric()
            .log_density((z - self.node(i).mean()).norm_squared())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::config::MergeRule;
    use crate::engine::metric::Metric;

    fn obs(t: [f64; 3]) -> Observation {
        Observation::from([t[0], t[1], t[2], 1.0, 0.0, 0.0, 0.0])
    }

    #[test]
    fn parameters_follow_the_counts_and_keep_the_end_mass() {
        let mut g =
            ObservationGraph::new(Metric::diagonal(1.0, 0.01).unwrap(), 0.7, MergeRule::Total)
                .unwrap();
        let (a, b, c) = (
            obs([10.0, 0.0, 0.0]),
            obs([0.0, 10.0, 0.0]),
            obs([0.0, 0.0, 10.0]),
        );
        g.assimilate_routine(&[a, b]);
        g.assimilate_routine(&[a, c]);
        g.assimilate_routine(&[a]);
        let h = Hmm::new(&g);
        assert_eq!(h.states(), 3);
        assert!((h.initial(0) - 1.0).abs() < 1e-12);
        let t: Vec<_> = h.transitions(0).collect();
        assert_eq!(t.len(), 2);
        assert!(t.iter().all(|(_, p)| (p - 1.0 / 3.0).abs() < 1e-12));
        // One of three routines ended after `a`.
        assert!((h.continue_probability(0) - 2.0 / 3.0).abs() < 1e-12);
        assert!((h.occupancy(0) - 3.0 / 5.0).abs() < 1e-12);
        assert!(
            h.log_emission(0, &g.metric().whiten(&a)) > h.log_emission(1, &g.metric().whiten(&a))
        );
    }

    #[test]
    fn pending_move_is_neither_continuation_nor_end() {
        let mut g =
            ObservationGraph::new(Metric::diagonal(1.0, 0.01).unwrap(), 0.7, MergeRule::Total)
                .unwrap();
        let (a, b) = (obs([10.0, 0.0, 0.0]), obs([0.0, 10.0, 0.0]));
        g.assimilate_routine(&[a, b]);
        g.push(&a);
        let h = Hmm::new(&g);
        // `a` has two members; one was followed by `b`, the other (pending) is undecided.
        assert!((h.continue_probability(0) - 1.0).abs() < 1e-12);
        g.push(&b);
        g.push(&a);
        g.end_routine();
        let h = Hmm::new(&g);
        assert!((h.continue_probability(0) - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn recency_weights_recent_outcomes_and_one_is_plain_counts() {
        let (a, b, c) = (
            obs([10.0, 0.0, 0.0]),
            obs([0.0, 10.0, 0.0]),
            obs([0.0, 0.0, 10.0]),
        );
        for (lambda, expect_c) in [(1.0, 0.5), (0.25, 1.0 / 1.25)] {
            let mut g =
                ObservationGraph::new(Metric::diagonal(1.0, 0.01).unwrap(), 0.7, MergeRule::Total)
                    .unwrap()
                    .with_recency(lambda)
                    .unwrap();
            g.assimilate_routine(&[a, b, a, c]);
            let h = Hmm::new(&g);
            let to_c = h
                .transitions(0)
                .find(|(j, _)| *j == 2)
                .map(|(_, p)| p)
                .unwrap();
            assert!((to_c - expect_c).abs() < 1e-12, "λ = {lambda}: {to_c}");
        }
        let g = ObservationGraph::new(Metric::diagonal(1.0, 0.01).unwrap(), 0.7, MergeRule::Total)
            .unwrap();
        assert!(g.with_recency(0.0).is_err());
    }
}
