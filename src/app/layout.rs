//! Layout search as a service: where to stand an arm so that it reaches a program's (or a
//! cell's, or given) waypoints, by [`crate::kinematics::layout::search_layout`] on a blocking
//! thread.

use super::cell_model::stored_pose;
use super::error::AppError;
use super::settings::parse_settings;
use super::{App, Result};
use crate::api::{self, PlacementSearch, Placements};
use crate::engine::{Pose, PoseValues};
use crate::kinematics::layout::{LayoutOptions, Placement, search_layout};

/// Most placements one search returns.
pub const MAX_KEEP: usize = 10;
/// Bounds of the search effort a request may ask for.
pub const MIN_EVALUATIONS: usize = 100;
pub const MAX_EVALUATIONS: usize = 20_000;
/// Most targets one search takes (the largest corpus program has 836).
pub const MAX_TARGETS: usize = 20_000;

impl App {
    /// The stored waypoints of a program (or of every program of a cell), with their ids, and
    /// the cell's tool.
    async fn stored_targets(
        &self,
        program_id: Option<i64>,
        cell_id: Option<i64>,
    ) -> Result<(Vec<Pose>, Vec<i64>, Pose)> {
        let (cell, programs) = match (program_id, cell_id) {
            (Some(p), None) => {
                let program = self
                    .store
                    .program(p)
                    .await?
                    .ok_or_else(|| AppError::not_found("program", p))?;
                (self.cell_row(program.cell_id).await?, vec![program])
            }
            (None, Some(c)) => {
                let cell = self.cell_row(c).await?;
                let programs = self.store.programs(c).await?;
                (cell, programs)
            }
            _ => {
                return Err(AppError::Invalid(
                    "give exactly one of program_id, cell_id and targets".into(),
                ));
            }
        };
        let mut poses = Vec::new();
        let mut ids = Vec::new();
        for program in &programs {
            for routine in self.store.routines(program.id).await? {
                for w in self.store.waypoints(routine.id).await? {
                    poses.push(stored_pose(&w)?);
                    ids.push(w.id);
                }
            }
        }
        let tool = parse_settings(&cell)?.tool.to_pose()?;
        Ok((poses, ids, tool))
    }

    /// Searches base placements of `robot` for the request's targets.
    pub async fn search_placements(
        &self,
        robot: &str,
        request: PlacementSearch,
    ) -> Result<Placements> {
        let arm = self
            .robots
            .get(robot)
            .ok_or_else(|| AppError::NotFoundName {
                what: "robot",
                name: robot.to_string(),
            })?;
        let keep = request.keep.unwrap_or(3);
        if !(1..=MAX_KEEP).contains(&keep) {
            return Err(AppError::Invalid(format!(
                "keep must be 1–{MAX_KEEP}, not {keep}"
            )));
        }
        let evaluations = request
            .evaluations
            .unwrap_or(LayoutOptions::default().evaluations);
        if !(MIN_EVALUATIONS..=MAX_EVALUATIONS).contains(&evaluations) {
            return Err(AppError::Invalid(format!(
                "evaluations must be {MIN_EVALUATIONS}–{MAX_EVALUATIONS}, not {evaluations}"
            )));
        }
        let given = [
            request.program_id.is_some(),
            request.cell_id.is_some(),
            request.targets.is_some(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            return Err(AppError::Invalid(
                "give exactly one of program_id, cell_id and targets".into(),
            ));
        }
        let (targets, ids, cell_tool) = match &request.targets {
            Some(values) => {
                if values.is_empty() {
                    return Err(AppError::Invalid("targets is empty".into()));
                }
                let poses = values
                    .iter()
                    .map(PoseValues::to_pose)
                    .collect::<std::result::Result<Vec<_>, _>>()?;
                (poses, None, Pose::identity())
            }
            None => {
                let (poses, ids, tool) = self
                    .stored_targets(request.program_id, request.cell_id)
                    .await?;
                (poses, Some(ids), tool)
            }
        };
        if targets.is_empty() {
            // The program or cell has no waypoints yet: a state of the resource, not of the
            // request.
            return Err(AppError::Conflict(
                "there are no waypoints to place the arm for".into(),
            ));
        }
        if targets.len() > MAX_TARGETS {
            return Err(AppError::Invalid(format!(
                "{} targets; at most {MAX_TARGETS} are searched at once",
                targets.len()
            )));
        }
        let tool = match &request.tool {
            Some(t) => t.to_pose()?,
            None => cell_tool,
        };
        let options = LayoutOptions {
            mounting: request.mounting,
            tool: tool.values(),
            seed: request.seed.unwrap_or(0),
            evaluations,
            keep,
            ..LayoutOptions::default()
        };
        let total = targets.len();
        let found = super::blocking(move || search_layout(&arm, &targets, &options))
            .await?
            .map_err(|e| AppError::Invalid(e.to_string()))?;
        Ok(Placements {
            robot: robot.to_string(),
            targets: total,
            placements: found.iter().map(|p| dto(p, ids.as_deref())).collect(),
        })
    }
}

fn dto(p: &Placement, ids: Option<&[i64]>) -> api::Placement {
    api::Placement {
        base: p.base.values(),
        reached: p.reached,
        total: p.total,
        unreached: p.unreached.clone(),
        unreached_waypoints: ids.map(|ids| {
            p.unreached
                .iter()
                .filter_map(|&i| ids.get(i).copied())
                .collect()
        }),
        min_joint_margin_deg: p.min_joint_margin_rad.map(f64::to_degrees),
        min_sigma: p.min_sigma,
        score: p.score,
    }
}
