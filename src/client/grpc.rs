//! The gRPC transport: unary calls for cells, programs, routines, feedback, stats, rebuild,
//! predictions and imports, and a `Teach` stream for teaching (start, waypoint → prediction,
//! finish), driven in lock-step (each command waits for its answer). Requests and answers go
//! through the adapter's own conversions ([`crate::grpc::convert`]), so both transports read
//! the same resources.

use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::metadata::MetadataValue;
use tonic::transport::Channel;
use tonic::{Request, Streaming};

use super::{ClientError, Result};
use crate::api::{
    CellStats, CreateCell, CreateProgram, CreateRoutine, Feedback, ImportRequest, ModelInfo,
    NewWaypoint, PredictQuery, PredictionSet, Taught, TrajectoryAnswer, TrajectoryRequest,
};
use crate::grpc::convert;
use crate::grpc::pb;
use crate::grpc::pb::nextpose_client::NextposeClient;
use crate::grpc::pb::teach_request::Command;
use crate::grpc::pb::teach_response::Event;

/// A gRPC client of one server (the same port as REST).
#[derive(Debug, Clone)]
pub struct GrpcClient {
    base: String,
    inner: NextposeClient<Channel>,
    token: Option<MetadataValue<tonic::metadata::Ascii>>,
}

/// A failed call, named.
fn failed(what: &str) -> impl FnOnce(tonic::Status) -> ClientError + '_ {
    move |status| ClientError::Grpc {
        what: what.to_string(),
        status,
    }
}

/// An answer that does not convert into its resource.
fn unexpected(what: &str) -> impl FnOnce(tonic::Status) -> ClientError + '_ {
    move |status| ClientError::Unexpected {
        what: what.to_string(),
        detail: status.message().to_string(),
    }
}

impl GrpcClient {
    /// Connects to `base` (`http://host:port`).
    pub async fn connect(base: &str, token: Option<String>) -> Result<GrpcClient> {
        let base = base.trim_end_matches('/').to_string();
        let token = token
            .map(|t| MetadataValue::try_from(format!("Bearer {t}")))
            .transpose()
            .map_err(|_| ClientError::Usage("the token cannot be sent as gRPC metadata"))?;
        let channel = Channel::from_shared(base.clone())
            .map_err(|_| ClientError::BadAddress(base.clone()))?
            .connect()
            .await
            .map_err(|e| ClientError::Unreachable {
                what: "connecting over gRPC".into(),
                base: base.clone(),
                source: Box::new(e),
            })?;
        Ok(GrpcClient {
            base,
            inner: NextposeClient::new(channel),
            token,
        })
    }

    pub fn base(&self) -> &str {
        &self.base
    }

    fn request<T>(&self, message: T) -> Request<T> {
        let mut r = Request::new(message);
        if let Some(t) = &self.token {
            r.metadata_mut().insert("authorization", t.clone());
        }
        r
    }

    /// Creates a cell; its id.
    pub async fn create_cell(&self, cell: &CreateCell) -> Result<i64> {
        let r = self.request(convert::create_cell_request(cell.clone()));
        let cell = self.inner.clone().create_cell(r).await;
        Ok(cell.map_err(failed("CreateCell"))?.into_inner().id)
    }

    /// Creates a program in a cell; its id.
    pub async fn create_program(&self, cell: i64, program: &CreateProgram) -> Result<i64> {
        let r = self.request(pb::CreateProgramRequest {
            cell_id: cell,
            name: program.name.clone(),
        });
        let p = self.inner.clone().create_program(r).await;
        Ok(p.map_err(failed("CreateProgram"))?.into_inner().id)
    }

    /// Starts a routine in a program; its id.
    pub async fn create_routine(&self, program: i64, routine: &CreateRoutine) -> Result<i64> {
        let r = self.request(pb::CreateRoutineRequest {
            program_id: program,
            name: routine.name.clone(),
        });
        let routine = self.inner.clone().create_routine(r).await;
        Ok(routine.map_err(failed("CreateRoutine"))?.into_inner().id)
    }

    /// Appends one waypoint by a unary call (teaching goes through [`TeachStream`]).
    pub async fn append(&self, routine: i64, waypoint: &NewWaypoint) -> Result<Taught> {
        let r = self.request(pb::AppendWaypointRequest {
            routine_id: routine,
            waypoint: Some(convert::new_waypoint_out(waypoint.clone())),
        });
        let t = self.inner.clone().append_waypoint(r).await;
        let t = t.map_err(failed("AppendWaypoint"))?.into_inner();
        t.try_into().map_err(unexpected("AppendWaypoint"))
    }

    /// Appends a hand-guided trajectory's attractors (or previews them).
    pub async fn append_trajectory(
        &self,
        routine: i64,
        trajectory: &TrajectoryRequest,
    ) -> Result<TrajectoryAnswer> {
        let r = self.request(convert::trajectory_request_out(routine, trajectory.clone()));
        let t = self.inner.clone().append_trajectory(r).await;
        let t = t.map_err(failed("AppendTrajectory"))?.into_inner();
        t.try_into().map_err(unexpected("AppendTrajectory"))
    }

    pub async fn feedback(&self, prediction: i64, feedback: &Feedback) -> Result<()> {
        let r = self.request(convert::feedback_request(prediction, feedback.clone()));
        self.inner
            .clone()
            .feedback(r)
            .await
            .map_err(failed("Feedback"))?;
        Ok(())
    }

    pub async fn finish(&self, routine: i64) -> Result<()> {
        let r = self.request(pb::FinishRoutineRequest {
            routine_id: routine,
        });
        self.inner
            .clone()
            .finish_routine(r)
            .await
            .map_err(failed("FinishRoutine"))?;
        Ok(())
    }

    pub async fn stats(&self, cell: i64) -> Result<CellStats> {
        let r = self.request(pb::GetCellStatsRequest { cell_id: cell });
        let s = self.inner.clone().get_cell_stats(r).await;
        let s = s.map_err(failed("GetCellStats"))?.into_inner();
        s.try_into().map_err(unexpected("GetCellStats"))
    }

    pub async fn rebuild(&self, cell: i64) -> Result<ModelInfo> {
        let r = self.request(pb::RebuildModelRequest { cell_id: cell });
        let m = self.inner.clone().rebuild_model(r).await;
        let m = m.map_err(failed("RebuildModel"))?.into_inner();
        m.try_into().map_err(unexpected("RebuildModel"))
    }

    /// The prediction for an open routine (with `k`: an open-loop completion).
    pub async fn predict(&self, routine: i64, query: &PredictQuery) -> Result<PredictionSet> {
        let r = self.request(convert::predict_request(routine, query.clone()));
        let set = self.inner.clone().predict(r).await;
        let set = set.map_err(failed("Predict"))?.into_inner();
        set.try_into().map_err(unexpected("Predict"))
    }

    /// Imports offline program files into a cell.
    pub async fn import(&self, cell: i64, request: &ImportRequest) -> Result<()> {
        let r = self.request(convert::import_programs_request(cell, request.clone()));
        self.inner
            .clone()
            .import_programs(r)
            .await
            .map_err(failed("ImportPrograms"))?;
        Ok(())
    }

    /// Opens a `Teach` session.
    pub async fn teach(&self) -> Result<TeachStream> {
        let (tx, rx) = mpsc::channel(crate::grpc::TEACH_BUFFER);
        let r = self.request(ReceiverStream::new(rx));
        let events = self.inner.clone().teach(r).await.map_err(failed("Teach"))?;
        Ok(TeachStream {
            tx,
            events: events.into_inner(),
            tag: 0,
        })
    }
}

/// An open `Teach` session, driven in lock-step: one command, then its answer.
#[derive(Debug)]
pub struct TeachStream {
    tx: mpsc::Sender<pb::TeachRequest>,
    events: Streaming<pb::TeachResponse>,
    tag: u64,
}

impl TeachStream {
    async fn call(&mut self, command: Command, what: &str) -> Result<Event> {
        let what = format!("Teach {what}");
        let protocol = |detail: String| ClientError::Unexpected {
            what: what.clone(),
            detail,
        };
        self.tag += 1;
        let tag = self.tag;
        self.tx
            .send(pb::TeachRequest {
                tag,
                command: Some(command),
            })
            .await
            .map_err(|_| protocol("the stream is closed".into()))?;
        let answer = self.events.message().await.map_err(failed(&what))?;
        let Some(answer) = answer else {
            return Err(protocol("the server ended the stream".into()));
        };
        if answer.tag != tag {
            return Err(protocol(format!(
                "answer tagged {} for command {tag}",
                answer.tag
            )));
        }
        match answer.event {
            Some(Event::Error(e)) => Err(ClientError::Grpc {
                what: what.clone(),
                status: tonic::Status::new(
                    tonic::Code::from(e.code),
                    format!("{}: {}", e.reason, e.message),
                ),
            }),
            Some(event) => Ok(event),
            None => Err(protocol("an answer without an event".into())),
        }
    }

    /// Selects the open routine the following commands apply to.
    pub async fn start(&mut self, routine: i64) -> Result<()> {
        let start = Command::Start(pb::StartCommand {
            routine_id: routine,
        });
        match self.call(start, "start").await? {
            Event::Started(_) => Ok(()),
            other => Err(ClientError::Unexpected {
                what: "Teach start".into(),
                detail: format!("{other:?}"),
            }),
        }
    }

    pub async fn waypoint(&mut self, waypoint: &NewWaypoint) -> Result<Taught> {
        let w = Command::Waypoint(convert::new_waypoint_out(waypoint.clone()));
        match self.call(w, "waypoint").await? {
            Event::Taught(t) => t.try_into().map_err(unexpected("Teach waypoint")),
            other => Err(ClientError::Unexpected {
                what: "Teach waypoint".into(),
                detail: format!("{other:?}"),
            }),
        }
    }

    pub async fn finish(&mut self) -> Result<()> {
        match self
            .call(Command::Finish(pb::FinishCommand {}), "finish")
            .await?
        {
            Event::Finished(_) => Ok(()),
            other => Err(ClientError::Unexpected {
                what: "Teach finish".into(),
                detail: format!("{other:?}"),
            }),
        }
    }
}
