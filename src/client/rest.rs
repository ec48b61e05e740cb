//! The REST transport: JSON over HTTP, the resources read and written with their own serde
//! derives; an error answer is read as the API's error body.

use reqwest::{Method, RequestBuilder};
use serde::Serialize;
use serde::de::DeserializeOwned;

use super::{ClientError, Result};
use crate::api::ErrorBody;
use crate::api::{
    Cell, CellStats, CreateCell, CreateProgram, CreateRoutine, Feedback, FeedbackRecorded,
    Finished, ImportRequest, ImportResult, ModelInfo, NewWaypoint, PredictQuery, PredictionSet,
    Program, ProgramExport, Routine, Taught, TrajectoryAnswer, TrajectoryRequest,
};

/// A REST client of one server.
#[derive(Debug, Clone)]
pub struct RestClient {
    base: String,
    http: reqwest::Client,
    token: Option<String>,
}

impl RestClient {
    pub fn new(base: &str, token: Option<String>) -> RestClient {
        RestClient {
            base: base.trim_end_matches('/').to_string(),
            http: reqwest::Client::new(),
            token,
        }
    }

    pub fn base(&self) -> &str {
        &self.base
    }

    /// A request to `path` (below the base), with the token when there is one.
    pub fn request(&self, method: Method, path: &str) -> RequestBuilder {
        let rb = self.http.request(method, format!("{}{path}", self.base));
        match &self.token {
            Some(t) => rb.bearer_auth(t),
            None => rb,
        }
    }

    async fn call<T: DeserializeOwned>(&self, rb: RequestBuilder, what: String) -> Result<T> {
        let r = rb.send().await.map_err(|e| ClientError::Unreachable {
            what: what.clone(),
            base: self.base.clone(),
            source: Box::new(e),
        })?;
        let status = r.status();
        let text = r.text().await.map_err(|e| ClientError::Unexpected {
            what: what.clone(),
            detail: format!("reading the body: {e}"),
        })?;
        if !status.is_success() {
            let (code, message) = match serde_json::from_str::<ErrorBody>(&text) {
                Ok(b) => (b.error.code, b.error.message),
                Err(_) => (String::new(), text),
            };
            return Err(ClientError::Refused {
                what,
                status: status.as_u16(),
                code,
                message,
            });
        }
        serde_json::from_str(&text).map_err(|e| ClientError::Unexpected {
            what,
            detail: format!("{e}: {text}"),
        })
    }

    async fn get<T: DeserializeOwned>(&self, path: &str) -> Result<T> {
        self.call(self.request(Method::GET, path), format!("GET {path}"))
            .await
    }

    async fn post<T: DeserializeOwned>(&self, path: &str, body: &impl Serialize) -> Result<T> {
        self.call(
            self.request(Method::POST, path).json(body),
            format!("POST {path}"),
        )
        .await
    }

    pub async fn list_cells(&self) -> Result<Vec<Cell>> {
        self.get("/v1/cells").await
    }

    pub async fn create_cell(&self, cell: &CreateCell) -> Result<Cell> {
        self.post("/v1/cells", cell).await
    }

    pub async fn create_program(&self, cell: i64, program: &CreateProgram) -> Result<Program> {
        self.post(&format!("/v1/cells/{cell}/programs"), program)
            .await
    }

    pub async fn create_routine(&self, program: i64, routine: &CreateRoutine) -> Result<Routine> {
        self.post(&format!("/v1/programs/{program}/routines"), routine)
            .await
    }

    pub async fn append(&self, routine: i64, waypoint: &NewWaypoint) -> Result<Taught> {
        self.post(&format!("/v1/routines/{routine}/waypoints"), waypoint)
            .await
    }

    /// Appends a hand-guided trajectory's attractors (or previews them).
    pub async fn append_trajectory(
        &self,
        routine: i64,
        trajectory: &TrajectoryRequest,
    ) -> Result<TrajectoryAnswer> {
        self.post(&format!("/v1/routines/{routine}/trajectory"), trajectory)
            .await
    }

    pub async fn finish(&self, routine: i64) -> Result<Finished> {
        self.post(
            &format!("/v1/routines/{routine}/finish"),
            &serde_json::json!({}),
        )
        .await
    }

    pub async fn feedback(&self, prediction: i64, feedback: &Feedback) -> Result<FeedbackRecorded> {
        self.post(&format!("/v1/predictions/{prediction}/feedback"), feedback)
            .await
    }

    pub async fn stats(&self, cell: i64) -> Result<CellStats> {
        self.get(&format!("/v1/cells/{cell}/stats")).await
    }

    pub async fn rebuild(&self, cell: i64) -> Result<ModelInfo> {
        self.post(&format!("/v1/cells/{cell}/rebuild"), &serde_json::json!({}))
            .await
    }

    pub async fn predict(&self, routine: i64, query: &PredictQuery) -> Result<PredictionSet> {
        let path = format!("/v1/routines/{routine}/prediction");
        self.call(
            self.request(Method::GET, &path).query(query),
            format!("GET {path}"),
        )
        .await
    }

    pub async fn import(&self, cell: i64, request: &ImportRequest) -> Result<ImportResult> {
        self.post(&format!("/v1/cells/{cell}/imports"), request)
            .await
    }

    /// A program as a controller file (`rapid`, `krl`, `fanuc`).
    pub async fn export(&self, program: i64, format: &str) -> Result<ProgramExport> {
        self.get(&format!("/v1/programs/{program}/export?format={format}"))
            .await
    }
}
