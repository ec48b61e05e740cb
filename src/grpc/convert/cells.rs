//! Cells: a cell with its settings ([`super::settings`]), what its model holds, and its
//! feedback counts.

use crate::api::{
    CalibrationRoutine, Cell, CellPatch, CellStats, CreateCell, FeedbackStats, ModelInfo,
    TeachingStats,
};
use crate::grpc::pb;

use super::wire::{In, both_ways};

both_ways!(Cell => Cell { id, name, settings, created_at, settings_changed_at });
both_ways!(ModelInfo => ModelInfo {
    states, edges, perplexity, routines, depth, observations, version,
});
both_ways!(plain FeedbackStats => FeedbackStats {
    offered, accepted, adjusted, rejected, pending, acceptance, median_adjustment_mm,
});
both_ways!(TeachingStats => TeachingStats {
    noise, noise_learned, tolerance, tolerance_learned, offer_threshold, threshold_steered,
});
both_ways!(CellStats => CellStats { cell_id, model, teaching, feedback });

pub fn create_cell(r: pb::CreateCellRequest) -> In<CreateCell> {
    Ok(CreateCell {
        name: r.name,
        settings: r.settings.unwrap_or_default().try_into()?,
    })
}

pub fn cell_patch(r: pb::UpdateCellRequest) -> In<CellPatch> {
    Ok(CellPatch {
        name: r.name,
        settings: r.settings.map(TryInto::try_into).transpose()?,
    })
}

pub fn calibration(r: pb::CalibrateCellRequest) -> CalibrationRoutine {
    CalibrationRoutine {
        poses: r.poses.into_iter().map(Into::into).collect(),
    }
}

/// The request as a client sends it.
pub fn create_cell_request(c: CreateCell) -> pb::CreateCellRequest {
    pb::CreateCellRequest {
        name: c.name,
        settings: Some(c.settings.into()),
    }
}
