//! Poses and tolerances: the seven numbers of a pose (an absolute one, or a move relative to the
//! last waypoint) and the two of a tolerance, the same on both sides, one pair of `From` each.

use crate::api::PoseValues;
use crate::engine::Noise;
use crate::engine::Tolerance;

use super::wire::both_ways;

both_ways!(plain PoseValues => Pose { x, y, z, qw, qx, qy, qz });
both_ways!(plain PoseValues => RelativeMove { x, y, z, qw, qx, qy, qz });
both_ways!(plain Noise => Tolerance { mm, rad });
both_ways!(plain Tolerance => Tolerance { mm, rad });
