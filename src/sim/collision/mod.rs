//! Collisions of cloth triangles with each other, with triangle-mesh colliders
//! and with the sharp features of analytic colliders (PAPER sections 3-4,
//! Algorithm 1).
//!
//! One step's pipeline, after the implicit solve has proposed where every
//! particle goes:
//!
//! 1. **refit**: each cloth triangle's box over the whole step (start and
//!    proposed end of its corners, grown by half the largest thickness, as
//!    every obstacle point's box is, so two features' boxes overlap wherever
//!    they can come within a thickness) refits a BVH built once; boxes are
//!    taken in a frame that moves with the cloth's mean
//!    displacement, so motion the features share does not stretch them. The
//!    mesh colliders' triangles have a BVH of their own, refitted once per
//!    step: they do not move within it;
//! 2. **broad**: overlapping triangle pairs (within a garment only if its
//!    self-collision is on), cloth triangles near mesh-collider triangles
//!    (the two hierarchies traversed together, or the moved cloth triangles'
//!    queries after a response) and near sharp obstacle features;
//! 3. **narrow**: for each pair, only the features the triangles own
//!    (representative triangles), each first culled by its own box and by a
//!    distance bound, then tested by continuous collision detection;
//! 4. **response**: detect → respond passes of inelastic impulses with
//!    friction; contacts that keep coming back gain influence (eq. 16) and,
//!    above the threshold, are solved together as a constraint set; what is
//!    still crossing after the passes is made to move in rigid impact zones
//!    until nothing crosses. Every pass and every round is corrected by the
//!    step's [`PassHook`] (strain limits, analytic colliders) before the next
//!    detection checks it, so the pipeline ends on a detection of the final
//!    positions and reports the crossings that detection found.
//!
//! A scene without self-collision and without mesh or sharp colliders builds
//! none of this; a step whose boxes do not overlap runs no narrow phase.

mod adjacent;
mod after_zones;
pub mod bvh;
pub mod ccd;
mod detect;
pub mod features;
pub mod geometry;
pub mod obstacles;
mod pair_sort;
mod partners;
mod passes;
mod queries;
pub mod response;
pub mod resting;
mod slabs;
mod speculate;
mod zones;

use std::collections::{HashMap, HashSet};
use std::time::{Duration, Instant};

use nalgebra::Vector3;

use self::adjacent::AdjacentTriangles;
use self::after_zones::ZONE_CORRECTIONS;
use self::bvh::{Box3, SweptBvh};
pub use self::detect::carried_displacement;
use self::detect::{Detection, Job, Scope};
use self::features::Ownership;
use self::obstacles::Obstacles;
use self::pair_sort::PairSorter;
use self::response::{Contact, Points, Zones};
use super::contact::StepWindow;
use super::motion::Placement;

/// Influence below which a contact is forgotten.
const FORGOTTEN: f64 = 1e-3;

/// The collision constants of a scene (PAPER Fig. 10c), as the scene file's
/// `[collision]` table ([`crate::scene::file::CollisionSettings`]) sets them.
#[derive(Clone, Debug, PartialEq)]
pub struct CollisionSettings {
    /// Detect → respond passes per step before impact zones take over.
    pub passes: u32,
    /// Fraction of the contacts' total shortfall (how far short of the
    /// thickness they would end, summed in thicknesses) that a pass must take
    /// away for the next one to respond, in [0, 1); 0 (the default) turns the
    /// check off. Where the pass hook keeps undoing the impulses (strain
    /// limits pulling a cloth back over a table's corner) more passes only
    /// repeat the fight, and a scene can hand such steps to the impact zones
    /// early; where many contacts converge slowly together (a wrung cloth),
    /// cutting the passes short makes large zones and costs more.
    pub pass_progress: f64,
    /// Factor `a` by which a contact's influence decays when it is not seen
    /// again (eq. 16), in (0, 1).
    pub influence_decay: f64,
    /// Influence at which a contact joins the constraint set solved together.
    pub influence_threshold: f64,
    /// Sweeps over the constraint set per pass.
    pub constraint_sweeps: u32,
    /// Rounds of impact-zone merging before a step gives up.
    pub zone_rounds: u32,
    /// Test each vertex and edge once, from the one triangle that owns it
    /// (PAPER Algorithm 1); off tests them from every incident triangle, for
    /// comparison only: the contacts found are the same.
    pub representative_triangles: bool,
    /// Stiffness of the springs that push the cloth's resting self-contacts
    /// apart in the implicit solve ([`crate::sim::repulsion`]), N/m; 0 turns
    /// them off. At 0.5 `drape_sphere`, `spin_sphere` and the tiered skirt
    /// keep most of what 2 gives them, and `pillars`, whose folds rest on
    /// sharp tops, no longer pays for it (f858749).
    pub repulsion_stiffness: f64,
    /// Stiffness of the springs that push the cloth off the analytic
    /// colliders' sharp features it rests on (a table's edge, a needle's
    /// tip; not a body's skin) in the implicit solve, N/m; 0 turns them off.
    /// At 30 `drape_table`'s corners keep their strain limit with no impact
    /// zone and its response takes a third of the time, and `needles`' frame
    /// is 40 % shorter (91a3e83). A weaker spring
    /// pushes the cloth only part of the way and the corners tear more than
    /// with none: 15 is enough at N = 96, not at N = 48, whose coarser edges
    /// carry twice the tension each.
    pub feature_repulsion_stiffness: f64,
    /// Stiffness of the springs that hold the cloth on the tips of props
    /// it rests on as on a point (a needle: a prop narrower than the cloth's
    /// edges, [`obstacles::Obstacles::holds`]) in the implicit solve, N/m;
    /// 0 turns them off. A tip carries all that hangs from it through the
    /// few triangles over it: a needle of `needles` about 0.05 N, which
    /// the edges' 30 N/m carry only some 2 mm down, ten times the band, so
    /// every solve let the cloth sink round the tips and every step's
    /// passes and projections lifted it back (30-80 Newton iterations a
    /// step). At 100 the cloth stays on the tips within about the band and
    /// `needles` takes half the time, at the same strain.
    pub tip_repulsion_stiffness: f64,
    /// How near the thickness a remembered contact must lie to rest (and how
    /// far past it its spring pushes), as a fraction of it.
    pub repulsion_band: f64,
}

impl Default for CollisionSettings {
    fn default() -> Self {
        CollisionSettings {
            passes: 6,
            pass_progress: 0.0,
            influence_decay: 0.5,
            influence_threshold: 1.5,
            constraint_sweeps: 8,
            zone_rounds: 40,
            representative_triangles: true,
            repulsion_stiffness: 0.5,
            feature_repulsion_stiffness: 30.0,
            tip_repulsion_stiffness: 100.0,
            repulsion_band: 0.1,
        }
    }
}

impl CollisionSettings {
    /// The influence a resting pair is given at a step's start so that it is
    /// still remembered after every pass of the step has missed it (its
    /// spring holding it past the thickness, where no pass sees it): twice
    /// `FORGOTTEN / aᵖᵃˢˢᵉˢ`. Kept below what one sighting would lift into
    /// the constraint set (eq. 16), which stays the recurring contacts'.
    fn influence_kept_for_a_step(&self) -> f64 {
        let a = self.influence_decay;
        let outlives_the_passes = 2.0 * FORGOTTEN / a.powi(self.passes as i32);
        let joins_the_set = (self.influence_threshold - 1.0) / a;
        outlives_the_passes.min(0.5 * joins_the_set)
    }
}

/// Which part of the response a pass hook follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResponseStage {
    /// A pass of impulses and the constraint set.
    Impulses,
    /// A round of rigid impact zones.
    ImpactZones,
    /// Impact zones that left nothing crossing: the hook may move the cloth
    /// after them, the zones' points with it (the edges leaving a rigid
    /// zone, or between two zones, are stretched), and the passes and zones
    /// then run again over what it moved ([`after_zones`]).
    AfterZones,
}

/// What a pass hook sees and may correct: the cloth's end positions and
/// velocities (m, m/s), which particles the response just moved, and after
/// which part of it.
pub struct PassState<'a> {
    /// Proposed positions at the end of the step, m.
    pub end: &'a mut [Vector3<f64>],
    /// Velocities, m/s.
    pub velocity: &'a mut [Vector3<f64>],
    /// Per particle, whether the response moved it since the last detection.
    pub moved: &'a [bool],
    /// Per particle, the sum of the normals (weighted by the particle's
    /// share of the contact) along which this pass's impulses pushed it off
    /// a triangle mesh collider (a body) or the features of an analytic
    /// collider thinner than the cloth's edges (a needle): zero where none
    /// did. Pushes off wider analytic colliders' sharp features do not
    /// count: the cloth wraps round a table's edge, whose normal turns
    /// under it ([`obstacles::Obstacles::holds`]).
    pub pushed_off: &'a [Vector3<f64>],
    /// The part of the response just run.
    pub stage: ResponseStage,
    /// Cloth particles the response has fixed for the rest of the step (once
    /// impact zones left nothing crossing: the points they carried with an
    /// obstacle and those the hook held after a round): the hook must not
    /// move them.
    pub frozen: &'a [u32],
}

/// A correction run after every response pass and every impact-zone round,
/// before the next detection checks its result: the inextensibility
/// projection (so that impulses and strain limits are met together) and the
/// particles' paths against the analytic colliders (so that nothing the
/// response pushed into a collider is moved out unchecked). Returns whether
/// it moved anything.
pub type PassHook<'a> = &'a mut dyn FnMut(PassState) -> bool;

/// The contact influences a pipeline keeps between steps (see
/// [`CollisionPipeline::save_memory`]).
#[derive(Clone, Debug, Default)]
pub struct CollisionMemory(HashMap<[u32; 5], (f64, bool)>);

impl CollisionMemory {
    /// Every remembered contact (its feature key), its influence (eq. 16)
    /// and whether the last response pass saw it, in key order.
    pub fn entries(&self) -> Vec<([u32; 5], f64, bool)> {
        let mut entries: Vec<_> = self.0.iter().map(|(&key, &(influence, seen))| (key, influence, seen)).collect();
        entries.sort_unstable_by_key(|e| e.0);
        entries
    }

    /// The memory holding `entries` (as [`Self::entries`] lists them).
    pub fn from_entries(entries: &[([u32; 5], f64, bool)]) -> Self {
        CollisionMemory(entries.iter().map(|&(key, influence, seen)| (key, (influence, seen))).collect())
    }
}

/// What collision processing did in one step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CollisionReport {
    /// Loading the step: points, boxes and BVH refits.
    pub refit: Duration,
    /// Broad phase.
    pub broad: Duration,
    /// Narrow phase (continuous collision detection).
    pub narrow: Duration,
    /// Impulses, constraint set, impact zones, and the pass hook's
    /// corrections.
    pub response: Duration,
    /// Candidate pairs of the last detection.
    pub pairs: u32,
    /// Elementary feature pairs (vertex-triangle, edge-edge) of the step's
    /// first detection that passed the box test and went on to distance
    /// culling and continuous detection.
    pub tests: u64,
    /// The same count if every vertex and edge of both triangles were tested
    /// (no representative triangles).
    pub tests_without_ownership: u64,
    /// Contacts found in the first detection.
    pub contacts: u32,
    /// Detect → respond passes run.
    pub passes: u32,
    /// Contacts in the constraint set at the last pass.
    pub constraint_set: u32,
    /// Rounds of impact zones needed.
    pub zone_rounds: u32,
    /// Corrections after impact zones ([`ResponseStage::AfterZones`]).
    pub zone_corrections: u32,
    /// Corrections undone: their own zones left crossings, or (the
    /// simulator's measure) more strain than the first zones did.
    pub corrections_undone: u32,
    /// Crossings left when the step ends (should be 0).
    pub unresolved: u32,
}

/// One garment-level fact the pipeline needs per cloth particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleCollision {
    /// Distance to keep, m.
    pub thickness: f64,
    /// Friction coefficient, unitless.
    pub friction: f64,
    /// Prescribed motion of a pinned particle (`None`: free).
    pub pinned: Option<Kinematic>,
}

/// How a kinematic point (a pinned particle or an obstacle vertex) moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kinematic {
    /// Rigidly, with this placement.
    Rigid(Placement),
    /// Each point its own way (a deforming body, or a point glued to one):
    /// known by its positions at the step's start and end.
    Deforming,
}

/// The collision pipeline of one cloth: topology, hierarchy, obstacles and
/// reusable buffers.
#[derive(Clone, Debug)]
pub struct CollisionPipeline {
    settings: CollisionSettings,
    triangles: Vec<[u32; 3]>,
    triangle_garment: Vec<u32>,
    self_collision: Vec<bool>,
    ownership: Ownership,
    /// The triangles sharing a vertex, in garments that collide with themselves.
    adjacent: AdjacentTriangles,
    obstacles: Obstacles,
    particles: Vec<ParticleCollision>,
    bvh: Option<SweptBvh>,
    /// Over the mesh colliders' triangles (none without any).
    obstacle_bvh: Option<SweptBvh>,
    influence: HashMap<[u32; 5], (f64, bool)>,
    /// The step the obstacles were last framed for, until a resolve uses it.
    framed: Option<StepWindow>,
    ws: Workspace,
}

#[derive(Clone, Debug, Default)]
struct Workspace {
    obstacle_start: Vec<Vector3<f64>>,
    obstacle_end: Vec<Vector3<f64>>,
    start: Vec<Vector3<f64>>,
    end: Vec<Vector3<f64>>,
    velocity: Vec<Vector3<f64>>,
    inverse_mass: Vec<f64>,
    moved: Vec<bool>,
    /// See [`PassState::pushed_off`].
    pushed_off: Vec<Vector3<f64>>,
    /// Normal impulse each cloth particle took from the obstacles this step, N·s.
    obstacle_impulse: Vec<f64>,
    /// The step's frame: boxes span each point's start and its end minus
    /// this, m (see [`CollisionPipeline::frame_obstacles`]).
    shift: Vector3<f64>,
    /// How much every point's box is grown, m ([`detect::box_growth`]).
    growth: f64,
    /// Per point (cloth, then obstacles): its box over the step in that frame.
    node_box: Vec<Box3>,
    /// Per point: what the narrow phase reads of it, packed.
    point: Vec<detect::PointState>,
    triangle_box: Vec<Box3>,
    /// Per point (cloth, then obstacles): its face-diagonal slabs over the
    /// step in that frame.
    point_slabs: Vec<slabs::DiagonalSlabs>,
    /// Per cloth triangle: its face-diagonal slabs over the step.
    triangle_slabs: Vec<slabs::DiagonalSlabs>,
    /// Per cloth triangle: the boxes of its edges and corners.
    feature_box: Vec<detect::FeatureBoxes>,
    /// Per obstacle triangle: its box over the step (empty while parked).
    obstacle_box: Vec<Box3>,
    /// The region the obstacle triangles are boxed in, in the step's frame
    /// (`None`: everywhere; see [`CollisionPipeline::frame_obstacles_near`]).
    obstacle_region: Option<Box3>,
    /// The obstacle triangles a framing boxed.
    fresh_obstacles: Vec<u32>,
    /// Per obstacle triangle: the boxes of its edges and corners over the step.
    obstacle_feature_box: Vec<detect::FeatureBoxes>,
    /// Per obstacle triangle: its face-diagonal slabs over the step (stale
    /// while parked, as its feature boxes).
    obstacle_slabs: Vec<slabs::DiagonalSlabs>,
    pairs: Vec<(u32, u32)>,
    /// The hierarchy's pairs, before the adjacent pairs are merged in.
    broad_pairs: Vec<(u32, u32)>,
    /// Adjacent triangle pairs that pass the coarse test, sorted.
    adjacent_pairs: Vec<(u32, u32)>,
    /// `(obstacle triangle, cloth triangle)` pairs of a broad phase.
    mesh_pairs: Vec<(u32, u32)>,
    hits: Vec<u32>,
    /// The remembered contacts the repulsions may push (self-contacts and
    /// contacts with sharp features), sorted: scratch of
    /// [`CollisionPipeline::resting_pairs`].
    resting_keys: Vec<[u32; 5]>,
    jobs: Vec<Job>,
    chunks: Vec<(Vec<Contact>, detect::TestCount)>,
    contacts: Vec<Contact>,
    /// Contacts of the last detection whose points have not moved since.
    kept: Vec<Contact>,
    /// Per cloth triangle, whether its box is queried again: one of its
    /// points moved (Scope::Moved), or it escaped its speculative box.
    moved_triangle: Vec<bool>,
    /// Those triangles, in increasing order.
    moved_list: Vec<u32>,
    /// Buffers of the parallel hierarchy queries of those triangles.
    query_chunks: Vec<queries::QueryChunk>,
    /// Scratch of the broad phase's pair sorts.
    pair_sorter: PairSorter,
    /// The cloth's boxes and pairs were speculated for this step, and its
    /// first detection has yet to confirm them (see [`speculate`]).
    speculative: bool,
    /// Per cloth triangle, after a speculation: its hierarchy leaf's box,
    /// over the step from the predicted ends, or, once the triangle
    /// escaped it, its real box grown by the same margin.
    leaf_box: Vec<Box3>,
    /// Self pairs of the speculative boxes, sorted.
    speculative_pairs: Vec<(u32, u32)>,
    /// `(obstacle triangle, cloth triangle)` pairs of the speculative boxes.
    speculative_mesh_pairs: Vec<(u32, u32)>,
    /// Self pairs of the escaped triangles' queries.
    escaped_pairs: Vec<(u32, u32)>,
    /// The moved triangles whose real boxes left their leaves this detection.
    escaping: Vec<u32>,
    /// Each cloth triangle's leaf partners, for the step's later detections.
    partners: partners::Partners,
    /// End positions before the pass hook, to see which it moved.
    before_hook: Vec<Vector3<f64>>,
    /// Cloth points made kinematic for the rest of the step's rounds: moved
    /// by the pass hook after an impact-zone round (pushed out of an
    /// analytic collider), on the path it gave them (`Deforming`), so a zone
    /// cannot push them back in round after round; or carried along by a
    /// crossing with rigid kinematic points (`Rigid`, their motion).
    held: Vec<Option<Kinematic>>,
    /// Keys of a detection's contacts.
    found: HashSet<[u32; 5]>,
    /// Indices into `contacts` of the eq. 16 constraint set of this pass.
    constraint_set: Vec<usize>,
    zones: Zones,
    /// The free points joined by this step's crossings alone, which move
    /// rigidly together inside a zone whose kinematic points move apart.
    inner_zones: Zones,
    /// The step's first detection is still to come (it is a full one).
    fresh: bool,
    /// The cloth particles fixed after impact zones ([`PassState::frozen`]).
    frozen: Vec<u32>,
    /// The cloth's end positions and velocities as the step's first zones
    /// left them, to undo the corrections after them.
    zoned_end: Vec<Vector3<f64>>,
    zoned_velocity: Vec<Vector3<f64>>,
    /// The resolve under way (or the last one) corrected after zones and
    /// kept it (so far): its later passes are fewer
    /// ([`after_zones::CORRECTION_PASSES`]) and its zones send their points
    /// back to where the first zones left them.
    correction_kept: bool,
    /// Which points are the root of a zone being made rigid this round.
    zone_root: Vec<bool>,
    /// `(zone root, member)` of every point in such a zone, sorted.
    zone_members: Vec<(u32, u32)>,
}

/// What the pipeline reads and changes: the cloth particles' state.
pub struct ClothState<'a> {
    /// Positions at the start of the step, m.
    pub start: &'a [Vector3<f64>],
    /// Proposed positions at the end of the step, m (corrected in place).
    pub end: &'a mut [Vector3<f64>],
    /// Velocities, m/s (corrected in place).
    pub velocity: &'a mut [Vector3<f64>],
    /// Masses, kg.
    pub mass: &'a [f64],
}

impl CollisionPipeline {
    /// A pipeline for `triangles` (cloth particle indices) of garments
    /// `triangle_garment`, with per-garment `self_collision` switches, against
    /// `obstacles`; `None` when there is nothing for it to do.
    pub fn new(
        triangles: Vec<[u32; 3]>,
        triangle_garment: Vec<u32>,
        self_collision: Vec<bool>,
        particles: Vec<ParticleCollision>,
        mut obstacles: Obstacles,
        settings: CollisionSettings,
    ) -> Option<Self> {
        let garments = self_collision.len();
        let needed = self_collision.iter().any(|&s| s) || garments > 1 || !obstacles.is_empty();
        let ownership = match settings.representative_triangles {
            true => Ownership::new(&triangles, particles.len()),
            false => {
                obstacles.ownership = Ownership::everything(obstacles.triangles.len());
                Ownership::everything(triangles.len())
            }
        };
        needed.then(|| CollisionPipeline {
            settings,
            ownership,
            adjacent: AdjacentTriangles::new(&triangles, particles.len(), |t| {
                self_collision[triangle_garment[t] as usize]
            }),
            triangles,
            triangle_garment,
            self_collision,
            obstacles,
            particles,
            bvh: None,
            obstacle_bvh: None,
            influence: HashMap::new(),
            framed: None,
            ws: Workspace::default(),
        })
    }

    /// Sets particle `i`'s thickness (m) and friction coefficient.
    pub fn set_surface(&mut self, i: usize, thickness: f64, friction: f64) {
        let particle = &mut self.particles[i];
        (particle.thickness, particle.friction) = (thickness, friction);
    }

    /// Whether an animated body is among the obstacles: only then can the
    /// cloth snag on one ([`crate::sim::adaptive`]).
    pub fn has_animated_bodies(&self) -> bool {
        self.obstacles.bodies.iter().any(|b| b.animation.is_some())
    }

    /// Copies what the pipeline carries from one step to the next (each
    /// recurring contact's influence, eq. 16) into `into`, reusing its
    /// storage. Restoring it with [`Self::restore_memory`] makes a retried
    /// step start as the first attempt did.
    pub fn save_memory(&self, into: &mut CollisionMemory) {
        into.0.clone_from(&self.influence);
    }

    /// Puts back what [`Self::save_memory`] saved.
    pub fn restore_memory(&mut self, memory: &CollisionMemory) {
        self.influence.clone_from(&memory.0);
    }

    /// Detects and resolves this step's collisions between `window`'s start
    /// and end, correcting the proposed end positions and velocities. The
    /// obstacles are those [`Self::frame_obstacles`] placed for `window`
    /// (a simulator frames them while its implicit solve runs); without
    /// that, they are framed here, in the frame of the cloth's mean
    /// displacement.
    pub fn resolve(&mut self, cloth: ClothState, window: StepWindow, after_pass: PassHook) -> CollisionReport {
        let mut report = CollisionReport::default();
        let n = cloth.start.len();
        let clock = Instant::now();
        self.load(&cloth, window);
        report.refit += clock.elapsed();
        let mut zoned =
            !self.impulse_passes(window, after_pass, &mut report) && self.zones(window, after_pass, &mut report);
        while zoned && report.zone_corrections < ZONE_CORRECTIONS && self.correct_after_zones(after_pass) {
            report.zone_corrections += 1;
            zoned =
                !self.impulse_passes(window, after_pass, &mut report) && self.zones(window, after_pass, &mut report);
            if report.unresolved > 0 {
                self.undo_correction(&mut report);
                break;
            }
        }
        cloth.end.copy_from_slice(&self.ws.end[..n]);
        cloth.velocity.copy_from_slice(&self.ws.velocity[..n]);
        self.framed = None;
        self.ws.speculative = false;
        report
    }

    /// The normal impulse each cloth particle took from the obstacles
    /// (colliders' meshes and sharp features) in the last resolve's
    /// impulse passes, N·s: how hard the cloth is pressed on the body.
    pub fn obstacle_impulses(&self) -> &[f64] {
        &self.ws.obstacle_impulse
    }
}

#[cfg(test)]
mod tests;
