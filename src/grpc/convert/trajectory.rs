//! Hand-guided trajectories: the samples recorded and how to segment them, and the attractors
//! taught from them with the segmentation that found them.

use crate::api::{
    Criterion, Segmentation, TrajectoryAnswer, TrajectoryPoint, TrajectoryRequest,
    TrajectorySample, TrajectorySegment, TrajectorySettings,
};
use crate::grpc::pb;

use super::wire::{In, both_ways, enum_both_ways, required};

enum_both_ways!(Criterion => SegmentCriterion as "segment criterion" {
    Direction,
    ErrorOverStep = Seed,
});

both_ways!(TrajectorySample => TrajectorySample { t, pose, joints });
both_ways!(TrajectorySettings => TrajectorySettings {
    epsilon_max, criterion, min_step_mm, rotation_mm_per_rad, zeta_mm, min_segment_steps,
    kappa_max, rank_tolerance,
});
both_ways!(TrajectoryPoint => TrajectoryPoint { sample, t, pose, joints, taught });
both_ways!(TrajectorySegment => TrajectorySegment {
    from, to, steps, rank, condition, identity, alpha, epsilon, r,
});
both_ways!(Segmentation => Segmentation {
    samples, kept, segments, mean_error_mm, max_error_mm, converged, parameters, raw_parameters,
});
both_ways!(TrajectoryAnswer => TrajectoryAnswer {
    preview, start, attractors, waypoints, segmentation,
});

/// A trajectory to append: every sample needs its pose (named by its place when missing);
/// empty joints are none sent; no settings are the defaults.
pub fn trajectory_request(r: pb::AppendTrajectoryRequest) -> In<TrajectoryRequest> {
    Ok(TrajectoryRequest {
        samples: r
            .samples
            .into_iter()
            .enumerate()
            .map(|(i, s)| {
                let pose = required(s.pose, &format!("samples[{i}].pose"))?;
                pb::TrajectorySample {
                    pose: Some(pose),
                    ..s
                }
                .try_into()
            })
            .collect::<In<_>>()?,
        preview: r.preview,
        settings: r.settings.unwrap_or_default().try_into()?,
    })
}

/// The request as a client sends it.
pub fn trajectory_request_out(
    routine_id: i64,
    r: TrajectoryRequest,
) -> pb::AppendTrajectoryRequest {
    pb::AppendTrajectoryRequest {
        routine_id,
        samples: r.samples.into_iter().map(Into::into).collect(),
        preview: r.preview,
        settings: Some(r.settings.into()),
    }
}
