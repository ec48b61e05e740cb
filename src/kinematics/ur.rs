//! Closed-form IK of the Universal Robots family (UR3/5/10/16, CB3 and e-Series): shoulder,
//! elbow and wrist-1 axes parallel, no spherical wrist. Eight solutions in general, from the
//! standard analytic derivation on UR's DH table (`d1, a2, a3, d4, d5, d6`; all other DH lengths
//! zero, twists `π/2, 0, 0, π/2, −π/2, 0`).
//!
//! The DH lengths and the joint signs are read off the URDF chain at zero, and any constant
//! rotation between the DH flange and the URDF tip becomes a `post` transform; the model is then
//! checked against the chain's own FK.

use std::f64::consts::FRAC_PI_2;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::error::KinematicsError;
use super::urdf::{Chain, DOF, Joints};
use super::{check_against_chain, wrap_angle};

const GEOM_TOL: f64 = 1e-9;
/// How far outside `[-1, 1]` an acos argument may stray by rounding and still be clamped.
const CLAMP_TOL: f64 = 1e-10;
/// Below this `|sin θ5|` the wrist is (nearly) singular: besides the computed θ6 (noise at the
/// singularity itself), the one chosen by [`UrSolver::singular_theta6`] is tried.
const WRIST_SINGULAR: f64 = 1e-6;

/// UR DH lengths in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UrParameters {
    pub d1: f64,
    pub a2: f64,
    pub a3: f64,
    pub d4: f64,
    pub d5: f64,
    pub d6: f64,
}

/// The analytic UR model of one arm.
#[derive(Debug, Clone)]
pub struct UrSolver {
    p: UrParameters,
    /// URDF joint value × sign = DH joint value.
    signs: [f64; DOF],
    post: Isometry3<f64>,
    post_inv: Isometry3<f64>,
}

fn unsupported(reason: &str) -> KinematicsError {
    KinematicsError::UnsupportedGeometry(format!("UR: {reason}"))
}

fn unit_sign(v: f64, what: &str) -> Result<f64, KinematicsError> {
    if (v.abs() - 1.0).abs() < GEOM_TOL {
        Ok(v.signum())
    } else {
        Err(unsupported(what))
    }
}

/// One DH link transform `Rz(θ) Tz(d) Tx(a) Rx(α)`.
fn dh(theta: f64, d: f64, a: f64, alpha: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta),
    ) * Isometry3::from_parts(
        Translation3::new(a, 0.0, d),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), alpha),
    )
}

fn clamp_unit(x: f64) -> Option<f64> {
    if x.abs() <= 1.0 {
        Some(x)
    } else if x.abs() <= 1.0 + CLAMP_TOL {
        Some(x.signum())
    } else {
        None
    }
}

impl UrSolver {
    /// Derives the UR model of `chain`; fails for arms of another kind.
    pub fn from_chain(chain: &Chain) -> Result<UrSolver, KinematicsError> {
        let (axes, tip0) = chain.axes_at(&[0.0; DOF]);
        let [(w1, o1), (w2, o2), (w3, o3), (w4, o4), (w5, o5), (w6, o6)] = axes;
        // DH axis directions at zero: z, −y, −y, −y, −z, −y.
        let signs = [
            unit_sign(w1.z, "joint 1 is not vertical")?,
            -unit_sign(w2.y, "joint 2 is not along y at zero")?,
            -unit_sign(w3.y, "joint 3 is not along y at zero")?,
            -unit_sign(w4.y, "joint 4 is not along y at zero")?,
            -unit_sign(w5.z, "joint 5 is not vertical at zero")?,
            -unit_sign(w6.y, "joint 6 is not along y at zero")?,
        ];
        if o1.x.abs() > GEOM_TOL || o1.y.abs() > GEOM_TOL || o2.x.abs() > GEOM_TOL {
            return Err(unsupported("joint 1 or 2 is off the base axis"));
        }
        let p = UrParameters {
            d1: o2.z,
            a2: o3.x - o2.x,
            a3: o4.x - o3.x,
            d4: -o5.y,
            d5: o2.z - o6.z,
            d6: -tip0.translation.vector.y + o5.y,
        };
        let mut solver = UrSolver {
            p,
            signs,
            post: Isometry3::identity(),
            post_inv: Isometry3::identity(),
        };
        let post = solver.dh_fk(&[0.0; DOF]).inv_mul(&tip0);
        solver.post = post;
        solver.post_inv = post.inverse();
        check_against_chain(chain, |q| Some(solver.fk(q))).map_err(|err| {
            unsupported(&format!("derived model disagrees with the URDF by {err:e}"))
        })?;
        Ok(solver)
    }

    pub fn parameters(&self) -> &UrParameters {
        &self.p
    }

    /// DH flange pose for DH joint values.
    fn dh_fk(&self, t: &Joints) -> Isometry3<f64> {
        let p = &self.p;
        dh(t[0], p.d1, 0.0, FRAC_PI_2)
            * dh(t[1], 0.0, p.a2, 0.0)
            * dh(t[2], 0.0, p.a3, 0.0)
            * dh(t[3], p.d4, 0.0, FRAC_PI_2)
            * dh(t[4], p.d5, 0.0, -FRAC_PI_2)
            * dh(t[5], p.d6, 0.0, 0.0)
    }

    /// Tip pose (metres) by the analytic model, for URDF joint values.
    pub fn fk(&self, q: &Joints) -> Isometry3<f64> {
        let mut t = [0.0; DOF];
        for i in 0..DOF {
            t[i] = q[i] * self.signs[i];
        }
        self.dh_fk(&t) * self.post
    }

    /// All analytic solutions for a tip pose (metres), each joint in `(-π, π]`, limits not
    /// applied. At a wrist singularity the free split of θ2…θ4 and θ6 is chosen near `hint`.
    pub fn solve(&self, tip: &Isometry3<f64>, hint: Option<&Joints>, out: &mut Vec<Joints>) {
        let p = &self.p;
        let t = tip * self.post_inv;
        let r = t.rotation.to_rotation_matrix();
        let x6 = r.matrix().column(0).into_owned();
        let y6 = r.matrix().column(1).into_owned();
        let z6 = r.matrix().column(2).into_owned();
        let pos = t.translation.vector;
        // Wrist-2 centre (frame 5 origin).
        let p5 = pos - z6 * p.d6;
        let rho = p5.x.hypot(p5.y);
        if rho < 1e-12 {
            return; // shoulder singularity with the wrist on the base axis: θ1 is undefined
        }
        let Some(s) = clamp_unit(p.d4 / rho) else {
            return; // inside the cylinder of radius d4 around the base axis
        };
        let phi = p5.y.atan2(p5.x);
        let asin = s.asin();
        for theta1 in [phi + asin, phi + std::f64::consts::PI - asin] {
            let (s1, c1) = theta1.sin_cos();
            let z1 = Vector3::new(s1, -c1, 0.0);
            // z1 in the flange frame is (s5·c6, −s5·s6, c5): θ5 from atan2 stays accurate near
            // the wrist singularity, where acos of c5 would lose half the digits.
            let (zx, zy, zz) = (z1.dot(&x6), z1.dot(&y6), z1.dot(&z6));
            let s5_abs = zx.hypot(zy);
            let acos5 = s5_abs.atan2(zz);
            for theta5 in [acos5, -acos5] {
                let s5 = theta5.sin();
                let computed = (-zy / s5).atan2(zx / s5);
                if computed.is_finite() {
                    self.arm(&t, theta1, theta5, computed, out);
                }
                if s5.abs() < WRIST_SINGULAR
                    && let Some(theta6) = self.singular_theta6(&t, theta1, zz, &p5, hint)
                {
                    self.arm(&t, theta1, theta5, theta6, out);
                }
            }
        }
    }

    /// θ6 at the wrist singularity (θ5 = 0 or π, `c5` its cosine). Joint 6 is then parallel to
    /// joints 2–4: the pose fixes φ = θ2 + θ3 + θ4 ± θ6 but not the split, and φ moves frame 4
    /// on a circle of radius d5 around frame 5, so only an arc of φ lets the 2R arm reach.
    /// Picks φ in that arc nearest the hint's (mid-arc without a hint) and returns its θ6.
    fn singular_theta6(
        &self,
        t: &Isometry3<f64>,
        theta1: f64,
        c5: f64,
        p5: &Vector3<f64>,
        hint: Option<&Joints>,
    ) -> Option<f64> {
        let p = &self.p;
        let t01 = dh(theta1, p.d1, 0.0, FRAC_PI_2);
        let p5_1 = t01.inverse_transform_point(&(*p5).into());
        let (a, b) = (p5_1.x, p5_1.y);
        let r = a.hypot(b);
        if r < 1e-12 || p.d5.abs() < 1e-12 {
            return None;
        }
        let beta = b.atan2(a);
        let (long, short) = (p.a2.abs() + p.a3.abs(), (p.a2.abs() - p.a3.abs()).abs());
        let base = a * a + b * b + p.d5 * p.d5;
        let lo = ((base - long * long) / (2.0 * p.d5 * r)).max(-1.0);
        let hi = ((base - short * short) / (2.0 * p.d5 * r)).min(1.0);
        if lo > hi {
            return None;
        }
        let phi = match hint {
            Some(h) => {
                let phi_h = (1..4).map(|i| h[i] * self.signs[i]).sum::<f64>();
                let s = (phi_h - beta).sin().clamp(lo, hi);
                let candidates = [beta + s.asin(), beta + std::f64::consts::PI - s.asin()];
                let dist = |x: f64| wrap_angle(x - phi_h).abs();
                if dist(candidates[0]) <= dist(candidates[1]) {
                    candidates[0]
                } else {
                    candidates[1]
                }
            }
            None => beta + (0.5 * (lo + hi)).asin(),
        };
        // Flange rotation in frame 1: Rz(φ + θ6) when c5 > 0, Rz(φ − θ6)·Ry(π) when c5 < 0.
        let r16 = (t01.rotation.inverse() * t.rotation).to_rotation_matrix();
        let psi = if c5 > 0.0 {
            r16[(1, 0)].atan2(r16[(0, 0)])
        } else {
            (-r16[(1, 0)]).atan2(-r16[(0, 0)])
        };
        Some(if c5 > 0.0 { psi - phi } else { phi - psi })
    }

    /// θ2, θ3, θ4 for given θ1, θ5, θ6 (DH values): the planar 2R problem of frame 4 in frame 1.
    fn arm(
        &self,
        t: &Isometry3<f64>,
        theta1: f64,
        theta5: f64,
        theta6: f64,
        out: &mut Vec<Joints>,
    ) {
        let p = &self.p;
        let t01 = dh(theta1, p.d1, 0.0, FRAC_PI_2);
        let t45 = dh(theta5, p.d5, 0.0, -FRAC_PI_2);
        let t56 = dh(theta6, p.d6, 0.0, 0.0);
        let t14 = t01.inv_mul(t) * (t45 * t56).inverse();
        let (px, py) = (t14.translation.x, t14.translation.y);
        let Some(c3) =
            clamp_unit((px * px + py * py - p.a2 * p.a2 - p.a3 * p.a3) / (2.0 * p.a2 * p.a3))
        else {
            return;
        };
        let acos3 = c3.acos();
        let r14 = t14.rotation.to_rotation_matrix();
        let theta234 = r14[(1, 0)].atan2(r14[(0, 0)]);
        for theta3 in [acos3, -acos3] {
            let s3 = theta3.sin();
            let theta2 = py.atan2(px) - (p.a3 * s3).atan2(p.a2 + p.a3 * c3);
            let theta4 = theta234 - theta2 - theta3;
            let dh_q = [theta1, theta2, theta3, theta4, theta5, theta6];
            let mut q = [0.0; DOF];
            for i in 0..DOF {
                q[i] = wrap_angle(dh_q[i] * self.signs[i]);
            }
            if q.iter().all(|v| v.is_finite()) {
                out.push(q);
            }
        }
    }
}
