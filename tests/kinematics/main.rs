//! The arm models (`robots/`) and their kinematics: forward and inverse kinematics against
//! published geometry, singularities, reachability and the model errors (`models`), and the
//! library of bundled arms, each checked against its data sheet and, where one exists, an
//! independent model (`library`). `helpers` has what both use.

mod helpers;
mod library;
mod models;
