//! The experts and the calibrated offer rule (the `default` profile's `offer`): besides the
//! CDHMM, simpler readers of the same history propose the next waypoint, and each proposal is
//! offered by the probability that it is right rather than by its proposer's own gates.
//!
//! Every expert is an [`Expert`]: it learns from each finished routine, proposes candidates for
//! the routine being taught (none, one or several, each a [`Candidate`] with its typed
//! [`Evidence`]), and takes back what a taught waypoint changed of it. The [`super::Teacher`]
//! holds them as one list ([`experts`]), asks each in turn, and hands every candidate, the
//! CDHMM's own among them ([`Proposer::Model`]), to the one offer rule.
//!
//! In the order a taught waypoint meets them: [`frames`] reads a routine three ways (tool-frame
//! moves, work-frame moves, absolute poses), and the [`sequence`] experts (one per frame) keep
//! the finished routines in their frame; [`noise`] widens the cell's tolerance by its teaching
//! noise, so contexts of noisy waypoints still match; [`template`], in a noisy cell only, fits
//! one rigid transform to the last few waypoints and an earlier stretch of the same shape;
//! [`lattice`] proposes the next point of a row or a grid the routine walks, the station its
//! items return to and the move that followed the same role. [`calibration`] turns each
//! candidate's evidence into `p_useful`, and learns from every waypoint taught whether each
//! candidate would have been right; [`acceptance`] reads the operator's verdicts on what was
//! offered (a rejection counts as wrong, adjustments tighten the tolerance).
//!
//! **Adding an expert**: a file with a type that implements [`Expert`], a variant of
//! [`Evidence`] for what its candidates rest on (and of [`Proposer`], its name in predictions),
//! and one line in [`experts`]; the calibration classes the new evidence
//! (`calibration::Coarse::of`).

pub mod acceptance;
pub mod agreement;
mod agreement_weights;
pub mod alignment;
pub mod calibration;
pub mod frames;
pub mod lattice;
pub mod noise;
pub mod sequence;
pub mod template;

use serde::{Deserialize, Serialize};

use crate::engine::pose::Pose;
use frames::{Frame, Tolerance};
use noise::Noise;

/// One expert: a reader of the cell's routines that proposes the next waypoint.
///
/// The [`super::Teacher`] calls [`Expert::learn`] with every finished routine,
/// [`Expert::taught`] after every waypoint taught and [`Expert::undo`] when that waypoint is
/// taken back (an expert that changes nothing while a routine is taught keeps the defaults),
/// and [`Expert::propose`] whenever the routine being taught changed, or a completion or a
/// prediction with other settings extends it hypothetically (so a proposal reads the routine
/// it is given, never one of its own).
pub trait Expert: ExpertClone + std::fmt::Debug + Send + Sync {
    /// Remembers a finished routine (any length, empty included: the experts' histories stay
    /// aligned with the cell's routines).
    fn learn(&mut self, routine: &[Pose]);

    /// The candidates for the waypoint after `routine` (not empty) in a cell as `cell` says,
    /// in the order the offer rule is to meet them (the first of equals wins).
    fn propose(&self, routine: &[Pose], cell: &Cell) -> Vec<Candidate>;

    /// A waypoint was taught: `routine` is the routine being taught, ending with it.
    fn taught(&mut self, _routine: &[Pose]) {}

    /// Takes back what [`Expert::taught`] changed for the newest waypoint.
    fn undo(&mut self) {}
}

/// Lets a list of boxed experts be cloned with the [`super::Teacher`] that holds it.
pub trait ExpertClone {
    fn clone_box(&self) -> Box<dyn Expert>;
}

impl<T: Expert + Clone + 'static> ExpertClone for T {
    fn clone_box(&self) -> Box<dyn Expert> {
        Box::new(self.clone())
    }
}

impl Clone for Box<dyn Expert> {
    fn clone(&self) -> Box<dyn Expert> {
        self.clone_box()
    }
}

/// The experts of a cell, in the order they are asked: the sequence experts (tool, work,
/// absolute), the template expert, the lattice expert.
pub fn experts() -> Vec<Box<dyn Expert>> {
    vec![
        Box::new(sequence::SequenceExpert::new(Frame::Tool)),
        Box::new(sequence::SequenceExpert::new(Frame::Work)),
        Box::new(sequence::SequenceExpert::new(Frame::Absolute)),
        Box::new(template::TemplateExpert::new()),
        Box::new(lattice::LatticeExpert::new()),
    ]
}

/// What an expert is told of the cell when asked for candidates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// The cell's teaching noise: set, or learned so far.
    pub noise: Noise,
    /// What counts as right.
    pub tolerance: Tolerance,
    /// The noise matters: it widens the tolerance (a cell taught by hand).
    pub noisy: bool,
}

impl Cell {
    /// The cell's tolerance for elements of `frame`, widened by its noise ([`Noise::widen`]).
    pub fn widened(&self, frame: Frame) -> Tolerance {
        self.noise.widen(self.tolerance, frame)
    }
}

/// Who proposed a candidate: the name a prediction reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Proposer {
    /// The CDHMM over tool-frame moves (the dissertation's engine).
    Model,
    /// An earlier tool-frame move after the same context.
    Tool,
    /// An earlier work-frame move after the same context.
    Work,
    /// A return to an earlier absolute pose after the same context.
    Absolute,
    /// An earlier stretch of waypoints placed anew by one rigid transform
    /// ([`template`]).
    Template,
    /// The next point of a row or grid the routine walks ([`lattice`]).
    Lattice,
}

impl Proposer {
    pub const ALL: [Proposer; 6] = [
        Proposer::Model,
        Proposer::Tool,
        Proposer::Work,
        Proposer::Absolute,
        Proposer::Template,
        Proposer::Lattice,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Proposer::Model => "model",
            Proposer::Tool => "tool",
            Proposer::Work => "work",
            Proposer::Absolute => "absolute",
            Proposer::Template => "template",
            Proposer::Lattice => "lattice",
        }
    }

    /// The sequence expert of a frame.
    pub fn of(frame: Frame) -> Proposer {
        match frame {
            Frame::Tool => Proposer::Tool,
            Frame::Work => Proposer::Work,
            Frame::Absolute => Proposer::Absolute,
        }
    }
}

/// What a candidate rests on, per kind of expert.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Evidence {
    /// The CDHMM's own prediction.
    Model {
        /// Moves in the window it conditioned on.
        window: usize,
        /// Its own gates would offer it.
        gated_in: bool,
    },
    /// A sequence expert's: a context of the routine's newest elements that occurred before.
    Sequence {
        /// The frame the context was matched in (which sequence expert).
        frame: Frame,
        /// Elements of context matched.
        context: usize,
        /// Places the context occurred at.
        places: usize,
        /// Of those, the places whose follower agrees with the proposal.
        agreeing: usize,
        /// The most recent place is in the routine being taught.
        in_routine: bool,
    },
    /// The template expert's: earlier stretches aligned with the routine's newest waypoints.
    Template {
        /// Steps aligned (the waypoints aligned less one).
        steps: usize,
        /// Earlier stretches aligned on that many waypoints.
        places: usize,
        /// Of those, the ones whose guess agrees with the best-fitting one's.
        agreeing: usize,
    },
    /// The lattice expert's.
    Lattice(LatticeEvidence),
}

/// What a lattice expert's candidate rests on ([`lattice`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LatticeEvidence {
    /// The next point of a walk.
    Walk {
        /// Points of the walk (up to 8).
        points: usize,
        /// The walk has rows (a grid, or a layer laid like one before); else one row goes on.
        grid: bool,
        /// False for a guess of its own class: a new row only the layer's own rows foretell,
        /// or the second row's way guessed from its first point.
        settled: bool,
    },
    /// The station a role of the routine's items keeps returning to.
    Station {
        /// Its newest visits (up to 8).
        visits: usize,
    },
    /// The move that followed the same role in the items before.
    Follower {
        /// Items that moved alike (up to 8).
        items: usize,
    },
}

impl Evidence {
    /// The expert that proposes on such evidence.
    pub fn proposer(&self) -> Proposer {
        match self {
            Evidence::Model { .. } => Proposer::Model,
            Evidence::Sequence { frame, .. } => Proposer::of(*frame),
            Evidence::Template { .. } => Proposer::Template,
            Evidence::Lattice(_) => Proposer::Lattice,
        }
    }
}

/// A proposal for the next waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub pose: Pose,
    pub evidence: Evidence,
}

impl Candidate {
    /// Who proposed it.
    pub fn proposer(&self) -> Proposer {
        self.evidence.proposer()
    }
}
