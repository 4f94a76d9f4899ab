//! The virtual fabric lab: the standard physical tests a fabric kit runs,
//! done on the simulator, so a preset can be checked against measured fabric
//! and fitted to it (what Marvelous Designer's Fabric Kit does with a
//! physical kit).
//!
//! * [`cantilever`]: ASTM D1388 (option A, the Peirce cantilever): bending
//!   length and flexural rigidity.
//! * [`cusick`]: the Cusick drape test (BS EN ISO 9073-9): drape coefficient
//!   and node count of a 30 cm specimen on an 18 cm disc.
//! * [`elastica`]: the exact strip the cantilever test is read with.
//! * [`fit`]: bend and shear parameters from measured bending length and drape
//!   coefficient.
//! * [`report`]: the figures next to a preset's targets.

pub mod cantilever;
pub mod cusick;
pub mod elastica;
pub mod fit;
pub mod report;
pub mod shadow;

use nalgebra::Vector3;

use crate::mesh::TriMesh;
use crate::sim::colliders::Collider;
use crate::sim::collision::CollisionSettings;
use crate::sim::fabric::{Fabric, FabricError};
use crate::sim::pcg::{PcgSettings, PreconditionerKind};
use crate::sim::step::{Settings, SimError, StepError};
use crate::sim::{Pin, PinTarget, Simulator};

/// Air damping the lab adds while a specimen settles, 1/s. It removes motion
/// only, so the rest shape it settles into is the fabric's own.
const SETTLING_AIR_DAMPING_PER_S: f64 = 10.0;

/// Why a virtual test could not run.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// A parameter of the fabric is out of range.
    #[error("fabric: {0}")]
    Fabric(#[from] FabricError),
    /// The tests hang cloth under gravity.
    #[error("the fabric's gravity is zero: the cantilever and drape tests hang the cloth under its weight")]
    NoGravity,
    /// The specimen could not be simulated.
    #[error("the specimen could not be simulated: {0}")]
    Sim(#[from] SimError),
    /// The simulation failed.
    #[error("the specimen's simulation failed: {0}")]
    Step(#[from] StepError),
    /// A fit target is outside what the parameters can reach.
    #[error("{0}")]
    Unreachable(String),
    /// A target value is not a positive finite number.
    #[error("{what} = {value} is out of range: {expected}")]
    Target {
        /// The target's name with its unit.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The accepted range.
        expected: &'static str,
    },
}

/// A specimen at rest: where it settled and how long that took.
#[derive(Clone, Debug)]
pub struct Settled {
    /// Particle positions at rest, m.
    pub positions: Vec<Vector3<f64>>,
    /// Simulated time to come to rest, s.
    pub time_s: f64,
    /// Fastest particle at the end, m/s: below [`Specimen::rest_speed`] when
    /// the specimen came to rest within its time limit.
    pub max_speed: f64,
}

impl Settled {
    /// Whether the specimen came to rest before the time limit.
    pub fn at_rest(&self, specimen: &Specimen) -> bool {
        self.max_speed < specimen.rest_speed
    }
}

/// A test specimen: a cloth mesh cut from the fabric, held and hung.
pub struct Specimen {
    /// The cloth, in place.
    pub mesh: TriMesh,
    /// Vertices held fixed (the clamp).
    pub clamped: Vec<u32>,
    /// Solid supports.
    pub colliders: Vec<Collider>,
    /// Whether the cloth collides with itself.
    pub self_collision: bool,
    /// Step length, s.
    pub step_s: f64,
    /// The specimen is at rest when no particle moves faster, m/s.
    pub rest_speed: f64,
    /// It must stay that slow for this long (a swing passes through rest at
    /// its turning points), s.
    pub quiet_s: f64,
    /// It is not simulated for longer than this, s.
    pub max_time_s: f64,
}

/// Weight per area of `fabric`, N/m² (area density times |g|).
pub fn weight_per_area(fabric: &Fabric) -> Result<f64, LabError> {
    fabric.validate()?;
    let g = Vector3::from(fabric.gravity_m_per_s2).norm();
    if g == 0.0 {
        return Err(LabError::NoGravity);
    }
    Ok(fabric.area_density_kg_per_m2 * g)
}

/// `fabric` as the lab hangs it: gravity straight down (−Y) at its own
/// magnitude, extra air damping so it settles sooner.
fn lab_fabric(fabric: &Fabric) -> Fabric {
    let g = Vector3::from(fabric.gravity_m_per_s2).norm();
    Fabric {
        gravity_m_per_s2: [0.0, -g, 0.0],
        air_damping_per_s: fabric.air_damping_per_s.max(SETTLING_AIR_DAMPING_PER_S),
        ..fabric.clone()
    }
}

/// Simulates `specimen` of `fabric` from flat until it comes to rest (or its
/// time limit passes).
pub fn settle(specimen: &Specimen, fabric: &Fabric) -> Result<Settled, LabError> {
    weight_per_area(fabric)?;
    let cloth = crate::sim::cloth::Cloth::new([(&specimen.mesh, lab_fabric(fabric))]);
    let pins = specimen.clamped.iter().map(|&vertex| Pin { vertex, target: PinTarget::Still }).collect();
    let settings = Settings {
        solver: PcgSettings { tolerance: 1e-12, max_iterations: 2000, preconditioner: PreconditionerKind::default() },
        collision: CollisionSettings::default(),
        self_collision: vec![specimen.self_collision],
        strain_limiting: Default::default(),
    };
    let mut simulator = Simulator::new(cloth, pins, specimen.colliders.clone(), Vec::new(), settings)?;
    // Settling starts from rest: let it fall for a while before judging.
    let min_time = 0.25 * specimen.max_time_s.min(1.0);
    let mut quiet_since = None;
    loop {
        simulator.step(specimen.step_s)?;
        let max_speed = simulator.velocities().iter().map(|v| v.norm()).fold(0.0, f64::max);
        let time_s = simulator.time();
        quiet_since = if max_speed < specimen.rest_speed { quiet_since.or(Some(time_s)) } else { None };
        let quiet = quiet_since.is_some_and(|since| time_s - since >= specimen.quiet_s);
        if time_s >= specimen.max_time_s || (time_s >= min_time && quiet) {
            return Ok(Settled { positions: simulator.positions().to_vec(), time_s, max_speed });
        }
    }
}
