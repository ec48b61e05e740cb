//! Lattice walks: points visited one after another on a row or a grid (the slots of a pallet's
//! layer, a tray, a grid of screws), found from the points themselves, and the next point of
//! the walk (issue 30, item 1).
//!
//! **The model.** A layer's points are `o + i·a + j·b` for integer `i` along the row and `j`
//! across it; the walk visits `i = 0 … n − 1` along a row, then steps to the next row, which it
//! walks the same way (raster) or back (serpentine). A column-first walk is a raster walk whose
//! first axis is the column: the model names its axes by the walk, not by the work frame, so
//! pitches in any direction (a pallet turned on the table) are one case.
//!
//! **The fit** ([`LatticeWalk::fit`]), over the points in the order taught, within a step
//! tolerance `tol` (the cell's, widened by its noise):
//!
//! 1. the first step is `a`; every step that repeats it (or its reverse, after a row change in
//!    a serpentine walk) continues a row;
//! 2. the first other step ends the first row, which gives the row length `n`; the step after
//!    it must repeat `a` one way or the other, and says the order (`+a`: raster, `−a`:
//!    serpentine), and with it `b` (raster: the change plus `(n − 1)·a`; serpentine: the change
//!    itself). Until then the walk is one row: a turn of a path is no evidence of a grid, and
//!    three points with two different steps are not a walk;
//! 3. every later point must be where the walk puts it; the origin, `a` and `b` are then fitted
//!    by least squares over all points (the noise averages out), and the residual's RMS is the
//!    evidence.
//!
//! A sequence that breaks the walk anywhere is not a lattice walk ([`LatticeWalk::fit`] gives
//! `None`); [`LatticeWalk::fit_tail`] finds the longest tail that is one (a new layer, turned or
//! not, starts a new walk). [`LatticeWalk::next`] is the next point; before the first row ends
//! it continues the row, and the row's end cannot be known yet.
//!
//! **The expert** ([`propose`]). A palletising routine repeats its moves item by item, and only
//! some of them move with the item: the waypoints of one *role* (the slot's approach, the place,
//! the retract) walk the lattice, the others (the pick station) stay. So for each period `P`
//! from [`MIN_PERIOD`] to [`MAX_PERIOD`] the waypoints `P`, `2P`, … before the next one are
//! read as a walk (the newest [`MAX_WALK_POINTS`]); the shortest period whose walk fits
//! proposes its next point, turned as the waypoint one period back. Its evidence: the walk's
//! length (as a context) and whether it is a grid yet (two places) or one row (one place, whose
//! end cannot be seen coming). The cell's calibration learns how often each is right, starting
//! at one half, as for the template expert.
//!
//! Pure: no I/O, no state beyond the fit.

use nalgebra::{Isometry3, Matrix3, Translation3, Vector3};

use super::frames::Tolerance;
use super::{Candidate, Evidence, Expert};
use crate::engine::pose::Pose;

/// The shortest period of a routine's items the expert reads (every other waypoint).
pub const MIN_PERIOD: usize = 2;
/// The longest (a machine-tending part is 11 waypoints).
pub const MAX_PERIOD: usize = 12;
/// The newest points of a role read as a walk (a layer of up to 32 slots; bounds the cost).
pub const MAX_WALK_POINTS: usize = 32;

/// The lattice expert's candidate for the waypoint after `routine` (module doc, "The expert"),
/// with steps matched within `tolerance`.
pub fn propose(routine: &[Pose], tolerance: &Tolerance) -> Option<Candidate> {
    let n = routine.len();
    (MIN_PERIOD..=MAX_PERIOD).find_map(|period| {
        let mut role: Vec<Vector3<f64>> = (1..=MAX_WALK_POINTS)
            .map_while(|k| n.checked_sub(k * period))
            .map(|i| routine[i].position())
            .collect();
        role.reverse();
        let (start, walk) = LatticeWalk::fit_tail(&role, tolerance.mm)?;
        let points = role.len() - start;
        let last = &routine[n - period];
        let pose = Pose::from_isometry(Isometry3::from_parts(
            Translation3::from(walk.next()),
            last.rotation(),
        ));
        Some(Candidate {
            expert: Expert::Lattice,
            pose,
            evidence: Evidence {
                context: points.min(8),
                places: if walk.rows.is_some() { 2 } else { 1 },
                agreeing: if walk.rows.is_some() { 2 } else { 1 },
                in_routine: true,
                gated_in: false,
            },
        })
    })
}

/// How a walk goes from row to row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// Every row in the same direction.
    Raster,
    /// Every other row back.
    Serpentine,
}

/// A lattice walk fitted to taught points.
#[derive(Debug, Clone, PartialEq)]
pub struct LatticeWalk {
    /// The first point's lattice position, and the two pitch vectors (`b` zero while the walk
    /// has one row), mm.
    pub origin: Vector3<f64>,
    pub a: Vector3<f64>,
    pub b: Vector3<f64>,
    /// Points per row and the order, once the first row has ended and the second row has two
    /// points (`None`: one row so far).
    pub rows: Option<(usize, Order)>,
    /// Each point's `(i, j)`.
    pub indices: Vec<(i64, i64)>,
    /// RMS distance of the points from their fitted lattice positions, mm.
    pub rms_mm: f64,
}

/// The fewest points a walk is fitted to: two steps that agree.
pub const MIN_POINTS: usize = 3;

impl LatticeWalk {
    /// The walk through all of `points` (module doc), or `None` if they are not one.
    pub fn fit(points: &[Vector3<f64>], tol: f64) -> Option<LatticeWalk> {
        if points.len() < MIN_POINTS {
            return None;
        }
        let a = points[1] - points[0];
        if a.norm() <= 2.0 * tol {
            return None;
        }
        let near = |d: &Vector3<f64>, want: &Vector3<f64>| (d - want).norm() <= tol;
        // The first row: the steps that repeat `a`.
        let mut n = 1;
        while n < points.len() && near(&(points[n] - points[n - 1]), &a) {
            n += 1;
        }
        let mut indices: Vec<(i64, i64)> = (0..n as i64).map(|i| (i, 0)).collect();
        if n == 2 && points.len() == 3 {
            // Two steps that differ: nothing repeats yet.
            return None;
        }
        let (mut rows, mut b) = (None, Vector3::zeros());
        if n < points.len() {
            // The row change, then the order from the step after it, which must repeat `a` one
            // way or the other (a row change alone is any turn of a path).
            let change = points[n] - points[n - 1];
            if change.norm() <= 2.0 * tol {
                return None;
            }
            let last = n as i64 - 1;
            let (o, j0) = match points.get(n + 1).map(|p| p - points[n]) {
                Some(d) if near(&d, &a) => (Order::Raster, (0, 1)),
                Some(d) if near(&d, &(-a)) => (Order::Serpentine, (last, 1)),
                _ => return None,
            };
            rows = Some((n, o));
            b = match o {
                Order::Raster => change + a * (n as f64 - 1.0),
                Order::Serpentine => change,
            };
            if b.norm() <= 2.0 * tol || b.cross(&a).norm() <= tol * a.norm() {
                return None;
            }
            // The rest must be where the walk puts it.
            let mut at = j0;
            indices.push(at);
            for k in n + 1..points.len() {
                at = step(at, n, o);
                let want = points[0] + a * at.0 as f64 + b * at.1 as f64;
                // Each point against the one before plus the pitch, so noise does not add up.
                let prev = indices[k - 1];
                let from = points[k - 1] + a * (at.0 - prev.0) as f64 + b * (at.1 - prev.1) as f64;
                if (points[k] - from).norm() > tol && (points[k] - want).norm() > 2.0 * tol {
                    return None;
                }
                indices.push(at);
            }
        }
        let mut walk = LatticeWalk {
            origin: points[0],
            a,
            b,
            rows,
            indices,
            rms_mm: 0.0,
        };
        walk.refine(points);
        Some(walk)
    }

    /// The walk through the longest tail of `points` that is one (at least [`MIN_POINTS`]),
    /// with the index in `points` where it starts.
    pub fn fit_tail(points: &[Vector3<f64>], tol: f64) -> Option<(usize, LatticeWalk)> {
        (0..=points.len().saturating_sub(MIN_POINTS))
            .find_map(|s| LatticeWalk::fit(&points[s..], tol).map(|w| (s, w)))
    }

    /// The lattice position of `(i, j)`.
    pub fn point(&self, (i, j): (i64, i64)) -> Vector3<f64> {
        self.origin + self.a * i as f64 + self.b * j as f64
    }

    /// The next point of the walk: along the row, or (the row's length and the order known) on
    /// to the next row.
    pub fn next(&self) -> Vector3<f64> {
        let last = self.indices.last().copied().unwrap_or((0, 0));
        match self.rows {
            Some((n, o)) => self.point(step(last, n, o)),
            None => self.point((last.0 + 1, last.1)),
        }
    }

    /// Least-squares origin and pitches over all points, and the residual.
    fn refine(&mut self, points: &[Vector3<f64>]) {
        let two_d = self.indices.iter().any(|&(_, j)| j != 0);
        // Normal equations per coordinate for the unknowns (o, a, b) — or (o, a) on one row.
        let k = if two_d { 3 } else { 2 };
        let mut m = Matrix3::<f64>::zeros();
        let mut rhs = [Vector3::<f64>::zeros(); 3];
        for (p, &(i, j)) in points.iter().zip(&self.indices) {
            let x = [1.0, i as f64, j as f64];
            for r in 0..k {
                for c in 0..k {
                    m[(r, c)] += x[r] * x[c];
                }
                rhs[r] += p * x[r];
            }
        }
        if !two_d {
            m[(2, 2)] = 1.0;
        }
        if let Some(inv) = m.try_inverse() {
            let solve =
                |r: usize| rhs[0] * inv[(r, 0)] + rhs[1] * inv[(r, 1)] + rhs[2] * inv[(r, 2)];
            self.origin = solve(0);
            self.a = solve(1);
            if two_d {
                self.b = solve(2);
            }
        }
        let ss: f64 = points
            .iter()
            .zip(&self.indices)
            .map(|(p, &ix)| (p - self.point(ix)).norm_squared())
            .sum();
        self.rms_mm = (ss / points.len() as f64).sqrt();
    }
}

/// The index after `(i, j)` on a walk of rows of `n`.
fn step((i, j): (i64, i64), n: usize, order: Order) -> (i64, i64) {
    let last = n as i64 - 1;
    let forward = order == Order::Raster || j % 2 == 0;
    match (forward, order) {
        (true, _) if i < last => (i + 1, j),
        (false, _) if i > 0 => (i - 1, j),
        (_, Order::Raster) => (0, j + 1),
        (_, Order::Serpentine) => (i, j + 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The points of an `n × m` layer at pitches `a`, `b` from `o`, in `order`, first axis `a`.
    fn walk(n: i64, m: i64, a: Vector3<f64>, b: Vector3<f64>, order: Order) -> Vec<Vector3<f64>> {
        let o = Vector3::new(900.0, -300.0, 200.0);
        (0..m)
            .flat_map(|j| {
                (0..n).map(move |i| {
                    let i = if order == Order::Serpentine && j % 2 == 1 {
                        n - 1 - i
                    } else {
                        i
                    };
                    o + a * i as f64 + b * j as f64
                })
            })
            .collect()
    }

    /// After every prefix of at least one row and one point more, the walk's next point is
    /// the pattern's next, to within `within` mm.
    fn predicts_the_rest(
        points: &[Vector3<f64>],
        truth: &[Vector3<f64>],
        tol: f64,
        within: f64,
        from: usize,
    ) {
        for k in from..points.len() {
            let w = LatticeWalk::fit(&points[..k], tol)
                .unwrap_or_else(|| panic!("no walk through {k} points"));
            let err = (w.next() - truth[k]).norm();
            assert!(err <= within, "after {k} points: {err} mm off");
        }
    }

    #[test]
    fn raster_serpentine_and_column_first_walks_are_followed_across_rows() {
        let (x, y) = (Vector3::new(200.0, 0.0, 0.0), Vector3::new(0.0, 250.0, 0.0));
        for order in [Order::Raster, Order::Serpentine] {
            let points = walk(3, 4, x, y, order);
            // Once the second row has two points the order is known: every later point is
            // predicted exactly.
            predicts_the_rest(&points, &points, 1.0, 1e-9, 5);
            let w = LatticeWalk::fit(&points, 1.0).unwrap();
            assert_eq!(w.rows, Some((3, order)));
            assert!(w.rms_mm < 1e-9);
        }
        // Column first: the walk's first axis is the work frame's y.
        let columns = walk(4, 3, y, x, Order::Raster);
        predicts_the_rest(&columns, &columns, 1.0, 1e-9, 6);
        // Along the first row, the row goes on (its end cannot be known yet).
        let w = LatticeWalk::fit(&columns[..3], 1.0).unwrap();
        assert_eq!(w.rows, None);
        assert!((w.next() - columns[3]).norm() < 1e-9);
    }

    #[test]
    fn a_pitch_not_along_the_axes_and_a_turned_layer_are_walks_too() {
        let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.35);
        let (a, b) = (
            turn * Vector3::new(180.0, 0.0, 0.0),
            turn * Vector3::new(0.0, 240.0, 0.0),
        );
        let layer1 = walk(4, 3, a, b, Order::Serpentine);
        predicts_the_rest(&layer1, &layer1, 1.0, 1e-9, 6);
        // The next layer, turned by 90° (rows along b), 120 mm up: a new walk starts there.
        let up = Vector3::new(0.0, 0.0, 120.0);
        let layer2: Vec<Vector3<f64>> = walk(3, 4, b, a, Order::Raster)
            .iter()
            .map(|p| p + up)
            .collect();
        let both: Vec<Vector3<f64>> = layer1.iter().chain(&layer2).copied().collect();
        assert!(
            LatticeWalk::fit(&both, 1.0).is_none(),
            "two layers are not one walk"
        );
        for k in layer1.len() + 5..both.len() {
            let (start, w) = LatticeWalk::fit_tail(&both[..k], 1.0).unwrap();
            assert!(start >= layer1.len() - 1, "the tail from {start}");
            assert!((w.next() - both[k]).norm() < 1e-9, "after {k}");
        }
    }

    /// Points placed by hand with 0.5 mm per axis on a 100 mm grid: the walk is found within a
    /// 3 mm step tolerance, and the least-squares lattice predicts each next point within
    /// 2.5 mm of the meant one (closer than the last point's own error adds up to).
    #[test]
    fn a_noisy_walk_is_found_and_averaged() {
        let meant = walk(
            5,
            4,
            Vector3::new(100.0, 0.0, 0.0),
            Vector3::new(0.0, 80.0, 0.0),
            Order::Raster,
        );
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut gauss = || {
            let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let taught: Vec<Vector3<f64>> = meant
            .iter()
            .map(|p| p + Vector3::new(gauss(), gauss(), gauss()) * 0.5)
            .collect();
        predicts_the_rest(&taught, &meant, 3.0, 2.5, 7);
        let w = LatticeWalk::fit(&taught, 3.0).unwrap();
        assert!(w.rms_mm < 1.0 && w.rms_mm > 0.1, "{}", w.rms_mm);
    }

    /// The expert reads the slot's waypoints as walks with the item's period: once the second
    /// row has two items, it proposes every later slot approach, place and retract exactly, as
    /// a grid (two places); the pick station, which does not move, it leaves to the others.
    #[test]
    fn the_expert_proposes_each_slot_waypoint_of_a_pallet() {
        // A 3 × 4 pallet as one routine: per item the pick station's approach, pick and
        // retract, then the slot's approach, place and retract.
        let routine = crate::engine::experts::noise::estimate::tests::pallet();
        let tol = Tolerance { mm: 1.0, rad: 0.1 };
        let mut proposed = 0;
        for n in 30..routine.len() {
            let slot_role = n % 6 >= 3;
            let c = propose(&routine[..n], &tol);
            if slot_role {
                let c = c.unwrap_or_else(|| panic!("nothing proposed for waypoint {n}"));
                assert_eq!(c.expert, Expert::Lattice);
                assert!(c.pose.distance_to(&routine[n]) < 1e-6, "waypoint {n}");
                assert!(c.pose.angle_to(&routine[n]) < 1e-9);
                assert_eq!(c.evidence.places, 2);
                proposed += 1;
            } else if let Some(c) = c {
                assert!(
                    c.pose.distance_to(&routine[n]) > 1.0,
                    "a pick at {n} read as a walk"
                );
            }
        }
        assert_eq!(proposed, 21);
        // After the first row of three, one place: the row goes on (its end could not be seen
        // coming), 200 mm on from its last slot.
        let c = propose(&routine[..21], &tol).expect("a row of three");
        assert_eq!(c.evidence.places, 1);
        let on = routine[15].position() + Vector3::new(200.0, 0.0, 0.0);
        assert!((c.pose.position() - on).norm() < 1e-6);
    }

    /// A pattern that stops early and goes elsewhere is a walk up to where it stops, not after;
    /// scattered points and a path with one long and one short step are not walks.
    #[test]
    fn what_is_not_a_walk_is_not_claimed() {
        let x = Vector3::new(150.0, 0.0, 0.0);
        let y = Vector3::new(0.0, 150.0, 0.0);
        let mut points = walk(4, 4, x, y, Order::Raster)[..10].to_vec();
        assert!(LatticeWalk::fit(&points, 1.0).is_some());
        points.push(Vector3::new(0.0, 0.0, 900.0));
        assert!(LatticeWalk::fit(&points, 1.0).is_none());
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for _ in 0..50 {
            let scattered: Vec<Vector3<f64>> = (0..8)
                .map(|_| {
                    Vector3::new(
                        rng.random_range(0.0..800.0),
                        rng.random_range(0.0..800.0),
                        100.0,
                    )
                })
                .collect();
            assert!(LatticeWalk::fit(&scattered, 1.0).is_none());
            assert!(LatticeWalk::fit_tail(&scattered, 1.0).is_none());
        }
        let path = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(100.0, 0.0, 0.0),
            Vector3::new(130.0, 0.0, 0.0),
        ];
        assert!(LatticeWalk::fit(&path, 1.0).is_none());
    }
}
