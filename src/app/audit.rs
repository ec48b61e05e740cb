//! The audit trail as the adapters use it: a request that may change something runs inside
//! a [`Recorder`] (who, which request, which operation), every write it makes puts the
//! request's one row in its own transaction (`storage::audit`), and once answered the adapter
//! hands over the answer ([`App::audit_answer`]): a failure after a change is written into the
//! row. `GET /v1/audit` reads it ([`App::audit`]).

use crate::api::{AuditEntry, AuditPage, AuditQuery};
use crate::storage::{AuditFilter, AuditRow};

pub use crate::storage::Recorder;

use super::{App, AppError, Result};

/// Entries per page unless asked.
pub const AUDIT_PAGE: u32 = 100;
/// Most entries per page.
pub const MAX_AUDIT_PAGE: u32 = 1000;

/// How `at` is stored (UTC, milliseconds), so that text order is time order.
const STORED: &[time::format_description::BorrowedFormatItem<'_>] = time::macros::format_description!(
    "[year]-[month]-[day]T[hour]:[minute]:[second].[subsecond digits:3]Z"
);

impl App {
    /// A page of the audit trail, newest first.
    pub async fn audit(&self, query: AuditQuery) -> Result<AuditPage> {
        let limit = query.limit.unwrap_or(AUDIT_PAGE);
        if !(1..=MAX_AUDIT_PAGE).contains(&limit) {
            return Err(AppError::Invalid(format!(
                "limit must be 1 to {MAX_AUDIT_PAGE}, not {limit}"
            )));
        }
        if query.before.is_some_and(|b| b < 1) {
            return Err(AppError::Invalid(
                "before must be an entry's id (≥ 1)".into(),
            ));
        }
        let since = query.since.as_deref().map(stored_time).transpose()?;
        let mut rows = self
            .store
            .audit_rows(&AuditFilter {
                cell_id: query.cell_id,
                since,
                before: query.before,
                // One more than the page: whether there is a next one.
                limit: i64::from(limit) + 1,
            })
            .await?;
        let more = rows.len() > limit as usize;
        rows.truncate(limit as usize);
        let next = more.then(|| rows.last().map(|r| r.id)).flatten();
        Ok(AuditPage {
            entries: rows.into_iter().map(entry).collect(),
            next,
        })
    }

    /// How a request was answered (`ok`: it succeeded, as its row says already; otherwise
    /// its status or code, written into its row if it changed something before it failed).
    /// A failure here is logged, not answered: the change and its row stand.
    pub async fn audit_answer(&self, recorder: &Recorder, ok: bool, answer: &str) {
        if ok {
            return;
        }
        if let Err(e) = self.store.audit_failure(recorder, answer).await {
            tracing::error!(error = %e, "recording a request's outcome in the audit trail");
        }
    }
}

/// An RFC 3339 time as `at` is stored; a client's typo is a 422 naming the format.
fn stored_time(text: &str) -> Result<String> {
    let parsed = time::OffsetDateTime::parse(text, &time::format_description::well_known::Rfc3339)
        .map_err(|e| {
            AppError::Invalid(format!(
                "since must be an RFC 3339 time such as 2026-12-06T08:00:00Z ({e}), not {text:?}"
            ))
        })?;
    parsed
        .to_offset(time::UtcOffset::UTC)
        .format(STORED)
        .map_err(|e| AppError::Invalid(format!("since {text:?} cannot be used: {e}")))
}

fn entry(r: AuditRow) -> AuditEntry {
    AuditEntry {
        id: r.id,
        at: r.at,
        token: r.token,
        request_id: r.request_id,
        operation: r.operation,
        target: r.target,
        cell_id: r.cell_id,
        outcome: r.outcome,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn since_is_compared_as_stored() {
        assert_eq!(
            stored_time("2026-12-06T09:00:00+01:00").unwrap(),
            "2026-12-06T08:00:00.000Z"
        );
        assert_eq!(
            stored_time("2026-12-06T08:00:00.5Z").unwrap(),
            "2026-12-06T08:00:00.500Z"
        );
        assert!(matches!(
            stored_time("yesterday"),
            Err(AppError::Invalid(_))
        ));
    }
}
