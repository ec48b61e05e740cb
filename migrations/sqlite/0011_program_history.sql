-- Program history (storage::history): every change to a program's routines or waypoints is
-- a revision, numbered 1, 2, … per program, written in the transaction of the change. A
-- revision stores the change (what a reader needs to take it back: the values a waypoint had
-- before an edit, a deleted routine's waypoints), not a copy of the program; the program as of
-- a revision is its present state with the later revisions taken back. Revision 0 is the
-- program as it was when its history began (empty, for a program created since this
-- migration). A program's history goes with it.
CREATE TABLE program_history (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    program_id INTEGER NOT NULL REFERENCES programs(id) ON DELETE CASCADE,
    -- 1, 2, … within the program.
    revision INTEGER NOT NULL,
    at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    -- Who and how, as in the audit trail (NULL: a change made without a request, e.g. by
    -- the command line).
    token TEXT,
    request_id TEXT,
    operation TEXT,
    -- The changes, in the order made: a JSON array (storage::history::Change).
    changes TEXT NOT NULL,
    UNIQUE (program_id, revision)
);
