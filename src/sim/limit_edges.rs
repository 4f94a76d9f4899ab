//! The strain-limited edges linearised at the current positions, for the
//! projection of [`super::inextensibility`]: each edge's direction, constraint
//! value and `J W Jᵀ` diagonal, whether it is near its limit, and per chunk of
//! edges the largest excess and the sum of squared excesses.
//!
//! A projection linearises every edge once, where the solve or the collision
//! pass left the cloth, and from then on moves only the particles at the ends
//! of its active edges. After such a move only the edges at those particles
//! are linearised again ([`LinearisedEdges::update_at`]) and only their
//! chunks' summaries are redone: a few hundred edges instead of every edge of
//! the garment, several times per projection. (A move that reaches most edges,
//! as on a skirt pulled taut between the legs, linearises them all in parallel
//! chunks instead.) Each summary is taken over its
//! chunk in edge order and the summaries are combined in chunk order, as a
//! full pass does at any thread count, so the figures do not depend on which
//! edges were redone.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::constraint::Constraint;
use super::parallel::{CHUNK, PARALLEL_FROM, chunk_count};

/// Edges incident to each particle, with the side the particle is on.
#[derive(Clone, Debug)]
pub(super) struct Incidence {
    /// `start[v]..start[v + 1]` indexes `edges` for particle `v`.
    start: Vec<u32>,
    /// Edge index times two, plus 1 when the particle is the edge's second end.
    edges: Vec<u32>,
}

impl Incidence {
    /// The incidence of `ends` (each edge's two particles) over `vertex_count` particles.
    fn new(vertex_count: usize, ends: &[[u32; 2]]) -> Self {
        let mut count = vec![0u32; vertex_count + 1];
        for [a, b] in ends {
            count[*a as usize + 1] += 1;
            count[*b as usize + 1] += 1;
        }
        for v in 0..vertex_count {
            count[v + 1] += count[v];
        }
        let mut fill = count.clone();
        let mut edges = vec![0u32; count[vertex_count] as usize];
        for (e, [a, b]) in ends.iter().enumerate() {
            for (side, v) in [(0, *a), (1, *b)] {
                edges[fill[v as usize] as usize] = 2 * e as u32 + side;
                fill[v as usize] += 1;
            }
        }
        Incidence { start: count, edges }
    }

    /// How many edges particle `v` is an end of.
    fn degree(&self, v: usize) -> usize {
        (self.start[v + 1] - self.start[v]) as usize
    }

    /// `(edge, sign)` of each edge at particle `v`: sign +1 at the first end, −1 at the second.
    pub(super) fn of(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let range = self.start[v] as usize..self.start[v + 1] as usize;
        self.edges[range].iter().map(|&k| ((k / 2) as usize, if k % 2 == 0 { 1.0 } else { -1.0 }))
    }
}

/// One constrained edge linearised at the current iterate.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct EdgeState {
    /// Unit direction from the second end to the first (∂C/∂x_a).
    pub direction: Vector3<f64>,
    /// Constraint value C = |x_a − x_b| − (1 + ε) L, m.
    pub violation: f64,
    /// Diagonal entry of J W Jᵀ, 1/kg; 0 when neither end can move along the edge.
    pub diagonal: f64,
}

/// Edges within this strain of their limit join the active set before they
/// exceed it (the multipliers release those that would push): a cloth
/// hanging on its constraints keeps them from step to step, and the Newton
/// iterations need not discover them one ring at a time.
pub const NEAR_LIMIT: f64 = 1e-3;

/// The strain-limited edges: fixed by the mesh, their maximal lengths set
/// by the fabrics.
#[derive(Clone, Debug)]
pub(super) struct EdgeSet {
    /// Each edge's two particles.
    pub ends: Vec<[u32; 2]>,
    /// Each edge's rest length `L`, m.
    pub rest_length: Vec<f64>,
    /// Each edge's maximal length `(1 + ε) L`, m (infinite without a limit).
    pub max_length: Vec<f64>,
    /// The edges at each particle.
    pub incidence: Incidence,
}

impl EdgeSet {
    /// The edges `ends` among `vertex_count` particles with their rest
    /// lengths (m), without limits (infinite maximal lengths).
    pub fn new(vertex_count: usize, ends: Vec<[u32; 2]>, rest_length: Vec<f64>) -> Self {
        let incidence = Incidence::new(vertex_count, &ends);
        let max_length = vec![f64::INFINITY; ends.len()];
        EdgeSet { ends, rest_length, max_length, incidence }
    }

    /// The most edges a path between two particles must cross, over every
    /// connected piece of cloth (a double sweep: from a particle of each
    /// piece to the one furthest from it, then to the one furthest from
    /// that; exact on a grid, a lower bound elsewhere). An `n × n` grid's
    /// warp and weft span `2 (n − 1)`.
    pub fn span_in_edges(&self) -> u32 {
        let n = self.incidence.start.len() - 1;
        let mut distance = vec![u32::MAX; n];
        let mut queue = Vec::with_capacity(n);
        let mut span = 0;
        for first in 0..n {
            if distance[first] != u32::MAX {
                continue;
            }
            let (furthest, _) = self.sweep(first, &mut distance, &mut queue);
            for &v in &queue {
                distance[v as usize] = u32::MAX;
            }
            let (_, across) = self.sweep(furthest, &mut distance, &mut queue);
            span = span.max(across);
        }
        span
    }

    /// A breadth-first search from `from` over unvisited particles
    /// (`u32::MAX` in `distance`), which it marks with their distance in
    /// edges; `queue` ends holding the particles it reached. Returns the
    /// furthest particle and its distance.
    fn sweep(&self, from: usize, distance: &mut [u32], queue: &mut Vec<u32>) -> (usize, u32) {
        queue.clear();
        queue.push(from as u32);
        distance[from] = 0;
        let mut next = 0;
        while next < queue.len() {
            let v = queue[next] as usize;
            next += 1;
            for (e, _) in self.incidence.of(v) {
                let [a, b] = self.ends[e];
                let other = (if a as usize == v { b } else { a }) as usize;
                if distance[other] == u32::MAX {
                    distance[other] = distance[v] + 1;
                    queue.push(other as u32);
                }
            }
        }
        let last = queue[queue.len() - 1] as usize;
        (last, distance[last])
    }
}

/// The particles, as a linearisation reads them.
#[derive(Clone, Copy)]
pub(super) struct Particles<'a> {
    /// Positions, m.
    pub x: &'a [Vector3<f64>],
    /// What each particle may do (pinned, on a surface, held, free).
    pub constraints: &'a [Constraint],
    /// Masses, kg.
    pub mass: &'a [f64],
}

/// What a chunk of edges contributes to the projection's figures.
#[derive(Clone, Copy, Debug, Default)]
struct ChunkSummary {
    /// Largest strain beyond its limit of a movable edge, unitless (0 when none is over).
    largest_movable_excess: f64,
    /// `Σ_e max(0, C_e / L_e)²` over the chunk's edges, unitless.
    squared_excess: f64,
    /// The same sum over the chunk's movable edges only, unitless.
    squared_movable_excess: f64,
}

/// Every constrained edge linearised at the current positions, with each
/// chunk's summary (see the module documentation).
#[derive(Clone, Debug, Default)]
pub(super) struct LinearisedEdges {
    /// Per edge.
    pub states: Vec<EdgeState>,
    /// Per edge: its ends can move along it (see [`is_movable`]).
    movable: Vec<bool>,
    /// Per edge: movable, and over its limit or within [`NEAR_LIMIT`] of it.
    pub near: Vec<bool>,
    /// Per chunk of [`CHUNK`] edges.
    summaries: Vec<ChunkSummary>,
    /// Per chunk: an edge of it was linearised again since its summary.
    stale: Vec<bool>,
    /// Per particle: among the particles [`Self::update_at`] is given,
    /// scratch (all false between calls).
    is_moved: Vec<bool>,
}

/// One chunk of the per-edge parts of [`LinearisedEdges`].
struct ChunkMut<'a> {
    states: &'a mut [EdgeState],
    movable: &'a mut [bool],
    near: &'a mut [bool],
}

impl LinearisedEdges {
    /// Linearises every edge at `particles`, in parallel chunks.
    pub fn linearise_all(&mut self, edges: &EdgeSet, particles: Particles) {
        let n = edges.ends.len();
        self.states.resize(n, EdgeState::default());
        self.movable.resize(n, false);
        self.near.resize(n, false);
        self.summaries.resize(chunk_count(n), ChunkSummary::default());
        self.stale.clear();
        self.stale.resize(chunk_count(n), false);
        let work = |(c, (((states, movable), near), summary)): (usize, (((_, _), _), &mut ChunkSummary))| {
            *summary = linearise_chunk(c * CHUNK, ChunkMut { states, movable, near }, edges, particles);
        };
        let (states, movable, near) = (&mut self.states, &mut self.movable, &mut self.near);
        if n < PARALLEL_FROM {
            let chunks = states.chunks_mut(CHUNK).zip(movable.chunks_mut(CHUNK)).zip(near.chunks_mut(CHUNK));
            chunks.zip(self.summaries.iter_mut()).enumerate().for_each(work);
        } else {
            let chunks =
                states.par_chunks_mut(CHUNK).zip(movable.par_chunks_mut(CHUNK)).zip(near.par_chunks_mut(CHUNK));
            chunks.zip(self.summaries.par_iter_mut()).enumerate().for_each(work);
        }
    }

    /// Linearises again, at `particles`, every edge at one of `moved` (the
    /// only particles that moved, or whose constraints changed, since the
    /// last linearisation), once each (an edge between two of them from its
    /// end with the lower index), and redoes the summaries of their chunks.
    /// When they reach most of the edges, every edge is linearised again in
    /// parallel chunks instead: the same bits, on both cores.
    pub fn update_at(&mut self, moved: &[u32], edges: &EdgeSet, particles: Particles) {
        let reached: usize = moved.iter().map(|&v| edges.incidence.degree(v as usize)).sum();
        if edges.ends.len() >= PARALLEL_FROM && 2 * reached >= edges.ends.len() {
            return self.linearise_all(edges, particles);
        }
        self.is_moved.resize(particles.x.len(), false);
        for &v in moved {
            self.is_moved[v as usize] = true;
        }
        for &v in moved {
            for (e, _) in edges.incidence.of(v as usize) {
                let [a, b] = edges.ends[e];
                let other = if a == v { b } else { a };
                if other < v && self.is_moved[other as usize] {
                    continue;
                }
                (self.states[e], self.movable[e], self.near[e]) = linearise_edge(e, edges, particles);
                self.stale[e / CHUNK] = true;
            }
        }
        for &v in moved {
            self.is_moved[v as usize] = false;
        }
        for (c, stale) in self.stale.iter_mut().enumerate().filter(|(_, stale)| **stale) {
            let range = c * CHUNK..((c + 1) * CHUNK).min(self.states.len());
            let (states, movable) = (&self.states[range.clone()], &self.movable[range.clone()]);
            self.summaries[c] = summarise(range.start, states, movable, edges);
            *stale = false;
        }
    }

    /// Largest strain beyond its limit of a movable edge, unitless (0 when all are within).
    pub fn largest_movable_excess(&self) -> f64 {
        self.summaries.iter().fold(0.0, |largest, s| largest.max(s.largest_movable_excess))
    }

    /// `Σ_e max(0, C_e / L_e)²` over every edge, unitless: what a Newton step must reduce.
    pub fn squared_excess(&self) -> f64 {
        self.summaries.iter().map(|s| s.squared_excess).sum()
    }

    /// [`Self::squared_excess`] over the movable edges only, unitless: what
    /// a Newton step can reduce at all (an edge between two pins stretched
    /// by them keeps its share whatever the step does).
    pub fn squared_movable_excess(&self) -> f64 {
        self.summaries.iter().map(|s| s.squared_movable_excess).sum()
    }
}

/// Linearises the chunk of edges from `first` into `states`, `movable`
/// and `near`, and returns its summary.
fn linearise_chunk(first: usize, chunk: ChunkMut, edges: &EdgeSet, particles: Particles) -> ChunkSummary {
    let ChunkMut { states, movable, near } = chunk;
    for (k, ((state, movable), near)) in states.iter_mut().zip(movable.iter_mut()).zip(near.iter_mut()).enumerate() {
        (*state, *movable, *near) = linearise_edge(first + k, edges, particles);
    }
    summarise(first, states, movable, edges)
}

/// Edge `e` linearised at `particles`, whether it is movable and whether it is near its limit.
fn linearise_edge(e: usize, edges: &EdgeSet, particles: Particles) -> (EdgeState, bool, bool) {
    let state = edge_state(particles, edges.ends[e], edges.max_length[e]);
    let movable = is_movable(&state, edges.ends[e], particles.mass);
    let near = movable && state.violation > -NEAR_LIMIT * edges.rest_length[e];
    (state, movable, near)
}

/// The summary of the chunk of `states` (and their `movable` flags) whose first edge is `first`.
fn summarise(first: usize, states: &[EdgeState], movable: &[bool], edges: &EdgeSet) -> ChunkSummary {
    let mut summary = ChunkSummary::default();
    for (k, (state, &movable)) in states.iter().zip(movable).enumerate() {
        let excess = if state.violation > 0.0 { state.violation / edges.rest_length[first + k] } else { 0.0 };
        summary.squared_excess += excess * excess;
        if movable {
            summary.squared_movable_excess += excess * excess;
            summary.largest_movable_excess = summary.largest_movable_excess.max(excess);
        }
    }
    summary
}

/// Edge `[a, b]` with maximal length `max_length` (m) linearised at `particles`.
fn edge_state(particles: Particles, [a, b]: [u32; 2], max_length: f64) -> EdgeState {
    let Particles { x, constraints, mass } = particles;
    let weight = |v: u32, d: &Vector3<f64>| constraints[v as usize].filter(*d).dot(d) / mass[v as usize];
    let edge = x[a as usize] - x[b as usize];
    let length = edge.norm();
    let direction = if length > 0.0 { edge / length } else { Vector3::zeros() };
    let diagonal = weight(a, &direction) + weight(b, &direction);
    EdgeState { direction, violation: length - max_length, diagonal }
}

/// Whether `edge`'s ends can move along it (its `J W Jᵀ` diagonal is more
/// than round-off of its ends' inverse masses).
fn is_movable(edge: &EdgeState, [a, b]: [u32; 2], mass: &[f64]) -> bool {
    edge.diagonal > 1e-12 * (1.0 / mass[a as usize] + 1.0 / mass[b as usize])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of `n` squares (two triangles each) along X with a 10 %
    /// limit, and positions stretched by 12 % along X, with a wave.
    fn stretched_strip(n: usize) -> (EdgeSet, Vec<Vector3<f64>>) {
        let vertex = |i: usize, j: usize| (2 * i + j) as u32;
        let mut ends = Vec::new();
        for i in 0..n {
            ends.extend([[vertex(i, 0), vertex(i + 1, 0)], [vertex(i, 1), vertex(i + 1, 1)]]);
            ends.extend([[vertex(i, 0), vertex(i + 1, 1)], [vertex(i, 0), vertex(i, 1)]]);
        }
        ends.push([vertex(n, 0), vertex(n, 1)]);
        let rest = |v: u32| Vector3::new((v / 2) as f64, 0.0, (v % 2) as f64);
        let rest_length = ends.iter().map(|[a, b]| (rest(*a) - rest(*b)).norm()).collect();
        let mut edges = EdgeSet::new(2 * (n + 1), ends, rest_length);
        edges.max_length = edges.rest_length.iter().map(|l| 1.1 * l).collect();
        let x =
            (0..2 * (n + 1)).map(|k| Vector3::new(1.12 * (k / 2) as f64, 0.1 * ((k / 2) as f64).sin(), (k % 2) as f64));
        (edges, x.collect())
    }

    /// The warp and weft of an `n × n` grid (no diagonals), unit rest lengths.
    fn warp_and_weft(n: usize) -> EdgeSet {
        let (ends, _) = crate::sim::test_grid::quad_grid(n);
        let ends: Vec<[u32; 2]> = ends.into_iter().filter(|[a, b]| b - a == 1 || (b - a) as usize == n).collect();
        let rest_length = vec![1.0; ends.len()];
        EdgeSet::new(n * n, ends, rest_length)
    }

    #[test]
    fn a_grid_spans_its_two_sides_and_a_second_piece_counts_on_its_own() {
        assert_eq!(warp_and_weft(9).span_in_edges(), 16);
        assert_eq!(warp_and_weft(1).span_in_edges(), 0);
        // A 3 × 3 grid and, apart from it, a strip of 6 particles.
        let mut ends = warp_and_weft(3).ends;
        ends.extend((9..14).map(|v| [v, v + 1]));
        let rest_length = vec![1.0; ends.len()];
        assert_eq!(EdgeSet::new(15, ends, rest_length).span_in_edges(), 5);
    }

    #[test]
    fn updating_the_moved_edges_gives_the_bits_of_a_full_linearisation() {
        let (edges, mut x) = stretched_strip(400);
        let mass = vec![0.01; x.len()];
        let mut constraints = vec![Constraint::Free; x.len()];
        constraints[0] = Constraint::Fixed;
        let mut updated = LinearisedEdges::default();
        updated.linearise_all(&edges, Particles { x: &x, constraints: &constraints, mass: &mass });
        let moved: Vec<u32> = vec![3, 4, 5, 300, 301, 801];
        for &v in &moved {
            x[v as usize] += Vector3::new(-0.07, 0.01 * v as f64, 0.02);
        }
        constraints[4] = Constraint::Normal(Vector3::y());
        let particles = Particles { x: &x, constraints: &constraints, mass: &mass };
        updated.update_at(&moved, &edges, particles);
        let mut full = LinearisedEdges::default();
        full.linearise_all(&edges, particles);
        for (a, b) in updated.states.iter().zip(&full.states) {
            assert_eq!(a.direction, b.direction);
            assert_eq!((a.violation.to_bits(), a.diagonal.to_bits()), (b.violation.to_bits(), b.diagonal.to_bits()));
        }
        assert_eq!(updated.near, full.near);
        assert_eq!(updated.squared_excess().to_bits(), full.squared_excess().to_bits());
        assert_eq!(updated.largest_movable_excess(), full.largest_movable_excess());

        // Most particles moved: every edge is linearised again, the same bits.
        let most: Vec<u32> = (0..x.len() as u32).filter(|v| v % 5 != 0).collect();
        for &v in &most {
            x[v as usize].y += 0.003 * f64::from(v % 7);
        }
        let particles = Particles { x: &x, constraints: &constraints, mass: &mass };
        updated.update_at(&most, &edges, particles);
        full.linearise_all(&edges, particles);
        let bits = |l: &LinearisedEdges| l.states.iter().map(|s| s.violation.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&updated), bits(&full));
        assert_eq!(updated.squared_excess().to_bits(), full.squared_excess().to_bits());
    }

    #[test]
    fn the_summaries_are_the_excess_of_each_edge_beyond_its_limit() {
        let (edges, x) = stretched_strip(3);
        let mass = vec![0.01; x.len()];
        let constraints = vec![Constraint::Free; x.len()];
        let mut linearised = LinearisedEdges::default();
        linearised.linearise_all(&edges, Particles { x: &x, constraints: &constraints, mass: &mass });
        let excess: Vec<f64> = (edges.ends.iter())
            .zip(&edges.max_length)
            .zip(&edges.rest_length)
            .map(|(([a, b], max), rest)| ((x[*a as usize] - x[*b as usize]).norm() - max).max(0.0) / rest)
            .collect();
        let squared: f64 = excess.iter().map(|e| e * e).sum();
        assert!((linearised.squared_excess() - squared).abs() < 1e-15);
        assert_eq!(linearised.largest_movable_excess(), excess.iter().fold(0.0, |m: f64, e| m.max(*e)));
        // The rungs (Z) are unstretched, the rails (X) 12 % long against a 10 % limit.
        assert!(!linearised.near[3] && linearised.near[0]);
        assert!(linearised.largest_movable_excess() > 0.015);
    }

    /// An edge whose ends are both pinned counts in the squared excess but
    /// not in the movable one; every other edge counts in both.
    #[test]
    fn the_movable_squared_excess_leaves_out_edges_between_two_pins() {
        let (edges, x) = stretched_strip(3);
        let mass = vec![0.01; x.len()];
        let mut constraints = vec![Constraint::Free; x.len()];
        let [a, b] = edges.ends[0];
        (constraints[a as usize], constraints[b as usize]) = (Constraint::Fixed, Constraint::Fixed);
        let mut linearised = LinearisedEdges::default();
        linearised.linearise_all(&edges, Particles { x: &x, constraints: &constraints, mass: &mass });
        let pinned_excess = ((x[a as usize] - x[b as usize]).norm() - edges.max_length[0]) / edges.rest_length[0];
        assert!(pinned_excess > 0.015, "the pinned rail is over its limit: {pinned_excess}");
        let (all, movable) = (linearised.squared_excess(), linearised.squared_movable_excess());
        assert!((all - movable - pinned_excess * pinned_excess).abs() < 1e-15, "{all} vs {movable}");
    }
}
