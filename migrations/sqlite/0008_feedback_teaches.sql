-- Feedback that teaches the cell: given while its routine was being taught, about the waypoint
-- just taught after the prediction or the next one (app::feedback). The cell's model applies it
-- with that waypoint, and a rebuild applies it again from here; older feedback taught nothing.
ALTER TABLE feedback ADD COLUMN teaches INTEGER NOT NULL DEFAULT 0;
