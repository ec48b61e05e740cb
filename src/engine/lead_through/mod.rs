//! Hand-guided teaching (placeholder doc, rewritten in the docs step).

pub mod lds;
pub mod segment;
