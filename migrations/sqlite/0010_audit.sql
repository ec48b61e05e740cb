-- The audit trail (storage::audit): one row per request that changed the database, written in
-- the same transaction as its (first) change, so a change without its row, or a row without
-- its change, cannot be. Rows are only ever appended; they outlive what they name (no foreign
-- keys: a deleted cell's history stays).
CREATE TABLE audit (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    -- The token's name (bootstrap, anonymous or a stored token's), never its secret.
    token TEXT NOT NULL,
    request_id TEXT NOT NULL,
    -- REST: the method and route ("POST /v1/routines/{routine_id}/waypoints"); gRPC: the
    -- method ("nextpose.v1.Nextpose/AppendWaypoint").
    operation TEXT NOT NULL,
    -- The resource the request named ("routine 12"), if it named one.
    target TEXT,
    -- The cell the change was to, if it was to a cell.
    cell_id INTEGER,
    -- "ok" when the request succeeded; when it failed after a change had committed (a
    -- request of several transactions), its answer ("500", "ABORTED").
    outcome TEXT NOT NULL,
    -- One row per request however many transactions it commits.
    request_key TEXT NOT NULL UNIQUE
);
CREATE INDEX audit_cell ON audit (cell_id, id);
