//! The engine and what drives it, through the crate's public API: the `Teacher` on repeated,
//! moved, rotated and scaled patterns (`teacher`), lead-through teaching (`lead_through`), the
//! simulated operator teaching corpus programs against the real server (`simulate`) and the
//! simulated seed lab (`lab`). One binary, so the whole stack is linked once for all of them.

#[path = "../common/corpus.rs"]
mod corpus;
mod lab;
mod lead_through;
mod patterns;
mod simulate;
mod teacher;
