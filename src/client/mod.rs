//! A typed client of a nextpose server, over REST ([`RestClient`]) or gRPC ([`GrpcClient`]),
//! speaking the service's own wire types ([`crate::api`]): the same types
//! the server answers with, so a client cannot drift from the API. [`Client`] is the calls both
//! transports make, for code (the simulator, the CLI) that should not care which one is used;
//! [`Teaching`] teaches routines one after another (over gRPC on one `Teach` stream).
//!
//! This is the other end of the adapters: it may use their wire details (the error body, the
//! protobuf messages and their conversions), and nothing in the service uses it.

pub mod grpc;
pub mod rest;

use crate::api::{
    CellStats, CreateCell, CreateProgram, CreateRoutine, Feedback, ImportRequest, ModelInfo,
    NewWaypoint, PredictQuery, PredictionSet, Taught, TrajectoryAnswer, TrajectoryRequest,
};
use serde::{Deserialize, Serialize};

pub use grpc::{GrpcClient, TeachStream};
pub use rest::RestClient;

/// What went wrong with a call, named by the call (`POST /v1/cells`, `CreateCell`, ...).
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error("{what}: cannot reach {base}")]
    Unreachable {
        what: String,
        base: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The server refused the call (REST: a 4xx/5xx status with the error body's code).
    #[error("{what}: the server answered {status} ({code}): {message}")]
    Refused {
        what: String,
        status: u16,
        code: String,
        message: String,
    },
    /// The answer is not what the API describes.
    #[error("{what}: unexpected answer: {detail}")]
    Unexpected { what: String, detail: String },
    /// A gRPC call failed with this status.
    #[error("{what}: {} ({:?})", status.message(), status.code())]
    Grpc {
        what: String,
        #[source]
        status: tonic::Status,
    },
    #[error("not a server address: {0}")]
    BadAddress(String),
    /// A call made out of order (a waypoint before `start`).
    #[error("{0}")]
    Usage(&'static str),
}

pub type Result<T> = std::result::Result<T, ClientError>;

/// How a client talks to the server.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// The REST API (JSON over HTTP).
    #[default]
    Rest,
    /// The gRPC API on the same port: unary calls and a `Teach` stream for teaching.
    Grpc,
}

/// The calls a session makes, over one transport.
#[derive(Debug, Clone)]
pub enum Client {
    Rest(RestClient),
    Grpc(GrpcClient),
}

impl From<RestClient> for Client {
    fn from(c: RestClient) -> Client {
        Client::Rest(c)
    }
}

impl From<GrpcClient> for Client {
    fn from(c: GrpcClient) -> Client {
        Client::Grpc(c)
    }
}

/// The same call on whichever transport the client has.
macro_rules! either {
    ($self:ident, $c:ident => $call:expr) => {
        match $self {
            Client::Rest($c) => $call,
            Client::Grpc($c) => $call,
        }
    };
}

impl Client {
    /// A client of the server at `base` (`http://host:port`) over `transport`.
    pub async fn connect(
        transport: Transport,
        base: &str,
        token: Option<String>,
    ) -> Result<Client> {
        Ok(match transport {
            Transport::Rest => Client::Rest(RestClient::new(base, token)),
            Transport::Grpc => Client::Grpc(GrpcClient::connect(base, token).await?),
        })
    }

    pub fn transport(&self) -> Transport {
        match self {
            Client::Rest(_) => Transport::Rest,
            Client::Grpc(_) => Transport::Grpc,
        }
    }

    pub fn base(&self) -> &str {
        either!(self, c => c.base())
    }

    /// Creates a cell; its id.
    pub async fn create_cell(&self, cell: &CreateCell) -> Result<i64> {
        match self {
            Client::Rest(c) => Ok(c.create_cell(cell).await?.id),
            Client::Grpc(c) => c.create_cell(cell).await,
        }
    }

    /// Creates a program in a cell; its id.
    pub async fn create_program(&self, cell: i64, program: &CreateProgram) -> Result<i64> {
        match self {
            Client::Rest(c) => Ok(c.create_program(cell, program).await?.id),
            Client::Grpc(c) => c.create_program(cell, program).await,
        }
    }

    /// Starts a routine in a program; its id.
    pub async fn create_routine(&self, program: i64, routine: &CreateRoutine) -> Result<i64> {
        match self {
            Client::Rest(c) => Ok(c.create_routine(program, routine).await?.id),
            Client::Grpc(c) => c.create_routine(program, routine).await,
        }
    }

    /// Appends a waypoint by one call (for teaching many, see [`Client::teaching`]).
    pub async fn append(&self, routine: i64, waypoint: &NewWaypoint) -> Result<Taught> {
        either!(self, c => c.append(routine, waypoint).await)
    }

    /// Appends a hand-guided trajectory's attractors as taught waypoints (or, with
    /// `preview`, only shows them).
    pub async fn append_trajectory(
        &self,
        routine: i64,
        trajectory: &TrajectoryRequest,
    ) -> Result<TrajectoryAnswer> {
        either!(self, c => c.append_trajectory(routine, trajectory).await)
    }

    pub async fn finish(&self, routine: i64) -> Result<()> {
        match self {
            Client::Rest(c) => c.finish(routine).await.map(drop),
            Client::Grpc(c) => c.finish(routine).await,
        }
    }

    pub async fn feedback(&self, prediction: i64, feedback: &Feedback) -> Result<()> {
        match self {
            Client::Rest(c) => c.feedback(prediction, feedback).await.map(drop),
            Client::Grpc(c) => c.feedback(prediction, feedback).await,
        }
    }

    pub async fn stats(&self, cell: i64) -> Result<CellStats> {
        either!(self, c => c.stats(cell).await)
    }

    pub async fn rebuild(&self, cell: i64) -> Result<ModelInfo> {
        either!(self, c => c.rebuild(cell).await)
    }

    /// The prediction for an open routine (with `k`: an open-loop completion).
    pub async fn predict(&self, routine: i64, query: &PredictQuery) -> Result<PredictionSet> {
        either!(self, c => c.predict(routine, query).await)
    }

    /// Imports offline program files into a cell.
    pub async fn import(&self, cell: i64, request: &ImportRequest) -> Result<()> {
        match self {
            Client::Rest(c) => c.import(cell, request).await.map(drop),
            Client::Grpc(c) => c.import(cell, request).await,
        }
    }

    /// Ready to teach routines, one at a time (over gRPC: opens a `Teach` stream).
    pub async fn teaching(&self) -> Result<Teaching> {
        Ok(match self {
            Client::Rest(c) => Teaching::Rest {
                client: c.clone(),
                routine: None,
            },
            Client::Grpc(c) => Teaching::Grpc(c.teach().await?),
        })
    }
}

/// Teaches routines one after another: `start`, `waypoint`s, `finish`.
#[derive(Debug)]
pub enum Teaching {
    /// REST: each waypoint and the finish are requests on the routine started.
    Rest {
        client: RestClient,
        routine: Option<i64>,
    },
    /// gRPC: the commands of one `Teach` stream.
    Grpc(TeachStream),
}

impl Teaching {
    /// Selects the open routine the following waypoints go to.
    pub async fn start(&mut self, routine_id: i64) -> Result<()> {
        match self {
            Teaching::Rest { routine, .. } => {
                *routine = Some(routine_id);
                Ok(())
            }
            Teaching::Grpc(s) => s.start(routine_id).await,
        }
    }

    /// Teaches a waypoint: the stored waypoint and the prediction for the next one.
    pub async fn waypoint(&mut self, waypoint: &NewWaypoint) -> Result<Taught> {
        match self {
            Teaching::Rest {
                client,
                routine: Some(r),
            } => client.append(*r, waypoint).await,
            Teaching::Rest { routine: None, .. } => {
                Err(ClientError::Usage("a waypoint before start"))
            }
            Teaching::Grpc(s) => s.waypoint(waypoint).await,
        }
    }

    /// Finishes the routine started.
    pub async fn finish(&mut self) -> Result<()> {
        match self {
            Teaching::Rest { client, routine } => match routine.take() {
                Some(r) => client.finish(r).await.map(drop),
                None => Err(ClientError::Usage("finish before start")),
            },
            Teaching::Grpc(s) => s.finish().await,
        }
    }
}
