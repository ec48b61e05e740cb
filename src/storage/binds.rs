//! The values of a waypoint and of a prediction bound in their columns' order, for every
//! statement that stores one (single and batched inserts, edits), on plain and typed queries.

use sqlx::any::{Any, AnyArguments};
use sqlx::query::{Query, QueryAs};

use super::rows::{NewPrediction, NewWaypoint, flag, real};
use crate::engine::PoseValues;

pub(super) trait Binds<'q>: Sized {
    fn value<T: 'q + sqlx::Encode<'q, Any> + sqlx::Type<Any>>(self, v: T) -> Self;

    /// `x, y, z, qw, qx, qy, qz`.
    fn pose(self, pose: &PoseValues) -> Self {
        self.value(pose.x)
            .value(pose.y)
            .value(pose.z)
            .value(pose.qw)
            .value(pose.qx)
            .value(pose.qy)
            .value(pose.qz)
    }

    /// `x, y, z, qw, qx, qy, qz, joints, motion, name, reachable`.
    fn waypoint_values(
        self,
        pose: &PoseValues,
        joints: &Option<String>,
        motion: &Option<String>,
        name: &Option<String>,
        reachable: Option<bool>,
    ) -> Self {
        self.pose(pose)
            .value(joints.clone())
            .value(motion.clone())
            .value(name.clone())
            .value(reachable.map(flag))
    }

    /// `routine_id, seq`, then the [`Binds::waypoint_values`].
    fn new_waypoint(self, w: &NewWaypoint) -> Self {
        self.value(w.routine_id).value(w.seq).waypoint_values(
            &w.pose,
            &w.joints,
            &w.motion,
            &w.name,
            w.reachable,
        )
    }

    /// `x, y, z, qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version`.
    fn prediction_values(self, pr: &NewPrediction) -> Self {
        self.pose(&pr.pose)
            .value(pr.phi)
            .value(pr.psi)
            .value(real(pr.misfit))
            .value(pr.end_probability)
            .value(pr.model_version)
    }
}

impl<'q> Binds<'q> for Query<'q, Any, AnyArguments> {
    fn value<T: 'q + sqlx::Encode<'q, Any> + sqlx::Type<Any>>(self, v: T) -> Self {
        self.bind(v)
    }
}

impl<'q, O> Binds<'q> for QueryAs<'q, Any, O, AnyArguments> {
    fn value<T: 'q + sqlx::Encode<'q, Any> + sqlx::Type<Any>>(self, v: T) -> Self {
        self.bind(v)
    }
}
