//! The `predictions` table: the predictions offered to the operator, kept so that feedback can
//! refer to one and a cell's real-world precision can be counted ([`super::feedback`]).

use super::Store;
use super::audit;
use super::binds::Binds;
use super::error::Result;
use super::error::StorageError;
use super::inserts::insert_predictions;
use super::rows::{NewPrediction, PredictionRow};

impl Store {
    /// Records an offered prediction unless the same one is already recorded: made after the
    /// same waypoint (ids are never reused, so after an undo and a re-teach it is a new one),
    /// by the same model version, at the same pose. Returns its id either way.
    pub async fn record_prediction(&self, pr: &NewPrediction) -> Result<i64> {
        let mut tx = self.pool.begin().await?;
        let (last,): (Option<i64>,) = sqlx::query_as(
            "SELECT (SELECT id FROM waypoints WHERE routine_id = $1 ORDER BY seq DESC LIMIT 1)",
        )
        .bind(pr.routine_id)
        .fetch_one(&mut *tx)
        .await?;
        let existing: Option<(i64,)> = sqlx::query_as(
            "SELECT id FROM predictions WHERE routine_id = $1 AND after_seq = $2 \
             AND after_waypoint_id IS NOT DISTINCT FROM $3 AND model_version = $4 \
             AND x = $5 AND y = $6 AND z = $7 AND qw = $8 AND qx = $9 AND qy = $10 AND qz = $11 \
             ORDER BY id LIMIT 1",
        )
        .bind(pr.routine_id)
        .bind(pr.after_seq)
        .bind(last)
        .bind(pr.model_version)
        .pose(&pr.pose)
        .fetch_optional(&mut *tx)
        .await?;
        let id = match existing {
            // Found: nothing changes, and the request leaves no audit row for it (a retried
            // append, a prediction asked for again).
            Some((id,)) => id,
            None => {
                let (id, _) = insert_predictions(&mut tx, &[(pr, last)])
                    .await?
                    .pop()
                    .ok_or(StorageError::NotFound)?;
                audit::record(&mut tx, Some(pr.cell_id)).await?;
                id
            }
        };
        tx.commit().await?;
        Ok(id)
    }

    pub async fn prediction(&self, id: i64) -> Result<Option<PredictionRow>> {
        self.find("WHERE p.id = $1", &[id]).await
    }
}
