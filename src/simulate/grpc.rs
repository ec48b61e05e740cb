//! The gRPC transport of the simulation driver: unary calls for cells, programs, routines,
//! feedback, stats, rebuild, predictions and imports, and a `Teach` stream for teaching (start,
//! waypoint → prediction, finish), driven in lock-step (each command waits for its answer).
//! Answers are converted into the same views the REST transport reads, so the session logic
//! in [`super`] is the same for both.

use anyhow::{Context, Result, bail};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::metadata::MetadataValue;
use tonic::transport::Channel;
use tonic::{Request, Streaming};

use super::{
    CellSetup, CellStatsView, FeedbackView, ModelView, PredictionView, ReachabilityView,
    TaughtView, WaypointView, WithheldView,
};
use crate::app::resources::PoseDto;
use crate::engine::{Pose, Profile};
use crate::grpc::pb;
use crate::grpc::pb::nextpose_client::NextposeClient;
use crate::grpc::pb::teach_request::Command;
use crate::grpc::pb::teach_response::Event;
use crate::kinematics::ReachPolicy;
use crate::sim::Feedback;

/// A gRPC client of one server (the same port as REST).
#[derive(Debug, Clone)]
pub struct GrpcClient {
    base: String,
    inner: NextposeClient<Channel>,
    token: Option<MetadataValue<tonic::metadata::Ascii>>,
}

fn pb_pose(p: &Pose) -> pb::Pose {
    PoseDto::from(p).into()
}

fn usize_of(v: u64, what: &str) -> Result<usize> {
    usize::try_from(v).with_context(|| format!("{what} {v} does not fit this machine"))
}

fn model_view(m: Option<pb::ModelInfo>) -> Result<ModelView> {
    let m = m.context("the answer has no model")?;
    Ok(ModelView {
        states: usize_of(m.states, "states")?,
        edges: usize_of(m.edges, "edges")?,
        perplexity: m.perplexity,
        routines: m.routines,
        depth: usize_of(m.depth, "depth")?,
        observations: m.observations,
        version: m.version,
    })
}

fn prediction_view(p: pb::Prediction) -> PredictionView {
    PredictionView {
        id: p.id,
        offered: p.offered,
        withheld: p.withheld.map(|w| WithheldView { reason: w.reason }),
        reachability: p.reachability.map(|r| ReachabilityView {
            reachable: r.reachable,
        }),
        pose: p.pose.map(PoseDto::from),
        phi: p.phi,
        after_waypoints: p.after_waypoints,
        model_version: p.model_version,
    }
}

fn taught_view(t: pb::Taught) -> Result<TaughtView> {
    let w = t.waypoint.context("a taught answer without its waypoint")?;
    let p = t
        .prediction
        .context("a taught answer without a prediction")?;
    Ok(TaughtView {
        waypoint: WaypointView {
            id: w.id,
            seq: w.seq,
            reachable: w.reachable,
        },
        prediction: prediction_view(p),
    })
}

fn settings_input(s: &CellSetup) -> Result<pb::CellSettingsInput> {
    Ok(pb::CellSettingsInput {
        profile: match s.profile {
            Profile::Seed => pb::Profile::Seed,
            Profile::Default => pb::Profile::Default,
        }
        .into(),
        delta: s.delta,
        phi_min: s.phi_min,
        horizon: s
            .horizon
            .map(|h| u64::try_from(h).context("horizon"))
            .transpose()?,
        sigma_t_mm: Some(s.sigma_t_mm),
        sigma_q: Some(s.sigma_q),
        scale: None,
        robot: Some(s.robot.clone()),
        base: Some(pb_pose(&s.base)),
        tool: Some(pb_pose(&s.tool)),
        reach_policy: match s.reach_policy {
            ReachPolicy::Withhold => pb::ReachPolicy::Withhold,
            ReachPolicy::Flag => pb::ReachPolicy::Flag,
        }
        .into(),
    })
}

impl GrpcClient {
    /// Connects to `base` (`http://host:port`).
    pub async fn connect(base: &str, token: Option<String>) -> Result<GrpcClient> {
        let base = base.trim_end_matches('/').to_string();
        let token = token
            .map(|t| MetadataValue::try_from(format!("Bearer {t}")))
            .transpose()
            .context("the token cannot be sent as gRPC metadata")?;
        let channel = Channel::from_shared(base.clone())
            .with_context(|| format!("not a server address: {base}"))?
            .connect()
            .await
            .with_context(|| format!("cannot reach {base} over gRPC"))?;
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

    pub async fn create_cell(&self, name: &str, setup: &CellSetup) -> Result<i64> {
        let r = self.request(pb::CreateCellRequest {
            name: name.to_string(),
            settings: Some(settings_input(setup)?),
        });
        let cell = self
            .inner
            .clone()
            .create_cell(r)
            .await
            .context("CreateCell")?;
        Ok(cell.into_inner().id)
    }

    pub async fn create_program(&self, cell: i64, name: &str) -> Result<i64> {
        let r = self.request(pb::CreateProgramRequest {
            cell_id: cell,
            name: name.to_string(),
        });
        let p = self.inner.clone().create_program(r).await;
        Ok(p.context("CreateProgram")?.into_inner().id)
    }

    pub async fn create_routine(&self, program: i64, name: &str) -> Result<i64> {
        let r = self.request(pb::CreateRoutineRequest {
            program_id: program,
            name: Some(name.to_string()),
        });
        let routine = self.inner.clone().create_routine(r).await;
        Ok(routine.context("CreateRoutine")?.into_inner().id)
    }

    /// Appends one waypoint by a unary call (teaching goes through [`TeachStream`]).
    pub async fn append(&self, routine: i64, pose: &Pose) -> Result<TaughtView> {
        let r = self.request(pb::AppendWaypointRequest {
            routine_id: routine,
            waypoint: Some(pb::NewWaypoint {
                pose: Some(pb_pose(pose)),
                ..Default::default()
            }),
        });
        let t = self.inner.clone().append_waypoint(r).await;
        taught_view(t.context("AppendWaypoint")?.into_inner())
    }

    pub async fn feedback(&self, prediction: i64, feedback: &Feedback) -> Result<()> {
        let (verdict, pose) = match feedback {
            Feedback::Accepted => (pb::Verdict::Accepted, None),
            Feedback::Adjusted(p) => (pb::Verdict::Adjusted, Some(pb_pose(p))),
            Feedback::Rejected => (pb::Verdict::Rejected, None),
        };
        let r = self.request(pb::FeedbackRequest {
            prediction_id: prediction,
            verdict: verdict.into(),
            pose,
        });
        self.inner.clone().feedback(r).await.context("Feedback")?;
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
            .context("FinishRoutine")?;
        Ok(())
    }

    pub async fn stats(&self, cell: i64) -> Result<CellStatsView> {
        let r = self.request(pb::GetCellStatsRequest { cell_id: cell });
        let s = self.inner.clone().get_cell_stats(r).await;
        let s = s.context("GetCellStats")?.into_inner();
        let f = s.feedback.context("stats without feedback")?;
        Ok(CellStatsView {
            cell_id: s.cell_id,
            model: model_view(s.model)?,
            feedback: FeedbackView {
                offered: f.offered,
                accepted: f.accepted,
                adjusted: f.adjusted,
                rejected: f.rejected,
                pending: f.pending,
            },
        })
    }

    pub async fn rebuild(&self, cell: i64) -> Result<ModelView> {
        let r = self.request(pb::RebuildModelRequest { cell_id: cell });
        let m = self.inner.clone().rebuild_model(r).await;
        model_view(Some(m.context("RebuildModel")?.into_inner()))
    }

    /// Open-loop completion of up to `k` waypoints for an open routine.
    pub async fn predict(&self, routine: i64, k: usize) -> Result<Vec<PredictionView>> {
        let r = self.request(pb::PredictRequest {
            routine_id: routine,
            k: Some(u64::try_from(k).context("k")?),
            ..Default::default()
        });
        let set = self.inner.clone().predict(r).await;
        let set = set.context("Predict")?.into_inner();
        Ok(set.predictions.into_iter().map(prediction_view).collect())
    }

    /// Imports offline program files (`(name, text)`) into a cell and learns them.
    pub async fn import(&self, cell: i64, files: &[(String, String)]) -> Result<()> {
        let r = self.request(pb::ImportProgramsRequest {
            cell_id: cell,
            files: files
                .iter()
                .map(|(name, content)| pb::UploadedFile {
                    name: name.clone(),
                    content: content.clone(),
                })
                .collect(),
            learn: Some(true),
        });
        self.inner
            .clone()
            .import_programs(r)
            .await
            .context("ImportPrograms")?;
        Ok(())
    }

    /// Opens a `Teach` session.
    pub async fn teach(&self) -> Result<TeachStream> {
        let (tx, rx) = mpsc::channel(crate::grpc::TEACH_BUFFER);
        let r = self.request(ReceiverStream::new(rx));
        let events = self.inner.clone().teach(r).await.context("Teach")?;
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
        self.tag += 1;
        let tag = self.tag;
        self.tx
            .send(pb::TeachRequest {
                tag,
                command: Some(command),
            })
            .await
            .with_context(|| format!("Teach {what}: the stream is closed"))?;
        let Some(answer) = self
            .events
            .message()
            .await
            .with_context(|| format!("Teach {what}"))?
        else {
            bail!("Teach {what}: the server ended the stream");
        };
        if answer.tag != tag {
            bail!(
                "Teach {what}: answer tagged {} for command {tag}",
                answer.tag
            );
        }
        match answer.event {
            Some(Event::Error(e)) => bail!(
                "Teach {what}: {} (code {}): {}",
                e.reason,
                e.code,
                e.message
            ),
            Some(event) => Ok(event),
            None => bail!("Teach {what}: an answer without an event"),
        }
    }

    /// Selects the open routine the following commands apply to.
    pub async fn start(&mut self, routine: i64) -> Result<()> {
        match self
            .call(
                Command::Start(pb::StartCommand {
                    routine_id: routine,
                }),
                "start",
            )
            .await?
        {
            Event::Started(_) => Ok(()),
            other => bail!("Teach start: unexpected answer {other:?}"),
        }
    }

    pub async fn waypoint(&mut self, pose: &Pose) -> Result<TaughtView> {
        let w = pb::NewWaypoint {
            pose: Some(pb_pose(pose)),
            ..Default::default()
        };
        match self.call(Command::Waypoint(w), "waypoint").await? {
            Event::Taught(t) => taught_view(t),
            other => bail!("Teach waypoint: unexpected answer {other:?}"),
        }
    }

    pub async fn finish(&mut self) -> Result<()> {
        match self
            .call(Command::Finish(pb::FinishCommand {}), "finish")
            .await?
        {
            Event::Finished(_) => Ok(()),
            other => bail!("Teach finish: unexpected answer {other:?}"),
        }
    }
}
