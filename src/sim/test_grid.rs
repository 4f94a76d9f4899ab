//! A square cloth for tests: the particles and springs of an `n × n` quad grid.

use nalgebra::Vector3;

/// The springs of an `n × n` grid (edges along both axes and both diagonals
/// of every quad), and the particles' positions (1 m apart in XZ, particle
/// `i` at column `i % n`, row `i / n`).
pub fn quad_grid(n: usize) -> (Vec<[u32; 2]>, Vec<Vector3<f64>>) {
    let id = |r: usize, c: usize| (r * n + c) as u32;
    let mut edges = Vec::new();
    for r in 0..n {
        for c in 0..n {
            if c + 1 < n {
                edges.push([id(r, c), id(r, c + 1)]);
            }
            if r + 1 < n {
                edges.push([id(r, c), id(r + 1, c)]);
            }
            if r + 1 < n && c + 1 < n {
                edges.push([id(r, c), id(r + 1, c + 1)]);
                edges.push([id(r, c + 1), id(r + 1, c)]);
            }
        }
    }
    let points = (0..n * n).map(|i| Vector3::new((i % n) as f64, 0.0, (i / n) as f64)).collect();
    (edges, points)
}
