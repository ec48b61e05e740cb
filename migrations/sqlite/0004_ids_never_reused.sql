-- no-transaction
-- Ids that clients hold are never handed out twice: every table whose ids leave the service
-- gets AUTOINCREMENT (without it SQLite reuses the largest id after a delete, so a deleted
-- routine's id came back as another cell's routine). Predictions also record the waypoint
-- they followed, so one made after an undo and a re-teach is a new prediction, not the old
-- one with its feedback.
--
-- SQLite cannot add AUTOINCREMENT to a table: each table is rebuilt (the documented 12-step
-- procedure) with foreign keys off, which a transaction cannot change, hence no-transaction
-- and an explicit transaction below. Copying keeps every id; sqlite_sequence starts after the
-- largest. Re-running after a crash between the commit and sqlx's bookkeeping redoes the same
-- copy and ends in the same state.

PRAGMA foreign_keys = OFF;
BEGIN;

DROP TABLE IF EXISTS cells_new;
DROP TABLE IF EXISTS programs_new;
DROP TABLE IF EXISTS routines_new;
DROP TABLE IF EXISTS waypoints_new;
DROP TABLE IF EXISTS predictions_new;
DROP TABLE IF EXISTS feedback_new;

CREATE TABLE cells_new (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    name        TEXT    NOT NULL UNIQUE,
    -- CellSettings as JSON (engine settings, robot model, frames); validated by the service.
    settings    TEXT    NOT NULL,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
INSERT INTO cells_new (id, name, settings, created_at)
    SELECT id, name, settings, created_at FROM cells;

CREATE TABLE programs_new (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    cell_id     INTEGER NOT NULL REFERENCES cells(id) ON DELETE CASCADE,
    name        TEXT    NOT NULL,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    UNIQUE (cell_id, name)
);
INSERT INTO programs_new (id, cell_id, name, created_at)
    SELECT id, cell_id, name, created_at FROM programs;

CREATE TABLE routines_new (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    program_id  INTEGER NOT NULL REFERENCES programs(id) ON DELETE CASCADE,
    cell_id     INTEGER NOT NULL REFERENCES cells(id) ON DELETE CASCADE,
    -- Order of the routine within its program (1, 2, ...).
    position    INTEGER NOT NULL,
    name        TEXT,
    -- Set when the routine is finished: the order in which the cell's model assimilated it.
    finish_seq  INTEGER,
    finished_at TEXT,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    -- Imported from an offline program: immutable like finished routines; learned only when
    -- the import asked for it (finish_seq set, in program order).
    imported    INTEGER NOT NULL DEFAULT 0,
    UNIQUE (program_id, position),
    UNIQUE (cell_id, finish_seq)
);
INSERT INTO routines_new (id, program_id, cell_id, position, name, finish_seq, finished_at,
                          created_at, imported)
    SELECT id, program_id, cell_id, position, name, finish_seq, finished_at, created_at, imported
    FROM routines;

CREATE TABLE waypoints_new (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    routine_id  INTEGER NOT NULL REFERENCES routines(id) ON DELETE CASCADE,
    -- Teaching order within the routine (1, 2, ...).
    seq         INTEGER NOT NULL,
    x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
    qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
    -- Optional taught joint values (JSON array of radians).
    joints      TEXT,
    motion      TEXT,
    name        TEXT,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    -- Whether the cell's arm reaches the waypoint (NULL: not checked).
    reachable   INTEGER,
    UNIQUE (routine_id, seq)
);
INSERT INTO waypoints_new (id, routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name,
                           created_at, reachable)
    SELECT id, routine_id, seq, x, y, z, qw, qx, qy, qz, joints, motion, name, created_at,
           reachable
    FROM waypoints;

CREATE TABLE predictions_new (
    id            INTEGER PRIMARY KEY AUTOINCREMENT,
    cell_id       INTEGER NOT NULL REFERENCES cells(id) ON DELETE CASCADE,
    routine_id    INTEGER NOT NULL REFERENCES routines(id) ON DELETE CASCADE,
    -- Number of waypoints of the routine when the prediction was made.
    after_seq     INTEGER NOT NULL,
    -- The routine's last waypoint then (NULL: none, or made before this column existed). Not a
    -- foreign key: an undo deletes the waypoint, the offered prediction stays recorded.
    after_waypoint_id INTEGER,
    x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
    qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
    phi           REAL NOT NULL,
    psi           REAL NOT NULL,
    misfit        REAL,
    end_probability REAL NOT NULL,
    model_version INTEGER NOT NULL,
    created_at    TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
INSERT INTO predictions_new (id, cell_id, routine_id, after_seq, x, y, z, qw, qx, qy, qz, phi,
                             psi, misfit, end_probability, model_version, created_at)
    SELECT id, cell_id, routine_id, after_seq, x, y, z, qw, qx, qy, qz, phi, psi, misfit,
           end_probability, model_version, created_at
    FROM predictions;

CREATE TABLE feedback_new (
    prediction_id INTEGER PRIMARY KEY REFERENCES predictions(id) ON DELETE CASCADE,
    verdict       TEXT    NOT NULL CHECK (verdict IN ('accepted', 'adjusted', 'rejected')),
    -- The pose finally taught, for adjusted predictions.
    x REAL, y REAL, z REAL, qw REAL, qx REAL, qy REAL, qz REAL,
    -- Distance (mm) between the prediction and the final pose (0 when accepted as is).
    adjustment_mm REAL,
    created_at    TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
INSERT INTO feedback_new SELECT * FROM feedback;

DROP TABLE feedback;
DROP TABLE predictions;
DROP TABLE waypoints;
DROP TABLE routines;
DROP TABLE programs;
DROP TABLE cells;

ALTER TABLE cells_new RENAME TO cells;
ALTER TABLE programs_new RENAME TO programs;
ALTER TABLE routines_new RENAME TO routines;
ALTER TABLE waypoints_new RENAME TO waypoints;
ALTER TABLE predictions_new RENAME TO predictions;
ALTER TABLE feedback_new RENAME TO feedback;

-- At most one routine per cell is being taught at a time (one arm, one operator).
CREATE UNIQUE INDEX routines_one_open_per_cell ON routines (cell_id)
    WHERE finish_seq IS NULL AND imported = 0;
CREATE INDEX predictions_by_routine ON predictions (routine_id, after_seq);
CREATE INDEX predictions_by_cell ON predictions (cell_id);

COMMIT;
PRAGMA foreign_keys = ON;
