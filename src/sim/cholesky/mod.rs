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
//! A factor costs about ten of its own applications, and a kept one seldom
//! survives a step: only while the cloth does not turn (free fall, rest).
//! A stretch spring's block `k u uᵀ` turned by θ moves about `h²k θ` into
//! directions only mass and bending resist, and with `h²k/m ≈ 10⁴` a 0.02 rad
//! turn is 250 times the mass term: a one-step-old factor needs 61-201
//! iterations against 1-2 for a fresh one, even on a cloth hanging without
//! contact (and as many with no tension/compression switch). Contacts that
//! come and go add changes of high rank, one iteration each. So the factor is
//! *lagged* only as a cheap try: a kept factor is tried first on a small
//! iteration budget ([`STALE_BUDGET`]); when that is not enough the factor is rebuilt for the
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

mod dropped;
mod pattern;

use std::sync::Arc;

use faer::Side;
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use nalgebra::{Matrix3, Vector3};

use self::dropped::{DroppedBlocks, dropped_blocks, spectral_norm_bound};
use self::pattern::{
    LowerTriangle, dissection_order, filtered_block, kept_slots, slot_rows, symbolic_tree, without_fill,
};
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

/// Iterations a fresh single-precision factor may take to reach `tolerance`
/// (relative): [`SINGLE_PRECISION_ITERATIONS_PER_DIGIT`] per digit, at least
/// one digit's worth.
pub fn single_precision_allowance(tolerance: f64) -> u32 {
    let digits = if tolerance > 0.0 { (-tolerance.log10()).max(1.0) } else { f64::from(f32::DIGITS) };
    (SINGLE_PRECISION_ITERATIONS_PER_DIGIT * digits).ceil() as u32
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
mod tests;
