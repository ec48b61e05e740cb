-- Bearer tokens with a role and, optionally, the cells they are limited to (app::access).
-- Only the SHA-256 of each secret is kept (hex): the secret is shown once, at creation.
-- A revoked token keeps its row (who had access, and until when) and is unknown to the
-- service; its name may be given to a new token.
CREATE TABLE tokens (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    name TEXT NOT NULL,
    role TEXT NOT NULL CHECK (role IN ('operator', 'engineer', 'admin')),
    secret_sha256 TEXT NOT NULL UNIQUE,
    -- 1: every cell; 0: only the cells in token_cells (none left after they are all deleted:
    -- deleting a cell must never widen a token to every cell).
    all_cells INTEGER NOT NULL CHECK (all_cells IN (0, 1)),
    created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    revoked_at TEXT
);
CREATE UNIQUE INDEX tokens_active_name ON tokens (name) WHERE revoked_at IS NULL;

CREATE TABLE token_cells (
    token_id INTEGER NOT NULL REFERENCES tokens (id) ON DELETE CASCADE,
    cell_id INTEGER NOT NULL REFERENCES cells (id) ON DELETE CASCADE,
    PRIMARY KEY (token_id, cell_id)
);
