//! What a base is worth: whether the arm reaches each target from it, and the smooth surrogate
//! that ranks bases with equal reached counts (see the method in [`super`]). The arm's
//! workspace shell bounds how far out of reach a missed target is; the bounds keep the search
//! near the targets.

use std::f64::consts::PI;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::{BaseMounting, LayoutError, LayoutOptions, Params, Placement, pose_is_finite};
use crate::engine::Pose;
use crate::kinematics::{
    MM_PER_M, Mounting, ReachConfig, Robot, Unreachable, check_reach, wrap_angle,
};

/// Where the base origin may stand.
pub(super) struct Bounds {
    lo: [f64; 3],
    hi: [f64; 3],
    scale: f64,
}

impl Bounds {
    pub(super) fn clamp(&self, p: &Params) -> Params {
        [
            p[0].clamp(self.lo[0], self.hi[0]),
            p[1].clamp(self.lo[1], self.hi[1]),
            p[2].clamp(self.lo[2], self.hi[2]),
            wrap_angle(p[3]),
        ]
    }

    /// How far outside the box, in units of the arm's reach.
    pub(super) fn excess(&self, p: &[f64]) -> f64 {
        (0..3)
            .map(|i| (self.lo[i] - p[i]).max(p[i] - self.hi[i]).max(0.0))
            .sum::<f64>()
            / self.scale
    }
}

/// The arm's workspace for the surrogate: the wrist centre lies within a shell about the
/// shoulder (OPW: exact up to joint limits; other arms: a bound from the link lengths).
#[derive(Debug, Clone, Copy)]
pub(super) struct Shell {
    /// Wrist centre in the flange (`tool0`) frame, mm.
    wrist_in_tip_mm: Vector3<f64>,
    /// Shoulder (J2 axis) in the arm plane: distance from the J1 axis, lateral offset, height.
    shoulder_radial_mm: f64,
    shoulder_lateral_mm: f64,
    pub(super) shoulder_height_mm: f64,
    /// Distance range of the wrist centre from the shoulder.
    inner_mm: f64,
    outer_mm: f64,
    /// How far the TCP reaches from the J1 axis, tool included.
    pub(super) reach_mm: f64,
}

impl Shell {
    fn of(robot: &Robot, tool: &Pose) -> Shell {
        let chain = robot.chain();
        let (axes, tip0) = chain.axes_at(&[0.0; crate::kinematics::DOF]);
        let tool_mm = tool.position().norm();
        if let Some(opw) = robot.opw() {
            let p = opw.parameters();
            let forearm = p.a2.hypot(p.c3);
            // The wrist centre: where axes 4 and 5 meet (the solver checked they do).
            let (w4, o4) = axes[3];
            let (w5, o5) = axes[4];
            let n = w4.cross(&w5);
            let wc = if n.norm_squared() > 1e-12 {
                let t = (o5 - o4).cross(&w5).dot(&n) / n.norm_squared();
                o4 + w4 * t
            } else {
                tip0.translation.vector
            };
            let wrist_in_tip_mm = tip0.inverse_transform_point(&wc.into()).coords * MM_PER_M;
            let shell = Shell {
                wrist_in_tip_mm,
                shoulder_radial_mm: p.a1 * MM_PER_M,
                shoulder_lateral_mm: p.b * MM_PER_M,
                shoulder_height_mm: p.c1 * MM_PER_M,
                inner_mm: (p.c2 - forearm).abs() * MM_PER_M,
                outer_mm: (p.c2 + forearm) * MM_PER_M,
                reach_mm: 0.0,
            };
            return Shell {
                reach_mm: shell.shoulder_radial_mm
                    + shell.outer_mm
                    + wrist_in_tip_mm.norm()
                    + tool_mm,
                ..shell
            };
        }
        let o2 = axes[1].1;
        let mut outer = 0.0;
        for i in 1..crate::kinematics::DOF - 1 {
            outer += (axes[i + 1].1 - axes[i].1).norm();
        }
        outer += (tip0.translation.vector - axes[crate::kinematics::DOF - 1].1).norm();
        let radial = o2.x.hypot(o2.y) * MM_PER_M;
        Shell {
            wrist_in_tip_mm: Vector3::zeros(),
            shoulder_radial_mm: radial,
            shoulder_lateral_mm: 0.0,
            shoulder_height_mm: o2.z * MM_PER_M,
            inner_mm: 0.0,
            outer_mm: outer * MM_PER_M,
            reach_mm: radial + outer * MM_PER_M + tool_mm,
        }
    }

    /// The default place of the targets' median in the base frame: half the reach in front, at
    /// shoulder height.
    pub(super) fn comfort_point_mm(&self) -> Vector3<f64> {
        Vector3::new(0.5 * self.reach_mm, 0.0, self.shoulder_height_mm)
    }

    /// Distance (mm) of a flange pose's wrist centre (base frame) outside the shell.
    fn outside_mm(&self, flange: &Isometry3<f64>) -> f64 {
        let w = flange * nalgebra::Point3::from(self.wrist_in_tip_mm);
        let r = w.x.hypot(w.y);
        let s = (r * r - self.shoulder_lateral_mm.powi(2)).max(0.0).sqrt();
        let dz = w.z - self.shoulder_height_mm;
        // In front of the shoulder, or over the back (J1 turned half a turn).
        let d = (s - self.shoulder_radial_mm)
            .hypot(dz)
            .min((s + self.shoulder_radial_mm).hypot(dz));
        (d - self.outer_mm).max(self.inner_mm - d).max(0.0)
    }
}

/// One target seen from one base.
struct TargetEval {
    reached: bool,
    value: f64,
    margin: Option<f64>,
    sigma: Option<f64>,
}

pub(super) struct Evaluator<'a> {
    robot: &'a Robot,
    targets: &'a [Pose],
    tool: Pose,
    config: ReachConfig,
    pub(super) shell: Shell,
    mount: UnitQuaternion<f64>,
    comfort_margin: f64,
    comfort_sigma: f64,
}

impl<'a> Evaluator<'a> {
    pub(super) fn new(
        robot: &'a Robot,
        targets: &'a [Pose],
        options: &LayoutOptions,
    ) -> Result<Evaluator<'a>, LayoutError> {
        let tool = options.validate()?;
        if targets.is_empty() {
            return Err(LayoutError::NoTargets);
        }
        if let Some(index) = targets.iter().position(|t| !pose_is_finite(t)) {
            return Err(LayoutError::NonFiniteTarget { index });
        }
        let mount = match options.mounting {
            BaseMounting::Floor => UnitQuaternion::identity(),
            BaseMounting::Ceiling => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI),
        };
        Ok(Evaluator {
            robot,
            targets,
            tool,
            config: ReachConfig {
                min_singular_value: options.min_singular_value,
                ..ReachConfig::default()
            },
            shell: Shell::of(robot, &tool),
            mount,
            comfort_margin: options.comfort_joint_margin_rad,
            comfort_sigma: options.comfort_sigma,
        })
    }

    pub(super) fn bounds(&self, margin: Option<f64>) -> Bounds {
        let margin = margin.unwrap_or(self.shell.reach_mm + self.shell.shoulder_height_mm.abs());
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in self.targets {
            let p = t.position();
            for i in 0..3 {
                lo[i] = lo[i].min(p[i] - margin);
                hi[i] = hi[i].max(p[i] + margin);
            }
        }
        Bounds {
            lo,
            hi,
            scale: self.shell.reach_mm.max(1.0),
        }
    }

    fn rotation(&self, yaw: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), wrap_angle(yaw)) * self.mount
    }

    pub(super) fn base_pose(&self, p: &[f64]) -> Pose {
        Pose::from_isometry(Isometry3::from_parts(
            Translation3::new(p[0], p[1], p[2]),
            self.rotation(p[3]),
        ))
    }

    /// The base with yaw `yaw` that puts `point` (work frame) at `in_base` (base frame).
    pub(super) fn base_facing(
        &self,
        point: &Vector3<f64>,
        yaw: f64,
        in_base: &Vector3<f64>,
    ) -> Params {
        let o = point - self.rotation(yaw) * in_base;
        [o.x, o.y, o.z, wrap_angle(yaw)]
    }

    /// `(x, y, z, yaw)` of any base pose: the yaw of its x axis about the vertical.
    pub(super) fn params_of(&self, base: &Pose) -> Params {
        let o = base.position();
        let x = base.rotation() * Vector3::x();
        let yaw = if x.x.hypot(x.y) > 1e-9 {
            x.y.atan2(x.x)
        } else {
            0.0
        };
        [o.x, o.y, o.z, yaw]
    }

    fn target(&self, cell: &Mounting, target: &Pose) -> TargetEval {
        let r = check_reach(self.robot, cell, target, None, &self.config);
        let margin = r.limiting_joint.as_ref().map(|m| m.margin_rad);
        let penalty = match &r.unreachable {
            None => {
                let m = (margin.unwrap_or(0.0) / self.comfort_margin).clamp(0.0, 1.0);
                let s = ((r.sigma_min.unwrap_or(0.0) - self.config.min_singular_value)
                    / (self.comfort_sigma - self.config.min_singular_value))
                    .clamp(0.0, 1.0);
                return TargetEval {
                    reached: true,
                    value: 0.5 + 0.25 * (m + s),
                    margin,
                    sigma: r.sigma_min,
                };
            }
            Some(Unreachable::OutsideReach) => {
                let flange = cell.flange_target(target);
                0.1 + self.shell.outside_mm(flange.isometry()) / (0.1 * self.shell.reach_mm)
            }
            Some(Unreachable::JointLimit { excess_rad, .. }) => excess_rad / self.comfort_margin,
            Some(Unreachable::Singular { sigma_min }) => {
                0.5 * (1.0 - sigma_min / self.config.min_singular_value.max(1e-12)).max(0.0)
            }
        };
        let penalty = if penalty.is_finite() { penalty } else { 1e6 };
        TargetEval {
            reached: false,
            value: 0.5 / (1.0 + penalty),
            margin: None,
            sigma: None,
        }
    }

    fn cell(&self, base: &Pose) -> Mounting {
        Mounting::new(*base, self.tool)
    }

    /// The score of a base on the targets `indices`.
    pub(super) fn score(&self, base: &Pose, indices: &[usize]) -> f64 {
        let cell = self.cell(base);
        let mut reached = 0usize;
        let mut value = 0.0;
        for &i in indices {
            let t = self.target(&cell, &self.targets[i]);
            reached += usize::from(t.reached);
            value += t.value;
        }
        reached as f64 + value / indices.len().max(1) as f64
    }

    /// The full account of a base on all targets.
    pub(super) fn placement(&self, base: &Pose) -> Placement {
        let cell = self.cell(base);
        let mut p = Placement {
            base: *base,
            reached: 0,
            total: self.targets.len(),
            unreached: Vec::new(),
            min_joint_margin_rad: None,
            min_sigma: None,
            score: 0.0,
        };
        let mut value = 0.0;
        for (i, target) in self.targets.iter().enumerate() {
            let t = self.target(&cell, target);
            value += t.value;
            if !t.reached {
                p.unreached.push(i);
                continue;
            }
            p.reached += 1;
            if let Some(m) = t.margin {
                p.min_joint_margin_rad = Some(p.min_joint_margin_rad.map_or(m, |v| v.min(m)));
            }
            if let Some(s) = t.sigma {
                p.min_sigma = Some(p.min_sigma.map_or(s, |v| v.min(s)));
            }
        }
        p.score = p.reached as f64 + value / p.total.max(1) as f64;
        p
    }
}
