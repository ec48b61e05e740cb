//! How the arm moves to a waypoint: the motion classes the importers tell apart, the exporter
//! writes and the service stores. Named once (`joint`, `linear`, `circular`): parsed from that
//! name, never re-derived from an instruction's spelling.

use serde::{Deserialize, Serialize};

/// How the arm moves to a waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    /// Joint interpolation (`MoveJ`, `PTP`, `J`).
    Joint,
    /// Linear TCP path (`MoveL`, `LIN`, `L`).
    Linear,
    /// Circular arc: two consecutive circular waypoints are the via point and the end point
    /// (`MoveC`, `CIRC`, `C`).
    Circular,
}

impl Motion {
    pub const ALL: [Motion; 3] = [Motion::Joint, Motion::Linear, Motion::Circular];

    /// The motion's name, as stored and on the wire (`joint`, `linear`, `circular`).
    pub fn as_str(self) -> &'static str {
        match self {
            Motion::Joint => "joint",
            Motion::Linear => "linear",
            Motion::Circular => "circular",
        }
    }

    /// The motion named exactly `name` ([`Motion::as_str`]), if any.
    pub fn parse(name: &str) -> Option<Motion> {
        Motion::ALL.into_iter().find(|m| m.as_str() == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_exactly_and_are_what_serde_writes() {
        for m in Motion::ALL {
            assert_eq!(Motion::parse(m.as_str()), Some(m));
            assert_eq!(serde_json::to_value(m).unwrap(), m.as_str());
        }
        assert_eq!(Motion::parse("Linear"), None);
        assert_eq!(Motion::parse("MoveL"), None);
    }
}
