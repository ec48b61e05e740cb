//! The driver of `nextpose simulate`: the simulated operator ([`crate::simulation`]) teaching corpus
//! programs against a real nextpose server through the typed client ([`crate::client`]), over
//! REST or gRPC.
//!
//! Like a pendant, it creates a cell per session with the condition's settings and the arm's
//! placement, optionally teaches the cell a history first, then teaches each routine waypoint
//! by waypoint as the operator does (append → the prediction for the next waypoint → the
//! operator's decision → the waypoint taught → feedback), finishes the routines, and collects
//! the simulated times and counts. Both transports answer with the same resources, so a seed
//! gives the same session either way. [`LocalServer`] starts the real application on a
//! loopback port with a temporary SQLite file for the command and the tests.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use serde::Serialize;
use tokio::task::JoinSet;

use crate::api::{
    self, CellSettingsInput, CellStats, CreateCell, CreateProgram, CreateRoutine, ImportRequest,
    NewWaypoint, PoseValues, Prediction, UploadedFile, Verdict,
};
use crate::client::Client;
use crate::engine::Noise;
use crate::engine::Tolerance;
use crate::engine::{Pose, Profile};
use crate::kinematics::ReachPolicy;
use crate::kinematics::placement::{PlacedArm, ProgramArm};
use crate::replay::Program;
pub use crate::simulation::plan::placements;
use crate::simulation::plan::{RoutineResult, repository, waypoint_rng};
use crate::simulation::{
    Arm, Condition, ConditionSummary, Decision, Feedback, History, Operator, Plan, Suggestion,
    Time, summarise,
};

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
    /// The program's arm and where it stands ([`placements`]).
    pub arm: PlacedArm,
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
    pub stats: CellStats,
    /// Routine ids on the server, in teaching order.
    pub routine_ids: Vec<i64>,
}

/// A cell's settings as a session creates it: the condition's profile and overrides, the arm
/// and its placement, and, when the condition tells the cell about its operator, the plan's σs,
/// noise and tolerance (`None`: not set, the cell's own).
#[derive(Debug, Clone, PartialEq)]
pub struct CellSetup {
    pub profile: Profile,
    pub delta: Option<f64>,
    pub phi_min: Option<f64>,
    pub horizon: Option<usize>,
    pub sigma_t_mm: Option<f64>,
    pub sigma_q: Option<f64>,
    pub noise: Option<Noise>,
    pub tolerance: Option<Tolerance>,
    pub offer_threshold: Option<f64>,
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
        frames: &crate::kinematics::Mounting,
    ) -> CellSetup {
        let c = &session.condition;
        let known = c.operator_known;
        let (sigma_t_mm, sigma_q) = plan.sigmas(c.profile);
        let (noise, tolerance) = plan.noise();
        CellSetup {
            profile: c.profile,
            delta: c.delta,
            phi_min: c.phi_min,
            horizon: c.horizon,
            sigma_t_mm: known.then_some(sigma_t_mm),
            sigma_q: known.then_some(sigma_q),
            noise: known.then_some(noise),
            tolerance: known.then_some(tolerance),
            offer_threshold: c.offer_threshold,
            robot: robot.to_string(),
            base: frames.base,
            tool: frames.tool,
            reach_policy: session.reach_policy,
        }
    }

    /// The request that creates the cell named `name`.
    pub fn create_cell(&self, name: &str) -> CreateCell {
        CreateCell {
            name: name.to_string(),
            settings: CellSettingsInput {
                profile: Some(self.profile),
                delta: self.delta,
                phi_min: self.phi_min,
                horizon: self.horizon,
                sigma_t_mm: self.sigma_t_mm,
                sigma_q: self.sigma_q,
                robot: Some(self.robot.clone()),
                base: Some(PoseValues::from(&self.base)),
                tool: Some(PoseValues::from(&self.tool)),
                reach_policy: Some(self.reach_policy),
                noise: self.noise,
                tolerance: self.tolerance,
                offer_threshold: self.offer_threshold,
                ..CellSettingsInput::default()
            },
        }
    }
}

fn program_named(name: &str) -> CreateProgram {
    CreateProgram {
        name: name.to_string(),
    }
}

fn named(name: &str) -> CreateRoutine {
    CreateRoutine {
        name: Some(name.to_string()),
    }
}

/// The operator's decision as the feedback the pendant sends.
fn feedback_of(f: &Feedback) -> api::Feedback {
    match f {
        Feedback::Accepted => api::Feedback {
            verdict: Verdict::Accepted,
            pose: None,
        },
        Feedback::Adjusted(p) => api::Feedback {
            verdict: Verdict::Adjusted,
            pose: Some(p.into()),
        },
        Feedback::Rejected => api::Feedback {
            verdict: Verdict::Rejected,
            pose: None,
        },
    }
}

/// Teaches a program's routines exactly (no operator, no time): a cell's history.
async fn teach_exactly(client: &Client, cell: i64, program: &Program, name: &str) -> Result<()> {
    let pid = client.create_program(cell, &program_named(name)).await?;
    let mut teaching = client.teaching().await?;
    for r in &program.routines {
        let rid = client.create_routine(pid, &named(&r.name)).await?;
        teaching.start(rid).await?;
        for w in &r.waypoints {
            teaching.waypoint(&NewWaypoint::at(w)).await?;
        }
        teaching.finish().await?;
    }
    Ok(())
}

fn suggestion_of(p: &Prediction) -> Result<Option<(i64, Suggestion)>> {
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
    client: &Client,
    plan: &Plan,
    session: &Session,
) -> Result<SessionOutcome> {
    let program = &session.program;
    let robot = session.arm.robot.clone();
    let frames = session.arm.cell;
    let setup = CellSetup::new(plan, session, robot.name(), &frames);
    let cell = client
        .create_cell(&setup.create_cell(&session.cell_name))
        .await?;
    match &session.warmup {
        Warmup::None => {}
        Warmup::Programs(history) => {
            for (i, h) in history.iter().enumerate() {
                teach_exactly(client, cell, h, &format!("history {i}: {}", h.name)).await?;
            }
        }
        Warmup::Import(files) => {
            let files = files
                .iter()
                .map(|(name, content)| UploadedFile {
                    name: name.clone(),
                    content: content.clone(),
                })
                .collect();
            let request = ImportRequest {
                files,
                learn: Some(true),
            };
            client.import(cell, &request).await?;
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
    let pid = client
        .create_program(cell, &program_named(&program.name))
        .await?;
    let mut teaching = client.teaching().await?;
    let c = &session.condition;
    let mut routines = Vec::with_capacity(program.routines.len());
    let mut predictions: Vec<PredictionSeen> = Vec::new();
    let mut routine_ids = Vec::with_capacity(program.routines.len());
    for (ri, routine) in program.routines.iter().enumerate() {
        let rid = client.create_routine(pid, &named(&routine.name)).await?;
        teaching.start(rid).await?;
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
            let taught = teaching.waypoint(&NewWaypoint::at(&step.pose)).await?;
            if let (Some((id, _)), Some(fb)) = (shown, step.feedback.as_ref()) {
                client.feedback(*id, &feedback_of(fb)).await?;
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
            client
                .feedback(id, &feedback_of(&Feedback::Rejected))
                .await?;
            result.rejected += 1;
            result.dismissed += 1;
            if let Some(seen) = predictions.last_mut() {
                seen.decision = Some(Decision::Dismiss);
            }
        }
        teaching.finish().await?;
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
    /// Each program's arm, where it stands and how many taught waypoints it reaches, in
    /// program order.
    pub arms: Vec<ProgramArm>,
    pub summary: Vec<ConditionSummary>,
    pub routines: Vec<RoutineResult>,
}

/// The sessions of a plan, in a fixed order (condition, seed, program); `arms` are the
/// programs' arms ([`placements`]), in program order.
pub fn sessions(plan: &Plan, programs: &[Program], arms: &[PlacedArm], run: &str) -> Vec<Session> {
    let mut out = Vec::new();
    for c in &plan.conditions {
        for &seed in &plan.seeds {
            for (i, (p, arm)) in programs.iter().zip(arms).enumerate() {
                let warmup = match plan.history {
                    History::None => Warmup::None,
                    History::Repository | History::RepositoryOnline => {
                        let repo = repository(p);
                        let earlier: Vec<Program> = programs[..i]
                            .iter()
                            .enumerate()
                            .filter(|(_, q)| repository(q) == repo)
                            .map(|(j, q)| match plan.history {
                                History::RepositoryOnline => plan.as_taught_online(q, j, seed),
                                _ => q.clone(),
                            })
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
                    arm: arm.clone(),
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
    client: &Client,
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
    // The layout searches are CPU work: off the async workers.
    let arms = {
        let programs = programs.to_vec();
        tokio::task::spawn_blocking(move || placements(&programs))
            .await
            .context("the placement search panicked")??
    };
    let all = sessions(plan, programs, &arms, &run);
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
        arms: arms.into_iter().map(|a| a.arm).collect(),
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
            robots: None,
            backup_dir: None,
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
