//! The physics: pure, deterministic, no I/O, no GPU, no UI.
//!
//! Plain data in ([`cloth::Cloth`], [`step::Pin`], [`colliders::Collider`],
//! [`fabric::Fabric`]), plain data out (positions, velocities,
//! [`step::StepReport`]). Results are bit-identical at any thread count: every
//! parallel loop writes disjoint outputs and every reduction sums fixed chunks in
//! a fixed order.

pub mod adaptive;
pub mod cholesky;
pub mod cloth;
pub mod colliders;
pub mod collision;
pub mod constraint;
pub mod contact;
pub mod dissection;
pub mod edge_system;
pub mod fabric;
pub mod forces;
pub mod implicit;
pub mod inextensibility;
pub mod limit_edges;
pub mod llt;
pub mod local_error;
pub mod motion;
pub mod multigrid;
pub mod parallel;
pub mod pcg;
pub mod pin_reach;
pub mod repulsion;
pub mod snapshot;
pub mod sparse;
pub mod step;
pub mod supernodal;
#[cfg(test)]
pub(crate) mod test_grid;
pub mod tuning;
pub mod vertex_animation;

pub use step::{Pin, PinTarget, SimError, Simulator, StepError, StepReport};
