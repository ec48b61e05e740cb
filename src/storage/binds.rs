//! The values of a waypoint and of a prediction bound in their columns' order, for every
//! statement that stores one (single and batched inserts, edits), on plain and typed queries.

use sqlx::any::{Any, AnyArguments};
use sqlx::query::{Query, QueryAs};

use super::rows::{NewPrediction, PoseColumns, flag, real};

pub(super) trait Binds<'q>: Sized {
    fn value<T: 'q + sqlx::Encode<'q, Any> + sqlx::Type<Any>>(self, v: T) -> Self;

    /// `x, y, z, qw, qx, qy, qz, joints, motion, name, reachable`.
    fn waypoint_values(
        self,
        pose: &PoseColumns,
        joints: &Option<String>,
        motion: &Option<String>,
        name: &Option<String>,
        reachable: Option<bool>,
    ) -> Self {
        self.value(pose.x)
            .value(pose.y)
            .value(pose.z)
            .value(pose.qw)
            .value(pose.qx)
            .value(pose.qy)
            .value(pose.qz)
            .value(joints.clone())
            .value(motion.clone())
            .value(name.clone())
            .value(reachable.map(flag))
    }

    /// `x, y, z, qw, qx, qy, qz, phi, psi, misfit, end_probability, model_version`.
    fn prediction_values(self, pr: &NewPrediction) -> Self {
        self.value(pr.pose.x)
            .value(pr.pose.y)
            .value(pr.pose.z)
            .value(pr.pose.qw)
            .value(pr.pose.qx)
            .value(pr.pose.qy)
            .value(pr.pose.qz)
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
