//! The `feedback` table: the operator's verdict on an offered prediction (accepted, adjusted by
//! so many mm, or rejected), at most one per prediction, and a cell's counts of them.

use super::Store;
use super::error::{Result, classify};
use super::rows::{FeedbackCounts, NewFeedback, real};

impl Store {
    /// Stores feedback on a prediction; `Conflict` when it already has some.
    pub async fn insert_feedback(&self, fb: &NewFeedback) -> Result<()> {
        let p = fb.pose.as_ref();
        sqlx::query(
            "INSERT INTO feedback (prediction_id, verdict, x, y, z, qw, qx, qy, qz, adjustment_mm) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10)",
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
        .execute(&self.pool)
        .await
        .map_err(classify)?;
        Ok(())
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
