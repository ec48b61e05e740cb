//! Exporting a stored program as a controller file (RAPID, KRL, FANUC TP): the waypoints in the
//! cell's work frame with their names and motion types, the cell's speed and zone, and the arm
//! configuration of the joint solution the service chooses for each target (the taught joints
//! when the pendant sent them, else the solution nearest the previous target's, as the preview
//! of a prediction chooses it), so the controller takes the branch the pendant showed.

use super::cell_model::{stored_joint_values, stored_pose_values};
use super::error::AppError;
use super::registry::blocking;
use super::settings::parse_settings;
use super::{App, Result};
use crate::api::{ExportQuery, ExportedFile, ProgramExport};
use crate::export;
use crate::kinematics::{self, Joints};
use crate::program::{Motion, Program, Routine, Waypoint};
use crate::storage::WaypointState;

impl App {
    pub async fn export_program(&self, id: i64, query: ExportQuery) -> Result<ProgramExport> {
        let format =
            export::language_named(&query.format).map_err(|e| AppError::Invalid(e.to_string()))?;
        let p = self.program_row(id).await?;
        let settings = parse_settings(&self.cell_row(p.cell_id).await?)?;
        let arm = self.cell_arm(&settings)?;
        // As it is now, or as of the revision asked for.
        let (state, _) = self.program_state(id, query.revision).await?;
        let routines: Vec<(String, Vec<WaypointState>)> = state
            .routines
            .into_iter()
            .enumerate()
            .map(|(i, r)| {
                let name = r.name.unwrap_or_else(|| format!("routine{}", i + 1));
                (name, r.waypoints)
            })
            .collect();
        let (program_name, cell_id) = (p.name.clone(), p.cell_id);
        blocking(move || -> Result<ProgramExport> {
            let mut unreachable = Vec::new();
            let mut out = Vec::with_capacity(routines.len());
            for (name, rows) in routines {
                let mut previous: Option<Joints> = None;
                let mut waypoints = Vec::with_capacity(rows.len());
                for w in &rows {
                    let pose = stored_pose_values(&w.values.pose)?;
                    let taught: Option<Joints> = stored_joint_values(w.id, &w.values.joints)?
                        .and_then(|j| j.as_slice().try_into().ok());
                    let (reachable, joints) = match &arm {
                        Some(arm) => {
                            let reach = arm.check(&pose, previous.as_ref());
                            (Some(reach.is_reachable()), taught.or(reach.chosen))
                        }
                        None => (w.values.reachable, taught),
                    };
                    if reachable == Some(false) {
                        unreachable.push(w.id);
                    }
                    previous = joints.or(previous);
                    let configuration = match (&arm, &joints) {
                        (Some(arm), Some(q)) => kinematics::configuration(arm.robot(), q)
                            .ok()
                            .map(|c| c.written(format)),
                        _ => None,
                    };
                    let v = &w.values;
                    waypoints.push(Waypoint {
                        name: v.name.clone(),
                        pose,
                        // One without a motion type (or with one the service does not know)
                        // is moved to linearly by the exporter.
                        motion: v.motion.as_deref().and_then(Motion::parse),
                        configuration,
                        reachable,
                    });
                }
                out.push(Routine { name, waypoints });
            }
            let program = Program::stored(program_name, cell_id, out);
            let exported = export::export(&program, format, &settings.export)
                .map_err(|e| AppError::Invalid(e.to_string()))?;
            Ok(ProgramExport {
                format: format.as_str().to_string(),
                files: exported
                    .files
                    .into_iter()
                    .map(|f| ExportedFile {
                        file_name: f.file_name,
                        text: f.text,
                    })
                    .collect(),
                warnings: exported.warnings.iter().map(ToString::to_string).collect(),
                unreachable,
            })
        })
        .await?
    }
}
