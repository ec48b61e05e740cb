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
/// Below this `|sin θ5|` the wrist is singular and θ6 is free (chosen as 0 or the hint).
const WRIST_SINGULAR: f64 = 1e-10;

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
    Isometry3::from_parts(Translation3::identity(), UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta))
        * Isometry3::from_parts(
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
    /// applied. At a wrist singularity θ6 (URDF sign) is taken from `hint6`.
    pub fn solve(&self, tip: &Isometry3<f64>, hint6: f64, out: &mut Vec<Joints>) {
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
            let Some(c5) = clamp_unit((pos.dot(&z1) - p.d4) / p.d6) else {
                continue;
            };
            let acos5 = c5.acos();
            for theta5 in [acos5, -acos5] {
                let s5 = theta5.sin();
                let theta6 = if s5.abs() < WRIST_SINGULAR {
                    hint6 * self.signs[5]
                } else {
                    (-z1.dot(&y6) / s5).atan2(z1.dot(&x6) / s5)
                };
                // Frame 4 relative to frame 1 gives the planar 2R problem of θ2, θ3.
                let t01 = dh(theta1, p.d1, 0.0, FRAC_PI_2);
                let t45 = dh(theta5, p.d5, 0.0, -FRAC_PI_2);
                let t56 = dh(theta6, p.d6, 0.0, 0.0);
                let t14 = t01.inv_mul(&t) * (t45 * t56).inverse();
                let (px, py) = (t14.translation.x, t14.translation.y);
                let Some(c3) =
                    clamp_unit((px * px + py * py - p.a2 * p.a2 - p.a3 * p.a3) / (2.0 * p.a2 * p.a3))
                else {
                    continue;
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
    }
}
