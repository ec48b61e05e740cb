//! The dissertation's comparison learner: Stolcke and Omohundro's best-first MAP state merging
//! (dissertation §3.9, Theorem 3.9, Eq. 3.3–3.6; proofs A.1.7 and A.2.1; compared in §4.4.1).
//!
//! **Why it is here.** The dissertation argues that its similarity merge (Learn-HMM,
//! [`crate::engine::cdhmm::learner`]) beats MAP structure estimation on teach-pendant data, and
//! reports the MAP learner's models and errors (Figure 4.14). This module is that learner, so the
//! replay scoreboard can measure the claim on our corpus; nothing but the replay uses it, so it
//! lives with the replay's methods. It builds the same [`ObservationGraph`] the engine predicts
//! from (through [`ObservationGraph::push_to`]), so prediction is the engine's own; only the
//! structure differs.
//!
//! **The algorithm.** Each finished routine's moves (SRHCT observations, as the engine learns
//! them) become new states chained in order: one state per observation, which is the Viterbi
//! assignment of the routine to a model that has not merged it yet. Then, best first, the pair of
//! states whose merge raises the log posterior most (Eq. 3.6) is merged, while that gain is
//! positive. States merged for earlier routines stay merged, and every observation keeps the
//! state the merges gave it (the Viterbi assignment is not recomputed: Stolcke and Omohundro's
//! incremental "Viterbi merging").
//!
//! **How each term is read.** States are constant-variance Gaussians `N(μ_i, C⁻¹)` with the
//! engine's precision matrix `C` ([`Metric`]); statistics are kept in whitened space, where `C`
//! is the identity. For a merge of `i` and `j` into `k`:
//!
//! - *Observations* (Eq. 3.3's μ terms; A.1.7, Eq. A.3): `−½ (μ(V_k) − μ(V_i) − μ(V_j))
//!   = −½ ξ_i ξ_j / (ξ_i + ξ_j) · ‖mean_i − mean_j‖²_C`. Eq. 3.3 as printed has the opposite sign
//!   and no ½; A.1.7 derives the ½ and the sign (a merge can only lose observation likelihood),
//!   and its last line drops the square of the norm. We follow the derivation.
//! - *Transitions* (Eq. 3.3's two sums; A.1.7's inbound and outbound ratios), with `a(l|i) =
//!   f(i→l)/ξ_i` as the engine's HMM reads the graph ([`crate::engine::hmm`]). We compute the exact
//!   difference of the Viterbi path's log transition probabilities rather than the printed sums:
//!   inbound from every other state `l`, `f_li log((f_li+f_lj)/f_li) + f_lj log((f_li+f_lj)/f_lj)`
//!   (as printed); outbound, the merged state's row against the two rows, which is the printed
//!   outbound sum when `i` and `j` have no edges between them, and also handles those (the
//!   printed sums, taken over all `l` including `i` and `j`, would count `i → j` twice).
//!   Two pseudo-states complete the path of A.1.7's definition: the start (`P(c_0 = q_i) =
//!   g_i / M`, an inbound term like the others) and the routine's end (the share of a state's
//!   moves after which the routine ended, an outbound outcome like a successor, as
//!   [`crate::engine::hmm`] keeps it). The printed Eq. 3.3 leaves both out.
//! - *Prior* (Eq. 3.4–3.5; A.2.1: the description length `ℓ(q_i) = log|Var(x|q_i)| +
//!   |E_{q_i}| log|Q|`): `|E| log|Q| − |Ẽ| log(|Q| − 1)` with `|E|` the distinct transitions
//!   `i → j` (what [`ModelStats::edges`] counts; start and end are not edges), plus the variance
//!   term. With constant-variance states every `|Var(x|q)|` is `|C⁻¹|`, so the product of
//!   Eq. 3.4 loses one factor `|C⁻¹|⁻¹` per merge: the log ratio gains `log|C⁻¹|`. That is
//!   Eq. 3.5's odd `+|Var(x)|` (a log dropped, `Var(x)` the shared state variance). It is the
//!   same for every pair, so it only moves the stopping point, and its value depends on the
//!   units the variance is written in. We measure it in the units the likelihood is measured in,
//!   whitened, where `C⁻¹ = I` and the term is 0 ([`VarianceTerm::Whitened`], the default).
//!   Read in the engine's raw units (mm and quaternion components, σ_t = 1 mm, σ_q = 0.01) it is
//!   `4 log 10⁻⁴ ≈ −36.8` nats per merge ([`VarianceTerm::Raw`]), and then nothing ever merges:
//!   every model starts from singleton states, and a merge of two singletons gains at most
//!   `4 log 2 + 1 + 2 log(|Q| − 1)` nats (start and one shared source pooled, at most two edges
//!   saved; pooling rows or observations never gains), less than 36.8 below `|Q| ≈ 10⁷`. The
//!   dissertation's MAP models (≈ 249 states against Learn-HMM's ≈ 199) merged most observations,
//!   so that cannot be what it ran. Taken literally (a determinant, no log) the term is `10⁻¹⁶` in
//!   raw units or 1 whitened: negligible either way.
//!
//! **Making it fast.** The prior's pair-independent part `|E| log(|Q|/(|Q|−1))` and the
//! per-saved-edge weight `log(|Q| − 1)` change with every merge, but a pair's own part (its
//! likelihood ratio and the number of edges it saves) only changes when the pair's states or
//! their neighbours change. Pairs are kept in max-heaps by likelihood ratio, one heap per number
//! of saved edges, so the best pair under the current `|Q|` and `|E|` is the best of the heaps'
//! tops; an entry is stale (skipped) once either state was merged or a neighbour of it was. After
//! a merge only the merged state's and its neighbours' pairs are recomputed. Only pairs whose
//! means lie within [`MapSettings::pair_radius`] (Mahalanobis, σ units; default
//! [`DEFAULT_PAIR_RADIUS`]) are candidates: a merge of states that far apart costs at least
//! `r²/4` nats of observation likelihood (100 at the default), several times what the structure
//! terms can give back to singleton states. The unit tests check that the restriction leaves a
//! learned model unchanged; `pair_radius: None` considers every pair.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use crate::engine::cdhmm::learner::{ModelStats, ObservationGraph};
use crate::engine::config::MergeRule;
use crate::engine::metric::Metric;
use crate::engine::{ConfigError, Observation};

/// Candidate pairs' largest Mahalanobis distance between means, σ units (see the module docs).
pub const DEFAULT_PAIR_RADIUS: f64 = 20.0;

/// How Eq. 3.5's variance term `+|Var(x)|` is measured (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VarianceTerm {
    /// `log|C⁻¹|` in whitened units: 0.
    #[default]
    Whitened,
    /// `log|C⁻¹|` in the engine's raw units (mm, quaternion components).
    Raw,
}

/// Settings of the MAP learner beyond the engine's metric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSettings {
    /// Only pairs whose means are at most this far apart (Mahalanobis, σ units) are candidates;
    /// `None`: every pair.
    pub pair_radius: Option<f64>,
    pub variance: VarianceTerm,
}

impl Default for MapSettings {
    fn default() -> MapSettings {
        MapSettings {
            pair_radius: Some(DEFAULT_PAIR_RADIUS),
            variance: VarianceTerm::Whitened,
        }
    }
}

/// A pair's part of the log-posterior gain of a merge: what depends on the two states and their
/// neighbours only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairGain {
    /// Log conditional-likelihood ratio (Eq. 3.3 as read in the module docs), nats.
    pub likelihood: f64,
    /// Distinct transitions the merge removes (`|E| − |Ẽ|`).
    pub saved_edges: usize,
}

impl PairGain {
    /// Eq. 3.6: the likelihood ratio plus Eq. 3.5's prior ratio, for a model of `states` states
    /// and `edges` edges before the merge, with the variance term `variance` (nats).
    pub fn log_posterior(&self, states: usize, edges: usize, variance: f64) -> f64 {
        if states < 2 {
            return f64::NEG_INFINITY;
        }
        let (q, e) = (states as f64, edges as f64);
        let e_after = e - self.saved_edges as f64;
        self.likelihood + e * q.ln() - e_after * (q - 1.0).ln() + variance
    }
}

/// One state of the MAP model: its observations' statistics (whitened) and its transitions.
#[derive(Debug, Clone, Default)]
struct State {
    alive: bool,
    /// Bumped whenever the state or a neighbour changes; heap entries of older versions are stale.
    version: u32,
    /// ξ
    count: u32,
    mean: Observation,
    /// μ(V): sum of squared whitened distances to the mean.
    scatter: f64,
    /// g: routines that started here.
    initial: u32,
    /// Routines that ended after a move of this state.
    end: u32,
    /// (successor, f(i → j)).
    out: Vec<(u32, u32)>,
    /// (predecessor, f(l → i)).
    inc: Vec<(u32, u32)>,
}

/// A candidate merge in a heap: ordered by likelihood ratio, ties by the lower pair.
#[derive(Debug, Clone, Copy)]
struct Entry {
    likelihood: f64,
    a: u32,
    b: u32,
    version_a: u32,
    version_b: u32,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Entry) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Entry {}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Entry) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Entry {
    fn cmp(&self, other: &Entry) -> Ordering {
        self.likelihood
            .total_cmp(&other.likelihood)
            .then_with(|| (other.a, other.b).cmp(&(self.a, self.b)))
    }
}

/// The best-first MAP learner of one program (or work cell).
#[derive(Debug, Clone)]
pub struct MapLearner {
    metric: Metric,
    settings: MapSettings,
    /// Eq. 3.5's variance term, nats per merge.
    variance: f64,
    /// States indexed by the observation that created them (observations numbered in the order
    /// learned); merged-away states are dead.
    states: Vec<State>,
    /// Union-find over observations: the state each one was merged into.
    parent: Vec<u32>,
    /// The finished routines' raw moves, to build the graph from.
    routines: Vec<Vec<Observation>>,
    alive: usize,
    edges: usize,
    merges: u64,
    /// Candidate merges by number of saved edges.
    heaps: Vec<BinaryHeap<Entry>>,
    empty: ObservationGraph,
    graph: ObservationGraph,
}

impl MapLearner {
    /// A learner with the engine's metric; `delta` only fills the graph's (unused) ε.
    pub fn new(
        metric: Metric,
        delta: f64,
        settings: MapSettings,
    ) -> Result<MapLearner, ConfigError> {
        if let Some(r) = settings.pair_radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(ConfigError::Threshold {
                name: "map.pair_radius",
                value: r,
            });
        }
        let variance = match settings.variance {
            VarianceTerm::Whitened => 0.0,
            VarianceTerm::Raw => -metric.precision().determinant().ln(),
        };
        let empty = ObservationGraph::new(metric.clone(), delta, MergeRule::Total)?;
        Ok(MapLearner {
            metric,
            settings,
            variance,
            states: Vec::new(),
            parent: Vec::new(),
            routines: Vec::new(),
            alive: 0,
            edges: 0,
            merges: 0,
            heaps: Vec::new(),
            graph: empty.clone(),
            empty,
        })
    }

    /// The learned model as the engine's graph (what prediction reads).
    pub fn graph(&self) -> &ObservationGraph {
        &self.graph
    }

    pub fn stats(&self) -> ModelStats {
        self.graph.stats()
    }

    /// Merges performed so far.
    pub fn merges(&self) -> u64 {
        self.merges
    }

    /// Eq. 3.5's variance term in use, nats per merge.
    pub fn variance_term(&self) -> f64 {
        self.variance
    }

    /// Learns a finished routine: its moves become a chain of new states, then states are merged
    /// best first while the posterior grows. A routine without moves teaches nothing.
    pub fn assimilate_routine(&mut self, moves: &[Observation]) {
        if moves.is_empty() {
            return;
        }
        let first = self.states.len();
        self.add_chain(moves);
        for id in first..self.states.len() {
            self.push_pairs(id, |c| c < id);
        }
        while let Some((a, b)) = self.best_pair() {
            self.merge(a, b);
        }
        self.rebuild_graph();
    }

    /// Adds a routine's moves as a chain of new states (the Viterbi assignment of moves no state
    /// has taken yet), without merging.
    fn add_chain(&mut self, moves: &[Observation]) {
        if moves.is_empty() {
            return;
        }
        let first = self.states.len();
        let last = first + moves.len() - 1;
        for (k, x) in moves.iter().enumerate() {
            let id = first + k;
            let mut s = State {
                alive: true,
                count: 1,
                mean: self.metric.whiten(x),
                ..State::default()
            };
            if id == first {
                s.initial = 1;
            } else {
                s.inc.push(((id - 1) as u32, 1));
            }
            if id == last {
                s.end = 1;
            } else {
                s.out.push(((id + 1) as u32, 1));
            }
            self.states.push(s);
            self.parent.push(id as u32);
        }
        self.alive += moves.len();
        self.edges += moves.len() - 1;
        self.routines.push(moves.to_vec());
    }

    /// The pair part of the log-posterior gain of merging states `a` and `b` (both alive).
    fn pair_gain(&self, a: usize, b: usize) -> PairGain {
        let (sa, sb) = (&self.states[a], &self.states[b]);
        let (na, nb) = (f64::from(sa.count), f64::from(sb.count));
        let observation = -0.5 * na * nb / (na + nb) * (sa.mean - sb.mean).norm_squared();
        let start = pooled(sa.initial, sb.initial);
        let (mut inbound, mut shared_sources) = (0.0, 0);
        for &(l, f) in &sa.inc {
            let l = l as usize;
            if l == a || l == b {
                continue;
            }
            if let Some(g) = count_of(&sb.inc, l) {
                inbound += pooled(f, g);
                shared_sources += 1;
            }
        }
        let merged = combined(&sa.out, &sb.out, b as u32, a as u32);
        let rows = row_log_likelihood(&merged, sa.end + sb.end, sa.count + sb.count)
            - row_log_likelihood(&sa.out, sa.end, sa.count)
            - row_log_likelihood(&sb.out, sb.end, sb.count);
        PairGain {
            likelihood: observation + start + inbound + rows,
            saved_edges: sa.out.len() + sb.out.len() - merged.len() + shared_sources,
        }
    }

    /// Log-posterior gain (Eq. 3.6) of merging `a` and `b` in the current model.
    #[cfg(test)]
    fn log_posterior_gain(&self, a: usize, b: usize) -> f64 {
        self.pair_gain(a, b)
            .log_posterior(self.alive, self.edges, self.variance)
    }

    /// Whether `a` and `b` are close enough to be a candidate pair.
    fn within_radius(&self, a: usize, b: usize) -> bool {
        self.settings
            .pair_radius
            .is_none_or(|r| (self.states[a].mean - self.states[b].mean).norm_squared() <= r * r)
    }

    /// Pushes the candidate pairs of state `n` with every live state `c` that `partner` accepts.
    fn push_pairs(&mut self, n: usize, partner: impl Fn(usize) -> bool) {
        for c in 0..self.states.len() {
            if c == n || !self.states[c].alive || !partner(c) || !self.within_radius(n, c) {
                continue;
            }
            let (a, b) = (n.min(c), n.max(c));
            let gain = self.pair_gain(a, b);
            if self.heaps.len() <= gain.saved_edges {
                self.heaps
                    .resize_with(gain.saved_edges + 1, BinaryHeap::new);
            }
            self.heaps[gain.saved_edges].push(Entry {
                likelihood: gain.likelihood,
                a: a as u32,
                b: b as u32,
                version_a: self.states[a].version,
                version_b: self.states[b].version,
            });
        }
    }

    fn is_current(&self, e: &Entry) -> bool {
        let (a, b) = (&self.states[e.a as usize], &self.states[e.b as usize]);
        a.alive && b.alive && a.version == e.version_a && b.version == e.version_b
    }

    /// The pair with the largest log-posterior gain, taken off its heap, when that gain is > 0.
    fn best_pair(&mut self) -> Option<(usize, usize)> {
        if self.alive < 2 {
            return None;
        }
        let per_saved_edge = ((self.alive - 1) as f64).ln();
        let mut best: Option<(f64, usize)> = None;
        for saved in 0..self.heaps.len() {
            while let Some(top) = self.heaps[saved].peek() {
                if self.is_current(top) {
                    break;
                }
                self.heaps[saved].pop();
            }
            if let Some(top) = self.heaps[saved].peek() {
                let part = top.likelihood + saved as f64 * per_saved_edge;
                if best.is_none_or(|(b, _)| part > b) {
                    best = Some((part, saved));
                }
            }
        }
        let (_, saved) = best?;
        let top = *self.heaps[saved].peek()?;
        let gain = PairGain {
            likelihood: top.likelihood,
            saved_edges: saved,
        };
        if gain.log_posterior(self.alive, self.edges, self.variance) <= 0.0 {
            return None;
        }
        self.heaps[saved].pop();
        Some((top.a as usize, top.b as usize))
    }

    /// Merges state `b` into state `a`, then renews the candidate pairs around the merged state.
    fn merge(&mut self, a: usize, b: usize) {
        let saved = self.pair_gain(a, b).saved_edges;
        let sb = std::mem::take(&mut self.states[b]);
        let (a32, b32) = (a as u32, b as u32);
        for &(l, _) in &sb.inc {
            if l != a32 && l != b32 {
                rename(&mut self.states[l as usize].out, b32, a32);
            }
        }
        for &(t, _) in &sb.out {
            if t != a32 && t != b32 {
                rename(&mut self.states[t as usize].inc, b32, a32);
            }
        }
        let sa = &mut self.states[a];
        sa.out = combined(&sa.out, &sb.out, b32, a32);
        sa.inc = combined(&sa.inc, &sb.inc, b32, a32);
        let (na, nb) = (f64::from(sa.count), f64::from(sb.count));
        let d = sb.mean - sa.mean;
        sa.scatter += sb.scatter + na * nb / (na + nb) * d.norm_squared();
        sa.mean += d * (nb / (na + nb));
        sa.count += sb.count;
        sa.initial += sb.initial;
        sa.end += sb.end;
        self.parent[b] = a32;
        self.alive -= 1;
        self.edges -= saved;
        self.merges += 1;

        let mut touched: Vec<usize> = std::iter::once(a)
            .chain(self.states[a].out.iter().map(|&(t, _)| t as usize))
            .chain(self.states[a].inc.iter().map(|&(l, _)| l as usize))
            .collect();
        touched.sort_unstable();
        touched.dedup();
        for &n in &touched {
            self.states[n].version = self.states[n].version.wrapping_add(1);
        }
        for &n in &touched {
            self.push_pairs(n, |_| true);
        }
    }

    /// The state observation `m` belongs to (path-compressing).
    fn find(parent: &mut [u32], m: usize) -> usize {
        let mut root = m;
        while parent[root] as usize != root {
            root = parent[root] as usize;
        }
        let mut at = m;
        while parent[at] as usize != root {
            let next = parent[at] as usize;
            parent[at] = root as u32;
            at = next;
        }
        root
    }

    /// Rebuilds the engine's graph from the routines and the states their moves were merged into.
    fn rebuild_graph(&mut self) {
        let mut graph = self.empty.clone();
        let mut node_of: HashMap<usize, usize> = HashMap::new();
        let mut m = 0;
        for routine in &self.routines {
            for x in routine {
                let state = Self::find(&mut self.parent, m);
                let node = node_of.get(&state).copied().unwrap_or(usize::MAX);
                node_of.insert(state, graph.push_to(x, node));
                m += 1;
            }
            graph.end_routine();
        }
        self.graph = graph;
    }
}

/// `x log((x+y)/x) + y log((x+y)/y)`: the log-likelihood gained by pooling two counts of the same
/// source's outcomes into one (0 when either is 0).
fn pooled(x: u32, y: u32) -> f64 {
    if x == 0 || y == 0 {
        return 0.0;
    }
    let (x, y) = (f64::from(x), f64::from(y));
    x * ((x + y) / x).ln() + y * ((x + y) / y).ln()
}

fn count_of(list: &[(u32, u32)], key: usize) -> Option<u32> {
    list.iter()
        .find(|(k, _)| *k as usize == key)
        .map(|&(_, f)| f)
}

/// `Σ_j f_j log(f_j/ξ) + e log(e/ξ)`: a state's outcomes' log-likelihood under its own estimate.
fn row_log_likelihood(out: &[(u32, u32)], end: u32, count: u32) -> f64 {
    let total = f64::from(count);
    out.iter()
        .map(|&(_, f)| f)
        .chain(std::iter::once(end))
        .filter(|&f| f > 0)
        .map(|f| {
            let f = f64::from(f);
            f * (f / total).ln()
        })
        .sum()
}

/// The union of two adjacency lists with `from` renamed to `to`, counts summed.
fn combined(x: &[(u32, u32)], y: &[(u32, u32)], from: u32, to: u32) -> Vec<(u32, u32)> {
    let mut out: Vec<(u32, u32)> = Vec::with_capacity(x.len() + y.len());
    for &(k, f) in x.iter().chain(y) {
        let k = if k == from { to } else { k };
        match out.iter_mut().find(|(j, _)| *j == k) {
            Some(e) => e.1 += f,
            None => out.push((k, f)),
        }
    }
    out
}

/// Renames `from` to `to` in an adjacency list, summing with an existing `to`.
fn rename(list: &mut Vec<(u32, u32)>, from: u32, to: u32) {
    let Some(i) = list.iter().position(|(k, _)| *k == from) else {
        return;
    };
    let (_, f) = list.remove(i);
    match list.iter_mut().find(|(k, _)| *k == to) {
        Some(e) => e.1 += f,
        None => list.push((to, f)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    fn learner(settings: MapSettings) -> MapLearner {
        MapLearner::new(Metric::diagonal(1.0, 0.01).unwrap(), 0.7, settings).unwrap()
    }

    fn obs(t: [f64; 3]) -> Observation {
        Observation::from([t[0], t[1], t[2], 1.0, 0.0, 0.0, 0.0])
    }

    /// A learner holding `routines` as unmerged chains (no merging yet).
    fn chains(routines: &[Vec<Observation>]) -> MapLearner {
        let mut l = learner(MapSettings::default());
        for r in routines {
            l.add_chain(r);
        }
        l.rebuild_graph();
        check_invariants(&mut l);
        l
    }

    /// The model's invariants: every state's outcomes are its moves, in- and out-lists mirror
    /// each other, and the edge count is the number of distinct transitions.
    fn check_invariants(l: &mut MapLearner) {
        l.rebuild_graph();
        let mut edges = 0;
        let mut alive = 0;
        for (i, s) in l.states.iter().enumerate() {
            if !s.alive {
                continue;
            }
            alive += 1;
            edges += s.out.len();
            let out: u32 = s.out.iter().map(|e| e.1).sum();
            assert_eq!(out + s.end, s.count, "state {i}");
            for &(t, f) in &s.out {
                assert!(l.states[t as usize].alive);
                assert_eq!(count_of(&l.states[t as usize].inc, i), Some(f));
            }
        }
        assert_eq!((alive, edges), (l.alive, l.edges));
        let s = l.stats();
        assert_eq!((s.states, s.edges), (l.alive, l.edges));
    }

    #[test]
    fn merging_identical_states_with_identical_successors_raises_the_posterior() {
        let (a, b, c) = (
            obs([10.0, 0.0, 0.0]),
            obs([0.0, 10.0, 0.0]),
            obs([0.0, 0.0, 10.0]),
        );
        // Two copies of a → b → c: states 0–2 and 3–5.
        let l = chains(&[vec![a, b, c], vec![a, b, c]]);
        // The last states: same mean, both end their routine, same predecessor structure.
        let gain = l.pair_gain(2, 5);
        assert_eq!(gain.likelihood, 0.0);
        assert!(l.log_posterior_gain(2, 5) > 0.0);
        // Once the ends are merged, the middle states share their successor: an edge saved.
        let mut l = l;
        l.merge(2, 5);
        check_invariants(&mut l);
        let g = l.pair_gain(1, 4);
        assert_eq!(g.saved_edges, 1);
        assert!(l.log_posterior_gain(1, 4) > 0.0);
    }

    #[test]
    fn merging_far_apart_states_lowers_the_posterior() {
        let (a, b) = (obs([10.0, 0.0, 0.0]), obs([0.0, 10.0, 0.0]));
        let far = obs([10.0, 30.0, 0.0]);
        let l = chains(&[vec![a, b], vec![far, b]]);
        // 20σ ≈ 28 mm apart: the observation term alone is −½·½·28²·... nats.
        assert!(l.pair_gain(0, 2).likelihood < -100.0);
        assert!(l.log_posterior_gain(0, 2) < 0.0);
        // Nearby states with the same successor and both routine starts do merge.
        let near = obs([10.5, 0.0, 0.0]);
        let l = chains(&[vec![a, b], vec![near, b]]);
        assert!(l.pair_gain(0, 2).likelihood < 0.0);
        assert!(l.log_posterior_gain(0, 2) > 0.0);
    }

    #[test]
    fn observation_term_is_the_scatter_increase_of_the_merge() {
        let (a, b) = (obs([1.0, 0.0, 0.0]), obs([4.0, 0.0, 0.0]));
        let l = chains(&[vec![a], vec![b]]);
        // Both states start and end a routine: pooling the start gives 2 log 2, the rows 0.
        let expected = -0.5 * 0.5 * 9.0 + 2.0 * 2f64.ln();
        assert!((l.pair_gain(0, 1).likelihood - expected).abs() < 1e-12);
    }

    #[test]
    fn best_first_merges_the_pair_with_the_largest_gain() {
        let mut rng = StdRng::seed_from_u64(3);
        let centres: Vec<Observation> = (0..5)
            .map(|k| obs([20.0 * f64::from(k), 0.0, 0.0]))
            .collect();
        let routines: Vec<Vec<Observation>> = (0..3)
            .map(|_| {
                (0..6)
                    .map(|_| {
                        let mut x = centres[rng.random_range(0..centres.len())];
                        x[0] += rng.random_range(-2.0..2.0);
                        x
                    })
                    .collect()
            })
            .collect();
        let mut l = chains(&routines);
        l.settings.pair_radius = None;
        for id in 0..l.states.len() {
            l.push_pairs(id, |c| c < id);
        }
        let mut merged = 0;
        loop {
            // Exhaustive search over live pairs, against the heaps' choice.
            let live: Vec<usize> = (0..l.states.len()).filter(|&i| l.states[i].alive).collect();
            let mut best: Option<(f64, usize, usize)> = None;
            for (k, &a) in live.iter().enumerate() {
                for &b in &live[k + 1..] {
                    let g = l.log_posterior_gain(a, b);
                    if best.is_none_or(|(bg, _, _)| g > bg) {
                        best = Some((g, a, b));
                    }
                }
            }
            let chosen = l.best_pair();
            match best {
                Some((g, a, b)) if g > 0.0 => {
                    let (x, y) = chosen.expect("a pair with positive gain");
                    let got = l.log_posterior_gain(x, y);
                    assert!(
                        (got - g).abs() < 1e-9,
                        "chose ({x},{y}) {got}, best ({a},{b}) {g}"
                    );
                    l.merge(x, y);
                    check_invariants(&mut l);
                    merged += 1;
                }
                _ => {
                    assert_eq!(chosen, None);
                    break;
                }
            }
        }
        assert!(merged > 0);
    }

    #[test]
    fn a_repeated_pattern_is_learned_with_fewer_states_than_observations() {
        let pattern = [
            obs([10.0, 0.0, 0.0]),
            obs([0.0, 10.0, 0.0]),
            obs([-10.0, 0.0, 0.0]),
            obs([0.0, -10.0, 5.0]),
        ];
        let mut l = learner(MapSettings::default());
        for k in 0..5 {
            let moves: Vec<Observation> = pattern
                .iter()
                .map(|x| {
                    let mut x = *x;
                    x[2] += 0.01 * f64::from(k);
                    x
                })
                .collect();
            l.assimilate_routine(&moves);
            check_invariants(&mut l);
        }
        let s = l.stats();
        assert_eq!(s.observations, 20);
        assert_eq!(s.routines, 5);
        assert_eq!(s.states, 4, "one state per move of the pattern");
        assert_eq!(s.edges, 3);
        // The graph's nodes hold all the observations.
        let counts: u32 = l.graph().nodes().iter().map(|n| n.count()).sum();
        assert_eq!(counts, 20);
    }

    #[test]
    fn the_pair_radius_does_not_change_the_learned_model() {
        for seed in 0..4u64 {
            let mut rng = StdRng::seed_from_u64(seed);
            let centres: Vec<Observation> = (0..6)
                .map(|_| {
                    obs([
                        rng.random_range(-60.0..60.0),
                        rng.random_range(-60.0..60.0),
                        0.0,
                    ])
                })
                .collect();
            let mut near = learner(MapSettings::default());
            let mut all = learner(MapSettings {
                pair_radius: None,
                ..MapSettings::default()
            });
            for _ in 0..6 {
                let moves: Vec<Observation> = (0..8)
                    .map(|_| {
                        let mut x = centres[rng.random_range(0..centres.len())];
                        x[0] += rng.random_range(-1.5..1.5);
                        x[1] += rng.random_range(-1.5..1.5);
                        x
                    })
                    .collect();
                near.assimilate_routine(&moves);
                all.assimilate_routine(&moves);
            }
            check_invariants(&mut near);
            assert_eq!(near.graph().trace(), all.graph().trace(), "seed {seed}");
            assert!(near.stats().states < 48);
        }
    }

    #[test]
    fn the_raw_variance_term_forbids_merging_and_bad_radii_are_refused() {
        let raw = learner(MapSettings {
            variance: VarianceTerm::Raw,
            ..MapSettings::default()
        });
        assert!((raw.variance_term() - 4.0 * 1e-4f64.ln()).abs() < 1e-9);
        assert_eq!(learner(MapSettings::default()).variance_term(), 0.0);
        let mut raw = raw;
        let a = obs([10.0, 0.0, 0.0]);
        raw.assimilate_routine(&[a, a, a]);
        raw.assimilate_routine(&[a, a, a]);
        assert_eq!(raw.stats().states, 6);
        for r in [0.0, -1.0, f64::NAN] {
            assert!(
                MapLearner::new(
                    Metric::diagonal(1.0, 0.01).unwrap(),
                    0.7,
                    MapSettings {
                        pair_radius: Some(r),
                        ..MapSettings::default()
                    }
                )
                .is_err()
            );
        }
    }
}
