//! Importing offline programs (RAPID, KRL, FANUC TP) into a cell as finished programs, learned
//! in program order unless asked not to.

use super::error::AppError;
use super::registry::blocking;
use super::rows::program;
use super::{App, MAX_NAME, Result, check_name};
use crate::api::{
    ImportRequest, ImportResult, ImportedProgram, ModelInfo, PoseValues, Program, Skipped,
};
use crate::engine::Pose;
use crate::import;
use crate::program::Waypoint;
use crate::storage::{NewImportedRoutine, WaypointValues};

impl App {
    /// Imports offline programs (RAPID, KRL, FANUC TP) into a cell as new programs whose
    /// routines take no teaching (edits apply); with `learn` (default) the model learns them in program order.
    /// All of it is one transaction: a syntax error or a name clash imports nothing.
    pub async fn import(&self, cell_id: i64, input: ImportRequest) -> Result<ImportResult> {
        self.to_completion(move |app| async move { app.import_now(cell_id, input).await })
            .await
    }

    async fn import_now(&self, cell_id: i64, input: ImportRequest) -> Result<ImportResult> {
        check_upload(&input)?;
        let learn = input.learn.unwrap_or(true);
        let report = parse(cell_id, input).await?;
        let upload = Upload::of(&report)?;
        self.cell_row(cell_id).await?;
        let mut locked = self.lock_cell_id(cell_id).await?;
        if learn && locked.model()?.open.is_some() {
            return Err(AppError::Conflict(format!(
                "cell {cell_id} is teaching a routine; finish or delete it before importing \
                 with learn"
            )));
        }
        let (stored, state, last_finish) = self
            .store
            .import_programs(cell_id, &upload.programs, learn)
            .await
            .map_err(|e| match AppError::from(e) {
                AppError::Conflict(_) => AppError::Exists(format!(
                    "cell {cell_id} already has a program with one of the names {:?}",
                    upload
                        .programs
                        .iter()
                        .map(|p| p.0.as_str())
                        .collect::<Vec<_>>()
                )),
                other => other,
            })?;
        let info = if learn {
            // Learning is CPU work too: on a blocking thread, with the cell's lock.
            let poses = upload.poses;
            blocking(move || -> Result<ModelInfo> {
                let mut locked = locked;
                let model = locked.model()?;
                model.learned(&poses, &state, last_finish);
                Ok(model.info())
            })
            .await??
        } else {
            let model = locked.model()?;
            model.moved_to(state.revision);
            model.info()
        };
        let programs = stored
            .into_iter()
            .zip(&report.programs)
            .map(|((row, _), p)| imported(program(row), p))
            .collect();
        Ok(ImportResult {
            programs,
            skipped: report.skipped.iter().map(skipped).collect(),
            model: info,
        })
    }
}

/// What is checked of an upload before anything is parsed.
fn check_upload(input: &ImportRequest) -> Result<()> {
    if input.files.is_empty() {
        return Err(AppError::Invalid("no files to import".into()));
    }
    for f in &input.files {
        check_name("file name", &f.name)?;
    }
    Ok(())
}

/// Parses an upload. Parsing is CPU work (seconds for large uploads): off the async workers.
async fn parse(cell_id: i64, input: ImportRequest) -> Result<import::ImportReport> {
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
        import::parse_upload(&files)
    })
    .await??;
    tracing::info!(
        cell = cell_id,
        files = n_files,
        programs = report.programs.len(),
        skipped = report.skipped.len(),
        "parsed an upload"
    );
    Ok(report)
}

/// The routines an upload teaches a cell's model, in program order, each pose checked and as
/// it will be read back from the database: the pure part of an import between the parser and
/// the engine, which the fuzz target `import` drives (parse, this, then
/// [`crate::engine::Teacher::learn_routine`] for each, as [`App::import`] learns them).
pub fn routines_learned(report: &import::ImportReport) -> Result<Vec<Vec<Pose>>> {
    Upload::of(report).map(|u| u.poses)
}

/// A parsed upload in the two shapes it is used in: the rows to store (programs by name, with
/// their routines) and, routine by routine, the poses the model learns — as they will be read
/// back from the database, so that a rebuild gives bit-identical results.
struct Upload {
    programs: Vec<(String, Vec<NewImportedRoutine>)>,
    poses: Vec<Vec<Pose>>,
}

impl Upload {
    fn of(report: &import::ImportReport) -> Result<Upload> {
        let mut programs = Vec::with_capacity(report.programs.len());
        let mut poses = Vec::new();
        for p in &report.programs {
            let p = &p.program;
            let mut routines = Vec::with_capacity(p.routines.len());
            for r in &p.routines {
                let (waypoints, taught) = r
                    .waypoints
                    .iter()
                    .map(|w| {
                        let stored = PoseValues::from(&w.pose);
                        let pose = stored.to_pose()?;
                        Ok((waypoint(w, stored), pose))
                    })
                    .collect::<Result<(Vec<_>, Vec<_>)>>()?;
                poses.push(taught);
                routines.push(NewImportedRoutine {
                    name: truncated(&r.name),
                    waypoints,
                });
            }
            programs.push((truncated(&p.name), routines));
        }
        Ok(Upload { programs, poses })
    }
}

/// The stored values of an imported waypoint.
fn waypoint(w: &Waypoint, pose: PoseValues) -> WaypointValues {
    WaypointValues {
        pose,
        joints: None,
        motion: w.motion.map(|m| m.as_str().to_string()),
        name: w.name.as_deref().map(truncated),
        reachable: None,
    }
}

/// A name from a program, cut to the longest name stored.
fn truncated(name: &str) -> String {
    name.chars().take(MAX_NAME).collect()
}

/// The wire's imported program, from the stored program's row and the program read.
fn imported(program: Program, p: &import::Imported) -> ImportedProgram {
    ImportedProgram {
        program,
        language: p.program.language_name().to_string(),
        source: p.source(),
        routines: p.program.routines.len(),
        waypoints: p.program.waypoint_count(),
    }
}

fn skipped(s: &import::Skipped) -> Skipped {
    Skipped {
        file: s.file.clone(),
        line: s.line,
        routine: s.routine.clone(),
        reason: s.reason.as_str().to_string(),
        text: s.text.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::{EngineConfig, Teacher};

    /// The fuzz target `rapid` found this in 22 s on the code before issue 46's fixes (one
    /// flipped character in a corpus file, `1790.90` → `1790e90`, minimised by libFuzzer): the
    /// second target's y of 1e90 passed the importer, and the sequence experts' grid overflowed
    /// an i64 (a panic in a debug build, a 500 from the route). Now the upload is refused naming
    /// the file, line and value; and the engine taught the two poses directly does not panic.
    #[test]
    fn the_fuzzers_finding_is_refused_and_no_longer_panics_the_engine() {
        let found = "pROC s()MoveJ[[1,1,9],[0,.347,.938,0]];ArcL[[7,1e90,1],[.04,.342,.938,0]]";
        let err = import::parse_upload(&[("fuzz.mod", found)]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "fuzz.mod line 1: y = 1e90 is outside ±100000 mm (target literal@L1)"
        );
        // What the importer let through before: the poses as written, taught as the import
        // route teaches them.
        let report = import::parse_upload(&[("fuzz.mod", &found.replace("1e90", "1e3"))])
            .unwrap_or_else(|e| panic!("{e}"));
        let mut routines = routines_learned(&report).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(routines.len(), 1);
        let far = routines[0][1].values();
        routines[0][1] = Pose::new([far.x, 1e90, far.z], [far.qw, far.qx, far.qy, far.qz])
            .unwrap_or_else(|e| panic!("{e}"));
        for config in [
            EngineConfig::default(),
            EngineConfig::profile(crate::engine::Profile::Dissertation),
        ] {
            let mut teacher = Teacher::new(config).unwrap_or_else(|e| panic!("{e}"));
            for _ in 0..3 {
                teacher.learn_routine(&routines[0]);
                teacher.teach(routines[0][0]);
                let _ = teacher.predict();
                teacher.abandon_routine();
            }
            assert_eq!(teacher.stats().routines, 3);
        }
    }
}
