//! The gRPC adapter (tonic): the same application service as the REST adapter, on the same
//! port. Handlers convert messages ([`convert`]), call [`App`] and map its errors once
//! ([`status`]); no business logic lives here.
//!
//! Requests with `content-type: application/grpc*` go to the gRPC router before any REST layer
//! (see [`beside`]), so REST's JSON error bodies, timeouts and body limits never touch gRPC
//! responses. The optional bearer token applies to gRPC metadata (`authorization: Bearer …`,
//! `UNAUTHENTICATED` otherwise), except for the health service, like REST's `/healthz`.
//! Reflection (v1 and v1alpha) and health (`grpc.health.v1`) are served for `grpcurl` and
//! load balancers.

pub mod convert;
pub mod status;
pub mod track;

use std::convert::Infallible;
use std::pin::Pin;
use std::sync::Arc;

use axum::Router;
use axum::extract::{Request as HttpRequest, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response as HttpResponse};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Code, Request, Response, Status, Streaming};
use tower::ServiceExt;

use crate::api::{CreateProgram, CreateRoutine, ExportQuery, Rename};
use crate::app::{App, AppError};
use crate::transport::TransportOptions;
use crate::transport::auth::BearerToken;
use crate::transport::request_id::{Protocol, with_request_ids};

/// The generated messages, client and server of `proto/nextpose/v1/nextpose.proto`.
pub mod pb {
    #![allow(clippy::all, clippy::pedantic, missing_docs)]
    tonic::include_proto!("nextpose.v1");
}

/// The encoded file descriptor set of the API, served by reflection.
pub const FILE_DESCRIPTOR_SET: &[u8] =
    include_bytes!(concat!(env!("OUT_DIR"), "/nextpose_descriptor.bin"));

/// Responses a `Teach` session may have in flight before it stops reading commands: a client
/// that does not read its responses slows down to the server's pace (HTTP/2 flow control does
/// the rest).
pub const TEACH_BUFFER: usize = 16;

use pb::nextpose_server::{Nextpose, NextposeServer};
use pb::teach_request::Command;
use pb::teach_response::Event;

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

#[tonic::async_trait]
impl Nextpose for Service {
    async fn create_cell(&self, r: Request<pb::CreateCellRequest>) -> Reply<pb::Cell> {
        let input = convert::create_cell(r.into_inner())?;
        reply(self.app.create_cell(input).await)
    }

    async fn list_cells(&self, _: Request<pb::ListCellsRequest>) -> Reply<pb::ListCellsResponse> {
        let cells = self.app.cells().await.map_err(status::status)?;
        Ok(Response::new(pb::ListCellsResponse {
            cells: cells.into_iter().map(Into::into).collect(),
        }))
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
        let programs = self
            .app
            .programs(r.into_inner().cell_id)
            .await
            .map_err(status::status)?;
        Ok(Response::new(pb::ListProgramsResponse {
            programs: programs.into_iter().map(Into::into).collect(),
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
        let routines = self
            .app
            .routines(r.into_inner().program_id)
            .await
            .map_err(status::status)?;
        Ok(Response::new(pb::ListRoutinesResponse {
            routines: routines.into_iter().map(Into::into).collect(),
        }))
    }

    async fn get_routine(&self, r: Request<pb::GetRoutineRequest>) -> Reply<pb::RoutineDetail> {
        reply(self.app.get_routine(r.into_inner().routine_id).await)
    }

    async fn delete_routine(
        &self,
        r: Request<pb::DeleteRoutineRequest>,
    ) -> Reply<pb::DeleteRoutineResponse> {
        self.app
            .delete_routine(r.into_inner().routine_id)
            .await
            .map_err(status::status)?;
        Ok(Response::new(pb::DeleteRoutineResponse {}))
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
        self.app
            .delete_program(r.into_inner().program_id)
            .await
            .map_err(status::status)?;
        Ok(Response::new(pb::DeleteProgramResponse {}))
    }

    async fn update_cell(&self, r: Request<pb::UpdateCellRequest>) -> Reply<pb::Cell> {
        let r = r.into_inner();
        let id = r.cell_id;
        let patch = convert::cell_patch(r)?;
        reply(self.app.edit_cell(id, patch).await)
    }

    async fn delete_cell(
        &self,
        r: Request<pb::DeleteCellRequest>,
    ) -> Reply<pb::DeleteCellResponse> {
        self.app
            .delete_cell(r.into_inner().cell_id)
            .await
            .map_err(status::status)?;
        Ok(Response::new(pb::DeleteCellResponse {}))
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
        let mut inbound = r.into_inner();
        let (tx, rx) = mpsc::channel(TEACH_BUFFER);
        let app = self.app.clone();
        let counted = app.metrics().teach_session();
        // The session runs in its own task, so a command being applied always completes (the
        // application applies each one atomically); between commands the task stops as soon
        // as the client goes away.
        tokio::spawn(async move {
            let _counted = counted;
            let mut session = TeachStream { app, routine: None };
            loop {
                let next = tokio::select! {
                    m = inbound.message() => m,
                    _ = tx.closed() => break,
                };
                let request = match next {
                    Ok(Some(request)) => request,
                    Ok(None) => break,
                    Err(e) => {
                        // The client went away, or sent what cannot be read (a message over
                        // the size limit, OUT_OF_RANGE): the stream ends with that status.
                        tracing::debug!(status = %e, "teach stream ended by the client");
                        let _ = tx.send(Err(e)).await;
                        break;
                    }
                };
                let event = session.apply(request.command).await;
                let response = pb::TeachResponse {
                    tag: request.tag,
                    event: Some(event),
                };
                // Waits while the client is TEACH_BUFFER responses behind (back-pressure).
                if tx.send(Ok(response)).await.is_err() {
                    break;
                }
            }
        });
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn list_robots(
        &self,
        _: Request<pb::ListRobotsRequest>,
    ) -> Reply<pb::ListRobotsResponse> {
        Ok(Response::new(pb::ListRobotsResponse {
            robots: self.app.robots().into_iter().map(Into::into).collect(),
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
        self.app
            .delete_robot(&r.into_inner().name)
            .await
            .map_err(status::status)?;
        Ok(Response::new(pb::DeleteRobotResponse {}))
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
}

/// One `Teach` stream: which routine its commands apply to.
struct TeachStream {
    app: Arc<App>,
    routine: Option<i64>,
}

fn app_error(e: AppError) -> pb::TeachError {
    pb::TeachError {
        code: status::code(&e) as i32,
        reason: e.code().to_string(),
        message: status::message(&e),
    }
}

fn adapter_error(s: Status) -> pb::TeachError {
    let reason = match s.code() {
        Code::InvalidArgument => "invalid",
        Code::FailedPrecondition => "no_routine",
        _ => "bad_request",
    };
    pb::TeachError {
        code: s.code() as i32,
        reason: reason.to_string(),
        message: s.message().to_string(),
    }
}

impl TeachStream {
    fn routine(&self) -> Result<i64, pb::TeachError> {
        self.routine.ok_or_else(|| {
            adapter_error(Status::failed_precondition(
                "no routine selected; send `start` first",
            ))
        })
    }

    async fn apply(&mut self, command: Option<Command>) -> Event {
        self.try_apply(command).await.unwrap_or_else(Event::Error)
    }

    async fn try_apply(&mut self, command: Option<Command>) -> Result<Event, pb::TeachError> {
        let app = &self.app;
        match command {
            None => Err(adapter_error(Status::invalid_argument(
                "a command (start, waypoint, undo or finish) is required",
            ))),
            Some(Command::Start(s)) => {
                let detail = app.resume_routine(s.routine_id).await.map_err(app_error)?;
                self.routine = Some(s.routine_id);
                Ok(Event::Started(pb::Started {
                    routine: Some(detail.routine.into()),
                }))
            }
            Some(Command::Waypoint(w)) => {
                let id = self.routine()?;
                let input = convert::new_waypoint(w).map_err(adapter_error)?;
                let taught = app.append_waypoint(id, input).await.map_err(app_error)?;
                Ok(Event::Taught(taught.into()))
            }
            Some(Command::Undo(_)) => {
                let id = self.routine()?;
                let undone = app.undo(id).await.map_err(app_error)?;
                Ok(Event::Undone(undone.into()))
            }
            Some(Command::Finish(_)) => {
                let id = self.routine()?;
                let finished = app.finish_routine(id).await.map_err(app_error)?;
                self.routine = None;
                Ok(Event::Finished(finished.into()))
            }
        }
    }
}

/// The gRPC router: the API, health and reflection, behind the optional bearer token, with
/// the same request ids and tracing as REST ([`crate::transport::request_id::with_request_ids`])
/// and its own call metrics ([`track`]).
///
/// A request message of the API may be as large as a REST body (`options.body_limit`, 2 MiB by
/// default, instead of tonic's 4 MiB): larger ones are refused with `OUT_OF_RANGE`.
pub async fn router(
    app: Arc<App>,
    options: &TransportOptions,
    token: Option<BearerToken>,
) -> anyhow::Result<Router> {
    let metrics = app.metrics().clone();
    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_serving::<NextposeServer<Service>>().await;
    // Reflection describes the health service too, so that `grpcurl` can call it.
    let reflection = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1()?;
    let reflection_alpha = tonic_reflection::server::Builder::configure()
        .register_encoded_file_descriptor_set(FILE_DESCRIPTOR_SET)
        .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
        .build_v1alpha()?;
    let api = NextposeServer::new(Service::new(app)).max_decoding_message_size(options.body_limit);
    let mut routes = tonic::service::Routes::new(api)
        .add_service(health_service)
        .add_service(reflection)
        .add_service(reflection_alpha)
        .into_axum_router();
    if let Some(token) = token {
        routes = routes.layer(axum::middleware::from_fn_with_state(token, require_token));
    }
    let routes = routes.layer(axum::middleware::from_fn_with_state(metrics, track::track));
    Ok(with_request_ids(routes, Protocol::Grpc))
}

/// Requires `authorization: Bearer <token>` metadata on every call but health checks.
async fn require_token(
    State(token): State<BearerToken>,
    request: HttpRequest,
    next: Next,
) -> HttpResponse {
    if request.uri().path().starts_with("/grpc.health.v1.Health/") {
        return next.run(request).await;
    }
    let given = request
        .headers()
        .get(header::AUTHORIZATION)
        .map(|v| v.as_bytes());
    if token.admits(given) {
        return next.run(request).await;
    }
    Status::unauthenticated("a valid bearer token is required")
        .into_http::<axum::body::Body>()
        .into_response()
}

/// Whether a request is a gRPC call (`content-type: application/grpc`, `application/grpc+proto`…).
pub fn is_grpc<B>(request: &axum::http::Request<B>) -> bool {
    request
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/grpc"))
}

/// One router for both adapters: gRPC calls go to `grpc` before any REST layer sees them,
/// everything else to `rest`.
pub fn beside(rest: Router, grpc: Router) -> Router {
    type Fut = Pin<Box<dyn Future<Output = Result<HttpResponse, Infallible>> + Send>>;
    let dispatch = tower::service_fn(move |request: HttpRequest| -> Fut {
        let target = if is_grpc(&request) {
            grpc.clone()
        } else {
            rest.clone()
        };
        Box::pin(target.oneshot(request))
    });
    Router::new().fallback_service(dispatch)
}
