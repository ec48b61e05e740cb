//! The incremental learner: an observation graph built by similarity-based merging
//! (ALGORITHM §2, dissertation §3.5–3.7, Fig. 3.8).
//!
//! Each node is a multiset of moves summarised by sufficient statistics; each edge counts how
//! often one node's move was followed by another's. A new move joins the node that stays most
//! compact after taking it, or starts a node of its own. Statistics live in whitened space
//! (see [`Metric`]), so a node's *scatter* `μ(V) = Σ ‖z − mean‖²` is the dissertation's
//! `κ − sᵀCs/ξ`, kept here with Welford's update for numerical stability:
//! `μ(V ∪ {z}) = μ(V) + ξ/(ξ+1)·‖z − mean(V)‖²`. Since `ξ/(ξ+1) ≥ ½`, only nodes whose mean lies
//! within `√(2ε)` of `z` can accept it; a k-d tree over node means answers that query, so
//! learning does not slow down linearly with the number of states.
//!
//! Routines are learned one move at a time: [`ObservationGraph::push`] assimilates the next move
//! of the *open* routine and [`ObservationGraph::end_routine`] closes it. The open routine's last
//! node is *pending*: its newest member's successor is not known yet, which is different from
//! the routine having ended there. The HMM view ([`super::hmm`]) keeps the two apart.
//!
//! **Taking moves back.** Undo must leave the graph exactly as a rebuild would. Between
//! [`ObservationGraph::begin_journal`] and [`ObservationGraph::commit`], every push keeps the
//! first pre-image of each node it changes (a node's statistics are not reversible bit for bit),
//! and [`ObservationGraph::rollback`] puts them back, drops the nodes created since and restores
//! the counters: the cost is that of the moves taken back, not of the model's size.

use kiddo::{MutableKdTree, SquaredEuclidean};
use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::engine::config::MergeRule;
use crate::engine::error::ConfigError;
use crate::engine::metric::Metric;
use crate::engine::pose::Observation;

/// Degrees of freedom of an observation.
pub const DIMENSION: usize = 7;

/// `ε = F⁻¹_{χ²(7)}(1 − δ)`: the scatter a node may reach (total, the dissertation's) or gain per
/// move (incremental).
pub fn epsilon_for_delta(delta: f64) -> Result<f64, ConfigError> {
    if !(delta > 0.0 && delta <= 1.0) {
        return Err(ConfigError::Delta(delta));
    }
    if delta == 1.0 {
        return Ok(0.0);
    }
    let chi2 = ChiSquared::new(DIMENSION as f64).map_err(|_| ConfigError::Delta(delta))?;
    Ok(chi2.inverse_cdf(1.0 - delta))
}

/// One state of the graph: a multiset of whitened moves and its outgoing edges.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// ξ: number of moves merged into the node.
    count: u32,
    /// Mean of the whitened moves.
    mean: Observation,
    /// μ: sum of squared whitened distances to the mean.
    scatter: f64,
    /// g: how many routines started with a move in this node.
    initial: u32,
    /// f(i → j) for each successor j, in the order the edges first appeared.
    out: Vec<(u32, u32)>,
    /// Σ_j f(i → j).
    out_total: u32,
    /// Recency-weighted outcome weights, parallel to `out`: at each new outcome (a successor or
    /// the routine's end) the older weights are multiplied by the graph's `recency` λ and the new
    /// outcome gets 1. With λ = 1 they equal the counts.
    weights: Vec<f64>,
    /// Recency-weighted weight of "the routine ended after this move".
    end_weight: f64,
    /// Positions of the node's moves in the graph's trace, oldest first.
    occurrences: Vec<u32>,
}

impl Node {
    fn new(z: &Observation) -> Node {
        Node {
            count: 1,
            mean: *z,
            scatter: 0.0,
            initial: 0,
            out: Vec::new(),
            out_total: 0,
            weights: Vec::new(),
            end_weight: 0.0,
            occurrences: Vec::new(),
        }
    }

    pub fn count(&self) -> u32 {
        self.count
    }

    /// Mean move, whitened.
    pub fn mean(&self) -> &Observation {
        &self.mean
    }

    /// μ(V): sum of squared whitened distances of the members to their mean.
    pub fn scatter(&self) -> f64 {
        self.scatter
    }

    pub fn initial(&self) -> u32 {
        self.initial
    }

    /// Successors with their counts f(i → j).
    pub fn successors(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        self.out.iter().map(|&(j, f)| (j as usize, f))
    }

    pub fn out_total(&self) -> u32 {
        self.out_total
    }

    /// Positions of the node's moves in [`ObservationGraph::trace`], oldest first.
    pub fn occurrences(&self) -> &[u32] {
        &self.occurrences
    }

    /// Scatter increase if `z` joined: `ξ/(ξ+1)·‖z − mean‖²`.
    fn increase(&self, z: &Observation) -> f64 {
        let c = f64::from(self.count);
        c / (c + 1.0) * (z - self.mean).norm_squared()
    }

    fn absorb(&mut self, z: &Observation) {
        let increase = self.increase(z);
        self.count += 1;
        self.mean += (z - self.mean) / f64::from(self.count);
        self.scatter += increase;
    }

    /// Recency-weighted successors: (j, weight) and the end weight.
    pub fn weighted_successors(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.out
            .iter()
            .zip(&self.weights)
            .map(|(&(j, _), &w)| (j as usize, w))
    }

    /// Total recency-weighted outcome mass (successors and end).
    pub fn outcome_weight(&self) -> f64 {
        self.weights.iter().sum::<f64>() + self.end_weight
    }

    fn decay(&mut self, recency: f64) {
        if recency != 1.0 {
            self.weights.iter_mut().for_each(|w| *w *= recency);
            self.end_weight *= recency;
        }
    }

    fn count_edge(&mut self, to: usize, recency: f64) {
        self.decay(recency);
        self.out_total += 1;
        let to = to as u32;
        match self.out.iter().position(|(j, _)| *j == to) {
            Some(k) => {
                self.out[k].1 += 1;
                self.weights[k] += 1.0;
            }
            None => {
                self.out.push((to, 1));
                self.weights.push(1.0);
            }
        }
    }

    fn count_end(&mut self, recency: f64) {
        self.decay(recency);
        self.end_weight += 1.0;
    }
}

/// Size and shape of a learned model.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ModelStats {
    pub states: usize,
    /// Distinct transitions i → j.
    pub edges: usize,
    /// Mean out-degree (edges / states).
    pub perplexity: f64,
    /// Finished routines assimilated.
    pub routines: u32,
    /// Longest routine assimilated, in moves.
    pub depth: usize,
    /// Moves assimilated in all.
    pub observations: u64,
}

/// The open routine: its last node and how many moves it has so far.
#[derive(Debug, Clone, Copy, PartialEq)]
struct OpenRoutine {
    last: usize,
    len: usize,
}

/// The observation graph of one work cell.
#[derive(Debug, Clone)]
pub struct ObservationGraph {
    metric: Metric,
    epsilon: f64,
    merge: MergeRule,
    recency: f64,
    nodes: Vec<Node>,
    /// Node means, contiguous (a scan over them stays in cache; the scale search uses it).
    means: Vec<Observation>,
    index: NodeIndex,
    counts: Counts,
    open: Option<OpenRoutine>,
    /// Nodes of the open routine's moves, in order (what the predictor must not count as
    /// evidence for the routine's own window).
    open_path: Vec<usize>,
    /// Every assimilated move's node in order, [`TRACE_END`] after each finished routine.
    trace: Vec<u32>,
    /// What to restore on [`ObservationGraph::rollback`], while a journal is kept.
    journal: Option<Box<Journal>>,
}

/// The graph as it was when the journal began: its counters, and the first pre-image of every
/// node changed since (nodes created since are dropped instead).
#[derive(Debug, Clone)]
struct Journal {
    nodes: usize,
    counts: Counts,
    open: Option<OpenRoutine>,
    open_path: Vec<usize>,
    trace: usize,
    touched: Vec<(usize, Node)>,
}

/// What the graph has counted since it began (see [`ModelStats`]).
#[derive(Debug, Clone, Copy, Default)]
struct Counts {
    edges: usize,
    routines: u32,
    depth: usize,
    observations: u64,
}

/// Marks the end of a routine in [`ObservationGraph::trace`].
pub const TRACE_END: u32 = u32::MAX;

impl ObservationGraph {
    pub fn new(
        metric: Metric,
        delta: f64,
        merge: MergeRule,
    ) -> Result<ObservationGraph, ConfigError> {
        Ok(ObservationGraph {
            metric,
            epsilon: epsilon_for_delta(delta)?,
            merge,
            recency: 1.0,
            nodes: Vec::new(),
            means: Vec::new(),
            index: NodeIndex::default(),
            counts: Counts::default(),
            open: None,
            open_path: Vec::new(),
            trace: Vec::new(),
            journal: None,
        })
    }

    /// Recency weighting of transitions: λ ∈ (0, 1], 1 = plain counts (the dissertation's).
    pub fn with_recency(mut self, recency: f64) -> Result<ObservationGraph, ConfigError> {
        if !(recency > 0.0 && recency <= 1.0) {
            return Err(ConfigError::Threshold {
                name: "recency",
                value: recency,
            });
        }
        self.recency = recency;
        Ok(self)
    }

    pub fn metric(&self) -> &Metric {
        &self.metric
    }

    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }

    pub fn merge_rule(&self) -> MergeRule {
        self.merge
    }

    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Every node's mean (whitened), indexed like [`Self::nodes`].
    pub fn means(&self) -> &[Observation] {
        &self.means
    }

    /// The pending node: the open routine's latest move, whose successor is not known yet.
    pub fn pending(&self) -> Option<usize> {
        self.open.map(|o| o.last)
    }

    /// The nodes the open routine's moves joined, in order (empty when no routine is open).
    pub fn open_path(&self) -> &[usize] {
        &self.open_path
    }

    /// The node of every assimilated move in the order assimilated, with [`TRACE_END`] after
    /// each finished routine: which context preceded which move, and how recently.
    pub fn trace(&self) -> &[u32] {
        &self.trace
    }

    /// Assimilates the next move of the open routine (opening one if none is open) and returns
    /// the node it joined.
    pub fn push(&mut self, x: &Observation) -> usize {
        let z = self.metric.whiten(x);
        let best = self.best_node(&z);
        self.push_whitened(z, best)
    }

    /// Assimilates the next move of the open routine into the node the caller chose (a learner
    /// with a merge criterion of its own, e.g. the MAP baseline, `map_merge`): node `node` when it
    /// exists, else a new node (whose index is returned). Statistics, edges and the trace are
    /// kept exactly as [`ObservationGraph::push`] keeps them.
    pub fn push_to(&mut self, x: &Observation, node: usize) -> usize {
        let z = self.metric.whiten(x);
        let existing = (node < self.nodes.len()).then_some(node);
        self.push_whitened(z, existing)
    }

    fn push_whitened(&mut self, z: Observation, best: Option<usize>) -> usize {
        if let Some(i) = best {
            self.remember(i);
        }
        if let Some(open) = self.open {
            self.remember(open.last);
        }
        let node = match best {
            Some(i) => {
                self.nodes[i].absorb(&z);
                self.means[i] = self.nodes[i].mean;
                self.index.moved(i, &self.nodes[i].mean);
                i
            }
            None => {
                let i = self.nodes.len();
                self.nodes.push(Node::new(&z));
                self.means.push(z);
                self.index.insert(i, &z);
                i
            }
        };
        match self.open {
            Some(OpenRoutine { last, len }) => {
                let before = self.nodes[last].out.len();
                let recency = self.recency;
                self.nodes[last].count_edge(node, recency);
                self.counts.edges += self.nodes[last].out.len() - before;
                self.open = Some(OpenRoutine {
                    last: node,
                    len: len + 1,
                });
            }
            None => {
                self.nodes[node].initial += 1;
                self.open = Some(OpenRoutine { last: node, len: 1 });
                self.open_path.clear();
            }
        }
        self.open_path.push(node);
        self.nodes[node].occurrences.push(self.trace.len() as u32);
        self.trace.push(node as u32);
        self.counts.observations += 1;
        node
    }

    /// Closes the open routine: its last move now counts as "the routine ended here".
    /// Does nothing when no routine is open (a routine without moves teaches nothing).
    pub fn end_routine(&mut self) {
        self.open_path.clear();
        if let Some(open) = self.open.take() {
            self.remember(open.last);
            let recency = self.recency;
            self.nodes[open.last].count_end(recency);
            self.trace.push(TRACE_END);
            self.counts.routines += 1;
            self.counts.depth = self.counts.depth.max(open.len);
        }
    }

    /// Starts keeping what [`ObservationGraph::rollback`] needs to take back the moves pushed
    /// from now on (a journal already kept goes on from where it began).
    pub fn begin_journal(&mut self) {
        if self.journal.is_none() {
            self.journal = Some(Box::new(Journal {
                nodes: self.nodes.len(),
                counts: self.counts,
                open: self.open,
                open_path: self.open_path.clone(),
                trace: self.trace.len(),
                touched: Vec::new(),
            }));
        }
    }

    /// Keeps what was learned since [`ObservationGraph::begin_journal`] and stops journaling.
    pub fn commit(&mut self) {
        self.journal = None;
    }

    /// Takes the graph back to what it was at [`ObservationGraph::begin_journal`] and stops
    /// journaling (nothing to do without a journal).
    pub fn rollback(&mut self) {
        let Some(j) = self.journal.take() else {
            return;
        };
        for id in (j.nodes..self.nodes.len()).rev() {
            self.index.remove(id);
        }
        self.nodes.truncate(j.nodes);
        self.means.truncate(j.nodes);
        for (i, old) in j.touched.into_iter().rev() {
            if self.means[i] != old.mean {
                self.index.moved(i, &old.mean);
            }
            self.means[i] = old.mean;
            self.nodes[i] = old;
        }
        self.counts = j.counts;
        self.open = j.open;
        self.open_path = j.open_path;
        self.trace.truncate(j.trace);
    }

    /// Keeps node `i`'s pre-image in the journal, the first time it is changed.
    fn remember(&mut self, i: usize) {
        if let Some(j) = self.journal.as_mut()
            && i < j.nodes
            && !j.touched.iter().any(|(k, _)| *k == i)
        {
            j.touched.push((i, self.nodes[i].clone()));
        }
    }

    /// assimilate-task: learns a whole finished routine.
    pub fn assimilate_routine(&mut self, moves: &[Observation]) {
        for x in moves {
            self.push(x);
        }
        self.end_routine();
    }

    /// The node minimising the merge criterion, if that minimum is within ε.
    fn best_node(&self, z: &Observation) -> Option<usize> {
        let mut best: Option<(f64, usize)> = None;
        let mut candidates = Vec::new();
        self.index
            .candidates(z, 2.0 * self.epsilon, &mut candidates);
        for i in candidates {
            let node = &self.nodes[i];
            let criterion = match self.merge {
                MergeRule::Total => node.scatter + node.increase(z),
                MergeRule::Incremental => node.increase(z),
            };
            if criterion <= self.epsilon && best.is_none_or(|(c, j)| (criterion, i) < (c, j)) {
                best = Some((criterion, i));
            }
        }
        best.map(|(_, i)| i)
    }

    /// Nodes whose mean lies within `radius_sq` (squared whitened distance) of `z`, plus nodes
    /// the k-d tree could not hold (the caller filters by exact distance).
    pub fn candidates(&self, z: &Observation, radius_sq: f64, out: &mut Vec<usize>) {
        self.index.candidates(z, radius_sq, out);
    }

    pub fn stats(&self) -> ModelStats {
        let states = self.nodes.len();
        ModelStats {
            states,
            edges: self.counts.edges,
            perplexity: if states == 0 {
                0.0
            } else {
                self.counts.edges as f64 / states as f64
            },
            routines: self.counts.routines,
            depth: self.counts.depth.max(self.open.map_or(0, |o| o.len)),
            observations: self.counts.observations,
        }
    }
}

/// A k-d tree over node means. kiddo's mutable tree cannot split a bucket whose points all share
/// a coordinate on the split axis (common here: many moves have `q_x = 0`); nodes it refuses
/// are kept in a small overflow list that every query returns, so correctness never depends on
/// the tree accepting a point. A mean with a non-finite coordinate (a move between poses near
/// the ends of the floats, which the service refuses where poses enter) is never handed to the
/// tree, whose leaf sort panics on NaN: it goes to the overflow list too, where the exact
/// criterion (NaN or infinite, so never within ε) keeps every move from joining it.
#[derive(Debug, Default)]
struct NodeIndex {
    tree: MutableKdTree<f64, DIMENSION>,
    /// For each node: the point it is stored under in the tree, or None when in `overflow`.
    stored: Vec<Option<[f64; DIMENSION]>>,
    overflow: Vec<usize>,
}

impl Clone for NodeIndex {
    /// kiddo's tree is not `Clone`; rebuild it from the stored points (same contents).
    fn clone(&self) -> NodeIndex {
        let mut tree = MutableKdTree::default();
        let mut stored = self.stored.clone();
        let mut overflow = self.overflow.clone();
        for (id, p) in self.stored.iter().enumerate() {
            if let Some(p) = p
                && tree.add(p, id as u32).is_err()
            {
                stored[id] = None;
                overflow.push(id);
            }
        }
        NodeIndex {
            tree,
            stored,
            overflow,
        }
    }
}

impl NodeIndex {
    fn insert(&mut self, id: usize, z: &Observation) {
        let p: [f64; DIMENSION] = (*z).into();
        if self.stored.len() <= id {
            self.stored.resize(id + 1, None);
        }
        let finite = p.iter().all(|v| v.is_finite());
        if finite && self.tree.add(&p, id as u32).is_ok() {
            self.stored[id] = Some(p);
        } else {
            self.stored[id] = None;
            if !self.overflow.contains(&id) {
                self.overflow.push(id);
            }
        }
    }

    /// Drops node `id` from the index (the newest nodes, on rollback).
    fn remove(&mut self, id: usize) {
        if let Some(p) = self.stored.get(id).copied().flatten() {
            self.tree.remove(&p, id as u32);
        }
        self.overflow.retain(|k| *k != id);
        self.stored.truncate(id);
    }

    fn moved(&mut self, id: usize, new: &Observation) {
        if let Some(p) = self.stored.get(id).copied().flatten() {
            self.tree.remove(&p, id as u32);
            self.insert(id, new);
        }
        // Overflow nodes are returned by every query; nothing to update.
    }

    fn candidates(&self, z: &Observation, radius_sq: f64, out: &mut Vec<usize>) {
        out.clear();
        let q: [f64; DIMENSION] = (*z).into();
        // A non-finite move is within no node's reach: only the overflow list is returned.
        if q.iter().all(|v| v.is_finite()) && radius_sq.is_finite() {
            self.tree
                .query(&q)
                .within::<SquaredEuclidean<f64>>(radius_sq)
                .unsorted()
                .visit(|n| out.push(n.item as usize));
        }
        out.extend_from_slice(&self.overflow);
        // In node order: the tree's layout (which depends on how it was built, e.g. after a
        // rollback) must not change what a caller computes from the candidates.
        out.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    fn graph(delta: f64, merge: MergeRule) -> ObservationGraph {
        ObservationGraph::new(Metric::diagonal(1.0, 0.01).unwrap(), delta, merge).unwrap()
    }

    fn obs(t: [f64; 3]) -> Observation {
        Observation::from([t[0], t[1], t[2], 1.0, 0.0, 0.0, 0.0])
    }

    #[test]
    fn epsilon_is_the_chi_square_quantile() {
        assert!((epsilon_for_delta(0.7).unwrap() - 4.671330).abs() < 1e-5);
        assert_eq!(epsilon_for_delta(1.0).unwrap(), 0.0);
        assert!(epsilon_for_delta(0.0).is_err());
        assert!(epsilon_for_delta(f64::NAN).is_err());
        // Looser merging for small δ.
        assert!(epsilon_for_delta(0.1).unwrap() > epsilon_for_delta(0.9).unwrap());
    }

    #[test]
    fn repeated_routine_reuses_states_and_counts_edges() {
        let mut g = graph(0.7, MergeRule::Total);
        let routine = [
            obs([10.0, 0.0, 0.0]),
            obs([0.0, 10.0, 0.0]),
            obs([-10.0, 0.0, 0.0]),
        ];
        g.assimilate_routine(&routine);
        g.assimilate_routine(&routine);
        let s = g.stats();
        assert_eq!(
            (s.states, s.edges, s.routines, s.depth, s.observations),
            (3, 2, 2, 3, 6)
        );
        assert_eq!(g.nodes()[0].initial(), 2);
        assert_eq!(g.nodes()[0].successors().collect::<Vec<_>>(), vec![(1, 2)]);
        assert_eq!(g.nodes()[2].out_total(), 0);
        assert!((s.perplexity - 2.0 / 3.0).abs() < 1e-12);
    }

    fn same_graph(a: &ObservationGraph, b: &ObservationGraph) {
        assert_eq!(a.nodes(), b.nodes());
        assert_eq!(a.means(), b.means());
        assert_eq!(a.stats(), b.stats());
        assert_eq!(a.trace(), b.trace());
        assert_eq!(a.pending(), b.pending());
        assert_eq!(a.open_path(), b.open_path());
        for (i, z) in a.means().iter().enumerate() {
            let (mut ca, mut cb) = (Vec::new(), Vec::new());
            a.candidates(z, 4.0, &mut ca);
            b.candidates(z, 4.0, &mut cb);
            assert_eq!(ca, cb, "node {i}");
        }
    }

    /// A rollback leaves the graph exactly as it was when the journal began, whether the moves
    /// since joined existing nodes (changing their means, edges and recency weights) or made new
    /// ones, and whether a routine was open at the start; a commit keeps what was learned.
    #[test]
    fn rollback_restores_the_graph_the_journal_began_with() {
        let mut rng = StdRng::seed_from_u64(7);
        let mut random = |g: &mut ObservationGraph, n: usize| {
            for _ in 0..n {
                // A few distinct moves, jittered: some merge, some start nodes.
                let k = f64::from(rng.random_range(0..6u8)) * 10.0;
                g.push(&obs([k + rng.random_range(-0.3..0.3), k, 0.0]));
            }
        };
        let mut g = graph(0.7, MergeRule::Incremental)
            .with_recency(0.9)
            .unwrap();
        for _ in 0..20 {
            random(&mut g, 8);
            g.end_routine();
        }
        random(&mut g, 3);
        let before = g.clone();
        g.begin_journal();
        random(&mut g, 6);
        g.push(&obs([500.0, 500.0, 0.0]));
        random(&mut g, 6);
        assert!(g.stats().states > before.stats().states);
        g.rollback();
        same_graph(&g, &before);
        // Rolled back again without a journal: nothing changes.
        g.rollback();
        same_graph(&g, &before);
        g.begin_journal();
        random(&mut g, 5);
        let learned = g.clone();
        g.commit();
        g.rollback();
        same_graph(&g, &learned);
    }

    #[test]
    fn pending_node_is_the_open_routines_last() {
        let mut g = graph(0.7, MergeRule::Incremental);
        assert_eq!(g.pending(), None);
        let a = g.push(&obs([5.0, 0.0, 0.0]));
        assert_eq!(g.pending(), Some(a));
        let b = g.push(&obs([0.0, 5.0, 0.0]));
        assert_eq!(g.pending(), Some(b));
        g.end_routine();
        assert_eq!(g.pending(), None);
        assert_eq!(g.stats().routines, 1);
        g.end_routine();
        assert_eq!(g.stats().routines, 1, "closing nothing counts nothing");
    }

    /// Every node of a learned graph keeps the compactness its merge rule promises:
    /// total scatter ≤ ε (total, the dissertation's), or ≤ (ξ − 1)·ε when each merge adds at most ε
    /// (incremental).
    #[test]
    fn learned_graphs_are_epsilon_compact() {
        for seed in 0..20u64 {
            let mut rng = StdRng::seed_from_u64(seed);
            for merge in [MergeRule::Total, MergeRule::Incremental] {
                let delta = rng.random_range(0.05..0.95);
                let mut g = graph(delta, merge);
                // Clustered data so that merges happen; some duplicates to stress the k-d tree.
                let centres: Vec<Observation> = (0..8)
                    .map(|_| {
                        obs([
                            rng.random_range(-50.0..50.0),
                            rng.random_range(-50.0..50.0),
                            0.0,
                        ])
                    })
                    .collect();
                for _ in 0..10 {
                    let moves: Vec<Observation> = (0..30)
                        .map(|_| {
                            let c = centres[rng.random_range(0..centres.len())];
                            let mut x = c;
                            for k in 0..3 {
                                x[k] += rng.random_range(-1.5..1.5);
                            }
                            x
                        })
                        .collect();
                    g.assimilate_routine(&moves);
                }
                let eps = g.epsilon();
                for (i, n) in g.nodes().iter().enumerate() {
                    let bound = match merge {
                        MergeRule::Total => eps,
                        MergeRule::Incremental => f64::from(n.count() - 1) * eps,
                    };
                    assert!(
                        n.scatter() <= bound + 1e-9,
                        "seed {seed} {merge:?} node {i}: {} > {bound}",
                        n.scatter()
                    );
                }
                assert_eq!(g.stats().observations, 300);
            }
        }
    }

    /// The k-d tree's candidate search must find exactly what a linear scan would.
    #[test]
    fn index_finds_the_same_best_node_as_a_linear_scan() {
        let mut rng = StdRng::seed_from_u64(7);
        let mut g = graph(0.5, MergeRule::Incremental);
        for _ in 0..2000 {
            // Many moves share coordinates exactly (axis-aligned, no rotation).
            let axis = rng.random_range(0..3);
            let mut t = [0.0; 3];
            t[axis] = f64::from(rng.random_range(-20..20)) * 2.5;
            let x = obs(t);
            let z = g.metric().whiten(&x);
            let linear = g
                .nodes()
                .iter()
                .enumerate()
                .map(|(i, n)| (n.increase(&z), i))
                .filter(|(c, _)| *c <= g.epsilon())
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map(|(_, i)| i);
            assert_eq!(g.best_node(&z), linear);
            g.push(&x);
        }
    }
}
