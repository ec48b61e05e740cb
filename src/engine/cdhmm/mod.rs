//! The continuous-density HMM (placeholder doc, rewritten in the docs step).

pub mod hmm;
pub mod learner;
pub mod predict;
