//! The simulator: cloth state plus one explicit step pipeline.
//!
//! `Simulator::step(h)` runs, in order and each timed:
//!
//! 1. **springs**: every spring's force and system block (parallel);
//! 2. **assembly**: the backward-Euler matrix and right-hand side (parallel);
//! 3. **solve**: filtered PCG for the velocity change. Pins are prescribed;
//!    particles resting on a collider are held to its surface along the normal
//!    and feel Coulomb friction as an implicit tangential damping (μN/|v_T|,
//!    with N from the previous step's constraint impulse). Then detect →
//!    respond passes: particles whose solved path would reach a collider are
//!    constrained to arrive at its surface and, when that moves one by more
//!    than a thickness, the system is solved again, so the whole cloth feels
//!    each new contact within the step. A contact whose impulse pulls instead
//!    of pushing is released for the next step;
//! 4. **constraints**: `x̂ = x + h v`, projected onto the inextensibility
//!    constraints (eq. 6, [`super::inextensibility`]), velocities with it;
//! 5. **collisions**: each particle's path against the analytic colliders,
//!    then the triangle-collision pipeline when the scene needs one. What its
//!    response moves goes through the analytic colliders again before its
//!    next detection, so the step ends on a detection of its final
//!    positions and reports the crossings it found (the safety net,
//!    [`super::adaptive`], rolls such a step back);
//! 6. **finish**: pins placed exactly, finiteness check, the step's local error
//!    estimate ([`super::local_error`]), commit, strain.
//!
//! A step that produces a non-finite value is not committed: the state stays
//! as it was before the step and the error names the time and the particle.
//! Buffers live in a workspace and are reused, so a running simulation does not
//! allocate.

mod checkpoint;
mod collider_paths;
mod errors;
mod report;
mod stages;
mod strain;

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use nalgebra::{Matrix3, Point3, Vector3};
use rayon::prelude::*;

use super::cholesky::CholeskyError;
use super::cloth::{Cloth, SpringKind};
use super::colliders::Collider;
use super::collision::obstacles::{ClothScale, MeshCollider, Obstacles};
use super::collision::{
    ClothState, CollisionMemory, CollisionPipeline, CollisionReport, CollisionSettings, Kinematic, ParticleCollision,
    PassState, ResponseStage, carried_displacement,
};
use super::constraint::Constraint;
use super::contact::{ParticleSurface, StepWindow, SurfaceContact, resolve_particle};
use super::fabric::{Fabric, FabricError};
use super::implicit::{
    AssemblyInput, ParticleCoefficients, SpringCoefficients, SystemBuffers, SystemLayout, assemble, evaluate_springs,
    net_forces,
};
use super::inextensibility::{ProjectedState, ProjectionReport, STRAIN_TOLERANCE, StrainLimiting, StrainLimits};
use super::local_error::LocalError;
use super::motion::Placement;
use super::motion::RigidMotion;
use super::parallel::{self, CHUNK};
use super::pcg::{FilteredSystem, PcgReport, PcgSettings, PcgWorkspace, Preconditioner, SystemChange};
use super::pin_reach::{PinReach, Unreachable};
use super::repulsion::Repulsion;
use super::repulsion::RestingPair;
use super::snapshot::{Snapshot, SnapshotError, from_arrays, to_arrays};
use super::tuning::Ramp;

pub use self::checkpoint::Checkpoint;
use self::collider_paths::{ColliderPaths, collision_pipeline};
pub use self::errors::{SimError, StepError, TuningError};
pub use self::report::{StageTimings, StepReport};

/// No collider (in per-particle collider indices).
const NO_COLLIDER: u32 = u32::MAX;

/// Most solves per step when new contacts keep appearing; contacts still new
/// after the last are handled by the collision stage alone.
const CONTACT_PASSES: u32 = 4;

/// A new contact that moves its particle by less than this fraction of the
/// thickness over the step does not call for another solve: the collision
/// stage puts it on the surface. At half a thickness, `needles` solved again
/// in most steps (14.8 CG iterations a step against 3.9); at one, its bake
/// takes half the time, `drape_table`'s a tenth less, and the error against
/// the 16× reference is unchanged (86a72f4).
const RESOLVE_SHIFT: f64 = 1.0;

/// A particle whose held pushes in one pass (off mesh colliders and props
/// thinner than the cloth's edges, [`PassState::pushed_off`]) sum to a normal shorter
/// than this (unitless: each push counts its unit normal times the particle's
/// share of the contact) was pushed both ways, and is not held between passes.
const PUSH_SUM_MIN: f64 = 1e-6;

/// A particle held by the scene (a constraint of PAPER eq. 1: its position is
/// prescribed, the solve keeps its row fixed).
#[derive(Clone, Debug, PartialEq)]
pub struct Pin {
    /// Particle index.
    pub vertex: u32,
    /// Where it is held.
    pub target: PinTarget,
}

/// Where a pinned particle is held.
#[derive(Clone, Debug, PartialEq)]
pub enum PinTarget {
    /// Fixed where it starts.
    Still,
    /// Its starting position carried by a rigid motion.
    Moving(RigidMotion),
    /// Glued to a point of mesh collider `mesh`: the barycentric `weights` of
    /// its triangle `triangle`, plus `offset_m` in the triangle's own frame,
    /// following the triangle's vertices wherever the mesh takes them (a
    /// waistband on a body, kept where it was fitted off the skin).
    OnMesh {
        /// Index among the simulator's mesh colliders.
        mesh: u32,
        /// Triangle of that mesh.
        triangle: u32,
        /// Barycentric weights of its three corners (non-negative, sum 1).
        weights: [f64; 3],
        /// Offset from that point in the triangle's frame (along its first
        /// edge, across it, along its counter-clockwise normal), m.
        offset_m: Vector3<f64>,
    },
}

/// How a simulation is solved.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The linear solver.
    pub solver: PcgSettings,
    /// The collision pipeline's constants.
    pub collision: CollisionSettings,
    /// Per garment, whether it collides with itself.
    pub self_collision: Vec<bool>,
    /// How strain limits are enforced.
    pub strain_limiting: StrainLimiting,
}

/// A triangle's orthonormal frame as matrix columns: along its first edge,
/// across it in its plane, and its counter-clockwise unit normal (zero columns
/// for a degenerate triangle).
pub fn triangle_frame(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> Matrix3<f64> {
    let along = (b - a).try_normalize(0.0).unwrap_or_else(Vector3::zeros);
    let normal = (b - a).cross(&(c - a)).try_normalize(0.0).unwrap_or_else(Vector3::zeros);
    Matrix3::from_columns(&[along, normal.cross(&along), normal])
}

/// Reusable buffers of a step.
#[derive(Clone, Debug, Default)]
struct Workspace {
    system: SystemBuffers,
    pcg: PcgWorkspace,
    constraints: Vec<Constraint>,
    surface_contacts: Vec<Option<SurfaceContact>>,
    residual: Vec<Vector3<f64>>,
    weight_impulse: Vec<Vector3<f64>>,
    velocity_change: Vec<Vector3<f64>>,
    next_x: Vec<Vector3<f64>>,
    next_v: Vec<Vector3<f64>>,
    /// End positions before a strain projection inside the collision
    /// response, to see which particles it moved.
    before_projection: Vec<Vector3<f64>>,
    /// The step's constraints with the particles the collision response
    /// fixed after impact zones made `Fixed`, for the projections after them.
    frozen_constraints: Vec<Constraint>,
    /// Per particle, the sum of the analytic colliders' normals it was
    /// pushed off along in their last resolve (zero where none touched).
    pushed_by_colliders: Vec<Vector3<f64>>,
    /// The particles the last impulse pass pushed off a mesh collider or a
    /// thin prop, with the unit normal away from it, for the projection
    /// after it.
    holds: Vec<(u32, Vector3<f64>)>,
    contacts: Vec<u32>,
    partials: Vec<f64>,
    /// The positions at the start of a step and their ends predicted from
    /// the start velocities, for the collision pipeline's speculation.
    speculative_start: Vec<Vector3<f64>>,
    predicted_end: Vec<Vector3<f64>>,
    /// The cloth's resting contacts at the step's start and the
    /// repulsions that push them apart in the solve, if the scene has them.
    resting: Vec<RestingPair>,
    repulsion: Option<Repulsion>,
}

/// A cloth simulation: state, parameters, colliders and the step pipeline.
#[derive(Clone, Debug)]
pub struct Simulator {
    cloth: Cloth,
    layout: SystemLayout,
    particles: ParticleCoefficients,
    springs: SpringCoefficients,
    surfaces: Vec<ParticleSurface>,
    stretch_springs: Vec<u32>,
    pins: Vec<Pin>,
    pin_rest: Vec<Vector3<f64>>,
    fixed: Vec<bool>,
    /// Collider each particle rested on at the end of the last step.
    resting_on: Vec<u32>,
    /// Particles whose contact pulled in the last solve: free for one step.
    released: Vec<bool>,
    /// Normal force of each particle's contact in the last solve, N.
    normal_force: Vec<f64>,
    /// Normal impulse each particle took from the colliders since
    /// [`Self::take_contact_impulses`], N·s.
    contact_impulse: Vec<f64>,
    /// The local error estimate of the last step.
    last_step: LocalError,
    colliders: Vec<Collider>,
    /// The mesh colliders particles are glued to (all of them when any is).
    attachment_meshes: Vec<MeshCollider>,
    settings: PcgSettings,
    preconditioner: Preconditioner,
    collision: Option<CollisionPipeline>,
    strain_limits: Option<StrainLimits>,
    strain_limiting: StrainLimiting,
    /// How far apart the pins may be with the limits still reachable (none
    /// without pins or limits): made the first time a frame asks, and again
    /// after a fabric change, so that neither building a simulator nor
    /// dragging a slider pays for its searches.
    pin_reach: OnceLock<Option<PinReach>>,
    /// A change of fabric being blended in.
    ramp: Option<Ramp>,
    x: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    time: f64,
    ws: Workspace,
}

impl Simulator {
    /// A simulator at rest in the cloth's rest shape at time 0, with analytic
    /// `colliders` and triangle-mesh colliders `meshes`.
    pub fn new(
        cloth: Cloth,
        pins: Vec<Pin>,
        colliders: Vec<Collider>,
        meshes: Vec<MeshCollider>,
        settings: Settings,
    ) -> Result<Self, SimError> {
        let n = cloth.vertex_count();
        if n == 0 {
            return Err(SimError::Empty);
        }
        if let Some(pin) = pins.iter().find(|p| p.vertex as usize >= n) {
            return Err(SimError::PinOutOfRange { vertex: pin.vertex, count: n });
        }
        for pin in &pins {
            if let PinTarget::OnMesh { mesh, triangle, .. } = pin.target {
                let exists = meshes.get(mesh as usize).is_some_and(|m| (triangle as usize) < m.triangles.len());
                if !exists {
                    return Err(SimError::AttachmentOutOfRange { vertex: pin.vertex, mesh, triangle });
                }
            }
        }
        let mut fixed = vec![false; n];
        for pin in &pins {
            fixed[pin.vertex as usize] = true;
        }
        let surfaces = (0..n)
            .map(|i| {
                let f = cloth.fabric_of(i);
                ParticleSurface { thickness: f.thickness_m, friction: f.friction }
            })
            .collect();
        let stretch_springs = (0..cloth.spring_count() as u32)
            .filter(|&s| cloth.spring_kind[s as usize] == SpringKind::Stretch)
            .collect();
        let layout = SystemLayout::new(&cloth);
        let preconditioner = Preconditioner::new(
            settings.solver.preconditioner,
            &layout.pattern.all,
            &cloth.spring_ends,
            &cloth.rest_positions,
        )?;
        let collision = collision_pipeline(&cloth, &pins, &colliders, &meshes, &settings);
        let strain_limits = StrainLimits::new(&cloth, settings.strain_limiting);
        let glued = pins.iter().any(|p| matches!(p.target, PinTarget::OnMesh { .. }));
        let attachment_meshes = if glued { meshes } else { Vec::new() };
        Ok(Simulator {
            layout,
            strain_limits,
            strain_limiting: settings.strain_limiting,
            pin_reach: OnceLock::new(),
            ramp: None,
            preconditioner,
            collision,
            particles: ParticleCoefficients::new(&cloth),
            springs: SpringCoefficients::new(&cloth),
            surfaces,
            stretch_springs,
            pin_rest: pins.iter().map(|p| cloth.rest_positions[p.vertex as usize]).collect(),
            pins,
            fixed,
            resting_on: vec![NO_COLLIDER; n],
            released: vec![false; n],
            normal_force: vec![0.0; n],
            contact_impulse: vec![0.0; n],
            last_step: LocalError::default(),
            colliders,
            attachment_meshes,
            settings: settings.solver,
            x: cloth.rest_positions.clone(),
            v: vec![Vector3::zeros(); n],
            time: 0.0,
            cloth,
            ws: Workspace::default(),
        })
    }

    /// Current positions, m.
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.x
    }

    /// Current velocities, m/s.
    pub fn velocities(&self) -> &[Vector3<f64>] {
        &self.v
    }

    /// The normal impulse each particle took from the colliders (resting
    /// on them, pushed off their meshes) since the last call, N·s; the
    /// count starts again from zero.
    pub fn take_contact_impulses(&mut self) -> Vec<f64> {
        let zeros = vec![0.0; self.contact_impulse.len()];
        std::mem::replace(&mut self.contact_impulse, zeros)
    }

    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The local error estimate of the last step (none before the first).
    pub fn last_step(&self) -> LocalError {
        self.last_step
    }

    /// The cloth (topology, masses, fabrics).
    pub fn cloth(&self) -> &Cloth {
        &self.cloth
    }

    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// The pins.
    pub fn pins(&self) -> &[Pin] {
        &self.pins
    }

    /// Total normal force the colliders exerted on the particles resting on
    /// them during the last step, N: the constraint impulses of eq. 14 over
    /// the step duration. A cloth lying still on the ground is carried with
    /// exactly its weight.
    pub fn collider_support(&self) -> f64 {
        self.normal_force.iter().sum()
    }

    /// Kinetic energy ½ Σ m v², J.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.v.iter().zip(&self.particles.mass).map(|(v, m)| m * v.norm_squared()).sum::<f64>()
    }

    /// Force the pins exert on the cloth to hold it as it is now, N: the
    /// negative of the net force (springs, bending, gravity, damping) on the
    /// pinned particles.
    pub fn pin_reaction(&self) -> Vector3<f64> {
        let forces = net_forces(&self.cloth, &self.layout, &self.particles, &self.springs, &self.x, &self.v);
        -self.pins.iter().map(|p| forces[p.vertex as usize]).sum::<Vector3<f64>>()
    }

    /// Gives garment `garment` a new fabric between two steps, with no
    /// rebuild of topology: the mechanical coefficients blend in over the
    /// next [`super::tuning::RAMP_STEPS`] steps ([`super::tuning`]); thickness and friction
    /// apply at once. A change during a ramp starts from where it is.
    pub fn set_fabric(&mut self, garment: usize, fabric: Fabric) -> Result<(), TuningError> {
        let count = self.cloth.garments.len();
        if garment >= count {
            return Err(TuningError::NoGarment { garment, count });
        }
        fabric.validate()?;
        let vertices = self.cloth.garments[garment].vertices.clone();
        for i in vertices {
            self.surfaces[i] = ParticleSurface { thickness: fabric.thickness_m, friction: fabric.friction };
            if let Some(pipeline) = &mut self.collision {
                pipeline.set_surface(i, fabric.thickness_m, fabric.friction);
            }
        }
        self.cloth.set_fabric(garment, fabric);
        if self.strain_limits.is_none() {
            // The first limit of the scene: the constraints start unlimited,
            // so the ramp draws every edge in from its current length.
            self.strain_limits = StrainLimits::new(&self.cloth, self.strain_limiting);
            if let Some(limits) = &mut self.strain_limits {
                limits.set_max_lengths(|_| f64::INFINITY);
            }
        }
        let to_particles = ParticleCoefficients::new(&self.cloth);
        let to_lengths = self.strain_limits.as_ref().map_or_else(Vec::new, |l| l.max_lengths_for(&self.cloth));
        let to = (to_particles, SpringCoefficients::new(&self.cloth), to_lengths);
        self.ramp = Some(Ramp::new(&self.particles, &self.springs, self.strain_limits.as_ref(), &self.x, to));
        self.pin_reach = OnceLock::new();
        Ok(())
    }

    /// The two pins furthest beyond the length the cloth between them may
    /// reach now, when any are: where the strain limits cannot be met
    /// ([`crate::sim::pin_reach`]), whatever the solver does.
    pub fn unreachable_limits(&self) -> Option<Unreachable> {
        let reach =
            self.pin_reach.get_or_init(|| pin_reach(&self.cloth, self.strain_limits.as_ref(), &self.pins, &self.fixed));
        reach.as_ref()?.worst(&self.x, STRAIN_TOLERANCE)
    }

    /// Sets the linear solver's relative tolerance (unitless, 0 < t < 1) from
    /// the next solve on.
    pub fn set_solver_tolerance(&mut self, tolerance: f64) {
        if tolerance > 0.0 && tolerance < 1.0 {
            self.settings.tolerance = tolerance;
        }
    }

    /// Whether the cloth collides with an animated body (a deforming mesh).
    pub fn has_animated_bodies(&self) -> bool {
        self.collision.as_ref().is_some_and(CollisionPipeline::has_animated_bodies)
    }
}

/// The reaches between `pins` under `limits` (none without either).
fn pin_reach(cloth: &Cloth, limits: Option<&StrainLimits>, pins: &[Pin], fixed: &[bool]) -> Option<PinReach> {
    let vertices: Vec<u32> = pins.iter().map(|p| p.vertex).collect();
    limits.filter(|_| !vertices.is_empty()).map(|l| l.pin_reach(cloth, fixed, &vertices))
}
