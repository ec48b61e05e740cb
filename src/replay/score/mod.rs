//! The figures computed from replayed records: what the scoreboard says about a method, and
//! the bounds and checks that say how to read it.
//!
//! - [`matched`]: a method restricted to its most confident guesses at another's precision
//!   (the best baseline at the engine's precision).
//! - [`metrics`]: the scoreboard line of a method ([`Scores`]) and the statistics behind it.
//! - [`oracle`]: oracle bounds, the share of waypoints some earlier candidate of each kind
//!   would have got right (not methods: they see the answer).
//! - [`reach`]: whether the cell's arm could reach the guesses (kinematics).
//! - [`reliability`]: calibration of `p_useful` (reliability table by decile, ECE) and the
//!   risk–coverage curve of the offer threshold.

pub mod matched;
pub mod metrics;
pub mod oracle;
pub mod reach;
pub mod reliability;

pub use metrics::{Accuracy, Scores};
