//! The driver of `nextpose simulate`: the simulated operator ([`crate::sim`]) teaching corpus
//! programs against a real nextpose server over its REST API or over gRPC ([`Transport`]).
//!
//! This is an adapter, like a pendant: it creates a cell per session with the condition's
//! settings and the arm's placement, optionally teaches the cell a history first, then teaches
//! each routine waypoint by waypoint as the operator does (append → the prediction for the next
//! waypoint → the operator's decision → the waypoint taught → feedback), finishes the routines,
//! and collects the simulated times and counts. [`LocalServer`] starts the real application on
//! a loopback port with a temporary SQLite file for the command and the tests.
//!
//! The session logic is written once against [`Driver`] (the calls a session makes) and
//! [`Teacher`] (teaching one routine after another): over REST each is an HTTP request
//! ([`Client`]); over gRPC ([`grpc`]) the cells, programs, routines, feedback and stats are
//! unary calls and the waypoints go through one `Teach` stream per session. Both read the
//! answers into the same views, so a seed gives the same session either way.

pub mod grpc;

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};
use tokio::task::JoinSet;

use crate::app::resources::PoseDto;
use crate::engine::{Pose, Profile};
use crate::kinematics::{ReachPolicy, bundled_robots_dir, load_robot};
use crate::replay::Program;
use crate::sim::plan::{RoutineResult, placement, repository, waypoint_rng};
use crate::sim::{
    Arm, Condition, ConditionSummary, Decision, Feedback, History, Operator, Plan, Suggestion,
    Time, summarise,
};
pub use grpc::{GrpcClient, TeachStream};

// ---- the client -------------------------------------------------------------------------------

/// A REST client of one server.
#[derive(Debug, Clone)]
pub struct Client {
    base: String,
    http: reqwest::Client,
    token: Option<String>,
}

impl Client {
    pub fn new(base: &str, token: Option<String>) -> Client {
        Client {
            base: base.trim_end_matches('/').to_string(),
            http: reqwest::Client::new(),
            token,
        }
    }

    pub fn base(&self) -> &str {
        &self.base
    }

    async fn send<T: DeserializeOwned>(
        &self,
        rb: reqwest::RequestBuilder,
        what: &str,
    ) -> Result<T> {
        let rb = match &self.token {
            Some(t) => rb.bearer_auth(t),
            None => rb,
        };
        let r = rb
            .send()
            .await
            .with_context(|| format!("{what}: cannot reach {}", self.base))?;
        let status = r.status();
        let text = r.text().await.with_context(|| format!("{what}: reading"))?;
        if !status.is_success() {
            bail!("{what}: server answered {status}: {text}");
        }
        let text = if text.is_empty() { "null" } else { &text };
        serde_json::from_str(text).with_context(|| format!("{what}: unexpected answer {text}"))
    }

    pub async fn post<T: DeserializeOwned>(&self, path: &str, body: &Value) -> Result<T> {
        let url = format!("{}{path}", self.base);
        self.send(self.http.post(&url).json(body), &format!("POST {path}"))
            .await
    }

    pub async fn get<T: DeserializeOwned>(&self, path: &str) -> Result<T> {
        let url = format!("{}{path}", self.base);
        self.send(self.http.get(&url), &format!("GET {path}")).await
    }

    pub async fn delete<T: DeserializeOwned>(&self, path: &str) -> Result<T> {
        let url = format!("{}{path}", self.base);
        self.send(self.http.delete(&url), &format!("DELETE {path}"))
            .await
    }

    pub async fn create_cell(&self, name: &str, settings: &Value) -> Result<i64> {
        let c: Id = self
            .post("/v1/cells", &json!({ "name": name, "settings": settings }))
            .await?;
        Ok(c.id)
    }

    pub async fn create_program(&self, cell: i64, name: &str) -> Result<i64> {
        let p: Id = self
            .post(
                &format!("/v1/cells/{cell}/programs"),
                &json!({ "name": name }),
            )
            .await?;
        Ok(p.id)
    }

    pub async fn create_routine(&self, program: i64, name: &str) -> Result<i64> {
        let r: Id = self
            .post(
                &format!("/v1/programs/{program}/routines"),
                &json!({ "name": name }),
            )
            .await?;
        Ok(r.id)
    }

    pub async fn append(&self, routine: i64, pose: &Pose) -> Result<TaughtView> {
        self.post(
            &format!("/v1/routines/{routine}/waypoints"),
            &json!({ "pose": PoseDto::from(pose) }),
        )
        .await
    }

    pub async fn feedback(&self, prediction: i64, feedback: &Feedback) -> Result<()> {
        let body = match feedback {
            Feedback::Accepted => json!({ "verdict": "accepted" }),
            Feedback::Adjusted(p) => json!({ "verdict": "adjusted", "pose": PoseDto::from(p) }),
            Feedback::Rejected => json!({ "verdict": "rejected" }),
        };
        let _: Value = self
            .post(&format!("/v1/predictions/{prediction}/feedback"), &body)
            .await?;
        Ok(())
    }

    pub async fn finish(&self, routine: i64) -> Result<()> {
        let _: Value = self
            .post(&format!("/v1/routines/{routine}/finish"), &json!({}))
            .await?;
        Ok(())
    }

    pub async fn stats(&self, cell: i64) -> Result<CellStatsView> {
        self.get(&format!("/v1/cells/{cell}/stats")).await
    }

    pub async fn rebuild(&self, cell: i64) -> Result<ModelView> {
        self.post(&format!("/v1/cells/{cell}/rebuild"), &json!({}))
            .await
    }

    /// Open-loop completion of up to `k` waypoints for an open routine.
    pub async fn predict(&self, routine: i64, k: usize) -> Result<Vec<PredictionView>> {
        let set: PredictionSetView = self
            .get(&format!("/v1/routines/{routine}/prediction?k={k}"))
            .await?;
        Ok(set.predictions)
    }

    /// Imports offline program files (`(name, text)`) into a cell and learns them.
    pub async fn import(&self, cell: i64, files: &[(String, String)]) -> Result<Value> {
        let files: Vec<Value> = files
            .iter()
            .map(|(name, content)| json!({ "name": name, "content": content }))
            .collect();
        self.post(
            &format!("/v1/cells/{cell}/imports"),
            &json!({ "files": files, "learn": true }),
        )
        .await
    }
}

#[derive(Debug, Deserialize)]
struct Id {
    id: i64,
}

/// What the driver reads of a taught waypoint's answer.
#[derive(Debug, Clone, Deserialize)]
pub struct TaughtView {
    pub waypoint: WaypointView,
    pub prediction: PredictionView,
}

#[derive(Debug, Clone, Deserialize)]
pub struct WaypointView {
    pub id: i64,
    pub seq: i64,
    pub reachable: Option<bool>,
}

/// What the driver reads of a prediction.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct PredictionView {
    pub id: Option<i64>,
    pub offered: bool,
    pub withheld: Option<WithheldView>,
    pub reachability: Option<ReachabilityView>,
    pub pose: Option<PoseDto>,
    pub phi: f64,
    pub after_waypoints: i64,
    pub model_version: i64,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct WithheldView {
    pub reason: String,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct ReachabilityView {
    pub reachable: bool,
}

#[derive(Debug, Deserialize)]
struct PredictionSetView {
    predictions: Vec<PredictionView>,
}

/// A cell's model as the stats and rebuild routes report it.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct ModelView {
    pub states: usize,
    pub edges: usize,
    pub perplexity: f64,
    pub routines: u32,
    pub depth: usize,
    pub observations: u64,
    pub version: i64,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct FeedbackView {
    pub offered: i64,
    pub accepted: i64,
    pub adjusted: i64,
    pub rejected: i64,
    pub pending: i64,
}

#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct CellStatsView {
    pub cell_id: i64,
    pub model: ModelView,
    pub feedback: FeedbackView,
}

// ---- a session --------------------------------------------------------------------------------

/// What the cell learns before the operator starts.
#[derive(Debug, Clone)]
pub enum Warmup {
    None,
    /// Programs taught exactly through the API (offline programs), each in its own program.
    Programs(Vec<Program>),
    /// Offline program files `(name, text)` imported through the import API.
    Import(Vec<(String, String)>),
}

/// One session: a condition, a program, a seed.
#[derive(Debug, Clone)]
pub struct Session {
    pub condition: Condition,
    pub program: Program,
    pub program_index: usize,
    pub seed: u64,
    pub warmup: Warmup,
    pub reach_policy: ReachPolicy,
    /// Unique within the server (cells are named).
    pub cell_name: String,
}

/// A prediction the operator was shown (or would have been), as the service answered it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictionSeen {
    pub routine_index: usize,
    /// Waypoints taught in the routine when it was made.
    pub after_waypoints: usize,
    pub offered: bool,
    /// The service's reachability verdict, when it checked one.
    pub reachable: Option<bool>,
    pub withheld: Option<String>,
    /// What the operator did with it (only when offered and predictions are on).
    pub decision: Option<Decision>,
}

/// What a session yields.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionOutcome {
    pub cell_id: i64,
    pub routines: Vec<RoutineResult>,
    pub predictions: Vec<PredictionSeen>,
    /// The cell's statistics after the session.
    pub stats: CellStatsView,
    /// Routine ids on the server, in teaching order.
    pub routine_ids: Vec<i64>,
}

/// A cell's settings as a session creates it: the condition's profile and overrides, the
/// σs of the plan, the arm and its placement.
#[derive(Debug, Clone, PartialEq)]
pub struct CellSetup {
    pub profile: Profile,
    pub delta: Option<f64>,
    pub phi_min: Option<f64>,
    pub horizon: Option<usize>,
    pub sigma_t_mm: f64,
    pub sigma_q: f64,
    pub robot: String,
    pub base: Pose,
    pub tool: Pose,
    pub reach_policy: ReachPolicy,
}

impl CellSetup {
    fn new(
        plan: &Plan,
        session: &Session,
        robot: &str,
        frames: &crate::kinematics::Cell,
    ) -> CellSetup {
        let c = &session.condition;
        let (sigma_t_mm, sigma_q) = plan.sigmas(c.profile);
        CellSetup {
            profile: c.profile,
            delta: c.delta,
            phi_min: c.phi_min,
            horizon: c.horizon,
            sigma_t_mm,
            sigma_q,
            robot: robot.to_string(),
            base: frames.base,
            tool: frames.tool,
            reach_policy: session.reach_policy,
        }
    }

    /// The `settings` object of `POST /v1/cells`.
    pub fn json(&self) -> Value {
        let mut s = json!({
            "profile": self.profile.name(),
            "sigma_t_mm": self.sigma_t_mm,
            "sigma_q": self.sigma_q,
            "robot": self.robot,
            "base": PoseDto::from(&self.base),
            "tool": PoseDto::from(&self.tool),
            "reach_policy": self.reach_policy,
        });
        for (key, v) in [("delta", self.delta), ("phi_min", self.phi_min)] {
            if let Some(v) = v {
                s[key] = json!(v);
            }
        }
        if let Some(h) = self.horizon {
            s["horizon"] = json!(h);
        }
        s
    }
}

// ---- the transports ---------------------------------------------------------------------------

/// How the driver talks to the server.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// The REST API (JSON over HTTP).
    #[default]
    Rest,
    /// The gRPC API on the same port: unary calls and a `Teach` stream per session.
    Grpc,
}

/// The calls a session makes, over one transport.
#[derive(Debug, Clone)]
pub enum Driver {
    Rest(Client),
    Grpc(GrpcClient),
}

impl From<Client> for Driver {
    fn from(c: Client) -> Driver {
        Driver::Rest(c)
    }
}

impl From<GrpcClient> for Driver {
    fn from(c: GrpcClient) -> Driver {
        Driver::Grpc(c)
    }
}

impl Driver {
    /// A client of the server at `base` (`http://host:port`) over `transport`.
    pub async fn connect(
        transport: Transport,
        base: &str,
        token: Option<String>,
    ) -> Result<Driver> {
        Ok(match transport {
            Transport::Rest => Driver::Rest(Client::new(base, token)),
            Transport::Grpc => Driver::Grpc(GrpcClient::connect(base, token).await?),
        })
    }

    pub fn transport(&self) -> Transport {
        match self {
            Driver::Rest(_) => Transport::Rest,
            Driver::Grpc(_) => Transport::Grpc,
        }
    }

    pub fn base(&self) -> &str {
        match self {
            Driver::Rest(c) => c.base(),
            Driver::Grpc(c) => c.base(),
        }
    }

    pub async fn create_cell(&self, name: &str, setup: &CellSetup) -> Result<i64> {
        match self {
            Driver::Rest(c) => c.create_cell(name, &setup.json()).await,
            Driver::Grpc(c) => c.create_cell(name, setup).await,
        }
    }

    pub async fn create_program(&self, cell: i64, name: &str) -> Result<i64> {
        match self {
            Driver::Rest(c) => c.create_program(cell, name).await,
            Driver::Grpc(c) => c.create_program(cell, name).await,
        }
    }

    pub async fn create_routine(&self, program: i64, name: &str) -> Result<i64> {
        match self {
            Driver::Rest(c) => c.create_routine(program, name).await,
            Driver::Grpc(c) => c.create_routine(program, name).await,
        }
    }

    pub async fn feedback(&self, prediction: i64, feedback: &Feedback) -> Result<()> {
        match self {
            Driver::Rest(c) => c.feedback(prediction, feedback).await,
            Driver::Grpc(c) => c.feedback(prediction, feedback).await,
        }
    }

    pub async fn stats(&self, cell: i64) -> Result<CellStatsView> {
        match self {
            Driver::Rest(c) => c.stats(cell).await,
            Driver::Grpc(c) => c.stats(cell).await,
        }
    }

    pub async fn rebuild(&self, cell: i64) -> Result<ModelView> {
        match self {
            Driver::Rest(c) => c.rebuild(cell).await,
            Driver::Grpc(c) => c.rebuild(cell).await,
        }
    }

    /// Open-loop completion of up to `k` waypoints for an open routine.
    pub async fn predict(&self, routine: i64, k: usize) -> Result<Vec<PredictionView>> {
        match self {
            Driver::Rest(c) => c.predict(routine, k).await,
            Driver::Grpc(c) => c.predict(routine, k).await,
        }
    }

    /// Imports offline program files (`(name, text)`) into a cell and learns them.
    pub async fn import(&self, cell: i64, files: &[(String, String)]) -> Result<()> {
        match self {
            Driver::Rest(c) => c.import(cell, files).await.map(|_| ()),
            Driver::Grpc(c) => c.import(cell, files).await,
        }
    }

    /// Ready to teach routines, one at a time (over gRPC: opens a `Teach` stream).
    pub async fn teacher(&self) -> Result<Teacher> {
        Ok(match self {
            Driver::Rest(c) => Teacher::Rest {
                client: c.clone(),
                routine: None,
            },
            Driver::Grpc(c) => Teacher::Grpc(c.teach().await?),
        })
    }
}

/// Teaches routines one after another: `start`, `waypoint`s, `finish`.
#[derive(Debug)]
pub enum Teacher {
    /// REST: each waypoint and the finish are requests on the routine started.
    Rest {
        client: Client,
        routine: Option<i64>,
    },
    /// gRPC: the commands of one `Teach` stream.
    Grpc(TeachStream),
}

impl Teacher {
    /// Selects the open routine the following waypoints go to.
    pub async fn start(&mut self, routine_id: i64) -> Result<()> {
        match self {
            Teacher::Rest { routine, .. } => {
                *routine = Some(routine_id);
                Ok(())
            }
            Teacher::Grpc(s) => s.start(routine_id).await,
        }
    }

    /// Teaches a waypoint: the stored waypoint and the prediction for the next one.
    pub async fn waypoint(&mut self, pose: &Pose) -> Result<TaughtView> {
        match self {
            Teacher::Rest {
                client,
                routine: Some(r),
            } => client.append(*r, pose).await,
            Teacher::Rest { routine: None, .. } => bail!("a waypoint before start"),
            Teacher::Grpc(s) => s.waypoint(pose).await,
        }
    }

    /// Finishes the routine started.
    pub async fn finish(&mut self) -> Result<()> {
        match self {
            Teacher::Rest { client, routine } => match routine.take() {
                Some(r) => client.finish(r).await,
                None => bail!("finish before start"),
            },
            Teacher::Grpc(s) => s.finish().await,
        }
    }
}

/// Teaches a program's routines exactly (no operator, no time): a cell's history.
async fn teach_exactly(client: &Driver, cell: i64, program: &Program, name: &str) -> Result<()> {
    let pid = client.create_program(cell, name).await?;
    let mut teacher = client.teacher().await?;
    for r in &program.routines {
        let rid = client.create_routine(pid, &r.name).await?;
        teacher.start(rid).await?;
        for w in &r.waypoints {
            teacher.waypoint(w).await?;
        }
        teacher.finish().await?;
    }
    Ok(())
}

fn suggestion_of(p: &PredictionView) -> Result<Option<(i64, Suggestion)>> {
    if !p.offered {
        return Ok(None);
    }
    let (Some(id), Some(pose)) = (p.id, p.pose.as_ref()) else {
        bail!("an offered prediction without id or pose: {p:?}");
    };
    let pose = pose.to_pose().context("the offered pose")?;
    let reachable = p.reachability.as_ref().is_none_or(|r| r.reachable);
    Ok(Some((id, Suggestion { pose, reachable })))
}

/// Runs one session against the server.
pub async fn run_session(
    client: &Driver,
    plan: &Plan,
    session: &Session,
) -> Result<SessionOutcome> {
    let program = &session.program;
    let (robot_name, frames) = placement(program)?;
    let robot = load_robot(&bundled_robots_dir(), &robot_name)?;
    let cell = client
        .create_cell(
            &session.cell_name,
            &CellSetup::new(plan, session, &robot_name, &frames),
        )
        .await?;
    match &session.warmup {
        Warmup::None => {}
        Warmup::Programs(history) => {
            for (i, h) in history.iter().enumerate() {
                teach_exactly(client, cell, h, &format!("history {i}: {}", h.name)).await?;
            }
        }
        Warmup::Import(files) => {
            client.import(cell, files).await?;
        }
    }
    let Some(first) = program
        .routines
        .iter()
        .flat_map(|r| r.waypoints.first())
        .next()
    else {
        bail!("program {} has no waypoints", program.name);
    };
    let mut operator = Operator::new(
        plan.operator.clone(),
        Arm::new(robot, frames, plan.limits, first),
    );
    let pid = client.create_program(cell, &program.name).await?;
    let mut teacher = client.teacher().await?;
    let c = &session.condition;
    let mut routines = Vec::with_capacity(program.routines.len());
    let mut predictions: Vec<PredictionSeen> = Vec::new();
    let mut routine_ids = Vec::with_capacity(program.routines.len());
    for (ri, routine) in program.routines.iter().enumerate() {
        let rid = client.create_routine(pid, &routine.name).await?;
        teacher.start(rid).await?;
        routine_ids.push(rid);
        let mut result = RoutineResult {
            condition: c.key.clone(),
            seed: session.seed,
            program: program.name.clone(),
            program_index: session.program_index,
            routine: routine.name.clone(),
            routine_index: ri,
            waypoints: routine.waypoints.len(),
            time_s: 0.0,
            time: Time::default(),
            offered: 0,
            accepted: 0,
            adjusted: 0,
            rejected: 0,
            dismissed: 0,
            offered_unreachable: 0,
            unreachable_waypoints: 0,
        };
        let mut pending: Option<(i64, Suggestion)> = None;
        for (wi, target) in routine.waypoints.iter().enumerate() {
            let mut rng = waypoint_rng(session.seed, session.program_index, ri, wi);
            let shown = if c.predictions {
                pending.as_ref()
            } else {
                None
            };
            let step = operator.teach(target, shown.map(|(_, s)| s), &mut rng);
            let taught = teacher.waypoint(&step.pose).await?;
            if let (Some((id, _)), Some(fb)) = (shown, step.feedback.as_ref()) {
                client.feedback(*id, fb).await?;
                match fb {
                    Feedback::Accepted => result.accepted += 1,
                    Feedback::Adjusted(_) => result.adjusted += 1,
                    Feedback::Rejected => result.rejected += 1,
                }
                if let Some(seen) = predictions.last_mut() {
                    seen.decision = step.decision;
                }
            }
            result.time.add(&step.time);
            if taught.waypoint.reachable == Some(false) {
                result.unreachable_waypoints += 1;
            }
            let p = &taught.prediction;
            predictions.push(PredictionSeen {
                routine_index: ri,
                after_waypoints: usize::try_from(p.after_waypoints).unwrap_or(0),
                offered: p.offered,
                reachable: p.reachability.as_ref().map(|r| r.reachable),
                withheld: p.withheld.as_ref().map(|w| w.reason.clone()),
                decision: None,
            });
            if p.offered {
                result.offered += 1;
                if p.reachability.as_ref().is_some_and(|r| !r.reachable) {
                    result.offered_unreachable += 1;
                }
            }
            pending = suggestion_of(p)?;
        }
        if c.predictions
            && let Some((id, _)) = pending
        {
            result.time.add(&operator.dismiss());
            client.feedback(id, &Feedback::Rejected).await?;
            result.rejected += 1;
            result.dismissed += 1;
            if let Some(seen) = predictions.last_mut() {
                seen.decision = Some(Decision::Dismiss);
            }
        }
        teacher.finish().await?;
        result.time_s = result.time.total();
        routines.push(result);
    }
    let stats = client.stats(cell).await?;
    Ok(SessionOutcome {
        cell_id: cell,
        routines,
        predictions,
        stats,
        routine_ids,
    })
}

// ---- the experiment ---------------------------------------------------------------------------

/// A whole run: every condition × seed × program.
#[derive(Debug, Clone, Serialize)]
pub struct Experiment {
    pub plan: Plan,
    pub programs: Vec<String>,
    pub summary: Vec<ConditionSummary>,
    pub routines: Vec<RoutineResult>,
}

/// The sessions of a plan, in a fixed order (condition, seed, program).
pub fn sessions(plan: &Plan, programs: &[Program], run: &str) -> Vec<Session> {
    let mut out = Vec::new();
    for c in &plan.conditions {
        for &seed in &plan.seeds {
            for (i, p) in programs.iter().enumerate() {
                let warmup = match plan.history {
                    History::None => Warmup::None,
                    History::Repository => {
                        let repo = repository(p);
                        let earlier: Vec<Program> = programs[..i]
                            .iter()
                            .filter(|q| repository(q) == repo)
                            .cloned()
                            .collect();
                        if earlier.is_empty() {
                            Warmup::None
                        } else {
                            Warmup::Programs(earlier)
                        }
                    }
                };
                out.push(Session {
                    condition: c.clone(),
                    program: p.clone(),
                    program_index: i,
                    seed,
                    warmup,
                    reach_policy: plan.reach_policy,
                    cell_name: format!("sim {run} {} seed {seed} program {i}", c.key),
                });
            }
        }
    }
    out
}

/// Runs every session of the plan, `jobs` at a time (each session is its own cell, so the
/// results do not depend on the interleaving), and summarises. `progress` is told after each
/// session how many are done of how many.
pub async fn run_experiment(
    client: &Driver,
    plan: &Plan,
    programs: &[Program],
    jobs: usize,
    progress: impl Fn(usize, usize),
) -> Result<Experiment> {
    let run = format!(
        "{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0)
    );
    let all = sessions(plan, programs, &run);
    let total = all.len();
    let plan_arc = Arc::new(plan.clone());
    let mut queue = all.into_iter().enumerate();
    let mut running = JoinSet::new();
    let mut done: Vec<(usize, Vec<RoutineResult>)> = Vec::with_capacity(total);
    loop {
        while running.len() < jobs.max(1) {
            let Some((i, s)) = queue.next() else { break };
            let (client, plan) = (client.clone(), plan_arc.clone());
            running.spawn(async move {
                let out = run_session(&client, &plan, &s).await.with_context(|| {
                    format!(
                        "session {} / seed {} / {}",
                        s.condition.key, s.seed, s.program.name
                    )
                });
                (i, out)
            });
        }
        let Some(joined) = running.join_next().await else {
            break;
        };
        let (i, out) = joined.context("a session panicked")?;
        done.push((i, out?.routines));
        progress(done.len(), total);
    }
    done.sort_by_key(|(i, _)| *i);
    let routines: Vec<RoutineResult> = done.into_iter().flat_map(|(_, r)| r).collect();
    let summary = summarise(&plan.conditions, &routines)?;
    Ok(Experiment {
        plan: plan.clone(),
        programs: programs.iter().map(|p| p.name.clone()).collect(),
        summary,
        routines,
    })
}

// ---- a local server ---------------------------------------------------------------------------

/// The real application on 127.0.0.1 (a free port) with a SQLite file in a temporary directory.
pub struct LocalServer {
    pub base: String,
    pub db: PathBuf,
    server: crate::server::Running,
    _dir: tempfile::TempDir,
}

impl LocalServer {
    /// Starts it on the current tokio runtime.
    pub async fn start() -> Result<LocalServer> {
        use crate::server::{Application, Database, ServerSettings};
        let dir = tempfile::tempdir().context("creating a temporary directory")?;
        let db = dir.path().join("nextpose-sim.db");
        let settings = ServerSettings {
            database: Database::File(db.clone()),
            durability: crate::storage::Durability::Process,
            addr: "127.0.0.1:0".into(),
            http: crate::transport::TransportOptions::default(),
            robots: bundled_robots_dir(),
        };
        let server = Application::build(settings).await?.spawn()?;
        Ok(LocalServer {
            base: server.base_url(),
            db,
            server,
            _dir: dir,
        })
    }

    /// Stops it gracefully (in-flight requests finish) and removes the database.
    pub async fn stop(mut self) -> Result<()> {
        self.server.stop().await
    }
}
