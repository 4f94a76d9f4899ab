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
use super::repulsion::Repulsion;
use super::repulsion::RestingPair;
use super::snapshot::{Snapshot, SnapshotError, from_arrays, to_arrays};
use super::tuning::Ramp;

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
/// the 16× reference is unchanged (BENCHMARKS.md, 2026-12-04).
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

/// Wall time spent in each stage of a step (or summed over steps).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StageTimings {
    /// Spring forces and blocks.
    pub springs: Duration,
    /// Matrix and right-hand side.
    pub assembly: Duration,
    /// Linear solves (with contact passes). The obstacles' placement,
    /// boxes and hierarchy for the step are made on another thread
    /// meanwhile, and counted nowhere.
    pub solve: Duration,
    /// Inextensibility projection.
    pub constraints: Duration,
    /// Particles against analytic colliders (before the triangle
    /// collisions; their corrections within those count as `response`).
    pub contacts: Duration,
    /// Loading the collision step: the cloth's points, boxes and hierarchy
    /// refits.
    pub refit: Duration,
    /// Collision broad phase.
    pub broad: Duration,
    /// Collision narrow phase.
    pub narrow: Duration,
    /// Collision response (impulses, constraint set, impact zones, and the
    /// strain projection and analytic colliders after each pass).
    pub response: Duration,
    /// Pins, checks, commit, strain.
    pub finish: Duration,
}

impl StageTimings {
    /// Stage names and durations, in pipeline order.
    pub fn stages(&self) -> [(&'static str, Duration); 10] {
        [
            ("springs", self.springs),
            ("assembly", self.assembly),
            ("solve", self.solve),
            ("constraints", self.constraints),
            ("contacts", self.contacts),
            ("refit", self.refit),
            ("broad", self.broad),
            ("narrow", self.narrow),
            ("response", self.response),
            ("finish", self.finish),
        ]
    }

    /// Sum of all stages.
    pub fn total(&self) -> Duration {
        self.stages().iter().map(|(_, d)| *d).sum()
    }

    /// Stage-wise sum.
    pub fn add(&mut self, other: &StageTimings) {
        let fields = [
            (&mut self.springs, other.springs),
            (&mut self.assembly, other.assembly),
            (&mut self.solve, other.solve),
            (&mut self.constraints, other.constraints),
            (&mut self.contacts, other.contacts),
            (&mut self.refit, other.refit),
            (&mut self.broad, other.broad),
            (&mut self.narrow, other.narrow),
            (&mut self.response, other.response),
            (&mut self.finish, other.finish),
        ];
        for (mine, theirs) in fields {
            *mine += theirs;
        }
    }
}

/// What one step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Time per stage.
    pub timings: StageTimings,
    /// Linear solver outcome.
    pub solver: PcgReport,
    /// Largest stretch of a stretch spring after the step, (l − l₀) / l₀
    /// (0 when none is longer than at rest): what a strain limit bounds.
    pub max_strain: f64,
    /// [`Self::max_strain`] over the stretch springs with an end that is not
    /// pinned: what the solver and the strain limits control. A spring
    /// between two pinned particles is as long as its pins make it (a
    /// waistband glued to skin that stretches).
    pub max_free_strain: f64,
    /// Mean stretch-spring strain |l − l₀| / l₀ after the step.
    pub mean_strain: f64,
    /// The inextensibility projection.
    pub projection: ProjectionReport,
    /// Particle-collider contacts handled.
    pub contacts: u32,
    /// Particles held to a collider's surface in the solve.
    pub resting_contacts: u32,
    /// Linear solves run (one, plus one per detect → respond pass that found
    /// new contacts).
    pub solves: u32,
    /// Cholesky factors built for the solves (the factor is kept across steps
    /// until it goes stale).
    pub factorizations: u32,
    /// Triangle collisions (self, meshes, sharp features).
    pub collision: CollisionReport,
    /// Backward Euler's local error estimate of the step.
    pub local_error: LocalError,
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

/// The cloth particles' straight paths over one step, for resolving them
/// against the analytic colliders.
struct ColliderPaths<'a> {
    /// Positions at the start of the step, m.
    start: &'a [Vector3<f64>],
    /// Pinned particles, which no collider moves.
    fixed: &'a [bool],
    surfaces: &'a [ParticleSurface],
    colliders: &'a [Collider],
    window: StepWindow,
}

impl<'a> ColliderPaths<'a> {
    /// The paths from `start` (m) over `window`, pinned particles `fixed`.
    fn new(
        start: &'a [Vector3<f64>],
        fixed: &'a [bool],
        surfaces: &'a [ParticleSurface],
        colliders: &'a [Collider],
        window: StepWindow,
    ) -> Self {
        ColliderPaths { start, fixed, surfaces, colliders, window }
    }

    /// Resolves every free particle `selected` (by index and proposed end)
    /// from its start to its proposed `end` (m, corrected in place with its
    /// `velocity`, m/s) against the analytic colliders, writing its contact
    /// count and the collider it ends resting on. Returns the contacts of the
    /// selected particles and whether any end moved.
    fn resolve(
        &self,
        end: &mut [Vector3<f64>],
        velocity: &mut [Vector3<f64>],
        selected: impl Fn(usize, &Vector3<f64>) -> bool + Sync,
        contacts: &mut [u32],
        resting_on: &mut [u32],
    ) -> (u32, bool) {
        if self.colliders.is_empty() {
            return (0, false);
        }
        end.par_iter_mut()
            .zip(velocity.par_iter_mut())
            .zip(contacts.par_iter_mut().zip(resting_on.par_iter_mut()))
            .enumerate()
            .with_min_len(CHUNK)
            .map(|(i, ((end, velocity), (contacts, resting)))| {
                if !selected(i, end) {
                    return (0, false);
                }
                if self.fixed[i] {
                    (*contacts, *resting) = (0, NO_COLLIDER);
                    return (0, false);
                }
                let proposed = *end;
                let surface = self.surfaces[i];
                let (count, on) = resolve_particle(&self.start[i], end, velocity, surface, self.colliders, self.window);
                (*contacts, *resting) = (count, on.unwrap_or(NO_COLLIDER));
                (count, *end != proposed)
            })
            .reduce(|| (0, false), |a, b| (a.0 + b.0, a.1 || b.1))
    }
}

/// The triangle-collision pipeline of `cloth`, if the scene needs one.
fn collision_pipeline(
    cloth: &Cloth,
    pins: &[Pin],
    colliders: &[Collider],
    meshes: &[MeshCollider],
    settings: &Settings,
) -> Option<CollisionPipeline> {
    let mut particles: Vec<ParticleCollision> = (0..cloth.vertex_count())
        .map(|i| {
            let f = cloth.fabric_of(i);
            ParticleCollision { thickness: f.thickness_m, friction: f.friction, pinned: None }
        })
        .collect();
    for pin in pins {
        // A rigid mesh carries a point glued to it as its own motion carries its
        // vertices: the same rigid motion applied to the point's start. A point
        // glued to a deforming mesh moves its own way.
        let rigid = |motion| Kinematic::Rigid(Placement { rest_pose: nalgebra::Isometry3::identity(), motion });
        let kinematic = match &pin.target {
            PinTarget::Still => rigid(None),
            PinTarget::Moving(motion) => rigid(Some(*motion)),
            PinTarget::OnMesh { mesh, .. } => match &meshes[*mesh as usize] {
                m if m.animation.is_some() => Kinematic::Deforming,
                m => rigid(m.placement.motion),
            },
        };
        particles[pin.vertex as usize].pinned = Some(kinematic);
    }
    let scale = ClothScale::of(&cloth.rest_positions, &cloth.triangles, particles.iter().map(|p| p.thickness));
    let self_collision =
        (0..cloth.garments.len()).map(|g| settings.self_collision.get(g).copied().unwrap_or(true)).collect();
    CollisionPipeline::new(
        cloth.triangles.clone(),
        cloth.triangle_garment.clone(),
        self_collision,
        particles,
        Obstacles::new(colliders, meshes, scale),
        settings.collision.clone(),
    )
}

/// Everything a step changes, kept to roll a failed step back
/// ([`Simulator::checkpoint`]).
#[derive(Clone, Debug, Default)]
pub struct Checkpoint {
    x: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    time: f64,
    resting_on: Vec<u32>,
    released: Vec<bool>,
    normal_force: Vec<f64>,
    contact_impulse: Vec<f64>,
    last_step: LocalError,
    collision: Option<CollisionMemory>,
    /// A fabric change in progress: it recomputes the coefficients of each
    /// step from its step count, so restoring it is enough.
    ramp: Option<Ramp>,
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
        Ok(())
    }

    /// Sets the linear solver's relative tolerance (unitless, 0 < t < 1) from
    /// the next solve on.
    pub fn set_solver_tolerance(&mut self, tolerance: f64) {
        if tolerance > 0.0 && tolerance < 1.0 {
            self.settings.tolerance = tolerance;
        }
    }

    /// Stores the state a step changes into `into` (reusing its buffers).
    pub fn checkpoint(&self, into: &mut Checkpoint) {
        into.x.clone_from(&self.x);
        into.v.clone_from(&self.v);
        into.time = self.time;
        into.resting_on.clone_from(&self.resting_on);
        into.released.clone_from(&self.released);
        into.normal_force.clone_from(&self.normal_force);
        into.contact_impulse.clone_from(&self.contact_impulse);
        into.last_step = self.last_step;
        if let Some(pipeline) = &self.collision {
            pipeline.save_memory(into.collision.get_or_insert_with(CollisionMemory::default));
        }
        into.ramp.clone_from(&self.ramp);
    }

    /// Returns to the state of `checkpoint`, taken from this simulator.
    pub fn restore(&mut self, checkpoint: &Checkpoint) {
        self.x.clone_from(&checkpoint.x);
        self.v.clone_from(&checkpoint.v);
        self.time = checkpoint.time;
        self.resting_on.clone_from(&checkpoint.resting_on);
        self.released.clone_from(&checkpoint.released);
        self.normal_force.clone_from(&checkpoint.normal_force);
        self.contact_impulse.clone_from(&checkpoint.contact_impulse);
        self.last_step = checkpoint.last_step;
        if let (Some(pipeline), Some(memory)) = (&mut self.collision, &checkpoint.collision) {
            pipeline.restore_memory(memory);
        }
        self.ramp.clone_from(&checkpoint.ramp);
    }

    /// Its whole state between steps, for a bake to go on later exactly
    /// where it is now ([`super::snapshot`]). Refused while a fabric change
    /// is being blended in.
    pub fn snapshot(&self) -> Result<Snapshot, SnapshotError> {
        if self.ramp.is_some() {
            return Err(SnapshotError::TuningInProgress);
        }
        Ok(Snapshot { factor: self.preconditioner.state(), ..self.state() })
    }

    /// Its state between steps without the kept factor (the next step
    /// rebuilds one), taken even while a fabric change blends in: what the
    /// editor keeps of each frame to simulate again from it
    /// ([`Self::restart_from`]).
    pub fn state(&self) -> Snapshot {
        let memory = self.collision.as_ref().map(|pipeline| {
            let mut memory = CollisionMemory::default();
            pipeline.save_memory(&mut memory);
            memory.entries()
        });
        let mut warm_start = to_arrays(&self.ws.velocity_change);
        warm_start.resize(self.x.len(), [0.0; 3]);
        Snapshot {
            time_s: self.time,
            positions: to_arrays(&self.x),
            velocities: to_arrays(&self.v),
            resting_on: self.resting_on.clone(),
            released: self.released.clone(),
            normal_force_n: self.normal_force.clone(),
            last_step: self.last_step,
            warm_start,
            contact_influence: memory.unwrap_or_default(),
            factor: None,
        }
    }

    /// Puts this simulator (built from the same scene) in the state of
    /// `snapshot`: the steps after it are bit-identical to those the
    /// snapshotted simulator would have taken.
    pub fn resume_from(&mut self, snapshot: &Snapshot) -> Result<(), SnapshotError> {
        let keeps_factor = matches!(self.preconditioner, Preconditioner::Cholesky(_));
        snapshot.check(self.x.len(), self.colliders.len(), keeps_factor)?;
        if let Some(factor) = &snapshot.factor {
            self.preconditioner.restore(factor)?;
        }
        self.take_state(snapshot);
        Ok(())
    }

    /// Puts this simulator in the state of `snapshot`, with or without a
    /// kept factor ([`Self::state`]): the editor simulating again from a
    /// frame, its current fabric blended in already. Without the factor the
    /// steps after are those of the run it left to within the solver's
    /// tolerance.
    pub fn restart_from(&mut self, snapshot: &Snapshot) -> Result<(), SnapshotError> {
        let keeps_factor = matches!(self.preconditioner, Preconditioner::Cholesky(_));
        snapshot.check(self.x.len(), self.colliders.len(), keeps_factor && snapshot.factor.is_some())?;
        if let Some(factor) = &snapshot.factor {
            self.preconditioner.restore(factor)?;
        }
        self.take_state(snapshot);
        Ok(())
    }

    /// The state of `snapshot` but its factor (checked already).
    fn take_state(&mut self, snapshot: &Snapshot) {
        self.time = snapshot.time_s;
        from_arrays(&snapshot.positions, &mut self.x);
        from_arrays(&snapshot.velocities, &mut self.v);
        from_arrays(&snapshot.warm_start, &mut self.ws.velocity_change);
        self.resting_on.clone_from(&snapshot.resting_on);
        self.released.clone_from(&snapshot.released);
        self.normal_force.clone_from(&snapshot.normal_force_n);
        self.last_step = snapshot.last_step;
        if let Some(pipeline) = &mut self.collision {
            pipeline.restore_memory(&CollisionMemory::from_entries(&snapshot.contact_influence));
        }
    }

    /// Where pin `k` must be at time `t`, m.
    fn pin_target(&self, k: usize, t: f64) -> Vector3<f64> {
        let rest = self.pin_rest[k];
        match &self.pins[k].target {
            PinTarget::Still => rest,
            PinTarget::Moving(m) => (m.world_from_rest(t) * Point3::from(rest)).coords,
            PinTarget::OnMesh { mesh, triangle, weights, offset_m } => {
                let mesh = &self.attachment_meshes[*mesh as usize];
                let world_from_local = mesh.placement.world_from_local(t);
                let [a, b, c] = mesh.triangles[*triangle as usize]
                    .map(|v| (world_from_local * Point3::from(mesh.local_vertex(v as usize, t))).coords);
                a * weights[0] + b * weights[1] + c * weights[2] + triangle_frame(&a, &b, &c) * offset_m
            }
        }
    }

    /// Advances by one backward-Euler step of `h` seconds, on a thread of
    /// the rayon pool ([`parallel::on_pool`]).
    pub fn step(&mut self, h: f64) -> Result<StepReport, StepError> {
        parallel::on_pool(|| self.step_on_pool(h))
    }

    /// [`Self::step`], on the thread it runs on.
    fn step_on_pool(&mut self, h: f64) -> Result<StepReport, StepError> {
        if let Some(ramp) = &mut self.ramp
            && !ramp.advance(&mut self.particles, &mut self.springs, self.strain_limits.as_mut())
        {
            self.ramp = None;
        }
        let window = StepWindow { t0: self.time, t1: self.time + h };
        let mut report = StepReport::default();
        // The obstacles of the step (a body's skin at its start and end,
        // their boxes and hierarchy) do not depend on the solve: they are
        // made on the other core while it runs, in the frame that the
        // cloth's start velocities carry it by, and only near the ends
        // those velocities predict; then the cloth's broad phase is
        // speculated there from those ends.
        let mut pipeline = self.collision.take();
        self.ws.repulsion = pipeline.as_mut().and_then(|p| p.repulsion(&self.x, window.t0, h, &mut self.ws.resting));
        let shift = carried_displacement(&self.v, h);
        let (mut start, mut predicted) =
            (std::mem::take(&mut self.ws.speculative_start), std::mem::take(&mut self.ws.predicted_end));
        if pipeline.is_some() {
            start.clone_from(&self.x);
            predicted.clear();
            predicted.extend(self.x.iter().zip(&self.v).map(|(x, v)| x + v * h));
        }
        rayon::join(
            || self.solve_velocity_change(window, h, &mut report),
            || {
                if let Some(pipeline) = pipeline.as_mut() {
                    pipeline.frame_obstacles_near(window, shift, (&start, &predicted));
                    pipeline.speculate(window, &start, &predicted);
                }
            },
        );
        (self.ws.speculative_start, self.ws.predicted_end) = (start, predicted);
        self.collision = pipeline;
        let mut clock = Instant::now();

        self.integrate(h);
        if let Some(limits) = &mut self.strain_limits {
            report.projection = limits.project(ProjectedState {
                x: &mut self.ws.next_x,
                v: &mut self.ws.next_v,
                constraints: &self.ws.constraints,
                mass: &self.particles.mass,
                h,
            });
        }
        report.timings.constraints = lap(&mut clock);
        report.contacts = self.collide_with_colliders(window);
        report.timings.contacts = lap(&mut clock);
        if let Some(pipeline) = &mut self.collision {
            let cloth = ClothState {
                start: &self.x,
                end: &mut self.ws.next_x,
                velocity: &mut self.ws.next_v,
                mass: &self.particles.mass,
            };
            let (limits, constraints, mass) = (&mut self.strain_limits, &self.ws.constraints, &self.particles.mass);
            let projection = &mut report.projection;
            let paths = ColliderPaths::new(&self.x, &self.fixed, &self.surfaces, &self.colliders, window);
            let (contacts, resting_on) = (&mut self.ws.contacts, &mut self.resting_on);
            let before_projection = &mut self.ws.before_projection;
            let holds = &mut self.ws.holds;
            // Limits that pins make unreachable (the first projection
            // stalled) are still approached after every pass, keeping
            // partial results; a stall without pins (cloth tented on a
            // sharp apex) leaves the passes unprojected, as the partial
            // projections stretched `pillars`' cone apex further.
            let pulled_apart = projection.stalled && !self.pins.is_empty();
            let mut after_pass = |pass: PassState| {
                let mut projected = false;
                before_projection.clear();
                if let Some(limits) = limits.as_mut()
                    && pass.stage == ResponseStage::Impulses
                {
                    let gave_up = projection.abandoned || projection.fell_back || (projection.stalled && !pulled_apart);
                    if !gave_up && limits.excess_strain(pass.end) > STRAIN_TOLERANCE {
                        before_projection.extend_from_slice(pass.end);
                        holds.clear();
                        holds.extend(
                            pass.pushed_off
                                .iter()
                                .enumerate()
                                .filter_map(|(i, n)| n.try_normalize(PUSH_SUM_MIN).map(|n| (i as u32, n))),
                        );
                        let state = ProjectedState { x: pass.end, v: pass.velocity, constraints, mass, h };
                        let report = if pulled_apart {
                            limits.project_partial(state, holds)
                        } else {
                            limits.project_holding(state, holds)
                        };
                        projection.add(&report);
                        projected = !report.abandoned;
                    }
                }
                // What the response or the projection moved goes through the
                // analytic colliders again, before the next detection sees it.
                let (moved, before_projection) = (pass.moved, &*before_projection);
                let again = |i: usize, end: &Vector3<f64>| moved[i] || (projected && before_projection[i] != *end);
                let (_, collided) = paths.resolve(pass.end, pass.velocity, again, contacts, resting_on);
                projected || collided
            };
            report.collision = pipeline.resolve(cloth, window, &mut after_pass);
            for (total, taken) in self.contact_impulse.iter_mut().zip(pipeline.obstacle_impulses()) {
                *total += taken;
            }
            let c = &report.collision;
            report.timings.refit = c.refit;
            report.timings.broad = c.broad;
            report.timings.narrow = c.narrow;
            report.timings.response = c.response;
            lap(&mut clock);
        }

        for k in 0..self.pins.len() {
            let i = self.pins[k].vertex as usize;
            self.ws.next_x[i] = self.pin_target(k, window.t1);
        }
        let bad = |v: &[Vector3<f64>]| v.par_iter().position_first(|p| !p.iter().all(|c| c.is_finite()));
        if let Some(particle) = bad(&self.ws.next_x).or_else(|| bad(&self.ws.next_v)) {
            self.ws.velocity_change.iter_mut().for_each(|d| *d = Vector3::zeros());
            return Err(StepError::NonFinite { time: window.t1, particle });
        }
        report.local_error = LocalError::of_step(h, &self.v, &self.ws.next_v, &self.fixed);
        self.last_step = report.local_error;
        std::mem::swap(&mut self.x, &mut self.ws.next_x);
        std::mem::swap(&mut self.v, &mut self.ws.next_v);
        for (total, force) in self.contact_impulse.iter_mut().zip(&self.normal_force) {
            *total += force * h;
        }
        self.time = window.t1;
        self.measure_strain(&mut report);
        report.timings.finish = lap(&mut clock);
        Ok(report)
    }

    /// The implicit velocity update of one step (PAPER eq. 3-5): assembles
    /// the system, sets each particle's constraint and solves, again while
    /// the solution predicts new collider contacts, for a step of `h`
    /// seconds over `window`. Fills the report's solver figures and its
    /// springs, assembly and solve times.
    fn solve_velocity_change(&mut self, window: StepWindow, h: f64, report: &mut StepReport) {
        let n = self.x.len();
        let mut clock = Instant::now();
        let input = AssemblyInput { x: &self.x, v: &self.v, h };
        evaluate_springs(&self.cloth, &self.springs, &input, &mut self.ws.system);
        report.timings.springs = lap(&mut clock);
        assemble(&self.layout, &self.particles, &input, &mut self.ws.system);
        if let Some(repulsion) = &self.ws.repulsion {
            repulsion.add_to(&self.ws.resting, &self.layout.pattern.blocks, &mut self.ws.system);
        }
        report.timings.assembly = lap(&mut clock);

        self.ws.velocity_change.resize(n, Vector3::zeros());
        report.resting_contacts = self.prepare_constraints(window);
        let (mass, gravity) = (&self.particles.mass, &self.particles.gravity);
        self.ws.weight_impulse.clear();
        self.ws.weight_impulse.extend((0..n).map(|i| gravity[i] * (mass[i] * h)));
        loop {
            let system = FilteredSystem {
                matrix: self.ws.system.system_matrix(&self.layout),
                b: &self.ws.system.rhs,
                typical: &self.ws.weight_impulse,
                constraints: &self.ws.constraints,
                positions: &self.x,
            };
            // After the first solve only new contacts' constraints change.
            let change = if report.solves == 0 { SystemChange::Matrix } else { SystemChange::Constraints };
            let (solve, factored) = self.preconditioner.solve(
                system,
                &mut self.ws.velocity_change,
                self.settings,
                &mut self.ws.pcg,
                change,
            );
            report.factorizations += factored;
            report.solver = PcgReport { iterations: report.solver.iterations + solve.iterations, ..solve };
            report.solves += 1;
            if report.solves == CONTACT_PASSES || self.colliders.is_empty() {
                break;
            }
            let (new_contacts, significant) = self.predict_contacts(window);
            report.resting_contacts += new_contacts;
            if significant == 0 {
                break;
            }
        }
        self.record_contact_forces(h);
        report.timings.solve = lap(&mut clock);
    }

    /// Sets each particle's constraint for the solve and the prescribed part of
    /// its velocity change: pins move to their target; a particle resting on a
    /// collider (and not released) keeps the surface's normal velocity, and its
    /// friction joins the system as a tangential damping. Returns the number of
    /// resting contacts.
    fn prepare_constraints(&mut self, window: StepWindow) -> u32 {
        let n = self.x.len();
        let h = window.h();
        let ws = &mut self.ws;
        ws.constraints.resize(n, Constraint::Free);
        ws.surface_contacts.resize(n, None);
        let (x, v, colliders, surfaces) = (&self.x, &self.v, &self.colliders, &self.surfaces);
        let (resting_on, released, fixed, normal_force) =
            (&self.resting_on, &self.released, &self.fixed, &self.normal_force);
        ws.constraints
            .par_iter_mut()
            .zip(ws.surface_contacts.par_iter_mut())
            .zip(ws.velocity_change.par_iter_mut().zip(ws.system.rhs.par_iter_mut()))
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(i, ((constraint, contact), (dv, rhs)))| {
                *contact = None;
                *constraint = if fixed[i] { Constraint::Fixed } else { Constraint::Free };
                if fixed[i] || released[i] || resting_on[i] == NO_COLLIDER {
                    return;
                }
                let surface = SurfaceContact::resting(&x[i], colliders, resting_on[i], window);
                let mu = colliders[surface.collider as usize].friction.unwrap_or(surfaces[i].friction);
                let (_, force) = surface.friction_damping(&v[i], normal_force[i], mu);
                *rhs += force * h;
                *constraint = surface.constraint();
                *dv = surface.prescribe(&v[i], dv);
                *contact = Some(surface);
            });
        // The damping's Jacobian joins the diagonal blocks.
        for i in 0..n {
            if let Some(surface) = &self.ws.surface_contacts[i] {
                let mu = self.colliders[surface.collider as usize].friction.unwrap_or(self.surfaces[i].friction);
                let (damping, _) = surface.friction_damping(&self.v[i], self.normal_force[i], mu);
                self.ws.system.matrix[self.layout.pattern.blocks.diagonal(i)] += damping * h;
            }
        }
        for k in 0..self.pins.len() {
            let i = self.pins[k].vertex as usize;
            let target = self.pin_target(k, window.t1);
            self.ws.velocity_change[i] = (target - self.x[i]) / h - self.v[i];
        }
        self.ws.surface_contacts.par_iter().filter(|c| c.is_some()).count() as u32
    }

    /// One detect pass: every particle still free whose solved path would
    /// reach a collider becomes constrained to arrive at its surface. Returns
    /// the number of new contacts, and how many of them change their particle's
    /// path by more than a fraction of the thickness (only those are worth
    /// solving again for; the rest are particles creeping onto a surface).
    fn predict_contacts(&mut self, window: StepWindow) -> (u32, u32) {
        let ws = &mut self.ws;
        let (x, v, colliders, surfaces) = (&self.x, &self.v, &self.colliders, &self.surfaces);
        ws.constraints
            .par_iter_mut()
            .zip(ws.surface_contacts.par_iter_mut())
            .zip(ws.velocity_change.par_iter_mut())
            .enumerate()
            .with_min_len(CHUNK)
            .map(|(i, ((constraint, contact), dv))| {
                if *constraint != Constraint::Free {
                    return (0, 0);
                }
                let end = x[i] + (v[i] + *dv) * window.h();
                let thickness = surfaces[i].thickness;
                let Some(surface) = SurfaceContact::predicted(&x[i], &end, thickness, colliders, window) else {
                    return (0, 0);
                };
                let corrected = surface.prescribe(&v[i], dv);
                let shift = (corrected - *dv).norm() * window.h();
                *constraint = surface.constraint();
                *dv = corrected;
                *contact = Some(surface);
                (1, u32::from(shift > RESOLVE_SHIFT * thickness))
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
    }

    /// Reads each contact's normal impulse from the final solve: the surface
    /// supplies what the system lacks, `A Δv − b` (N·s), along the normal.
    /// Its force drives the friction of the next step; a pulling contact is
    /// released for the next step instead.
    fn record_contact_forces(&mut self, h: f64) {
        let ws = &mut self.ws;
        let any_contact = ws.surface_contacts.iter().any(Option::is_some);
        if any_contact {
            ws.residual.resize(self.x.len(), Vector3::zeros());
            ws.system.system_matrix(&self.layout).multiply(&ws.velocity_change, &mut ws.residual);
        }
        let (contacts, product, rhs) = (&ws.surface_contacts, &ws.residual, &ws.system.rhs);
        self.normal_force.par_iter_mut().zip(self.released.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(
            |(i, (force, released))| {
                let impulse = contacts[i].as_ref().map_or(0.0, |c| (product[i] - rhs[i]).dot(&c.normal));
                *released = impulse < 0.0;
                *force = impulse.max(0.0) / h;
            },
        );
    }

    /// `v ← v + Δv`, `x ← x + h v` into the next-state buffers.
    fn integrate(&mut self, h: f64) {
        let n = self.x.len();
        let ws = &mut self.ws;
        ws.next_x.resize(n, Vector3::zeros());
        ws.next_v.resize(n, Vector3::zeros());
        let (x, v, dv) = (&self.x, &self.v, &ws.velocity_change);
        ws.next_x.par_iter_mut().zip(ws.next_v.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(
            |(i, (next_x, next_v))| {
                *next_v = v[i] + dv[i];
                *next_x = x[i] + *next_v * h;
            },
        );
    }

    /// Each free particle's path from its position to the next-state buffers
    /// against the analytic colliders, noting which collider it ends resting
    /// on. Returns the contact count.
    fn collide_with_colliders(&mut self, window: StepWindow) -> u32 {
        self.ws.contacts.resize(self.x.len(), 0);
        let paths = ColliderPaths::new(&self.x, &self.fixed, &self.surfaces, &self.colliders, window);
        let ws = &mut self.ws;
        let (contacts, _) =
            paths.resolve(&mut ws.next_x, &mut ws.next_v, |_, _| true, &mut ws.contacts, &mut self.resting_on);
        contacts
    }

    /// Whether the cloth collides with an animated body (a deforming mesh).
    pub fn has_animated_bodies(&self) -> bool {
        self.collision.as_ref().is_some_and(CollisionPipeline::has_animated_bodies)
    }

    /// Largest stretch of a stretch spring now, (l − l₀) / l₀, unitless (0
    /// when none is longer than at rest): what [`StepReport::max_strain`]
    /// reports after a step.
    pub fn largest_strain(&self) -> f64 {
        let (cloth, x, stretch) = (&self.cloth, &self.x, &self.stretch_springs);
        parallel::max(stretch.len(), |k| spring_strain(cloth, x, stretch[k]).max(0.0))
    }

    /// The largest strain now and the largest over the stretch springs with
    /// an end that is not pinned, unitless: what a step's report would say.
    pub fn largest_strains(&self) -> (f64, f64) {
        let largest = self.largest_strain();
        (largest, self.largest_free_strain_or(largest))
    }

    /// [`Self::largest_strain`] over the stretch springs with an end that is
    /// not pinned: what [`StepReport::max_free_strain`] reports. Without
    /// pins it is the largest strain, and `largest` is returned as it is.
    fn largest_free_strain_or(&self, largest: f64) -> f64 {
        if self.pins.is_empty() {
            return largest;
        }
        let (cloth, x, stretch, fixed) = (&self.cloth, &self.x, &self.stretch_springs, &self.fixed);
        parallel::max(stretch.len(), |k| {
            let [a, b] = cloth.spring_ends[stretch[k] as usize];
            if fixed[a as usize] && fixed[b as usize] { 0.0 } else { spring_strain(cloth, x, stretch[k]).max(0.0) }
        })
    }

    /// Writes the stretch springs' strains into `report`: the largest
    /// (l − l₀) / l₀, the largest of those not pinned at both ends, and the
    /// mean |l − l₀| / l₀.
    fn measure_strain(&mut self, report: &mut StepReport) {
        report.max_strain = self.largest_strain();
        report.max_free_strain = self.largest_free_strain_or(report.max_strain);
        let (cloth, x, stretch) = (&self.cloth, &self.x, &self.stretch_springs);
        let total = parallel::sum(stretch.len(), &mut self.ws.partials, |k| spring_strain(cloth, x, stretch[k]).abs());
        report.mean_strain = total / stretch.len().max(1) as f64;
    }

    /// Largest strain beyond its limit of an edge the strain limits hold
    /// now, unitless (0 when all are within, or without limits).
    pub fn excess_strain(&self) -> f64 {
        self.strain_limits.as_ref().map_or(0.0, |limits| limits.excess_strain(&self.x))
    }
}

/// The time since `clock`, which is set to now.
fn lap(clock: &mut Instant) -> Duration {
    let now = Instant::now();
    let elapsed = now - *clock;
    *clock = now;
    elapsed
}

/// Strain of spring `spring` at positions `x`, (l − l₀) / l₀, unitless.
fn spring_strain(cloth: &Cloth, x: &[Vector3<f64>], spring: u32) -> f64 {
    let [a, b] = cloth.spring_ends[spring as usize];
    let rest = cloth.rest_length[spring as usize];
    ((x[a as usize] - x[b as usize]).norm() - rest) / rest
}
