//! Predictions: the pose offered next (or why it was withheld), with the arm's reach of it, and
//! the query for one.

use crate::api::{
    JointMargin, PredictQuery, Prediction, PredictionSet, Reachability, Unreachable, Withheld,
};
use crate::grpc::pb;

use super::wire::{In, Wire, both_ways};

both_ways!(plain Withheld => Withheld { reason, message });
both_ways!(plain Unreachable => Unreachable { reason, message });
both_ways!(plain JointMargin => JointMargin { name, margin_rad });
both_ways!(Reachability => Reachability {
    robot, reachable, unreachable, solutions, chosen, sigma_min, manipulability, limiting_joint,
});
both_ways!(Prediction => Prediction {
    id, offered, withheld, reachability, pose, relative, phi, psi, routine_scale,
    end_probability, misfit, spread, support, window, states, after_waypoints, model_version,
    p_useful, expert,
});
both_ways!(PredictionSet => PredictionSet { routine_id, predictions });

pub fn predict_query(r: &pb::PredictRequest) -> In<PredictQuery> {
    Ok(PredictQuery {
        horizon: Wire::back(r.horizon, "horizon")?,
        phi_min: r.phi_min,
        scale: r.scale,
        k: Wire::back(r.k, "k")?,
    })
}

/// The request as a client sends it.
pub fn predict_request(routine_id: i64, q: PredictQuery) -> pb::PredictRequest {
    pb::PredictRequest {
        routine_id,
        horizon: q.horizon.out(),
        phi_min: q.phi_min,
        scale: q.scale,
        k: q.k.out(),
    }
}
