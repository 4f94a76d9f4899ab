//! Collisions of cloth triangles with each other, with triangle-mesh colliders
//! and with the sharp features of analytic colliders (PAPER sections 3-4,
//! Algorithm 1).
//!
//! One step's pipeline, after the implicit solve has proposed where every
//! particle goes:
//!
//! 1. **refit**: each cloth triangle's box over the whole step (start and
//!    proposed end of its corners, grown by the thickness) refits a BVH built
//!    once;
//! 2. **broad**: overlapping triangle pairs (within a garment only if its
//!    self-collision is on), cloth triangles near mesh-collider triangles and
//!    near sharp obstacle features;
//! 3. **narrow**: for each pair, only the features the triangles own
//!    (representative triangles), each first culled by its own box and by a
//!    distance bound, then tested by continuous collision detection;
//! 4. **response**: detect → respond passes of inelastic impulses with
//!    friction; contacts that keep coming back gain influence (eq. 16) and,
//!    above the threshold, are solved together as a constraint set; what is
//!    still crossing after the passes is made to move in rigid impact zones
//!    until nothing crosses.
//!
//! A scene without self-collision and without mesh or sharp colliders builds
//! none of this; a step whose boxes do not overlap runs no narrow phase.

pub mod bvh;
pub mod ccd;
pub mod features;
pub mod geometry;
pub mod obstacles;
pub mod response;

use std::collections::HashMap;
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use self::bvh::{Box3, SweptBvh};
use self::ccd::{Hit, Path, edge_edge_within, vertex_triangle_within};
use self::features::Ownership;
use self::obstacles::Obstacles;
use self::response::{Contact, ContactKind, Points, Zones, rigidify};
use super::motion::Placement;

/// Candidate jobs per parallel chunk of the narrow phase.
const JOBS_PER_CHUNK: usize = 512;
/// Influence below which a contact is forgotten.
const FORGOTTEN: f64 = 1e-3;
/// Distance at which impact zones and the final verdict count two features
/// as touching, m: a true crossing, not a thickness violation. A rigid zone
/// keeps its members' distances, so pairs inside it that start apart stay
/// apart; with the thickness instead, a pair that started closer than it
/// would be reported forever.
const CROSSING_GAP: f64 = 1e-6;

/// Which candidate pairs a detection tests.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scope {
    /// Every pair the broad phase finds.
    All,
    /// Only pairs with a point whose path changed since the last detection:
    /// the others would give the same answer as last time (no contact, or one
    /// that needed nothing).
    Moved,
}

/// What a detection looks for.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Detection {
    /// Crossings within the step and features closer than the thickness at
    /// its ends: what the impulse passes answer.
    Proximity,
    /// Only features that actually meet during the step: what the impact
    /// zones must remove.
    Crossings,
}

impl Detection {
    /// The distance within which features count as touching, m, for a
    /// contact that must keep `thickness`.
    fn reach(self, thickness: f64) -> f64 {
        match self {
            Detection::Proximity => thickness,
            Detection::Crossings => CROSSING_GAP,
        }
    }
}

/// The collision constants of a scene (PAPER Fig. 10c).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CollisionSettings {
    /// Detect → respond passes per step before impact zones take over.
    #[serde(default = "default_passes")]
    pub passes: u32,
    /// Factor `a` by which a contact's influence decays when it is not seen
    /// again (eq. 16), in (0, 1).
    #[serde(default = "default_decay")]
    pub influence_decay: f64,
    /// Influence at which a contact joins the constraint set solved together.
    #[serde(default = "default_threshold")]
    pub influence_threshold: f64,
    /// Sweeps over the constraint set per pass.
    #[serde(default = "default_sweeps")]
    pub constraint_sweeps: u32,
    /// Rounds of impact-zone merging before a step gives up.
    #[serde(default = "default_zone_rounds")]
    pub zone_rounds: u32,
    /// Test each vertex and edge once, from the one triangle that owns it
    /// (PAPER Algorithm 1); off tests them from every incident triangle, for
    /// comparison only: the contacts found are the same.
    #[serde(default = "default_representative")]
    pub representative_triangles: bool,
}

fn default_passes() -> u32 {
    6
}
fn default_decay() -> f64 {
    0.5
}
fn default_threshold() -> f64 {
    1.5
}
fn default_sweeps() -> u32 {
    8
}
fn default_zone_rounds() -> u32 {
    40
}
fn default_representative() -> bool {
    true
}

impl Default for CollisionSettings {
    fn default() -> Self {
        CollisionSettings {
            passes: default_passes(),
            influence_decay: default_decay(),
            influence_threshold: default_threshold(),
            constraint_sweeps: default_sweeps(),
            zone_rounds: default_zone_rounds(),
            representative_triangles: default_representative(),
        }
    }
}

/// What collision processing did in one step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CollisionReport {
    /// BVH refits.
    pub refit: Duration,
    /// Broad phase.
    pub broad: Duration,
    /// Narrow phase (continuous collision detection).
    pub narrow: Duration,
    /// Impulses, constraint set and impact zones.
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
    pub pinned: Option<Placement>,
}

/// A unit of narrow-phase work.
#[derive(Clone, Copy, Debug)]
enum Job {
    /// Two cloth triangles.
    Cloth(u32, u32),
    /// A cloth triangle and a mesh-collider triangle.
    Mesh(u32, u32),
    /// A cloth triangle and a sharp obstacle vertex.
    Vertex(u32, u32),
    /// A cloth triangle and a sharp obstacle edge.
    Edge(u32, u32),
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
    obstacles: Obstacles,
    particles: Vec<ParticleCollision>,
    bvh: Option<SweptBvh>,
    influence: HashMap<[u32; 5], (f64, bool)>,
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
    displacement: Vec<f64>,
    node_box: Vec<Box3>,
    triangle_box: Vec<Box3>,
    pairs: Vec<(u32, u32)>,
    hits: Vec<u32>,
    jobs: Vec<Job>,
    chunks: Vec<(Vec<Contact>, u64, u64)>,
    contacts: Vec<Contact>,
    zones: Zones,
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
            triangles,
            triangle_garment,
            self_collision,
            obstacles,
            particles,
            bvh: None,
            influence: HashMap::new(),
            ws: Workspace::default(),
        })
    }

    /// Detects and resolves this step's collisions between `window`'s start
    /// and end, correcting the proposed end positions and velocities.
    pub fn resolve(&mut self, cloth: ClothState, window: crate::sim::contact::StepWindow) -> CollisionReport {
        let mut report = CollisionReport::default();
        let n = cloth.start.len();
        self.load(&cloth, window);
        let mut first = true;
        let mut settled = false;
        for _ in 0..self.settings.passes {
            self.detect(Detection::Proximity, Scope::All, &mut report);
            if first {
                report.contacts = self.ws.contacts.len() as u32;
                first = false;
            }
            if self.ws.contacts.is_empty() {
                settled = true;
                break;
            }
            let clock = Instant::now();
            report.passes += 1;
            let (constraint_set, acted) = self.respond_pass(window.h());
            report.constraint_set = constraint_set;
            report.response += clock.elapsed();
            // Every contact within reach was already satisfied, so nothing
            // moved and detecting again would find the same contacts. That
            // does not prove nothing crosses (the deficit is linearised along
            // the hit normal), so the impact zones still look for crossings.
            if !acted {
                break;
            }
        }
        if !settled {
            (report.zone_rounds, report.unresolved) = self.impact_zones(window, &mut report);
        }
        cloth.end.copy_from_slice(&self.ws.end[..n]);
        cloth.velocity.copy_from_slice(&self.ws.velocity[..n]);
        report
    }

    /// Copies the cloth and obstacle points into the workspace.
    fn load(&mut self, cloth: &ClothState, window: crate::sim::contact::StepWindow) {
        let ws = &mut self.ws;
        self.obstacles.positions(window, &mut ws.obstacle_start, &mut ws.obstacle_end);
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
    }

    /// Boxes, broad phase and narrow phase over `scope`: fills the
    /// workspace's contacts.
    fn detect(&mut self, detection: Detection, scope: Scope, report: &mut CollisionReport) {
        let clock = Instant::now();
        let n = self.particles.len();
        let ws = &mut self.ws;
        ws.displacement.clear();
        ws.displacement.extend(ws.start.iter().zip(&ws.end).map(|(a, b)| (b - a).norm()));
        ws.node_box.clear();
        for i in 0..ws.start.len() {
            let margin = self.particles.get(i).map_or(0.0, |p| p.thickness);
            ws.node_box.push(Box3::empty().with(&ws.start[i]).with(&ws.end[i]).grown(margin));
        }
        ws.triangle_box.clear();
        ws.triangle_box.extend(self.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|v| ws.node_box[v as usize]);
            a.union(&b).union(&c)
        }));
        match &mut self.bvh {
            Some(bvh) => bvh.update(&ws.triangle_box),
            None => self.bvh = Some(SweptBvh::new(&ws.triangle_box)),
        }
        report.refit += clock.elapsed();

        let clock = Instant::now();
        let Some(bvh) = self.bvh.as_mut() else { return };
        ws.jobs.clear();
        if self.self_collision.iter().any(|&s| s) || self.self_collision.len() > 1 {
            bvh.self_pairs(&mut ws.pairs);
            let (garment, self_collision) = (&self.triangle_garment, &self.self_collision);
            ws.jobs.extend(ws.pairs.iter().filter_map(|&(a, b)| {
                let (ga, gb) = (garment[a as usize], garment[b as usize]);
                (ga != gb || self_collision[ga as usize]).then_some(Job::Cloth(a, b))
            }));
        }
        let o = &self.obstacles;
        for (t, tri) in o.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|v| ws.node_box[n + v as usize]);
            bvh.overlapping(&a.union(&b).union(&c), &mut ws.hits);
            ws.jobs.extend(ws.hits.iter().map(|&h| Job::Mesh(h, t as u32)));
        }
        for &v in &o.feature_vertices {
            bvh.overlapping(&ws.node_box[n + v as usize], &mut ws.hits);
            ws.jobs.extend(ws.hits.iter().map(|&h| Job::Vertex(h, v)));
        }
        for (e, [a, b]) in o.feature_edges.iter().enumerate() {
            bvh.overlapping(&ws.node_box[n + *a as usize].union(&ws.node_box[n + *b as usize]), &mut ws.hits);
            ws.jobs.extend(ws.hits.iter().map(|&h| Job::Edge(h, e as u32)));
        }
        if scope == Scope::Moved {
            let (moved, triangles, o) = (&ws.moved, &self.triangles, &self.obstacles);
            let cloth_moved = |t: u32| triangles[t as usize].iter().any(|&v| moved[v as usize]);
            ws.jobs.retain(|job| match *job {
                Job::Cloth(a, b) => cloth_moved(a) || cloth_moved(b),
                Job::Mesh(t, _) | Job::Vertex(t, _) | Job::Edge(t, _) => cloth_moved(t),
            });
            debug_assert!(o.is_empty() || !moved[n..].iter().any(|&m| m), "obstacles never move in a response");
        }
        ws.moved.fill(false);
        report.pairs = ws.jobs.len() as u32;
        report.broad += clock.elapsed();

        let clock = Instant::now();
        let chunk_count = ws.jobs.len().div_ceil(JOBS_PER_CHUNK);
        ws.chunks.resize_with(chunk_count.max(ws.chunks.len()), || (Vec::new(), 0, 0));
        let narrow = Narrow {
            pipeline_triangles: &self.triangles,
            ownership: &self.ownership,
            obstacles: o,
            particles: &self.particles,
            cloth_count: n,
            start: &ws.start,
            end: &ws.end,
            displacement: &ws.displacement,
            node_box: &ws.node_box,
            triangle_box: &ws.triangle_box,
            detection,
            counting: report.passes == 0 && detection == Detection::Proximity,
        };
        ws.jobs.par_chunks(JOBS_PER_CHUNK).zip(ws.chunks[..chunk_count].par_iter_mut()).for_each(
            |(jobs, (found, tests, without))| {
                found.clear();
                (*tests, *without) = (0, 0);
                for job in jobs {
                    narrow.run(*job, found, tests, without);
                }
            },
        );
        ws.contacts.clear();
        for (found, tests, without) in &ws.chunks[..chunk_count] {
            ws.contacts.extend_from_slice(found);
            if narrow.counting {
                report.tests += tests;
                report.tests_without_ownership += without;
            }
        }
        report.narrow += clock.elapsed();
    }

    /// One pass of impulses over every contact, then sweeps over the
    /// constraint set. Returns the constraint set's size, and whether any
    /// contact needed an impulse.
    fn respond_pass(&mut self, h: f64) -> (u32, bool) {
        let (a, threshold) = (self.settings.influence_decay, self.settings.influence_threshold);
        for entry in self.influence.values_mut() {
            entry.1 = false;
        }
        let mut set = Vec::new();
        for (k, c) in self.ws.contacts.iter().enumerate() {
            let entry = self.influence.entry(c.key()).or_insert((0.0, false));
            entry.0 = a * entry.0 + 1.0;
            entry.1 = true;
            if entry.0 >= threshold {
                set.push(k);
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
        let acted = ws.contacts.iter().fold(false, |acted, c| points.respond(c) | acted);
        for _ in 0..self.settings.constraint_sweeps {
            let changed = set.iter().fold(false, |changed, &k| points.respond(&ws.contacts[k]) | changed);
            if !changed {
                break;
            }
        }
        (set.len() as u32, acted)
    }

    /// Rigid impact zones until nothing crosses (or the rounds run out).
    /// Returns the rounds used and the crossings left.
    fn impact_zones(&mut self, window: crate::sim::contact::StepWindow, report: &mut CollisionReport) -> (u32, u32) {
        let total = self.ws.start.len();
        self.ws.zones.reset(total);
        let mut round = 0;
        loop {
            self.detect(Detection::Crossings, if round == 0 { Scope::All } else { Scope::Moved }, report);
            let crossings = std::mem::take(&mut self.ws.contacts);
            if crossings.is_empty() || round == self.settings.zone_rounds {
                let left = crossings.len() as u32;
                self.ws.contacts = crossings;
                return (round, left);
            }
            round += 1;
            let clock = Instant::now();
            for c in &crossings {
                for k in 1..4 {
                    if c.hit.weights[k] != 0.0 {
                        self.ws.zones.join(c.nodes[0], c.nodes[k]);
                    }
                }
            }
            let mut members: HashMap<u32, Vec<u32>> = HashMap::new();
            let roots: std::collections::BTreeSet<u32> =
                crossings.iter().map(|c| self.ws.zones.find(c.nodes[0])).collect();
            for i in 0..total as u32 {
                let root = self.ws.zones.find(i);
                if roots.contains(&root) {
                    members.entry(root).or_default().push(i);
                }
            }
            for root in roots {
                let zone = &members[&root];
                let kinematic = zone.iter().find_map(|&i| self.kinematic(i));
                let ws = &mut self.ws;
                let mut points = Points {
                    start: &ws.start,
                    end: &mut ws.end,
                    velocity: &mut ws.velocity,
                    inverse_mass: &ws.inverse_mass,
                    moved: &mut ws.moved,
                    h: window.h(),
                };
                let carry = kinematic.map(|placement| {
                    let step = placement.world_from_local(window.t1) * placement.world_from_local(window.t0).inverse();
                    move |p: &Vector3<f64>| (step * nalgebra::Point3::from(*p)).coords
                });
                rigidify(&mut points, zone, carry.as_ref().map(|f| f as &dyn Fn(&Vector3<f64>) -> Vector3<f64>));
            }
            report.response += clock.elapsed();
            self.ws.contacts = crossings;
        }
    }

    /// The prescribed motion of point `i`, if it has one (pinned particle or
    /// obstacle vertex).
    fn kinematic(&self, i: u32) -> Option<Placement> {
        match self.particles.get(i as usize) {
            Some(p) => p.pinned,
            None => {
                let o = &self.obstacles;
                let body = o.vertex_collider[i as usize - self.particles.len()];
                Some(o.bodies[body as usize].placement)
            }
        }
    }
}

/// Everything the narrow phase reads.
struct Narrow<'a> {
    pipeline_triangles: &'a [[u32; 3]],
    ownership: &'a Ownership,
    obstacles: &'a Obstacles,
    particles: &'a [ParticleCollision],
    cloth_count: usize,
    start: &'a [Vector3<f64>],
    end: &'a [Vector3<f64>],
    displacement: &'a [f64],
    node_box: &'a [Box3],
    triangle_box: &'a [Box3],
    detection: Detection,
    /// Whether to count the tests without ownership too (first detection of
    /// a step only: the count costs as much as a cheap test).
    counting: bool,
}

impl Narrow<'_> {
    fn path(&self, i: u32) -> Path {
        Path { start: self.start[i as usize], end: self.end[i as usize] }
    }

    /// The distance a contact between features of `nodes` must keep, m.
    fn thickness(&self, nodes: &[u32]) -> f64 {
        nodes.iter().filter_map(|&i| self.particles.get(i as usize)).map(|p| p.thickness).fold(0.0, f64::max)
    }

    /// Whether a hit is what this detection looks for.
    fn wanted(&self, hit: &Hit) -> bool {
        hit.crossing || self.detection != Detection::Crossings
    }

    /// The obstacle's friction if it names one, else the mean of the cloth
    /// particles' fabrics.
    fn friction(&self, nodes: &[u32], body: Option<u32>) -> f64 {
        let (sum, count) = nodes
            .iter()
            .filter_map(|&i| self.particles.get(i as usize))
            .fold((0.0, 0), |(s, n), p| (s + p.friction, n + 1));
        body.and_then(|b| self.obstacles.bodies[b as usize].friction).unwrap_or(sum / count.max(1) as f64)
    }

    /// The obstacle body of a point, if it is an obstacle vertex.
    fn body(&self, node: u32) -> Option<u32> {
        (node as usize).checked_sub(self.cloth_count).map(|o| self.obstacles.vertex_collider[o])
    }

    /// Vertex `p` against triangle `tri` (point indices): culled by box and by
    /// the start distance, else tested.
    fn vertex_triangle(&self, p: u32, tri: [u32; 3], tri_box: &Box3, found: &mut Vec<Contact>, tests: &mut u64) {
        if tri.contains(&p) || !self.node_box[p as usize].overlaps(tri_box) {
            return;
        }
        *tests += 1;
        let thickness = self.thickness(&[p, tri[0], tri[1], tri[2]]);
        let touching = self.detection.reach(thickness);
        let travel =
            self.displacement[p as usize] + tri.iter().map(|&v| self.displacement[v as usize]).fold(0.0, f64::max);
        let [pa, pb, pc] = tri.map(|v| self.path(v));
        let hit = vertex_triangle_within(&self.path(p), &pa, &pb, &pc, touching, travel);
        if let Some(hit) = hit.filter(|h| self.wanted(h)) {
            let nodes = [p, tri[0], tri[1], tri[2]];
            let body = nodes.iter().find_map(|&i| self.body(i));
            let friction = self.friction(&nodes, body);
            found.push(Contact { kind: ContactKind::VertexTriangle, nodes, hit, thickness, friction });
        }
    }

    /// Edge `e1` against edge `e2`: culled by box and distance, else tested.
    fn edge_edge(&self, e1: [u32; 2], e2: [u32; 2], found: &mut Vec<Contact>, tests: &mut u64) {
        if e1.iter().any(|v| e2.contains(v)) {
            return;
        }
        let box_of = |e: [u32; 2]| self.node_box[e[0] as usize].union(&self.node_box[e[1] as usize]);
        if !box_of(e1).overlaps(&box_of(e2)) {
            return;
        }
        *tests += 1;
        let nodes = [e1[0], e1[1], e2[0], e2[1]];
        let thickness = self.thickness(&nodes);
        let touching = self.detection.reach(thickness);
        let travel = |e: [u32; 2]| self.displacement[e[0] as usize].max(self.displacement[e[1] as usize]);
        let [pa, pb, pc, pd] = nodes.map(|v| self.path(v));
        let hit = edge_edge_within(&pa, &pb, &pc, &pd, touching, travel(e1) + travel(e2));
        if let Some(hit) = hit.filter(|h| self.wanted(h)) {
            let body = nodes.iter().find_map(|&i| self.body(i));
            let friction = self.friction(&nodes, body);
            found.push(Contact { kind: ContactKind::EdgeEdge, nodes, hit, thickness, friction });
        }
    }

    /// Feature pairs of two triangles passing the box test when every vertex
    /// and edge of both is tested (no representative triangles).
    fn feature_tests_without_ownership(&self, t1: [u32; 3], box1: &Box3, t2: [u32; 3], box2: &Box3) -> u64 {
        let box_of = |e: [u32; 2]| self.node_box[e[0] as usize].union(&self.node_box[e[1] as usize]);
        let vt = |p: u32, tri: [u32; 3], b: &Box3| !tri.contains(&p) && self.node_box[p as usize].overlaps(b);
        let vertices =
            t1.iter().filter(|&&p| vt(p, t2, box2)).count() + t2.iter().filter(|&&p| vt(p, t1, box1)).count();
        let edges = (0..3)
            .flat_map(|k1| (0..3).map(move |k2| ([t1[k1], t1[(k1 + 1) % 3]], [t2[k2], t2[(k2 + 1) % 3]])))
            .filter(|(e1, e2)| !e1.iter().any(|v| e2.contains(v)) && box_of(*e1).overlaps(&box_of(*e2)))
            .count();
        (vertices + edges) as u64
    }

    /// Runs one job, appending contacts; counts the feature pairs that pass
    /// the box test, with representative triangles and without.
    fn run(&self, job: Job, found: &mut Vec<Contact>, tests: &mut u64, without: &mut u64) {
        let cloth = |t: u32| self.pipeline_triangles[t as usize];
        let edge = |tri: [u32; 3], k: usize| [tri[k], tri[(k + 1) % 3]];
        let offset = self.cloth_count as u32;
        match job {
            Job::Cloth(t1, t2) | Job::Mesh(t1, t2) => {
                let is_mesh = matches!(job, Job::Mesh(..));
                let tri1 = cloth(t1);
                let (tri2, owner2, box2) = if is_mesh {
                    let o = self.obstacles.triangles[t2 as usize].map(|v| v + offset);
                    let [a, b, c] = o.map(|v| self.node_box[v as usize]);
                    (o, &self.obstacles.ownership, a.union(&b).union(&c))
                } else {
                    (cloth(t2), self.ownership, self.triangle_box[t2 as usize])
                };
                let box1 = self.triangle_box[t1 as usize];
                if self.counting {
                    *without += self.feature_tests_without_ownership(tri1, &box1, tri2, &box2);
                }
                for k in self.ownership.vertices(t1 as usize) {
                    self.vertex_triangle(tri1[k], tri2, &box2, found, tests);
                }
                for k in owner2.vertices(t2 as usize) {
                    self.vertex_triangle(tri2[k], tri1, &box1, found, tests);
                }
                for k1 in self.ownership.edges(t1 as usize) {
                    for k2 in owner2.edges(t2 as usize) {
                        self.edge_edge(edge(tri1, k1), edge(tri2, k2), found, tests);
                    }
                }
            }
            Job::Vertex(t, v) => {
                *without += u64::from(
                    self.counting && self.node_box[(v + offset) as usize].overlaps(&self.triangle_box[t as usize]),
                );
                self.vertex_triangle(v + offset, cloth(t), &self.triangle_box[t as usize], found, tests);
            }
            Job::Edge(t, e) => {
                let obstacle = self.obstacles.feature_edges[e as usize].map(|v| v + offset);
                let box_of = |e: [u32; 2]| self.node_box[e[0] as usize].union(&self.node_box[e[1] as usize]);
                if self.counting {
                    *without +=
                        (0..3).filter(|&k| box_of(edge(cloth(t), k)).overlaps(&box_of(obstacle))).count() as u64;
                }
                for k in self.ownership.edges(t as usize) {
                    self.edge_edge(edge(cloth(t), k), obstacle, found, tests);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use nalgebra::{Isometry3, Vector3};

    use super::obstacles::MeshCollider;
    use super::*;
    use crate::mesh::generate;
    use crate::sim::colliders::{Collider, Shape};
    use crate::sim::contact::StepWindow;

    const THICKNESS: f64 = 0.005;

    /// A deterministic value in [−1, 1] for index `i` and axis `k`.
    fn wobble(i: usize, k: usize) -> f64 {
        ((i * 3 + k) as f64 * 12.9898).sin() * 43_758.545 % 1.0
    }

    /// A cloth folded onto itself 4 mm apart and shaken by up to 6 mm over
    /// the step, lying on a box's sharp edge and a mesh tetrahedron; returns
    /// the contacts one detection finds and its test counts.
    fn detect_crumpled(representative_triangles: bool) -> (BTreeSet<[u32; 5]>, CollisionReport, u32) {
        let grid = generate::grid(1.0, 16);
        let start: Vec<Vector3<f64>> =
            grid.positions.iter().map(|p| if p.x > 0.0 { Vector3::new(-p.x, 0.004, p.z) } else { *p }).collect();
        let end: Vec<Vector3<f64>> =
            start.iter().enumerate().map(|(i, p)| p + Vector3::from_fn(|k, _| 0.006 * wobble(i, k))).collect();
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
        };
        let particles = vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; start.len()];
        let settings = CollisionSettings { representative_triangles, ..Default::default() };
        let obstacles = Obstacles::new(&[blade], &[tetrahedron]);
        let triangle_count = grid.triangles.len();
        let mut pipeline =
            CollisionPipeline::new(grid.triangles, vec![0; triangle_count], vec![true], particles, obstacles, settings)
                .unwrap();
        let cloth = ClothState { start: &start, end: &mut end_mut, velocity: &mut velocity, mass: &mass };
        pipeline.load(&cloth, StepWindow { t0: 0.0, t1: h });
        let mut report = CollisionReport::default();
        pipeline.detect(Detection::Proximity, Scope::All, &mut report);
        (pipeline.ws.contacts.iter().map(Contact::key).collect(), report, start.len() as u32)
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
