//! Symmetric block-sparse matrices with 3×3 blocks, stored by rows (both
//! triangles), with a fixed pattern built once from the cloth's topology.

use std::ops::Range;

use super::parallel::for_each_indexed;
use nalgebra::{Matrix3, Vector3};

/// Which blocks of an `n × n` block matrix may be non-zero, in compressed rows
/// with sorted columns. Every diagonal block is present.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockPattern {
    row_start: Vec<usize>,
    columns: Vec<u32>,
    diagonal: Vec<usize>,
}

impl BlockPattern {
    /// Pattern of an `n`-row matrix coupling each pair in `pairs` both ways.
    pub fn new(n: usize, pairs: impl IntoIterator<Item = [u32; 2]>) -> Self {
        let mut entries: Vec<(u32, u32)> = (0..n as u32).map(|i| (i, i)).collect();
        for [a, b] in pairs {
            entries.push((a, b));
            entries.push((b, a));
        }
        entries.sort_unstable();
        entries.dedup();
        let mut row_start = vec![0; n + 1];
        for &(row, _) in &entries {
            row_start[row as usize + 1] += 1;
        }
        for i in 0..n {
            row_start[i + 1] += row_start[i];
        }
        let columns: Vec<u32> = entries.iter().map(|&(_, c)| c).collect();
        let diagonal = (0..n)
            .map(|i| row_start[i] + columns[row_start[i]..row_start[i + 1]].partition_point(|&c| c < i as u32))
            .collect();
        BlockPattern { row_start, columns, diagonal }
    }

    /// Number of block rows.
    pub fn rows(&self) -> usize {
        self.diagonal.len()
    }

    /// Number of stored blocks.
    pub fn stored_blocks(&self) -> usize {
        self.columns.len()
    }

    /// Slots of row `i`.
    pub fn row(&self, i: usize) -> Range<usize> {
        self.row_start[i]..self.row_start[i + 1]
    }

    /// Column of slot `s`.
    pub fn column(&self, s: usize) -> usize {
        self.columns[s] as usize
    }

    /// Slot of the diagonal block of row `i`.
    pub fn diagonal(&self, i: usize) -> usize {
        self.diagonal[i]
    }

    /// Slot of block `(row, col)`, if stored.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let range = self.row(row);
        let cols = &self.columns[range.clone()];
        cols.binary_search(&(col as u32)).ok().map(|k| range.start + k)
    }

    /// `Σⱼ q_ij x_j` for row `i` of a matrix whose blocks are `q_ij · I`.
    pub fn scalar_row_product(&self, q: &[f64], i: usize, x: &[Vector3<f64>]) -> Vector3<f64> {
        self.row(i).map(|s| x[self.column(s)] * q[s]).sum()
    }
}

/// The pattern of a system matrix whose blocks are of two kinds: full 3×3
/// blocks (`blocks`: the diagonal and the pairs a spring joins) and multiples
/// of the identity, `cᵢ w_s I`, for the other pairs of `all` (those only a
/// bending hinge couples): a weight `w_s` fixed with the pattern and a scale
/// `cᵢ` per row. Such a block is one number to assemble, filter and multiply
/// instead of nine; on a grid cloth they are 12 of a row's 21 blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemPattern {
    /// Every coupled pair: the pattern of the whole matrix.
    pub all: BlockPattern,
    /// The pairs with a full 3×3 block, every diagonal among them.
    pub blocks: BlockPattern,
    /// For each slot of `all`: its slot in `blocks`, or [`ISOTROPIC`] plus
    /// its index in `isotropic_weights`.
    value_of_slot: Vec<u32>,
    /// The weight `w_s` of each isotropic slot, in slot order.
    isotropic_weights: Vec<f64>,
}

/// Marks a slot of a [`SystemPattern`] whose block is a multiple of the identity.
const ISOTROPIC: u32 = 1 << 31;

/// Where the value of a slot of a [`SystemPattern`] is kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SlotValue {
    /// A full block: its slot in the `blocks` pattern.
    Block(usize),
    /// A multiple of the identity, `cᵢ w I`, with this weight `w`.
    Isotropic(f64),
}

impl SystemPattern {
    /// The pattern of `all` whose `block_pairs` (and diagonal) hold full
    /// blocks, the other slots of `all` the multiple `weight_of(slot)` of
    /// their row's scale.
    pub fn new(all: BlockPattern, block_pairs: &[[u32; 2]], weight_of: impl Fn(usize) -> f64) -> Self {
        let blocks = BlockPattern::new(all.rows(), block_pairs.iter().copied());
        let (mut value_of_slot, mut isotropic_weights) = (Vec::with_capacity(all.stored_blocks()), Vec::new());
        for row in 0..all.rows() {
            for slot in all.row(row) {
                match blocks.slot(row, all.column(slot)) {
                    Some(block) => value_of_slot.push(block as u32),
                    None => {
                        value_of_slot.push(ISOTROPIC + isotropic_weights.len() as u32);
                        isotropic_weights.push(weight_of(slot));
                    }
                }
            }
        }
        SystemPattern { all, blocks, value_of_slot, isotropic_weights }
    }

    /// The pattern of a matrix of full blocks only.
    pub fn blocks_only(pattern: BlockPattern) -> Self {
        let value_of_slot = (0..pattern.stored_blocks() as u32).collect();
        SystemPattern { blocks: pattern.clone(), all: pattern, value_of_slot, isotropic_weights: Vec::new() }
    }

    /// Where the value of slot `slot` of `all` is kept.
    #[inline(always)]
    pub fn value_of(&self, slot: usize) -> SlotValue {
        match self.value_of_slot[slot] {
            v if v >= ISOTROPIC => SlotValue::Isotropic(self.isotropic_weights[(v - ISOTROPIC) as usize]),
            v => SlotValue::Block(v as usize),
        }
    }
}

/// The values of a matrix on a [`SystemPattern`].
#[derive(Clone, Copy, Debug)]
pub struct SystemMatrix<'a> {
    /// The pattern.
    pub pattern: &'a SystemPattern,
    /// The full blocks, one per slot of `pattern.blocks`.
    pub blocks: &'a [Matrix3<f64>],
    /// Each row's scale `cᵢ` of its isotropic blocks (empty if there are none).
    pub isotropic_scale: &'a [f64],
}

impl SystemMatrix<'_> {
    /// The block of slot `slot` of `pattern.all`, in row `row`.
    pub fn block(&self, row: usize, slot: usize) -> Matrix3<f64> {
        match self.pattern.value_of(slot) {
            SlotValue::Block(b) => self.blocks[b],
            SlotValue::Isotropic(w) => Matrix3::identity() * (self.isotropic_scale[row] * w),
        }
    }

    /// Every block of `pattern.all`, in slot order, into `out`.
    pub fn all_blocks(&self, out: &mut Vec<Matrix3<f64>>) {
        let all = &self.pattern.all;
        out.clear();
        out.extend((0..all.rows()).flat_map(|i| all.row(i).map(move |s| self.block(i, s))));
    }

    /// The diagonal block of row `i`.
    pub fn diagonal(&self, i: usize) -> &Matrix3<f64> {
        &self.blocks[self.pattern.blocks.diagonal(i)]
    }

    /// `(A x)_i`, row `i` of the product, summed over `all`'s slots in order.
    pub fn row_product(&self, x: &[Vector3<f64>], i: usize) -> Vector3<f64> {
        let pattern = &self.pattern.all;
        pattern.row(i).fold(Vector3::zeros(), |ax, s| ax + self.term(i, s, &x[pattern.column(s)]))
    }

    /// `((A x)_i, (A y)_i)`: [`Self::row_product`] of two vectors, reading
    /// the row's blocks once, each sum in the same order.
    pub fn row_products(&self, (x, y): (&[Vector3<f64>], &[Vector3<f64>]), i: usize) -> (Vector3<f64>, Vector3<f64>) {
        let pattern = &self.pattern.all;
        pattern.row(i).fold((Vector3::zeros(), Vector3::zeros()), |(ax, ay), s| {
            let j = pattern.column(s);
            (ax + self.term(i, s, &x[j]), ay + self.term(i, s, &y[j]))
        })
    }

    /// `y = A x`, parallel over rows.
    pub fn multiply(&self, x: &[Vector3<f64>], y: &mut [Vector3<f64>]) {
        for_each_indexed(y, |i, yi| *yi = self.row_product(x, i));
    }

    /// The product of slot `s` of row `i` with `x`: a multiple of the
    /// identity times `x` is `c x` to the bit.
    #[inline(always)]
    fn term(&self, i: usize, s: usize, x: &Vector3<f64>) -> Vector3<f64> {
        match self.pattern.value_of(s) {
            SlotValue::Block(b) => self.blocks[b] * x,
            SlotValue::Isotropic(w) => x * (self.isotropic_scale[i] * w),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_is_symmetric_sorted_and_has_every_diagonal() {
        let p = BlockPattern::new(4, [[0, 2], [2, 3], [2, 0]]);
        assert_eq!(p.stored_blocks(), 4 + 4);
        assert_eq!(p.slot(0, 2), Some(1));
        assert_eq!(p.slot(2, 0), Some(p.row(2).start));
        assert_eq!(p.slot(1, 3), None);
        for i in 0..4 {
            assert_eq!(p.column(p.diagonal(i)), i);
        }
    }

    /// A pattern of 5 particles whose pairs `[0, 1], [1, 2], [2, 3], [3, 4]`
    /// have full blocks and `[0, 2], [1, 3], [2, 4]` isotropic ones, with
    /// blocks of arbitrary values and row scales.
    fn split_system() -> (SystemPattern, Vec<Matrix3<f64>>, Vec<f64>) {
        let springs = [[0, 1], [1, 2], [2, 3], [3, 4]];
        let all = BlockPattern::new(5, springs.iter().copied().chain([[0, 2], [1, 3], [2, 4]]));
        let pattern = SystemPattern::new(all, &springs, |slot| (slot as f64 * 0.7).cos());
        let blocks = (0..pattern.blocks.stored_blocks())
            .map(|s| Matrix3::from_fn(|r, c| ((s * 9 + r * 3 + c) as f64).sin()))
            .collect();
        (pattern, blocks, vec![1.5, -0.25, 2.0, 0.125, 3.0])
    }

    #[test]
    fn full_blocks_are_the_springs_and_the_diagonal() {
        let (pattern, _, _) = split_system();
        assert_eq!((pattern.all.stored_blocks(), pattern.blocks.stored_blocks()), (5 + 14, 5 + 8));
        for i in 0..5 {
            for s in pattern.all.row(i) {
                let j = pattern.all.column(s);
                let expected = if i.abs_diff(j) <= 1 {
                    SlotValue::Block(pattern.blocks.slot(i, j).unwrap())
                } else {
                    SlotValue::Isotropic((s as f64 * 0.7).cos())
                };
                assert_eq!(pattern.value_of(s), expected, "({i}, {j})");
            }
        }
    }

    /// The product reads each isotropic block as `c w I` and sums a row in
    /// the slots' order: it is, to the bit, the product of the same matrix
    /// stored as full blocks.
    #[test]
    fn products_are_those_of_the_whole_matrix_to_the_bit() {
        let (pattern, blocks, scale) = split_system();
        let split = SystemMatrix { pattern: &pattern, blocks: &blocks, isotropic_scale: &scale };
        let mut whole_blocks = Vec::new();
        split.all_blocks(&mut whole_blocks);
        let whole_pattern = SystemPattern::blocks_only(pattern.all.clone());
        let whole = SystemMatrix { pattern: &whole_pattern, blocks: &whole_blocks, isotropic_scale: &[] };
        let slot = pattern.all.slot(0, 2).unwrap();
        assert_eq!(whole.block(0, slot), Matrix3::identity() * (1.5 * (slot as f64 * 0.7).cos()));
        let x: Vec<Vector3<f64>> = (0..5).map(|i| Vector3::new(0.1, -0.7, 1.3) * (i as f64 + 0.3).cos()).collect();
        let y: Vec<Vector3<f64>> = (0..5).map(|i| Vector3::new(2.9, 0.01, -5.0) * (i as f64).exp()).collect();
        let bits = |v: Vector3<f64>| v.map(f64::to_bits);
        let mut product = vec![Vector3::zeros(); 5];
        split.multiply(&x, &mut product);
        for (i, row) in product.iter().enumerate() {
            let (ax, ay) = split.row_products((&x, &y), i);
            assert_eq!(bits(ax), bits(whole.row_product(&x, i)));
            assert_eq!(bits(ay), bits(whole.row_product(&y, i)));
            assert_eq!(bits(*row), bits(ax));
        }
    }

    #[test]
    fn multiply_matches_dense_product() {
        let (pattern, blocks, scale) = split_system();
        let matrix = SystemMatrix { pattern: &pattern, blocks: &blocks, isotropic_scale: &scale };
        let x: Vec<Vector3<f64>> = (0..5).map(|i| Vector3::new(1.0, 2.0 - i as f64, 0.5 * i as f64)).collect();
        let mut y = vec![Vector3::zeros(); 5];
        matrix.multiply(&x, &mut y);
        let mut dense = nalgebra::DMatrix::<f64>::zeros(15, 15);
        for i in 0..5 {
            for s in pattern.all.row(i) {
                dense.view_mut((3 * i, 3 * pattern.all.column(s)), (3, 3)).copy_from(&matrix.block(i, s));
            }
        }
        let flat = nalgebra::DVector::from_iterator(15, x.iter().flat_map(|v| v.iter().copied()));
        let expected = dense * flat;
        for (i, yi) in y.iter().enumerate() {
            assert!((yi - expected.fixed_rows::<3>(3 * i)).norm() < 1e-12);
        }
    }
}
