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
//! not tried again for [`RETRY_STALE_AFTER`] solves.
//!
//! The factor is single precision: a preconditioner need not be exact (the
//! conjugate gradients run in f64 and stop at the same tolerance), and f32
//! halves the memory traffic of factor and solves. A system too stiff for it
//! (the f32 factor fails, or a fresh one needs more than
//! [`single_precision_allowance`]) switches the simulation to f64 factors.
//!
//! The factor keeps the diagonal and the blocks of the cloth's springs only.
//! Bending hinges also couple each hinge's two opposite corners. On a
//! triangle mesh the shear spring across the hinge's edge joins them anyway;
//! on a quad mesh (a grid) nothing does, and those blocks widen the stencil
//! from 9 to ~21 points and several times the factor's fill, for a coupling
//! that is weak next to the springs'. A dropped block `D` (rows `i`, `j`) is
//! replaced by a bound of `‖D‖₂` times `I` on both diagonal blocks, which adds
//! the positive semi-definite `[[‖D‖I, −D], [−Dᵀ, ‖D‖I]]`: the factored
//! matrix stays positive definite and at least `S A S + c (I − S)`, so
//! conjugate gradients converge in a few iterations more, each cheaper.
//!
//! The symbolic analysis (approximate minimum degree ordering, supernodes) is
//! done once per cloth from the kept pattern. Factor and solve run on one
//! thread, which on two cores is also the fastest here, and keeps the result
//! bit-identical at any thread count.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::traits::{ComplexField, RealField};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{Matrix3, Vector3};

use super::pcg::Constraint;
use super::sparse::BlockPattern;

/// Iterations a kept (stale) factor gets before it is rebuilt: a failed try
/// costs less than a third of a factor.
pub const STALE_BUDGET: u32 = 3;

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

/// Where each scalar entry of the lower triangle comes from: block slot `slot`
/// of the block pattern (row `j`, column `i ≥ j`), entry `(c, r)` of that block
/// (the transpose of block `(i, j)`), stored as `3 c + r`.
#[derive(Clone, Copy, Debug)]
struct LowerEntry {
    slot: u32,
    component: u8,
}

/// The scalar lower triangle of a 3×3-block symmetric matrix in compressed
/// columns, with the map from its entries back to the blocks.
#[derive(Clone, Debug)]
struct LowerTriangle {
    dimension: usize,
    column_start: Vec<u32>,
    row_index: Vec<u32>,
    entries: Vec<LowerEntry>,
}

impl LowerTriangle {
    /// The pattern of the lower triangle of the scalar matrix of the `kept`
    /// slots of `pattern`.
    fn new(pattern: &BlockPattern, kept: &[bool]) -> Self {
        let n = pattern.rows();
        let mut column_start = Vec::with_capacity(3 * n + 1);
        let (mut row_index, mut entries) = (Vec::new(), Vec::new());
        column_start.push(0);
        for j in 0..n {
            for c in 0..3 {
                // Row j of a symmetric pattern lists block column j's blocks.
                for s in pattern.row(j).filter(|&s| pattern.column(s) >= j && kept[s]) {
                    let i = pattern.column(s);
                    for r in (0..3).filter(|&r| i > j || r >= c) {
                        row_index.push((3 * i + r) as u32);
                        entries.push(LowerEntry { slot: s as u32, component: (3 * c + r) as u8 });
                    }
                }
                column_start.push(row_index.len() as u32);
            }
        }
        LowerTriangle { dimension: 3 * n, column_start, row_index, entries }
    }

    fn symbolic(&self) -> SymbolicSparseColMatRef<'_, u32> {
        SymbolicSparseColMatRef::new_checked(self.dimension, self.dimension, &self.column_start, None, &self.row_index)
    }

    /// The scalar entries of the blocks `filtered` (one per stored slot), in
    /// the triangle's order, as `T`.
    fn gather<T: Precision>(&self, filtered: &[Matrix3<f64>], values: &mut [T]) {
        for (value, entry) in values.iter_mut().zip(&self.entries) {
            let (c, r) = (entry.component as usize / 3, entry.component as usize % 3);
            *value = T::from_f64(filtered[entry.slot as usize][(c, r)]);
        }
    }
}

/// Fills `filtered` (one block per stored slot of `pattern`) with the blocks
/// of `S A S + c (I − S)`.
fn filter_blocks(
    pattern: &BlockPattern,
    a: &[Matrix3<f64>],
    constraints: &[Constraint],
    filtered: &mut [Matrix3<f64>],
) {
    for j in 0..pattern.rows() {
        let filter_j = constraints[j].filter_matrix();
        for s in pattern.row(j) {
            let i = pattern.column(s);
            filtered[s] = filter_j * a[s] * constraints[i].filter_matrix();
            if i == j {
                filtered[s] += (Matrix3::identity() - filter_j) * (a[s].trace() / 3.0);
            }
        }
    }
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

/// Adds, for each dropped block `D`, `‖D‖₂ I` to the two diagonal blocks it
/// couples (its slot is left as it is: the factor does not read it).
fn compensate_dropped(pattern: &BlockPattern, dropped: &[DroppedBlock], filtered: &mut [Matrix3<f64>]) {
    for block in dropped {
        let bound = spectral_norm_bound(&filtered[block.slot as usize]);
        for particle in [block.row, block.column] {
            filtered[pattern.diagonal(particle as usize)] += Matrix3::identity() * bound;
        }
    }
}

/// A floating-point type a factor can be kept in.
trait Precision: RealField + ComplexField<Real = Self> + Copy {
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
struct Numeric<T> {
    values: Vec<T>,
    factor: Vec<T>,
    rhs: Vec<T>,
    factor_scratch: MemBuffer,
    solve_scratch: MemBuffer,
}

impl<T: Precision> Numeric<T> {
    fn new(symbolic: &SymbolicCholesky<u32>, lower: &LowerTriangle) -> Self {
        Numeric {
            values: vec![T::from_f64(0.0); lower.entries.len()],
            factor: vec![T::from_f64(0.0); symbolic.len_val()],
            rhs: vec![T::from_f64(0.0); lower.dimension],
            factor_scratch: MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<T>(Par::Seq, Default::default())),
            solve_scratch: MemBuffer::new(symbolic.solve_in_place_scratch::<T>(1, Par::Seq)),
        }
    }

    /// Factors the filtered blocks.
    fn factor(
        &mut self,
        symbolic: &SymbolicCholesky<u32>,
        lower: &LowerTriangle,
        filtered: &[Matrix3<f64>],
    ) -> Result<(), CholeskyError> {
        lower.gather(filtered, &mut self.values);
        let matrix = SparseColMatRef::new(lower.symbolic(), &self.values);
        symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                matrix,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_scratch),
                Default::default(),
            )
            .map(|_| ())
            .map_err(|_| CholeskyError::NotPositiveDefinite)
    }

    /// `z = M⁻¹ r` with the factor.
    fn apply(&mut self, symbolic: &SymbolicCholesky<u32>, r: &[Vector3<f64>], z: &mut [Vector3<f64>]) {
        for (chunk, ri) in self.rhs.chunks_exact_mut(3).zip(r) {
            for (value, &component) in chunk.iter_mut().zip(ri.iter()) {
                *value = T::from_f64(component);
            }
        }
        let n = self.rhs.len();
        LltRef::new(symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.solve_scratch),
        );
        for (zi, chunk) in z.iter_mut().zip(self.rhs.chunks_exact(3)) {
            *zi = Vector3::new(chunk[0].to_f64(), chunk[1].to_f64(), chunk[2].to_f64());
        }
    }

    fn duplicate(&self, symbolic: &SymbolicCholesky<u32>, lower: &LowerTriangle) -> Self {
        let mut copy = Numeric::new(symbolic, lower);
        copy.values.clone_from(&self.values);
        copy.factor.clone_from(&self.factor);
        copy
    }
}

/// The numerical factor in the precision the system allows.
enum Factor {
    Single(Numeric<f32>),
    Double(Numeric<f64>),
}

/// A Cholesky factor of the filtered system, kept across steps.
pub struct LaggedCholesky {
    lower: LowerTriangle,
    /// Blocks of the system the factor leaves out, compensated on the diagonal.
    dropped: Arc<[DroppedBlock]>,
    /// The filtered blocks of the last factor, one per stored slot.
    filtered: Vec<Matrix3<f64>>,
    symbolic: Arc<SymbolicCholesky<u32>>,
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
    pub fn new(pattern: &BlockPattern, couplings: &[[u32; 2]]) -> Result<Self, CholeskyError> {
        let kept = kept_slots(pattern, couplings);
        let lower = LowerTriangle::new(pattern, &kept);
        let symbolic =
            factorize_symbolic_cholesky(lower.symbolic(), Side::Lower, SymmetricOrdering::Amd, Default::default())
                .map_err(|e| CholeskyError::Analysis(format!("{e:?}")))?;
        let numeric = Factor::Single(Numeric::new(&symbolic, &lower));
        Ok(LaggedCholesky {
            filtered: vec![Matrix3::zeros(); pattern.stored_blocks()],
            dropped: dropped_blocks(pattern, &kept).into(),
            lower,
            symbolic: Arc::new(symbolic),
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

    /// Notes that the kept factor did not solve this system within its budget.
    pub fn stale_failed(&mut self) {
        self.stale_failed_at = Some(self.solves);
    }

    /// Factors `S A S + c (I − S)` for block values `a` on `pattern` (its
    /// dropped blocks compensated on the diagonal), in
    /// single precision unless the system has needed double. On failure the
    /// old factor is dropped and the caller must precondition otherwise until
    /// a later factor succeeds.
    pub fn refactor(
        &mut self,
        pattern: &BlockPattern,
        a: &[Matrix3<f64>],
        constraints: &[Constraint],
    ) -> Result<(), CholeskyError> {
        self.current = false;
        filter_blocks(pattern, a, constraints, &mut self.filtered);
        compensate_dropped(pattern, &self.dropped, &mut self.filtered);
        let (symbolic, lower, filtered) = (&*self.symbolic, &self.lower, &self.filtered);
        if let Factor::Single(single) = &mut self.numeric {
            if single.factor(symbolic, lower, filtered).is_ok() {
                self.current = true;
                return Ok(());
            }
            self.use_double_precision();
        }
        if let Factor::Double(double) = &mut self.numeric {
            double.factor(&self.symbolic, &self.lower, &self.filtered)?;
        }
        self.current = true;
        Ok(())
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
        self.numeric = Factor::Double(Numeric::new(&self.symbolic, &self.lower));
    }

    /// `z = M⁻¹ r` with the current factor (unfiltered: the caller filters).
    pub fn apply(&mut self, r: &[Vector3<f64>], z: &mut [Vector3<f64>]) {
        match &mut self.numeric {
            Factor::Single(single) => single.apply(&self.symbolic, r, z),
            Factor::Double(double) => double.apply(&self.symbolic, r, z),
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
    /// one per stored slot of the pattern.
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
            self.numeric = Factor::Single(Numeric::new(&self.symbolic, &self.lower));
        }
        (self.current, self.solves, self.stale_failed_at) = (state.current, state.solves, state.stale_failed_at);
        if self.current {
            let (symbolic, lower, filtered) = (&*self.symbolic, &self.lower, &self.filtered);
            match &mut self.numeric {
                Factor::Single(single) => single.factor(symbolic, lower, filtered)?,
                Factor::Double(double) => double.factor(symbolic, lower, filtered)?,
            }
        }
        Ok(())
    }
}

impl Clone for LaggedCholesky {
    fn clone(&self) -> Self {
        let (symbolic, lower) = (&*self.symbolic, &self.lower);
        LaggedCholesky {
            lower: lower.clone(),
            dropped: Arc::clone(&self.dropped),
            filtered: self.filtered.clone(),
            symbolic: Arc::clone(&self.symbolic),
            numeric: match &self.numeric {
                Factor::Single(single) => Factor::Single(single.duplicate(symbolic, lower)),
                Factor::Double(double) => Factor::Double(double.duplicate(symbolic, lower)),
            },
            current: self.current,
            solves: self.solves,
            stale_failed_at: self.stale_failed_at,
        }
    }
}

impl std::fmt::Debug for LaggedCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LaggedCholesky")
            .field("dimension", &self.lower.dimension)
            .field("factor_values", &self.symbolic.len_val())
            .field("single_precision", &self.is_single_precision())
            .field("current", &self.current)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

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
        let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(12)).unwrap();
        assert!(!cholesky.begin_solve(), "no factor yet");
        cholesky.refactor(&pattern, &a, &constraints).unwrap();

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
        cholesky.refactor(&pattern, &a, &constraints).unwrap();
        let double = error(&mut cholesky);
        assert!(double < 1e-12, "double precision: relative error {double:e}");
    }

    /// With the ±2 couplings dropped, the factored matrix `P` is the system
    /// plus a positive semi-definite compensation: `P − A ⪰ 0`, and `P` is
    /// not `A` (something was dropped).
    #[test]
    fn dropped_blocks_leave_a_factor_of_a_larger_matrix() {
        let n = 12;
        let (pattern, a) = ring(n, 11);
        let neighbours: Vec<[u32; 2]> = (0..n as u32).map(|i| [i, (i + 1) % n as u32]).collect();
        let mut cholesky = LaggedCholesky::new(&pattern, &neighbours).unwrap();
        cholesky.use_double_precision();
        let free = vec![Constraint::Free; n];
        cholesky.refactor(&pattern, &a, &free).unwrap();

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
        let excess = (&factored - &system).symmetric_eigenvalues();
        let scale = system.norm();
        assert!(excess.min() > -1e-9 * scale, "P − A has eigenvalue {:e}", excess.min());
        assert!(excess.max() > 1e-3 * scale, "the ±2 couplings were dropped");
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
        let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(6)).unwrap();
        cholesky.begin_solve();
        cholesky.refactor(&pattern, &a, &[Constraint::Free; 6]).unwrap();
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
        let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(6)).unwrap();
        let free = vec![Constraint::Free; 6];
        assert_eq!(cholesky.refactor(&pattern, &a, &free), Err(CholeskyError::NotPositiveDefinite));
        assert!(!cholesky.begin_solve(), "no factor is left to try");
    }
}
