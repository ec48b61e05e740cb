-- Routines imported from offline programs. They are immutable like finished routines; when the
-- import asks for it they are also learned (finish_seq set, in program order), otherwise they
-- are kept for replay and reference only (finish_seq NULL, not open).
ALTER TABLE routines ADD COLUMN imported INTEGER NOT NULL DEFAULT 0;
DROP INDEX routines_one_open_per_cell;
CREATE UNIQUE INDEX routines_one_open_per_cell ON routines (cell_id)
    WHERE finish_seq IS NULL AND imported = 0;
