//! `nextpose simulate`: simulated operators teach corpus programs against the service and the
//! programming-time table is printed (the shape of the dissertation's Table 4.1).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};

use super::write_json;
use crate::replay::load_paths;

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
    /// The online operator's 3-D RMS placement error instead of the seed's 20 mm (with
    /// `--operator online`; the rotation error in proportion, the tolerance half the effective
    /// width): to check settings against steadier or shakier operators (5–30 mm).
    #[arg(long, value_name = "MM")]
    pub operator_mm: Option<f64>,
    /// What the cell knows before teaching: nothing; the earlier programs (in the order given)
    /// of the same repository, taught exactly (offline programs); or those programs as online
    /// operators taught them, each waypoint with the operator's placement error (the seed's
    /// lab: `nextpose lab` writes the intended programs).
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
    RepositoryOnline,
}

pub(super) fn run_simulate(args: &SimulateArgs) -> Result<()> {
    use crate::client::{Client, Transport};
    use crate::simulation::{self, History, JogLimits, OperatorModel, Plan};
    use crate::simulation_driver::{LocalServer, run_experiment};

    if args.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    if let Some(mm) = args.operator_mm
        && !(mm.is_finite() && (0.1..=200.0).contains(&mm))
    {
        bail!("--operator-mm must be between 0.1 and 200 mm, not {mm}");
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
        conditions: simulation::table_4_1_conditions(),
        seeds: (1..=args.seeds).collect(),
        operator: match (args.operator, args.operator_mm) {
            (OperatorArg::Online, None) => OperatorModel::online(limits.tcp_mm_s),
            (OperatorArg::Online, Some(mm)) => OperatorModel::online_at(limits.tcp_mm_s, mm),
            (OperatorArg::Precise, None) => OperatorModel::precise(limits.tcp_mm_s),
            (OperatorArg::Precise, Some(_)) => {
                bail!(
                    "--operator-mm sets the online operator's error; use it with --operator online"
                )
            }
        },
        limits,
        history: match args.history {
            HistoryArg::None => History::None,
            HistoryArg::Repository => History::Repository,
            HistoryArg::RepositoryOnline => History::RepositoryOnline,
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
            let client = Client::connect(transport, &base, args.token.clone()).await?;
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
    text.push_str(&simulation::markdown(&experiment.summary));
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
    text.push_str("\nThe arms, where they stand, and the taught waypoints they reach:\n\n");
    text.push_str(&simulation::arms_markdown(
        &experiment.programs,
        &experiment.arms,
    ));
    text.push_str("\nMean time per routine by component:\n\n");
    text.push_str(&simulation::breakdown_markdown(&experiment.summary));
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
        std::fs::write(
            path,
            simulation::change_chart_svg(&experiment.summary, &title),
        )
        .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(())
}
