//! The least-squares rigid transform between two sets of corresponding points, which the
//! template expert ([`super::template`]) and the noise estimate ([`super::noise::estimate`])
//! both fit.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// The rigid transform that takes the points `a` closest to their counterparts `b` (least
/// squares: Kabsch, with the reflection fixed); `None` when the SVD fails or the points are not
/// finite.
pub fn rigid_fit(a: &[Point3<f64>], b: &[Point3<f64>]) -> Option<Isometry3<f64>> {
    let n = a.len() as f64;
    let ca = a.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let cb = b.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
    let mut h = Matrix3::zeros();
    for (p, q) in a.iter().zip(b) {
        h += (p.coords - ca) * (q.coords - cb).transpose();
    }
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    if !r.iter().all(|x| x.is_finite()) {
        return None;
    }
    // U and V are orthonormal, so r is a rotation already. (`UnitQuaternion::from_matrix`
    // iterates towards one without a bound and never ended on some near-degenerate fits.)
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cb - rotation * ca;
    Some(Isometry3::from_parts(Translation3::from(t), rotation))
}
