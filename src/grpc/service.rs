//! The unary calls of the API: each converts its request ([`super::convert`]), calls [`App`]
//! and maps an error once ([`super::status`]); the `Teach` stream is a session of its own
//! ([`super::teach`]).

use std::sync::Arc;

use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status, Streaming};

use crate::api::{CreateProgram, CreateRoutine, ExportQuery, Rename};
use crate::app::{App, AppError};

use super::convert;
use super::pb;
use super::pb::nextpose_server::Nextpose;
use super::status;
use super::teach;

/// The gRPC service over the application.
#[derive(Debug, Clone)]
pub struct Service {
    app: Arc<App>,
}

impl Service {
    pub fn new(app: Arc<App>) -> Service {
        Service { app }
    }
}

type Reply<T> = Result<Response<T>, Status>;

fn reply<T, U: From<T>>(r: Result<T, AppError>) -> Reply<U> {
    r.map(|v| Response::new(v.into())).map_err(status::status)
}

/// A call whose answer says only that it was done (a deletion).
fn done<T, U: Default>(r: Result<T, AppError>) -> Reply<U> {
    r.map(|_| Response::new(U::default()))
        .map_err(status::status)
}

/// The items of a list answer.
fn each<T, U: From<T>>(items: Vec<T>) -> Vec<U> {
    items.into_iter().map(Into::into).collect()
}

#[tonic::async_trait]
impl Nextpose for Service {
    async fn create_cell(&self, r: Request<pb::CreateCellRequest>) -> Reply<pb::Cell> {
        let input = convert::create_cell(r.into_inner())?;
        reply(self.app.create_cell(input).await)
    }

    async fn list_cells(&self, _: Request<pb::ListCellsRequest>) -> Reply<pb::ListCellsResponse> {
        let cells = self.app.cells().await;
        reply(cells.map(|cells| pb::ListCellsResponse { cells: each(cells) }))
    }

    async fn get_cell(&self, r: Request<pb::GetCellRequest>) -> Reply<pb::Cell> {
        reply(self.app.get_cell(r.into_inner().cell_id).await)
    }

    async fn get_cell_stats(&self, r: Request<pb::GetCellStatsRequest>) -> Reply<pb::CellStats> {
        reply(self.app.cell_stats(r.into_inner().cell_id).await)
    }

    async fn rebuild_model(&self, r: Request<pb::RebuildModelRequest>) -> Reply<pb::ModelInfo> {
        reply(self.app.rebuild(r.into_inner().cell_id).await)
    }

    async fn create_program(&self, r: Request<pb::CreateProgramRequest>) -> Reply<pb::Program> {
        let r = r.into_inner();
        reply(
            self.app
                .create_program(r.cell_id, CreateProgram { name: r.name })
                .await,
        )
    }

    async fn list_programs(
        &self,
        r: Request<pb::ListProgramsRequest>,
    ) -> Reply<pb::ListProgramsResponse> {
        let programs = self.app.programs(r.into_inner().cell_id).await;
        reply(programs.map(|programs| pb::ListProgramsResponse {
            programs: each(programs),
        }))
    }

    async fn get_program(&self, r: Request<pb::GetProgramRequest>) -> Reply<pb::Program> {
        reply(self.app.get_program(r.into_inner().program_id).await)
    }

    async fn create_routine(&self, r: Request<pb::CreateRoutineRequest>) -> Reply<pb::Routine> {
        let r = r.into_inner();
        reply(
            self.app
                .create_routine(r.program_id, CreateRoutine { name: r.name })
                .await,
        )
    }

    async fn list_routines(
        &self,
        r: Request<pb::ListRoutinesRequest>,
    ) -> Reply<pb::ListRoutinesResponse> {
        let routines = self.app.routines(r.into_inner().program_id).await;
        reply(routines.map(|routines| pb::ListRoutinesResponse {
            routines: each(routines),
        }))
    }

    async fn get_routine(&self, r: Request<pb::GetRoutineRequest>) -> Reply<pb::RoutineDetail> {
        reply(self.app.get_routine(r.into_inner().routine_id).await)
    }

    async fn delete_routine(
        &self,
        r: Request<pb::DeleteRoutineRequest>,
    ) -> Reply<pb::DeleteRoutineResponse> {
        done(self.app.delete_routine(r.into_inner().routine_id).await)
    }

    async fn edit_routine(&self, r: Request<pb::EditRoutineRequest>) -> Reply<pb::RoutineEdit> {
        let r = r.into_inner();
        let patch = convert::routine_patch(&r);
        reply(self.app.edit_routine(r.routine_id, patch).await)
    }

    async fn export_program(
        &self,
        r: Request<pb::ExportProgramRequest>,
    ) -> Reply<pb::ProgramExport> {
        let r = r.into_inner();
        let query = ExportQuery { format: r.format };
        reply(self.app.export_program(r.program_id, query).await)
    }

    async fn rename_program(&self, r: Request<pb::RenameProgramRequest>) -> Reply<pb::Program> {
        let r = r.into_inner();
        reply(
            self.app
                .rename_program(r.program_id, Rename { name: r.name })
                .await,
        )
    }

    async fn delete_program(
        &self,
        r: Request<pb::DeleteProgramRequest>,
    ) -> Reply<pb::DeleteProgramResponse> {
        done(self.app.delete_program(r.into_inner().program_id).await)
    }

    async fn update_cell(&self, r: Request<pb::UpdateCellRequest>) -> Reply<pb::Cell> {
        let r = r.into_inner();
        let id = r.cell_id;
        let patch = convert::cell_patch(r)?;
        reply(self.app.edit_cell(id, patch).await)
    }

    async fn calibrate_cell(&self, r: Request<pb::CalibrateCellRequest>) -> Reply<pb::Cell> {
        let r = r.into_inner();
        let id = r.cell_id;
        reply(self.app.calibrate(id, convert::calibration(r)).await)
    }

    async fn delete_cell(
        &self,
        r: Request<pb::DeleteCellRequest>,
    ) -> Reply<pb::DeleteCellResponse> {
        done(self.app.delete_cell(r.into_inner().cell_id).await)
    }

    async fn modify_waypoint(
        &self,
        r: Request<pb::ModifyWaypointRequest>,
    ) -> Reply<pb::WaypointEdit> {
        let r = r.into_inner();
        let patch = convert::waypoint_patch(&r)?;
        reply(self.app.modify_waypoint(r.waypoint_id, patch).await)
    }

    async fn insert_waypoint(
        &self,
        r: Request<pb::InsertWaypointRequest>,
    ) -> Reply<pb::WaypointEdit> {
        let r = r.into_inner();
        let id = r.waypoint_id;
        let input = convert::insert_waypoint(r)?;
        reply(self.app.insert_waypoint(id, input).await)
    }

    async fn delete_waypoint(
        &self,
        r: Request<pb::DeleteWaypointRequest>,
    ) -> Reply<pb::WaypointEdit> {
        reply(self.app.delete_waypoint(r.into_inner().waypoint_id).await)
    }

    async fn retarget_routine(&self, r: Request<pb::RetargetRequest>) -> Reply<pb::Retargeted> {
        let r = r.into_inner();
        let id = r.id;
        reply(self.app.retarget_routine(id, convert::retarget(r)).await)
    }

    async fn retarget_program(&self, r: Request<pb::RetargetRequest>) -> Reply<pb::Retargeted> {
        let r = r.into_inner();
        let id = r.id;
        reply(self.app.retarget_program(id, convert::retarget(r)).await)
    }

    async fn finish_routine(&self, r: Request<pb::FinishRoutineRequest>) -> Reply<pb::Finished> {
        reply(self.app.finish_routine(r.into_inner().routine_id).await)
    }

    async fn append_waypoint(&self, r: Request<pb::AppendWaypointRequest>) -> Reply<pb::Taught> {
        let r = r.into_inner();
        let input = convert::new_waypoint(r.waypoint.unwrap_or_default())?;
        reply(self.app.append_waypoint(r.routine_id, input).await)
    }

    async fn append_trajectory(
        &self,
        r: Request<pb::AppendTrajectoryRequest>,
    ) -> Reply<pb::TrajectoryAnswer> {
        let r = r.into_inner();
        let id = r.routine_id;
        let input = convert::trajectory_request(r)?;
        reply(self.app.append_trajectory(id, input).await)
    }

    async fn undo(&self, r: Request<pb::UndoRequest>) -> Reply<pb::Undone> {
        reply(self.app.undo(r.into_inner().routine_id).await)
    }

    async fn predict(&self, r: Request<pb::PredictRequest>) -> Reply<pb::PredictionSet> {
        let r = r.into_inner();
        let query = convert::predict_query(&r)?;
        reply(self.app.predict(r.routine_id, query).await)
    }

    async fn feedback(&self, r: Request<pb::FeedbackRequest>) -> Reply<pb::FeedbackRecorded> {
        let r = r.into_inner();
        let id = r.prediction_id;
        let input = convert::feedback(r)?;
        reply(self.app.feedback(id, input).await)
    }

    type TeachStream = ReceiverStream<Result<pb::TeachResponse, Status>>;

    async fn teach(&self, r: Request<Streaming<pb::TeachRequest>>) -> Reply<Self::TeachStream> {
        Ok(Response::new(teach::run(self.app.clone(), r.into_inner())))
    }

    async fn list_robots(
        &self,
        _: Request<pb::ListRobotsRequest>,
    ) -> Reply<pb::ListRobotsResponse> {
        Ok(Response::new(pb::ListRobotsResponse {
            robots: each(self.app.robots()),
        }))
    }

    async fn get_robot(&self, r: Request<pb::GetRobotRequest>) -> Reply<pb::Robot> {
        reply(self.app.robot(&r.into_inner().name))
    }

    async fn upload_robot(&self, r: Request<pb::UploadRobotRequest>) -> Reply<pb::Robot> {
        reply(self.app.upload_robot(r.into_inner().into()).await)
    }

    async fn search_placements(
        &self,
        r: Request<pb::SearchPlacementsRequest>,
    ) -> Reply<pb::Placements> {
        let r = r.into_inner();
        let robot = r.robot.clone();
        let search = convert::placement_search(r)?;
        reply(self.app.search_placements(&robot, search).await)
    }

    async fn get_arm_frames(&self, r: Request<pb::GetArmFramesRequest>) -> Reply<pb::ArmFrames> {
        let r = r.into_inner();
        let joints = (!r.joints.is_empty()).then_some(r.joints);
        reply(self.app.arm_frames(r.cell_id, joints).await)
    }

    async fn check_reach(&self, r: Request<pb::CheckReachRequest>) -> Reply<pb::Reachability> {
        let r = r.into_inner();
        let cell_id = r.cell_id;
        reply(self.app.reach(cell_id, convert::reach_query(r)?).await)
    }

    async fn delete_robot(
        &self,
        r: Request<pb::DeleteRobotRequest>,
    ) -> Reply<pb::DeleteRobotResponse> {
        done(self.app.delete_robot(&r.into_inner().name).await)
    }

    async fn import_programs(
        &self,
        r: Request<pb::ImportProgramsRequest>,
    ) -> Reply<pb::ImportResult> {
        let r = r.into_inner();
        let cell_id = r.cell_id;
        reply(self.app.import(cell_id, convert::import_request(r)).await)
    }

    async fn replay(&self, r: Request<pb::ReplayRequest>) -> Reply<pb::ReplayReport> {
        let input = convert::replay_request(r.into_inner())?;
        reply(self.app.replay(input).await)
    }

    async fn create_backup(&self, r: Request<pb::CreateBackupRequest>) -> Reply<pb::Backup> {
        reply(self.app.backup(r.into_inner().into()).await)
    }
}
