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
pub mod bvh;
pub mod ccd;
mod detect;
pub mod features;
pub mod geometry;
pub mod obstacles;
mod pair_sort;
mod partners;
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
    /// sharp tops, no longer pays for it (BENCHMARKS, 2026-12-04).
    pub repulsion_stiffness: f64,
    /// Stiffness of the springs that push the cloth off the analytic
    /// colliders' sharp features it rests on (a table's edge, a needle's
    /// tip; not a body's skin) in the implicit solve, N/m; 0 turns them off.
    /// At 30 `drape_table`'s corners keep their strain limit with no impact
    /// zone and its response takes a third of the time, and `needles`' frame
    /// is 40 % shorter (BENCHMARKS, 2026-12-04 afternoon). A weaker spring
    /// pushes the cloth only part of the way and the corners tear more than
    /// with none: 15 is enough at N = 96, not at N = 48, whose coarser edges
    /// carry twice the tension each.
    pub feature_repulsion_stiffness: f64,
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
        let mut first = true;
        let mut settled = false;
        let mut last_shortfall = f64::INFINITY;
        for pass in 0..self.settings.passes {
            if pass == 0 {
                self.detect(Detection::Proximity, Scope::All, &mut report);
            } else {
                self.detect_again(Detection::Proximity, &mut report);
            }
            if first {
                report.contacts = self.ws.contacts.len() as u32;
                first = false;
            }
            if self.ws.contacts.is_empty() {
                settled = true;
                break;
            }
            let progress = self.settings.pass_progress;
            if progress > 0.0 {
                let shortfall = self.total_shortfall(window.h());
                if shortfall > (1.0 - progress) * last_shortfall {
                    break;
                }
                last_shortfall = shortfall;
            }
            let clock = Instant::now();
            report.passes += 1;
            let (constraint_set, acted) = self.respond_pass(window.h());
            report.constraint_set = constraint_set;
            // Every contact within reach was already satisfied, so nothing
            // moved and detecting again would find the same contacts; what
            // the hook corrected after the last pass is what this detection
            // checked. That does not prove nothing crosses (the deficit is
            // linearised along the hit normal), so the impact zones still
            // look for crossings.
            if acted {
                self.run_hook(after_pass, ResponseStage::Impulses);
            }
            report.response += clock.elapsed();
            if !acted {
                break;
            }
        }
        if !settled {
            (report.zone_rounds, report.unresolved) = self.impact_zones(window, after_pass, &mut report);
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

    /// Runs the pass hook after `stage` on the cloth's end positions and
    /// velocities and marks the points it moved.
    fn run_hook(&mut self, hook: PassHook, stage: ResponseStage) {
        let n = self.particles.len();
        let ws = &mut self.ws;
        ws.before_hook.clear();
        ws.before_hook.extend_from_slice(&ws.end[..n]);
        let state = PassState {
            end: &mut ws.end[..n],
            velocity: &mut ws.velocity[..n],
            moved: &ws.moved[..n],
            pushed_off: &ws.pushed_off[..n],
            stage,
        };
        let corrected = hook(state);
        if corrected {
            let hold = stage == ResponseStage::ImpactZones;
            for (i, (before, after)) in ws.before_hook.iter().zip(&ws.end[..n]).enumerate() {
                if before != after {
                    ws.moved[i] = true;
                    if hold {
                        ws.held[i] = Some(Kinematic::Deforming);
                        ws.inverse_mass[i] = 0.0;
                    }
                }
            }
        }
    }

    /// A detection after a response that gives the same contacts as a full
    /// one: the pairs with a point moved since the last proximity detection
    /// go through the broad phase again; of the others, only the feature
    /// pairs that were in contact can be now (each test is a function of its
    /// points' paths, and whatever a crossing detection finds, a proximity
    /// detection found too), so those alone are tested again.
    fn detect_again(&mut self, detection: Detection, report: &mut CollisionReport) {
        let ws = &mut self.ws;
        let moved = &ws.moved;
        ws.kept.clear();
        ws.kept.extend(ws.contacts.iter().filter(|c| c.nodes.iter().all(|&i| !moved[i as usize])));
        self.detect(detection, Scope::Moved, report);
        let Workspace { contacts, found, kept, .. } = &mut self.ws;
        found.clear();
        contacts.retain(|c| found.insert(c.key()));
        kept.clear();
    }

    /// Copies the cloth and obstacle points into the workspace, framing the
    /// obstacles for `window` unless that was done.
    fn load(&mut self, cloth: &ClothState, window: StepWindow) {
        if self.framed != Some(window) {
            self.frame_obstacles(window, detect::mean_displacement(cloth.start, cloth.end));
        }
        let ws = &mut self.ws;
        ws.start.clear();
        ws.start.extend_from_slice(cloth.start);
        ws.start.extend_from_slice(&ws.obstacle_start);
        ws.end.clear();
        ws.end.extend_from_slice(cloth.end);
        ws.end.extend_from_slice(&ws.obstacle_end);
        ws.velocity.clear();
        ws.velocity.extend_from_slice(cloth.velocity);
        ws.velocity.extend(ws.obstacle_start.iter().zip(&ws.obstacle_end).map(|(a, b)| (b - a) / window.h()));
        ws.inverse_mass.clear();
        ws.inverse_mass.extend(
            cloth.mass.iter().zip(&self.particles).map(|(m, p)| if p.pinned.is_some() { 0.0 } else { 1.0 / m }),
        );
        ws.inverse_mass.resize(ws.start.len(), 0.0);
        ws.moved.clear();
        ws.moved.resize(ws.start.len(), false);
        ws.pushed_off.clear();
        ws.pushed_off.resize(self.particles.len(), Vector3::zeros());
        ws.obstacle_impulse.clear();
        ws.obstacle_impulse.resize(self.particles.len(), 0.0);
        ws.held.clear();
        ws.held.resize(cloth.start.len(), None);
    }

    /// How far short of their thickness the contacts would end the step,
    /// summed in thicknesses.
    fn total_shortfall(&self, h: f64) -> f64 {
        let ws = &self.ws;
        ws.contacts.iter().map(|c| c.shortfall(&ws.velocity, h) / c.thickness).sum()
    }

    /// One pass of impulses over every contact, then sweeps over the
    /// constraint set. Returns the constraint set's size, and whether any
    /// contact needed an impulse.
    fn respond_pass(&mut self, h: f64) -> (u32, bool) {
        let (a, threshold) = (self.settings.influence_decay, self.settings.influence_threshold);
        for entry in self.influence.values_mut() {
            entry.1 = false;
        }
        let Workspace { contacts, constraint_set, .. } = &mut self.ws;
        constraint_set.clear();
        for (k, c) in contacts.iter().enumerate() {
            let entry = self.influence.entry(c.key()).or_insert((0.0, false));
            entry.0 = a * entry.0 + 1.0;
            entry.1 = true;
            if entry.0 >= threshold {
                constraint_set.push(k);
            }
        }
        self.influence.retain(|_, (e, seen)| {
            if !*seen {
                *e *= a;
            }
            *e >= FORGOTTEN
        });
        let ws = &mut self.ws;
        let mut points = Points {
            start: &ws.start,
            end: &mut ws.end,
            velocity: &mut ws.velocity,
            inverse_mass: &ws.inverse_mass,
            moved: &mut ws.moved,
            h,
        };
        let n = self.particles.len();
        let holds = &self.obstacles.holds;
        ws.pushed_off.iter_mut().for_each(|p| *p = Vector3::zeros());
        let (pushed_off, obstacle_impulse) = (&mut ws.pushed_off, &mut ws.obstacle_impulse);
        let mut respond = |c: &Contact| {
            let Some(impulse) = points.respond(c) else { return false };
            let cloth_nodes = || c.nodes.iter().zip(&c.hit.weights).filter(|(i, _)| (**i as usize) < n);
            if c.nodes.iter().any(|&i| i as usize >= n) {
                for (&i, &w) in cloth_nodes() {
                    obstacle_impulse[i as usize] += w.abs() * impulse;
                }
            }
            if c.nodes.iter().any(|&i| (i as usize).checked_sub(n).is_some_and(|o| holds[o])) {
                for (&i, &w) in cloth_nodes() {
                    pushed_off[i as usize] += c.hit.normal * w;
                }
            }
            true
        };
        let acted = ws.contacts.iter().fold(false, |acted, c| respond(c) | acted);
        for _ in 0..self.settings.constraint_sweeps {
            let changed = ws.constraint_set.iter().fold(false, |changed, &k| respond(&ws.contacts[k]) | changed);
            if !changed {
                break;
            }
        }
        (ws.constraint_set.len() as u32, acted)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use nalgebra::{Isometry3, Vector3};

    use super::obstacles::{ClothScale, MeshCollider};

    /// A cloth fine enough that no curved collider needs surface features.
    const FINE_CLOTH: ClothScale = ClothScale { longest_edge_m: 0.01, thinnest_m: THICKNESS };
    use super::*;
    use crate::mesh::{TriMesh, generate};
    use crate::sim::colliders::{Collider, Shape};

    const THICKNESS: f64 = 0.005;

    /// A deterministic value in [−1, 1] for index `i` and axis `k`.
    fn wobble(i: usize, k: usize) -> f64 {
        ((i * 3 + k) as f64 * 12.9898).sin() * 43_758.545 % 1.0
    }

    /// A cloth folded onto itself 4 mm apart and shaken by up to 6 mm over
    /// the step, lying on a box's sharp edge and a mesh tetrahedron: its
    /// pipeline with the step loaded, and the cloth's vertex count.
    fn crumpled(representative_triangles: bool) -> (CollisionPipeline, usize) {
        crumpled_by(representative_triangles, 0.006)
    }

    /// [`crumpled`], shaken by up to `shake` (m) over the step.
    fn crumpled_by(representative_triangles: bool, shake: f64) -> (CollisionPipeline, usize) {
        let grid = generate::grid(1.0, 16);
        let start: Vec<Vector3<f64>> =
            grid.positions.iter().map(|p| if p.x > 0.0 { Vector3::new(-p.x, 0.004, p.z) } else { *p }).collect();
        let end: Vec<Vector3<f64>> =
            start.iter().enumerate().map(|(i, p)| p + Vector3::from_fn(|k, _| shake * wobble(i, k))).collect();
        let h = 0.01;
        let mut velocity: Vec<Vector3<f64>> = start.iter().zip(&end).map(|(a, b)| (b - a) / h).collect();
        let mut end_mut = end.clone();
        let mass = vec![1e-3; start.len()];
        let at = |x: f64, y: f64, z: f64| Placement { rest_pose: Isometry3::translation(x, y, z), motion: None };
        let blade = Collider {
            name: "blade".into(),
            shape: Shape::Box { half_extents: Vector3::new(0.3, 0.01, 0.01) },
            placement: at(-0.25, -0.012, 0.0),
            friction: None,
        };
        let tetrahedron = MeshCollider {
            name: "tetrahedron".into(),
            vertices: vec![Vector3::zeros(), Vector3::x() * 0.2, Vector3::z() * 0.2, Vector3::new(0.05, -0.1, 0.05)],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
            placement: at(-0.3, -0.001, -0.3),
            friction: None,
            animation: None,
        };
        let particles = vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; start.len()];
        let settings = CollisionSettings { representative_triangles, ..Default::default() };
        let obstacles = Obstacles::new(&[blade], &[tetrahedron], FINE_CLOTH);
        let triangle_count = grid.triangles.len();
        let mut pipeline =
            CollisionPipeline::new(grid.triangles, vec![0; triangle_count], vec![true], particles, obstacles, settings)
                .unwrap();
        let cloth = ClothState { start: &start, end: &mut end_mut, velocity: &mut velocity, mass: &mass };
        pipeline.load(&cloth, StepWindow { t0: 0.0, t1: h });
        (pipeline, start.len())
    }

    /// The contacts one detection of [`crumpled`] finds and its test counts.
    fn detect_crumpled(representative_triangles: bool) -> (BTreeSet<[u32; 5]>, CollisionReport, u32) {
        let (mut pipeline, n) = crumpled(representative_triangles);
        let mut report = CollisionReport::default();
        pipeline.detect(Detection::Proximity, Scope::All, &mut report);
        (pipeline.ws.contacts.iter().map(Contact::key).collect(), report, n as u32)
    }

    /// Every contact of a pipeline's last detection, with its hit, as text.
    fn contact_set(pipeline: &CollisionPipeline) -> BTreeSet<String> {
        pipeline.ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect()
    }

    /// After a response pass and a pass hook that moved other points, the
    /// incremental detection finds exactly the contacts (and hits) a full
    /// detection of the same state finds, for both kinds of detection.
    #[test]
    fn detecting_again_after_a_response_equals_a_full_detection_and_reboxes_only_what_moved() {
        for detection in [Detection::Proximity, Detection::Crossings] {
            let (mut pipeline, n) = crumpled(true);
            let mut report = CollisionReport::default();
            pipeline.detect(Detection::Proximity, Scope::All, &mut report);
            let (_, acted) = pipeline.respond_pass(0.01);
            let mut lift = |pass: PassState| {
                pass.end.iter_mut().step_by(7).for_each(|p| p.y += 0.001);
                true
            };
            assert!(acted);
            pipeline.run_hook(&mut lift, ResponseStage::Impulses);
            let moved = pipeline.ws.moved.iter().filter(|&&m| m).count();
            assert!(moved > n / 7 && moved < n, "points moved, not all: {moved} of {n}");
            let mut full = pipeline.clone();
            full.detect(detection, Scope::All, &mut report);
            pipeline.detect_again(detection, &mut report);
            // Only the moved points' boxes were made again, and they are all
            // as a full detection makes them.
            assert_eq!(pipeline.ws.node_box, full.ws.node_box);
            assert_eq!(pipeline.ws.feature_box, full.ws.feature_box);
            assert_eq!(pipeline.ws.triangle_box, full.ws.triangle_box);
            assert_eq!(pipeline.ws.point_slabs, full.ws.point_slabs);
            assert_eq!(pipeline.ws.triangle_slabs, full.ws.triangle_slabs);
            let (again, full) = (contact_set(&pipeline), contact_set(&full));
            assert!(!full.is_empty());
            let only_again: Vec<_> = again.difference(&full).collect();
            let only_full: Vec<_> = full.difference(&again).collect();
            assert!(only_again.is_empty() && only_full.is_empty(), "{detection:?}: {only_again:?} vs {only_full:?}");
        }
    }

    /// The pass hook runs after every impulse pass and every impact-zone
    /// round with the points the response moved; a point it moves after a
    /// round (as an analytic collider pushing it out would) keeps that
    /// position, held, while the zones go on around it; and the crossings the
    /// pipeline reports are those of its final positions.
    #[test]
    fn zone_rounds_are_corrected_by_the_hook_and_hold_what_it_moved() {
        let (mut pipeline, n) = crumpled(true);
        pipeline.settings.passes = 1;
        let start = pipeline.ws.start[..n].to_vec();
        let mut end = pipeline.ws.end[..n].to_vec();
        let mut velocity = pipeline.ws.velocity[..n].to_vec();
        let mass = vec![1e-3; n];
        let window = StepWindow { t0: 0.0, t1: 0.01 };
        let mut stages = Vec::new();
        let mut pushed: HashMap<usize, (u32, Vector3<f64>)> = HashMap::new();
        let mut hook = |pass: PassState| {
            stages.push(pass.stage);
            if pass.stage == ResponseStage::Impulses {
                return false;
            }
            for (i, p) in pass.end.iter_mut().enumerate().filter(|(i, _)| pass.moved[*i]) {
                p.y += 5e-4;
                let entry = pushed.entry(i).or_insert((0, *p));
                *entry = (entry.0 + 1, *p);
            }
            pass.moved.iter().any(|&m| m)
        };
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        let report = pipeline.resolve(cloth, window, &mut hook);
        assert_eq!(stages[0], ResponseStage::Impulses);
        assert!(stages.contains(&ResponseStage::ImpactZones) && !pushed.is_empty(), "{stages:?}");
        for (i, (times, at)) in &pushed {
            assert_eq!(*times, 1, "point {i} was pushed once, then held");
            assert_eq!(end[*i], *at, "point {i} ends where the hook put it");
        }
        let (mut check, _) = crumpled(true);
        let cloth = ClothState { start: &start, end: &mut end.clone(), velocity: &mut velocity, mass: &mass };
        check.load(&cloth, window);
        check.detect(Detection::Crossings, Scope::All, &mut CollisionReport::default());
        assert_eq!(report.unresolved as usize, check.ws.contacts.len(), "the report is the final positions'");
    }

    /// The passes stop at the first one whose contacts all hold without an
    /// impulse, and the hook does not run after it: it has nothing new to
    /// correct, and what it corrected the pass before is what that pass's
    /// detection checked.
    #[test]
    fn passes_end_at_the_first_that_needs_no_impulse_without_the_hook() {
        let (mut pipeline, n) = crumpled(true);
        pipeline.settings.passes = 50;
        let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
        let mut velocity = pipeline.ws.velocity[..n].to_vec();
        let mass = vec![1e-3; n];
        let mut hooked = 0;
        let mut hook = |pass: PassState| {
            hooked += u32::from(pass.stage == ResponseStage::Impulses);
            false
        };
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        let report = pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut hook);
        assert!(report.passes > 1 && report.passes < 50, "{report:?}");
        assert_eq!(hooked, report.passes - 1, "the hook ran after every pass but the last");
    }

    /// A hook that undoes every pass (as strain limits pulling a cloth back
    /// over a table's corner can) leaves the contacts as short as before:
    /// the passes stop after the first, where without the progress check
    /// they would run to their limit, and the impact zones still end the
    /// step with nothing crossing.
    #[test]
    fn passes_stop_when_the_hook_undoes_them() {
        let run = |pass_progress: f64| {
            let (mut pipeline, n) = crumpled(true);
            pipeline.settings.pass_progress = pass_progress;
            let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
            let mut velocity = pipeline.ws.velocity[..n].to_vec();
            let (proposed_end, proposed_velocity) = (end.clone(), velocity.clone());
            let mass = vec![1e-3; n];
            let mut undo = |pass: PassState| {
                if pass.stage == ResponseStage::ImpactZones {
                    return false;
                }
                pass.end.copy_from_slice(&proposed_end);
                pass.velocity.copy_from_slice(&proposed_velocity);
                true
            };
            let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
            pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut undo)
        };
        let (checked, unchecked) = (run(0.3), run(0.0));
        assert_eq!(checked.passes, 1, "{checked:?}");
        assert_eq!(unchecked.passes, CollisionSettings::default().passes, "{unchecked:?}");
        assert_eq!(checked.unresolved, 0, "{checked:?}");
    }

    /// A cloth folded onto itself and shaken, with no obstacle, its whole
    /// motion over the step offset by `carried` (m): the contacts it finds
    /// and the detection's report.
    fn detect_folded(carried: Vector3<f64>) -> (BTreeSet<[u32; 5]>, CollisionReport) {
        let (pipeline, n) = crumpled(true);
        let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
        end.iter_mut().for_each(|p| *p += carried);
        let mut velocity = vec![Vector3::zeros(); n];
        let particles = pipeline.particles.clone();
        let triangles = pipeline.triangles.clone();
        let count = triangles.len();
        let obstacles = Obstacles::new(&[], &[], FINE_CLOTH);
        let mut folded =
            CollisionPipeline::new(triangles, vec![0; count], vec![true], particles, obstacles, Default::default())
                .unwrap();
        let mass = vec![1e-3; n];
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        folded.load(&cloth, StepWindow { t0: 0.0, t1: 0.01 });
        let mut report = CollisionReport::default();
        folded.detect(Detection::Proximity, Scope::All, &mut report);
        (folded.ws.contacts.iter().map(Contact::key).collect(), report)
    }

    /// Every feature pair within the thickness at an end of the step, or
    /// crossing during it, by brute force over all pairs of the crumpled
    /// cloth (vertex-triangle and edge-edge within the cloth, against the
    /// tetrahedron's triangles, edges and vertices, and against the blade's
    /// sharp edges and vertices): the contacts a detection finds through its
    /// boxes, hierarchies and owned features are exactly these.
    #[test]
    fn a_detection_finds_every_contact_a_brute_force_over_all_feature_pairs_finds() {
        let (found, expected, n) = detected_and_brute_force(crumpled(true));
        assert!(expected.len() > 100 && expected.iter().any(|k| k[4] >= n as u32), "the fold and the obstacles touch");
        assert_eq!(found, expected);
    }

    /// The same, with the cloth shaken by most of an edge over the step:
    /// triangles that share a vertex fold onto each other all over it.
    #[test]
    fn a_cloth_shaken_by_an_edge_finds_every_contact_a_brute_force_finds() {
        let (found, expected, _) = detected_and_brute_force(crumpled_by(true, 0.05));
        assert!(expected.len() > 1000, "{} contacts", expected.len());
        assert_eq!(found, expected);
    }

    /// The contacts one detection of a loaded `pipeline` (with `n` cloth
    /// points) finds, and those a brute force over all feature pairs finds.
    fn detected_and_brute_force(
        (mut pipeline, n): (CollisionPipeline, usize),
    ) -> (BTreeSet<[u32; 5]>, BTreeSet<[u32; 5]>, usize) {
        use super::ccd::{Path, edge_edge, vertex_triangle};
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        let found: BTreeSet<[u32; 5]> = pipeline.ws.contacts.iter().map(Contact::key).collect();

        let ws = &pipeline.ws;
        let path = |i: u32| Path { start: ws.start[i as usize], end: ws.end[i as usize] };
        let edges_of = |triangles: &[[u32; 3]]| -> BTreeSet<[u32; 2]> {
            let edge = |t: &[u32; 3], k: usize| [t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])];
            triangles.iter().flat_map(|t| (0..3).map(move |k| edge(t, k))).collect()
        };
        let offset = |v: u32| v + n as u32;
        let cloth_triangles = pipeline.triangles.clone();
        let obstacle_triangles: Vec<[u32; 3]> = pipeline.obstacles.triangles.iter().map(|t| t.map(offset)).collect();
        let cloth_edges = edges_of(&cloth_triangles);
        let mut obstacle_edges = edges_of(&obstacle_triangles);
        obstacle_edges.extend(pipeline.obstacles.feature_edges.iter().map(|e| e.map(offset)));
        let mut obstacle_vertices: BTreeSet<u32> = obstacle_triangles.iter().flatten().copied().collect();
        obstacle_vertices.extend(pipeline.obstacles.feature_vertices.iter().map(|&v| offset(v)));

        let mut expected = BTreeSet::new();
        let mut vertex_against = |v: u32, tri: [u32; 3]| {
            if !tri.contains(&v)
                && vertex_triangle(&path(v), &path(tri[0]), &path(tri[1]), &path(tri[2]), THICKNESS).is_some()
            {
                let mut sorted = tri;
                sorted.sort_unstable();
                expected.insert([0, v, sorted[0], sorted[1], sorted[2]]);
            }
        };
        for v in 0..n as u32 {
            cloth_triangles.iter().chain(&obstacle_triangles).for_each(|&tri| vertex_against(v, tri));
        }
        for &v in &obstacle_vertices {
            cloth_triangles.iter().for_each(|&tri| vertex_against(v, tri));
        }
        let mut edge_against = |a: [u32; 2], b: [u32; 2]| {
            if !a.iter().any(|v| b.contains(v))
                && edge_edge(&path(a[0]), &path(a[1]), &path(b[0]), &path(b[1]), THICKNESS).is_some()
            {
                let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
                expected.insert([1, lo[0], lo[1], hi[0], hi[1]]);
            }
        };
        for &a in &cloth_edges {
            cloth_edges.range(a..).chain(&obstacle_edges).for_each(|&b| edge_against(a, b));
        }
        // Triangles that share a vertex touch (at the fold, or where shaken):
        // the hierarchy leaves those pairs to the adjacent triangles' lists.
        let joined = |a: u32, b: u32| cloth_edges.contains(&[a.min(b), a.max(b)]);
        let adjacent = |k: &[u32; 5]| k[0] == 0 && k[2..].iter().any(|&corner| joined(k[1], corner));
        assert!(expected.iter().any(adjacent), "adjacent triangles touch");
        (found, expected, n)
    }

    /// Boxes are taken in a frame moving with the cloth's mean displacement:
    /// a cloth carried 0.3 m in a step (50 times its own shaking) finds the
    /// same contacts, after as many box tests, as the same cloth not carried.
    #[test]
    fn a_carried_cloth_finds_the_same_contacts_after_as_many_tests() {
        let (still, still_report) = detect_folded(Vector3::zeros());
        let (carried, carried_report) = detect_folded(Vector3::new(0.3, -0.1, 0.05));
        assert!(still.len() > 100, "the fold touches: {}", still.len());
        assert_eq!(still, carried);
        let (a, b) = (still_report.tests as f64, carried_report.tests as f64);
        assert!((a - b).abs() <= 0.01 * a, "{a} tests at rest, {b} carried");
    }

    /// The frame the boxes are taken in changes which boxes overlap, never
    /// the contacts: framed by the cloth's mean displacement (as `resolve`
    /// does unaided), by none, or by a far-off shift (as a simulator's
    /// prediction from the start velocities might be), one detection finds
    /// the same contacts, with the same hits, in the same order.
    #[test]
    fn any_frame_for_the_boxes_gives_the_same_contacts_in_the_same_order() {
        let contacts = |shift: Option<Vector3<f64>>| {
            let (mut pipeline, _) = crumpled(true);
            if let Some(shift) = shift {
                pipeline.frame_obstacles(StepWindow { t0: 0.0, t1: 0.01 }, shift);
            }
            pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
            pipeline.ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect::<Vec<_>>()
        };
        let by_mean_displacement = contacts(None);
        assert!(by_mean_displacement.len() > 100, "the fold touches: {}", by_mean_displacement.len());
        for shift in [Vector3::zeros(), Vector3::new(0.3, -0.2, 0.1)] {
            assert_eq!(contacts(Some(shift)), by_mean_displacement, "framed by {shift:?}");
        }
    }

    /// How a test predicts the end of cloth point `i` from its start and
    /// real end, m.
    type Prediction = fn(usize, &Vector3<f64>, &Vector3<f64>) -> Vector3<f64>;

    /// [`crumpled`] with its motion over the step scaled by `scale`, its
    /// broad phase speculated from `prediction` (if any), and its cloth's
    /// start, end and velocity.
    fn speculated(scale: f64, prediction: Option<Prediction>) -> (CollisionPipeline, [Vec<Vector3<f64>>; 3]) {
        let (mut pipeline, n) = crumpled(true);
        let ws = &mut pipeline.ws;
        for i in 0..n {
            ws.end[i] = ws.start[i] + (ws.end[i] - ws.start[i]) * scale;
        }
        let (start, end, velocity) = (ws.start[..n].to_vec(), ws.end[..n].to_vec(), ws.velocity[..n].to_vec());
        if let Some(predict) = prediction {
            let predicted: Vec<Vector3<f64>> = (0..n).map(|i| predict(i, &start[i], &end[i])).collect();
            pipeline.speculate(StepWindow { t0: 0.0, t1: 0.01 }, &start, &predicted);
            assert!(pipeline.ws.speculative, "the obstacles are framed for the step");
        }
        (pipeline, [start, end, velocity])
    }

    /// Predictions of a cloth's ends: exact, no motion, off by up to 3 cm,
    /// and backwards.
    const PREDICTIONS: [(Prediction, &str); 4] = [
        (|_, _, end| *end, "exact"),
        (|_, start, _| *start, "no motion"),
        (|i, _, end| end + Vector3::from_fn(|k, _| 0.03 * wobble(i + 7, k)), "off by up to 3 cm"),
        (|_, start, end| start * 2.0 - end, "backwards"),
    ];

    /// However good the prediction the broad phase was speculated from, the
    /// first detection finds the same pairs and the same contacts, with the
    /// same hits, in the same order, as one without; where the prediction
    /// is poor, triangles escape their speculative boxes (the fold moves up
    /// to 24 mm, beyond the margin).
    #[test]
    fn a_speculated_broad_phase_gives_the_same_contacts_in_the_same_order_for_any_prediction() {
        let detect = |prediction: Option<Prediction>| {
            let (mut pipeline, _) = speculated(4.0, prediction);
            pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
            let ws = &pipeline.ws;
            let contacts: Vec<String> = ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect();
            (contacts, ws.pairs.clone(), ws.mesh_pairs.clone(), ws.moved_list.len(), pipeline.triangles.len())
        };
        let (contacts, pairs, mesh_pairs, _, triangles) = detect(None);
        assert!(contacts.len() > 100 && !mesh_pairs.is_empty(), "the fold touches, and the tetrahedron is near");
        for (k, (prediction, name)) in PREDICTIONS.into_iter().enumerate() {
            let (speculated_contacts, speculated_pairs, speculated_mesh_pairs, escaped, _) = detect(Some(prediction));
            assert_eq!(speculated_contacts, contacts, "contacts, {name}");
            assert_eq!((speculated_pairs, speculated_mesh_pairs), (pairs.clone(), mesh_pairs.clone()), "pairs, {name}");
            match k {
                0 => assert_eq!(escaped, 0, "{name}"),
                _ => assert!(escaped > 0 && escaped < triangles, "{name}: {escaped} of {triangles} escape"),
            }
        }
    }

    /// A whole step's response ends in the same bits whether its first
    /// broad phase was speculated or not: the later detections, whose
    /// hierarchy keeps the speculative (larger) boxes of the triangles that
    /// did not move, find the same pairs too (the last one's are counted).
    #[test]
    fn a_speculated_step_ends_where_an_unspeculated_one_does() {
        let resolve = |prediction: Option<Prediction>| {
            let (mut pipeline, [start, mut end, mut velocity]) = speculated(2.0, prediction);
            let mass = vec![1e-3; start.len()];
            let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
            let report = pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut |_: PassState| false);
            (end, velocity, report.passes, report.contacts, report.pairs)
        };
        let unspeculated = resolve(None);
        assert!(unspeculated.2 > 1, "several passes: {}", unspeculated.2);
        for (prediction, name) in PREDICTIONS {
            assert!(resolve(Some(prediction)) == unspeculated, "{name}");
        }
    }

    /// After a speculated first detection, later detections read the moved
    /// triangles' leaf partners instead of querying the hierarchy; they
    /// find the same pairs, body pairs and contacts, in the same order, as
    /// the queries of an unspeculated step, pass after pass: when the
    /// response moved the points a little (each triangle stays in its
    /// leaf), further than the margin (they escape, get new leaves and are
    /// queried from then on), and then only points away from those (their
    /// triangles must find the escaped ones in their lists).
    #[test]
    fn later_detections_from_leaf_partners_find_what_queries_find() {
        let passes = |prediction: Option<Prediction>| {
            let (mut pipeline, _) = speculated(2.0, prediction);
            pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
            let n = pipeline.particles.len();
            let mut far_moved = vec![false; n];
            let mut found = Vec::new();
            for (pass, stride, reach) in [(1, 4, 0.001), (2, 29, 0.2), (3, 3, 0.0005)] {
                let ws = &mut pipeline.ws;
                for i in (pass..n).step_by(stride).filter(|&i| !far_moved[i]) {
                    ws.end[i] += Vector3::from_fn(|k, _| reach * wobble(i + pass, k));
                    ws.moved[i] = true;
                }
                pipeline.detect(Detection::Proximity, Scope::Moved, &mut CollisionReport::default());
                let ws = &pipeline.ws;
                let contacts: Vec<String> = ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect();
                found.push((ws.pairs.clone(), ws.mesh_pairs.clone(), contacts, ws.escaping.len()));
                if pass == 2 {
                    for &t in &ws.moved_list {
                        pipeline.triangles[t as usize].iter().for_each(|&v| far_moved[v as usize] = true);
                    }
                }
            }
            (found, pipeline.ws.partners.valid())
        };
        let (queried, listed) = passes(None);
        assert!(!listed, "without speculation nothing is listed");
        for (pairs, mesh_pairs, contacts, _) in &queried {
            assert!(pairs.len() > 20 && !mesh_pairs.is_empty() && !contacts.is_empty(), "{}", pairs.len());
        }
        for (prediction, name) in PREDICTIONS {
            let (found, listed) = passes(Some(prediction));
            assert!(listed, "{name}: the partners are listed");
            for (pass, (got, want)) in found.iter().zip(&queried).enumerate() {
                assert_eq!((&got.0, &got.1, &got.2), (&want.0, &want.1, &want.2), "{name}, pass {}", pass + 1);
            }
            let escaping: Vec<usize> = found.iter().map(|f| f.3).collect();
            assert!(escaping[1] > 0, "{name}: 20 cm moves escape the leaves ({escaping:?})");
        }
    }

    /// Two cloth triangles 30 cm apart, the first sliding onto the second
    /// and onto a floor patch 3 mm below it within the step, speculated as
    /// if nothing moved: the first escapes its speculative box, and only
    /// its own queries find the pairs its real box meets.
    #[test]
    fn an_escaped_triangle_finds_the_pairs_its_real_box_meets() {
        let detect = |speculate: bool| {
            let triangle =
                |x: f64, y: f64| [Vector3::new(x, y, 0.0), Vector3::new(x + 0.1, y, 0.0), Vector3::new(x, y, 0.1)];
            let start: Vec<Vector3<f64>> = [triangle(0.0, 0.0), triangle(0.3, 0.002)].concat();
            let mut end = start.clone();
            end[..3].iter_mut().for_each(|p| p.x += 0.3);
            let floor = MeshCollider {
                placement: Placement { rest_pose: Isometry3::translation(0.35, -0.003, 0.05), motion: None },
                ..floor_below()
            };
            let floor = MeshCollider {
                vertices: generate::grid(0.1, 2).positions,
                triangles: generate::grid(0.1, 2).triangles,
                ..floor
            };
            let particles = vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; 6];
            let obstacles = Obstacles::new(&[], &[floor], FINE_CLOTH);
            let mut pipeline = CollisionPipeline::new(
                vec![[0, 1, 2], [3, 4, 5]],
                vec![0, 0],
                vec![true],
                particles,
                obstacles,
                Default::default(),
            )
            .unwrap();
            let (mut velocity, mass) = (vec![Vector3::zeros(); 6], vec![1e-3; 6]);
            let window = StepWindow { t0: 0.0, t1: 0.01 };
            pipeline.load(
                &ClothState { start: &start, end: &mut end.clone(), velocity: &mut velocity, mass: &mass },
                window,
            );
            if speculate {
                pipeline.speculate(window, &start, &start);
            }
            pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
            let ws = &pipeline.ws;
            (ws.pairs.clone(), ws.mesh_pairs.len(), ws.contacts.len(), ws.moved_list.clone())
        };
        let (pairs, mesh_pairs, contacts, _) = detect(false);
        assert_eq!(pairs, vec![(0, 1)]);
        assert!(mesh_pairs > 0 && contacts > 0, "{mesh_pairs} body pairs, {contacts} contacts");
        assert_eq!(detect(true), (pairs, mesh_pairs, contacts, vec![0]));
    }

    /// A 1.2 m square floor mesh 4 mm below a grid cloth at rest.
    fn floor_below() -> MeshCollider {
        let floor = generate::grid(1.2, 23);
        MeshCollider {
            name: "floor".into(),
            vertices: floor.positions,
            triangles: floor.triangles,
            placement: Placement { rest_pose: Isometry3::translation(0.05, -0.004, 0.0), motion: None },
            friction: None,
            animation: None,
        }
    }

    /// The pipeline of cloth `mesh`, without self-collision, against `obstacles`.
    fn without_self_collision(mesh: TriMesh, obstacles: Obstacles) -> CollisionPipeline {
        let particles =
            vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; mesh.positions.len()];
        let count = mesh.triangles.len();
        CollisionPipeline::new(mesh.triangles, vec![0; count], vec![false], particles, obstacles, Default::default())
            .unwrap()
    }

    /// A cloth falling 6 cm in a step through a mesh floor 4 cm below it,
    /// with its obstacles framed for a cloth predicted not to move: every
    /// floor triangle lies beyond the region the obstacles are boxed in and
    /// is parked, and the first detection boxes those near the cloth's real
    /// boxes before its broad phase. It finds the same pairs and contacts, in
    /// the same order, as with every triangle boxed; the floor's far parts
    /// stay parked.
    #[test]
    fn parked_obstacle_triangles_are_boxed_when_the_cloth_reaches_them() {
        let window = StepWindow { t0: 0.0, t1: 0.01 };
        let detect = |near: bool| {
            let grid = generate::grid(0.3, 7);
            let start = grid.positions.clone();
            let mut end: Vec<Vector3<f64>> = start.iter().map(|p| p - Vector3::y() * 0.06).collect();
            let mut velocity = vec![Vector3::y() * -6.0; start.len()];
            let mut floor = floor_below();
            floor.placement.rest_pose = Isometry3::translation(0.0, -0.04, 0.0);
            let mut pipeline = without_self_collision(grid, Obstacles::new(&[], &[floor], FINE_CLOTH));
            let mass = vec![1e-3; start.len()];
            let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
            pipeline.load(&cloth, window);
            let parked =
                |pipeline: &CollisionPipeline| pipeline.ws.obstacle_box.iter().filter(|b| b.is_empty()).count();
            if near {
                pipeline.frame_obstacles_near(window, Vector3::zeros(), (&start, &start));
                assert_eq!(parked(&pipeline), pipeline.obstacles.triangles.len(), "the whole floor is parked");
                pipeline.speculate(window, &start, &start);
            }
            pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
            let contacts: Vec<String> =
                pipeline.ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect();
            (contacts, pipeline.ws.mesh_pairs.clone(), parked(&pipeline), pipeline.obstacles.triangles.len())
        };
        let (contacts, pairs, parked, _) = detect(false);
        assert!(contacts.len() > 40 && parked == 0, "the cloth goes through the floor: {} contacts", contacts.len());
        let (near_contacts, near_pairs, near_parked, floor) = detect(true);
        assert_eq!((near_contacts, near_pairs), (contacts, pairs));
        assert!(near_parked > floor / 2 && near_parked < floor, "{near_parked} of {floor} floor triangles parked");
    }

    /// The mesh colliders' hierarchy and the cloth's, traversed together,
    /// give exactly the (obstacle, cloth) triangle pairs whose boxes
    /// overlap; after a response, the moved cloth triangles' queries give
    /// exactly those of them that hold a moved triangle.
    #[test]
    fn mesh_collider_pairs_are_every_overlapping_pair() {
        let grid = generate::grid(1.0, 16);
        let start = grid.positions.clone();
        let end: Vec<Vector3<f64>> =
            start.iter().enumerate().map(|(i, p)| p + Vector3::from_fn(|k, _| 0.006 * wobble(i, k))).collect();
        let mut velocity = vec![Vector3::zeros(); start.len()];
        let mut pipeline = without_self_collision(grid, Obstacles::new(&[], &[floor_below()], FINE_CLOTH));
        let mass = vec![1e-3; start.len()];
        let cloth = ClothState { start: &start, end: &mut end.clone(), velocity: &mut velocity, mass: &mass };
        pipeline.load(&cloth, StepWindow { t0: 0.0, t1: 0.01 });
        let overlapping = |ws: &Workspace, wanted: &dyn Fn(usize) -> bool| {
            let mut pairs = Vec::new();
            for (t, obstacle) in ws.obstacle_box.iter().enumerate() {
                let hits = ws.triangle_box.iter().enumerate().filter(|(h, b)| wanted(*h) && b.overlaps(obstacle));
                pairs.extend(hits.map(|(h, _)| (t as u32, h as u32)));
            }
            pairs
        };
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        let all = overlapping(&pipeline.ws, &|_| true);
        assert!(all.len() > 1000, "the cloth lies on the floor: {} pairs", all.len());
        assert_eq!(pipeline.ws.mesh_pairs, all);
        pipeline.ws.moved.iter_mut().step_by(5).for_each(|m| *m = true);
        pipeline.detect(Detection::Proximity, Scope::Moved, &mut CollisionReport::default());
        let moved_triangle = pipeline.ws.moved_triangle.clone();
        let moved = overlapping(&pipeline.ws, &|h| moved_triangle[h]);
        assert!(!moved.is_empty() && moved.len() < all.len(), "{} of {}", moved.len(), all.len());
        assert_eq!(pipeline.ws.mesh_pairs, moved);
    }

    /// A 1 m cloth falling 1 cm in a step from 4 mm above `analytic` and
    /// `meshes`: what the hook sees after the first impulse pass, per
    /// particle: the normal it was pushed off a mesh along, and whether the
    /// pass moved it.
    fn first_pass_pushes(analytic: &[Collider], meshes: &[MeshCollider]) -> (Vec<Vector3<f64>>, Vec<bool>) {
        let grid = generate::grid(1.0, 16);
        let start = grid.positions.clone();
        let mut end: Vec<Vector3<f64>> = start.iter().map(|p| p - Vector3::new(0.0, 0.01, 0.0)).collect();
        let mut velocity = vec![Vector3::new(0.0, -1.0, 0.0); start.len()];
        let mut pipeline = without_self_collision(grid, Obstacles::new(analytic, meshes, FINE_CLOTH));
        let mass = vec![1e-3; start.len()];
        let mut first_pass = None;
        let mut hook = |pass: PassState| {
            if first_pass.is_none() {
                first_pass = Some((pass.pushed_off.to_vec(), pass.moved.to_vec()));
            }
            false
        };
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut hook);
        first_pass.expect("the cloth hits the obstacle")
    }

    /// The hook learns which particles this pass's impulses pushed off a
    /// mesh collider, and which way: a cloth falling through a floor is
    /// pushed up. Pushes off an analytic collider's sharp edge, around which
    /// the cloth wraps, do not count; off a rod thinner than the cloth's
    /// edges, which the cloth cannot wrap, they do.
    #[test]
    fn the_hook_sees_what_was_pushed_off_a_mesh_and_which_way() {
        let (pushed_off, moved) = first_pass_pushes(&[], &[floor_below()]);
        for (i, n) in pushed_off.iter().enumerate() {
            assert!(moved[i] && n.normalize().y > 0.99, "particle {i} falls through the floor: {n}");
        }
        // A bar along X of square section `side` m, its top 4 mm below the cloth.
        let bar = |side: f64| Collider {
            name: "bar".into(),
            shape: Shape::Box { half_extents: Vector3::new(0.3, side / 2.0, side / 2.0) },
            placement: Placement { rest_pose: Isometry3::translation(-0.25, -0.004 - side / 2.0, 0.0), motion: None },
            friction: None,
        };
        let (pushed_off, moved) = first_pass_pushes(&[bar(0.02)], &[]);
        assert!(moved.iter().any(|&m| m), "the blade's edges push the cloth");
        assert!(pushed_off.iter().all(|n| *n == Vector3::zeros()));
        let rod = bar(0.008);
        let (pushed_off, moved) = first_pass_pushes(&[rod], &[]);
        let held: Vec<usize> = (0..pushed_off.len()).filter(|&i| pushed_off[i] != Vector3::zeros()).collect();
        assert!(!held.is_empty(), "an 8 mm rod under a 10 mm cloth holds what it pushes");
        for i in held {
            assert!(moved[i] && pushed_off[i].y > 0.0, "particle {i} pushed along {}", pushed_off[i]);
        }
    }

    /// PAPER Algorithm 1: owning each feature once finds exactly the contacts
    /// that testing every feature of every triangle finds, with fewer tests.
    #[test]
    fn representative_triangles_find_the_same_contacts_with_fewer_tests() {
        let (owned, with, cloth_vertices) = detect_crumpled(true);
        let (all, without, _) = detect_crumpled(false);
        assert!(owned.len() > 200, "a crumpled cloth has many contacts: {}", owned.len());
        assert!(owned.iter().any(|k| k[0] == 0) && owned.iter().any(|k| k[0] == 1), "both kinds");
        assert!(owned.iter().any(|k| k[1..].iter().any(|&v| v >= cloth_vertices)), "obstacle contacts too");
        assert_eq!(owned, all);
        assert_eq!(with.tests_without_ownership, without.tests, "the count without ownership is what it would run");
        assert!((with.tests as f64) < 0.6 * without.tests as f64, "{} vs {}", with.tests, without.tests);
    }
}
