//! A sparse Cholesky factor of the filtered system, used as the PCG
//! preconditioner.
//!
//! The filtered solve of [`super::pcg`] finds `y = S y` with
//! `S A S y = S r`; the matrix `M = S A S + c (I − S)` is symmetric positive
//! definite, has exactly the block pattern of `A` (each `S_i` is a 3×3 block on
//! the diagonal) and its inverse, filtered, solves that system exactly. The
//! `c (I − S)` part only fills the constrained directions, which the filter
//! discards; `c` is the diagonal block's mean eigenvalue, so it does not
//! spoil the factor's conditioning.
//!
//! A factor costs about ten of its own applications, while the matrix may
//! change little from one step to the next (a falling or hanging cloth), or a
//! lot (in contact, stretch springs flip between their tension and
//! compression stiffness and contacts come and go, changes of high rank that
//! conjugate gradients pays for one iteration each). So the factor is
//! *lagged*: a kept factor is tried first on a small iteration budget
//! ([`STALE_BUDGET`]); when that is not enough the factor is rebuilt for the
//! system at hand, which then solves in a few, and stale factors are
//! not tried again for [`RETRY_STALE_AFTER`] solves. A solve of the same
//! matrix with constraints added to a few particles (new contacts found
//! after a solve) tries the kept factor on a larger budget
//! ([`RESOLVE_BUDGET`]): those matrices differ in a few rows only.
//!
//! The factor is single precision: a preconditioner need not be exact (the
//! conjugate gradients run in f64 and stop at the same tolerance), and f32
//! halves the memory traffic of factor and solves. A system too stiff for it
//! (the f32 factor fails, or a fresh one needs more than
//! [`single_precision_allowance`]) switches the simulation to f64 factors.
//!
//! The factor's pattern is the diagonal and the blocks of the cloth's springs.
//! Bending hinges also couple each hinge's two opposite corners. On a
//! triangle mesh the shear spring across the hinge's edge joins them anyway;
//! on a quad mesh (a grid) nothing does, and those blocks widen the stencil
//! from 9 to ~21 points and several times the factor's fill, for a coupling
//! that is weak next to the springs'. So a hinge's block is kept only where
//! the springs' factor already stores its entries (within a dissection leaf,
//! along a separator, into a separator its subtree already reaches), which
//! costs nothing, and dropped elsewhere. A dropped block `D` (rows `i`, `j`) is
//! replaced by a bound of `‖D‖₂` times `I` on both diagonal blocks, which adds
//! the positive semi-definite `[[‖D‖I, −D], [−Dᵀ, ‖D‖I]]`: the factored
//! matrix stays positive definite and at least `S A S + c (I − S)`, so
//! conjugate gradients converge in a few iterations more, each cheaper.
//!
//! The symbolic analysis is done once per cloth from the kept pattern: a
//! nested-dissection order of the particles ([`super::dissection`]), then
//! faer's supernodes. Under that order the factor is a balanced tree, whose
//! independent subtrees [`super::supernodal`] factors and solves in parallel,
//! bit-identical at any thread count.

use std::sync::Arc;

use faer::Side;
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use nalgebra::{Matrix3, Vector3};

use super::constraint::Constraint;
use super::dissection::{Adjacency, nested_dissection};
use super::parallel;
use super::sparse::{BlockPattern, SystemMatrix};
use super::supernodal::{Scalar, SupernodalFactor, SupernodalTree};

/// Iterations a kept (stale) factor gets before it is rebuilt: a failed try
/// costs less than a third of a factor.
pub const STALE_BUDGET: u32 = 3;

/// Iterations the factor of a step's matrix gets when only constraints were
/// added since (particles found coming into contact after a solve): the two
/// filtered matrices differ only in those particles' rows and columns, and
/// a new factor costs as much as six to ten iterations. Measured on
/// `drape_table`, whose steps solve again for new contacts in most steps:
/// 117 of 120 such solves converged within 8 iterations, most in 3 to 6,
/// however many contacts were new.
pub const RESOLVE_BUDGET: u32 = 8;

/// Solves to wait after a stale factor failed before trying one again.
pub const RETRY_STALE_AFTER: u64 = 8;

/// Iterations per digit of the solver tolerance a fresh single-precision
/// factor may need before the simulation switches to double-precision
/// factors. The factor leaves blocks out, so even an exact one needs a few
/// iterations, about in proportion to the digits asked for (measured: ~3
/// per step at 1e-3, ~7 at 1e-8); an f32 factor too coarse for the system
/// stalls instead, far past this.
pub const SINGLE_PRECISION_ITERATIONS_PER_DIGIT: f64 = 2.0;

/// Why a factor could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CholeskyError {
    /// The symbolic analysis failed (out of memory or index overflow).
    #[error("sparse Cholesky analysis failed: {0}")]
    Analysis(String),
    /// The filtered matrix is not numerically positive definite.
    #[error("the system matrix is not positive definite")]
    NotPositiveDefinite,
    /// A saved factor ([`FactorState`]) was made for another system.
    #[error("a saved factor of {saved} blocks does not fit this system of {expected}")]
    SavedStateMismatch {
        /// Blocks in the saved state.
        saved: usize,
        /// Blocks of this system.
        expected: usize,
    },
}

/// The scalar lower triangle of a 3×3-block symmetric matrix in compressed
/// columns, with the map from its entries back to the blocks, in an order of
/// its own: scalar unknown `k` of the triangle is unknown `system[k]`
/// (`3 particle + axis`) of the system.
#[derive(Clone, Debug)]
struct LowerTriangle {
    dimension: usize,
    column_start: Vec<u32>,
    row_index: Vec<u32>,
    /// Where each entry comes from: entry `(c, r)` of block slot `s` of the
    /// block pattern (row `j`, column `i ≥ j`: the transpose of block
    /// `(i, j)`), as its place `9 s + 3 r + c` among the blocks' values read
    /// as one array of column-major 3×3 blocks. The factor reads every entry
    /// through this one index.
    source: Vec<u32>,
    system: Vec<u32>,
}

impl LowerTriangle {
    /// The pattern of the lower triangle of the scalar matrix of the `kept`
    /// slots of `pattern`.
    fn new(pattern: &BlockPattern, kept: &[bool]) -> Self {
        let n = pattern.rows();
        let mut column_start = Vec::with_capacity(3 * n + 1);
        let (mut row_index, mut source) = (Vec::new(), Vec::new());
        column_start.push(0);
        for j in 0..n {
            for c in 0..3 {
                // Row j of a symmetric pattern lists block column j's blocks.
                for s in pattern.row(j).filter(|&s| pattern.column(s) >= j && kept[s]) {
                    let i = pattern.column(s);
                    for r in (0..3).filter(|&r| i > j || r >= c) {
                        row_index.push((3 * i + r) as u32);
                        source.push((9 * s + 3 * r + c) as u32);
                    }
                }
                column_start.push(row_index.len() as u32);
            }
        }
        let system = (0..3 * n as u32).collect();
        LowerTriangle { dimension: 3 * n, column_start, row_index, source, system }
    }

    /// The same matrix with its unknowns renumbered: unknown `k` of the result
    /// is unknown `order[k]` of this one, and `position[order[k]] = k`. The
    /// factor is then built without a permutation of its own, which it would
    /// otherwise apply to every matrix it factors.
    fn reordered(&self, order: &[u32], position: &[u32]) -> Self {
        let mut moved = Vec::with_capacity(self.source.len());
        for column in 0..self.dimension {
            let range = self.column_start[column] as usize..self.column_start[column + 1] as usize;
            for (&row, &entry) in self.row_index[range.clone()].iter().zip(&self.source[range]) {
                // The matrix is symmetric: an entry that lands above the
                // diagonal is stored as its mirror, which has the same value.
                let (a, b) = (position[row as usize], position[column]);
                moved.push((a.min(b), a.max(b), entry));
            }
        }
        moved.sort_unstable_by_key(|&(column, row, _)| (column, row));
        let mut column_start = vec![0u32; self.dimension + 1];
        for &(column, _, _) in &moved {
            column_start[column as usize + 1] += 1;
        }
        for k in 0..self.dimension {
            column_start[k + 1] += column_start[k];
        }
        LowerTriangle {
            dimension: self.dimension,
            column_start,
            row_index: moved.iter().map(|&(_, row, _)| row).collect(),
            source: moved.iter().map(|&(_, _, entry)| entry).collect(),
            system: order.iter().map(|&k| self.system[k as usize]).collect(),
        }
    }

    /// The supernodal analysis of the matrix in its own order (analysed in
    /// its own order, a matrix is read as its upper triangle).
    fn analysis(&self) -> Result<SymbolicCholesky<u32>, CholeskyError> {
        let (column_start, row_index) = self.upper();
        let n = self.dimension;
        let upper = SymbolicSparseColMatRef::new_checked(n, n, &column_start, None, &row_index);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        factorize_symbolic_cholesky(upper, Side::Upper, SymmetricOrdering::Identity, params)
            .map_err(|e| CholeskyError::Analysis(format!("{e:?}")))
    }

    /// The pattern of the upper triangle (the mirror of this one), as column
    /// starts and row indices.
    fn upper(&self) -> (Vec<u32>, Vec<u32>) {
        let mut column_start = vec![0u32; self.dimension + 1];
        for &row in &self.row_index {
            column_start[row as usize + 1] += 1;
        }
        for k in 0..self.dimension {
            column_start[k + 1] += column_start[k];
        }
        let mut next = column_start.clone();
        let mut row_index = vec![0u32; self.row_index.len()];
        for column in 0..self.dimension {
            for &row in &self.row_index[self.column_start[column] as usize..self.column_start[column + 1] as usize] {
                row_index[next[row as usize] as usize] = column as u32;
                next[row as usize] += 1;
            }
        }
        (column_start, row_index)
    }

    /// Scalar entry `e` (in the triangle's order) of the blocks `filtered`
    /// (one per stored slot) read as one array of their values, as `T`.
    fn entry<T: Precision>(&self, filtered: &[f64], e: usize) -> T {
        T::from_f64(filtered[self.source[e] as usize])
    }
}

/// The supernodal tree of `symbolic` (an analysis of a triangle of the same
/// order whose pattern holds `lower`'s), with `lower`'s entries placed in it.
fn symbolic_tree(symbolic: &SymbolicCholesky<u32>, lower: &LowerTriangle) -> Result<SupernodalTree, CholeskyError> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(supernodal) => {
            SupernodalTree::new(supernodal, &lower.column_start, &lower.row_index)
                .map_err(|e| CholeskyError::Analysis(e.to_string()))
        }
        SymbolicCholeskyRaw::Simplicial(_) => Err(CholeskyError::Analysis("not supernodal".into())),
    }
}

/// `kept` and every other block of `pattern` whose entries the factor of
/// the `kept` blocks already stores (`tree`, unknown `k` at `position[k]`):
/// keeping those fills in nothing and leaves fewer blocks to bound on the
/// diagonal. On a grid they are the bending hinges within a nested-dissection
/// leaf or along a separator, and those reaching a separator that their
/// subtree's rows already hold.
fn without_fill(pattern: &BlockPattern, mut kept: Vec<bool>, tree: &SupernodalTree, position: &[u32]) -> Vec<bool> {
    for row in 0..pattern.rows() {
        for slot in pattern.row(row) {
            if kept[slot] {
                continue;
            }
            let column = pattern.column(slot);
            kept[slot] = (0..9).all(|k| {
                let (a, b) = (position[3 * row + k / 3], position[3 * column + k % 3]);
                tree.stores(a.max(b), a.min(b))
            });
        }
    }
    kept
}

/// Block `a` of row constraint `row` and column constraint `column`, filtered:
/// `S_row a S_column`, plus `(I − S_row) c` on the `diagonal`.
fn filtered_block(row: &Constraint, a: &Matrix3<f64>, column: &Constraint, diagonal: bool) -> Matrix3<f64> {
    if *row == Constraint::Free && *column == Constraint::Free {
        return *a;
    }
    let filter_row = row.filter_matrix();
    let block = filter_row * a * column.filter_matrix();
    if diagonal { block + (Matrix3::identity() - filter_row) * (a.trace() / 3.0) } else { block }
}

/// The row of each stored slot of `pattern`.
fn slot_rows(pattern: &BlockPattern) -> Vec<u32> {
    (0..pattern.rows()).flat_map(|j| pattern.row(j).map(move |_| j as u32)).collect()
}

/// The scalar unknowns of `particles` particles in the nested-dissection
/// order of their `couplings` at `positions` (each particle's three axes
/// together), and the position of each unknown in that order.
fn dissection_order(particles: usize, couplings: &[[u32; 2]], positions: &[Vector3<f64>]) -> (Vec<u32>, Vec<u32>) {
    let by_particle = nested_dissection(&Adjacency::new(particles, couplings), positions);
    let order: Vec<u32> = by_particle.iter().flat_map(|&p| [3 * p, 3 * p + 1, 3 * p + 2]).collect();
    let mut position = vec![0u32; order.len()];
    for (k, &unknown) in order.iter().enumerate() {
        position[unknown as usize] = k as u32;
    }
    (order, position)
}

/// Slots of `pattern` the factor keeps: the diagonal and the blocks of `couplings`.
fn kept_slots(pattern: &BlockPattern, couplings: &[[u32; 2]]) -> Vec<bool> {
    let mut kept = vec![false; pattern.stored_blocks()];
    for i in 0..pattern.rows() {
        kept[pattern.diagonal(i)] = true;
    }
    for &[a, b] in couplings {
        for (row, column) in [(a, b), (b, a)] {
            if let Some(slot) = pattern.slot(row as usize, column as usize) {
                kept[slot] = true;
            }
        }
    }
    kept
}

/// Iterations a fresh single-precision factor may take to reach `tolerance`
/// (relative): [`SINGLE_PRECISION_ITERATIONS_PER_DIGIT`] per digit, at least
/// one digit's worth.
pub fn single_precision_allowance(tolerance: f64) -> u32 {
    let digits = if tolerance > 0.0 { (-tolerance.log10()).max(1.0) } else { f64::from(f32::DIGITS) };
    (SINGLE_PRECISION_ITERATIONS_PER_DIGIT * digits).ceil() as u32
}

/// A block the factor drops, above the diagonal: its slot, row and column.
#[derive(Clone, Copy, Debug)]
struct DroppedBlock {
    slot: u32,
    row: u32,
    column: u32,
}

/// The blocks of `pattern` above the diagonal that are not `kept`.
fn dropped_blocks(pattern: &BlockPattern, kept: &[bool]) -> Vec<DroppedBlock> {
    (0..pattern.rows())
        .flat_map(|row| pattern.row(row).map(move |slot| (row, slot)))
        .filter(|&(row, slot)| pattern.column(slot) > row && !kept[slot])
        .map(|(row, slot)| DroppedBlock { slot: slot as u32, row: row as u32, column: pattern.column(slot) as u32 })
        .collect()
}

/// An upper bound of the spectral norm of `d`: `√(‖d‖₁ ‖d‖∞)`, exact for a
/// multiple of the identity.
fn spectral_norm_bound(d: &Matrix3<f64>) -> f64 {
    let magnitudes = d.abs();
    let (columns, rows) = (magnitudes.row_sum().max(), magnitudes.column_sum().max());
    (columns * rows).sqrt()
}

/// The blocks the factor drops, and each particle's among them in
/// compressed rows (a block appears under both particles it couples).
#[derive(Clone, Debug)]
struct DroppedBlocks {
    blocks: Vec<DroppedBlock>,
    start: Vec<u32>,
    of_particle: Vec<u32>,
}

impl DroppedBlocks {
    fn new(particles: usize, blocks: Vec<DroppedBlock>) -> Self {
        let mut start = vec![0u32; particles + 1];
        for block in &blocks {
            start[block.row as usize + 1] += 1;
            start[block.column as usize + 1] += 1;
        }
        for i in 0..particles {
            start[i + 1] += start[i];
        }
        let mut next = start.clone();
        let mut of_particle = vec![0u32; blocks.len() * 2];
        for (b, block) in blocks.iter().enumerate() {
            for particle in [block.row, block.column] {
                of_particle[next[particle as usize] as usize] = b as u32;
                next[particle as usize] += 1;
            }
        }
        DroppedBlocks { blocks, start, of_particle }
    }

    /// The indices in `blocks` of the dropped blocks of `particle`.
    fn of(&self, particle: usize) -> &[u32] {
        &self.of_particle[self.start[particle] as usize..self.start[particle + 1] as usize]
    }
}

/// A floating-point type a factor can be kept in.
trait Precision: Scalar {
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
}

impl Precision for f32 {
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Precision for f64 {
    fn from_f64(x: f64) -> Self {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// The numerical part of a factor in precision `T`, with its work space.
#[derive(Clone)]
struct Numeric<T> {
    rhs: Vec<T>,
    factor: SupernodalFactor<T>,
}

impl<T: Precision> Numeric<T> {
    fn new(tree: &SupernodalTree, lower: &LowerTriangle) -> Self {
        Numeric { rhs: vec![T::from_f64(0.0); lower.dimension], factor: SupernodalFactor::new(tree) }
    }

    /// Factors the filtered blocks.
    fn factor(
        &mut self,
        tree: &SupernodalTree,
        lower: &LowerTriangle,
        filtered: &[Matrix3<f64>],
    ) -> Result<(), CholeskyError> {
        let values: &[f64] = bytemuck::cast_slice(filtered);
        self.factor.factor(tree, |e| lower.entry(values, e)).map_err(|_| CholeskyError::NotPositiveDefinite)
    }

    /// `z = M⁻¹ r` with the factor.
    fn apply(&mut self, tree: &SupernodalTree, lower: &LowerTriangle, r: &[Vector3<f64>], z: &mut [Vector3<f64>]) {
        for (value, &k) in self.rhs.iter_mut().zip(&lower.system) {
            *value = T::from_f64(r[k as usize / 3][k as usize % 3]);
        }
        self.factor.solve_in_place(tree, &mut self.rhs);
        for (value, &k) in self.rhs.iter().zip(&lower.system) {
            z[k as usize / 3][k as usize % 3] = value.to_f64();
        }
    }
}

/// The numerical factor in the precision the system allows.
#[derive(Clone)]
enum Factor {
    Single(Numeric<f32>),
    Double(Numeric<f64>),
}

/// A Cholesky factor of the filtered system, kept across steps.
#[derive(Clone)]
pub struct LaggedCholesky {
    lower: LowerTriangle,
    /// The row of each stored slot of the pattern.
    slot_rows: Arc<[u32]>,
    /// Whether the factor keeps each stored slot of the pattern.
    kept: Arc<[bool]>,
    /// Blocks of the system the factor leaves out, compensated on the diagonal.
    dropped: Arc<DroppedBlocks>,
    /// The norm bound of each dropped block, scratch.
    bounds: Vec<f64>,
    /// Each particle's compensation, scratch.
    compensation: Vec<f64>,
    /// The filtered blocks of the last factor, one per stored slot (the
    /// dropped ones zero).
    filtered: Vec<Matrix3<f64>>,
    tree: Arc<SupernodalTree>,
    numeric: Factor,
    current: bool,
    /// Solves started so far, and the solve at which a stale factor last failed.
    solves: u64,
    stale_failed_at: Option<u64>,
}

impl LaggedCholesky {
    /// Analyses the block pattern once (ordering and supernodes), keeping
    /// the diagonal and the blocks of `couplings` (a cloth's springs); the
    /// pattern's other blocks are dropped and compensated on the diagonal.
    /// `positions` (m, one per particle) guide the nested dissection.
    pub fn new(
        pattern: &BlockPattern,
        couplings: &[[u32; 2]],
        positions: &[Vector3<f64>],
    ) -> Result<Self, CholeskyError> {
        let springs = kept_slots(pattern, couplings);
        let (order, position) = dissection_order(pattern.rows(), couplings, positions);
        let analysed = LowerTriangle::new(pattern, &springs).reordered(&order, &position);
        let symbolic = analysed.analysis()?;
        let kept = without_fill(pattern, springs, &symbolic_tree(&symbolic, &analysed)?, &position);
        let dropped = DroppedBlocks::new(pattern.rows(), dropped_blocks(pattern, &kept));
        let lower = LowerTriangle::new(pattern, &kept).reordered(&order, &position);
        let tree = symbolic_tree(&symbolic, &lower)?;
        let numeric = Factor::Single(Numeric::new(&tree, &lower));
        Ok(LaggedCholesky {
            filtered: vec![Matrix3::zeros(); pattern.stored_blocks()],
            slot_rows: slot_rows(pattern).into(),
            bounds: vec![0.0; dropped.blocks.len()],
            dropped: Arc::new(dropped),
            kept: kept.into(),
            compensation: vec![0.0; pattern.rows()],
            lower,
            tree: Arc::new(tree),
            numeric,
            current: false,
            solves: 0,
            stale_failed_at: None,
        })
    }

    /// Starts a solve of a new system (a new matrix or new constraints) and
    /// says whether the kept factor is worth trying on it: there is one, and
    /// no stale factor failed in the last [`RETRY_STALE_AFTER`] solves.
    pub fn begin_solve(&mut self) -> bool {
        self.solves += 1;
        self.current && self.stale_failed_at.is_none_or(|at| self.solves - at >= RETRY_STALE_AFTER)
    }

    /// Starts a solve of the system last factored with constraints added to a
    /// few particles (new contacts found after a solve) and says whether the
    /// kept factor is worth trying on it: whenever there is one, since the
    /// two filtered matrices differ only in those particles' rows and
    /// columns (see [`RESOLVE_BUDGET`]).
    pub fn begin_resolve(&mut self) -> bool {
        self.solves += 1;
        self.current
    }

    /// Notes that the kept factor did not solve this system within its budget.
    pub fn stale_failed(&mut self) {
        self.stale_failed_at = Some(self.solves);
    }

    /// Factors `S A S + c (I − S)` for block values `a` on `pattern` (its
    /// dropped blocks compensated on the diagonal), in
    /// single precision unless the system has needed double. On failure the
    /// old factor is dropped and the caller must precondition otherwise until
    /// a later factor succeeds.
    pub fn refactor(&mut self, matrix: SystemMatrix, constraints: &[Constraint]) -> Result<(), CholeskyError> {
        self.current = false;
        self.filter_blocks(matrix, constraints);
        self.compensate_dropped(matrix, constraints);
        let (tree, lower, filtered) = (&*self.tree, &self.lower, &self.filtered);
        if let Factor::Single(single) = &mut self.numeric {
            if single.factor(tree, lower, filtered).is_ok() {
                self.current = true;
                return Ok(());
            }
            self.use_double_precision();
        }
        if let Factor::Double(double) = &mut self.numeric {
            double.factor(&self.tree, &self.lower, &self.filtered)?;
        }
        self.current = true;
        Ok(())
    }

    /// Fills `filtered` with the blocks of `S A S + c (I − S)` the factor
    /// keeps, for `matrix` (on the pattern the factor was made for); the
    /// dropped slots stay zero (the factor does not read them).
    fn filter_blocks(&mut self, matrix: SystemMatrix, constraints: &[Constraint]) {
        let (slot_rows, kept, pattern) = (&self.slot_rows, &self.kept, &matrix.pattern.all);
        parallel::for_each_indexed(&mut self.filtered, |s, block| {
            if kept[s] {
                let (j, i) = (slot_rows[s] as usize, pattern.column(s));
                *block = filtered_block(&constraints[j], &matrix.block(j, s), &constraints[i], i == j);
            }
        });
    }

    /// Adds, for each dropped block `D` of `matrix` (filtered by
    /// `constraints`), `‖D‖₂ I` to the two diagonal blocks of `filtered` it
    /// couples.
    fn compensate_dropped(&mut self, matrix: SystemMatrix, constraints: &[Constraint]) {
        let dropped = &self.dropped;
        parallel::for_each_indexed(&mut self.bounds, |b, bound| {
            let block = dropped.blocks[b];
            let (row, column) = (&constraints[block.row as usize], &constraints[block.column as usize]);
            let value = matrix.block(block.row as usize, block.slot as usize);
            *bound = spectral_norm_bound(&filtered_block(row, &value, column, false));
        });
        let bounds = &self.bounds;
        parallel::for_each_indexed(&mut self.compensation, |i, sum| {
            *sum = dropped.of(i).iter().map(|&b| bounds[b as usize]).sum();
        });
        for (i, extra) in self.compensation.iter().enumerate() {
            self.filtered[matrix.pattern.all.diagonal(i)] += Matrix3::identity() * *extra;
        }
    }

    /// Notes the iterations a solve to `tolerance` with a fresh factor took:
    /// a single-precision factor that needed more than
    /// [`single_precision_allowance`] is too coarse for this system, and later
    /// factors are double precision.
    pub fn fresh_factor_needed(&mut self, iterations: u32, tolerance: f64) {
        if iterations > single_precision_allowance(tolerance) && self.is_single_precision() {
            self.use_double_precision();
            self.current = false;
        }
    }

    /// True while factors are kept in single precision.
    pub fn is_single_precision(&self) -> bool {
        matches!(self.numeric, Factor::Single(_))
    }

    fn use_double_precision(&mut self) {
        self.numeric = Factor::Double(Numeric::new(&self.tree, &self.lower));
    }

    /// `z = M⁻¹ r` with the current factor (unfiltered: the caller filters).
    pub fn apply(&mut self, r: &[Vector3<f64>], z: &mut [Vector3<f64>]) {
        match &mut self.numeric {
            Factor::Single(single) => single.apply(&self.tree, &self.lower, r, z),
            Factor::Double(double) => double.apply(&self.tree, &self.lower, r, z),
        }
    }
}

/// What a [`LaggedCholesky`] carries from solve to solve, as plain data: the
/// blocks its factor was built from (the factor follows from them exactly),
/// its precision and its schedule. Restoring it makes the next solves what
/// they would have been ([`LaggedCholesky::restore`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FactorState {
    /// The filtered, compensated blocks of the last factor (row-major 3×3),
    /// one per stored slot of the pattern (the factor reads only the ones it
    /// keeps).
    pub filtered: Vec<[f64; 9]>,
    /// Whether factors are built in double precision.
    pub double_precision: bool,
    /// Whether a factor of `filtered` is in use.
    pub current: bool,
    /// Solves started so far.
    pub solves: u64,
    /// The solve at which a stale factor last failed.
    pub stale_failed_at: Option<u64>,
}

impl LaggedCholesky {
    /// Its state, to be restored later with [`Self::restore`].
    pub fn state(&self) -> FactorState {
        FactorState {
            filtered: self.filtered.iter().map(|m| std::array::from_fn(|k| m[(k / 3, k % 3)])).collect(),
            double_precision: !self.is_single_precision(),
            current: self.current,
            solves: self.solves,
            stale_failed_at: self.stale_failed_at,
        }
    }

    /// Returns to `state` (taken from a factor of the same pattern),
    /// rebuilding its factor from the saved blocks: the same arithmetic as
    /// when it was first built, so the same factor to the bit.
    pub fn restore(&mut self, state: &FactorState) -> Result<(), CholeskyError> {
        if state.filtered.len() != self.filtered.len() {
            return Err(CholeskyError::SavedStateMismatch {
                saved: state.filtered.len(),
                expected: self.filtered.len(),
            });
        }
        for (block, saved) in self.filtered.iter_mut().zip(&state.filtered) {
            *block = Matrix3::from_row_slice(saved);
        }
        if state.double_precision {
            self.use_double_precision();
        } else {
            self.numeric = Factor::Single(Numeric::new(&self.tree, &self.lower));
        }
        (self.current, self.solves, self.stale_failed_at) = (state.current, state.solves, state.stale_failed_at);
        if self.current {
            let (tree, lower, filtered) = (&*self.tree, &self.lower, &self.filtered);
            match &mut self.numeric {
                Factor::Single(single) => single.factor(tree, lower, filtered)?,
                Factor::Double(double) => double.factor(tree, lower, filtered)?,
            }
        }
        Ok(())
    }
}

impl std::fmt::Debug for LaggedCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LaggedCholesky")
            .field("dimension", &self.lower.dimension)
            .field("factor_values", &self.tree.value_count())
            .field("single_precision", &self.is_single_precision())
            .field("current", &self.current)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::sparse::SystemPattern;
    use nalgebra::{DMatrix, DVector};

    use crate::sim::test_grid::{quad_grid, ring_positions};

    /// The couplings of the ring of `n` particles to their neighbours at
    /// ±1 and ±2.
    fn ring_pairs(n: usize) -> Vec<[u32; 2]> {
        (0..n as u32).flat_map(|i| [[i, (i + 1) % n as u32], [i, (i + 2) % n as u32]]).collect()
    }

    /// A random SPD block system on a ring of `n` particles (couplings ±1, ±2).
    fn ring(n: usize, seed: u64) -> (BlockPattern, Vec<Matrix3<f64>>) {
        let pattern = BlockPattern::new(n, ring_pairs(n));
        let mut a = vec![Matrix3::zeros(); pattern.stored_blocks()];
        let mut state = seed;
        let mut rand = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as f64 / (1u64 << 31) as f64 - 0.5
        };
        for i in 0..n {
            a[pattern.diagonal(i)] += Matrix3::identity() * 0.01;
            for j in [(i + 1) % n, (i + 2) % n] {
                let u = Vector3::new(rand(), rand(), rand());
                let k = u * u.transpose() * 100.0;
                for (r, c, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                    a[pattern.slot(r, c).unwrap()] += k * sign;
                }
            }
        }
        (pattern, a)
    }

    fn dense(pattern: &BlockPattern, blocks: impl Fn(usize, usize) -> Matrix3<f64>) -> DMatrix<f64> {
        let n = pattern.rows();
        let mut m = DMatrix::zeros(3 * n, 3 * n);
        for i in 0..n {
            for s in pattern.row(i) {
                let j = pattern.column(s);
                m.view_mut((3 * i, 3 * j), (3, 3)).copy_from(&blocks(s, i));
            }
        }
        m
    }

    /// Refactors `cholesky` for the full blocks `a` on `pattern`.
    fn refactor_blocks(
        cholesky: &mut LaggedCholesky,
        pattern: &BlockPattern,
        a: &[Matrix3<f64>],
        constraints: &[Constraint],
    ) -> Result<(), CholeskyError> {
        let system = SystemPattern::blocks_only(pattern.clone());
        cholesky.refactor(SystemMatrix { pattern: &system, blocks: a, isotropic_scale: &[] }, constraints)
    }

    fn flatten(v: &[Vector3<f64>]) -> DVector<f64> {
        DVector::from_iterator(3 * v.len(), v.iter().flat_map(|x| x.iter().copied()))
    }

    /// The factor inverts `S A S + c (I − S)` exactly: checked against a dense
    /// solve of the same matrix, with pinned, contact and free particles.
    #[test]
    fn factor_solves_the_filtered_system() {
        let (pattern, a) = ring(12, 7);
        let mut constraints = vec![Constraint::Free; 12];
        constraints[3] = Constraint::Fixed;
        constraints[8] = Constraint::Normal(Vector3::new(1.0, 2.0, 2.0) / 3.0);
        let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(12), &ring_positions(12)).unwrap();
        assert!(!cholesky.begin_solve(), "no factor yet");
        refactor_blocks(&mut cholesky, &pattern, &a, &constraints).unwrap();

        let filtered = dense(&pattern, |s, i| {
            let j = pattern.column(s);
            let (si, sj) = (constraints[i].filter_matrix(), constraints[j].filter_matrix());
            let fill = if i == j { (Matrix3::identity() - si) * (a[s].trace() / 3.0) } else { Matrix3::zeros() };
            si * a[s] * sj + fill
        });
        let r: Vec<Vector3<f64>> = (0..12).map(|i| Vector3::new(i as f64, 1.0, -(i as f64) * 0.5)).collect();
        let expected = filtered.cholesky().unwrap().solve(&flatten(&r));
        let error = |cholesky: &mut LaggedCholesky| {
            let mut z = vec![Vector3::zeros(); 12];
            cholesky.apply(&r, &mut z);
            (flatten(&z) - &expected).norm() / expected.norm()
        };
        // Single precision loses about the condition number (here ~1e4) times
        // f32's 6e-8.
        let single = error(&mut cholesky);
        assert!(single < 1e-3, "single precision: relative error {single:e}");
        cholesky.use_double_precision();
        refactor_blocks(&mut cholesky, &pattern, &a, &constraints).unwrap();
        let double = error(&mut cholesky);
        assert!(double < 1e-12, "double precision: relative error {double:e}");
    }

    /// With the ±2 couplings dropped, the factored matrix `P` is the system
    /// plus a positive semi-definite compensation: `P − A ⪰ 0`, and `P` is
    /// not `A` (something was dropped).
    #[test]
    fn dropped_blocks_leave_a_factor_of_a_larger_matrix() {
        // Long enough for separators: the ±2 couplings across them would fill in.
        let (excess, scale) = factored_minus_system(48);
        assert!(excess.min() > -1e-9 * scale, "P − A has eigenvalue {:e}", excess.min());
        assert!(excess.max() > 1e-3 * scale, "the ±2 couplings across separators were dropped");
    }

    /// Besides the springs, the factor keeps exactly the blocks whose
    /// entries the springs' factor stores anyway: it stores as many values
    /// as the springs' alone, and on a quad grid that keeps some, not all,
    /// of the couplings two particles apart (where a quad mesh's hinges join).
    #[test]
    fn blocks_the_factor_stores_anyway_are_kept_at_no_fill() {
        let n = 24;
        let (springs, positions) = quad_grid(n);
        let id = |r: usize, c: usize| (r * n + c) as u32;
        let two_apart: Vec<[u32; 2]> = (0..n)
            .flat_map(|r| (0..n).map(move |c| (r, c)))
            .flat_map(|(r, c)| {
                [(r + 2 < n).then(|| [id(r, c), id(r + 2, c)]), (c + 2 < n).then(|| [id(r, c), id(r, c + 2)])]
            })
            .flatten()
            .collect();
        let pattern = BlockPattern::new(n * n, springs.iter().chain(&two_apart).copied());
        let cholesky = LaggedCholesky::new(&pattern, &springs, &positions).unwrap();

        let (order, position) = dissection_order(n * n, &springs, &positions);
        let springs_only = LowerTriangle::new(&pattern, &kept_slots(&pattern, &springs)).reordered(&order, &position);
        let springs_values = symbolic_tree(&springs_only.analysis().unwrap(), &springs_only).unwrap().value_count();
        assert_eq!(cholesky.tree.value_count(), springs_values);
        let kept_two_apart =
            two_apart.iter().filter(|&&[a, b]| cholesky.kept[pattern.slot(a as usize, b as usize).unwrap()]).count();
        assert!(kept_two_apart > two_apart.len() / 4, "{kept_two_apart} of {} kept", two_apart.len());
        assert!(kept_two_apart < two_apart.len(), "every coupling two apart kept: nothing crosses a separator");
    }

    /// The eigenvalues of `P − A` for the factored matrix `P` of a ring of
    /// `n` particles whose factor keeps the ±1 couplings, and `‖A‖`.
    fn factored_minus_system(n: usize) -> (DVector<f64>, f64) {
        let (pattern, a) = ring(n, 11);
        let neighbours: Vec<[u32; 2]> = (0..n as u32).map(|i| [i, (i + 1) % n as u32]).collect();
        let mut cholesky = LaggedCholesky::new(&pattern, &neighbours, &ring_positions(n)).unwrap();
        cholesky.use_double_precision();
        let free = vec![Constraint::Free; n];
        refactor_blocks(&mut cholesky, &pattern, &a, &free).unwrap();

        // P⁻¹ column by column, then P.
        let mut inverse = DMatrix::zeros(3 * n, 3 * n);
        for k in 0..3 * n {
            let mut unit = vec![Vector3::zeros(); n];
            unit[k / 3][k % 3] = 1.0;
            let mut column = vec![Vector3::zeros(); n];
            cholesky.apply(&unit, &mut column);
            inverse.set_column(k, &flatten(&column));
        }
        let factored = inverse.try_inverse().unwrap();
        let system = dense(&pattern, |s, _| a[s]);
        ((&factored - &system).symmetric_eigenvalues(), system.norm())
    }

    /// The factor is analysed in nested-dissection order: on a grid it fills
    /// in less than the grid's own row-by-row order, and its tree is
    /// balanced: most of the work lies off the longest chain of supernodes,
    /// in subtrees that factor in parallel.
    #[test]
    fn the_dissection_order_fills_in_little_and_balances_the_tree() {
        let side = 24u32;
        let at = |x: u32, y: u32| y * side + x;
        let mut pairs = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let neighbours = [(1, 0), (0, 1), (1, 1)].into_iter().chain((x > 0).then_some((-1, 1)));
                for (dx, dy) in neighbours {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < side as i64 && ny < side as i64 {
                        pairs.push([at(x, y), at(nx as u32, ny as u32)]);
                    }
                }
            }
        }
        let positions: Vec<_> =
            (0..side * side).map(|k| Vector3::new((k % side) as f64, 0.0, (k / side) as f64) * 0.01).collect();
        let pattern = BlockPattern::new((side * side) as usize, pairs.iter().copied());
        let natural = LowerTriangle::new(&pattern, &kept_slots(&pattern, &pairs));
        let unordered = symbolic_tree(&natural.analysis().unwrap(), &natural).unwrap().value_count();
        let cholesky = LaggedCholesky::new(&pattern, &pairs, &positions).unwrap();
        let dissected = cholesky.tree.value_count();
        assert!(dissected < unordered, "dissection fills {dissected} entries, the grid order {unordered}");
        let (longest_chain, total) = cholesky.tree.critical_path_flops();
        assert!(longest_chain < 0.4 * total, "{longest_chain:e} of {total:e} flops on one chain");
    }

    #[test]
    fn the_norm_bound_is_exact_for_multiples_of_the_identity_and_never_below_the_norm() {
        assert_eq!(spectral_norm_bound(&(Matrix3::identity() * -2.5)), 2.5);
        let mut state = 3u64;
        let mut rand = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as f64 / (1u64 << 31) as f64 - 0.5
        };
        for _ in 0..200 {
            let d = Matrix3::from_fn(|_, _| rand());
            let largest = d.singular_values().max();
            assert!(spectral_norm_bound(&d) >= largest * (1.0 - 1e-12), "{d}");
        }
    }

    #[test]
    fn the_single_precision_allowance_grows_with_the_digits_asked_for() {
        assert_eq!(single_precision_allowance(1e-3), 6);
        assert_eq!(single_precision_allowance(1e-10), 20);
        assert_eq!(single_precision_allowance(0.5), 2, "at least one digit's worth");
        assert_eq!(single_precision_allowance(0.0), 12, "f32's 6 digits when asked for exactness");
    }

    /// After a stale factor fails, stale factors are skipped for
    /// [`RETRY_STALE_AFTER`] solves, then tried again.
    #[test]
    fn failed_stale_factors_are_retried_later() {
        let (pattern, a) = ring(6, 5);
        let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(6), &ring_positions(6)).unwrap();
        cholesky.begin_solve();
        refactor_blocks(&mut cholesky, &pattern, &a, &[Constraint::Free; 6]).unwrap();
        assert!(cholesky.begin_solve(), "a kept factor is tried");
        cholesky.stale_failed();
        let tries: Vec<bool> = (0..RETRY_STALE_AFTER).map(|_| cholesky.begin_solve()).collect();
        assert_eq!(tries.iter().filter(|&&t| t).count(), 1);
        assert!(*tries.last().unwrap());
    }

    /// An indefinite matrix is reported, not factored, and leaves no factor
    /// (even after falling back to double precision).
    #[test]
    fn indefinite_matrix_is_rejected() {
        let (pattern, mut a) = ring(6, 3);
        a[pattern.diagonal(2)] = -Matrix3::identity();
        let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(6), &ring_positions(6)).unwrap();
        let free = vec![Constraint::Free; 6];
        assert_eq!(refactor_blocks(&mut cholesky, &pattern, &a, &free), Err(CholeskyError::NotPositiveDefinite));
        assert!(!cholesky.begin_solve(), "no factor is left to try");
    }
}
