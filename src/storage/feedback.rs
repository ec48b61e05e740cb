//! The `feedback` table: the operator's verdict on an offered prediction (accepted, adjusted by
//! so many mm, or rejected), at most one per prediction, and a cell's counts of them.

use super::Store;
use super::audit;
use super::cell_write::CellWrite;
use super::error::{Result, classify};
use super::rows::{CellState, FeedbackCounts, NewFeedback, Stored, TeachingVerdictRow, flag, real};
use super::transaction::{Tx, touch_cell};

impl Store {
    /// Stores feedback on a prediction that does not teach the cell; `Conflict` when it
    /// already has some.
    pub async fn insert_feedback(&self, fb: &NewFeedback) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        insert(&mut tx, fb).await?;
        audit::record(&mut tx, None).await?;
        tx.commit().await?;
        Ok(())
    }

    /// Stores feedback that teaches cell `cell_id`, as a write the model in memory made at
    /// revision `expected` (refused as [`super::StorageError::Stale`] when the cell moved on):
    /// the revision advances, and a model of the cell elsewhere learns it again.
    pub async fn insert_teaching_feedback(
        &self,
        fb: &NewFeedback,
        cell_id: i64,
        expected: i64,
    ) -> Result<CellState> {
        let mut tx = self.pool.begin().await?;
        let state = touch_cell(&mut tx, cell_id, CellWrite::following_alone(expected)).await?;
        insert(&mut tx, fb).await?;
        tx.commit().await?;
        Ok(state)
    }

    /// The feedback on a routine's predictions that teaches the cell, in the order the
    /// predictions were made.
    pub async fn teaching_verdicts(&self, routine_id: i64) -> Result<Vec<TeachingVerdictRow>> {
        let sql = format!(
            "SELECT {} FROM {} WHERE p.routine_id = $1 AND f.teaches = 1 ORDER BY p.id",
            TeachingVerdictRow::COLUMNS,
            TeachingVerdictRow::FROM
        );
        Ok(
            sqlx::query_as::<_, TeachingVerdictRow>(sqlx::AssertSqlSafe(sql))
                .bind(routine_id)
                .fetch_all(&self.pool)
                .await?,
        )
    }

    /// Offered/accepted/adjusted/rejected counts and the adjustment distances of a cell.
    pub async fn feedback_counts(&self, cell_id: i64) -> Result<FeedbackCounts> {
        let (offered,): (i64,) =
            sqlx::query_as("SELECT COUNT(*) FROM predictions WHERE cell_id = $1")
                .bind(cell_id)
                .fetch_one(&self.pool)
                .await?;
        let verdicts: Vec<(String, Option<f64>)> = sqlx::query_as(
            "SELECT f.verdict, f.adjustment_mm FROM feedback f \
             JOIN predictions p ON p.id = f.prediction_id WHERE p.cell_id = $1",
        )
        .bind(cell_id)
        .fetch_all(&self.pool)
        .await?;
        let mut counts = FeedbackCounts {
            offered,
            ..FeedbackCounts::default()
        };
        for (verdict, adjustment) in verdicts {
            match verdict.as_str() {
                "accepted" => counts.accepted += 1,
                "adjusted" => {
                    counts.adjusted += 1;
                    if let Some(a) = adjustment {
                        counts.adjustments_mm.push(a);
                    }
                }
                _ => counts.rejected += 1,
            }
        }
        Ok(counts)
    }
}

/// Inserts a feedback row; `Conflict` when the prediction already has feedback.
async fn insert(tx: &mut Tx<'_>, fb: &NewFeedback) -> Result<()> {
    let p = fb.pose.as_ref();
    sqlx::query(
        "INSERT INTO feedback (prediction_id, verdict, x, y, z, qw, qx, qy, qz, adjustment_mm, \
         teaches) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11)",
    )
    .bind(fb.prediction_id)
    .bind(fb.verdict)
    .bind(real(p.map(|p| p.x)))
    .bind(real(p.map(|p| p.y)))
    .bind(real(p.map(|p| p.z)))
    .bind(real(p.map(|p| p.qw)))
    .bind(real(p.map(|p| p.qx)))
    .bind(real(p.map(|p| p.qy)))
    .bind(real(p.map(|p| p.qz)))
    .bind(real(fb.adjustment_mm))
    .bind(flag(fb.teaches))
    .execute(&mut **tx)
    .await
    .map_err(classify)?;
    Ok(())
}
