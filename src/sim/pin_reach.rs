//! Whether the pins leave the strain limits reachable (PAPER eq. 1, 2).
//!
//! Between two pinned particles the cloth can be at most as long as its
//! shortest path of stretch edges, each at its maximal length `(1 + ε) L`:
//! the *reach* of the pair. Pins further apart than their reach stretch some
//! edge on every path between them past its limit, whatever the solver does:
//! the limits have no solution, and the least the largest strain can be is
//! the limit plus the excess spread evenly over the shortest path. A solver
//! that exceeds its limits there is not failing; anywhere else it is.
//!
//! Only edges with a free end count (two pinned ends leave the solver
//! nothing to move), so a reach is measured over cloth the solver owns. The
//! reaches are computed once per set of maximal lengths, by a Dijkstra
//! search from each pin (at most [`MAX_CHECKED_PINS`] of them, evenly
//! spaced in index order), and checking a frame costs a distance per pair.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use nalgebra::Vector3;

/// Pins whose reaches are kept: beyond this many, every k-th pin in index
/// order (neighbouring pins of a ring or a glued band have nearly the same
/// reaches, so spaced pins find the same pairs).
pub const MAX_CHECKED_PINS: usize = 64;

/// The reaches between pairs of pins.
#[derive(Clone, Debug, Default)]
pub struct PinReach {
    /// The pinned particles checked, ascending.
    pins: Vec<u32>,
    /// `reach[i * pins.len() + j]`: the longest the cloth between pins `i`
    /// and `j` may be, m (infinite when no path has a limit everywhere).
    reach: Vec<f64>,
    /// Rest length of the same shortest paths, m.
    rest: Vec<f64>,
}

/// Two pins further apart than the cloth between them may reach.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Unreachable {
    /// The two pinned particles.
    pub pins: [u32; 2],
    /// How much further apart they are than their reach, m.
    pub excess_m: f64,
    /// The least strain beyond its limit some edge between them must take:
    /// the excess over the rest length of their shortest path, unitless.
    pub forced_strain: f64,
}

impl std::fmt::Display for Unreachable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "limits unreachable: pins {} and {} are {:.4} m further apart than the cloth between them \
             (at least {:.2} points of strain over the limit)",
            self.pins[0],
            self.pins[1],
            self.excess_m,
            self.forced_strain * 100.0
        )
    }
}

/// The stretch edges a reach is measured over.
pub struct ReachEdges<'a> {
    /// Particle count.
    pub vertex_count: usize,
    /// Each edge's ends.
    pub ends: &'a [[u32; 2]],
    /// Each edge's rest length, m.
    pub rest_length: &'a [f64],
    /// Each edge's maximal length, m (infinite without a limit).
    pub max_length: &'a [f64],
    /// Per particle: pinned.
    pub fixed: &'a [bool],
}

impl PinReach {
    /// The reaches between the pinned particles `pins` over `edges`.
    pub fn new(edges: &ReachEdges, pins: &[u32]) -> Self {
        let mut pins = pins.to_vec();
        pins.sort_unstable();
        pins.dedup();
        let stride = pins.len().div_ceil(MAX_CHECKED_PINS).max(1);
        let pins: Vec<u32> = pins.into_iter().step_by(stride).collect();
        let graph = Graph::of(edges);
        let (mut reach, mut rest) = (Vec::with_capacity(pins.len().pow(2)), Vec::with_capacity(pins.len().pow(2)));
        for &source in &pins {
            let paths = graph.shortest_paths(source);
            reach.extend(pins.iter().map(|&p| paths[p as usize].0));
            rest.extend(pins.iter().map(|&p| paths[p as usize].1));
        }
        PinReach { pins, reach, rest }
    }

    /// The pair of pins at `x` furthest beyond its reach, if any is beyond it
    /// by more than `tolerance` (a fraction of the reach).
    pub fn worst(&self, x: &[Vector3<f64>], tolerance: f64) -> Option<Unreachable> {
        let n = self.pins.len();
        let mut worst: Option<Unreachable> = None;
        for i in 0..n {
            for j in i + 1..n {
                let reach = self.reach[i * n + j];
                let (a, b) = (self.pins[i], self.pins[j]);
                let excess_m = (x[a as usize] - x[b as usize]).norm() - reach;
                if excess_m > tolerance * reach && worst.is_none_or(|w| excess_m > w.excess_m) {
                    let forced_strain = excess_m / self.rest[i * n + j];
                    worst = Some(Unreachable { pins: [a, b], excess_m, forced_strain });
                }
            }
        }
        worst
    }
}

/// The stretch edges with a free end as an adjacency list (CSR), each
/// neighbour with the edge's maximal and rest lengths.
struct Graph {
    start: Vec<usize>,
    neighbour: Vec<(u32, f64, f64)>,
}

impl Graph {
    fn of(edges: &ReachEdges) -> Self {
        let free = |[a, b]: [u32; 2]| !(edges.fixed[a as usize] && edges.fixed[b as usize]);
        let mut degree = vec![0usize; edges.vertex_count + 1];
        for &[a, b] in edges.ends.iter().filter(|e| free(**e)) {
            degree[a as usize + 1] += 1;
            degree[b as usize + 1] += 1;
        }
        for v in 0..edges.vertex_count {
            degree[v + 1] += degree[v];
        }
        let start = degree;
        let mut fill = start.clone();
        let mut neighbour = vec![(0, 0.0, 0.0); start[edges.vertex_count]];
        for (e, &[a, b]) in edges.ends.iter().enumerate().filter(|(_, e)| free(**e)) {
            let lengths = (edges.max_length[e], edges.rest_length[e]);
            for (from, to) in [(a, b), (b, a)] {
                neighbour[fill[from as usize]] = (to, lengths.0, lengths.1);
                fill[from as usize] += 1;
            }
        }
        Graph { start, neighbour }
    }

    /// From `source`, each particle's shortest path by maximal length: that
    /// length (infinite where unreachable) and the path's rest length, m.
    fn shortest_paths(&self, source: u32) -> Vec<(f64, f64)> {
        let mut best = vec![(f64::INFINITY, f64::INFINITY); self.start.len() - 1];
        let mut queue = BinaryHeap::new();
        best[source as usize] = (0.0, 0.0);
        queue.push(Entry { length: 0.0, vertex: source });
        while let Some(Entry { length, vertex }) = queue.pop() {
            if length > best[vertex as usize].0 {
                continue;
            }
            let rest = best[vertex as usize].1;
            for &(to, max_length, rest_length) in
                &self.neighbour[self.start[vertex as usize]..self.start[vertex as usize + 1]]
            {
                let through = length + max_length;
                if through < best[to as usize].0 {
                    best[to as usize] = (through, rest + rest_length);
                    queue.push(Entry { length: through, vertex: to });
                }
            }
        }
        best
    }
}

/// A queued particle, the shortest first (then the lowest index, so the
/// search is the same on every run).
#[derive(PartialEq)]
struct Entry {
    length: f64,
    vertex: u32,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.length.total_cmp(&self.length).then_with(|| other.vertex.cmp(&self.vertex))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of `n` unit edges along X with a 1 % limit, pinned at both ends.
    fn chain(n: usize) -> (Vec<[u32; 2]>, Vec<f64>, Vec<f64>, Vec<bool>) {
        let ends = (0..n as u32).map(|i| [i, i + 1]).collect();
        let mut fixed = vec![false; n + 1];
        (fixed[0], fixed[n]) = (true, true);
        (ends, vec![1.0; n], vec![1.01; n], fixed)
    }

    fn positions(n: usize, spacing: f64) -> Vec<Vector3<f64>> {
        (0..=n).map(|i| Vector3::new(i as f64 * spacing, 0.0, 0.0)).collect()
    }

    #[test]
    fn pins_within_reach_are_reachable_and_beyond_it_are_not() {
        let (ends, rest, max, fixed) = chain(10);
        let edges = ReachEdges { vertex_count: 11, ends: &ends, rest_length: &rest, max_length: &max, fixed: &fixed };
        let reach = PinReach::new(&edges, &[10, 0]);
        assert_eq!(reach.worst(&positions(10, 1.005), 1e-9), None);
        assert_eq!(reach.worst(&positions(10, 1.0099), 1e-9), None);
        let apart = reach.worst(&positions(10, 1.03), 1e-9).expect("3 % apart is beyond a 1 % limit");
        assert_eq!(apart.pins, [0, 10]);
        assert!((apart.excess_m - (10.3 - 10.1)).abs() < 1e-12, "{apart:?}");
        // The least extra strain: 0.2 m over 10 m of rest length.
        assert!((apart.forced_strain - 0.02).abs() < 1e-12, "{apart:?}");
    }

    #[test]
    fn the_reach_is_the_shortest_path_and_edges_without_a_free_end_do_not_count() {
        // A square 0-1-2-3 with diagonal 0-2; 0 and 2 pinned: the diagonal
        // joins two pins and is left out, so the reach is round the side.
        let ends = [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]];
        let (rest, max) = ([1.0, 1.0, 1.0, 1.0, 2f64.sqrt()], [1.1, 1.1, 1.1, 1.1, 1.1 * 2f64.sqrt()]);
        let fixed = [true, false, true, false];
        let edges = ReachEdges { vertex_count: 4, ends: &ends, rest_length: &rest, max_length: &max, fixed: &fixed };
        let reach = PinReach::new(&edges, &[0, 2]);
        let x =
            |d: f64| vec![Vector3::zeros(), Vector3::new(1.0, 0.0, 0.0), Vector3::new(d, 0.0, 0.0), Vector3::zeros()];
        assert_eq!(reach.worst(&x(2.19), 1e-9), None);
        assert!(reach.worst(&x(2.21), 1e-9).is_some());
    }

    #[test]
    fn cloth_without_a_limit_reaches_anywhere() {
        let (ends, rest, _, fixed) = chain(4);
        let max = vec![f64::INFINITY; 4];
        let edges = ReachEdges { vertex_count: 5, ends: &ends, rest_length: &rest, max_length: &max, fixed: &fixed };
        assert_eq!(PinReach::new(&edges, &[0, 4]).worst(&positions(4, 100.0), 1e-9), None);
    }

    #[test]
    fn many_pins_are_checked_evenly_spaced() {
        let n = 1000;
        let (ends, rest, max, mut fixed) = chain(n);
        fixed.iter_mut().for_each(|f| *f = true);
        let pins: Vec<u32> = (0..=n as u32).collect();
        let edges =
            ReachEdges { vertex_count: n + 1, ends: &ends, rest_length: &rest, max_length: &max, fixed: &fixed };
        let reach = PinReach::new(&edges, &pins);
        assert!(reach.pins.len() <= MAX_CHECKED_PINS, "{}", reach.pins.len());
        assert_eq!(reach.pins[0], 0);
    }
}
