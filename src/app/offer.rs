//! The one place that turns an engine prediction and the reach check into what the operator is
//! told: *offered*, or *withheld* with a reason code and a message.

use super::reach;
use super::registry::OpenRoutine;
use crate::api::{self, PoseValues};
use crate::engine::{PredictOptions, Prediction, Teacher, Withheld};
use crate::kinematics::{Joints, ReachPolicy, Reachability};
use crate::storage::NewPrediction;

/// The reason code of a prediction withheld because the cell's arm cannot reach it.
pub(super) const UNREACHABLE: &str = "unreachable";

/// A prediction after the reachability check.
pub(super) struct Checked {
    pub(super) prediction: Prediction,
    pub(super) reach: Option<Reachability>,
    /// Withheld because the arm cannot reach it (policy `withhold`).
    pub(super) unreachable: bool,
}

impl Checked {
    pub(super) fn offered(&self) -> bool {
        self.prediction.offered() && !self.unreachable
    }

    /// The withheld reason code, if withheld.
    pub(super) fn reason(&self) -> Option<&'static str> {
        match (&self.prediction.withheld, self.unreachable) {
            (Some(w), _) => Some(w.code()),
            (None, true) => Some(UNREACHABLE),
            (None, false) => None,
        }
    }
}

/// Checks an engine prediction against the cell's arm (when it has one).
pub(super) fn check(
    arm: Option<&reach::CellArm>,
    prediction: Prediction,
    previous: Option<&Joints>,
) -> Checked {
    let reach = match (arm, &prediction.pose) {
        (Some(arm), Some(pose)) if prediction.offered() => Some(arm.check(pose, previous)),
        _ => None,
    };
    let unreachable = match (arm, &reach) {
        (Some(arm), Some(r)) => !r.is_reachable() && arm.policy() == ReachPolicy::Withhold,
        _ => false,
    };
    Checked {
        prediction,
        reach,
        unreachable,
    }
}

/// The prediction for the waypoint after the last one taught, with the cell's settings, checked
/// against the arm where it is now.
pub(super) fn next(teacher: &Teacher, arm: Option<&reach::CellArm>) -> (PredictOptions, Checked) {
    let opts = teacher.config().predict.clone();
    let checked = check(
        arm,
        teacher.predict_with(&opts),
        arm.and_then(|a| a.previous()),
    );
    (opts, checked)
}

/// An open-loop completion of up to `k` predictions, each checked against the arm from the
/// joints the previous one would leave it at; it stops after the first that is not offered
/// (the engine's stop rule, with reach as a further gate).
pub(super) fn complete(
    teacher: &Teacher,
    arm: Option<&reach::CellArm>,
    k: usize,
    opts: &PredictOptions,
) -> Vec<Checked> {
    let mut previous = arm.and_then(|a| a.previous()).copied();
    teacher.complete_with(k, opts, |p| {
        let c = check(arm, p, previous.as_ref());
        previous = c.reach.as_ref().and_then(|r| r.chosen).or(previous);
        let offered = c.offered();
        (c, offered)
    })
}

/// A human-readable account of why a prediction is withheld.
pub(super) fn describe(w: &Withheld, opts: &PredictOptions) -> String {
    match w {
        Withheld::NothingTaught => "the routine has no waypoint yet".into(),
        Withheld::EmptyModel => "nothing has been learned in this cell yet".into(),
        Withheld::TooFewStates { states } => {
            format!("the model has {states} state(s); at least 2 are needed")
        }
        Withheld::NoMatch => "the last moves match nothing learned".into(),
        Withheld::LikelyEnd { end_probability } => format!(
            "the routine probably ends here (p = {end_probability:.2}); taught routines like \
             this one usually stop at this point"
        ),
        Withheld::PoorMatch { misfit } => format!(
            "the last moves resemble learned ones only loosely (misfit {misfit:.2} above {:.2})",
            opts.max_misfit.unwrap_or(f64::INFINITY)
        ),
        Withheld::LowConfidence { phi } => {
            format!(
                "confidence φ = {phi:.2} is below φ_min = {:.2}",
                opts.phi_min
            )
        }
        Withheld::WideSpread { spread } => {
            format!("the moves that followed this pattern before disagree (spread {spread:.2})")
        }
        Withheld::LittleEvidence { support } => {
            format!("the pattern was followed by this move only {support:.1} time(s) before")
        }
        Withheld::Unlikely { p_useful } => format!(
            "the best suggestion is right with probability {p_useful:.2} only, below the cell's threshold"
        ),
    }
}

pub(super) fn record(
    r: &OpenRoutine,
    after: i64,
    version: i64,
    c: &Checked,
) -> Option<NewPrediction> {
    let p = &c.prediction;
    let pose = p.pose.as_ref().filter(|_| c.offered())?;
    Some(NewPrediction {
        cell_id: r.cell_id,
        routine_id: r.id,
        after_seq: after,
        pose: pose.into(),
        phi: p.phi,
        psi: p.psi,
        misfit: p.misfit,
        end_probability: p.end_probability,
        model_version: version,
    })
}

pub(super) fn dto(
    arm: Option<&reach::CellArm>,
    c: &Checked,
    opts: &PredictOptions,
    id: Option<i64>,
    after: i64,
    version: i64,
) -> api::Prediction {
    let p = &c.prediction;
    let reachability = match (arm, &c.reach) {
        (Some(arm), Some(r)) => Some(arm.dto(r)),
        _ => None,
    };
    let withheld = match (&p.withheld, &reachability) {
        (Some(w), _) => Some(api::Withheld {
            reason: w.code().to_string(),
            message: describe(w, opts),
        }),
        (None, Some(r)) if c.unreachable => Some(api::Withheld {
            reason: UNREACHABLE.to_string(),
            message: r
                .unreachable
                .as_ref()
                .map(|u| u.message.clone())
                .unwrap_or_else(|| "the arm cannot reach it".into()),
        }),
        _ => None,
    };
    api::Prediction {
        id,
        offered: c.offered(),
        withheld,
        reachability,
        pose: p.pose.as_ref().map(PoseValues::from),
        relative: p.relative.as_ref().map(|x| PoseValues {
            x: x[0],
            y: x[1],
            z: x[2],
            qw: x[3],
            qx: x[4],
            qy: x[5],
            qz: x[6],
        }),
        phi: p.phi,
        psi: p.psi,
        routine_scale: p.routine_scale(),
        end_probability: p.end_probability,
        misfit: p.misfit,
        spread: p.spread,
        support: p.support,
        window: p.window,
        states: p.states,
        after_waypoints: after,
        model_version: version,
        p_useful: p.p_useful,
        expert: p.expert.map(|e| e.name().to_string()),
    }
}
