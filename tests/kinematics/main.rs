//! The arm models (`robots/`) and their kinematics: forward and inverse kinematics against
//! published geometry, singularities, reachability and the model errors (`models`), the
//! library of bundled arms, each checked against its data sheet and, where one exists, an
//! independent model (`library`), and the edge cases an outside check found (`edges`).
//! `helpers` has what they share.

mod edges;
mod helpers;
mod library;
mod models;
