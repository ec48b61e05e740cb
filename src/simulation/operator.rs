//! The simulated operator: how long teaching a waypoint takes, how precisely it is placed, and
//! what the operator does with a suggestion.
//!
//! **Time of a manually taught waypoint** = the arm's jog from where it is to the target
//! ([`Arm::cartesian_jog`]: the arm cannot go faster) + the operator's *aiming* time + the time to
//! record. Aiming follows Fitts' law in its Shannon form (MacKenzie 1992) with translation and
//! rotation difficulties added (as Stoelen & Akin 2010 do for combined 3-D moves):
//!
//! ```text
//! aim = k · (a + b · (log2(1 + D/W) + log2(1 + θ/W_θ)))      (0 when already within W/2, W_θ/2)
//! ```
//!
//! `D`, `θ`: distance and rotation from the arm's pose to the target. `W = 4.133·σ` is the
//! effective target width of an operator whose end points scatter with one-sigma `σ` per axis
//! (Crossman's effective width, as in MacKenzie 1992), so a precise operator aims at a narrower
//! target and takes longer. `a = 0.99 s`, `b = 0.22 s/bit` are the rate-controlled joystick's
//! constants of Card, English & Burr (1978). A robot is slower to aim than a cursor (six
//! degrees of freedom, jog-mode switches, looking from several sides), so `k` scales both: it is
//! set so that the dissertation's lab waypoint (186 mm mean spacing, online precision) takes
//! 292.2 s / 9.75 = 30.0 s, the dissertation's baseline (Table 4.1; tasks of 13, 6, 10 and 10
//! waypoints).
//!
//! **Precision.** A manually placed waypoint is the intended one plus Gaussian error:
//! [`OperatorModel::online`] has a 3-D RMS error of 20 mm (the dissertation's ~2 cm one-sigma for
//! online teaching without external references, §3), [`OperatorModel::precise`] 0.05 mm (what
//! offline-programmed, arc-welding-grade waypoints have).
//!
//! **A suggestion** (the service's prediction for this waypoint) is handled as in the
//! dissertation's lab study (§4.5.3): the operator hears it, lets the arm move there (a joint move
//! while a button is held), looks, and then
//!
//! - *accepts* it when it is within tolerance of the intended target (records it as is:
//!   feedback `accepted`);
//! - otherwise *fine-tunes* it (jogs from the suggestion to the target and records: feedback
//!   `adjusted` with the final pose) or *rejects* it (undo: the arm goes back, and the waypoint is
//!   taught by hand: feedback `rejected`), whichever the time model says is quicker. That is a
//!   rational operator who judges distances correctly, an assumption in the suggestion's favour.
//!
//! Looking at a suggestion costs [`OperatorModel::look_s`] whatever follows: 10 % of the
//! dissertation's mean waypoint time, the dissertation's own cost of a suggestion (§4.3.5: a useful
//! prediction saves about 90 %, a useless one costs about 10 %). A suggestion the service flags as
//! unreachable is rejected after a look, without moving. A suggestion made after the routine's last
//! waypoint is dismissed after a look (feedback `rejected`).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use serde::Serialize;

use super::arm::Arm;
use crate::engine::Pose;

/// The dissertation's baseline programming time of one lab task, s (Table 4.1).
pub const DISSERTATION_BASELINE_S: f64 = 292.2;
/// Mean waypoints of the dissertation's four lab tasks (13, 6, 10, 10; §4.5).
pub const DISSERTATION_TASK_WAYPOINTS: f64 = 9.75;
/// Mean distance between waypoints of the dissertation's lab tasks, mm (§4.5).
pub const DISSERTATION_SPACING_MM: f64 = 186.0;
/// The dissertation's online repeatability: one-sigma Cartesian error, mm (§3).
pub const DISSERTATION_ONLINE_REPEATABILITY_MM: f64 = 20.0;
/// Effective target width per one-sigma of end-point scatter (Crossman; MacKenzie 1992).
pub const EFFECTIVE_WIDTH_PER_SIGMA: f64 = 4.133;
/// Rate-controlled joystick, Card, English & Burr (1978): intercept, s.
pub const JOYSTICK_A_S: f64 = 0.99;
/// … and slope, s/bit.
pub const JOYSTICK_B_S: f64 = 0.22;
/// Keystroke-level model (Card, Moran & Newell 1980): mental preparation M 1.35 s + one
/// keystroke K 0.28 s, the time to decide to record and press the button.
pub const RECORD_S: f64 = 1.35 + 0.28;

/// What the operator does with a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    Accept,
    FineTune,
    Reject,
    /// Offered after the routine's last waypoint: there is nothing left to teach.
    Dismiss,
}

/// The feedback the service expects for a decision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feedback {
    Accepted,
    /// With the pose finally taught.
    Adjusted(Pose),
    Rejected,
}

/// A suggestion as the operator sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Suggestion {
    pub pose: Pose,
    /// False when the service offers it flagged as out of the arm's reach.
    pub reachable: bool,
}

/// Where the time of one step went, simulated seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Time {
    /// The arm moving (jogs and automatic moves).
    pub travel_s: f64,
    /// The operator aiming (Fitts).
    pub aim_s: f64,
    /// Looking at suggestions.
    pub look_s: f64,
    /// Recording waypoints.
    pub record_s: f64,
}

impl Time {
    pub fn total(&self) -> f64 {
        self.travel_s + self.aim_s + self.look_s + self.record_s
    }

    pub fn add(&mut self, other: &Time) {
        self.travel_s += other.travel_s;
        self.aim_s += other.aim_s;
        self.look_s += other.look_s;
        self.record_s += other.record_s;
    }
}

/// One taught waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The pose to record.
    pub pose: Pose,
    /// What was done with the suggestion, when there was one.
    pub decision: Option<Decision>,
    pub feedback: Option<Feedback>,
    pub time: Time,
    /// Whether the recorded pose is within the arm's reach.
    pub reachable: bool,
}

/// The operator's parameters (see the module documentation for their sources).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OperatorModel {
    pub name: String,
    /// 3-D RMS position error of a manually placed waypoint, mm.
    pub repeatability_mm: f64,
    /// 3-D RMS orientation error of a manually placed waypoint, rad.
    pub repeatability_rad: f64,
    /// A suggestion within this distance of the intended target is accepted as is, mm …
    pub accept_mm: f64,
    /// … if also within this angle, rad.
    pub accept_rad: f64,
    /// Fitts intercept and slope (before scaling), s and s/bit.
    pub fitts_a_s: f64,
    pub fitts_b_s: f64,
    /// The factor `k` on both.
    pub fitts_scale: f64,
    /// Looking at a suggestion, s.
    pub look_s: f64,
    /// Recording a waypoint, s.
    pub record_s: f64,
    /// The arm moves to a suggestion before the operator judges it (the dissertation's pendant);
    /// when false the operator judges it on a display and a rejection costs only the look.
    pub inspect_by_moving: bool,
}

impl OperatorModel {
    /// An operator teaching online at the dissertation's precision (20 mm RMS; dissertation §3),
    /// who accepts a suggestion as good as their own placement (within half the effective width,
    /// about 24 mm) and 0.1 rad (the dissertation's angular tolerance, §4.3.1).
    pub fn online(tcp_mm_s: f64) -> OperatorModel {
        let repeatability_mm = DISSERTATION_ONLINE_REPEATABILITY_MM;
        let mut m = OperatorModel {
            name: "online".into(),
            repeatability_mm,
            repeatability_rad: 0.02 * 3f64.sqrt(),
            accept_mm: 0.0,
            accept_rad: 0.1,
            fitts_a_s: JOYSTICK_A_S,
            fitts_b_s: JOYSTICK_B_S,
            fitts_scale: 1.0,
            look_s: 0.1 * DISSERTATION_BASELINE_S / DISSERTATION_TASK_WAYPOINTS,
            record_s: RECORD_S,
            inspect_by_moving: true,
        };
        m.accept_mm = 0.5 * m.width_mm();
        m.fitts_scale = m.calibrated_scale(tcp_mm_s);
        m
    }

    /// A joystick operator as [`OperatorModel::online`] (the same person: the same Fitts `k`,
    /// `a` and `b`) placing waypoints to `repeatability_mm` 3-D RMS instead of 20 mm, the
    /// rotation error in proportion, and accepting within half their own effective width. For
    /// checking settings against operators other than the dissertation's (`simulate
    /// --operator-mm`).
    pub fn online_at(tcp_mm_s: f64, repeatability_mm: f64) -> OperatorModel {
        let online = OperatorModel::online(tcp_mm_s);
        let ratio = repeatability_mm / online.repeatability_mm;
        let mut m = OperatorModel {
            name: format!("online {repeatability_mm} mm"),
            repeatability_mm,
            repeatability_rad: online.repeatability_rad * ratio,
            ..online
        };
        m.accept_mm = 0.5 * m.width_mm();
        m
    }

    /// An operator placing waypoints to 0.05 mm RMS (arc-welding grade), who accepts a
    /// suggestion within the dissertation's "useful" tolerance of 1 mm and 0.1 rad (§4.3.1). Same
    /// `k`, `a`, `b` as [`OperatorModel::online`]: only the target width differs.
    pub fn precise(tcp_mm_s: f64) -> OperatorModel {
        let online = OperatorModel::online(tcp_mm_s);
        OperatorModel {
            name: "precise".into(),
            repeatability_mm: 0.05,
            repeatability_rad: 0.001 * 3f64.sqrt(),
            accept_mm: 1.0,
            accept_rad: 0.1,
            ..online
        }
    }

    /// One-sigma error per axis, mm (the 3-D RMS over √3).
    pub fn sigma_axis_mm(&self) -> f64 {
        self.repeatability_mm / 3f64.sqrt()
    }

    /// One-sigma rotation error per axis, rad.
    pub fn sigma_axis_rad(&self) -> f64 {
        self.repeatability_rad / 3f64.sqrt()
    }

    /// Effective target width, mm.
    pub fn width_mm(&self) -> f64 {
        EFFECTIVE_WIDTH_PER_SIGMA * self.sigma_axis_mm()
    }

    /// Effective target width in rotation, rad.
    pub fn width_rad(&self) -> f64 {
        EFFECTIVE_WIDTH_PER_SIGMA * self.sigma_axis_rad()
    }

    /// Aiming time for a target `d` mm and `theta` rad away; zero when the arm is already
    /// within half the effective widths.
    pub fn aim_time(&self, d: f64, theta: f64) -> f64 {
        let (w, wr) = (self.width_mm(), self.width_rad());
        if d <= 0.5 * w && theta <= 0.5 * wr {
            return 0.0;
        }
        let bits = (1.0 + d / w).log2() + (1.0 + theta / wr).log2();
        self.fitts_scale * (self.fitts_a_s + self.fitts_b_s * bits)
    }

    /// The `k` that makes a waypoint at the dissertation's mean spacing (pure translation, travel
    /// at `tcp_mm_s`) take the dissertation's mean waypoint time.
    fn calibrated_scale(&self, tcp_mm_s: f64) -> f64 {
        let target = DISSERTATION_BASELINE_S / DISSERTATION_TASK_WAYPOINTS;
        let rest = target - self.record_s - DISSERTATION_SPACING_MM / tcp_mm_s;
        let bits = (1.0 + DISSERTATION_SPACING_MM / self.width_mm()).log2();
        rest / (self.fitts_a_s + self.fitts_b_s * bits)
    }

    /// The manual time of a waypoint at the dissertation's mean spacing (the calibration point).
    pub fn anchor_time(&self, tcp_mm_s: f64) -> f64 {
        DISSERTATION_SPACING_MM / tcp_mm_s
            + self.aim_time(DISSERTATION_SPACING_MM, 0.0)
            + self.record_s
    }

    /// `intended` with this operator's placement error, drawn from `rng`.
    pub fn place<R: Rng>(&self, intended: &Pose, rng: &mut R) -> Pose {
        let (s, sr) = (self.sigma_axis_mm(), self.sigma_axis_rad());
        let dp = Vector3::new(normal(rng), normal(rng), normal(rng)) * s;
        let dr = Vector3::new(normal(rng), normal(rng), normal(rng)) * sr;
        let rotation = intended.rotation() * UnitQuaternion::from_scaled_axis(dr);
        Pose::from_isometry(Isometry3::from_parts(
            Translation3::from(intended.position() + dp),
            rotation,
        ))
    }
}

/// A standard normal draw (Box–Muller), so the stream depends only on `rand`'s uniform `f64`.
pub fn normal<R: Rng>(rng: &mut R) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// An operator at an arm.
#[derive(Debug, Clone)]
pub struct Operator {
    pub model: OperatorModel,
    pub arm: Arm,
}

impl Operator {
    pub fn new(model: OperatorModel, arm: Arm) -> Operator {
        Operator { model, arm }
    }

    /// Teaches the waypoint the operator intends, given the service's suggestion for it (if
    /// one is offered). `rng` draws the placement error of a hand-taught waypoint.
    pub fn teach<R: Rng>(
        &mut self,
        intended: &Pose,
        suggestion: Option<&Suggestion>,
        rng: &mut R,
    ) -> Step {
        let placed = self.model.place(intended, rng);
        let Some(s) = suggestion else {
            let mut time = Time::default();
            let reachable = self.by_hand(intended, &placed, &mut time);
            return Step {
                pose: placed,
                decision: None,
                feedback: None,
                time,
                reachable,
            };
        };
        let mut time = Time {
            look_s: self.model.look_s,
            ..Time::default()
        };
        let decision = self.decide(intended, s);
        let from = *self.arm.tcp();
        if s.reachable && (self.model.inspect_by_moving || decision != Decision::Reject) {
            time.travel_s += self.arm.joint_move(&s.pose).time_s;
        }
        let (pose, feedback, reachable) = match decision {
            Decision::Accept => {
                time.record_s += self.model.record_s;
                (s.pose, Feedback::Accepted, s.reachable)
            }
            Decision::FineTune => {
                let reachable = self.by_hand(intended, &placed, &mut time);
                (placed, Feedback::Adjusted(placed), reachable)
            }
            Decision::Reject | Decision::Dismiss => {
                if s.reachable && self.model.inspect_by_moving {
                    time.travel_s += self.arm.joint_move(&from).time_s;
                }
                let reachable = self.by_hand(intended, &placed, &mut time);
                (placed, Feedback::Rejected, reachable)
            }
        };
        Step {
            pose,
            decision: Some(decision),
            feedback: Some(feedback),
            time,
            reachable,
        }
    }

    /// A suggestion after the routine's last waypoint: looked at and dismissed.
    pub fn dismiss(&self) -> Time {
        Time {
            look_s: self.model.look_s,
            ..Time::default()
        }
    }

    /// Jogs by hand from where the arm is to `placed` (the operator aiming at `intended`) and
    /// records; returns whether `placed` is in reach.
    fn by_hand(&mut self, intended: &Pose, placed: &Pose, time: &mut Time) -> bool {
        let here = *self.arm.tcp();
        time.aim_s += self
            .model
            .aim_time(here.distance_to(intended), here.angle_to(intended));
        let jog = self.arm.cartesian_jog(placed);
        time.travel_s += jog.time_s;
        time.record_s += self.model.record_s;
        jog.reachable
    }

    /// Accept within tolerance; otherwise the quicker of fine-tuning and rejecting, as the
    /// time model estimates them (travel at the TCP speed limit).
    pub fn decide(&self, intended: &Pose, s: &Suggestion) -> Decision {
        if !s.reachable {
            return Decision::Reject;
        }
        let err_mm = s.pose.distance_to(intended);
        let err_rad = s.pose.angle_to(intended);
        if err_mm <= self.model.accept_mm && err_rad <= self.model.accept_rad {
            return Decision::Accept;
        }
        let v = self.arm.limits().tcp_mm_s;
        let here = self.arm.tcp();
        let fine = self.model.aim_time(err_mm, err_rad) + err_mm / v;
        let back = if self.model.inspect_by_moving {
            here.distance_to(&s.pose) / v
        } else {
            0.0
        };
        let d = here.distance_to(intended);
        let redo = back + self.model.aim_time(d, here.angle_to(intended)) + d / v;
        if fine <= redo {
            Decision::FineTune
        } else {
            Decision::Reject
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{Mounting, bundled_robots_dir, load_robot};
    use crate::simulation::arm::JogLimits;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn pose(x: f64, y: f64, z: f64) -> Pose {
        Pose::new([x, y, z], [0.0, 0.0, 1.0, 0.0]).unwrap()
    }

    fn operator(model: OperatorModel) -> Operator {
        let robot = load_robot(&bundled_robots_dir(), "abb_irb140").unwrap();
        Operator::new(
            model,
            Arm::new(
                robot,
                Mounting::default(),
                JogLimits::default(),
                &pose(450.0, 0.0, 400.0),
            ),
        )
    }

    /// An operator at another precision is the dissertation's online operator with the error and
    /// the tolerance scaled: at 20 mm they are the same, at 5 mm the tolerance is a quarter, and
    /// their placements scatter by what they were asked (within 10 % over 4,000 draws).
    #[test]
    fn an_online_operator_at_another_precision_scales_error_and_tolerance() {
        let v = JogLimits::default().tcp_mm_s;
        let online = OperatorModel::online(v);
        let same = OperatorModel::online_at(v, 20.0);
        assert_eq!(
            OperatorModel {
                name: online.name.clone(),
                ..same
            },
            online
        );
        for mm in [5.0, 30.0] {
            let m = OperatorModel::online_at(v, mm);
            let ratio = mm / 20.0;
            assert!((m.accept_mm - online.accept_mm * ratio).abs() < 1e-9);
            assert!((m.repeatability_rad - online.repeatability_rad * ratio).abs() < 1e-12);
            assert_eq!(
                (m.fitts_scale, m.accept_rad),
                (online.fitts_scale, online.accept_rad)
            );
            let target = pose(450.0, 0.0, 400.0);
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let n = 4000;
            let sq: f64 = (0..n)
                .map(|_| m.place(&target, &mut rng).distance_to(&target).powi(2))
                .sum();
            let rms = (sq / f64::from(n)).sqrt();
            assert!((rms / mm - 1.0).abs() < 0.1, "{rms} mm for {mm} mm");
        }
    }

    #[test]
    fn the_calibration_reproduces_the_dissertations_waypoint_time() {
        let v = JogLimits::default().tcp_mm_s;
        let m = OperatorModel::online(v);
        let want = DISSERTATION_BASELINE_S / DISSERTATION_TASK_WAYPOINTS;
        assert!(
            (m.anchor_time(v) - want).abs() < 1e-9,
            "{}",
            m.anchor_time(v)
        );
        assert!(m.fitts_scale > 1.0);
        // A precise operator aims at a narrower target: the same move takes longer.
        let p = OperatorModel::precise(v);
        assert!(p.anchor_time(v) > 1.5 * m.anchor_time(v));
        // Farther and more rotated targets take longer; a target in hand takes nothing.
        assert!(m.aim_time(400.0, 0.0) > m.aim_time(100.0, 0.0));
        assert!(m.aim_time(100.0, 0.5) > m.aim_time(100.0, 0.0));
        assert_eq!(m.aim_time(0.0, 0.0), 0.0);
    }

    #[test]
    fn placement_error_has_the_configured_spread_and_is_deterministic() {
        let m = OperatorModel::online(250.0);
        let target = pose(450.0, 0.0, 400.0);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 4000;
        let mut sq = 0.0;
        for _ in 0..n {
            sq += m.place(&target, &mut rng).distance_to(&target).powi(2);
        }
        let rms = (sq / n as f64).sqrt();
        assert!((rms - 20.0).abs() < 1.0, "{rms}");
        let a = m.place(&target, &mut ChaCha8Rng::seed_from_u64(3));
        let b = m.place(&target, &mut ChaCha8Rng::seed_from_u64(3));
        assert_eq!(a, b);
    }

    #[test]
    fn decisions_follow_the_error_of_the_suggestion() {
        let mut op = operator(OperatorModel::precise(250.0));
        let intended = pose(450.0, 200.0, 400.0);
        let near = Suggestion {
            pose: pose(450.3, 200.0, 400.0),
            reachable: true,
        };
        let close = Suggestion {
            pose: pose(455.0, 200.0, 400.0),
            reachable: true,
        };
        let far = Suggestion {
            pose: pose(450.0, -300.0, 400.0),
            reachable: true,
        };
        let unreachable = Suggestion {
            reachable: false,
            ..near
        };
        assert_eq!(op.decide(&intended, &near), Decision::Accept);
        assert_eq!(op.decide(&intended, &close), Decision::FineTune);
        assert_eq!(op.decide(&intended, &far), Decision::Reject);
        assert_eq!(op.decide(&intended, &unreachable), Decision::Reject);

        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let manual = op.clone().teach(&intended, None, &mut rng).time.total();
        let accepted = op.clone().teach(&intended, Some(&near), &mut rng);
        assert_eq!(accepted.pose, near.pose);
        assert_eq!(accepted.feedback, Some(Feedback::Accepted));
        assert!(accepted.time.total() < 0.5 * manual);
        let tuned = op.clone().teach(&intended, Some(&close), &mut rng);
        assert!(matches!(tuned.feedback, Some(Feedback::Adjusted(p)) if p == tuned.pose));
        assert!(tuned.pose.distance_to(&intended) < 1.0);
        let rejected = op.teach(&intended, Some(&far), &mut rng);
        assert_eq!(rejected.feedback, Some(Feedback::Rejected));
        assert!(rejected.time.total() > manual);
    }
}
