//! The followers.
//!
//! **Followers** ([`follow`]). The move into a new slot is new each time, so no context of
//! moves foretells what follows it; but the items before moved alike from the same role (the
//! place 150 mm under the approach, in the tool frame). For the shortest period whose newest
//! [`MIN_FOLLOWS`] or more items did, that move is proposed from the newest waypoint. Slots
//! need not be on a lattice.

use crate::engine::experts::{Candidate, Evidence, LatticeEvidence};
use crate::engine::pose::{Move, Pose};

/// The move that followed the previous waypoint's role in the routine's items (module doc,
/// "Followers"): for the shortest period whose newest [`MIN_FOLLOWS`] items or more moved alike
/// from that role (within `mm` and `rad`, in its tool frame), the newest such move from the
/// newest waypoint, with how many items moved alike (up to 8).
pub fn follow(routine: &[Pose], mm: f64, rad: f64) -> Option<Candidate> {
    let n = routine.len();
    let last = routine.last()?;
    for period in MIN_PERIOD..=MAX_PERIOD {
        let moves: Vec<Move> = (1..)
            .map_while(|k| {
                let to = n.checked_sub(k * period)?;
                let from = to.checked_sub(1)?;
                Some(Move::between(&routine[from], &routine[to]))
            })
            .take(8)
            .collect();
        let Some(newest) = moves.first() else {
            break;
        };
        let alike = moves
            .iter()
            .take_while(|m| {
                let d = m.isometry().inverse() * newest.isometry();
                d.translation.vector.norm() <= mm && d.rotation.angle() <= rad
            })
            .count();
        if alike >= MIN_FOLLOWS {
            return Some(Candidate {
                pose: last.then(newest),
                evidence: Evidence::Lattice(LatticeEvidence::Follower { items: alike }),
            });
        }
    }
    None
}

/// The shortest period of a routine's items the lattice expert and the followers read (every
/// other waypoint).
pub const MIN_PERIOD: usize = 2;
/// The longest (a machine-tending part is 11 waypoints).
pub const MAX_PERIOD: usize = 12;

/// Items that must have moved alike for [`follow`].
pub const MIN_FOLLOWS: usize = 2;

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{Isometry3, Translation3, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A pose at `p`, the tool pointing down.
    pub(crate) fn down_at(p: Vector3<f64>) -> Pose {
        Pose::from_isometry(Isometry3::from_parts(
            Translation3::from(p),
            nalgebra::UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.2),
        ))
    }

    /// The place under a slot's approach: the move into each new slot is new, so no context of
    /// moves foretells it, but the items before moved alike from their approach. Slots need
    /// not be on a lattice; one item before is not enough; random poses follow nothing.
    #[test]
    fn the_place_under_a_new_slot_follows_the_items_before() {
        let (pick, lift, depth) = (
            Vector3::new(600.0, -700.0, 400.0),
            Vector3::new(0.0, 0.0, 100.0),
            Vector3::new(0.0, 0.0, 150.0),
        );
        let slots: Vec<_> = (0..6)
            .map(|i| Vector3::new(900.0 + 170.0 * f64::from(i), 40.0 * f64::from(i * i), 200.0))
            .collect();
        let routine: Vec<Pose> = slots
            .iter()
            .flat_map(|s| [pick + lift, pick, pick + lift, s + depth, *s, s + depth].map(down_at))
            .collect();
        assert!(
            follow(&routine[..10], 1.0, 0.01).is_none(),
            "one item before"
        );
        for k in 2..slots.len() {
            let n = 6 * k + 4;
            let c = follow(&routine[..n], 1.0, 0.01)
                .unwrap_or_else(|| panic!("item {k}: nothing follows"));
            assert_eq!(
                c.evidence,
                Evidence::Lattice(LatticeEvidence::Follower { items: k })
            );
            assert!(c.pose.distance_to(&routine[n]) < 1e-6, "item {k}");
            assert!(c.pose.angle_to(&routine[n]) < 1e-9);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let scattered: Vec<Pose> = (0..60)
            .map(|_| {
                let p = Vector3::new(
                    rng.random_range(0.0..900.0),
                    rng.random_range(0.0..900.0),
                    rng.random_range(0.0..900.0),
                );
                Pose::from_isometry(Isometry3::from_parts(
                    Translation3::from(p),
                    nalgebra::UnitQuaternion::from_euler_angles(
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-1.5..1.5),
                        rng.random_range(-3.0..3.0),
                    ),
                ))
            })
            .collect();
        for n in 1..scattered.len() {
            assert!(follow(&scattered[..n], 1.0, 0.01).is_none(), "after {n}");
        }
    }
}
