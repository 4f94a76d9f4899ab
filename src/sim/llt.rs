//! The numbers of a sparse `L Lᵀ` factor (faer) and its work space, factored
//! and solved on the calling thread: the strain limits' multiplier system
//! ([`super::edge_system`]), a few hundred edges, for which one thread is the
//! fastest, and bit-identical at any thread count. (The springs' system, far
//! larger, is factored by subtrees in parallel: [`super::supernodal`].)

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky};
use faer::traits::{ComplexField, RealField};
use faer::{Conj, MatMut, Par, Side};

/// The matrix given to [`Llt::factor`] is not numerically positive definite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NotPositiveDefinite;

/// A factor's values in precision `T` for one symbolic analysis, with the
/// scratch space of its factorisation and of its solves.
pub struct Llt<T> {
    values: Vec<T>,
    factor_scratch: MemBuffer,
    solve_scratch: MemBuffer,
}

impl<T: RealField + ComplexField<Real = T> + Copy> Llt<T> {
    /// Space for a factor of `symbolic`'s structure.
    pub fn new(symbolic: &SymbolicCholesky<u32>) -> Self {
        Llt {
            values: vec![T::from_f64_impl(0.0); symbolic.len_val()],
            factor_scratch: MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<T>(Par::Seq, Default::default())),
            solve_scratch: MemBuffer::new(symbolic.solve_in_place_scratch::<T>(1, Par::Seq)),
        }
    }

    /// Factors `matrix` (its upper triangle, in the pattern `symbolic` was
    /// analysed from, which faer factors as it is when no ordering was
    /// asked for).
    pub fn factor(
        &mut self,
        symbolic: &SymbolicCholesky<u32>,
        matrix: SparseColMatRef<'_, u32, T>,
    ) -> Result<(), NotPositiveDefinite> {
        symbolic
            .factorize_numeric_llt(
                &mut self.values,
                matrix,
                Side::Upper,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_scratch),
                Default::default(),
            )
            .map(|_| ())
            .map_err(|_| NotPositiveDefinite)
    }

    /// `rhs ← (L Lᵀ)⁻¹ rhs` with the last factor of `symbolic`.
    pub fn solve_in_place(&mut self, symbolic: &SymbolicCholesky<u32>, rhs: &mut [T]) {
        let n = rhs.len();
        LltRef::new(symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.solve_scratch),
        );
    }

    /// A copy of the factor's values, with work space of its own.
    pub fn duplicate(&self, symbolic: &SymbolicCholesky<u32>) -> Self {
        let mut copy = Llt::new(symbolic);
        copy.values.clone_from(&self.values);
        copy
    }
}
