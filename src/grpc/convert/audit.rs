//! The audit trail: which entries to list, an entry, a page.

use crate::api::{AuditEntry, AuditPage, AuditQuery};

use super::wire::both_ways;

both_ways!(plain AuditQuery => ListAuditRequest { cell_id, since, before, limit });
both_ways!(AuditEntry => AuditEntry {
    id, at, token, request_id, operation, target, cell_id, outcome,
});
both_ways!(AuditPage => AuditPage { entries, next });
