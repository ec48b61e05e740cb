-- Arm models uploaded through the API (POST /v1/robots), beside the bundled ones in robots/.
-- The URDF text is kept as uploaded; the service loads and checks it again at start-up.
CREATE TABLE robots (
    name TEXT PRIMARY KEY NOT NULL,
    urdf TEXT NOT NULL,
    -- What the data sheet says, when the uploader gave it.
    maker TEXT,
    product TEXT,
    payload_kg REAL,
    created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
