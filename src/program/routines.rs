//! A routine of a program: its waypoints in the order visited.

use crate::engine::Pose;

use super::waypoints::Posed;

/// One routine (RAPID `PROC`, KRL `DEF`, a FANUC TP file, a taught routine): waypoints in the
/// order visited; a waypoint is a [`Pose`] or a [`super::Waypoint`].
#[derive(Debug, Clone, PartialEq)]
pub struct Routine<W = Pose> {
    pub name: String,
    pub waypoints: Vec<W>,
}

impl<W: Posed> Routine<W> {
    /// The poses visited, in order.
    pub fn poses(&self) -> impl Iterator<Item = &Pose> {
        self.waypoints.iter().map(Posed::pose)
    }

    /// The routine with only its poses.
    pub fn to_poses(&self) -> Routine {
        Routine {
            name: self.name.clone(),
            waypoints: self.poses().copied().collect(),
        }
    }
}
