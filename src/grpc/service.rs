//! The unary calls of the API: each converts its request ([`super::convert`]), calls [`App`]
//! and maps an error once ([`super::status`]); the `Teach` stream is a session of its own
//! ([`super::teach`]).

use std::sync::Arc;

use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status, Streaming};

use crate::api::{CreateProgram, CreateRoutine, ExportQuery, NewToken, Rename, RestoreProgram};
use crate::app::audit::Recorder;
use crate::app::{Action, App, AppError, Caller, Scope};

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

    /// The request's message, if its caller may do `action` on the resource `scope` names
    /// (`PERMISSION_DENIED` otherwise): asked before anything is read or changed, as REST's
    /// middleware does (`http::access`).
    async fn allow<T>(
        &self,
        r: Request<T>,
        action: Action,
        scope: impl FnOnce(&T) -> Scope,
    ) -> Result<T, Status> {
        let caller = caller(&r)?;
        let message = r.into_inner();
        let scope = scope(&message);
        self.app
            .authorize(&caller, action, scope)
            .await
            .map_err(status::status)?;
        if let Some(recorder) = Recorder::current()
            && scope != Scope::Service
        {
            recorder.name_target(scope.to_string());
        }
        Ok(message)
    }
}

/// Who is calling: found by the gate from the call's metadata (`super::require_caller`).
fn caller<T>(r: &Request<T>) -> Result<Caller, Status> {
    r.extensions()
        .get::<Caller>()
        .cloned()
        .ok_or_else(|| Status::unauthenticated("no caller was found for this call"))
}

use Action::{Administer, Delete, Edit, Inspect, ManageTokens, Read, Teach};

fn service<T>(_: &T) -> Scope {
    Scope::Service
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
        let r = self.allow(r, Edit, service).await?;
        let input = convert::create_cell(r)?;
        reply(self.app.create_cell(input).await)
    }

    async fn list_cells(&self, r: Request<pb::ListCellsRequest>) -> Reply<pb::ListCellsResponse> {
        let caller = caller(&r)?;
        self.allow(r, Read, service).await?;
        let cells = self.app.visible_cells(&caller).await;
        reply(cells.map(|cells| pb::ListCellsResponse { cells: each(cells) }))
    }

    async fn get_cell(&self, r: Request<pb::GetCellRequest>) -> Reply<pb::Cell> {
        let r = self.allow(r, Read, |m| Scope::Cell(m.cell_id)).await?;
        reply(self.app.get_cell(r.cell_id).await)
    }

    async fn get_cell_stats(&self, r: Request<pb::GetCellStatsRequest>) -> Reply<pb::CellStats> {
        let r = self.allow(r, Read, |m| Scope::Cell(m.cell_id)).await?;
        reply(self.app.cell_stats(r.cell_id).await)
    }

    async fn rebuild_model(&self, r: Request<pb::RebuildModelRequest>) -> Reply<pb::ModelInfo> {
        let r = self.allow(r, Edit, |m| Scope::Cell(m.cell_id)).await?;
        reply(self.app.rebuild(r.cell_id).await)
    }

    async fn create_program(&self, r: Request<pb::CreateProgramRequest>) -> Reply<pb::Program> {
        let r = self.allow(r, Edit, |m| Scope::Cell(m.cell_id)).await?;
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
        let r = self.allow(r, Read, |m| Scope::Cell(m.cell_id)).await?;
        let programs = self.app.programs(r.cell_id).await;
        reply(programs.map(|programs| pb::ListProgramsResponse {
            programs: each(programs),
        }))
    }

    async fn get_program(&self, r: Request<pb::GetProgramRequest>) -> Reply<pb::Program> {
        let r = self
            .allow(r, Read, |m| Scope::Program(m.program_id))
            .await?;
        reply(self.app.get_program(r.program_id).await)
    }

    async fn create_routine(&self, r: Request<pb::CreateRoutineRequest>) -> Reply<pb::Routine> {
        let r = self
            .allow(r, Teach, |m| Scope::Program(m.program_id))
            .await?;
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
        let r = self
            .allow(r, Read, |m| Scope::Program(m.program_id))
            .await?;
        let routines = self.app.routines(r.program_id).await;
        reply(routines.map(|routines| pb::ListRoutinesResponse {
            routines: each(routines),
        }))
    }

    async fn get_routine(&self, r: Request<pb::GetRoutineRequest>) -> Reply<pb::RoutineDetail> {
        let r = self
            .allow(r, Read, |m| Scope::Routine(m.routine_id))
            .await?;
        reply(self.app.get_routine(r.routine_id).await)
    }

    async fn delete_routine(
        &self,
        r: Request<pb::DeleteRoutineRequest>,
    ) -> Reply<pb::DeleteRoutineResponse> {
        let r = self
            .allow(r, Edit, |m| Scope::Routine(m.routine_id))
            .await?;
        done(self.app.delete_routine(r.routine_id).await)
    }

    async fn edit_routine(&self, r: Request<pb::EditRoutineRequest>) -> Reply<pb::RoutineEdit> {
        let r = self
            .allow(r, Edit, |m| Scope::Routine(m.routine_id))
            .await?;
        let patch = convert::routine_patch(&r);
        reply(self.app.edit_routine(r.routine_id, patch).await)
    }

    async fn export_program(
        &self,
        r: Request<pb::ExportProgramRequest>,
    ) -> Reply<pb::ProgramExport> {
        let r = self
            .allow(r, Edit, |m| Scope::Program(m.program_id))
            .await?;
        let query = ExportQuery {
            format: r.format,
            revision: r.revision,
        };
        reply(self.app.export_program(r.program_id, query).await)
    }

    async fn rename_program(&self, r: Request<pb::RenameProgramRequest>) -> Reply<pb::Program> {
        let r = self
            .allow(r, Edit, |m| Scope::Program(m.program_id))
            .await?;
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
        let r = self
            .allow(r, Delete, |m| Scope::Program(m.program_id))
            .await?;
        done(self.app.delete_program(r.program_id).await)
    }

    async fn update_cell(&self, r: Request<pb::UpdateCellRequest>) -> Reply<pb::Cell> {
        let r = self.allow(r, Edit, |m| Scope::Cell(m.cell_id)).await?;
        let id = r.cell_id;
        let patch = convert::cell_patch(r)?;
        reply(self.app.edit_cell(id, patch).await)
    }

    async fn calibrate_cell(&self, r: Request<pb::CalibrateCellRequest>) -> Reply<pb::Cell> {
        let r = self.allow(r, Edit, |m| Scope::Cell(m.cell_id)).await?;
        let id = r.cell_id;
        reply(self.app.calibrate(id, convert::calibration(r)).await)
    }

    async fn delete_cell(
        &self,
        r: Request<pb::DeleteCellRequest>,
    ) -> Reply<pb::DeleteCellResponse> {
        let r = self.allow(r, Delete, |m| Scope::Cell(m.cell_id)).await?;
        done(self.app.delete_cell(r.cell_id).await)
    }

    async fn modify_waypoint(
        &self,
        r: Request<pb::ModifyWaypointRequest>,
    ) -> Reply<pb::WaypointEdit> {
        let r = self
            .allow(r, Edit, |m| Scope::Waypoint(m.waypoint_id))
            .await?;
        let patch = convert::waypoint_patch(&r)?;
        reply(self.app.modify_waypoint(r.waypoint_id, patch).await)
    }

    async fn insert_waypoint(
        &self,
        r: Request<pb::InsertWaypointRequest>,
    ) -> Reply<pb::WaypointEdit> {
        let r = self
            .allow(r, Edit, |m| Scope::Waypoint(m.waypoint_id))
            .await?;
        let id = r.waypoint_id;
        let input = convert::insert_waypoint(r)?;
        reply(self.app.insert_waypoint(id, input).await)
    }

    async fn delete_waypoint(
        &self,
        r: Request<pb::DeleteWaypointRequest>,
    ) -> Reply<pb::WaypointEdit> {
        let r = self
            .allow(r, Edit, |m| Scope::Waypoint(m.waypoint_id))
            .await?;
        reply(self.app.delete_waypoint(r.waypoint_id).await)
    }

    async fn retarget_routine(&self, r: Request<pb::RetargetRequest>) -> Reply<pb::Retargeted> {
        let r = self.allow(r, Edit, |m| Scope::Routine(m.id)).await?;
        let id = r.id;
        reply(self.app.retarget_routine(id, convert::retarget(r)).await)
    }

    async fn retarget_program(&self, r: Request<pb::RetargetRequest>) -> Reply<pb::Retargeted> {
        let r = self.allow(r, Edit, |m| Scope::Program(m.id)).await?;
        let id = r.id;
        reply(self.app.retarget_program(id, convert::retarget(r)).await)
    }

    async fn finish_routine(&self, r: Request<pb::FinishRoutineRequest>) -> Reply<pb::Finished> {
        let r = self
            .allow(r, Teach, |m| Scope::Routine(m.routine_id))
            .await?;
        reply(self.app.finish_routine(r.routine_id).await)
    }

    async fn append_waypoint(&self, r: Request<pb::AppendWaypointRequest>) -> Reply<pb::Taught> {
        let r = self
            .allow(r, Teach, |m| Scope::Routine(m.routine_id))
            .await?;
        let input = convert::new_waypoint(r.waypoint.unwrap_or_default())?;
        reply(self.app.append_waypoint(r.routine_id, input).await)
    }

    async fn append_trajectory(
        &self,
        r: Request<pb::AppendTrajectoryRequest>,
    ) -> Reply<pb::TrajectoryAnswer> {
        let r = self
            .allow(r, Teach, |m| Scope::Routine(m.routine_id))
            .await?;
        let id = r.routine_id;
        let input = convert::trajectory_request(r)?;
        reply(self.app.append_trajectory(id, input).await)
    }

    async fn undo(&self, r: Request<pb::UndoRequest>) -> Reply<pb::Undone> {
        let r = self
            .allow(r, Teach, |m| Scope::Routine(m.routine_id))
            .await?;
        reply(self.app.undo(r.routine_id).await)
    }

    async fn predict(&self, r: Request<pb::PredictRequest>) -> Reply<pb::PredictionSet> {
        let r = self
            .allow(r, Teach, |m| Scope::Routine(m.routine_id))
            .await?;
        let query = convert::predict_query(&r)?;
        reply(self.app.predict(r.routine_id, query).await)
    }

    async fn feedback(&self, r: Request<pb::FeedbackRequest>) -> Reply<pb::FeedbackRecorded> {
        let r = self
            .allow(r, Teach, |m| Scope::Prediction(m.prediction_id))
            .await?;
        let id = r.prediction_id;
        let input = convert::feedback(r)?;
        reply(self.app.feedback(id, input).await)
    }

    type TeachStream = ReceiverStream<Result<pb::TeachResponse, Status>>;

    async fn teach(&self, r: Request<Streaming<pb::TeachRequest>>) -> Reply<Self::TeachStream> {
        // Each `start` asks whether the caller may teach that routine.
        let caller = caller(&r)?;
        let request_id = r
            .metadata()
            .get("x-request-id")
            .and_then(|v| v.to_str().ok())
            .unwrap_or("-")
            .to_string();
        Ok(Response::new(teach::run(
            self.app.clone(),
            caller,
            request_id,
            r.into_inner(),
        )))
    }

    async fn list_robots(
        &self,
        r: Request<pb::ListRobotsRequest>,
    ) -> Reply<pb::ListRobotsResponse> {
        self.allow(r, Read, service).await?;
        Ok(Response::new(pb::ListRobotsResponse {
            robots: each(self.app.robots()),
        }))
    }

    async fn get_robot(&self, r: Request<pb::GetRobotRequest>) -> Reply<pb::Robot> {
        let r = self.allow(r, Read, service).await?;
        reply(self.app.robot(&r.name))
    }

    async fn upload_robot(&self, r: Request<pb::UploadRobotRequest>) -> Reply<pb::Robot> {
        let r = self.allow(r, Edit, service).await?;
        reply(self.app.upload_robot(r.into()).await)
    }

    async fn search_placements(
        &self,
        r: Request<pb::SearchPlacementsRequest>,
    ) -> Reply<pb::Placements> {
        let r = self.allow(r, Read, service).await?;
        let robot = r.robot.clone();
        let search = convert::placement_search(r)?;
        reply(self.app.search_placements(&robot, search).await)
    }

    async fn get_arm_frames(&self, r: Request<pb::GetArmFramesRequest>) -> Reply<pb::ArmFrames> {
        let r = self.allow(r, Read, |m| Scope::Cell(m.cell_id)).await?;
        let joints = (!r.joints.is_empty()).then_some(r.joints);
        reply(self.app.arm_frames(r.cell_id, joints).await)
    }

    async fn check_reach(&self, r: Request<pb::CheckReachRequest>) -> Reply<pb::Reachability> {
        let r = self.allow(r, Read, |m| Scope::Cell(m.cell_id)).await?;
        let cell_id = r.cell_id;
        reply(self.app.reach(cell_id, convert::reach_query(r)?).await)
    }

    async fn delete_robot(
        &self,
        r: Request<pb::DeleteRobotRequest>,
    ) -> Reply<pb::DeleteRobotResponse> {
        let r = self.allow(r, Edit, service).await?;
        done(self.app.delete_robot(&r.name).await)
    }

    async fn import_programs(
        &self,
        r: Request<pb::ImportProgramsRequest>,
    ) -> Reply<pb::ImportResult> {
        let r = self.allow(r, Edit, |m| Scope::Cell(m.cell_id)).await?;
        let cell_id = r.cell_id;
        reply(self.app.import(cell_id, convert::import_request(r)).await)
    }

    async fn replay(&self, r: Request<pb::ReplayRequest>) -> Reply<pb::ReplayReport> {
        let r = self.allow(r, Edit, service).await?;
        let input = convert::replay_request(r)?;
        reply(self.app.replay(input).await)
    }

    async fn create_backup(&self, r: Request<pb::CreateBackupRequest>) -> Reply<pb::Backup> {
        let r = self.allow(r, Administer, service).await?;
        reply(self.app.backup(r.into()).await)
    }

    async fn create_token(&self, r: Request<pb::CreateTokenRequest>) -> Reply<pb::CreatedToken> {
        let r = self.allow(r, ManageTokens, service).await?;
        let input = NewToken::try_from(r)?;
        reply(self.app.create_token(input).await)
    }

    async fn list_tokens(
        &self,
        r: Request<pb::ListTokensRequest>,
    ) -> Reply<pb::ListTokensResponse> {
        self.allow(r, ManageTokens, service).await?;
        let tokens = self.app.tokens().await;
        reply(tokens.map(|tokens| pb::ListTokensResponse {
            tokens: each(tokens),
        }))
    }

    async fn revoke_token(
        &self,
        r: Request<pb::RevokeTokenRequest>,
    ) -> Reply<pb::RevokeTokenResponse> {
        let r = self.allow(r, ManageTokens, service).await?;
        done(self.app.revoke_token(&r.name).await)
    }

    async fn list_audit(&self, r: Request<pb::ListAuditRequest>) -> Reply<pb::AuditPage> {
        let r = self.allow(r, Inspect, service).await?;
        reply(self.app.audit(r.into()).await)
    }

    async fn list_program_history(
        &self,
        r: Request<pb::ListProgramHistoryRequest>,
    ) -> Reply<pb::ProgramHistory> {
        let r = self
            .allow(r, Read, |m| Scope::Program(m.program_id))
            .await?;
        let query = convert::history_query(&r);
        reply(self.app.program_history(r.program_id, query).await)
    }

    async fn get_program_revision(
        &self,
        r: Request<pb::GetProgramRevisionRequest>,
    ) -> Reply<pb::ProgramRevision> {
        let r = self
            .allow(r, Read, |m| Scope::Program(m.program_id))
            .await?;
        reply(self.app.program_revision(r.program_id, r.revision).await)
    }

    async fn diff_program(&self, r: Request<pb::DiffProgramRequest>) -> Reply<pb::ProgramDiff> {
        let r = self
            .allow(r, Read, |m| Scope::Program(m.program_id))
            .await?;
        let query = convert::diff_query(&r);
        reply(self.app.diff_program(r.program_id, query).await)
    }

    async fn restore_program(&self, r: Request<pb::RestoreProgramRequest>) -> Reply<pb::Restored> {
        let r = self
            .allow(r, Edit, |m| Scope::Program(m.program_id))
            .await?;
        let input = RestoreProgram {
            revision: r.revision,
        };
        reply(self.app.restore_program(r.program_id, input).await)
    }

    async fn who_am_i(&self, r: Request<pb::WhoAmIRequest>) -> Reply<pb::Caller> {
        let caller = caller(&r)?;
        self.allow(r, Read, service).await?;
        Ok(Response::new(self.app.whoami(&caller).into()))
    }
}
