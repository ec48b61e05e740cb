//! Closed-form IK of ortho-parallel arms with a spherical wrist (ABB, KUKA, Fanuc, …) through
//! `rs-opw-kinematics`, with its seven parameters, joint signs and offsets derived from the URDF
//! chain rather than typed in per robot.
//!
//! OPW's own zero pose has the whole arm pointing straight up; ours is whatever the URDF says
//! (ABB: forearm horizontal; KUKA: whole arm horizontal). The derivation reads the chain's joint
//! axes at zero, finds the wrist centre, and expresses the URDF zero as OPW angles (the offsets).
//! Whatever rotation remains between OPW's flange and the URDF tip is a constant `post`
//! transform. [`OpwSolver::from_chain`] then checks the result against the chain's own FK and
//! refuses arms it does not fit.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use rs_opw_kinematics::glam::{DQuat, DVec3};
use rs_opw_kinematics::kinematic_traits::{Kinematics, Pose as OpwPose};
use rs_opw_kinematics::kinematics_impl::OPWKinematics;
use rs_opw_kinematics::parameters::opw_kinematics::Parameters;

use super::error::KinematicsError;
use super::urdf::{Chain, DOF, Joints};
use super::{check_against_chain, wrap_angle};

/// Tolerance for "parallel", "through the origin" and the like in the derivation (metres, or
/// cosine deviation).
const GEOM_TOL: f64 = 1e-9;

/// `|sin J5|` below which the wrist counts as singular for choosing J4/J6 near a hint.
const NEAR_SINGULAR_WRIST: f64 = 1e-6;

/// `|sin J5|` below which a solution's wrist phase is recomputed from the pose
/// ([`OpwSolver::correct_wrist_phase`]). The solver's J4 and J6 there are off by about
/// ε/|sin J5|; above this bound that is under 1e-11 rad, well within the FK check.
const WRIST_PHASE_CORRECTION: f64 = 1e-4;

/// The OPW model of one arm.
#[derive(Debug, Clone)]
pub struct OpwSolver {
    params: Parameters,
    kin: OPWKinematics,
    /// OPW flange → URDF tip.
    post: Isometry3<f64>,
    post_inv: Isometry3<f64>,
}

fn unsupported(reason: &str) -> KinematicsError {
    KinematicsError::UnsupportedGeometry(format!("OPW: {reason}"))
}

fn unit_sign(v: f64) -> Option<i8> {
    if (v.abs() - 1.0).abs() < GEOM_TOL {
        Some(if v > 0.0 { 1 } else { -1 })
    } else {
        None
    }
}

/// Closest point on line `(o1, w1)` to line `(o2, w2)` and the distance between the lines.
fn closest_point(
    o1: &Vector3<f64>,
    w1: &Vector3<f64>,
    o2: &Vector3<f64>,
    w2: &Vector3<f64>,
) -> Option<(Vector3<f64>, f64)> {
    let n = w1.cross(w2);
    let nn = n.norm_squared();
    if nn < 1e-12 {
        return None;
    }
    let d = o2 - o1;
    let t1 = d.cross(w2).dot(&n) / nn;
    let t2 = d.cross(w1).dot(&n) / nn;
    let p1 = o1 + w1 * t1;
    let p2 = o2 + w2 * t2;
    Some((p1, (p1 - p2).norm()))
}

fn distance_to_line(p: &Vector3<f64>, o: &Vector3<f64>, w: &Vector3<f64>) -> f64 {
    (p - o).cross(w).norm()
}

impl OpwSolver {
    /// Derives the OPW model of `chain`; fails when the arm is not ortho-parallel with a
    /// spherical wrist in the usual orientation (J1 vertical through the root origin, J2/J3
    /// along y at zero, J5 along y at zero).
    pub fn from_chain(chain: &Chain) -> Result<OpwSolver, KinematicsError> {
        let (axes, tip0) = chain.axes_at(&[0.0; DOF]);
        let [(w1, o1), (w2, o2), (w3, o3), (w4, o4), (w5, o5), (w6, o6)] = axes;
        let s1 = unit_sign(w1.z).ok_or_else(|| unsupported("joint 1 is not vertical"))?;
        if o1.x.abs() > GEOM_TOL || o1.y.abs() > GEOM_TOL {
            return Err(unsupported("joint 1 does not pass through the root origin"));
        }
        let s2 = unit_sign(w2.y).ok_or_else(|| unsupported("joint 2 is not along y at zero"))?;
        let s3 = unit_sign(w3.y).ok_or_else(|| unsupported("joint 3 is not along y at zero"))?;
        let s5 = unit_sign(w5.y).ok_or_else(|| unsupported("joint 5 is not along y at zero"))?;
        let (wc, gap) = closest_point(&o4, &w4, &o5, &w5)
            .ok_or_else(|| unsupported("joints 4 and 5 are parallel"))?;
        if gap > GEOM_TOL || distance_to_line(&wc, &o6, &w6) > GEOM_TOL {
            return Err(unsupported("wrist axes 4, 5, 6 do not meet in one point"));
        }
        let a1 = o2.x;
        let c1 = o2.z;
        let b = wc.y;
        let d23 = Vector3::new(o3.x - o2.x, 0.0, o3.z - o2.z);
        let c2 = d23.norm();
        let theta2 = d23.x.atan2(d23.z);
        let d3w = Vector3::new(wc.x - o3.x, 0.0, wc.z - o3.z);
        if w4.y.abs() > GEOM_TOL {
            return Err(unsupported("joint 4 is not in the arm plane at zero"));
        }
        // Forearm direction, pointing away from joint 3.
        let u = if d3w.dot(&w4) >= 0.0 { w4 } else { -w4 };
        let s4 = unit_sign(w4.dot(&u)).ok_or_else(|| unsupported("joint 4 axis"))?;
        let s6 = unit_sign(w6.dot(&u))
            .ok_or_else(|| unsupported("joint 6 is not along joint 4 at zero"))?;
        let theta23 = u.x.atan2(u.z);
        let c3 = d3w.dot(&u);
        let a2 = d3w.dot(&Vector3::new(theta23.cos(), 0.0, -theta23.sin()));
        let c4 = (tip0.translation.vector - wc).dot(&u);
        let params = Parameters {
            a1,
            a2,
            b,
            c1,
            c2,
            c3,
            c4,
            offsets: [
                0.0,
                wrap_angle(-theta2),
                wrap_angle(-(theta23 - theta2)),
                0.0,
                0.0,
                0.0,
            ],
            sign_corrections: [s1, s2, s3, s4, s5, s6],
            dof: 6,
        };
        let kin = OPWKinematics::new(params);
        let opw0 = kin
            .try_forward(&[0.0; DOF])
            .map_err(|e| unsupported(&e.to_string()))?;
        let post = to_iso(&opw0).inv_mul(&tip0);
        let solver = OpwSolver {
            params,
            kin,
            post,
            post_inv: post.inverse(),
        };
        check_against_chain(chain, |q| solver.fk(q)).map_err(|err| {
            unsupported(&format!("derived model disagrees with the URDF by {err:e}"))
        })?;
        Ok(solver)
    }

    /// The derived OPW parameters (metres, radians), for inspection.
    pub fn parameters(&self) -> &Parameters {
        &self.params
    }

    /// Tip pose (metres) by the OPW model, for checking it against the chain.
    pub fn fk(&self, q: &Joints) -> Option<Isometry3<f64>> {
        self.kin.try_forward(q).ok().map(|p| to_iso(&p) * self.post)
    }

    /// All OPW solutions for a tip pose (metres), each joint in `(-π, π]`, limits not applied.
    /// At a wrist singularity J4 and J6 are chosen near `hint` (near zero without one).
    pub fn solve(&self, tip: &Isometry3<f64>, hint: Option<&Joints>, out: &mut Vec<Joints>) {
        let target = tip * self.post_inv;
        let Ok(pose) = from_iso(&target) else {
            return;
        };
        // `inverse_continuing` (J4/J6 near the hint at a singular wrist) costs about half as
        // much again as `inverse`, and only matters near J5 = 0: use it only there.
        let mut solutions = self.kin.inverse(&pose);
        if let Some(h) = hint
            && solutions
                .iter()
                .any(|q| q[4].sin().abs() < NEAR_SINGULAR_WRIST)
        {
            solutions = self.kin.inverse_continuing(&pose, h);
        }
        for mut q in solutions {
            for v in q.iter_mut() {
                *v = wrap_angle(*v);
            }
            if q.iter().all(|v| v.is_finite()) {
                if q[4].sin().abs() < WRIST_PHASE_CORRECTION {
                    self.correct_wrist_phase(&target, &mut q);
                }
                out.push(q);
            }
        }
    }

    /// Near J5 = 0 (or ±180°) the solver finds J4 and J6 each as the angle of a vector of
    /// length |sin J5|, so each is off by about ε/|sin J5| rad, and so is the wrist phase (J4 ± J6,
    /// the rotation about the aligned axes 4 and 6) — though the pose fixes the phase to full
    /// precision. At |J5| = 1e-7 an IRB 140's tip was turned 3e-9 rad about its axis, the FK
    /// check dropped the solution, and a reachable pose was reported beyond a joint limit
    /// (between about 1e-9 and 1e-6 rad neither this nor the solver's exact-pole candidate,
    /// J5 = 0, is within the check's 1e-9 rad). The split between J4 and J6 is what the pose
    /// barely determines and is kept; the rotation about the flange's z axis (joint 6) that
    /// separates the solution from the target is turned away with J6 alone.
    fn correct_wrist_phase(&self, target: &Isometry3<f64>, q: &mut Joints) {
        let Ok(reached) = self.kin.try_forward(q) else {
            return;
        };
        // What is left to turn, in the flange frame: about z for a wrist near its pole.
        let left = (to_iso(&reached).rotation.inverse() * target.rotation).to_rotation_matrix();
        let about_z = (left[(1, 0)] - left[(0, 1)]).atan2(left[(0, 0)] + left[(1, 1)]);
        q[5] = wrap_angle(q[5] + f64::from(self.params.sign_corrections[5]) * about_z);
    }
}

fn to_iso(p: &OpwPose) -> Isometry3<f64> {
    let t = p.translation;
    let r = p.rotation;
    Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::new_normalize(Quaternion::new(r.w, r.x, r.y, r.z)),
    )
}

fn from_iso(iso: &Isometry3<f64>) -> Result<OpwPose, rs_opw_kinematics::pose::PoseError> {
    let t = iso.translation.vector;
    let q = iso.rotation;
    OpwPose::try_from_parts(
        DVec3::new(t.x, t.y, t.z),
        DQuat::from_xyzw(q.i, q.j, q.k, q.w),
    )
}
