//! The simulator's errors: a scene it cannot build, a fabric it cannot
//! take while running, a step it cannot finish.

use super::*;

/// Problems that prevent building a simulator.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SimError {
    /// Nothing to simulate.
    #[error("the scene has no cloth particles")]
    Empty,
    /// An attachment names a mesh collider or triangle that does not exist.
    #[error("particle {vertex} is attached to triangle {triangle} of mesh collider {mesh}, which does not exist")]
    AttachmentOutOfRange {
        /// The attached particle.
        vertex: u32,
        /// The mesh collider index.
        mesh: u32,
        /// The triangle index.
        triangle: u32,
    },
    /// A pin names a particle that does not exist.
    #[error("a pin refers to particle {vertex}, but the cloth has {count} particles")]
    PinOutOfRange {
        /// The pinned index.
        vertex: u32,
        /// Number of particles.
        count: usize,
    },
    /// The linear solver could not analyse the cloth's system.
    #[error(transparent)]
    Solver(#[from] CholeskyError),
}

/// A fabric change that cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TuningError {
    /// No such garment.
    #[error("there is no garment {garment} (the scene has {count})")]
    NoGarment {
        /// The index asked for.
        garment: usize,
        /// Number of garments.
        count: usize,
    },
    /// A parameter out of its range.
    #[error(transparent)]
    Fabric(#[from] FabricError),
}

/// A step that could not be completed.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum StepError {
    /// A position or velocity became NaN or infinite.
    #[error(
        "the simulation became non-finite in the step ending at t = {time:.4} s (particle {particle}); the state before that step is kept"
    )]
    NonFinite {
        /// End time of the failed step, s.
        time: f64,
        /// First offending particle.
        particle: usize,
    },
}
