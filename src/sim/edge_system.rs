//! The multiplier system `J W Jᵀ μ = C` of fast projection
//! ([`super::inextensibility`]) on the active edges, as a sparse Cholesky
//! factor: the preconditioner of every multiplier solve.
//!
//! Row `e` of `J` is the gradient of edge `e`'s length: `u_e` at its first
//! end, `−u_e` at its second. Entry `(i, j)` of `J W Jᵀ` is therefore
//! `Σ_v s_iv s_jv u_iᵀ W_v u_j` over the particles `v` the two edges share
//! (`s = ±1` the side, `W_v = S_v / m_v` the particle's filtered inverse
//! mass), so the pattern is the edges' adjacency, fixed by the mesh: it is
//! ordered once for all the edges (approximate minimum degree). A factor
//! covers only the active edges, a few hundred of the skirt's 4,392 in a
//! typical projection: their pattern is taken from the mesh's, eliminated
//! in the mesh's order, and analysed (simplicial) when edges join the
//! active set, which costs about what the numeric factor does and allocates
//! (faer's symbolic factor is an owned structure): the one allocation of a
//! running projection. The new analysis keeps the last one's order and
//! merges the joining edges in, rather than sorting again; the pattern's
//! neighbour lists are kept in elimination order, so each restricted
//! column comes out sorted. Edges that leave (multipliers that push) stay
//! in the analysis as identity rows while they are few: of `drape_table`'s
//! 3,898 factors over 3 s, 868 had only lost edges since the one before,
//! by 1-30 %. (A factor of every edge, the inactive ones given identity
//! rows, cost ~1.3 ms; Jacobi preconditioning needed ~50 iterations per
//! solve on the skirt and hundreds on long chains of active edges between
//! pins or contacts.)
//!
//! A stretch edge set is often dependent (a flat, fully triangulated patch
//! has more edges than in-plane degrees of freedom), so `J W Jᵀ` is only
//! semi-definite. The system is scaled to a unit diagonal and shifted by
//! [`REGULARIZATION`]: the shift decides only multipliers in the null space
//! of `W Jᵀ`, which move no particle, and changes the others by a relative
//! [`REGULARIZATION`]. Preconditioned by the factor, conjugate gradients
//! converge in one or two iterations. Factor and solve run on the calling
//! thread, so the result is the same at any thread count.

use std::sync::Arc;

use faer::Side;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use nalgebra::Vector3;

use super::constraint::Constraint;
use super::llt::Llt;

/// Relative shift of the scaled system's unit diagonal, unitless.
pub const REGULARIZATION: f64 = 1e-9;

/// An analysis serves a smaller active set while the edges that left are
/// at most this many, or at most [`SPARE_SHARE`]'s share of the active
/// ones: edges leave mostly by a few at a time (multipliers that push),
/// and an analysis costs about as much as the numeric factor.
const SPARE_EDGES: usize = 8;

/// See [`SPARE_EDGES`]: a quarter.
const SPARE_SHARE: usize = 4;

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
    /// Row edge `i` (`i >` the column's edge).
    row: u32,
    /// The shared particle.
    particle: u32,
    /// `s_iv s_jv`.
    sign: f64,
}

/// What is fixed by the mesh: the lower triangle's pattern over every edge,
/// in natural edge order, where each entry's value comes from, and an
/// elimination order of all the edges.
struct Pattern {
    edges: usize,
    /// Where each column's entries start; its first is the diagonal `(e, e)`.
    column_start: Vec<u32>,
    row_index: Vec<u32>,
    /// Where each column's couplings start in `couplings`.
    coupling_start: Vec<u32>,
    /// By column, then row, then particle.
    couplings: Vec<Coupling>,
    /// Where each edge's neighbours start in `neighbours`.
    neighbour_start: Vec<u32>,
    /// Per edge, the edges it shares a particle with and the index of their
    /// entry in the lower triangle, in elimination order (`rank`).
    neighbours: Vec<(u32, u32)>,
    /// Each edge's place in an approximate minimum degree order of all the
    /// edges: active edges are eliminated in this order.
    rank: Vec<u32>,
}

impl Pattern {
    /// The pattern of `J W Jᵀ` for edges `ends` on `vertex_count` particles.
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
        let n = ends.len();
        let (mut row_index, mut couplings) = (Vec::new(), Vec::new());
        let (mut column_start, mut coupling_start) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
        for &(column, row, particle, sign) in &terms {
            if row == column {
                column_start.push(row_index.len() as u32);
                coupling_start.push(couplings.len() as u32);
                row_index.push(row);
                continue;
            }
            if row_index.last() != Some(&row) {
                row_index.push(row);
            }
            couplings.push(Coupling { entry: row_index.len() as u32 - 1, row, particle, sign });
        }
        column_start.push(row_index.len() as u32);
        coupling_start.push(couplings.len() as u32);
        let (neighbour_start, mut neighbours) = symmetric_neighbours(n, &column_start, &row_index);
        let rank = minimum_degree_rank(n, &column_start, &row_index)?;
        for e in 0..n {
            let list = &mut neighbours[neighbour_start[e] as usize..neighbour_start[e + 1] as usize];
            list.sort_unstable_by_key(|&(i, _)| rank[i as usize]);
        }
        Ok(Pattern { edges: n, column_start, row_index, coupling_start, couplings, neighbour_start, neighbours, rank })
    }

    /// The couplings of column `e`.
    fn couplings_of(&self, e: usize) -> &[Coupling] {
        &self.couplings[self.coupling_start[e] as usize..self.coupling_start[e + 1] as usize]
    }

    /// The edges that share a particle with edge `e`, with their entry, in
    /// elimination order.
    fn neighbours_of(&self, e: usize) -> &[(u32, u32)] {
        &self.neighbours[self.neighbour_start[e] as usize..self.neighbour_start[e + 1] as usize]
    }
}

/// Both triangles of a lower-triangle pattern (`column_start`, `row_index`,
/// each column's diagonal first) as neighbour lists: where each column's
/// list starts, and the lists of `(neighbour, entry index)`.
fn symmetric_neighbours(n: usize, column_start: &[u32], row_index: &[u32]) -> (Vec<u32>, Vec<(u32, u32)>) {
    let below_diagonal = |j: usize| {
        let entries = column_start[j] as usize + 1..column_start[j + 1] as usize;
        entries.map(move |entry| (entry, row_index[entry] as usize))
    };
    let mut start = vec![0u32; n + 1];
    for j in 0..n {
        for (_, i) in below_diagonal(j) {
            start[i + 1] += 1;
            start[j + 1] += 1;
        }
    }
    for j in 0..n {
        start[j + 1] += start[j];
    }
    let mut fill = start.clone();
    let mut neighbours = vec![(0, 0); start[n] as usize];
    for j in 0..n {
        for (entry, i) in below_diagonal(j) {
            for (at, other) in [(i, j), (j, i)] {
                neighbours[fill[at] as usize] = (other as u32, entry as u32);
                fill[at] += 1;
            }
        }
    }
    (start, neighbours)
}

/// Each column's place in faer's approximate minimum degree order of the
/// symmetric matrix whose lower triangle has pattern `column_start`,
/// `row_index`.
fn minimum_degree_rank(n: usize, column_start: &[u32], row_index: &[u32]) -> Result<Vec<u32>, EdgeSystemError> {
    let pattern = SymbolicSparseColMatRef::new_checked(n, n, column_start, None, row_index);
    let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, simplicial())
        .map_err(|e| EdgeSystemError::Analysis(format!("{e:?}")))?;
    let mut rank: Vec<u32> = (0..n as u32).collect();
    if let Some(permutation) = symbolic.perm() {
        // `order[k]` is the column eliminated k-th.
        let (order, _) = permutation.arrays();
        for (k, &column) in order.iter().enumerate() {
            rank[column as usize] = k as u32;
        }
    }
    Ok(rank)
}

/// Edge adjacency fills little: supernodes would be a few columns wide, and
/// the simplicial factor is faster here (measured on a skirt's 4,392 edges:
/// 1.3 ms against 1.8 ms).
fn simplicial() -> CholeskySymbolicParams<'static> {
    CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
        ..Default::default()
    }
}

/// The pattern of `J W Jᵀ` on one set of edges, in their elimination order
/// (their ranks in the mesh's order: restricting an elimination order to a
/// subset of the columns fills no more than the whole order does on them),
/// analysed.
struct ActivePattern {
    /// The edges it was made for, ascending.
    edges: Vec<u32>,
    /// The same edges in elimination order (column by column).
    order: Vec<u32>,
    /// Upper triangle, each column's diagonal last.
    upper: SymbolicSparseColMat<u32>,
    symbolic: SymbolicCholesky<u32>,
}

impl ActivePattern {
    /// `pattern` restricted to the `edges` (ascending, `is_active` per
    /// edge), whose elimination order is the `previous` analysis's where
    /// they share edges. Fills `column`, per edge its column, and `entry`,
    /// per entry of `pattern` between two of the edges its index here.
    fn new(
        pattern: &Pattern,
        edges: &[u32],
        is_active: &[bool],
        previous: Option<&ActivePattern>,
        column: &mut [u32],
        entry: &mut [u32],
    ) -> Result<Self, EdgeSystemError> {
        let order = elimination_order(pattern, edges, is_active, previous);
        for (c, &e) in order.iter().enumerate() {
            column[e as usize] = c as u32;
        }
        let n = edges.len();
        let (mut column_start, mut row_index) = (Vec::with_capacity(n + 1), Vec::new());
        for (c, &e) in order.iter().enumerate() {
            let e = e as usize;
            column_start.push(row_index.len() as u32);
            // Neighbours come in elimination order, so their columns ascend.
            let earlier = pattern.neighbours_of(e).iter().filter(|&&(i, _)| is_active[i as usize]);
            let earlier = earlier.map(|&(i, at)| (column[i as usize], at)).take_while(|&(r, _)| r < c as u32);
            for (r, at) in earlier.chain([(c as u32, pattern.column_start[e])]) {
                entry[at as usize] = row_index.len() as u32;
                row_index.push(r);
            }
        }
        column_start.push(row_index.len() as u32);
        let upper = SymbolicSparseColMat::new_checked(n, n, column_start, None, row_index);
        let symbolic =
            factorize_symbolic_cholesky(upper.as_ref(), Side::Upper, SymmetricOrdering::Identity, simplicial())
                .map_err(|e| EdgeSystemError::Analysis(format!("{e:?}")))?;
        Ok(ActivePattern { edges: edges.to_vec(), order, upper, symbolic })
    }

    /// Whether this analysis can serve the `active` edges (ascending): they
    /// are among its edges, and the others, which a factor then carries as
    /// identity rows, are few.
    fn covers(&self, active: &[u32]) -> bool {
        let spare = self.edges.len().saturating_sub(active.len());
        spare <= SPARE_EDGES.max(active.len() / SPARE_SHARE) && is_subset(active, &self.edges)
    }
}

/// The `edges` (ascending, `is_active` per edge) sorted by their rank in
/// `pattern`'s elimination order: the `previous` analysis's order without
/// the edges that left, then those that joined, sorted together (a stable
/// sort takes the first as one sorted run and merges the few others in).
fn elimination_order(
    pattern: &Pattern,
    edges: &[u32],
    is_active: &[bool],
    previous: Option<&ActivePattern>,
) -> Vec<u32> {
    let Some(previous) = previous else {
        let mut order = edges.to_vec();
        order.sort_unstable_by_key(|&e| pattern.rank[e as usize]);
        return order;
    };
    let mut order: Vec<u32> = previous.order.iter().copied().filter(|&e| is_active[e as usize]).collect();
    let mut earlier = previous.edges.iter().peekable();
    order.extend(edges.iter().filter(|&e| {
        while earlier.next_if(|&p| p < e).is_some() {}
        earlier.peek() != Some(&e)
    }));
    order.sort_by_key(|&e| pattern.rank[e as usize]);
    order
}

/// Whether ascending `a` is a subset of ascending `b`.
fn is_subset(a: &[u32], b: &[u32]) -> bool {
    let mut rest = b.iter();
    a.iter().all(|x| rest.by_ref().any(|y| y == x))
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
    pattern: Arc<Pattern>,
    /// The last analysis, on a superset of the last factor's edges, and its
    /// factor.
    analysed: Option<(ActivePattern, Llt<f64>)>,
    /// The active edges of the last factor, ascending.
    factored_for: Vec<u32>,
    /// Per edge: its column in the analysed pattern (valid for its edges).
    column: Vec<u32>,
    /// Per entry of `pattern`: its index in the analysed pattern (valid for
    /// entries between its edges).
    entry: Vec<u32>,
    /// Upper-triangle values of the scaled, shifted system on the analysed
    /// edges (each column's diagonal last), identity rows on the inactive.
    values: Vec<f64>,
    /// Per column of the analysed pattern, `1 / √(J W Jᵀ)_ee` of its edge
    /// (1 for an inactive edge).
    scale: Vec<f64>,
    /// A right-hand side in the analysed pattern's column order.
    permuted: Vec<f64>,
}

impl EdgeSystem {
    /// The system of edges `ends` on `vertex_count` particles, with an
    /// elimination order of all of them.
    pub fn new(vertex_count: usize, ends: &[[u32; 2]]) -> Result<Self, EdgeSystemError> {
        Ok(Self::with_pattern(Arc::new(Pattern::new(vertex_count, ends)?)))
    }

    fn with_pattern(pattern: Arc<Pattern>) -> Self {
        EdgeSystem {
            column: vec![0; pattern.edges],
            entry: vec![0; pattern.row_index.len()],
            analysed: None,
            factored_for: Vec::new(),
            values: Vec::new(),
            scale: Vec::new(),
            permuted: Vec::new(),
            pattern,
        }
    }

    /// Whether the last factor was made for the `active` edges.
    pub fn is_factored_for(&self, active: &[u32]) -> bool {
        self.analysed.is_some() && self.factored_for == active
    }

    /// Factors `J W Jᵀ` restricted to the `active` edges (ascending;
    /// `is_active` per edge), edge `e` linearised as `row(e)`, for particles
    /// with `constraints` and `mass` (kg). The restricted pattern is analysed
    /// again when edges joined since the last analysis, or when many left:
    /// a few that left stay in the factor as identity rows, coupled to
    /// nothing (the active edges' values are those of their own factor).
    pub fn factor(
        &mut self,
        active: &[u32],
        is_active: &[bool],
        row: impl Fn(usize) -> EdgeRow,
        constraints: &[Constraint],
        mass: &[f64],
    ) -> Result<(), EdgeSystemError> {
        let pattern = &*self.pattern;
        self.factored_for.clear();
        if !self.analysed.as_ref().is_some_and(|(analysed, _)| analysed.covers(active)) {
            let previous = self.analysed.take().map(|(previous, _)| previous);
            let (column, entry) = (&mut self.column, &mut self.entry);
            let analysed = ActivePattern::new(pattern, active, is_active, previous.as_ref(), column, entry)?;
            let factor = Llt::new(&analysed.symbolic);
            self.analysed = Some((analysed, factor));
        }
        let Some((analysed, factor)) = &mut self.analysed else { return Ok(()) };
        self.factored_for.extend_from_slice(active);
        let column = &self.column;
        self.scale.clear();
        self.scale.resize(analysed.edges.len(), 1.0);
        for &e in active {
            self.scale[column[e as usize] as usize] = 1.0 / row(e as usize).diagonal.sqrt();
        }
        let upper = analysed.upper.as_ref();
        self.values.clear();
        self.values.resize(upper.row_idx().len(), 0.0);
        for &end in &upper.col_ptr()[1..] {
            self.values[end as usize - 1] = 1.0 + REGULARIZATION;
        }
        let weighted = |v: u32, u: &Vector3<f64>| constraints[v as usize].filter(*u) / mass[v as usize];
        for &j in active {
            let (j, entry) = (j as usize, &self.entry);
            let direction = row(j).direction;
            for c in pattern.couplings_of(j).iter().filter(|c| is_active[c.row as usize]) {
                let i = c.row as usize;
                let coupling = c.sign * row(i).direction.dot(&weighted(c.particle, &direction));
                let scale = self.scale[column[i] as usize] * self.scale[column[j] as usize];
                self.values[entry[c.entry as usize] as usize] += coupling * scale;
            }
        }
        let matrix = SparseColMatRef::new(upper, &self.values);
        factor.factor(&analysed.symbolic, matrix).map_err(|_| EdgeSystemError::NotPositiveDefinite)
    }

    /// `out = M⁻¹ rhs` on the active edges of the last [`Self::factor`]
    /// (`rhs` and `out` hold one value per active edge, in ascending edge
    /// order), with `M` the factored `J W Jᵀ`.
    pub fn solve(&mut self, rhs: &[f64], out: &mut [f64]) {
        let Some((analysed, factor)) = &mut self.analysed else { return out.copy_from_slice(rhs) };
        self.permuted.clear();
        self.permuted.resize(analysed.edges.len(), 0.0);
        let columns = || self.factored_for.iter().map(|&e| self.column[e as usize] as usize);
        for (c, &value) in columns().zip(rhs) {
            self.permuted[c] = value * self.scale[c];
        }
        factor.solve_in_place(&analysed.symbolic, &mut self.permuted);
        for (c, value) in columns().zip(out) {
            *value = self.permuted[c] * self.scale[c];
        }
    }
}

impl Clone for EdgeSystem {
    /// The same mesh pattern, with fresh work space (each projection builds
    /// its own factors).
    fn clone(&self) -> Self {
        Self::with_pattern(Arc::clone(&self.pattern))
    }
}

impl std::fmt::Debug for EdgeSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EdgeSystem")
            .field("edges", &self.pattern.edges)
            .field("active_edges", &self.factored_for.len())
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
        let error = error_against_dense(&mut system, (&ends, &active), &rows, &constraints, &mass);
        assert!(error < 1e-6, "relative error {error:e}");
    }

    /// The relative error of `system`'s solve of `J W Jᵀ μ = C` on the
    /// `listed` edges of `ends` (those it was last factored for) against a
    /// dense solve, for a made-up `C`.
    fn error_against_dense(
        system: &mut EdgeSystem,
        (ends, listed): (&[[u32; 2]], &[u32]),
        rows: &[EdgeRow],
        constraints: &[Constraint],
        mass: &[f64],
    ) -> f64 {
        let violation: Vec<f64> = listed.iter().map(|&e| 0.01 * (f64::from(e) * 0.37).cos()).collect();
        let mut mu = vec![0.0; listed.len()];
        system.solve(&violation, &mut mu);
        let (j, w) = dense(ends, listed, rows, constraints, mass);
        let expected = (&j * &w * j.transpose()).cholesky().unwrap().solve(&DVector::from_column_slice(&violation));
        (DVector::from_column_slice(&mu) - &expected).norm() / expected.norm()
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
        system.solve(violation.as_slice(), &mut mu);
        let motion = &w * j.transpose() * DVector::from_column_slice(&mu);
        let exact = &w * j.transpose() * &mu0;
        let error = (&motion - &exact).norm() / exact.norm();
        assert!(error < 1e-5, "particle motion off by {error:e}");
    }

    /// After a factor of many edges, a factor of most of them reuses its
    /// analysis, the edges that left kept as identity rows, and still
    /// solves the smaller system as a dense solve does.
    #[test]
    fn edges_that_left_stay_in_the_analysis_as_identity_rows() {
        let (ends, x, mass) = patch(6, 0.3);
        let mut constraints = vec![Constraint::Free; mass.len()];
        constraints[3] = Constraint::Normal(Vector3::new(0.0, 0.6, 0.8));
        let rows = rows(&ends, &x, &constraints, &mass);
        let mut system = EdgeSystem::new(mass.len(), &ends).unwrap();
        let all: Vec<u32> = (0..ends.len() as u32).collect();
        system.factor(&all, &vec![true; ends.len()], |e| rows[e], &constraints, &mass).unwrap();
        let most: Vec<u32> = all.iter().copied().filter(|e| e % 9 != 4).collect();
        let mut is_active = vec![false; ends.len()];
        most.iter().for_each(|&e| is_active[e as usize] = true);
        system.factor(&most, &is_active, |e| rows[e], &constraints, &mass).unwrap();
        let (analysed, _) = system.analysed.as_ref().unwrap();
        assert_eq!(analysed.edges, all, "the analysis of every edge serves");
        assert!(system.is_factored_for(&most) && !system.is_factored_for(&all));
        let error = error_against_dense(&mut system, (&ends, &most), &rows, &constraints, &mass);
        assert!(error < 1e-6, "relative error {error:e}");
    }

    /// An analysis made after edges joined and left orders its edges as a
    /// fresh analysis of the same edges does: the same fill.
    #[test]
    fn an_analysis_after_edges_joined_orders_as_a_fresh_one() {
        let (ends, _, mass) = patch(8, 0.0);
        let pattern = Pattern::new(mass.len(), &ends).unwrap();
        let (mut column, mut entry) = (vec![0; ends.len()], vec![0; pattern.row_index.len()]);
        let flags = |edges: &[u32]| {
            let mut is_active = vec![false; ends.len()];
            edges.iter().for_each(|&e| is_active[e as usize] = true);
            is_active
        };
        let first: Vec<u32> = (0..ends.len() as u32).filter(|e| e % 3 == 0).collect();
        let previous = ActivePattern::new(&pattern, &first, &flags(&first), None, &mut column, &mut entry).unwrap();
        let next: Vec<u32> = (0..ends.len() as u32).filter(|e| e % 3 == 0 && e % 7 != 0 || e % 5 == 1).collect();
        let is_active = flags(&next);
        let merged = ActivePattern::new(&pattern, &next, &is_active, Some(&previous), &mut column, &mut entry).unwrap();
        let fresh = ActivePattern::new(&pattern, &next, &is_active, None, &mut column, &mut entry).unwrap();
        assert_eq!(merged.order, fresh.order);
        assert_eq!(merged.symbolic.len_val(), fresh.symbolic.len_val());
    }

    /// The active pattern takes its elimination order from the mesh's:
    /// with every edge active it fills exactly as faer's own minimum degree
    /// analysis of the whole pattern does, and on a subset no more than
    /// that analysis restricted to it.
    #[test]
    fn active_edges_are_eliminated_in_the_mesh_order_without_extra_fill() {
        let (ends, _, mass) = patch(8, 0.0);
        let pattern = Pattern::new(mass.len(), &ends).unwrap();
        let (mut column, mut entry) = (vec![0; ends.len()], vec![0; pattern.row_index.len()]);
        let all: Vec<u32> = (0..ends.len() as u32).collect();
        let restricted =
            ActivePattern::new(&pattern, &all, &vec![true; ends.len()], None, &mut column, &mut entry).unwrap();
        let n = ends.len();
        let whole = SymbolicSparseColMatRef::new_checked(n, n, &pattern.column_start, None, &pattern.row_index);
        let amd = factorize_symbolic_cholesky(whole, Side::Lower, SymmetricOrdering::Amd, simplicial()).unwrap();
        assert_eq!(restricted.symbolic.len_val(), amd.len_val());

        let some: Vec<u32> = all.iter().copied().filter(|e| e % 4 != 1).collect();
        let mut is_active = vec![false; n];
        some.iter().for_each(|&e| is_active[e as usize] = true);
        let subset = ActivePattern::new(&pattern, &some, &is_active, None, &mut column, &mut entry).unwrap();
        assert!(subset.symbolic.len_val() < amd.len_val());
    }
}
