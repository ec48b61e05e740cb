//! Cells: create, list, read, statistics, and rebuilding a cell's model from the database.

use super::cell_model::CellModel;
use super::error::AppError;
use super::settings::parse_settings;
use super::{App, Result, check_name};
use crate::api::{Cell, CellStats, CreateCell, FeedbackStats, ModelInfo};
use crate::storage::CellRow;

impl App {
    pub(super) fn cell(&self, row: CellRow) -> Result<Cell> {
        Ok(Cell {
            settings: parse_settings(&row)?,
            id: row.id,
            name: row.name,
            created_at: row.created_at,
            settings_changed_at: row.settings_changed_at,
        })
    }

    pub async fn create_cell(&self, input: CreateCell) -> Result<Cell> {
        check_name("cell name", &input.name)?;
        let settings = input.settings.resolve()?;
        self.robots.require(&settings.robot)?;
        let json = serde_json::to_string(&settings)
            .map_err(|e| AppError::Internal(format!("settings: {e}")))?;
        let row = self
            .store
            .insert_cell(input.name.trim(), &json)
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => {
                    AppError::Exists(format!("a cell named {:?} exists", input.name.trim()))
                }
                other => other,
            })?;
        self.cell(row)
    }

    pub async fn cells(&self) -> Result<Vec<Cell>> {
        self.store
            .cells()
            .await?
            .into_iter()
            .map(|r| self.cell(r))
            .collect()
    }

    pub async fn get_cell(&self, id: i64) -> Result<Cell> {
        let row = self.cell_row(id).await?;
        self.cell(row)
    }

    pub async fn cell_stats(&self, id: i64) -> Result<CellStats> {
        self.cell_row(id).await?;
        let (model, teaching) = {
            let mut locked = self.lock_cell_id(id).await?;
            let m = locked.model()?;
            (m.info(), m.teaching())
        };
        let counts = self.store.feedback_counts(id).await?;
        let judged = counts.accepted + counts.adjusted + counts.rejected;
        let mut adj = counts.adjustments_mm.clone();
        adj.sort_by(f64::total_cmp);
        let median = match adj.len() {
            0 => None,
            n if n % 2 == 1 => Some(adj[n / 2]),
            n => Some(0.5 * (adj[n / 2 - 1] + adj[n / 2])),
        };
        Ok(CellStats {
            cell_id: id,
            model,
            teaching,
            feedback: FeedbackStats {
                offered: counts.offered,
                accepted: counts.accepted,
                adjusted: counts.adjusted,
                rejected: counts.rejected,
                pending: counts.offered - judged,
                acceptance: (judged > 0)
                    .then(|| (counts.accepted + counts.adjusted) as f64 / judged as f64),
                median_adjustment_mm: median,
            },
        })
    }

    /// Re-learns the cell's model from the stored routines, in the order they were finished.
    pub async fn rebuild(&self, id: i64) -> Result<ModelInfo> {
        self.to_completion(move |app| async move { app.rebuild_now(id).await })
            .await
    }

    async fn rebuild_now(&self, id: i64) -> Result<ModelInfo> {
        self.cell_row(id).await?;
        // Locked as for any use: a model behind writes of another instance catches up first,
        // so what is compared is what this instance would answer from.
        let mut locked = self.lock_cell_id(id).await?;
        let cell = self.cell_row(id).await?;
        let model = CellModel::load(&self.store, &cell, &self.robots).await?;
        let info = model.info();
        let guard = &mut locked.0;
        if let Some(previous) = guard.as_ref()
            && !previous.in_step_with(&model)
        {
            tracing::error!(cell = id, before = ?previous.info(), rebuilt = ?info, "the cell's model in memory differed from the database");
            self.metrics.record_divergence();
        }
        **guard = Some(model);
        Ok(info)
    }
}
