//! Playback: one recorded program through one [`Method`], exactly as an operator would have
//! taught it (ALGORITHM §5, dissertation §4.3.1), keeping one [`WaypointRecord`] per waypoint that
//! had a predecessor.
//!
//! The records are kept raw, so that the figures ([`super::score`]) can pool them over waypoints
//! and pick their own population. What a record says about a guess is judged here once, at the
//! scoreboard's tolerance: *useful* means the operator could accept the guess as taught, within
//! [`USEFUL_MAX_MM`] and [`USEFUL_MAX_RAD`] (arc-welding tolerance).

use std::time::Instant;

use super::corpus::Program;
use super::method::{Method, ModelSummary, Proposal};

/// A guess is useful when its position error is at most this (mm)...
pub const USEFUL_MAX_MM: f64 = 1.0;
/// ...and its orientation error at most this (rad).
pub const USEFUL_MAX_RAD: f64 = 0.1;

/// One predicted waypoint `w[n]` (`n ≥ 1`) of one routine.
#[derive(Debug, Clone, PartialEq)]
pub struct WaypointRecord {
    /// Routine index in the program.
    pub routine: usize,
    /// Number of waypoints taught before this one in its routine (`n`).
    pub predecessors: usize,
    /// Whether the method offered a guess.
    pub offered: bool,
    /// Position error of the guess, mm (offered only).
    pub cart_mm: Option<f64>,
    /// Geodesic orientation error of the guess, rad (offered only).
    pub angle_rad: Option<f64>,
    /// Distance actually travelled from `w[n-1]` to `w[n]`, mm.
    pub travel_mm: f64,
    /// Angle actually turned from `w[n-1]` to `w[n]`, rad.
    pub travel_rad: f64,
    /// The method's own confidence figure (higher = more sure), when it has one.
    pub confidence: Option<f64>,
    /// Engine only: φ.
    pub phi: Option<f64>,
    /// Engine only: ψ̂.
    pub psi: Option<f64>,
    /// Moves the method's model had assimilated when it made this prediction, all routines of
    /// the program so far (`None` for methods without a model). The x axis of the learning curve.
    pub assimilated: Option<u64>,
    /// Wall-clock time of `predict` + `observe` for this waypoint, µs. Measured, never asserted.
    pub micros: f64,
    /// The method's best candidate with its `p_useful`, offered or not (engine under the
    /// experts' offer rule only; see [`super::score::reliability`]).
    pub candidate: Option<CandidateRecord>,
}

/// A candidate's calibrated probability and how far it was from the waypoint then taught.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateRecord {
    pub p_useful: f64,
    pub cart_mm: f64,
    pub angle_rad: f64,
}

impl CandidateRecord {
    /// Within [`USEFUL_MAX_MM`] and [`USEFUL_MAX_RAD`] of the truth (offered or not).
    pub fn useful(&self) -> bool {
        self.cart_mm <= USEFUL_MAX_MM && self.angle_rad <= USEFUL_MAX_RAD
    }
}

impl WaypointRecord {
    /// Offered, within [`USEFUL_MAX_MM`] and [`USEFUL_MAX_RAD`].
    pub fn useful(&self) -> bool {
        self.offered
            && self.cart_mm.is_some_and(|e| e <= USEFUL_MAX_MM)
            && self.angle_rad.is_some_and(|e| e <= USEFUL_MAX_RAD)
    }
}

/// Everything one method did on one program.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramRecord {
    pub program: String,
    pub language: String,
    pub method: String,
    pub waypoints: Vec<WaypointRecord>,
    /// The method's model size after the whole program.
    pub summary: Option<ModelSummary>,
}

/// Replays one program through `method` (ALGORITHM §5), in the call order documented on
/// [`Method`]: `reset`; per routine, for each `n ≥ 1` `predict(&w[..n])` then `observe(&w[..=n])`
/// (and `observe(&w[..1])` for the first waypoint); `finish_routine(&w)` at the end.
pub fn replay_program(program: &Program, method: &mut dyn Method) -> ProgramRecord {
    method.reset();
    let mut waypoints = Vec::new();
    for (routine_index, routine) in program.routines.iter().enumerate() {
        let w = &routine.waypoints;
        for n in 0..w.len() {
            if n == 0 {
                method.observe(&w[..1]);
                continue;
            }
            let assimilated = method.summary().map(|s| s.observations);
            let start = Instant::now();
            let Proposal { guess, candidate } = method.propose(&w[..n]);
            method.observe(&w[..=n]);
            let micros = start.elapsed().as_secs_f64() * 1e6;
            let (prev, truth) = (&w[n - 1], &w[n]);
            waypoints.push(WaypointRecord {
                routine: routine_index,
                predecessors: n,
                offered: guess.is_some(),
                cart_mm: guess.as_ref().map(|g| g.pose.distance_to(truth)),
                angle_rad: guess.as_ref().map(|g| g.pose.angle_to(truth)),
                travel_mm: prev.distance_to(truth),
                travel_rad: prev.angle_to(truth),
                confidence: guess.as_ref().and_then(|g| g.confidence),
                phi: guess.as_ref().and_then(|g| g.phi),
                psi: guess.as_ref().and_then(|g| g.psi),
                assimilated,
                micros,
                candidate: candidate.map(|c| CandidateRecord {
                    p_useful: c.p_useful,
                    cart_mm: c.pose.distance_to(truth),
                    angle_rad: c.pose.angle_to(truth),
                }),
            });
        }
        method.finish_routine(w);
    }
    ProgramRecord {
        program: program.name.clone(),
        language: program.language_name().to_string(),
        method: method.name().to_string(),
        waypoints,
        summary: method.summary(),
    }
}
