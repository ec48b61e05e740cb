-- Every write to a cell advances its revision; one after which a model of the cell in another
-- service instance's memory cannot follow incrementally (an edit, new settings, an import to
-- be learned, an open routine deleted) also sets reload_revision to it. A write that follows
-- the model in memory checks the revision it was made at, in its transaction (see
-- storage::CellWrite): several instances on one database never let a model diverge from it.
ALTER TABLE cells ADD COLUMN revision INTEGER NOT NULL DEFAULT 0;
ALTER TABLE cells ADD COLUMN reload_revision INTEGER NOT NULL DEFAULT 0;
