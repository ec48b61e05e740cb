//! The lattice expert: points visited one after another on a row or a grid (the slots of a
//! pallet's layer, a tray, a grid of screws), found from the points themselves, and the next
//! point of the walk (issue 30, item 1); the station a routine's items keep returning to; the
//! move that followed the same role in the items before.
//!
//! - [`walk`]: the lattice walk fitted to taught points ([`LatticeWalk`]), and the layers a
//!   sequence of them is cut into;
//! - [`expert`]: the [`LatticeExpert`], which reads a routine's items as roles of a period and
//!   proposes each role's next point or its station;
//! - [`followers`]: the move that followed the newest waypoint's role in the items before.
//!
//! Its evidence ([`super::LatticeEvidence`]): a walk's next point (its points; a grid or a layer
//! laid like one before, or one row; a new row only the layer's own rows foretell, or the
//! guessed order, is not settled), a station (its visits) or a follower (the items that moved
//! alike); each long from four. The calibration starts each class from its counts on the
//! pattern tuning set (`calibration::LATTICE_PRIOR`) and learns the cell's own outcomes.
//!
//! Pure: no I/O; the expert reads the routine being taught and the previous one.

pub mod expert;
pub mod followers;
pub mod walk;

pub use expert::{LatticeExpert, propose};
pub use followers::follow;
pub use walk::{LatticeWalk, Order, WalkTolerance};
