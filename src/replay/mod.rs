//! Replay recorded programs through the engine and baselines (ALGORITHM §5).
pub mod engine_method;
pub mod method;
