//! The `nextpose` command line.
//!
//! - `nextpose replay <PATHS>...` replays corpus programs through the engine and the baselines
//!   and prints the scoreboard (optionally writes it as JSON, and plots as PNG and SVG).
//! - `nextpose sweep <PATHS>...` replays the engine over a grid of δ, φ_min and h.
//!
//! Engine settings start from a named profile; each flag overrides one field, and the result is
//! validated before anything runs, so a bad value is a one-line error, not a panic.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use serde::Serialize;

use crate::engine::config::{MergeRule, RecallGate};
use crate::engine::{EngineConfig, Profile};
use crate::replay::baselines::{self, DEFAULT_NEAREST_SEQ_GATE};
use crate::replay::engine_method::EngineMethod;
#[cfg(feature = "plots")]
use crate::replay::plots::{PlotGrid, plot_data, write_plots};
use crate::replay::report::{RunConfig, replay_all};
use crate::replay::sweep::{sweep, sweep_table};
use crate::replay::{Method, load_paths};

#[derive(Debug, Parser)]
#[command(
    name = "nextpose",
    version,
    about = "Teach-pendant next-waypoint prediction for industrial robot arms"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Replay corpus programs through the engine and the baselines; print the scoreboard.
    Replay(ReplayArgs),
    /// Replay the engine over a grid of delta, phi_min and horizon; print one line per setting.
    Sweep(SweepArgs),
    /// Run the service (REST API) until SIGINT/SIGTERM.
    Serve(ServeArgs),
    /// Print the OpenAPI description of the REST API (YAML), as committed in openapi.yaml.
    Openapi,
    /// Import offline program files (RAPID, KRL, FANUC TP) into a cell of a running server.
    Import(ImportArgs),
    /// Simulated operators teach corpus programs against the service; print the
    /// programming-time table (the shape of the seed's Table 4.1).
    Simulate(SimulateArgs),
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Corpus JSON files, or directories of them (all *.json, sorted by name).
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    /// Only the first N programs.
    #[arg(long)]
    pub programs: Option<usize>,
    /// Operator seeds per program and condition (seeds 1..=K).
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// The operator's precision: online (20 mm RMS, the seed's lab) or precise (0.05 mm).
    #[arg(long, value_enum, default_value_t = OperatorArg::Online)]
    pub operator: OperatorArg,
    /// What the cell knows before teaching: nothing, or the earlier programs (in the order
    /// given) of the same repository, taught exactly.
    #[arg(long, value_enum, default_value_t = HistoryArg::None)]
    pub history: HistoryArg,
    /// Suggestions the arm cannot reach: withheld (the service's default) or offered flagged
    /// (the operator then rejects them after a look).
    #[arg(long, value_enum, default_value_t = ReachPolicyArg::Withhold)]
    pub reach_policy: ReachPolicyArg,
    /// Keep the profiles' σ_t and σ_q instead of setting them to the operator's repeatability.
    #[arg(long)]
    pub profile_sigmas: bool,
    /// A running server; by default one is started in-process on 127.0.0.1 (a free port) with
    /// a temporary SQLite file.
    #[arg(long)]
    pub server: Option<String>,
    /// Bearer token, when the server requires one.
    #[arg(long, env = "NEXTPOSE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// How the operator's pendant talks to the service: the REST API, or gRPC (unary calls and
    /// a `Teach` stream per session). Both give the same results for the same seeds.
    #[arg(long, value_enum, default_value_t = TransportArg::Rest)]
    pub transport: TransportArg,
    /// Sessions run at once (each in its own cell).
    #[arg(long, default_value_t = 2)]
    pub jobs: usize,
    /// Also write the summary and every routine's result as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Also write the tables as Markdown.
    #[arg(long, value_name = "OUT.md")]
    pub markdown: Option<PathBuf>,
    /// Also write a bar chart of the change in programming time (simulated and the seed's).
    #[arg(long, value_name = "OUT.svg")]
    pub svg: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OperatorArg {
    Online,
    Precise,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TransportArg {
    Rest,
    Grpc,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReachPolicyArg {
    Withhold,
    Flag,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum HistoryArg {
    None,
    Repository,
}

#[derive(Debug, Args)]
pub struct ImportArgs {
    /// Program files of one upload (parsed together).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Name of the cell (created with default settings when it does not exist).
    #[arg(long)]
    pub cell: String,
    /// Store the programs without learning them into the cell's model.
    #[arg(long)]
    pub no_learn: bool,
    /// The server.
    #[arg(long, env = "NEXTPOSE_URL", default_value = "http://127.0.0.1:8080")]
    pub server: String,
    /// Bearer token, when the server requires one.
    #[arg(long, env = "NEXTPOSE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
}

#[derive(Debug, Args)]
pub struct ServeArgs {
    /// SQLite database file (created when missing).
    #[arg(long, env = "NEXTPOSE_DB", default_value = "nextpose.db")]
    pub db: PathBuf,
    /// Address to listen on.
    #[arg(long, env = "NEXTPOSE_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: String,
    /// Bearer token required on every route but /healthz (unset: no authentication).
    #[arg(long, env = "NEXTPOSE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// fsync every commit, so acknowledged writes survive a power loss too (slower). Without
    /// it they survive a crash or kill of the process.
    #[arg(long, env = "NEXTPOSE_SYNC_FULL")]
    pub sync_full: bool,
    /// Largest request body accepted, in bytes.
    #[arg(long, default_value_t = 2 * 1024 * 1024)]
    pub body_limit: usize,
    /// Requests taking longer than this many seconds are answered 408.
    #[arg(long, default_value_t = 30)]
    pub request_timeout_s: u64,
    /// Directory of robot models (*.urdf); default: the bundled robots/.
    #[arg(long, env = "NEXTPOSE_ROBOTS")]
    pub robots: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Corpus JSON files or raw program files (RAPID, KRL, FANUC TP; all raw files named are one
    /// upload), or directories of them (all *.json sorted by name; else the raw files as one
    /// upload; else each subdirectory in turn).
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Gate of the gated nearest-sequence baselines: mean squared Mahalanobis distance per
    /// window move.
    #[arg(long, default_value_t = DEFAULT_NEAREST_SEQ_GATE)]
    pub gate: f64,
    /// Also write the full report (every program, every method) as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Print only the totals table (no per-program table).
    #[arg(long)]
    pub quiet: bool,
    /// Also write the plots (offered/useful % vs phi_min, median error vs delta, median error
    /// vs moves assimilated, confidence vs error) into this directory, each as PNG and SVG,
    /// with the plotted numbers in plots.json.
    /// The two sweeps replay the engine 31 more times.
    #[cfg(feature = "plots")]
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Corpus JSON files or raw program files (RAPID, KRL, FANUC TP; all raw files named are one
    /// upload), or directories of them (all *.json sorted by name; else the raw files as one
    /// upload; else each subdirectory in turn).
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    /// Base engine settings; --delta, --phi-min and --horizon are replaced by the grid.
    #[command(flatten)]
    pub engine: EngineArgs,
    #[arg(long, value_delimiter = ',', default_value = "0.3,0.5,0.7,0.9")]
    pub deltas: Vec<f64>,
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.7,0.9")]
    pub phi_mins: Vec<f64>,
    #[arg(long, value_delimiter = ',', default_value = "1,2,3,4")]
    pub horizons: Vec<usize>,
    /// Also write the rows as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
}

/// Engine settings on the command line: a profile, then per-field overrides.
#[derive(Debug, Clone, Args)]
pub struct EngineArgs {
    /// Settings to start from.
    #[arg(long, value_enum, default_value_t = ProfileArg::Default)]
    pub profile: ProfileArg,
    /// Complexity δ in (0, 1]: larger = stricter merging, more states.
    #[arg(long)]
    pub delta: Option<f64>,
    /// Minimum confidence φ for a guess to be offered.
    #[arg(long)]
    pub phi_min: Option<f64>,
    /// Number of most recent moves a guess conditions on (h).
    #[arg(long)]
    pub horizon: Option<usize>,
    /// Estimate the scale ψ at prediction time.
    #[arg(long, value_enum)]
    pub scale: Option<Switch>,
    /// Merge test of the learner.
    #[arg(long, value_enum)]
    pub merge: Option<MergeArg>,
    /// Learn each move as it is taught (on) or only finished routines (off).
    #[arg(long, value_enum)]
    pub within: Option<Switch>,
    /// Misfit gate (number, or "none" for no gate).
    #[arg(long, value_name = "F|none", value_parser = parse_limit)]
    pub max_misfit: Option<Limit>,
    /// Spread gate (number, or "none" for no gate).
    #[arg(long, value_name = "F|none", value_parser = parse_limit)]
    pub max_spread: Option<Limit>,
    /// End-of-routine probability gate (number, or "none" for no gate).
    #[arg(long, value_name = "F|none", value_parser = parse_limit)]
    pub max_end_prob: Option<Limit>,
    /// Recall of the most recent occurrence: "K" or "K:COST" (fewest window moves, mean squared
    /// distance allowed), or "none".
    #[arg(long, value_name = "K[:COST]|none", value_parser = parse_gate)]
    pub recall: Option<GateArg>,
}

/// A recall gate given on the command line, `None` meaning "off".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateArg(pub Option<RecallGate>);

fn parse_gate(s: &str) -> Result<GateArg, String> {
    if s.eq_ignore_ascii_case("none") {
        return Ok(GateArg(None));
    }
    let bad = || format!("expected K, K:COST or \"none\", got {s:?}");
    let (k, cost) = s.split_once(':').unwrap_or((s, "0.1"));
    let min_window = k.parse::<usize>().map_err(|_| bad())?;
    let max_cost = cost.parse::<f64>().map_err(|_| bad())?;
    Ok(GateArg(Some(RecallGate {
        max_cost,
        min_window,
    })))
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    Seed,
    Default,
}

impl From<ProfileArg> for Profile {
    fn from(p: ProfileArg) -> Profile {
        match p {
            ProfileArg::Seed => Profile::Seed,
            ProfileArg::Default => Profile::Default,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    On,
    Off,
}

impl Switch {
    fn on(self) -> bool {
        self == Switch::On
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MergeArg {
    Total,
    Incremental,
}

/// A gate threshold, `None` meaning "no gate".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit(pub Option<f64>);

fn parse_limit(s: &str) -> Result<Limit, String> {
    if s.eq_ignore_ascii_case("none") {
        return Ok(Limit(None));
    }
    s.parse::<f64>()
        .map(|v| Limit(Some(v)))
        .map_err(|_| format!("expected a number or \"none\", got {s:?}"))
}

impl EngineArgs {
    /// The profile's settings with the given overrides, validated.
    pub fn config(&self) -> Result<EngineConfig> {
        let mut c = EngineConfig::profile(self.profile.into());
        if let Some(v) = self.delta {
            c.delta = v;
        }
        if let Some(v) = self.phi_min {
            c.phi_min = v;
        }
        if let Some(v) = self.horizon {
            c.horizon = v;
        }
        if let Some(v) = self.scale {
            c.scale.enabled = v.on();
        }
        if let Some(v) = self.merge {
            c.merge = match v {
                MergeArg::Total => MergeRule::Total,
                MergeArg::Incremental => MergeRule::Incremental,
            };
        }
        if let Some(v) = self.within {
            c.learn_within_routine = v.on();
        }
        if let Some(Limit(v)) = self.max_misfit {
            c.max_misfit = v;
        }
        if let Some(Limit(v)) = self.max_spread {
            c.max_spread = v;
        }
        if let Some(Limit(v)) = self.max_end_prob {
            c.max_end_prob = v;
        }
        if let Some(GateArg(v)) = self.recall {
            c.recall = v;
        }
        c.validate().context("invalid engine settings")?;
        Ok(c)
    }

    fn profile_name(&self) -> &'static str {
        Profile::from(self.profile).name()
    }
}

/// Parses the process arguments and runs the command.
pub fn run() -> Result<()> {
    run_cli(Cli::parse())
}

/// Runs a parsed command line (separate from [`run`] so tests can drive it).
pub fn run_cli(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Replay(args) => run_replay(&args),
        Command::Sweep(args) => run_sweep(&args),
        Command::Serve(args) => run_serve(args),
        Command::Import(args) => run_import(args),
        Command::Simulate(args) => run_simulate(&args),
        Command::Openapi => {
            let yaml = crate::http::openapi()
                .to_yaml()
                .context("rendering the OpenAPI description")?;
            print!("{yaml}");
            Ok(())
        }
    }
}

fn run_import(args: ImportArgs) -> Result<()> {
    let mut files = Vec::with_capacity(args.files.len());
    for path in &args.files {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        files.push(serde_json::json!({
            "name": path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            "content": crate::import::decode_text(&bytes),
        }));
    }
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async move {
        let base = args.server.trim_end_matches('/');
        let client = reqwest::Client::new();
        let auth = |rb: reqwest::RequestBuilder| match &args.token {
            Some(t) => rb.bearer_auth(t),
            None => rb,
        };
        let answer = |r: reqwest::Response| async move {
            let status = r.status();
            let text = r.text().await.context("reading the server's answer")?;
            let body: serde_json::Value = match serde_json::from_str(&text) {
                Ok(v) => v,
                Err(e) if status.is_success() => {
                    bail!("server answered {status} with a body that is not JSON ({e}): {text}")
                }
                Err(_) => bail!("server answered {status}: {text}"),
            };
            if status.is_success() {
                Ok(body)
            } else {
                bail!(
                    "server answered {status}: {}",
                    body["error"]["message"].as_str().unwrap_or(&text)
                )
            }
        };
        let cells = answer(
            auth(client.get(format!("{base}/v1/cells")))
                .send()
                .await
                .with_context(|| format!("connecting to {base}"))?,
        )
        .await?;
        let existing = cells
            .as_array()
            .and_then(|a| a.iter().find(|c| c["name"] == args.cell.as_str()))
            .and_then(|c| c["id"].as_i64());
        let cell = match existing {
            Some(id) => id,
            None => answer(
                auth(client.post(format!("{base}/v1/cells")))
                    .json(&serde_json::json!({ "name": args.cell }))
                    .send()
                    .await?,
            )
            .await?["id"]
                .as_i64()
                .context("the server returned no cell id")?,
        };
        let result = answer(
            auth(client.post(format!("{base}/v1/cells/{cell}/imports")))
                .json(&serde_json::json!({ "files": files, "learn": !args.no_learn }))
                .send()
                .await?,
        )
        .await?;
        for p in result["programs"].as_array().into_iter().flatten() {
            println!(
                "imported {} ({}): {} routines, {} waypoints",
                p["program"]["name"].as_str().unwrap_or("?"),
                p["language"].as_str().unwrap_or("?"),
                p["routines"],
                p["waypoints"]
            );
        }
        let skipped = result["skipped"].as_array().map(Vec::len).unwrap_or(0);
        for s in result["skipped"].as_array().into_iter().flatten() {
            println!(
                "skipped {}:{} ({}): {}",
                s["file"].as_str().unwrap_or("?"),
                s["line"],
                s["reason"].as_str().unwrap_or("?"),
                s["text"].as_str().unwrap_or("")
            );
        }
        println!(
            "cell {:?}: {skipped} skipped; model now {} states, {} routines",
            args.cell, result["model"]["states"], result["model"]["routines"]
        );
        Ok(())
    })
}

fn run_serve(args: ServeArgs) -> Result<()> {
    use crate::server::{Application, Database, ServerSettings, shutdown_signal};
    use crate::storage::Durability;
    use std::io::Write;

    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,sqlx=warn".into()),
        )
        .init();
    let settings = ServerSettings {
        database: Database::File(args.db.clone()),
        durability: if args.sync_full {
            Durability::Full
        } else {
            Durability::Process
        },
        addr: args.addr.clone(),
        http: crate::transport::TransportOptions {
            body_limit: args.body_limit,
            request_timeout: std::time::Duration::from_secs(args.request_timeout_s.max(1)),
            token: args.token.clone(),
        },
        robots: args
            .robots
            .clone()
            .unwrap_or_else(crate::kinematics::bundled_robots_dir),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async move {
        let application = Application::build(settings).await?;
        let addr = application.local_addr()?;
        // Tests and scripts read this line to find the port.
        println!(
            "nextpose listening on http://{addr} (database {})",
            args.db.display()
        );
        std::io::stdout().flush().ok();
        tracing::info!(%addr, db = %args.db.display(), "serving");
        application.run_until_stopped(shutdown_signal()).await?;
        Ok(())
    })
}

fn run_replay(args: &ReplayArgs) -> Result<()> {
    let config = args.engine.config()?;
    if !(args.gate.is_finite() && args.gate >= 0.0) {
        bail!("--gate must be finite and non-negative, got {}", args.gate);
    }
    let programs = load_paths(&args.paths)?;
    let mut methods: Vec<Box<dyn Method>> = vec![Box::new(
        EngineMethod::new(config.clone()).context("invalid engine settings")?,
    )];
    methods.extend(baselines::scoreboard(&config, args.gate));
    let run_config = RunConfig::new(args.engine.profile_name(), config.clone(), args.gate);
    let mut report = replay_all(&programs, &mut methods, run_config)
        .context("loading the arm of the reachability figures")?;
    report.add_oracles(&programs);

    let mut out = std::io::stdout().lock();
    if !args.quiet {
        writeln!(out, "{}", report.program_table("engine"))?;
    }
    write!(out, "{}", report.totals_table())?;
    if let Some(path) = &args.json {
        write_json(path, &report)?;
    }
    #[cfg(feature = "plots")]
    if let Some(dir) = &args.plots {
        let data = plot_data(
            &programs,
            args.engine.profile_name(),
            &config,
            &PlotGrid::default(),
        )
        .context("invalid plot sweep settings")?;
        let written = write_plots(dir, &data)?;
        writeln!(
            out,
            "wrote {} plot files to {}",
            written.len(),
            dir.display()
        )?;
    }
    Ok(())
}

/// The sweep's JSON file: the base settings and one row per combination.
#[derive(Serialize)]
struct SweepReport<'a> {
    profile: &'a str,
    base: &'a EngineConfig,
    rows: &'a [crate::replay::SweepRow],
}

fn run_sweep(args: &SweepArgs) -> Result<()> {
    let base = args.engine.config()?;
    for (name, empty) in [
        ("--deltas", args.deltas.is_empty()),
        ("--phi-mins", args.phi_mins.is_empty()),
        ("--horizons", args.horizons.is_empty()),
    ] {
        if empty {
            bail!("{name} needs at least one value");
        }
    }
    let programs = load_paths(&args.paths)?;
    let rows = sweep(
        &programs,
        &base,
        &args.deltas,
        &args.phi_mins,
        &args.horizons,
    )
    .context("invalid sweep settings")?;
    write!(std::io::stdout().lock(), "{}", sweep_table(&rows))?;
    if let Some(path) = &args.json {
        let report = SweepReport {
            profile: args.engine.profile_name(),
            base: &base,
            rows: &rows,
        };
        write_json(path, &report)?;
    }
    Ok(())
}

fn run_simulate(args: &SimulateArgs) -> Result<()> {
    use crate::sim::{self, History, JogLimits, OperatorModel, Plan};
    use crate::simulate::{Driver, LocalServer, Transport, run_experiment};

    if args.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    let mut programs = load_paths(&args.paths)?;
    if let Some(n) = args.programs {
        programs.truncate(n);
    }
    programs.retain(|p| p.waypoint_count() > 0);
    if programs.is_empty() {
        bail!("no programs with waypoints to simulate");
    }
    let limits = JogLimits::default();
    let plan = Plan {
        conditions: sim::table_4_1_conditions(),
        seeds: (1..=args.seeds).collect(),
        operator: match args.operator {
            OperatorArg::Online => OperatorModel::online(limits.tcp_mm_s),
            OperatorArg::Precise => OperatorModel::precise(limits.tcp_mm_s),
        },
        limits,
        history: match args.history {
            HistoryArg::None => History::None,
            HistoryArg::Repository => History::Repository,
        },
        reach_policy: match args.reach_policy {
            ReachPolicyArg::Withhold => crate::kinematics::ReachPolicy::Withhold,
            ReachPolicyArg::Flag => crate::kinematics::ReachPolicy::Flag,
        },
        calibrate_sigma: !args.profile_sigmas,
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let experiment = runtime.block_on(async {
        let local = match &args.server {
            Some(_) => None,
            None => Some(LocalServer::start().await?),
        };
        let base = match (&args.server, &local) {
            (Some(url), _) => url.clone(),
            (None, Some(l)) => l.base.clone(),
            (None, None) => bail!("no server"),
        };
        let transport = match args.transport {
            TransportArg::Rest => Transport::Rest,
            TransportArg::Grpc => Transport::Grpc,
        };
        let sessions = plan.conditions.len() * plan.seeds.len() * programs.len();
        eprintln!(
            "simulating {} programs x {} seeds x {} conditions ({sessions} sessions) against {base} over {}",
            programs.len(),
            plan.seeds.len(),
            plan.conditions.len(),
            match transport {
                Transport::Rest => "REST",
                Transport::Grpc => "gRPC",
            }
        );
        let result = async {
            let client = Driver::connect(transport, &base, args.token.clone()).await?;
            run_experiment(&client, &plan, &programs, args.jobs, |done, total| {
                if done % 20 == 0 || done == total {
                    eprintln!("  {done}/{total} sessions");
                }
            })
            .await
        }
        .await;
        if let Some(l) = local {
            l.stop().await?;
        }
        result
    })?;
    let mut text = String::new();
    text.push_str(&format!(
        "Programming time per routine: {} programs, {} routines, seeds 1..={}, operator {}, history {:?}\n\n",
        programs.len(),
        programs.iter().map(|p| p.routines.len()).sum::<usize>(),
        args.seeds,
        plan.operator.name,
        plan.history
    ));
    text.push_str(&sim::markdown(&experiment.summary));
    let taught: usize = experiment.summary.first().map(|r| r.waypoints).unwrap_or(0);
    let unreachable = experiment
        .summary
        .first()
        .map(|r| r.unreachable_waypoints)
        .unwrap_or(0);
    text.push_str(&format!(
        "\nTaught waypoints outside the arm's reach as placed (baseline): {unreachable} of {taught}; \
         offered suggestions out of reach: {}.\n",
        experiment
            .summary
            .iter()
            .map(|r| r.offered_unreachable)
            .sum::<usize>()
    ));
    text.push_str("\nMean time per routine by component:\n\n");
    text.push_str(&sim::breakdown_markdown(&experiment.summary));
    print!("{text}");
    if let Some(path) = &args.markdown {
        std::fs::write(path, &text).with_context(|| format!("{}: cannot write", path.display()))?;
    }
    if let Some(path) = &args.json {
        write_json(path, &experiment)?;
    }
    if let Some(path) = &args.svg {
        let title = format!(
            "Change in programming time per routine vs no suggestions ({} operator)",
            plan.operator.name
        );
        std::fs::write(path, sim::change_chart_svg(&experiment.summary, &title))
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(())
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let file = File::create(path).with_context(|| format!("{}: cannot create", path.display()))?;
    let mut w = BufWriter::new(file);
    serde_json::to_writer_pretty(&mut w, value)
        .with_context(|| format!("{}: cannot write JSON", path.display()))?;
    writeln!(w)
        .and_then(|()| w.flush())
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Cli {
        Cli::try_parse_from(args).unwrap()
    }

    #[test]
    fn overrides_apply_on_top_of_the_profile() {
        let cli = parse(&[
            "nextpose",
            "replay",
            "x.json",
            "--profile",
            "seed",
            "--delta",
            "0.5",
            "--within",
            "on",
            "--max-misfit",
            "2.5",
            "--max-end-prob",
            "none",
            "--scale",
            "off",
        ]);
        let Command::Replay(args) = cli.command else {
            panic!("not replay")
        };
        let c = args.engine.config().unwrap();
        assert_eq!(c.delta, 0.5);
        assert!(c.learn_within_routine);
        assert_eq!(c.max_misfit, Some(2.5));
        assert_eq!(c.max_end_prob, None);
        assert!(!c.scale.enabled);
        assert_eq!(c.merge, MergeRule::Total);
    }

    #[test]
    fn invalid_values_are_errors_not_panics() {
        let cli = parse(&["nextpose", "replay", "x.json", "--delta", "1.5"]);
        let err = run_cli(cli).unwrap_err();
        assert!(format!("{err:#}").contains("delta"), "{err:#}");
        assert!(
            Cli::try_parse_from(["nextpose", "replay", "x.json", "--max-spread", "lots"]).is_err()
        );
        let cli = parse(&["nextpose", "sweep", "x.json", "--horizons", "1,0"]);
        let err = run_cli(cli).unwrap_err();
        assert!(format!("{err:#}").contains("x.json"), "{err:#}");
    }
}
