//! The multiplier system `J W Jᵀ μ = C` of fast projection
//! ([`super::inextensibility`]) as a sparse Cholesky factor: the
//! preconditioner of the projections that Jacobi-preconditioned conjugate
//! gradients cannot finish quickly.
//!
//! Row `e` of `J` is the gradient of edge `e`'s length: `u_e` at its first
//! end, `−u_e` at its second. Entry `(i, j)` of `J W Jᵀ` is therefore
//! `Σ_v s_iv s_jv u_iᵀ W_v u_j` over the particles `v` the two edges share
//! (`s = ±1` the side, `W_v = S_v / m_v` the particle's filtered inverse
//! mass), so the pattern is the edges' adjacency: fixed by the mesh and
//! analysed (approximate minimum degree, simplicial) once. Only the active
//! edges take part in a solve; the others get an identity row, so one
//! analysis serves every active set.
//!
//! A stretch edge set is often dependent (a flat, fully triangulated patch
//! has more edges than in-plane degrees of freedom), so `J W Jᵀ` is only
//! semi-definite. The system is scaled to a unit diagonal and shifted by
//! [`REGULARIZATION`]: the shift decides only multipliers in the null space
//! of `W Jᵀ`, which move no particle, and changes the others by a relative
//! [`REGULARIZATION`].
//!
//! Where Jacobi-preconditioned conjugate gradients need hundreds of
//! iterations (long chains of active edges held by pins or by contacts), a
//! factor costs a few dozen of them, and preconditioned by it they converge
//! in one or two. Factor and solve run on the calling thread, so the result
//! is the same at any thread count.

use std::sync::Arc;

use faer::Side;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use nalgebra::Vector3;

use super::llt::Llt;
use super::pcg::Constraint;

/// Relative shift of the scaled system's unit diagonal, unitless.
pub const REGULARIZATION: f64 = 1e-9;

/// Why the system could not be solved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EdgeSystemError {
    /// The symbolic analysis failed (out of memory or index overflow).
    #[error("analysis of the strain-limit system failed: {0}")]
    Analysis(String),
    /// Round-off made the shifted system indefinite.
    #[error("the strain-limit system is not numerically positive definite")]
    NotPositiveDefinite,
}

/// One term `sign · u_iᵀ W_v u_j` of an off-diagonal entry.
#[derive(Clone, Copy, Debug)]
struct Coupling {
    /// Index of the entry in the lower triangle's values.
    entry: u32,
    /// Row edge `i` and column edge `j` (`i > j`).
    row: u32,
    column: u32,
    /// The shared particle.
    particle: u32,
    /// `s_iv s_jv`.
    sign: f64,
}

/// What is fixed by the mesh: the lower triangle's pattern in natural edge
/// order, where each entry's value comes from, and the symbolic factor.
struct Analysis {
    edges: usize,
    /// Where each column starts, which is its diagonal entry `(e, e)`.
    column_start: Vec<u32>,
    row_index: Vec<u32>,
    couplings: Vec<Coupling>,
    symbolic: SymbolicCholesky<u32>,
}

impl Analysis {
    /// The pattern of `J W Jᵀ` for edges `ends` on `vertex_count` particles, analysed.
    fn new(vertex_count: usize, ends: &[[u32; 2]]) -> Result<Self, EdgeSystemError> {
        let mut incident: Vec<Vec<(u32, f64)>> = vec![Vec::new(); vertex_count];
        for (e, [a, b]) in ends.iter().enumerate() {
            incident[*a as usize].push((e as u32, 1.0));
            incident[*b as usize].push((e as u32, -1.0));
        }
        // (column, row, particle, sign): every edge's diagonal (it sorts
        // first in its column), and every pair of edges at a particle.
        let mut terms: Vec<(u32, u32, u32, f64)> = (0..ends.len() as u32).map(|e| (e, e, 0, 0.0)).collect();
        for (v, edges) in incident.iter().enumerate() {
            for (k, &(i, si)) in edges.iter().enumerate() {
                terms.extend(edges[..k].iter().map(|&(j, sj)| (i.min(j), i.max(j), v as u32, si * sj)));
            }
        }
        terms.sort_unstable_by_key(|&(column, row, particle, _)| (column, row, particle));
        let (mut row_index, mut column_start, mut couplings) =
            (Vec::new(), Vec::with_capacity(ends.len() + 1), Vec::new());
        for &(column, row, particle, sign) in &terms {
            if row == column {
                column_start.push(row_index.len() as u32);
                row_index.push(row);
                continue;
            }
            if row_index.last() != Some(&row) {
                row_index.push(row);
            }
            couplings.push(Coupling { entry: row_index.len() as u32 - 1, row, column, particle, sign });
        }
        column_start.push(row_index.len() as u32);
        let n = ends.len();
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &column_start, None, &row_index);
        // Edge adjacency fills little: supernodes would be a few columns wide,
        // and the simplicial factor is faster here (measured on a skirt's
        // 4,392 edges: 1.3 ms against 1.8 ms).
        let simplicial = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, simplicial)
            .map_err(|e| EdgeSystemError::Analysis(format!("{e:?}")))?;
        Ok(Analysis { edges: n, column_start, row_index, couplings, symbolic })
    }

    /// Index of entry `(e, e)` in the values.
    fn diagonal(&self, e: usize) -> usize {
        self.column_start[e] as usize
    }

    fn pattern(&self) -> SymbolicSparseColMatRef<'_, u32> {
        SymbolicSparseColMatRef::new_checked(self.edges, self.edges, &self.column_start, None, &self.row_index)
    }
}

/// What a solve reads of one edge at the current iterate.
#[derive(Clone, Copy, Debug)]
pub struct EdgeRow {
    /// Unit direction from the second end to the first, ∂C/∂x_a.
    pub direction: Vector3<f64>,
    /// Diagonal entry `(J W Jᵀ)_ee`, 1/kg (> 0 for an active edge).
    pub diagonal: f64,
}

/// The factorable system `J W Jᵀ` of a cloth's constrained edges, with its
/// work space.
pub struct EdgeSystem {
    analysis: Arc<Analysis>,
    /// Lower-triangle values of the scaled, shifted system.
    values: Vec<f64>,
    factor: Llt<f64>,
    /// `1 / √(J W Jᵀ)_ee` of each active edge (1 for the others).
    scale: Vec<f64>,
    rhs: Vec<f64>,
}

impl EdgeSystem {
    /// The system of edges `ends` on `vertex_count` particles, analysed once.
    pub fn new(vertex_count: usize, ends: &[[u32; 2]]) -> Result<Self, EdgeSystemError> {
        Ok(Self::with_analysis(Arc::new(Analysis::new(vertex_count, ends)?)))
    }

    fn with_analysis(analysis: Arc<Analysis>) -> Self {
        let symbolic = &analysis.symbolic;
        EdgeSystem {
            values: vec![0.0; analysis.row_index.len()],
            factor: Llt::new(symbolic),
            scale: vec![1.0; analysis.edges],
            rhs: vec![0.0; analysis.edges],
            analysis,
        }
    }

    /// Entries of the factor: its cost, about
    /// [`super::inextensibility::FACTOR_ENTRY_COST`] Jacobi iterations on one
    /// active edge each.
    pub fn factor_entries(&self) -> usize {
        self.analysis.symbolic.len_val()
    }

    /// Factors `J W Jᵀ` restricted to the `active` edges (`is_active` per
    /// edge, `active` their list), edge `e` linearised as `row(e)`, for
    /// particles with `constraints` and `mass` (kg).
    pub fn factor(
        &mut self,
        active: &[u32],
        is_active: &[bool],
        row: impl Fn(usize) -> EdgeRow,
        constraints: &[Constraint],
        mass: &[f64],
    ) -> Result<(), EdgeSystemError> {
        let analysis = &*self.analysis;
        self.values.fill(0.0);
        self.scale.fill(1.0);
        for e in 0..analysis.edges {
            self.values[analysis.diagonal(e)] = 1.0;
        }
        for &e in active {
            let e = e as usize;
            self.scale[e] = 1.0 / row(e).diagonal.sqrt();
            self.values[analysis.diagonal(e)] = 1.0 + REGULARIZATION;
        }
        let weighted = |v: u32, u: &Vector3<f64>| constraints[v as usize].filter(*u) / mass[v as usize];
        for c in &analysis.couplings {
            let (i, j) = (c.row as usize, c.column as usize);
            if is_active[i] && is_active[j] {
                let coupling = c.sign * row(i).direction.dot(&weighted(c.particle, &row(j).direction));
                self.values[c.entry as usize] += coupling * self.scale[i] * self.scale[j];
            }
        }
        let matrix = SparseColMatRef::new(analysis.pattern(), &self.values);
        self.factor.factor(&analysis.symbolic, matrix).map_err(|_| EdgeSystemError::NotPositiveDefinite)
    }

    /// `out = M⁻¹ rhs` on the `active` edges (as [`Self::factor`] was given
    /// them; `rhs` and `out` hold one value per entry of `active`), with `M`
    /// the factored `J W Jᵀ`.
    pub fn solve(&mut self, active: &[u32], rhs: &[f64], out: &mut [f64]) {
        self.rhs.fill(0.0);
        for (&e, &value) in active.iter().zip(rhs) {
            self.rhs[e as usize] = value * self.scale[e as usize];
        }
        self.factor.solve_in_place(&self.analysis.symbolic, &mut self.rhs);
        for (value, &e) in out.iter_mut().zip(active) {
            *value = self.rhs[e as usize] * self.scale[e as usize];
        }
    }
}

impl Clone for EdgeSystem {
    /// The same analysis, with fresh work space (each projection builds its
    /// own factors).
    fn clone(&self) -> Self {
        Self::with_analysis(Arc::clone(&self.analysis))
    }
}

impl std::fmt::Debug for EdgeSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EdgeSystem")
            .field("edges", &self.analysis.edges)
            .field("factor_values", &self.analysis.symbolic.len_val())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A flat triangulated square of `n` × `n` particles (all its edges,
    /// diagonals included), positions jittered in the plane and lifted by a
    /// gentle wave (`lift`), with pseudo-random masses.
    fn patch(n: u32, lift: f64) -> (Vec<[u32; 2]>, Vec<Vector3<f64>>, Vec<f64>) {
        let at = |x: u32, y: u32| y * n + x;
        let mut ends = Vec::new();
        for y in 0..n {
            for x in 0..n {
                if x + 1 < n {
                    ends.push([at(x, y), at(x + 1, y)]);
                }
                if y + 1 < n {
                    ends.push([at(x, y), at(x, y + 1)]);
                }
                if x + 1 < n && y + 1 < n {
                    ends.push([at(x + 1, y), at(x, y + 1)]);
                }
            }
        }
        let positions = (0..n * n)
            .map(|k| {
                let (x, y) = (f64::from(k % n), f64::from(k / n));
                let jitter = 0.1 * (1.7 * x + 3.1 * y).sin();
                Vector3::new(x + jitter, lift * (x * 0.9).sin() * (y * 0.7).cos(), y - jitter)
            })
            .collect();
        let mass = (0..n * n).map(|k| 1.0 + 0.5 * f64::from(k % 3)).collect();
        (ends, positions, mass)
    }

    fn rows(ends: &[[u32; 2]], x: &[Vector3<f64>], constraints: &[Constraint], mass: &[f64]) -> Vec<EdgeRow> {
        ends.iter()
            .map(|&[a, b]| {
                let direction = (x[a as usize] - x[b as usize]).normalize();
                let weight = |v: u32| constraints[v as usize].filter(direction).dot(&direction) / mass[v as usize];
                EdgeRow { direction, diagonal: weight(a) + weight(b) }
            })
            .collect()
    }

    /// `J` (one row per listed edge, 3 columns per particle) and `W`, dense.
    fn dense(
        ends: &[[u32; 2]],
        listed: &[u32],
        rows: &[EdgeRow],
        constraints: &[Constraint],
        mass: &[f64],
    ) -> (DMatrix<f64>, DMatrix<f64>) {
        let n = mass.len();
        let mut j = DMatrix::zeros(listed.len(), 3 * n);
        for (r, &e) in listed.iter().enumerate() {
            let [a, b] = ends[e as usize];
            let u = rows[e as usize].direction;
            j.view_mut((r, 3 * a as usize), (1, 3)).copy_from(&u.transpose());
            j.view_mut((r, 3 * b as usize), (1, 3)).copy_from(&(-u).transpose());
        }
        let mut w = DMatrix::zeros(3 * n, 3 * n);
        for v in 0..n {
            w.view_mut((3 * v, 3 * v), (3, 3)).copy_from(&(constraints[v].filter_matrix() / mass[v]));
        }
        (j, w)
    }

    /// On a curved patch with a pinned and a sliding particle, the factor
    /// solves `J W Jᵀ μ = C` over the active edges as a dense solve does.
    #[test]
    fn the_factor_solves_the_active_edges_system() {
        let (ends, x, mass) = patch(5, 0.3);
        let mut constraints = vec![Constraint::Free; mass.len()];
        constraints[0] = Constraint::Fixed;
        constraints[7] = Constraint::Normal(Vector3::new(0.0, 0.6, 0.8));
        let rows = rows(&ends, &x, &constraints, &mass);
        let active: Vec<u32> = (0..ends.len() as u32).filter(|e| e % 3 != 2).collect();
        let mut is_active = vec![false; ends.len()];
        active.iter().for_each(|&e| is_active[e as usize] = true);
        let mut system = EdgeSystem::new(mass.len(), &ends).unwrap();
        system.factor(&active, &is_active, |e| rows[e], &constraints, &mass).unwrap();
        let violation: Vec<f64> = active.iter().map(|&e| 0.01 * (f64::from(e) * 0.37).cos()).collect();
        let mut mu = vec![0.0; active.len()];
        system.solve(&active, &violation, &mut mu);

        let (j, w) = dense(&ends, &active, &rows, &constraints, &mass);
        let expected = (&j * &w * j.transpose()).cholesky().unwrap().solve(&DVector::from_column_slice(&violation));
        let error = (DVector::from_column_slice(&mu) - &expected).norm() / expected.norm();
        assert!(error < 1e-6, "relative error {error:e}");
    }

    /// A flat, fully triangulated patch has more edges than in-plane
    /// freedoms: `J W Jᵀ` is singular. The shifted factor still exists, and
    /// the particle motion `W Jᵀ μ` it gives is the one of any exact solution.
    #[test]
    fn a_dependent_edge_set_moves_the_particles_as_an_exact_solution_does() {
        let (ends, x, mass) = patch(5, 0.0);
        let constraints = vec![Constraint::Free; mass.len()];
        let rows = rows(&ends, &x, &constraints, &mass);
        let active: Vec<u32> = (0..ends.len() as u32).collect();
        let (j, w) = dense(&ends, &active, &rows, &constraints, &mass);
        let system_matrix = &j * &w * j.transpose();
        let rank = system_matrix.clone().svd(false, false).rank(1e-9 * system_matrix.norm());
        assert!(rank < active.len(), "the flat patch's edges are dependent: rank {rank} of {}", active.len());

        // A consistent right-hand side: C = J W Jᵀ μ₀.
        let mu0 = DVector::from_fn(active.len(), |e, _| 0.02 * (e as f64 * 0.61).sin());
        let violation = &system_matrix * &mu0;
        let mut system = EdgeSystem::new(mass.len(), &ends).unwrap();
        system.factor(&active, &vec![true; ends.len()], |e| rows[e], &constraints, &mass).unwrap();
        let mut mu = vec![0.0; active.len()];
        system.solve(&active, violation.as_slice(), &mut mu);
        let motion = &w * j.transpose() * DVector::from_column_slice(&mu);
        let exact = &w * j.transpose() * &mu0;
        let error = (&motion - &exact).norm() / exact.norm();
        assert!(error < 1e-5, "particle motion off by {error:e}");
    }
}
