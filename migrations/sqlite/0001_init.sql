-- nextpose schema: cells own programs, programs own ordered routines, routines own waypoints in
-- teaching order. The database is the source of truth; each cell's model is rebuilt from it.

CREATE TABLE cells (
    id          INTEGER PRIMARY KEY,
    name        TEXT    NOT NULL UNIQUE,
    -- CellSettings as JSON (engine settings, robot model, frames); validated by the service.
    settings    TEXT    NOT NULL,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);

CREATE TABLE programs (
    id          INTEGER PRIMARY KEY,
    cell_id     INTEGER NOT NULL REFERENCES cells(id) ON DELETE CASCADE,
    name        TEXT    NOT NULL,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    UNIQUE (cell_id, name)
);

CREATE TABLE routines (
    id          INTEGER PRIMARY KEY,
    program_id  INTEGER NOT NULL REFERENCES programs(id) ON DELETE CASCADE,
    cell_id     INTEGER NOT NULL REFERENCES cells(id) ON DELETE CASCADE,
    -- Order of the routine within its program (1, 2, ...).
    position    INTEGER NOT NULL,
    name        TEXT,
    -- Set when the routine is finished: the order in which the cell's model assimilated it.
    finish_seq  INTEGER,
    finished_at TEXT,
    created_at  TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    UNIQUE (program_id, position),
    UNIQUE (cell_id, finish_seq)
);

-- At most one routine per cell is being taught at a time (one arm, one operator).
CREATE UNIQUE INDEX routines_one_open_per_cell ON routines (cell_id) WHERE finish_seq IS NULL;

CREATE TABLE waypoints (
    id          INTEGER PRIMARY KEY,
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
    UNIQUE (routine_id, seq)
);

-- Offered predictions, kept so feedback can refer to them and a cell's real-world precision
-- can be reported.
CREATE TABLE predictions (
    id            INTEGER PRIMARY KEY,
    cell_id       INTEGER NOT NULL REFERENCES cells(id) ON DELETE CASCADE,
    routine_id    INTEGER NOT NULL REFERENCES routines(id) ON DELETE CASCADE,
    -- Number of waypoints of the routine when the prediction was made.
    after_seq     INTEGER NOT NULL,
    x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
    qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
    phi           REAL NOT NULL,
    psi           REAL NOT NULL,
    misfit        REAL,
    end_probability REAL NOT NULL,
    model_version INTEGER NOT NULL,
    created_at    TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
CREATE INDEX predictions_by_routine ON predictions (routine_id, after_seq);
CREATE INDEX predictions_by_cell ON predictions (cell_id);

CREATE TABLE feedback (
    prediction_id INTEGER PRIMARY KEY REFERENCES predictions(id) ON DELETE CASCADE,
    verdict       TEXT    NOT NULL CHECK (verdict IN ('accepted', 'adjusted', 'rejected')),
    -- The pose finally taught, for adjusted predictions.
    x REAL, y REAL, z REAL, qw REAL, qx REAL, qy REAL, qz REAL,
    -- Distance (mm) between the prediction and the final pose (0 when accepted as is).
    adjustment_mm REAL,
    created_at    TEXT    NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
