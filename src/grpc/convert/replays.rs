//! Replays: a replay asked for (uploaded files or a stored cell, with engine settings) and its
//! report: the scoreboard of each method in total and per program, the oracles' bounds and the
//! calibration of the offer rule.

use crate::api::ReplayRequest;
use crate::grpc::pb;
use crate::replay::report::{MethodMetrics, OracleSection, Report};
use crate::replay::score::Scores;
use crate::replay::score::reliability::{Calibration, ReliabilityBin, RiskCoveragePoint};

use super::wire::{In, Wire};

/// An empty `files` is "not given" (protobuf cannot tell the two apart), so the application's
/// "files or cell_id" rule decides.
pub fn replay_request(r: pb::ReplayRequest) -> In<ReplayRequest> {
    Ok(ReplayRequest {
        files: (!r.files.is_empty()).then(|| r.files.into_iter().map(Into::into).collect()),
        cell_id: r.cell_id,
        profile: Wire::back(r.profile, "profile")?,
        delta: r.delta,
        phi_min: r.phi_min,
        horizon: Wire::back(r.horizon, "horizon")?,
        scale: r.scale,
    })
}

impl From<Scores> for pb::ReplayMetrics {
    fn from(m: Scores) -> pb::ReplayMetrics {
        let n = |v: usize| v as u64;
        pb::ReplayMetrics {
            predictable: n(m.n2.predictable),
            offered: n(m.n2.offered),
            useful: n(m.n2.useful),
            offered_pct: m.n2.offered_pct,
            useful_pct: m.n2.useful_pct,
            precision_pct: m.n2.precision_pct,
            saved_pct: m.n2.saved_pct,
            median_cart_mm: m.n2.median_cart_mm,
            median_angle_rad: m.n2.median_angle_rad,
            median_cart_pct_travel: m.n2.median_cart_pct_travel,
            median_angle_pct_travel: m.n2.median_angle_pct_travel,
            spearman_conf_err: m.n2.spearman_conf_err,
            pearson_conf_err: m.n2.pearson_conf_err,
            spearman_phi_err: m.n2.spearman_phi_err,
            predictable_n1: n(m.n1.predictable),
            offered_n1: n(m.n1.offered),
            useful_n1: n(m.n1.useful),
            offered_pct_n1: m.n1.offered_pct,
            useful_pct_n1: m.n1.useful_pct,
            precision_pct_n1: m.n1.precision_pct,
            saved_pct_n1: m.n1.saved_pct,
            median_cart_mm_n1: m.n1.median_cart_mm,
            median_angle_rad_n1: m.n1.median_angle_rad,
            spearman_conf_err_n1: m.n1.spearman_conf_err,
            states: m.states.map(n),
            edges: m.edges.map(n),
            perplexity: m.perplexity,
            us_per_waypoint: m.us_per_waypoint,
            reachable_pct: m.reachable_pct,
            taught_reachable_pct: m.taught_reachable_pct,
        }
    }
}

fn method_metrics(m: MethodMetrics) -> Vec<pb::MethodMetrics> {
    m.0.into_iter()
        .map(|(method, metrics)| pb::MethodMetrics {
            method,
            metrics: Some(metrics.into()),
        })
        .collect()
}

impl From<Report> for pb::ReplayReport {
    fn from(r: Report) -> pb::ReplayReport {
        // Serialising plain data into a string does not fail; an empty `json` if it ever did.
        let json = serde_json::to_string(&r.config).unwrap_or_default();
        let c = r.config;
        pb::ReplayReport {
            config: Some(pb::ReplayConfig {
                profile: c.profile,
                delta: c.engine.delta,
                phi_min: c.engine.predict.phi_min,
                horizon: c.engine.predict.horizon as u64,
                scale: c.engine.predict.scale.enabled,
                sigma_t: c.engine.sigma_t,
                sigma_q: c.engine.sigma_q,
                nearest_seq_gate: c.nearest_seq_gate,
                useful_max_mm: c.useful_max_mm,
                useful_max_rad: c.useful_max_rad,
                json,
            }),
            totals: method_metrics(r.totals),
            programs: r
                .programs
                .into_iter()
                .map(|p| pb::ProgramScore {
                    program: p.program,
                    language: p.language,
                    methods: method_metrics(p.methods),
                })
                .collect(),
            oracles: r.oracles.map(Into::into),
            calibration: r
                .calibration
                .0
                .into_iter()
                .map(|(method, c)| calibration_out(method, c))
                .collect(),
        }
    }
}

impl From<OracleSection> for pb::ReplayOracles {
    fn from(o: OracleSection) -> pb::ReplayOracles {
        pb::ReplayOracles {
            meaning: o.meaning.to_string(),
            useful_max_mm: o.useful_max_mm,
            useful_max_rad: o.useful_max_rad,
            kinds: o
                .kinds
                .into_iter()
                .map(|k| pb::OracleBound {
                    name: k.name,
                    candidates: k.candidates,
                    predictable: k.predictable as u64,
                    covered: k.covered as u64,
                    share_pct: k.share_pct,
                    predictable_n1: k.predictable_n1 as u64,
                    covered_n1: k.covered_n1 as u64,
                    share_pct_n1: k.share_pct_n1,
                })
                .collect(),
        }
    }
}

impl From<ReliabilityBin> for pb::ReliabilityBin {
    fn from(b: ReliabilityBin) -> pb::ReliabilityBin {
        pb::ReliabilityBin {
            from: b.from,
            to: b.to,
            candidates: b.candidates as u64,
            useful: b.useful as u64,
            mean_p_useful: b.mean_p_useful,
            observed: b.observed,
            gap: b.gap,
            within_target: b.within_target,
        }
    }
}

impl From<RiskCoveragePoint> for pb::RiskCoveragePoint {
    fn from(p: RiskCoveragePoint) -> pb::RiskCoveragePoint {
        pb::RiskCoveragePoint {
            threshold: p.threshold,
            offered: p.offered as u64,
            useful: p.useful as u64,
            offered_pct: p.offered_pct,
            precision_pct: p.precision_pct,
            useful_pct: p.useful_pct,
            saved_pct: p.saved_pct,
        }
    }
}

fn calibration_out(method: String, c: Calibration) -> pb::MethodCalibration {
    pb::MethodCalibration {
        method,
        meaning: c.meaning.to_string(),
        predictable: c.predictable as u64,
        candidates: c.candidates as u64,
        useful: c.useful as u64,
        offered: c.offered as u64,
        target_gap: c.target_gap,
        bins: c.bins.into_iter().map(Into::into).collect(),
        ece: c.ece,
        max_abs_gap: c.max_abs_gap,
        meets_target: c.meets_target,
        spearman_p_err: c.spearman_p_err,
        as_offered: Some(c.as_offered.into()),
        risk_coverage: c.risk_coverage.into_iter().map(Into::into).collect(),
        target_precision_pct: c.threshold_for_target_precision.target_precision_pct,
        threshold_for_target_precision: c.threshold_for_target_precision.point.map(Into::into),
    }
}
