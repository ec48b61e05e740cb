//! The lattice expert.
//!
//! **The expert** ([`propose`]). A palletising routine repeats its moves item by item, and only
//! some of them move with the item: the waypoints of one *role* (the slot's approach, the place,
//! the retract) walk the lattice, the others (the pick station) stay. So for each period `P`
//! from [`MIN_PERIOD`] to [`MAX_PERIOD`] the waypoints `P`, `2P`, … before the next one are
//! read (the newest [`MAX_WALK_POINTS`]): a role whose newest [`MIN_POINTS`] or more are one
//! place is a *station*, proposed again (at its visits' mean); else the role's last layer,
//! when it ends at the newest point, proposes its next point, turned as the waypoint one
//! period back. The shortest period that gives either wins, except that a station of fewer
//! than [`STRONG_STATION`] visits (a machine's back-and-forth inside one item gives three)
//! lets the longer periods propose too: a tending item's tray slots walk beside it. The layer
//! before is the role's own, or (a routine per layer) a layer of the previous routine's roles
//! of the same period. Where the pattern ends: once a layer is complete, nothing of that period
//! or a longer one is proposed, and a station is not proposed once another role of its items
//! has completed its layer (the routine goes on elsewhere); nothing either after a new layer's
//! first point (where its rows go is not known yet), nor for any role of an item one of whose
//! roles has just left its layer for a new one (the place under a new layer's first approach
//! is not the old layer's next place). The first layer's end cannot be known: its new rows are
//! proposed from six points on (two rows of two zigzag in any star), and the cell's outcomes
//! (below) learn how often they hold.

use nalgebra::{Isometry3, Translation3, Vector3};

use super::followers::{MAX_PERIOD, MIN_PERIOD, follow};
use super::walk::{LatticeWalk, MIN_LAYER_POINTS, MIN_POINTS, WalkTolerance};
use crate::engine::experts::frames::Frame;
use crate::engine::experts::{Candidate, Cell, Evidence, Expert, LatticeEvidence};
use crate::engine::pose::Pose;

/// The lattice expert: its walks, stations and followers over the routine being taught, and
/// the last finished routine of two waypoints or more (whose layers a routine per layer is laid
/// like).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LatticeExpert {
    previous: Vec<Pose>,
}

impl LatticeExpert {
    pub fn new() -> LatticeExpert {
        LatticeExpert::default()
    }
}

impl Expert for LatticeExpert {
    fn learn(&mut self, routine: &[Pose]) {
        if routine.len() >= 2 {
            self.previous = routine.to_vec();
        }
    }

    /// The follower first, then the walks' and stations' candidates: moves matched within the
    /// tool frame's widened tolerance, a point against where the walk puts it within the pose
    /// frame's, a step against a step within the work frame's.
    fn propose(&self, routine: &[Pose], cell: &Cell) -> Vec<Candidate> {
        let moves = cell.widened(Frame::Tool);
        let mut out: Vec<Candidate> = follow(routine, moves.mm, moves.rad).into_iter().collect();
        out.extend(propose(
            routine,
            &self.previous,
            WalkTolerance {
                point: cell.widened(Frame::Absolute).mm,
                step: cell.widened(Frame::Work).mm,
            },
        ));
        out
    }
}

/// The newest points of a role read as a walk (a layer of up to 32 slots; bounds the cost).
pub const MAX_WALK_POINTS: usize = 48;

/// The lattice expert's candidates for the waypoint after `routine` (module doc, "The expert"),
/// with steps matched within `tolerance`: the shortest period's, and while that is a station of
/// fewer than [`STRONG_STATION`] visits (what a back-and-forth inside one item gives too), the
/// next period's as well.
pub fn propose(routine: &[Pose], previous: &[Pose], tol: WalkTolerance) -> Vec<Candidate> {
    let mut out = Vec::new();
    let mut from = MIN_PERIOD;
    while let Some((c, period)) = propose_from(routine, previous, tol, from) {
        out.push(c);
        match c.evidence {
            Evidence::Lattice(LatticeEvidence::Station { visits }) if visits < STRONG_STATION => {}
            _ => break,
        }
        from = period + 1;
    }
    out
}

/// Visits from which a station is read as one without looking at longer periods.
pub const STRONG_STATION: usize = 4;

/// The candidate of the shortest period from `from` on that gives one, and that period.
fn propose_from(
    routine: &[Pose],
    previous: &[Pose],
    tol: WalkTolerance,
    from: usize,
) -> Option<(Candidate, usize)> {
    let n = routine.len();
    for period in from..=MAX_PERIOD.min(n) {
        let role = role_points(routine, period, period);
        let last = &routine[n - period];
        let candidate = |position: Vector3<f64>, evidence: LatticeEvidence| Candidate {
            pose: Pose::from_isometry(Isometry3::from_parts(
                Translation3::from(position),
                last.rotation(),
            )),
            evidence: Evidence::Lattice(evidence),
        };
        if let Some(visits) = station(&role, tol.point) {
            // The role stays: the station it keeps returning to — unless a role of the same
            // items has just completed its layer (the pattern is done; the routine goes on
            // elsewhere).
            if (1..period).any(|back| {
                Layer::of(&role_points(routine, period, back), tol, previous, period)
                    .is_some_and(|l| l.complete())
            }) {
                return None;
            }
            // Its visits' mean: a hand-taught station's scatter averages out.
            let mean = role[role.len() - visits..].iter().sum::<Vector3<f64>>() / visits as f64;
            return Some((
                candidate(
                    mean,
                    LatticeEvidence::Station {
                        visits: visits.min(8),
                    },
                ),
                period,
            ));
        }
        let Some(layer) = Layer::of(&role, tol, previous, period) else {
            if Layer::starting(&role, tol) {
                // A layer has just ended and the next has one point: where its rows go is not
                // known yet, and no longer period knows better (its walk would skip items).
                return None;
            }
            continue;
        };
        if layer.complete() {
            // Nothing of this period is proposed, and no longer period either (its walk would
            // skip items).
            return None;
        }
        if (1..period).any(|back| {
            let other = role_points(routine, period, back);
            Layer::of(&other, tol, previous, period).is_none() && Layer::starting(&other, tol)
        }) {
            // A role of the same items has just left its layer for a new one: this item is off
            // this role's walk too (the place under a new layer's first approach).
            return None;
        }
        let walk = &layer.walk;
        if walk.starts_row() && layer.before.is_none() && walk.indices.len() < MIN_LAYER_POINTS {
            // A new row after two rows of two: four points zigzag in any star or weave, not
            // only on a grid.
            return None;
        }
        // A new row that only this layer's own rows foretell, and the second row's way guessed
        // from its first point, are guesses of their own class: the pattern may have ended
        // there, or gone the other way.
        let settled = !((walk.starts_row() || walk.guessed) && layer.before.is_none());
        return Some((
            candidate(
                walk.next(),
                LatticeEvidence::Walk {
                    points: walk.indices.len().min(8),
                    grid: walk.rows.is_some(),
                    settled,
                },
            ),
            period,
        ));
    }
    None
}

/// The positions of one role of a routine's items of `period` waypoints, oldest first: the
/// waypoints `back`, `back + period`, … before the next one (the newest [`MAX_WALK_POINTS`]).
fn role_points(routine: &[Pose], period: usize, back: usize) -> Vec<Vector3<f64>> {
    let n = routine.len();
    let mut role: Vec<Vector3<f64>> = (0..MAX_WALK_POINTS)
        .map_while(|k| n.checked_sub(back + k * period))
        .map(|i| routine[i].position())
        .collect();
    role.reverse();
    role
}

/// The layer a role's newest point is on, and the number of points of the layer before it.
struct Layer {
    walk: LatticeWalk,
    /// Points of the layer before (walked in rows), if there is one.
    before: Option<usize>,
}

impl Layer {
    /// The role's last layer ([`LatticeWalk::layers`]) when it ends at the newest point. The
    /// layer before it is the role's layer before, else the newest layer of the `previous`
    /// routine's roles of the same `period` this one is laid like (a routine per layer).
    fn of(
        points: &[Vector3<f64>],
        tol: WalkTolerance,
        previous: &[Pose],
        period: usize,
    ) -> Option<Layer> {
        let own = Layer::last(points, tol, None);
        if own.as_ref().is_none_or(|l| l.before.is_none()) {
            // A layer of the previous routine this one is laid like (a routine per layer).
            for back in 1..=period.min(previous.len()) {
                let earlier = LatticeWalk::layers(&role_points(previous, period, back), tol, None);
                for (_, e) in earlier.iter().rev().filter(|(_, e)| e.is_a_layer()) {
                    if let Some(laid) = Layer::last(points, tol, Some(e))
                        && laid.before.is_some()
                    {
                        return Some(laid);
                    }
                }
            }
        }
        own
    }

    /// The last of `points`' layers when it ends at the newest point, with the layer before it:
    /// the one before it in `points`, else `earlier` when the first layer was laid like it.
    fn last(
        points: &[Vector3<f64>],
        tol: WalkTolerance,
        earlier: Option<&LatticeWalk>,
    ) -> Option<Layer> {
        let mut layers = LatticeWalk::layers(points, tol, earlier);
        let (start, walk) = layers.pop()?;
        if start + walk.indices.len() != points.len() {
            return None;
        }
        let before = match layers.last() {
            Some((s, w)) if w.is_a_layer() && s + w.indices.len() == start => Some(w.indices.len()),
            Some(_) => None,
            None => earlier
                .filter(|e| {
                    [e.a.norm(), e.b.norm()]
                        .iter()
                        .any(|p| (p - walk.a.norm()).abs() <= tol.step)
                })
                .map(|e| e.indices.len()),
        };
        Some(Layer { walk, before })
    }

    /// Whether the role's newest point follows a layer (of [`MIN_LAYER_POINTS`] or more, in
    /// rows) that ended at the point before it: a new layer's first point.
    fn starting(points: &[Vector3<f64>], tol: WalkTolerance) -> bool {
        let Some(before) = points.len().checked_sub(1) else {
            return false;
        };
        LatticeWalk::layers(&points[..before], tol, None)
            .last()
            .is_some_and(|(s, w)| w.is_a_layer() && s + w.indices.len() == before)
    }

    /// As many points as the layer before: the layer is done.
    fn complete(&self) -> bool {
        self.before.is_some_and(|b| self.walk.indices.len() >= b)
    }
}

/// How many of the newest `points` are one place (within `tol` of the newest), when at least
/// [`MIN_POINTS`] are: the pick station of a pallet, returned to item after item.
fn station(points: &[Vector3<f64>], tol: f64) -> Option<usize> {
    let newest = points.last()?;
    let visits = points
        .iter()
        .rev()
        .take_while(|p| (*p - newest).norm() <= tol)
        .count();
    (visits >= MIN_POINTS).then_some(visits)
}

#[cfg(test)]
mod tests {
    use super::super::followers::tests::down_at;
    use super::super::walk::Order;
    use super::super::walk::tests::walk;
    use super::*;

    /// A candidate's lattice evidence.
    fn lattice(c: &Candidate) -> LatticeEvidence {
        match c.evidence {
            Evidence::Lattice(e) => e,
            other => panic!("not the lattice expert's evidence: {other:?}"),
        }
    }

    /// A walk's evidence as `(grid, settled)`; None for a station or a follower.
    fn walk_class(c: &Candidate) -> Option<(bool, bool)> {
        match lattice(c) {
            LatticeEvidence::Walk { grid, settled, .. } => Some((grid, settled)),
            _ => None,
        }
    }

    fn is_station(c: &Candidate) -> bool {
        matches!(lattice(c), LatticeEvidence::Station { .. })
    }

    /// The expert's first candidate (the shortest period's).
    fn propose1(routine: &[Pose], previous: &[Pose], tol: WalkTolerance) -> Option<Candidate> {
        propose(routine, previous, tol).into_iter().next()
    }

    /// The expert reads the slot's waypoints as walks with the item's period: once the second
    /// row has two items, it proposes every later slot approach, place and retract exactly, as
    /// a grid (two places), and the pick station's approach, pick and retract as a station.
    #[test]
    fn the_expert_proposes_each_waypoint_of_a_pallet() {
        // A 3 × 4 pallet as one routine: per item the pick station's approach, pick and
        // retract, then the slot's approach, place and retract.
        let routine = crate::engine::experts::noise::estimate::tests::pallet();
        let tol = WalkTolerance::from(1.0);
        for n in 30..routine.len() {
            let c = propose1(&routine[..n], &[], tol)
                .unwrap_or_else(|| panic!("nothing proposed for waypoint {n}"));
            assert!(c.pose.distance_to(&routine[n]) < 1e-6, "waypoint {n}");
            assert!(c.pose.angle_to(&routine[n]) < 1e-9);
            let slot_role = n % 6 >= 3;
            if slot_role {
                assert_eq!(walk_class(&c).map(|w| w.0), Some(true), "waypoint {n}");
            } else {
                assert!(is_station(&c), "waypoint {n}");
            }
        }
        // After the first row of three, one place: the row goes on (its end could not be seen
        // coming), 200 mm on from its last slot.
        let c = propose1(&routine[..21], &[], tol).expect("a row of three");
        assert_eq!(walk_class(&c), Some((false, true)));
        let on = routine[15].position() + Vector3::new(200.0, 0.0, 0.0);
        assert!((c.pose.position() - on).norm() < 1e-6);
        // The second row's first slot settles the order: its second is a grid's next point.
        let c = propose1(&routine[..27], &[], tol).expect("the second row's second slot");
        assert!(c.pose.distance_to(&routine[27]) < 1e-6);
        assert_eq!(walk_class(&c), Some((true, true)));
        // A new row foretold by the layer's own rows alone is a class of its own.
        let c = propose1(&routine[..39], &[], tol).expect("the third row's first slot");
        assert!(c.pose.distance_to(&routine[39]) < 1e-6);
        assert_eq!(walk_class(&c), Some((true, false)));
        // A pick station visited twice is no station yet.
        assert!(propose1(&routine[..12], &[], tol).is_none_or(|c| !is_station(&c)));
    }

    /// Per item: the pick station's approach, pick and retract, then the slot's.
    fn items(slots: &[Vector3<f64>]) -> Vec<Pose> {
        let at = |p: Vector3<f64>| {
            Pose::from_isometry(Isometry3::from_parts(
                Translation3::from(p),
                nalgebra::UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0),
            ))
        };
        let (pick, up) = (
            Vector3::new(600.0, -700.0, 400.0),
            Vector3::new(0.0, 0.0, 150.0),
        );
        slots
            .iter()
            .flat_map(|s| [pick + up, pick, pick + up, s + up, *s, s + up].map(at))
            .collect()
    }

    /// A second layer laid like the first (120 mm up, its rows as long), or turned a quarter
    /// (the boxes turned: rows of the first layer's row count at its row pitch): every slot of
    /// it after its first two is proposed exactly, the first row change included, and once it
    /// has as many slots as the first, nothing more (the routine goes home) — neither the next
    /// slot nor the pick station. The same when each layer is a routine of its own.
    #[test]
    fn a_second_layer_is_laid_like_the_first_and_ends_where_it_does() {
        let (x, y) = (Vector3::new(200.0, 0.0, 0.0), Vector3::new(0.0, 250.0, 0.0));
        let up = Vector3::new(0.0, 0.0, 120.0);
        let first = walk(3, 4, x, y, Order::Serpentine);
        let same: Vec<_> = first.iter().map(|p| p + up).collect();
        let turned: Vec<_> = walk(4, 3, x * 1.25, y * 0.8, Order::Serpentine)
            .iter()
            .map(|p| p + up)
            .collect();
        let tol = WalkTolerance::from(1.0);
        for second in [&same, &turned] {
            let one = items(
                &first
                    .iter()
                    .chain(second.iter())
                    .copied()
                    .collect::<Vec<_>>(),
            );
            let (l1, l2) = (items(&first), items(second));
            let home = |r: &[Pose]| [r.to_vec(), vec![r[0]]].concat();
            // One routine; a routine per layer (the first finished, with a home at its end).
            let cases = [
                (one.clone(), Vec::new(), first.len() * 6),
                (l2, home(&l1), 0),
            ];
            for (routine, previous, start) in cases {
                for k in 2..second.len() {
                    for role in 3..6 {
                        let n = start + 6 * k + role;
                        let c = propose1(&routine[..n], &previous, tol)
                            .unwrap_or_else(|| panic!("slot {k}, waypoint {n}: nothing"));
                        let err = c.pose.distance_to(&routine[n]);
                        assert!(err < 1e-6, "slot {k}, waypoint {n}: {err} mm off");
                    }
                }
                assert!(
                    propose1(&routine, &previous, tol).is_none(),
                    "the pattern is done"
                );
            }
        }
    }

    /// Two rows of two zigzag in any star or weave: no new row is foretold from them.
    #[test]
    fn a_star_is_not_a_grid() {
        let at = |x: f64, y: f64| Pose::from_isometry(Isometry3::translation(x, y, 300.0));
        let star = [
            at(0.0, 0.0),
            at(500.0, 900.0),
            at(180.0, 0.0),
            at(-400.0, 700.0),
            at(180.0, 150.0),
            at(800.0, -300.0),
            at(0.0, 150.0),
            at(-600.0, -500.0),
        ];
        assert!(propose1(&star, &[], 1.0.into()).is_none());
    }

    /// A machine-tending item goes back and forth at the machine, so its last waypoints, two
    /// apart, are a station of three visits at every item's start: that short station does not
    /// hide the tray's slots, which walk with the item's longer period.
    #[test]
    fn a_short_station_does_not_hide_a_longer_periods_walk() {
        let (m1, m2, up) = (
            Vector3::new(450.0, 840.0, 700.0),
            Vector3::new(600.0, 860.0, 700.0),
            Vector3::new(0.0, 0.0, 150.0),
        );
        let slots = walk(
            3,
            3,
            Vector3::new(80.0, 0.0, 0.0),
            Vector3::new(0.0, 80.0, 0.0),
            Order::Raster,
        );
        let routine: Vec<Pose> = slots
            .iter()
            .flat_map(|s| [s + up, *s, s + up, m1, m2, m1, m2, m1].map(down_at))
            .collect();
        let tol = WalkTolerance::from(1.0);
        // From the second row's second slot on (the first row's end could not be seen coming).
        for k in 4..slots.len() {
            let n = 8 * k + 1;
            let all = propose(&routine[..n], &[], tol);
            let first = all.first().expect("a candidate");
            assert_eq!(lattice(first), LatticeEvidence::Station { visits: 3 });
            assert!(
                all.iter().any(|c| c.pose.distance_to(&routine[n]) < 1e-6),
                "slot {k}: the tray's next slot is not proposed"
            );
        }
    }

    /// When a role of an item leaves its layer for a new one (the first approach of a new
    /// layer, somewhere the first layer's rows do not go), the item's other roles leave theirs
    /// too: the place under that approach is not the first layer's next place.
    #[test]
    fn a_new_layers_first_approach_ends_the_other_roles_walks() {
        let (x, y) = (Vector3::new(200.0, 0.0, 0.0), Vector3::new(0.0, 250.0, 0.0));
        let first = walk(3, 4, x, y, Order::Raster);
        let second: Vec<_> = walk(4, 3, y, x, Order::Raster)
            .iter()
            .map(|p| p + Vector3::new(0.0, 0.0, 120.0))
            .collect();
        let routine = items(&[first.clone(), second].concat());
        let tol = WalkTolerance::from(1.0);
        // The first layer's last place is still proposed as its walk's.
        let n = 6 * (first.len() - 1) + 4;
        let c = propose1(&routine[..n], &[], tol).expect("the first layer's last place");
        assert!(c.pose.distance_to(&routine[n]) < 1e-6);
        // The second layer's first place is not.
        let n = 6 * first.len() + 4;
        assert!(propose(&routine[..n], &[], tol).is_empty());
    }
}
