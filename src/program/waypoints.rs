//! A waypoint of a program: the pose visited and what the program says of the move there.

use crate::engine::Pose;

use super::configuration::Configuration;
use super::motion::Motion;

/// One waypoint: where the tool goes (pose in the work frame, mm) and, when known, the target's
/// name, the motion to it, the arm configuration to reach it with and whether the arm reaches
/// it. An imported waypoint has a name and a motion; a taught one what the operator gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Waypoint {
    /// The target as written or taught (`p10`, `Offs(p10,0,0,50)`, `P[3]`, `literal@L12`).
    pub name: Option<String>,
    pub pose: Pose,
    /// `None`: not said (a waypoint taught by its pose alone is moved to linearly).
    pub motion: Option<Motion>,
    /// In the notation of the language it was read from or is to be written in.
    pub configuration: Option<Configuration>,
    /// Whether the arm reaches it (`None`: not checked).
    pub reachable: Option<bool>,
}

impl Waypoint {
    /// A waypoint known by its pose alone.
    pub fn at(pose: Pose) -> Waypoint {
        Waypoint {
            name: None,
            pose,
            motion: None,
            configuration: None,
            reachable: None,
        }
    }
}

/// What every kind of waypoint a program holds has: a pose. A program of poses alone
/// (`Program<Pose>`, what replay and the simulation read) and one of [`Waypoint`]s (what the
/// importer gives and the exporter writes) are the same program type.
pub trait Posed {
    fn pose(&self) -> &Pose;
}

impl Posed for Pose {
    fn pose(&self) -> &Pose {
        self
    }
}

impl Posed for Waypoint {
    fn pose(&self) -> &Pose {
        &self.pose
    }
}
