//! The transitions a prediction conditions on: the HMM's, less the current routine's own edges
//! inside the window (within-routine learning, see `teach`).

use crate::engine::cdhmm::hmm::Hmm;

/// The HMM's transitions less the current routine's own edges inside the window.
///
/// With within-routine learning at a lag shorter than the window, the model already holds the
/// window's own path, which is no evidence for the window (it would always match itself): its
/// edges are discounted, and a state made only of window moves explains nothing.
pub(super) struct Transitions<'h, 'g> {
    pub(super) hmm: &'h Hmm<'g>,
    /// The window's own edges (i, j), repeated as often as they occur.
    own: Vec<(usize, usize)>,
    /// The window's own moves' states, repeated as often as they occur.
    own_states: Vec<usize>,
}

impl<'h, 'g> Transitions<'h, 'g> {
    pub(super) fn new(hmm: &'h Hmm<'g>, own: Vec<(usize, usize)>) -> Transitions<'h, 'g> {
        Transitions {
            hmm,
            own,
            own_states: Vec::new(),
        }
    }

    /// For a window of the last `window` of `moves` moves, `path` being the states of the
    /// routine's moves assimilated so far.
    pub(super) fn for_window(
        hmm: &'h Hmm<'g>,
        path: &[usize],
        moves: usize,
        window: usize,
    ) -> Transitions<'h, 'g> {
        let start = moves.saturating_sub(window).min(path.len());
        let inside = &path[start..];
        Transitions {
            hmm,
            own: inside.windows(2).map(|e| (e[0], e[1])).collect(),
            own_states: inside.to_vec(),
        }
    }

    /// Whether every member of state j is one of the window's own moves.
    pub(super) fn self_only(&self, j: usize) -> bool {
        !self.own_states.is_empty()
            && self.own_states.iter().filter(|&&s| s == j).count() as u32
                >= self.hmm.node(j).count()
    }

    /// How many own edges leave `i` (towards `j`, or anywhere with None).
    pub(super) fn own_count(&self, i: usize, j: Option<usize>) -> f64 {
        self.own
            .iter()
            .filter(|&&(a, b)| a == i && j.is_none_or(|j| j == b))
            .count() as f64
    }

    /// Calls `f(j, a(j|i))` for each successor j of i.
    pub(super) fn for_each(&self, i: usize, mut f: impl FnMut(usize, f64)) {
        let own_out = self.own_count(i, None);
        if own_out == 0.0 {
            for (j, a) in self.hmm.transitions(i) {
                f(j, a);
            }
            return;
        }
        let node = self.hmm.node(i);
        let total = node.outcome_weight() - own_out;
        if total <= 1e-9 {
            return;
        }
        for (j, w) in node.weighted_successors() {
            let w = w - self.own_count(i, Some(j));
            if w > 1e-9 {
                f(j, w / total);
            }
        }
    }
}
