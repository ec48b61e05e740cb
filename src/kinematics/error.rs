//! Typed errors of the kinematics module. Adapters map them to HTTP/gRPC statuses once, at the edge.

use thiserror::Error;

/// A robot description that cannot be loaded or used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum KinematicsError {
    #[error("cannot read {path}: {message}")]
    Io { path: String, message: String },
    #[error("malformed URDF: {0}")]
    Urdf(String),
    #[error("joint {joint:?} refers to unknown link {link:?}")]
    UnknownLink { joint: String, link: String },
    #[error("URDF has no root link (every link is some joint's child)")]
    NoRoot,
    #[error("URDF has several root links: {0:?}")]
    SeveralRoots(Vec<String>),
    #[error("link {0:?} is the child of more than one joint")]
    SeveralParents(String),
    #[error("not a serial chain: link {link:?} has {children} moving branches")]
    NotSerial { link: String, children: usize },
    #[error("tip link {0:?} not found below the root")]
    UnknownTip(String),
    #[error("expected {expected} revolute joints between {root:?} and {tip:?}, found {found}")]
    JointCount {
        expected: usize,
        found: usize,
        root: String,
        tip: String,
    },
    #[error("joint {joint:?} has type {kind}, which the solvers do not support")]
    UnsupportedJointType { joint: String, kind: String },
    #[error("joint {joint:?} has a zero or non-finite axis")]
    BadAxis { joint: String },
    #[error("joint {joint:?} has no usable limits (lower {lower}, upper {upper})")]
    BadLimits {
        joint: String,
        lower: f64,
        upper: f64,
    },
    #[error("joint {joint:?} has a non-finite origin")]
    BadOrigin { joint: String },
    #[error("no closed-form solver fits this arm: {0}")]
    UnsupportedGeometry(String),
    #[error("joint values must be finite")]
    NonFiniteJoints,
    /// A joint vector the arm cannot take (see [`super::Robot::check_joints`]).
    #[error(
        "joint {joint} ({name}) is {} rad, outside its range {} to {} rad",
        rad(*.value),
        rad(*.lower),
        rad(*.upper)
    )]
    JointOutOfRange {
        /// 1-based.
        joint: usize,
        name: String,
        value: f64,
        lower: f64,
        upper: f64,
    },
    #[error("unknown robot {0:?}")]
    UnknownRobot(String),
    #[error("malformed robot catalogue {path}: {message}")]
    Catalog { path: String, message: String },
}

/// A joint value for a message: a few decimals, or a mantissa and exponent when it is huge.
fn rad(v: f64) -> String {
    if v.abs() < 1e6 {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

impl KinematicsError {
    pub(crate) fn io(path: &std::path::Path, err: &std::io::Error) -> KinematicsError {
        KinematicsError::Io {
            path: path.display().to_string(),
            message: err.to_string(),
        }
    }
}
