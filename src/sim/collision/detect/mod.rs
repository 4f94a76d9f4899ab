//! One detection: every point's box over the step, the BVH refit, the broad
//! phase (cloth-cloth pairs where self-collision is on, cloth against mesh
//! colliders and sharp features) and the narrow phase on the features each
//! triangle owns, in parallel chunks whose results are merged in order.

mod narrow;

use std::time::Instant;

use nalgebra::Vector3;
use rayon::prelude::*;

pub(super) use self::narrow::TestCount;
use self::narrow::{Narrow, add_adjacent_pairs};
use super::adjacent::{self, AdjacentTriangles, Sharing};
use super::bvh::{Box3, SweptBvh};
use super::ccd::{Hit, Path, edge_edge_within, relative_reach, vertex_triangle_within};
use super::features::Ownership;
use super::obstacles::Obstacles;
use super::pair_sort::merge_sorted;
use super::partners::moved_pairs;
use super::queries::parallel_queries;
use super::response::{Contact, ContactKind};
use super::slabs::DiagonalSlabs;
use super::speculate::{MARGIN_IN_THICKNESSES, leaf_margin};
use super::{CollisionPipeline, CollisionReport, ParticleCollision, Workspace, speculate};
use crate::sim::contact::StepWindow;

/// How far beyond the cloth's predicted boxes obstacle triangles are boxed
/// for a step, m (see [`CollisionPipeline::frame_obstacles_near`]): a
/// detection whose cloth goes further boxes the parked triangles it nears
/// then, at the price of a pass over the obstacle's triangles.
pub const OBSTACLE_REGION_MARGIN: f64 = 0.02;

/// Candidate jobs per parallel chunk of the narrow phase.
const JOBS_PER_CHUNK: usize = 512;
/// Points or triangles per parallel task when a detection boxes them all.
const BOXES_PER_TASK: usize = 1024;
/// Distance at which impact zones and the final verdict count two features
/// as touching, m: a true crossing, not a thickness violation. A rigid zone
/// keeps its members' distances, so pairs inside it that start apart stay
/// apart; with the thickness instead, a pair that started closer than it
/// would be reported forever.
const CROSSING_GAP: f64 = 1e-6;

/// Which candidate pairs a detection tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Scope {
    /// Every pair the broad phase finds.
    All,
    /// Only pairs with a point whose path changed since the last detection
    /// (the others would give the same answer as last time), and the feature
    /// pairs of the workspace's kept contacts, first.
    Moved,
}

/// What a detection looks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Detection {
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
    pub(super) fn reach(self, thickness: f64) -> f64 {
        match self {
            Detection::Proximity => thickness,
            Detection::Crossings => CROSSING_GAP,
        }
    }
}

/// A unit of narrow-phase work.
#[derive(Clone, Copy, Debug)]
pub(super) enum Job {
    /// Two cloth triangles.
    Cloth(u32, u32),
    /// A cloth triangle and a mesh-collider triangle.
    Mesh(u32, u32),
    /// A cloth triangle and a sharp obstacle vertex.
    Vertex(u32, u32),
    /// A cloth triangle and a sharp obstacle edge.
    Edge(u32, u32),
    /// The feature pair of the last detection's contact with this index
    /// among the workspace's kept contacts, tested again.
    Again(u32),
}

impl CollisionPipeline {
    /// Places the obstacles over `window` and boxes them in the step's
    /// frame, which moves by `shift` (m) over the step, and refits their
    /// hierarchy: obstacles do not move within a step, so every detection of
    /// the step shares them. Any `shift` gives the same contacts (a box spans
    /// a point's start and its end minus the shift, so two boxes overlap
    /// wherever the points' relative paths come near); one close to the
    /// cloth's own displacement keeps a carried cloth's boxes small.
    pub fn frame_obstacles(&mut self, window: StepWindow, shift: Vector3<f64>) {
        self.frame_obstacles_in(window, shift, None);
    }

    /// [`Self::frame_obstacles`] for a cloth going from `start` towards
    /// `predicted_end` (m), boxing only the obstacle triangles near it: those
    /// whose boxes meet the cloth's predicted boxes (as
    /// [`Self::speculate`] grows them) grown by [`OBSTACLE_REGION_MARGIN`].
    /// The others are *parked*: their boxes are left empty and their
    /// hierarchy leaves as they were, so no pair with them is kept. A
    /// detection whose cloth boxes leave that region boxes the parked
    /// triangles near them first ([`cover_cloth`]): the pairs found
    /// are those of a full framing, and a body mostly far from its garment
    /// (a head, arms and feet above and below a skirt) costs little.
    pub fn frame_obstacles_near(
        &mut self,
        window: StepWindow,
        shift: Vector3<f64>,
        (start, predicted_end): (&[Vector3<f64>], &[Vector3<f64>]),
    ) {
        let growth = box_growth(&self.particles);
        let cloth = start.iter().zip(predicted_end).zip(&self.particles).map(|((a, b), particle)| {
            let grown = growth + particle.thickness * MARGIN_IN_THICKNESSES;
            Box3::empty().with(a).with(&(b - shift)).grown(grown)
        });
        let region = cloth.fold(Box3::empty(), |all, b| all.union(&b)).grown(OBSTACLE_REGION_MARGIN);
        self.frame_obstacles_in(window, shift, Some(region));
    }

    /// Frames the obstacles (see [`Self::frame_obstacles`]), boxing only the
    /// triangles whose boxes meet `region` when there is one.
    fn frame_obstacles_in(&mut self, window: StepWindow, shift: Vector3<f64>, region: Option<Box3>) {
        let n = self.particles.len();
        let ws = &mut self.ws;
        self.obstacles.positions(window, &mut ws.obstacle_start, &mut ws.obstacle_end);
        ws.shift = shift;
        ws.growth = box_growth(&self.particles);
        ws.speculative = false;
        ws.node_box.clear();
        ws.node_box.resize(n, Box3::empty());
        // The cloth's boxes are of the last step: the next detection makes
        // all of them again.
        ws.triangle_box.clear();
        let (paths, growth) = (ws.obstacle_start.iter().zip(&ws.obstacle_end), ws.growth);
        ws.node_box.extend(paths.clone().map(|(a, b)| Box3::empty().with(a).with(&(b - shift)).grown(growth)));
        ws.point_slabs.clear();
        ws.point_slabs.resize(n, DiagonalSlabs::empty());
        ws.point_slabs.extend(paths.map(|(a, b)| DiagonalSlabs::of_path(a, &(b - shift), growth)));
        let obstacle_nodes = &ws.node_box[n..];
        let triangles = &self.obstacles.triangles;
        ws.obstacle_box.clear();
        ws.obstacle_box.extend(triangles.iter().map(|tri| triangle_box(*tri, obstacle_nodes)));
        ws.obstacle_region = region;
        self.framed = Some(window);
        if ws.obstacle_box.is_empty() {
            return;
        }
        let bvh = self.obstacle_bvh.get_or_insert_with(|| SweptBvh::new(&ws.obstacle_box));
        ws.obstacle_feature_box.resize(triangles.len(), FeatureBoxes::empty());
        ws.obstacle_slabs.resize(triangles.len(), DiagonalSlabs::empty());
        let obstacle_points = &ws.point_slabs[n..];
        ws.fresh_obstacles.clear();
        for (t, (tri, whole)) in triangles.iter().zip(&mut ws.obstacle_box).enumerate() {
            if region.is_none_or(|region| whole.overlaps(&region)) {
                ws.obstacle_feature_box[t] = FeatureBoxes::of(*tri, obstacle_nodes);
                ws.obstacle_slabs[t] = DiagonalSlabs::of_triangle(*tri, obstacle_points);
                ws.fresh_obstacles.push(t as u32);
            } else {
                *whole = Box3::empty();
            }
        }
        bvh.update_leaves(&ws.obstacle_box, ws.fresh_obstacles.iter().map(|&t| t as usize));
    }

    /// Whether the broad phase pairs cloth triangles with each other: a
    /// garment collides with itself, or several garments with each other.
    pub(super) fn cloth_pairs_wanted(&self) -> bool {
        self.self_collision.iter().any(|&s| s) || self.self_collision.len() > 1
    }

    /// Brings the swept boxes of the cloth's points, edges and triangles, the
    /// points' packed states and the hierarchy up to date. With `only_moved`
    /// (and boxes already made this step) only the points that moved since
    /// the last detection and the workspace's `moved_triangle`s are boxed
    /// again: every other path, and so every other box, is as it was. After
    /// a speculation (`speculated`) only the leaves of the triangles that
    /// escaped their speculative boxes are updated, and so, in the step's
    /// later detections, are only those of the moved triangles that left
    /// their leaves (see [`super::partners`]).
    fn refit(&mut self, only_moved: bool, speculated: bool) {
        let ws = &mut self.ws;
        let (start, end, shift, growth) = (&ws.start, &ws.end, ws.shift, ws.growth);
        let point_box = |i: usize| Box3::empty().with(&start[i]).with(&(end[i] - shift)).grown(growth);
        let point_state = |i: usize| PointState::of(i, start, end, &self.particles);
        let point_slabs = |i: usize| DiagonalSlabs::of_path(&start[i], &(end[i] - shift), growth);
        let bvh = match &mut self.bvh {
            Some(bvh) if only_moved && ws.triangle_box.len() == self.triangles.len() => bvh,
            _ => {
                let n = self.particles.len();
                let cloth_boxes = ws.node_box[..n].par_iter_mut().zip(ws.point_slabs[..n].par_iter_mut());
                cloth_boxes.with_min_len(BOXES_PER_TASK).enumerate().for_each(|(i, (b, s))| {
                    *b = point_box(i);
                    *s = point_slabs(i);
                });
                ws.point.clear();
                ws.point.par_extend((0..start.len()).into_par_iter().with_min_len(BOXES_PER_TASK).map(point_state));
                let (node_box, point_slabs) = (&ws.node_box, &ws.point_slabs);
                let triangles = self.triangles.par_iter().with_min_len(BOXES_PER_TASK);
                let bounds =
                    |t: &[u32; 3]| (FeatureBoxes::of(*t, node_box), DiagonalSlabs::of_triangle(*t, point_slabs));
                triangles.map(bounds).unzip_into_vecs(&mut ws.feature_box, &mut ws.triangle_slabs);
                ws.triangle_box.clear();
                let features = ws.feature_box.par_iter().with_min_len(BOXES_PER_TASK);
                ws.triangle_box.par_extend(features.map(FeatureBoxes::whole));
                cover_cloth(ws, (&self.obstacles, &mut self.obstacle_bvh), &self.particles, false);
                if speculated {
                    self.update_escaped();
                } else {
                    match &mut self.bvh {
                        Some(bvh) => bvh.update(&ws.triangle_box),
                        None => self.bvh = Some(SweptBvh::new(&ws.triangle_box)),
                    }
                }
                return;
            }
        };
        for i in (0..self.particles.len()).filter(|&i| ws.moved[i]) {
            ws.node_box[i] = point_box(i);
            ws.point[i] = point_state(i);
            ws.point_slabs[i] = point_slabs(i);
        }
        for &t in &ws.moved_list {
            let t = t as usize;
            ws.triangle_slabs[t] = DiagonalSlabs::of_triangle(self.triangles[t], &ws.point_slabs);
            ws.feature_box[t] = FeatureBoxes::of(self.triangles[t], &ws.node_box);
            ws.triangle_box[t] = ws.feature_box[t].whole();
        }
        cover_cloth(ws, (&self.obstacles, &mut self.obstacle_bvh), &self.particles, true);
        if !ws.partners.valid() {
            bvh.update_leaves(&ws.triangle_box, ws.moved_list.iter().map(|&t| t as usize));
            return;
        }
        // Only the triangles that left their leaves get new ones.
        let (leaf_box, real) = (&ws.leaf_box, &ws.triangle_box);
        ws.escaping.clear();
        ws.escaping.extend(ws.moved_list.iter().filter(|&&t| !leaf_box[t as usize].contains(&real[t as usize])));
        let margin = leaf_margin(&self.triangles, &self.particles);
        let boxes = (&ws.triangle_box[..], &mut ws.leaf_box[..]);
        ws.partners.re_leaf(&ws.escaping, boxes, margin, bvh, (&mut ws.query_chunks, &mut ws.pair_sorter));
    }

    /// Boxes, broad phase and narrow phase over `scope`: fills the
    /// workspace's contacts.
    pub(super) fn detect(&mut self, detection: Detection, scope: Scope, report: &mut CollisionReport) {
        let clock = Instant::now();
        let n = self.particles.len();
        let moved = scope == Scope::Moved;
        let cloth_pairs = self.cloth_pairs_wanted();
        let ws = &mut self.ws;
        ws.moved_triangle.clear();
        ws.moved_list.clear();
        if moved {
            let points = &ws.moved;
            ws.moved_triangle.extend(self.triangles.iter().map(|t| t.iter().any(|&v| points[v as usize])));
            let moved_triangle = ws.moved_triangle.iter().enumerate().filter(|&(_, &m)| m);
            ws.moved_list.extend(moved_triangle.map(|(t, _)| t as u32));
        }
        let speculated = !moved && std::mem::take(&mut ws.speculative);
        if !moved && !speculated {
            ws.partners.invalidate();
        }
        self.refit(moved, speculated);
        let ws = &mut self.ws;
        report.refit += clock.elapsed();

        let clock = Instant::now();
        let Some(bvh) = self.bvh.as_mut() else { return };
        ws.jobs.clear();
        // With Scope::Moved only pairs holding a moved cloth triangle are
        // wanted: the queries start from those triangles (and obstacle parts
        // near them), and give the pairs a full query would, in its order,
        // after the kept contacts' feature pairs.
        if moved {
            ws.jobs.extend((0..ws.kept.len() as u32).map(Job::Again));
        }
        // The (moved) cloth's box, for the sharp features' queries only.
        let sharp = !self.obstacles.feature_vertices.is_empty() || !self.obstacles.feature_edges.is_empty();
        let boxes = ws.triangle_box.iter().enumerate().filter(|&(t, _)| !moved || ws.moved_triangle[t]);
        let near = if sharp { boxes.fold(Box3::empty(), |all, (_, b)| all.union(b)) } else { Box3::empty() };
        if cloth_pairs {
            let triangles = &self.triangles;
            let apart = adjacent::apart(triangles);
            match moved {
                true => {
                    let listed = ws.partners.valid().then_some(&ws.partners);
                    moved_pairs(
                        bvh,
                        (&ws.triangle_box, &ws.moved_triangle, &ws.moved_list),
                        listed,
                        apart,
                        (&mut ws.query_chunks, &mut ws.pair_sorter),
                        &mut ws.pairs,
                    )
                }
                false if speculated => speculate::confirmed_self_pairs(bvh, triangles, ws),
                false => {
                    bvh.self_pairs(apart, &mut ws.pairs);
                    let boxes = &ws.triangle_box;
                    ws.pairs.retain(|&(a, b)| boxes[a as usize].overlaps(&boxes[b as usize]));
                }
            }
            add_adjacent_pairs((&self.adjacent, triangles), moved, ws);
            let (garment, self_collision) = (&self.triangle_garment, &self.self_collision);
            ws.jobs.extend(ws.pairs.iter().filter_map(|&(a, b)| {
                let (ga, gb) = (garment[a as usize], garment[b as usize]);
                (ga != gb || self_collision[ga as usize]).then_some(Job::Cloth(a, b))
            }));
        }
        let o = &self.obstacles;
        if let Some(obstacle_bvh) = &self.obstacle_bvh {
            mesh_pairs(bvh, obstacle_bvh, ws, moved, speculated);
            ws.jobs.extend(ws.mesh_pairs.iter().map(|&(t, h)| Job::Mesh(h, t)));
        }
        for &v in &o.feature_vertices {
            let vertex_box = ws.node_box[n + v as usize];
            if vertex_box.overlaps(&near) {
                bvh.overlapping(&vertex_box, &mut ws.hits);
                let hits = ws.hits.iter().filter(|&&h| ws.triangle_box[h as usize].overlaps(&vertex_box));
                ws.jobs.extend(hits.map(|&h| Job::Vertex(h, v)));
            }
        }
        for (e, [a, b]) in o.feature_edges.iter().enumerate() {
            let edge_box = ws.node_box[n + *a as usize].union(&ws.node_box[n + *b as usize]);
            if edge_box.overlaps(&near) {
                bvh.overlapping(&edge_box, &mut ws.hits);
                let hits = ws.hits.iter().filter(|&&h| ws.triangle_box[h as usize].overlaps(&edge_box));
                ws.jobs.extend(hits.map(|&h| Job::Edge(h, e as u32)));
            }
        }
        if moved {
            let moved_triangle = &ws.moved_triangle;
            ws.jobs.retain(|job| match *job {
                Job::Cloth(a, b) => moved_triangle[a as usize] || moved_triangle[b as usize],
                Job::Mesh(t, _) | Job::Vertex(t, _) | Job::Edge(t, _) => moved_triangle[t as usize],
                Job::Again(_) => true,
            });
            debug_assert!(o.is_empty() || !ws.moved[n..].iter().any(|&m| m), "obstacles never move in a response");
        }
        ws.moved.fill(false);
        report.pairs = ws.jobs.len() as u32;
        report.broad += clock.elapsed();

        let clock = Instant::now();
        let chunk_count = ws.jobs.len().div_ceil(JOBS_PER_CHUNK);
        ws.chunks.resize_with(chunk_count.max(ws.chunks.len()), Default::default);
        let narrow = Narrow {
            pipeline_triangles: &self.triangles,
            ownership: &self.ownership,
            obstacles: o,
            particles: &self.particles,
            cloth_count: n,
            point: &ws.point,
            node_box: &ws.node_box,
            triangle_box: &ws.triangle_box,
            point_slabs: &ws.point_slabs,
            triangle_slabs: &ws.triangle_slabs,
            obstacle_box: &ws.obstacle_box,
            feature_box: &ws.feature_box,
            obstacle_feature_box: &ws.obstacle_feature_box,
            obstacle_slabs: &ws.obstacle_slabs,
            kept: &ws.kept,
            detection,
        };
        // Only the step's first detection is counted.
        let counting = report.passes == 0 && detection == Detection::Proximity;
        ws.jobs.par_chunks(JOBS_PER_CHUNK).zip(ws.chunks[..chunk_count].par_iter_mut()).for_each(
            |(jobs, (found, count))| {
                found.clear();
                *count = TestCount::default();
                for job in jobs {
                    narrow.run(*job, found, count);
                }
            },
        );
        ws.contacts.clear();
        for (found, count) in &ws.chunks[..chunk_count] {
            ws.contacts.extend_from_slice(found);
            if counting {
                report.tests += count.run;
                report.tests_without_ownership += count.without_ownership;
            }
        }
        report.narrow += clock.elapsed();
    }
}

/// The overlapping pairs `(obstacle triangle, cloth triangle)` of the
/// workspace's boxes into its `mesh_pairs`, sorted: every pair, or with
/// `moved` only those of a moved cloth triangle; when `speculated`, the
/// speculation's pairs with those of the escaped cloth triangles (marked as
/// moved).
fn mesh_pairs(cloth: &SweptBvh, obstacles: &SweptBvh, ws: &mut Workspace, moved: bool, speculated: bool) {
    if moved || speculated {
        let listed = (moved && ws.partners.valid()).then_some(&ws.partners);
        let cloth_box = &ws.triangle_box;
        parallel_queries(&ws.moved_list, &mut ws.query_chunks, &mut ws.mesh_pairs, |h, hits, pairs| {
            match listed.filter(|partners| !partners.queried(h)) {
                Some(partners) => pairs.extend(partners.obstacles_of(h).iter().map(|&t| (t, h))),
                None => {
                    obstacles.overlapping(&cloth_box[h as usize], hits);
                    pairs.extend(hits.iter().map(|&t| (t, h)));
                }
            }
        });
    } else {
        ws.mesh_pairs.clear();
        obstacles.pairs_with(cloth, &mut ws.mesh_pairs);
    }
    if speculated {
        ws.mesh_pairs.extend_from_slice(&ws.speculative_mesh_pairs);
    }
    let (cloth_box, obstacle_box) = (&ws.triangle_box, &ws.obstacle_box);
    ws.mesh_pairs.retain(|&(t, h)| obstacle_box[t as usize].overlaps(&cloth_box[h as usize]));
    ws.pair_sorter.sort(&mut ws.mesh_pairs);
    ws.mesh_pairs.dedup();
}

/// The boxes of a triangle's features over the step, side by side: a
/// narrow-phase pair reads both triangles' from two places instead of from
/// six points' scattered across the cloth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FeatureBoxes {
    /// Edge `k → k + 1`.
    edges: [Box3; 3],
    /// Corner `k`.
    corners: [Box3; 3],
}

impl FeatureBoxes {
    /// The feature boxes of triangle `tri` whose points have boxes `node_box`.
    fn of(tri: [u32; 3], node_box: &[Box3]) -> Self {
        let corners @ [a, b, c] = tri.map(|v| node_box[v as usize]);
        FeatureBoxes { edges: [a.union(&b), b.union(&c), c.union(&a)], corners }
    }

    /// The whole triangle's box.
    fn whole(&self) -> Box3 {
        self.edges[0].union(&self.edges[1])
    }

    /// No boxes: those of a parked obstacle triangle.
    fn empty() -> Self {
        FeatureBoxes { edges: [Box3::empty(); 3], corners: [Box3::empty(); 3] }
    }
}

/// Boxes the parked obstacle triangles near the cloth's triangles when their
/// boxes (all of them, or with `only_listed` those of the workspace's
/// `moved_list`, whose boxes are new), grown to the leaves they may be given
/// ([`leaf_margin`]), left the region the obstacles were boxed in; the region
/// grows to take them in with [`OBSTACLE_REGION_MARGIN`] to spare. Run
/// before any leaf is made or queried, it keeps every cloth leaf in the
/// region, so every obstacle triangle a leaf meets is boxed when the leaf's
/// partners are listed.
fn cover_cloth(
    ws: &mut Workspace,
    (obstacles, obstacle_bvh): (&Obstacles, &mut Option<SweptBvh>),
    particles: &[ParticleCollision],
    only_listed: bool,
) {
    let (Some(region), Some(bvh)) = (ws.obstacle_region, obstacle_bvh) else { return };
    let boxes = &ws.triangle_box;
    let cloth = match only_listed {
        true => ws.moved_list.iter().fold(Box3::empty(), |all, &t| all.union(&boxes[t as usize])),
        false => boxes.iter().fold(Box3::empty(), |all, b| all.union(b)),
    };
    let thickest = particles.iter().map(|p| p.thickness).fold(0.0, f64::max);
    let cloth = cloth.grown(MARGIN_IN_THICKNESSES * thickest);
    if cloth.is_empty() || region.contains(&cloth) {
        return;
    }
    let region = region.union(&cloth).grown(OBSTACLE_REGION_MARGIN);
    ws.obstacle_region = Some(region);
    let obstacle_nodes = &ws.node_box[particles.len()..];
    let obstacle_points = &ws.point_slabs[particles.len()..];
    ws.fresh_obstacles.clear();
    for (t, tri) in obstacles.triangles.iter().enumerate() {
        let whole = triangle_box(*tri, obstacle_nodes);
        if ws.obstacle_box[t].is_empty() && whole.overlaps(&region) {
            ws.obstacle_box[t] = whole;
            ws.obstacle_feature_box[t] = FeatureBoxes::of(*tri, obstacle_nodes);
            ws.obstacle_slabs[t] = DiagonalSlabs::of_triangle(*tri, obstacle_points);
            ws.fresh_obstacles.push(t as u32);
        }
    }
    bvh.update_leaves(&ws.obstacle_box, ws.fresh_obstacles.iter().map(|&t| t as usize));
}

/// How much every point's box over the step is grown, m: half the largest
/// thickness of `particles`. A contact needs its features within its
/// thickness of each other at some time of the step, and the features lie in
/// their points' unshrunk boxes at every time, so the boxes of any two
/// features that can touch, each grown by this, overlap: cloth features with
/// each other and with obstacles' (whose boxes are grown by it too).
pub(super) fn box_growth(particles: &[ParticleCollision]) -> f64 {
    let thickest = particles.iter().map(|p| p.thickness).fold(0.0, f64::max);
    thickest / 2.0
}

/// The box of triangle `tri` whose points have boxes `node_box`: the
/// [`FeatureBoxes::whole`] of its feature boxes.
fn triangle_box(tri: [u32; 3], node_box: &[Box3]) -> Box3 {
    let [a, b, c] = tri.map(|v| node_box[v as usize]);
    a.union(&b).union(&c)
}

/// The mean displacement over the step of the points that go `start` → `end`
/// (zero for none), m: the frame of a step's boxes when no other was given.
///
/// Every box of a step's detections is taken in a frame that moves by a
/// shift over the step: each point's box spans its start and its end minus
/// the shift. Two points' relative position at every time is the same in
/// that frame as in the world (both are shifted by the same `t · shift`),
/// and every test a box stands for is one of two features' relative
/// position, so no contact is lost; but a garment carried along with a
/// body, or a cloth falling as one, no longer has boxes stretched by the
/// motion they share.
pub(super) fn mean_displacement(start: &[Vector3<f64>], end: &[Vector3<f64>]) -> Vector3<f64> {
    mean(start.iter().zip(end).map(|(a, b)| b - a))
}

/// The displacement over a step of `h` seconds that particles with start
/// velocities `velocity` (m/s) are carried by on average, m: the frame a
/// simulator boxes a step in before its solve has proposed the ends (see
/// [`mean_displacement`] for why any frame is exact).
pub fn carried_displacement(velocity: &[Vector3<f64>], h: f64) -> Vector3<f64> {
    mean(velocity.iter().copied()) * h
}

/// The mean of `vectors` (zero for none).
fn mean(vectors: impl ExactSizeIterator<Item = Vector3<f64>>) -> Vector3<f64> {
    let count = vectors.len();
    let sum: Vector3<f64> = vectors.sum();
    if count == 0 { Vector3::zeros() } else { sum / count as f64 }
}

/// What the narrow phase reads of one point, in one cache line: its path
/// over the step, the distance its contacts keep and whether it moves by
/// prescription. A test reads four points; from separate arrays of starts,
/// ends and particles that is up to twelve cache misses, from these four.
#[derive(Clone, Copy, Debug)]
#[repr(align(64))]
pub(super) struct PointState {
    path: Path,
    /// Distance its contacts keep, m (zero for an obstacle vertex, which
    /// takes the cloth's).
    thickness: f64,
    /// A pinned particle or an obstacle vertex.
    kinematic: bool,
}

impl PointState {
    /// Point `i` of `start`/`end` (cloth particles `particles` first, then
    /// obstacle vertices).
    fn of(i: usize, start: &[Vector3<f64>], end: &[Vector3<f64>], particles: &[ParticleCollision]) -> Self {
        let particle = particles.get(i);
        PointState {
            path: Path { start: start[i], end: end[i] },
            thickness: particle.map_or(0.0, |p| p.thickness),
            kinematic: particle.is_none_or(|p| p.pinned.is_some()),
        }
    }
}

#[cfg(test)]
mod tests;
