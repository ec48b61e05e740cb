-- When a cell's settings last changed (null: as created).
ALTER TABLE cells ADD COLUMN settings_changed_at TEXT;

-- A cell's model version: advanced each time its learned model changes (a routine finished or
-- imported to be learned, an edit of a learned routine), so predictions keep the version they
-- were made with. Until now it was the number of learned routines, so it starts there.
ALTER TABLE cells ADD COLUMN model_version INTEGER NOT NULL DEFAULT 0;
UPDATE cells SET model_version =
    (SELECT COUNT(*) FROM routines WHERE routines.cell_id = cells.id AND finish_seq IS NOT NULL);
