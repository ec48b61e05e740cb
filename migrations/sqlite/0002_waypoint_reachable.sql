-- Whether the cell's arm reaches a taught waypoint (NULL: not checked). Unreachable waypoints
-- are stored all the same (the operator is the authority) but flagged.
ALTER TABLE waypoints ADD COLUMN reachable INTEGER;
