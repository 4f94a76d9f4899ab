//! Aggregation multigrid with rigid-body coarse spaces, used as the
//! preconditioner of the implicit solve.
//!
//! With stiff stretch springs and large steps a tension wave crosses the whole
//! cloth within one step, and a preconditioner that only looks at each
//! particle's own block needs about one iteration per cell the wave must
//! cross. Multigrid corrects the long wavelengths on coarser versions of the
//! cloth, so the iteration count stays nearly constant with resolution,
//! stiffness and step.
//!
//! Springs resist only along their axis, so the cloth's smooth low-energy
//! motions are local *rigid* motions: translations and rotations. Each coarse
//! node therefore carries six degrees of freedom, a translation and a rotation
//! of a patch of cloth about the patch's current centroid (the rigid-body
//! modes of aggregation multigrid for elasticity; Vaněk, Mandel and Brezina
//! 1996). With translations only, a slowly turning patch cannot be represented
//! and most of the benefit is lost on cloth.
//!
//! * **Setup, once per topology**: particles are grouped into aggregates (a
//!   particle and its spring neighbours, greedily), aggregates into
//!   aggregates, until a few dozen nodes remain.
//! * **Per solve**: the filtered matrix `Â = S A S + α (I − S)` (constrained
//!   directions decoupled, scaled like the rest); each level's Galerkin product
//!   `A_c = R̂ᵀ Â R̂` with the rigid interpolation `R` about the current
//!   centroids, filtered at the finest level (`R̂ = S R`) so that a coarse
//!   correction never moves a pinned particle or pushes a contact into its
//!   surface; damped block-Jacobi smoothers; a dense Cholesky factor at the
//!   bottom.
//! * **Apply**: one symmetric V-cycle (one smoothing sweep before and after each
//!   coarse correction), so the preconditioner is symmetric positive definite.
//!
//! The smoother is `ω D⁻¹` with `D` the diagonal blocks and
//! `ω = 1 / λ_max(D⁻¹ A)`, estimated by a few power iterations warm-started
//! from the previous solve. (An l1-Jacobi smoother, which adds `Σⱼ‖A_ij‖ I` to
//! each diagonal block, is safe but smothers the soft directions of spring
//! blocks that are stiff along one axis only; measured, it lost most of the
//! gain.)
//!
//! Every loop writes disjoint outputs or gathers in a fixed order, so the
//! result is the same at any thread count.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, SMatrix, SVector, Vector3, Vector6};

use super::constraint::Constraint;
use super::parallel::{self, for_each_indexed as each};
use super::sparse::{BlockPattern, SystemMatrix};

/// Stop coarsening at this many nodes; the last level is solved directly.
const COARSEST_NODES: usize = 40;
/// Stop coarsening when a level keeps more than this fraction of its nodes.
const MIN_REDUCTION: f64 = 0.6;
/// Power iterations per solve for each smoother's spectral estimate.
const POWER_ITERATIONS: usize = 3;
/// Safety factor on the spectral estimate (power iteration underestimates).
const SPECTRAL_MARGIN: f64 = 1.25;
/// Relative size of the regularisation added to coarse diagonal blocks (a
/// coarse node whose patch is entirely pinned would otherwise be singular).
const COARSE_REGULARISATION: f64 = 1e-9;

/// A compressed list of lists.
#[derive(Clone, Debug, Default)]
struct Csr<T> {
    start: Vec<usize>,
    items: Vec<T>,
}

impl<T: Clone> Csr<T> {
    fn from_lists(lists: Vec<Vec<T>>) -> Self {
        let mut start = Vec::with_capacity(lists.len() + 1);
        start.push(0);
        for list in &lists {
            start.push(start.last().copied().unwrap_or(0) + list.len());
        }
        Csr { start, items: lists.concat() }
    }

    fn row(&self, i: usize) -> &[T] {
        &self.items[self.start[i]..self.start[i + 1]]
    }

    fn rows(&self) -> usize {
        self.start.len() - 1
    }
}

/// A fine block's place: slot, row, column.
#[derive(Clone, Copy, Debug)]
struct FineBlock {
    slot: u32,
    row: u32,
    column: u32,
}

/// Aggregation from one level to the next coarser one.
#[derive(Clone, Debug)]
struct Transfer {
    /// Aggregate of each fine node.
    aggregate: Vec<u32>,
    /// Fine nodes of each aggregate.
    members: Csr<u32>,
    /// Pattern of the coarser matrix.
    coarse: BlockPattern,
    /// Per coarse slot, the fine blocks it sums.
    galerkin: Csr<FineBlock>,
}

impl Transfer {
    fn new(fine: &BlockPattern, graph: &Csr<u32>) -> Option<Self> {
        let (aggregate, count) = aggregate(graph);
        if count == 0 || count as f64 > MIN_REDUCTION * fine.rows() as f64 {
            return None;
        }
        let mut members = vec![Vec::new(); count];
        for (i, &a) in aggregate.iter().enumerate() {
            members[a as usize].push(i as u32);
        }
        let fine_blocks = (0..fine.rows()).flat_map(|i| {
            fine.row(i).map(move |s| FineBlock { slot: s as u32, row: i as u32, column: fine.column(s) as u32 })
        });
        let coarse = BlockPattern::new(
            count,
            fine_blocks.clone().map(|b| [aggregate[b.row as usize], aggregate[b.column as usize]]),
        );
        let mut galerkin = vec![Vec::new(); coarse.stored_blocks()];
        for b in fine_blocks {
            let (ci, cj) = (aggregate[b.row as usize] as usize, aggregate[b.column as usize] as usize);
            if let Some(slot) = coarse.slot(ci, cj) {
                galerkin[slot].push(b);
            }
        }
        Some(Transfer { aggregate, members: Csr::from_lists(members), coarse, galerkin: Csr::from_lists(galerkin) })
    }

    /// Centroid of each aggregate of `points`.
    fn centroids(&self, points: &[Vector3<f64>], out: &mut Vec<Vector3<f64>>) {
        out.clear();
        out.extend((0..self.members.rows()).map(|c| {
            let m = self.members.row(c);
            m.iter().map(|&i| points[i as usize]).sum::<Vector3<f64>>() / m.len() as f64
        }));
    }

    /// `A_c = Rᵀ A R` for the interpolation `rigid(node, offset from its
    /// aggregate's centroid)`, plus a small regularisation of each diagonal block.
    fn galerkin<const D: usize>(
        &self,
        fine: &[SMatrix<f64, D, D>],
        points: &[Vector3<f64>],
        centroids: &[Vector3<f64>],
        rigid: impl Fn(usize, &Vector3<f64>) -> SMatrix<f64, D, 6> + Sync,
        out: &mut Vec<Matrix6<f64>>,
    ) {
        out.resize(self.coarse.stored_blocks(), Matrix6::zeros());
        let interpolation = |i: u32| {
            let i = i as usize;
            rigid(i, &(points[i] - centroids[self.aggregate[i] as usize]))
        };
        each(out, |slot, block| {
            *block = self.galerkin.row(slot).iter().fold(Matrix6::zeros(), |acc, b| {
                acc + interpolation(b.row).transpose() * fine[b.slot as usize] * interpolation(b.column)
            });
        });
        let scale = out.iter().map(|m| m.trace().abs()).sum::<f64>() / out.len().max(1) as f64;
        for c in 0..self.coarse.rows() {
            out[self.coarse.diagonal(c)] += Matrix6::identity() * (COARSE_REGULARISATION * scale);
        }
    }

    /// `b_c = Rᵀ r`.
    fn restrict<const D: usize>(
        &self,
        r: &[SVector<f64, D>],
        points: &[Vector3<f64>],
        centroids: &[Vector3<f64>],
        rigid: impl Fn(usize, &Vector3<f64>) -> SMatrix<f64, D, 6> + Sync,
        out: &mut [Vector6<f64>],
    ) {
        each(out, |c, b| {
            *b = self
                .members
                .row(c)
                .iter()
                .map(|&i| rigid(i as usize, &(points[i as usize] - centroids[c])).transpose() * r[i as usize])
                .sum();
        });
    }

    /// `x += R e`.
    fn prolong<const D: usize>(
        &self,
        e: &[Vector6<f64>],
        points: &[Vector3<f64>],
        centroids: &[Vector3<f64>],
        rigid: impl Fn(usize, &Vector3<f64>) -> SMatrix<f64, D, 6> + Sync,
        x: &mut [SVector<f64, D>],
    ) {
        each(x, |i, xi| {
            let c = self.aggregate[i] as usize;
            *xi += rigid(i, &(points[i] - centroids[c])) * e[c];
        });
    }
}

/// Rigid interpolation of a particle at `offset` from its patch's centroid:
/// velocity `t + ω × offset` for the patch's translation `t` and rotation `ω`.
fn particle_rigid(offset: &Vector3<f64>) -> SMatrix<f64, 3, 6> {
    let mut r = SMatrix::<f64, 3, 6>::zeros();
    r.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
    r.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-offset.cross_matrix()));
    r
}

/// Rigid interpolation of a patch at `offset` from its parent patch's centroid:
/// translation `t + ω × offset`, the same rotation `ω`.
fn patch_rigid(offset: &Vector3<f64>) -> Matrix6<f64> {
    let mut r = Matrix6::identity();
    r.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-offset.cross_matrix()));
    r
}

/// Values and scratch space of one level, `D` degrees of freedom per node.
#[derive(Clone, Debug, Default)]
struct Level<const D: usize> {
    matrix: Vec<SMatrix<f64, D, D>>,
    inverse_diagonal: Vec<SMatrix<f64, D, D>>,
    /// Smoother weight `1 / λ_max(D⁻¹ A)`, with a margin.
    omega: f64,
    /// Power-iteration vector, kept from solve to solve.
    probe: Vec<SVector<f64, D>>,
    partials: Vec<f64>,
    rhs: Vec<SVector<f64, D>>,
    solution: Vec<SVector<f64, D>>,
    residual: Vec<SVector<f64, D>>,
}

impl<const D: usize> Level<D> {
    /// Sizes the vectors, inverts the diagonal blocks and estimates the
    /// smoother weight by power iteration on `D⁻¹ A`.
    fn prepare(
        &mut self,
        pattern: &BlockPattern,
        invert: impl Fn(SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> + Sync,
    ) {
        let n = pattern.rows();
        for v in [&mut self.rhs, &mut self.solution, &mut self.residual] {
            v.resize(n, SVector::zeros());
        }
        inverse_diagonal(pattern, &self.matrix, &mut self.inverse_diagonal, invert);
        if self.probe.len() != n {
            self.probe = (0..n).map(|i| SVector::from_fn(|k, _| 1.0 + ((i * 7 + k * 3) % 5) as f64)).collect();
        }
        let Level { matrix, inverse_diagonal, probe, partials, residual, .. } = self;
        let mut lambda = 1.0;
        for _ in 0..POWER_ITERATIONS {
            multiply(pattern, matrix, probe, residual);
            let energy = parallel::sum(n, partials, |i| probe[i].dot(&residual[i]));
            let weight = parallel::sum(n, partials, |i| probe[i].dot(&(matrix[pattern.diagonal(i)] * probe[i])));
            if weight > 0.0 {
                lambda = (energy / weight).max(1.0);
            }
            each(probe, |i, p| *p = inverse_diagonal[i] * residual[i]);
            let norm = parallel::sum(n, partials, |i| probe[i].norm_squared()).sqrt();
            if norm > 0.0 {
                each(probe, |_, p| *p /= norm);
            }
        }
        self.omega = 1.0 / (lambda * SPECTRAL_MARGIN);
    }

    /// Pre-smoothing from zero: `x = ω D⁻¹ b`, then `r = b − A x`.
    fn smooth_from_zero(&mut self, pattern: &BlockPattern) {
        let Level { matrix, inverse_diagonal, omega, rhs, solution, residual, .. } = self;
        each(solution, |i, x| *x = inverse_diagonal[i] * rhs[i] * *omega);
        residual_into(pattern, matrix, rhs, solution, residual);
    }

    /// Post-smoothing: `r = b − A x`, `x += ω D⁻¹ r`.
    fn smooth(&mut self, pattern: &BlockPattern) {
        let Level { matrix, inverse_diagonal, omega, rhs, solution, residual, .. } = self;
        residual_into(pattern, matrix, rhs, solution, residual);
        each(solution, |i, x| *x += inverse_diagonal[i] * residual[i] * *omega);
    }
}

/// A multigrid hierarchy over a fixed block pattern.
#[derive(Clone, Debug)]
pub struct Multigrid {
    fine: BlockPattern,
    transfers: Vec<Transfer>,
    points: Vec<Vector3<f64>>,
    projectors: Vec<Matrix3<f64>>,
    centroids: Vec<Vec<Vector3<f64>>>,
    fine_level: Level<3>,
    coarse_levels: Vec<Level<6>>,
    coarsest: Coarsest,
}

/// The coarsest level's dense Cholesky factor, with buffers reused from solve
/// to solve.
#[derive(Clone, Debug)]
struct Coarsest {
    factor: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    spare: DMatrix<f64>,
    vector: DVector<f64>,
}

impl Coarsest {
    /// Factors the block matrix `a` on `pattern` (no factor if it is not
    /// positive definite).
    fn factor<const D: usize>(&mut self, pattern: &BlockPattern, a: &[SMatrix<f64, D, D>]) {
        let n = D * pattern.rows();
        let mut m = match self.factor.take() {
            Some(f) => f.unpack(),
            None => std::mem::replace(&mut self.spare, DMatrix::zeros(0, 0)),
        };
        if m.shape() != (n, n) {
            m = DMatrix::zeros(n, n);
        }
        m.fill(0.0);
        for i in 0..pattern.rows() {
            for s in pattern.row(i) {
                m.view_mut((D * i, D * pattern.column(s)), (D, D)).copy_from(&a[s]);
            }
        }
        self.factor = nalgebra::Cholesky::new(m);
        self.vector.resize_vertically_mut(n, 0.0);
    }

    /// Solves for the stacked `rhs` into `solution` (zero without a factor).
    fn solve<const D: usize>(&mut self, rhs: &[SVector<f64, D>], solution: &mut [SVector<f64, D>]) {
        for (i, b) in rhs.iter().enumerate() {
            self.vector.fixed_rows_mut::<D>(D * i).copy_from(b);
        }
        match &self.factor {
            Some(f) => f.solve_mut(&mut self.vector),
            None => self.vector.fill(0.0),
        }
        for (i, x) in solution.iter_mut().enumerate() {
            *x = self.vector.fixed_rows::<D>(D * i).into();
        }
    }
}

impl Multigrid {
    /// Builds the hierarchy for matrices on `pattern`, aggregating particles
    /// along `edges` (the strong couplings: the springs).
    pub fn new(pattern: &BlockPattern, edges: &[[u32; 2]]) -> Self {
        let mut transfers: Vec<Transfer> = Vec::new();
        let mut graph = adjacency(pattern.rows(), edges.iter().copied());
        let mut current = pattern;
        while current.rows() > COARSEST_NODES {
            let Some(transfer) = Transfer::new(current, &graph) else { break };
            let c = &transfer.coarse;
            graph =
                adjacency(c.rows(), (0..c.rows()).flat_map(|i| c.row(i).map(move |s| [i as u32, c.column(s) as u32])));
            transfers.push(transfer);
            current = &transfers[transfers.len() - 1].coarse;
        }
        Multigrid {
            fine: pattern.clone(),
            centroids: vec![Vec::new(); transfers.len()],
            coarse_levels: vec![Level::default(); transfers.len()],
            transfers,
            points: Vec::new(),
            projectors: Vec::new(),
            fine_level: Level::default(),
            coarsest: Coarsest { factor: None, spare: DMatrix::zeros(0, 0), vector: DVector::zeros(0) },
        }
    }

    /// Node counts per level, finest first.
    pub fn level_sizes(&self) -> Vec<usize> {
        std::iter::once(self.fine.rows()).chain(self.transfers.iter().map(|t| t.coarse.rows())).collect()
    }

    /// Prepares the hierarchy for the fine matrix `a` (on the pattern the
    /// hierarchy was built for) with `constraints`, the particles being at
    /// `positions` (m).
    pub fn prepare(&mut self, a: SystemMatrix, constraints: &[Constraint], positions: &[Vector3<f64>]) {
        self.points.clear();
        self.points.extend_from_slice(positions);
        self.projectors.clear();
        self.projectors.extend(constraints.iter().map(|c| c.filter_matrix()));
        filtered_matrix(a, &self.projectors, &mut self.fine_level.matrix);
        self.fine_level.prepare(&self.fine, |m| m.try_inverse());
        for k in 0..self.transfers.len() {
            let transfer = &self.transfers[k];
            let (parents, rest) = self.centroids.split_at_mut(k);
            let points: &[Vector3<f64>] = if k == 0 { &self.points } else { &parents[k - 1] };
            transfer.centroids(points, &mut rest[0]);
            let (done, todo) = self.coarse_levels.split_at_mut(k);
            let level = &mut todo[0];
            if k == 0 {
                let projectors = &self.projectors;
                let rigid = |i: usize, d: &Vector3<f64>| projectors[i] * particle_rigid(d);
                transfer.galerkin(&self.fine_level.matrix, points, &rest[0], rigid, &mut level.matrix);
            } else {
                transfer.galerkin(&done[k - 1].matrix, points, &rest[0], |_, d| patch_rigid(d), &mut level.matrix);
            }
            level.prepare(&transfer.coarse, |m| m.try_inverse());
        }
        match (self.transfers.last(), self.coarse_levels.last()) {
            (Some(t), Some(bottom)) => self.coarsest.factor(&t.coarse, &bottom.matrix),
            _ => self.coarsest.factor(&self.fine, &self.fine_level.matrix),
        }
    }

    /// One V-cycle for `r` into `z`: down the levels smoothing and restricting,
    /// the coarsest solved exactly, back up correcting and smoothing.
    pub fn apply(&mut self, r: &[Vector3<f64>], z: &mut [Vector3<f64>]) {
        let depth = self.transfers.len();
        if depth == 0 {
            self.coarsest.solve(r, z);
            return;
        }
        let projectors = &self.projectors;
        let fine_rigid = |i: usize, d: &Vector3<f64>| projectors[i] * particle_rigid(d);
        self.fine_level.rhs.copy_from_slice(r);
        self.fine_level.smooth_from_zero(&self.fine);
        let coarse_rhs = &mut self.coarse_levels[0].rhs;
        self.transfers[0].restrict(&self.fine_level.residual, &self.points, &self.centroids[0], fine_rigid, coarse_rhs);
        for k in 1..depth {
            let (upper, lower) = self.coarse_levels.split_at_mut(k);
            let level = &mut upper[k - 1];
            level.smooth_from_zero(&self.transfers[k - 1].coarse);
            let (from, to) = (&self.centroids[k - 1], &self.centroids[k]);
            self.transfers[k].restrict(&level.residual, from, to, |_, d| patch_rigid(d), &mut lower[0].rhs);
        }
        let bottom = &mut self.coarse_levels[depth - 1];
        self.coarsest.solve(&bottom.rhs, &mut bottom.solution);
        for k in (1..depth).rev() {
            let (upper, lower) = self.coarse_levels.split_at_mut(k);
            let level = &mut upper[k - 1];
            let (to, from) = (&self.centroids[k - 1], &self.centroids[k]);
            self.transfers[k].prolong(&lower[0].solution, to, from, |_, d| patch_rigid(d), &mut level.solution);
            level.smooth(&self.transfers[k - 1].coarse);
        }
        let correction = &self.coarse_levels[0].solution;
        self.transfers[0].prolong(
            correction,
            &self.points,
            &self.centroids[0],
            fine_rigid,
            &mut self.fine_level.solution,
        );
        self.fine_level.smooth(&self.fine);
        z.copy_from_slice(&self.fine_level.solution);
    }
}

/// Symmetric neighbour lists of `n` nodes from undirected `edges` (self loops
/// dropped), each sorted.
fn adjacency(n: usize, edges: impl Iterator<Item = [u32; 2]>) -> Csr<u32> {
    let mut lists = vec![Vec::new(); n];
    for [a, b] in edges {
        if a != b {
            lists[a as usize].push(b);
            lists[b as usize].push(a);
        }
    }
    for list in &mut lists {
        list.sort_unstable();
        list.dedup();
    }
    Csr::from_lists(lists)
}

/// Greedy aggregation: first, every node whose neighbourhood is untouched
/// roots an aggregate of itself and its neighbours; then leftovers join the
/// neighbouring aggregate they touch most; the rest form aggregates of their
/// own. Returns each node's aggregate and the aggregate count.
fn aggregate(graph: &Csr<u32>) -> (Vec<u32>, usize) {
    const NONE: u32 = u32::MAX;
    let n = graph.rows();
    let mut owner = vec![NONE; n];
    let mut count = 0u32;
    for i in 0..n {
        if owner[i] == NONE && graph.row(i).iter().all(|&j| owner[j as usize] == NONE) {
            owner[i] = count;
            for &j in graph.row(i) {
                owner[j as usize] = count;
            }
            count += 1;
        }
    }
    let rooted = owner.clone();
    for (i, slot) in owner.iter_mut().enumerate() {
        if *slot != NONE {
            continue;
        }
        let mut best: Option<(usize, u32)> = None;
        for &j in graph.row(i) {
            let a = rooted[j as usize];
            if a == NONE {
                continue;
            }
            let links = graph.row(i).iter().filter(|&&k| rooted[k as usize] == a).count();
            if best.is_none_or(|(l, b)| links > l || (links == l && a < b)) {
                best = Some((links, a));
            }
        }
        if let Some((_, a)) = best {
            *slot = a;
        }
    }
    for i in 0..n {
        if owner[i] == NONE {
            owner[i] = count;
            for &j in graph.row(i) {
                if owner[j as usize] == NONE {
                    owner[j as usize] = count;
                }
            }
            count += 1;
        }
    }
    (owner, count as usize)
}

/// `Â = S A S + α (I − S)` for each row's filter `S` (`projectors`), with `α`
/// a third of the row's diagonal trace.
fn filtered_matrix(a: SystemMatrix, projectors: &[Matrix3<f64>], out: &mut Vec<Matrix3<f64>>) {
    let pattern = &a.pattern.all;
    a.all_blocks(out);
    for (i, &si) in projectors.iter().enumerate() {
        if si == Matrix3::identity() {
            continue;
        }
        let diagonal = pattern.diagonal(i);
        for s in pattern.row(i) {
            out[s] = si * out[s];
            if let Some(back) = pattern.slot(pattern.column(s), i) {
                out[back] *= si;
            }
        }
        out[diagonal] += (Matrix3::identity() - si) * (a.diagonal(i).trace() / 3.0);
    }
}

/// Inverse diagonal blocks `D⁻¹` (zero where a block is singular).
fn inverse_diagonal<const D: usize>(
    pattern: &BlockPattern,
    a: &[SMatrix<f64, D, D>],
    out: &mut Vec<SMatrix<f64, D, D>>,
    invert: impl Fn(SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> + Sync,
) {
    out.resize(pattern.rows(), SMatrix::zeros());
    each(out, |i, inverse| *inverse = invert(a[pattern.diagonal(i)]).unwrap_or_else(SMatrix::zeros));
}

/// `y = A x` for `D`-blocks.
fn multiply<const D: usize>(
    pattern: &BlockPattern,
    a: &[SMatrix<f64, D, D>],
    x: &[SVector<f64, D>],
    y: &mut [SVector<f64, D>],
) {
    each(y, |i, yi| *yi = pattern.row(i).map(|s| a[s] * x[pattern.column(s)]).sum());
}

/// `r = b − A x` for `D`-blocks.
fn residual_into<const D: usize>(
    pattern: &BlockPattern,
    a: &[SMatrix<f64, D, D>],
    b: &[SVector<f64, D>],
    x: &[SVector<f64, D>],
    r: &mut [SVector<f64, D>],
) {
    each(r, |i, ri| *ri = b[i] - pattern.row(i).map(|s| a[s] * x[pattern.column(s)]).sum::<SVector<f64, D>>());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::pcg::{FilteredSystem, PcgSettings, PcgWorkspace, PreconditionerKind, Preconditioning, solve};
    use crate::sim::sparse::SystemPattern;
    use crate::sim::test_grid::quad_grid as grid;

    /// `I + Σ_springs B` with each spring's block `B` from `block(direction, is_diagonal)`.
    fn system(
        n: usize,
        edges: &[[u32; 2]],
        points: &[Vector3<f64>],
        block: impl Fn(Vector3<f64>, bool) -> Matrix3<f64>,
    ) -> (BlockPattern, Vec<Matrix3<f64>>) {
        let pattern = BlockPattern::new(n, edges.iter().copied());
        let mut a = vec![Matrix3::zeros(); pattern.stored_blocks()];
        for i in 0..n {
            a[pattern.diagonal(i)] = Matrix3::identity();
        }
        for &[p, q] in edges {
            let d = points[p as usize] - points[q as usize];
            let b = block(d.normalize(), d.x != 0.0 && d.z != 0.0);
            let (p, q) = (p as usize, q as usize);
            for (r, c, sign) in [(p, p, 1.0), (q, q, 1.0), (p, q, -1.0), (q, p, -1.0)] {
                a[pattern.slot(r, c).unwrap()] += b * sign;
            }
        }
        (pattern, a)
    }

    /// Iterations of block-Jacobi and multigrid PCG to 1e-6 on `a` with two
    /// particles pinned, checking they agree on the solution.
    fn iterations(
        pattern: &BlockPattern,
        a: &[Matrix3<f64>],
        edges: &[[u32; 2]],
        points: &[Vector3<f64>],
    ) -> (u32, u32) {
        let n = pattern.rows();
        let b: Vec<Vector3<f64>> = (0..n).map(|i| Vector3::new((i as f64 * 0.37).sin(), 1.0, (i % 7) as f64)).collect();
        let mut constraints = vec![Constraint::Free; n];
        constraints[0] = Constraint::Fixed;
        constraints[n - 1] = Constraint::Normal(Vector3::y());
        let settings =
            PcgSettings { tolerance: 1e-6, max_iterations: 5000, preconditioner: PreconditionerKind::Multigrid };
        let mut multigrid = Multigrid::new(pattern, edges);
        let whole = SystemPattern::blocks_only(pattern.clone());
        let matrix = SystemMatrix { pattern: &whole, blocks: a, isotropic_scale: &[] };
        multigrid.prepare(matrix, &constraints, points);
        let run = |p: Preconditioning| {
            let mut x = vec![Vector3::zeros(); n];
            let system = FilteredSystem { matrix, b: &b, typical: &b, constraints: &constraints, positions: &[] };
            let report = solve(system, &mut x, settings, p, &mut PcgWorkspace::default());
            assert!(report.converged, "{report:?}");
            (report.iterations, x)
        };
        let (jacobi, x_jacobi) = run(Preconditioning::BlockJacobi);
        let (mg, x_mg) = run(Preconditioning::Multigrid(&mut multigrid));
        let scale = x_jacobi.iter().map(|p| p.norm()).fold(0.0, f64::max);
        let diff = x_jacobi.iter().zip(&x_mg).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max);
        assert!(diff < 1e-4 * scale, "same solution: {diff} vs {scale}");
        assert_eq!(x_mg[0], Vector3::zeros(), "the pinned particle kept its value");
        (jacobi, mg)
    }

    #[test]
    fn aggregates_cover_every_node_and_shrink_a_grid_about_ninefold() {
        let (edges, _) = grid(30);
        let (owner, count) = aggregate(&adjacency(900, edges.into_iter()));
        assert!(owner.iter().all(|&a| (a as usize) < count));
        let ratio = 900.0 / count as f64;
        assert!((6.0..12.0).contains(&ratio), "coarsening ratio {ratio}");
    }

    #[test]
    fn multigrid_solves_a_stiff_vector_laplacian_in_few_iterations() {
        let (edges, points) = grid(48);
        let (pattern, a) = system(48 * 48, &edges, &points, |_, _| Matrix3::identity() * 1e4);
        let (jacobi, mg) = iterations(&pattern, &a, &edges, &points);
        assert!(mg * 5 < jacobi, "multigrid {mg} vs block-Jacobi {jacobi}");
    }

    /// Springs that resist only along their axis (a flat cloth without
    /// tension): rotations are low-energy, and the rigid coarse space keeps
    /// multigrid far ahead of block-Jacobi.
    #[test]
    fn multigrid_handles_axial_spring_blocks() {
        let (edges, points) = grid(48);
        let k = |diagonal: bool| if diagonal { 400.0 } else { 1e4 };
        let (pattern, a) = system(48 * 48, &edges, &points, |u, diagonal| u * u.transpose() * k(diagonal));
        let (jacobi, mg) = iterations(&pattern, &a, &edges, &points);
        assert!(mg * 5 < jacobi, "multigrid {mg} vs block-Jacobi {jacobi}");
    }
}
