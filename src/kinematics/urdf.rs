//! Loading a serial arm from URDF, forward kinematics and the geometric Jacobian of its chain.
//!
//! The chain is everything between the root link and the tip link (`tool0` when the file has
//! one): six revolute joints, with fixed joints folded into the origins around them. Lengths are
//! metres here, as in the URDF; conversion to the crate's millimetres happens in
//! [`super::units`] only.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Isometry3, Matrix6, Translation3, Unit, UnitQuaternion, Vector3};
use serde::Serialize;

use super::error::KinematicsError;

/// Number of joints of the arms this module handles.
pub const DOF: usize = 6;

/// Joint values in radians, URDF joint order and sign.
pub type Joints = [f64; DOF];

/// The name used for the tip link when the caller does not name one.
pub const DEFAULT_TIP: &str = "tool0";

/// One joint as the service describes it: name, position limits (rad) and velocity limit (rad/s).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointSpec {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
}

impl JointSpec {
    /// Radians from `q` to the nearer limit; negative when `q` is outside the range.
    pub fn margin(&self, q: f64) -> f64 {
        (q - self.lower).min(self.upper - q)
    }
}

/// A joint axis in the root frame: unit direction and a point on it.
pub type JointAxis = (Vector3<f64>, Vector3<f64>);

/// A serial chain of six revolute joints from the root link to the tip link.
#[derive(Debug, Clone)]
pub struct Chain {
    name: String,
    root: String,
    tip: String,
    /// Frame of joint i relative to the frame of joint i-1 (or the root for i = 0), before the
    /// joint's own rotation.
    origins: [Isometry3<f64>; DOF],
    /// Joint axes in their own joint frames.
    axes: [Unit<Vector3<f64>>; DOF],
    /// Tip relative to the last joint's frame (after its rotation).
    tip_offset: Isometry3<f64>,
    joints: Vec<JointSpec>,
}

impl Chain {
    /// Parses URDF text and extracts the chain to `tip` (default: `tool0`, else the only leaf).
    pub fn from_urdf_str(urdf: &str, tip: Option<&str>) -> Result<Chain, KinematicsError> {
        let robot =
            urdf_rs::read_from_string(urdf).map_err(|e| KinematicsError::Urdf(e.to_string()))?;
        Chain::from_robot(&robot, tip)
    }

    /// Reads and parses a URDF file (the only I/O of the module besides listing `robots/`).
    pub fn from_urdf_file(path: &Path, tip: Option<&str>) -> Result<Chain, KinematicsError> {
        let text = std::fs::read_to_string(path).map_err(|e| KinematicsError::io(path, &e))?;
        Chain::from_urdf_str(&text, tip)
    }

    /// Extracts the chain from a parsed URDF robot.
    pub fn from_robot(robot: &urdf_rs::Robot, tip: Option<&str>) -> Result<Chain, KinematicsError> {
        let links: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
        // child link → joint index; parent link → joint indices.
        let mut parent_joint: HashMap<&str, usize> = HashMap::new();
        let mut child_joints: HashMap<&str, Vec<usize>> = HashMap::new();
        for (i, j) in robot.joints.iter().enumerate() {
            for link in [&j.parent.link, &j.child.link] {
                if !links.contains(&link.as_str()) {
                    return Err(KinematicsError::UnknownLink {
                        joint: j.name.clone(),
                        link: link.clone(),
                    });
                }
            }
            if parent_joint.insert(j.child.link.as_str(), i).is_some() {
                return Err(KinematicsError::SeveralParents(j.child.link.clone()));
            }
            child_joints
                .entry(j.parent.link.as_str())
                .or_default()
                .push(i);
        }
        let roots: Vec<&str> = links
            .iter()
            .copied()
            .filter(|l| !parent_joint.contains_key(l))
            .collect();
        let root = match roots.as_slice() {
            [] => return Err(KinematicsError::NoRoot),
            [r] => *r,
            _ => {
                return Err(KinematicsError::SeveralRoots(
                    roots.iter().map(|s| s.to_string()).collect(),
                ));
            }
        };
        let tip = match tip {
            Some(t) => t.to_string(),
            None if links.contains(&DEFAULT_TIP) => DEFAULT_TIP.to_string(),
            None => {
                let leaves: Vec<&str> = links
                    .iter()
                    .copied()
                    .filter(|l| !child_joints.contains_key(l))
                    .collect();
                match leaves.as_slice() {
                    [l] => l.to_string(),
                    _ => {
                        return Err(KinematicsError::NotSerial {
                            link: root.to_string(),
                            children: leaves.len(),
                        });
                    }
                }
            }
        };
        if !links.contains(&tip.as_str()) {
            return Err(KinematicsError::UnknownTip(tip));
        }
        // Walk up from the tip to the root.
        let mut path: Vec<usize> = Vec::new();
        let mut link = tip.as_str();
        while let Some(&j) = parent_joint.get(link) {
            if path.len() > robot.joints.len() {
                return Err(KinematicsError::NoRoot); // a cycle
            }
            path.push(j);
            link = robot.joints[j].parent.link.as_str();
        }
        if link != root {
            return Err(KinematicsError::UnknownTip(tip));
        }
        path.reverse();
        // Every moving joint of the file must lie on the path: a moving side branch (a second
        // arm, a gripper finger) makes this no serial arm.
        for (i, j) in robot.joints.iter().enumerate() {
            let moving = !matches!(j.joint_type, urdf_rs::JointType::Fixed);
            if moving && !path.contains(&i) {
                let parent = j.parent.link.as_str();
                let children = child_joints.get(parent).map_or(0, |c| c.len());
                return Err(KinematicsError::NotSerial {
                    link: parent.to_string(),
                    children,
                });
            }
        }
        let revolute = path
            .iter()
            .filter(|&&j| !matches!(robot.joints[j].joint_type, urdf_rs::JointType::Fixed))
            .count();
        if revolute != DOF {
            return Err(KinematicsError::JointCount {
                expected: DOF,
                found: revolute,
                root: root.to_string(),
                tip,
            });
        }

        let mut origins = [Isometry3::identity(); DOF];
        let mut axes = [Vector3::z_axis(); DOF];
        let mut joints = Vec::with_capacity(DOF);
        let mut pending = Isometry3::identity();
        for &j in &path {
            let joint = &robot.joints[j];
            let origin = origin_of(joint)?;
            match joint.joint_type {
                urdf_rs::JointType::Fixed => pending *= origin,
                urdf_rs::JointType::Revolute => {
                    let k = joints.len();
                    origins[k] = pending * origin;
                    pending = Isometry3::identity();
                    let a = Vector3::new(joint.axis.xyz[0], joint.axis.xyz[1], joint.axis.xyz[2]);
                    if !a.iter().all(|v| v.is_finite()) || a.norm() < 1e-12 {
                        return Err(KinematicsError::BadAxis {
                            joint: joint.name.clone(),
                        });
                    }
                    axes[k] = Unit::new_normalize(a);
                    let (lower, upper) = (joint.limit.lower, joint.limit.upper);
                    let velocity = joint.limit.velocity;
                    let usable = lower.is_finite()
                        && upper.is_finite()
                        && lower < upper
                        && velocity.is_finite()
                        && velocity > 0.0;
                    if !usable {
                        return Err(KinematicsError::BadLimits {
                            joint: joint.name.clone(),
                            lower,
                            upper,
                        });
                    }
                    joints.push(JointSpec {
                        name: joint.name.clone(),
                        lower,
                        upper,
                        velocity,
                    });
                }
                ref other => {
                    return Err(KinematicsError::UnsupportedJointType {
                        joint: joint.name.clone(),
                        kind: format!("{other:?}").to_lowercase(),
                    });
                }
            }
        }
        Ok(Chain {
            name: robot.name.clone(),
            root: root.to_string(),
            tip,
            origins,
            axes,
            tip_offset: pending,
            joints,
        })
    }

    /// The robot name given in the URDF.
    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn root(&self) -> &str {
        &self.root
    }

    pub fn tip(&self) -> &str {
        &self.tip
    }

    /// The six joints, base first.
    pub fn joints(&self) -> &[JointSpec] {
        &self.joints
    }

    /// Tip pose in the root frame, metres.
    pub fn fk(&self, q: &Joints) -> Isometry3<f64> {
        let mut t = Isometry3::identity();
        for (i, &qi) in q.iter().enumerate() {
            t = t * self.origins[i] * UnitQuaternion::from_axis_angle(&self.axes[i], qi);
        }
        t * self.tip_offset
    }

    /// The frame of each joint after its rotation, in the root frame, metres: drawing a
    /// segment from the root through these origins to [`Chain::fk`]'s tip draws the arm.
    pub fn joint_frames(&self, q: &Joints) -> [Isometry3<f64>; DOF] {
        let mut t = Isometry3::identity();
        let mut out = [Isometry3::identity(); DOF];
        for (i, &qi) in q.iter().enumerate() {
            t = t * self.origins[i] * UnitQuaternion::from_axis_angle(&self.axes[i], qi);
            out[i] = t;
        }
        out
    }

    /// Each joint's axis (unit, root frame) and a point on it, plus the tip pose; metres.
    pub fn axes_at(&self, q: &Joints) -> ([JointAxis; DOF], Isometry3<f64>) {
        let mut t = Isometry3::identity();
        let mut out = [(Vector3::zeros(), Vector3::zeros()); DOF];
        for (i, &qi) in q.iter().enumerate() {
            t *= self.origins[i];
            out[i] = (t.rotation * self.axes[i].into_inner(), t.translation.vector);
            t *= UnitQuaternion::from_axis_angle(&self.axes[i], qi);
        }
        (out, t * self.tip_offset)
    }

    /// Geometric Jacobian at the tip, in the root frame: rows 0–2 linear velocity (m/s per rad/s),
    /// rows 3–5 angular velocity.
    pub fn jacobian(&self, q: &Joints) -> Matrix6<f64> {
        let (axes, tip) = self.axes_at(q);
        let p = tip.translation.vector;
        let mut j = Matrix6::zeros();
        for (i, (w, o)) in axes.iter().enumerate() {
            let v = w.cross(&(p - o));
            j.fixed_view_mut::<3, 1>(0, i).copy_from(&v);
            j.fixed_view_mut::<3, 1>(3, i).copy_from(w);
        }
        j
    }
}

fn origin_of(joint: &urdf_rs::Joint) -> Result<Isometry3<f64>, KinematicsError> {
    let xyz = joint.origin.xyz;
    let rpy = joint.origin.rpy;
    if !xyz.iter().chain(rpy.iter()).all(|v| v.is_finite()) {
        return Err(KinematicsError::BadOrigin {
            joint: joint.name.clone(),
        });
    }
    // URDF rpy: fixed-axis roll about x, then pitch about y, then yaw about z.
    Ok(Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    ))
}
