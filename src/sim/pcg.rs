//! Filtered preconditioned conjugate gradients (Baraff and Witkin 1998, §5.3).
//!
//! Solves `A x = b` for a symmetric positive-definite block matrix while rows
//! marked *fixed* keep the value they start with: the residual and search
//! directions are filtered to zero there, so pinned particles get exactly their
//! prescribed velocity change. The preconditioner is the inverse of each 3×3
//! diagonal block. All reductions go through [`super::parallel::sum`], so the
//! result is bit-identical at any thread count.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::parallel::{self, CHUNK};
use super::sparse::BlockPattern;

/// When to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgSettings {
    /// Stop when the preconditioned residual norm falls below this fraction of
    /// the right-hand side's, unitless.
    pub tolerance: f64,
    /// Stop after this many iterations even if not converged.
    pub max_iterations: u32,
}

/// How a solve ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PcgReport {
    /// Iterations run.
    pub iterations: u32,
    /// Final preconditioned residual norm over the right-hand side's, unitless.
    pub relative_residual: f64,
    /// True when the tolerance was reached.
    pub converged: bool,
}

/// Reusable buffers of the solver.
#[derive(Clone, Debug, Default)]
pub struct PcgWorkspace {
    residual: Vec<Vector3<f64>>,
    direction: Vec<Vector3<f64>>,
    product: Vec<Vector3<f64>>,
    preconditioned: Vec<Vector3<f64>>,
    inverse_diagonal: Vec<Matrix3<f64>>,
    partials: Vec<f64>,
}

impl PcgWorkspace {
    fn resize(&mut self, n: usize) {
        for v in [
            &mut self.residual,
            &mut self.direction,
            &mut self.product,
            &mut self.preconditioned,
        ] {
            v.resize(n, Vector3::zeros());
        }
        self.inverse_diagonal.resize(n, Matrix3::zeros());
    }
}

/// Solves `A x = b` (block values `a` on `pattern`) starting from `x`; rows with
/// `fixed[i]` keep `x[i]`.
pub fn solve(
    pattern: &BlockPattern,
    a: &[Matrix3<f64>],
    b: &[Vector3<f64>],
    fixed: &[bool],
    x: &mut [Vector3<f64>],
    settings: PcgSettings,
    ws: &mut PcgWorkspace,
) -> PcgReport {
    let n = b.len();
    ws.resize(n);
    ws.inverse_diagonal
        .par_iter_mut()
        .enumerate()
        .with_min_len(CHUNK)
        .for_each(|(i, p)| {
            let block = a[pattern.diagonal(i)];
            *p = block
                .try_inverse()
                .unwrap_or_else(|| Matrix3::from_diagonal(&block.diagonal().map(|d| 1.0 / d)));
        });
    let filter = |i: usize, v: Vector3<f64>| if fixed[i] { Vector3::zeros() } else { v };

    let reference = parallel::sum(n, &mut ws.partials, |i| {
        let bi = filter(i, b[i]);
        bi.dot(&(ws.inverse_diagonal[i] * bi))
    });
    pattern.multiply(a, x, &mut ws.product);
    let PcgWorkspace {
        residual,
        direction,
        product,
        preconditioned,
        inverse_diagonal,
        partials,
    } = ws;
    par_each(residual, |i, r| *r = filter(i, b[i] - product[i]));
    par_each(direction, |i, d| {
        *d = filter(i, inverse_diagonal[i] * residual[i])
    });
    let mut delta = parallel::sum(n, partials, |i| residual[i].dot(&direction[i]));
    let threshold = settings.tolerance * settings.tolerance * reference;
    let relative = |delta: f64| {
        if reference > 0.0 {
            (delta / reference).max(0.0).sqrt()
        } else {
            0.0
        }
    };

    let mut iterations = 0;
    while delta > threshold && iterations < settings.max_iterations {
        pattern.multiply(a, direction, product);
        par_each(product, |i, q| *q = filter(i, *q));
        let curvature = parallel::sum(n, partials, |i| direction[i].dot(&product[i]));
        if curvature <= 0.0 {
            break;
        }
        let alpha = delta / curvature;
        x.par_chunks_mut(CHUNK)
            .zip(residual.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (xs, rs))| {
                for (k, (xi, ri)) in xs.iter_mut().zip(rs.iter_mut()).enumerate() {
                    let i = c * CHUNK + k;
                    *xi += direction[i] * alpha;
                    *ri -= product[i] * alpha;
                }
            });
        par_each(preconditioned, |i, s| {
            *s = inverse_diagonal[i] * residual[i]
        });
        let previous = delta;
        delta = parallel::sum(n, partials, |i| residual[i].dot(&preconditioned[i]));
        let beta = delta / previous;
        par_each(direction, |i, d| {
            *d = filter(i, preconditioned[i] + *d * beta)
        });
        iterations += 1;
    }
    PcgReport {
        iterations,
        relative_residual: relative(delta),
        converged: delta <= threshold,
    }
}

/// Sets every element of `v` from its index, in parallel chunks.
fn par_each(v: &mut [Vector3<f64>], f: impl Fn(usize, &mut Vector3<f64>) + Sync) {
    v.par_chunks_mut(CHUNK).enumerate().for_each(|(c, chunk)| {
        for (k, e) in chunk.iter_mut().enumerate() {
            f(c * CHUNK + k, e);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A random SPD block matrix on a ring of `n` particles (couplings to ±1, ±2).
    fn ring_system(n: usize) -> (BlockPattern, Vec<Matrix3<f64>>, Vec<Vector3<f64>>) {
        let pairs = (0..n as u32).flat_map(|i| [[i, (i + 1) % n as u32], [i, (i + 2) % n as u32]]);
        let pattern = BlockPattern::new(n, pairs);
        let mut a = vec![Matrix3::zeros(); pattern.stored_blocks()];
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5
        };
        for i in 0..n {
            for j in [(i + 1) % n, (i + 2) % n] {
                // A spring-like PSD coupling K = u uᵀ s.
                let u = Vector3::new(rand(), rand(), rand());
                let k = u * u.transpose() * 10.0;
                for (r, c, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                    a[pattern.slot(r, c).unwrap()] += k * sign;
                }
            }
            a[pattern.diagonal(i)] += Matrix3::identity() * 0.05;
        }
        let b = (0..n)
            .map(|_| Vector3::new(rand(), rand(), rand()))
            .collect();
        (pattern, a, b)
    }

    fn dense(pattern: &BlockPattern, a: &[Matrix3<f64>]) -> DMatrix<f64> {
        let n = pattern.rows();
        let mut m = DMatrix::zeros(3 * n, 3 * n);
        for i in 0..n {
            for s in pattern.row(i) {
                m.view_mut((3 * i, 3 * pattern.column(s)), (3, 3))
                    .copy_from(&a[s]);
            }
        }
        m
    }

    const TIGHT: PcgSettings = PcgSettings {
        tolerance: 1e-12,
        max_iterations: 1000,
    };

    #[test]
    fn pcg_matches_a_dense_cholesky_solve() {
        let (pattern, a, b) = ring_system(20);
        let mut x = vec![Vector3::zeros(); 20];
        let report = solve(
            &pattern,
            &a,
            &b,
            &[false; 20],
            &mut x,
            TIGHT,
            &mut PcgWorkspace::default(),
        );
        assert!(report.converged, "{report:?}");
        let rhs = DVector::from_iterator(60, b.iter().flat_map(|v| v.iter().copied()));
        let exact = dense(&pattern, &a).cholesky().unwrap().solve(&rhs);
        for i in 0..20 {
            assert!((x[i] - exact.fixed_rows::<3>(3 * i)).norm() < 1e-8 * exact.norm());
        }
    }

    #[test]
    fn fixed_rows_keep_their_value_exactly_and_the_rest_solve_the_reduced_system() {
        let n = 12;
        let (pattern, a, b) = ring_system(n);
        let mut fixed = vec![false; n];
        fixed[3] = true;
        fixed[7] = true;
        let prescribed = Vector3::new(0.25, -1.5, 3.0);
        let mut x = vec![Vector3::zeros(); n];
        x[3] = prescribed;
        solve(
            &pattern,
            &a,
            &b,
            &fixed,
            &mut x,
            TIGHT,
            &mut PcgWorkspace::default(),
        );
        assert_eq!(x[3], prescribed);
        assert_eq!(x[7], Vector3::zeros());
        // Free rows satisfy their equations.
        let mut ax = vec![Vector3::zeros(); n];
        pattern.multiply(&a, &x, &mut ax);
        for i in (0..n).filter(|&i| !fixed[i]) {
            assert!((ax[i] - b[i]).norm() < 1e-8, "row {i}");
        }
    }

    #[test]
    fn loose_tolerance_stops_early_and_says_so() {
        let (pattern, a, b) = ring_system(40);
        let mut x = vec![Vector3::zeros(); 40];
        let settings = PcgSettings {
            tolerance: 1e-2,
            max_iterations: 1000,
        };
        let report = solve(
            &pattern,
            &a,
            &b,
            &[false; 40],
            &mut x,
            settings,
            &mut PcgWorkspace::default(),
        );
        assert!(report.converged && report.relative_residual <= 1e-2);
        let capped = PcgSettings {
            tolerance: 1e-14,
            max_iterations: 2,
        };
        let mut x = vec![Vector3::zeros(); 40];
        let report = solve(
            &pattern,
            &a,
            &b,
            &[false; 40],
            &mut x,
            capped,
            &mut PcgWorkspace::default(),
        );
        assert_eq!(report.iterations, 2);
        assert!(!report.converged);
    }
}
