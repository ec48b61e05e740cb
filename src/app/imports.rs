//! Importing offline programs (RAPID, KRL, FANUC TP) into a cell as finished programs, learned
//! in program order unless asked not to.

use super::error::AppError;
use super::registry::blocking;
use super::rows::program;
use super::{App, MAX_NAME, Result, check_name};
use crate::api::{
    ImportRequest, ImportResult, ImportedProgram, ModelInfo, MotionType, PoseValues, Skipped,
};
use crate::storage::{NewImportedRoutine, WaypointValues};

/// The motion type of an imported instruction (`MoveL`, `ArcCStart`, `PTP`, `L`, `C`, ...).
fn motion_of(instruction: &str) -> MotionType {
    let m = instruction.to_ascii_lowercase();
    if m == "j" || m == "ptp" || m.starts_with("ptp_") || m.starts_with("movej") {
        MotionType::Joint
    } else if m == "c"
        || m.starts_with("movec")
        || m.starts_with("arcc")
        || m.starts_with("circ")
        || m.starts_with("triggc")
    {
        MotionType::Circular
    } else {
        MotionType::Linear
    }
}

impl App {
    /// Imports offline programs (RAPID, KRL, FANUC TP) into a cell as new programs whose
    /// routines take no teaching (edits apply); with `learn` (default) the model learns them in program order.
    /// All of it is one transaction: a syntax error or a name clash imports nothing.
    pub async fn import(&self, cell_id: i64, input: ImportRequest) -> Result<ImportResult> {
        self.to_completion(move |app| async move { app.import_now(cell_id, input).await })
            .await
    }

    async fn import_now(&self, cell_id: i64, input: ImportRequest) -> Result<ImportResult> {
        if input.files.is_empty() {
            return Err(AppError::Invalid("no files to import".into()));
        }
        for f in &input.files {
            check_name("file name", &f.name)?;
        }
        let learn = input.learn.unwrap_or(true);
        // Parsing is CPU work (seconds for large uploads): off the async workers.
        let n_files = input.files.len();
        tracing::info!(cell = cell_id, files = n_files, "parsing an upload");
        let report = blocking(move || {
            let files: Vec<(&str, &str)> = input
                .files
                .iter()
                .map(|f| (f.name.as_str(), f.content.as_str()))
                .collect();
            // Two files of the upload that give programs of one name are refused here, naming
            // both (the database would only say that a name is taken).
            crate::import::parse_upload(&files)
        })
        .await??;
        tracing::info!(
            cell = cell_id,
            files = n_files,
            programs = report.programs.len(),
            skipped = report.skipped.len(),
            "parsed an upload"
        );
        let mut programs = Vec::with_capacity(report.programs.len());
        let mut poses = Vec::new();
        for p in &report.programs {
            let mut routines = Vec::with_capacity(p.routines.len());
            for r in &p.routines {
                let mut waypoints = Vec::with_capacity(r.waypoints.len());
                let mut taught = Vec::with_capacity(r.waypoints.len());
                for w in &r.waypoints {
                    let stored = PoseValues::from(&w.pose);
                    taught.push(stored.to_pose()?);
                    waypoints.push(WaypointValues {
                        pose: stored.into(),
                        joints: None,
                        motion: Some(motion_of(&w.motion).as_str().to_string()),
                        name: Some(w.name.chars().take(MAX_NAME).collect()),
                        reachable: None,
                    });
                }
                poses.push(taught);
                routines.push(NewImportedRoutine {
                    name: r.name.chars().take(MAX_NAME).collect(),
                    waypoints,
                });
            }
            programs.push((p.name.chars().take(MAX_NAME).collect::<String>(), routines));
        }
        self.cell_row(cell_id).await?;
        let mut locked = self.lock_cell_id(cell_id).await?;
        let model = locked.model()?;
        if learn && model.open.is_some() {
            return Err(AppError::Conflict(format!(
                "cell {cell_id} is teaching a routine; finish or delete it before importing \
                 with learn"
            )));
        }
        let (stored, state, last_finish) = self
            .store
            .import_programs(cell_id, &programs, learn)
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {cell_id} already has a program with one of the names {:?}",
                    programs.iter().map(|p| p.0.as_str()).collect::<Vec<_>>()
                )),
                other => other,
            })?;
        // Learning is CPU work too: on a blocking thread, with the cell's lock.
        let info = if learn {
            blocking(move || -> Result<ModelInfo> {
                let mut locked = locked;
                let model = locked.model()?;
                for routine in &poses {
                    for pose in routine {
                        model.teacher.teach(*pose);
                    }
                    model.teacher.finish_routine();
                }
                model.version = state.model_version;
                model.revision = state.revision;
                model.last_finish_seq = last_finish.unwrap_or(model.last_finish_seq);
                Ok(model.info())
            })
            .await??
        } else {
            model.revision = state.revision;
            model.info()
        };
        let out = stored
            .into_iter()
            .zip(&report.programs)
            .map(|((row, _), p)| ImportedProgram {
                program: program(row),
                language: format!("{:?}", p.language).to_lowercase(),
                source: p.source.clone(),
                routines: p.routines.len(),
                waypoints: p.routines.iter().map(|r| r.waypoints.len()).sum(),
            })
            .collect();
        let skipped = report
            .skipped
            .iter()
            .map(|s| Skipped {
                file: s.file.clone(),
                line: s.line,
                routine: s.routine.clone(),
                reason: serde_json::to_value(s.reason)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_else(|| format!("{:?}", s.reason)),
                text: s.text.clone(),
            })
            .collect();
        Ok(ImportResult {
            programs: out,
            skipped,
            model: info,
        })
    }
}
