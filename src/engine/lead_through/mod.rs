//! Lead-through teaching (dissertation chapter 5): the operator guides the arm by hand and the
//! recorded trajectory, not a list of waypoints, is what arrives.
//!
//! [`segment`] thins the samples and cuts the trajectory where its direction turns into a
//! sequence of simple trajectories, each fitted by [`lds`] as one linear dynamical system that
//! converges to its attractor; the attractors are the waypoints, which the cell then learns like
//! taught ones, and the systems in turn reproduce the path (how far it lies from the recording
//! says how well the cut fits).

pub mod lds;
pub mod segment;
