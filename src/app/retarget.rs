//! Re-targeting a routine or a program to a moved fixture: given the moved work object's frame,
//! or three points measured on the fixture in its old and new place, every waypoint is moved
//! rigidly with it ([`crate::kinematics::fixture`]), checked against the cell's arm, and the
//! result stored as a new program (or a new routine at the end of the routine's program),
//! finished and not learned: it was not taught. Taught joints do not move with the fixture, so
//! the copy has none.

use nalgebra::Isometry3;

use super::cell_model::stored_pose;
use super::error::AppError;
use super::reach::CellArm;
use super::rows::{program, routine, waypoint};
use super::settings::parse_settings;
use super::{App, Result, check_name};
use crate::api::{PoseValues, Retarget, Retargeted, RoutineDetail};
use crate::kinematics::Joints;
use crate::kinematics::fixture::{fixture_move, moved_pose};
use crate::storage::{NewImportedRoutine, ProgramRow, WaypointRow, WaypointValues};

/// The rigid move a request describes, checked.
fn the_move(input: &Retarget) -> Result<Isometry3<f64>> {
    match (&input.frame, &input.points) {
        (Some(frame), None) => Ok(*frame.to_pose()?.isometry()),
        (None, Some(points)) => {
            let three = |what: &str, v: &[[f64; 3]]| -> Result<[[f64; 3]; 3]> {
                v.try_into().map_err(|_| {
                    AppError::Invalid(format!(
                        "points.{what} must hold 3 points (origin, x axis, xy plane), not {}",
                        v.len()
                    ))
                })
            };
            fixture_move(three("old", &points.old)?, three("new", &points.new)?)
                .map_err(|e| AppError::Invalid(format!("points: {e}")))
        }
        _ => Err(AppError::Invalid(
            "give exactly one of frame (the moved work object) and points (old and new)".into(),
        )),
    }
}

impl App {
    /// The waypoints of the stored routines, moved, with the arm's verdict on each.
    fn moved_waypoints(
        arm: Option<&CellArm>,
        moved: &Isometry3<f64>,
        rows: &[WaypointRow],
        unreachable: &mut usize,
    ) -> Result<Vec<WaypointValues>> {
        let mut previous: Option<Joints> = None;
        let mut out = Vec::with_capacity(rows.len());
        for w in rows {
            let pose = moved_pose(moved, &stored_pose(w)?);
            // As it will be read back from the database.
            let stored = PoseValues::from(&pose);
            let pose = stored.to_pose()?;
            let reachable = arm.map(|arm| {
                let reach = arm.check(&pose, previous.as_ref());
                previous = reach.chosen.or(previous);
                reach.is_reachable()
            });
            if reachable == Some(false) {
                *unreachable += 1;
            }
            out.push(WaypointValues {
                pose: stored,
                joints: None,
                motion: w.motion.clone(),
                name: w.name.clone(),
                reachable,
            });
        }
        Ok(out)
    }

    async fn retargeted(
        &self,
        p: ProgramRow,
        ids: &[i64],
        unreachable: usize,
    ) -> Result<Retargeted> {
        let mut routines = Vec::with_capacity(ids.len());
        for id in ids {
            let r = self.routine_row(*id).await?;
            let waypoints = self.store.waypoints(*id).await?;
            routines.push(RoutineDetail {
                routine: routine(r),
                waypoints: waypoints.into_iter().map(waypoint).collect::<Result<_>>()?,
            });
        }
        Ok(Retargeted {
            program: program(p),
            routines,
            unreachable,
        })
    }

    /// A copy of a routine on the moved fixture, at the end of its program.
    pub async fn retarget_routine(&self, id: i64, input: Retarget) -> Result<Retargeted> {
        if let Some(n) = &input.name {
            check_name("routine name", n)?;
        }
        let moved = the_move(&input)?;
        let r = self.routine_row(id).await?;
        let p = self.program_row(r.program_id).await?;
        let settings = parse_settings(&self.cell_row(r.cell_id).await?)?;
        let arm = self.cell_arm(&settings)?;
        let rows = self.store.waypoints(id).await?;
        let mut unreachable = 0;
        let values = Self::moved_waypoints(arm.as_ref(), &moved, &rows, &mut unreachable)?;
        let name = input
            .name
            .map(|n| n.trim().to_string())
            .unwrap_or_else(|| match &r.name {
                Some(n) => format!("{n} (moved)"),
                None => format!("routine {} (moved)", r.position),
            });
        let new = self
            .store
            .insert_unlearned_routine(&p, Some(&name), &values)
            .await?;
        self.retargeted(p, &[new], unreachable).await
    }

    /// A copy of a program on the moved fixture, as a new program of the same cell.
    pub async fn retarget_program(&self, id: i64, input: Retarget) -> Result<Retargeted> {
        if let Some(n) = &input.name {
            check_name("program name", n)?;
        }
        let moved = the_move(&input)?;
        let p = self.program_row(id).await?;
        let settings = parse_settings(&self.cell_row(p.cell_id).await?)?;
        let arm = self.cell_arm(&settings)?;
        let mut unreachable = 0;
        let mut routines = Vec::new();
        for r in self.store.routines(id).await? {
            let rows = self.store.waypoints(r.id).await?;
            let values = Self::moved_waypoints(arm.as_ref(), &moved, &rows, &mut unreachable)?;
            routines.push(NewImportedRoutine {
                name: r
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("routine {}", r.position)),
                waypoints: values,
            });
        }
        let name = input
            .name
            .map(|n| n.trim().to_string())
            .unwrap_or_else(|| format!("{} (moved)", p.name));
        let (stored, _, _) = self
            .store
            .import_programs(p.cell_id, &[(name.clone(), routines)], false)
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {} already has a program named {name:?}",
                    p.cell_id
                )),
                other => other,
            })?;
        let Some((row, ids)) = stored.into_iter().next() else {
            return Err(AppError::Internal("the copy was not stored".into()));
        };
        self.retargeted(row, &ids, unreachable).await
    }
}
