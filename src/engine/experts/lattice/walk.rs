//! The lattice walk fitted to taught points.
//!
//! **The model.** A layer's points are `o + i·a + j·b` for integer `i` along the row and `j`
//! across it; the walk visits `i = 0 … n − 1` along a row, then steps to the next row, which it
//! walks the same way (raster) or back (serpentine). A column-first walk is a raster walk whose
//! first axis is the column: the model names its axes by the walk, not by the work frame, so
//! pitches in any direction (a pallet turned on the table) are one case.
//!
//! **The fit** ([`LatticeWalk::fit`]), over the points in the order taught, within the
//! [`WalkTolerance`]s (the cell's, widened by its noise: a step against a step carries four
//! placements' error when taught by hand, a point against where the walk puts it two):
//!
//! 1. the first step is `a`; every step that repeats the row's mean step so far (or its
//!    reverse, after a row change in a serpentine walk) continues a row; a pitch must exceed
//!    the point tolerance (what the noise makes of one place);
//! 2. the first other step ends the first row, which gives the row length `n`; the step after
//!    it must repeat `a` one way or the other, and says the order (`+a`: raster, `−a`:
//!    serpentine), and with it `b` (raster: the change plus `(n − 1)·a`; serpentine: the change
//!    itself). Without that step, the change alone settles the order only after a row of three
//!    or more and when square to it (below, "Layers"); otherwise the walk is one row: a turn of
//!    a path is no evidence of a grid, and three points with two different steps are not a
//!    walk;
//! 3. every later point must be where the walk puts it: one pitch from the point before, or
//!    where the lattice least-squares-fitted to the points before it puts it (by hand, the
//!    errors average out there); the origin, `a` and `b` are then fitted by least squares
//!    over all points, and the residual's RMS is the evidence.
//!
//! A sequence that breaks the walk anywhere is not a lattice walk ([`LatticeWalk::fit`] gives
//! `None`); [`LatticeWalk::fit_prefix`] gives the longest prefix that is one, and
//! [`LatticeWalk::layers`] cuts a sequence into walks where each breaks (a new layer, turned or
//! not, starts a new walk). [`LatticeWalk::next`] is the next point; before the first row ends
//! it continues the row, and the row's end cannot be known yet.
//!
//! **Layers laid like the one before.** A walk that follows a layer of at least
//! [`MIN_LAYER_POINTS`] is read as laid like it: once its first row is as long as that layer's
//! rows at the same pitch, or (the boxes turned a quarter, the pitches swapped) as long as that
//! layer had rows at its row pitch, it goes on to the next row as that layer did, before its
//! own second row shows the way; two points at one of that layer's pitches already start it;
//! and it is complete when it has as many points. Its row at a pitch of that layer (along
//! either of its pitches, either way, as long as either) walks at that layer's fitted pitch,
//! and laid like it, it keeps both pitches and fits only its origin: two hand-placed points
//! do not set a layer's direction. Without a layer before, the second row's
//! first point alone gives the order by how far back along the row it lies: settled when the
//! row pitch that gives is square to the rows and the other order's is not ([`SQUARE_COS`],
//! [`SKEWED_COS`]: the three corners a pallet wizard asks for), else a guess.

use nalgebra::{Matrix3, Vector3};

/// The tolerances a walk is matched with: `point`, between a taught point and where the walk
/// puts it (two placements' error when taught by hand: the pose frame's widened tolerance);
/// `step`, between two steps (four placements': the move frames'). Both the cell's own
/// tolerance for exact waypoints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WalkTolerance {
    pub point: f64,
    pub step: f64,
}

impl From<f64> for WalkTolerance {
    /// One tolerance for both (exact waypoints).
    fn from(tol: f64) -> WalkTolerance {
        WalkTolerance {
            point: tol,
            step: tol,
        }
    }
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
    /// The order is a guess: the second row has one point so far ([`LatticeWalk::fit_prefix`]).
    pub guessed: bool,
    /// Laid like the layer before: its pitches are that layer's, and only the origin is
    /// fitted to this walk's own points.
    pub laid: bool,
    /// Each point's `(i, j)`.
    pub indices: Vec<(i64, i64)>,
    /// RMS distance of the points from their fitted lattice positions, mm.
    pub rms_mm: f64,
}

/// The fewest points a walk is fitted to: two steps that agree.
pub const MIN_POINTS: usize = 3;

/// A second row's first point settles the order when the row pitch it gives is within this
/// cosine of square to the rows...
pub const SQUARE_COS: f64 = 0.2;
/// ...and the other order's is beyond this one.
pub const SKEWED_COS: f64 = 0.5;

/// The fewest points of a layer a later walk is laid like (two rows of three).
pub const MIN_LAYER_POINTS: usize = 6;

impl LatticeWalk {
    /// The walk through all of `points` (module doc), or `None` if they are not one.
    pub fn fit(points: &[Vector3<f64>], tol: impl Into<WalkTolerance>) -> Option<LatticeWalk> {
        LatticeWalk::fit_prefix(points, tol, None)
            .filter(|(k, w)| *k == points.len() && !w.guessed)
            .map(|(_, w)| w)
    }

    /// The walk through the longest prefix of `points` that is one (at least [`MIN_POINTS`];
    /// two at a pitch of `earlier`), with its length. With `earlier` (the layer before, in rows), a first row as long as its
    /// rows, at its pitch, goes on to the next row as it did (its order, its row pitch turned
    /// as this row is turned from its rows): a new layer laid like the one before.
    pub fn fit_prefix(
        points: &[Vector3<f64>],
        tol: impl Into<WalkTolerance>,
        earlier: Option<&LatticeWalk>,
    ) -> Option<(usize, LatticeWalk)> {
        let WalkTolerance { point, step: steps } = tol.into();
        if points.len() < 2 {
            return None;
        }
        let a = points[1] - points[0];
        if a.norm() <= point {
            return None;
        }
        let near = |d: &Vector3<f64>, want: &Vector3<f64>| (d - want).norm() <= steps;
        // Two points are a walk only as the start of a layer at a pitch of the one before.
        let fewest = match earlier {
            Some(e)
                if [e.a.norm(), e.b.norm()]
                    .iter()
                    .any(|p| (p - a.norm()).abs() <= steps) =>
            {
                2
            }
            _ => MIN_POINTS,
        };
        // The first row: the steps that repeat the row's mean step so far (its first step
        // alone would carry two placements' error into every comparison).
        let mut n = 1;
        while n < points.len() {
            let mean = if n == 1 {
                a
            } else {
                (points[n - 1] - points[0]) / (n as f64 - 1.0)
            };
            if !near(&(points[n] - points[n - 1]), &mean) {
                break;
            }
            n += 1;
        }
        // The first step repeats itself: the row has two points or more.
        let a = (points[n - 1] - points[0]) / (n as f64 - 1.0);
        let mut indices: Vec<(i64, i64)> = (0..n as i64).map(|i| (i, 0)).collect();
        // A row at a pitch of the layer before walks at that pitch.
        let snapped = earlier
            .filter(|e| e.is_a_layer())
            .and_then(|e| e.pitch_near(&a, steps));
        let a = snapped.unwrap_or(a);
        let laid = earlier.and_then(|e| e.laid_on(n, &a, steps));
        // The row change and the step after it, which must repeat `a` one way or the other (a
        // row change alone is any turn of a path): the order they show, else the one laid
        // before, else (the second row's first point alone) a guess from how far back along
        // the row it is (a serpentine walk turns at the row's end, a raster walk goes back to
        // its start).
        let mut guessed = false;
        let change = points.get(n).map(|p| p - points[n - 1]);
        let shown = match (change, points.get(n + 1).map(|p| p - points[n])) {
            (Some(c), _) if c.norm() <= point => None,
            (Some(c), Some(d)) if near(&d, &a) => Some((Order::Raster, c + a * (n as f64 - 1.0))),
            (Some(c), Some(d)) if near(&d, &(-a)) => Some((Order::Serpentine, c)),
            _ => None,
        };
        // Laid like the layer before, its pitches are that layer's (fitted over all its
        // points), unless the second row shows another way.
        let mut a = a;
        let shown = match (shown, laid) {
            (Some((order, b)), Some((o, la, lb))) if order == o && near(&b, &lb) => {
                a = la;
                Some((o, lb))
            }
            (s, _) => s,
        };
        let setup = match (shown, laid, change) {
            (Some(s), _, _) => Some(s),
            (None, Some((o, la, lb)), _) => {
                a = la;
                Some((o, lb))
            }
            (None, None, Some(c)) if n >= MIN_POINTS && n + 1 == points.len() => {
                let back = -c.dot(&a) / a.norm_squared();
                let (raster, serpentine) = (c + a * (n as f64 - 1.0), c);
                let (chosen, other) = if back > (n as f64 - 1.0) / 2.0 {
                    ((Order::Raster, raster), serpentine)
                } else {
                    ((Order::Serpentine, serpentine), raster)
                };
                // No guess when the row pitch it gives is square to the rows and the other's
                // is far from it (the three corners a pallet wizard asks for).
                let skew = |b: &Vector3<f64>| b.dot(&a).abs() / (b.norm() * a.norm()).max(1e-9);
                guessed = !(skew(&chosen.1) <= SQUARE_COS && skew(&other) > SKEWED_COS);
                Some(chosen)
            }
            _ => None,
        };
        // One row at the layer before's pitch keeps it; with rows, see below.
        let mut fixed = snapped.is_some();
        let (mut rows, mut b) = (None, Vector3::zeros());
        if let Some((order, pitch)) = setup
            && pitch.norm() > point
            && pitch.cross(&a).norm() > point * a.norm()
        {
            rows = Some((n, order));
            b = pitch;
            // Both pitches are the layer's before only when laid like it.
            fixed = laid.is_some_and(|(o, la, lb)| o == order && la == a && lb == b);
            // The rest must be where the walk puts it.
            let mut normal = Normal::default();
            for (p, &ix) in points.iter().zip(&indices) {
                normal.add(p, ix);
            }
            let mut at = (n as i64 - 1, 0);
            for k in n..points.len() {
                at = step(at, n, order);
                let want = points[0] + a * at.0 as f64 + b * at.1 as f64;
                // Each point against the one before plus the pitch, so noise does not add up;
                // or against the lattice fitted to the points so far, where it averages out.
                let prev = indices[k - 1];
                let from = points[k - 1] + a * (at.0 - prev.0) as f64 + b * (at.1 - prev.1) as f64;
                let fitted = normal
                    .solve(fixed.then_some((a, b)))
                    .filter(|_| fixed || normal.two_d())
                    .map(|(o, fa, fb)| o + fa * at.0 as f64 + fb * at.1 as f64);
                if (points[k] - from).norm() > steps
                    && (points[k] - want).norm() > 2.0 * point
                    && fitted.is_none_or(|f| (points[k] - f).norm() > point)
                {
                    break;
                }
                normal.add(&points[k], at);
                indices.push(at);
            }
        }
        let k = indices.len();
        if k < fewest {
            return None;
        }
        let mut walk = LatticeWalk {
            origin: points[0],
            a,
            b,
            rows,
            guessed: guessed && rows.is_some(),
            laid: fixed,
            indices,
            rms_mm: 0.0,
        };
        walk.refine(&points[..k]);
        Some((k, walk))
    }

    /// Whether a new walk may be laid like this one: it has rows, and at least
    /// [`MIN_LAYER_POINTS`] points (four corners of a frame are no layer).
    pub(super) fn is_a_layer(&self) -> bool {
        self.rows.is_some() && self.indices.len() >= MIN_LAYER_POINTS
    }

    /// A new layer's order and row pitch when its first row of `n` points at pitch `a` is laid
    /// like this walk's rows: as long and at the same pitch, or (a layer turned a quarter) as
    /// long as this walk has rows and at its row pitch. The row pitch is this walk's, turned
    /// as `a` is turned from this walk's rows; or, turned, across `a` as long as this walk's
    /// rows' pitch.
    fn laid_on(
        &self,
        n: usize,
        a: &Vector3<f64>,
        tol: f64,
    ) -> Option<(Order, Vector3<f64>, Vector3<f64>)> {
        let (rows_n, order) = self.rows?;
        let points = self.indices.len();
        if rows_n == n && (self.a.norm() - a.norm()).abs() <= tol {
            let a = self.pitch_near(a, tol).unwrap_or(*a);
            let turned = nalgebra::Rotation3::rotation_between(&self.a, &a)
                .unwrap_or_else(nalgebra::Rotation3::identity)
                * self.b;
            Some((order, a, turned))
        } else if points.is_multiple_of(rows_n)
            && points / rows_n == n
            && (self.b.norm() - a.norm()).abs() <= tol
        {
            // The pitches swapped: the rows step across, in the layer's plane, as far as this
            // walk's rows were long, to the side this walk's rows went (else its rows' way).
            let a = self.pitch_near(a, tol).unwrap_or(*a);
            let across = self.a.cross(&self.b).cross(&a).try_normalize(1e-9)?;
            let side = if across.dot(&self.b).abs() > 0.1 * self.b.norm() {
                across.dot(&self.b).signum()
            } else {
                across.dot(&self.a).signum()
            };
            Some((order, a, across * side * self.a.norm()))
        } else {
            None
        }
    }

    /// The pitch of a layer laid like this one nearest `a`, within `tol`: along one of this
    /// walk's pitches, either way, as long as one of them (a layer turned a quarter, or its
    /// boxes turned on their rows). It is fitted over all of this walk's points, so a new
    /// layer's rows are not walked at their first points' own (noisy) pitch.
    fn pitch_near(&self, a: &Vector3<f64>, tol: f64) -> Option<Vector3<f64>> {
        let lengths = [self.a.norm(), self.b.norm()];
        [self.a, -self.a, self.b, -self.b]
            .iter()
            .filter_map(|d| d.try_normalize(1e-9))
            .flat_map(|d| lengths.map(|l| d * l))
            .map(|p| ((p - a).norm(), p))
            .filter(|(d, _)| *d <= tol)
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .map(|(_, p)| p)
    }

    /// `points` cut into layers, oldest first: from the first point, the longest walk
    /// ([`LatticeWalk::fit_prefix`], laid like the layer before it; the first like `first`),
    /// then the next from the point where it broke; a point no walk starts at is skipped. With
    /// the index each starts at.
    pub fn layers(
        points: &[Vector3<f64>],
        tol: impl Into<WalkTolerance>,
        first: Option<&LatticeWalk>,
    ) -> Vec<(usize, LatticeWalk)> {
        let tol = tol.into();
        let mut out: Vec<(usize, LatticeWalk)> = Vec::new();
        let mut i = 0;
        while i + 2 <= points.len() {
            let earlier = match out.last() {
                Some((_, w)) => Some(w).filter(|w| w.is_a_layer()),
                None => first,
            };
            match LatticeWalk::fit_prefix(&points[i..], tol, earlier) {
                Some((k, w)) => {
                    out.push((i, w));
                    i += k;
                }
                None => i += 1,
            }
        }
        out
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

    /// Whether the next point starts a new row (the row's length known).
    pub fn starts_row(&self) -> bool {
        let last = self.indices.last().copied().unwrap_or((0, 0));
        match self.rows {
            Some((n, o)) => step(last, n, o).1 != last.1,
            None => false,
        }
    }

    /// Least-squares origin and pitches over all points (the origin alone when laid like the
    /// layer before), and the residual.
    fn refine(&mut self, points: &[Vector3<f64>]) {
        let mut normal = Normal::default();
        for (p, &ix) in points.iter().zip(&self.indices) {
            normal.add(p, ix);
        }
        if let Some((o, a, b)) = normal.solve(self.laid.then_some((self.a, self.b))) {
            (self.origin, self.a) = (o, a);
            if normal.two_d() {
                self.b = b;
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

/// A lattice `o + i·a + j·b` fitted to points by least squares: the normal equations `XᵀX` and
/// `XᵀP` of the design matrix (rows `x = (1, i, j)`) and the points (rows `p`), summed point by
/// point so a walk checks each point against the fit so far, and solved by nalgebra for the
/// three coordinates at once.
#[derive(Default)]
struct Normal {
    /// `Σ x xᵀ`.
    xtx: Matrix3<f64>,
    /// `Σ x pᵀ`: row `r` is the points summed with weight `x_r`.
    xtp: Matrix3<f64>,
    /// Points summed.
    count: usize,
    /// Some point is off the first row (`j ≠ 0`).
    rows: bool,
}

impl Normal {
    fn add(&mut self, p: &Vector3<f64>, (i, j): (i64, i64)) {
        let x = Vector3::new(1.0, i as f64, j as f64);
        self.xtx += x * x.transpose();
        self.xtp += x * p.transpose();
        self.count += 1;
        self.rows |= j != 0;
    }

    /// Whether the points span more than one row.
    fn two_d(&self) -> bool {
        self.rows
    }

    /// `(o, a, b)`: with `fixed` pitches, the origin alone (the mean of `p − i·a − j·b`);
    /// else all three (`b` zero on one row). None without enough points to fit.
    fn solve(
        &self,
        fixed: Option<(Vector3<f64>, Vector3<f64>)>,
    ) -> Option<(Vector3<f64>, Vector3<f64>, Vector3<f64>)> {
        if self.count == 0 {
            return None;
        }
        if let Some((a, b)) = fixed {
            let n = self.xtx[(0, 0)];
            let sum = self.xtp.row(0).transpose();
            let o = (sum - a * self.xtx[(0, 1)] - b * self.xtx[(0, 2)]) / n;
            return Some((o, a, b));
        }
        let mut xtx = self.xtx;
        if !self.rows {
            // One row: every `j` is 0, so b's row and column are zero; solve for (o, a).
            xtx[(2, 2)] = 1.0;
        }
        // Rows: o, a, b.
        let fitted = xtx.try_inverse()? * self.xtp;
        let row = |r: usize| fitted.row(r).transpose();
        let b = if self.rows { row(2) } else { Vector3::zeros() };
        Some((row(0), row(1), b))
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
pub(crate) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The points of an `n × m` layer at pitches `a`, `b` from `o`, in `order`, first axis `a`.
    pub(crate) fn walk(
        n: i64,
        m: i64,
        a: Vector3<f64>,
        b: Vector3<f64>,
        order: Order,
    ) -> Vec<Vector3<f64>> {
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
            let (start, w) = LatticeWalk::layers(&both[..k], 1.0, None).pop().unwrap();
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

    /// A joystick operator's scatter: 11.5 mm per axis (20 mm 3-D RMS, the dissertation's online
    /// teaching), matched at the engine's widened tolerances for poses (1.5 × √6 σ) and for
    /// moves (1.5 × √12 σ).
    const JOYSTICK_SIGMA: f64 = 11.5;

    fn joystick_tol() -> WalkTolerance {
        WalkTolerance {
            point: 1.5 * 6f64.sqrt() * JOYSTICK_SIGMA,
            step: 1.5 * 12f64.sqrt() * JOYSTICK_SIGMA,
        }
    }

    /// `meant` placed by hand at [`JOYSTICK_SIGMA`] with the given seed.
    fn by_joystick(meant: &[Vector3<f64>], seed: u64) -> Vec<Vector3<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut gauss = || {
            let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        meant
            .iter()
            .map(|p| p + Vector3::new(gauss(), gauss(), gauss()) * JOYSTICK_SIGMA)
            .collect()
    }

    /// A pallet layer placed by a joystick operator is one walk: each point is checked
    /// against the lattice fitted so far (the first step alone carries two placements' error
    /// into every comparison, and broke most such layers), and the fit predicts the next
    /// slot within the operator's own acceptance (half their effective width, 2.07 σ).
    #[test]
    fn a_layer_taught_by_joystick_is_one_walk() {
        let (x, y) = (Vector3::new(200.0, 0.0, 0.0), Vector3::new(0.0, 250.0, 0.0));
        let meant = walk(3, 4, x, y, Order::Serpentine);
        let (mut whole, mut near, mut predicted) = (0, 0, 0);
        for seed in 1..=20 {
            let taught = by_joystick(&meant, seed);
            if LatticeWalk::fit(&taught, joystick_tol()).is_some() {
                whole += 1;
            }
            for k in 7..meant.len() {
                if let Some(w) = LatticeWalk::fit(&taught[..k], joystick_tol()) {
                    predicted += 1;
                    if (w.next() - meant[k]).norm() <= 2.07 * JOYSTICK_SIGMA {
                        near += 1;
                    }
                }
            }
        }
        // A first row's second step is compared with its first (four placements' error):
        // about one layer in twelve breaks there, whatever is done after it.
        assert!(whole >= 14, "{whole} of 20 layers are one walk");
        assert!(predicted >= 70, "{predicted} of 100 prefixes walked");
        assert!(
            near * 5 >= predicted * 4,
            "{near} of {predicted} within acceptance"
        );
    }

    /// A second layer whose boxes are turned on their rows (rows along the first layer's rows,
    /// at its row pitch) walks at the first layer's fitted pitch from its first two points,
    /// rather than at the pitch those two hand-placed points make.
    #[test]
    fn a_joystick_second_layer_walks_at_the_first_layers_pitch() {
        let (x, y) = (Vector3::new(200.0, 0.0, 0.0), Vector3::new(0.0, 250.0, 0.0));
        let up = Vector3::new(0.0, 0.0, 150.0);
        let first = walk(3, 4, x, y, Order::Serpentine);
        let second: Vec<_> = walk(4, 3, x * 1.25, y * 0.8, Order::Serpentine)
            .iter()
            .map(|p| p + up)
            .collect();
        let (mut laid_err, mut own_err, mut runs) = (0.0, 0.0, 0);
        for seed in 1..=20 {
            let layer = by_joystick(&first, seed);
            let Some(e) = LatticeWalk::fit(&layer, joystick_tol()) else {
                continue;
            };
            let start = by_joystick(&second[..2], seed + 100);
            let (k, w) = LatticeWalk::fit_prefix(&start, joystick_tol(), Some(&e))
                .expect("two points at a pitch of the layer before start a walk");
            assert_eq!(k, 2);
            runs += 1;
            laid_err += (w.next() - second[2]).norm();
            own_err += (start[1] * 2.0 - start[0] - second[2]).norm();
        }
        assert!(runs >= 14, "{runs} first layers walked");
        let (laid, own) = (laid_err / runs as f64, own_err / runs as f64);
        assert!(
            laid <= 2.07 * JOYSTICK_SIGMA,
            "laid: {laid:.1} mm off on average"
        );
        assert!(
            laid < 0.6 * own,
            "laid {laid:.1} mm against its own pitch's {own:.1} mm"
        );
    }

    /// A first row and the second row's first point (the three corners a wizard asks for)
    /// settle the order when one order's row pitch is square to the rows and the other's is
    /// not; a second row starting half way back is only a guess.
    #[test]
    fn three_corners_settle_the_order() {
        let x = Vector3::new(200.0, 0.0, 0.0);
        let row = |start: Vector3<f64>| (0..3).map(move |i| start + x * f64::from(i));
        let o = Vector3::new(900.0, -300.0, 200.0);
        for (next, order) in [
            (o + Vector3::new(0.0, 250.0, 0.0), Order::Raster),
            (o + Vector3::new(400.0, 250.0, 0.0), Order::Serpentine),
        ] {
            let points: Vec<_> = row(o).chain([next]).collect();
            let (k, w) = LatticeWalk::fit_prefix(&points, 1.0, None).expect("a walk");
            assert_eq!((k, w.rows, w.guessed), (4, Some((3, order)), false));
            let want = if order == Order::Raster {
                next + x
            } else {
                next - x
            };
            assert!((w.next() - want).norm() < 1e-9);
            assert!(LatticeWalk::fit(&points, 1.0).is_some());
        }
        let halfway: Vec<_> = row(o)
            .chain([o + Vector3::new(100.0, 250.0, 0.0)])
            .collect();
        let (_, w) = LatticeWalk::fit_prefix(&halfway, 1.0, None).expect("a walk");
        assert!(w.guessed);
        assert!(
            LatticeWalk::fit(&halfway, 1.0).is_none(),
            "a guess is no walk"
        );
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
            assert!(LatticeWalk::layers(&scattered, 1.0, None).is_empty());
        }
        let path = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(100.0, 0.0, 0.0),
            Vector3::new(130.0, 0.0, 0.0),
        ];
        assert!(LatticeWalk::fit(&path, 1.0).is_none());
    }
}
