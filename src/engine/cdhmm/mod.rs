//! The continuous-density HMM of the dissertation (ALGORITHM §2–4): the engine's model of how a
//! cell's routines go on, learned from every move taught.
//!
//! A taught move first meets the [`learner`], which assimilates it into an observation graph by
//! similarity-based merging: the move joins the node that stays most compact with it, within the
//! merge threshold ε, or starts a node of its own; edges count which node followed which, and
//! the graph records where routines ended. [`hmm`] reads that graph as an HMM without copying
//! it: a state per node, a Gaussian emission at the node's mean, transitions and the end of a
//! routine from the counts. [`predict`] conditions on the last few moves of the routine being
//! taught, proposes the next move and decides, by its gates, whether to offer it.

pub mod hmm;
pub mod learner;
pub mod predict;
