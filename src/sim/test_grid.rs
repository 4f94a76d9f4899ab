//! Cloths for tests: an `n × n` quad grid, a ring of particles; and a seeded
//! sampler for tests that draw random cases.

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

/// The positions of a ring of `n` particles of radius 1 m in XZ.
pub fn ring_positions(n: usize) -> Vec<Vector3<f64>> {
    (0..n).map(|i| i as f64 / n as f64 * std::f64::consts::TAU).map(|a| Vector3::new(a.cos(), 0.0, a.sin())).collect()
}

/// Uniform samples in `[-0.5, 0.5)` from a xorshift generator started at
/// `seed` (not zero): the same cases on every run.
pub fn uniform_samples(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}
