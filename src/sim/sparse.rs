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

    /// `y = A x` for block values `a`, parallel over rows.
    pub fn multiply(&self, a: &[Matrix3<f64>], x: &[Vector3<f64>], y: &mut [Vector3<f64>]) {
        for_each_indexed(y, |i, yi| *yi = self.row_product(a, x, i));
    }

    /// `(A x)_i`, row `i` of the product, for block values `a`.
    pub fn row_product(&self, a: &[Matrix3<f64>], x: &[Vector3<f64>], i: usize) -> Vector3<f64> {
        self.row(i).map(|s| a[s] * x[self.column(s)]).sum()
    }

    /// `((A x)_i, (A y)_i)`: [`Self::row_product`] of two vectors, reading
    /// the row's blocks once, each sum in the same order.
    pub fn row_products(
        &self,
        a: &[Matrix3<f64>],
        (x, y): (&[Vector3<f64>], &[Vector3<f64>]),
        i: usize,
    ) -> (Vector3<f64>, Vector3<f64>) {
        self.row(i).fold((Vector3::zeros(), Vector3::zeros()), |(ax, ay), s| {
            let (block, j) = (&a[s], self.column(s));
            (ax + block * x[j], ay + block * y[j])
        })
    }

    /// `Σⱼ q_ij x_j` for row `i` of a matrix whose blocks are `q_ij · I`.
    pub fn scalar_row_product(&self, q: &[f64], i: usize, x: &[Vector3<f64>]) -> Vector3<f64> {
        self.row(i).map(|s| x[self.column(s)] * q[s]).sum()
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

    #[test]
    fn multiply_matches_dense_product() {
        let p = BlockPattern::new(3, [[0, 1], [1, 2]]);
        let a: Vec<Matrix3<f64>> =
            (0..p.stored_blocks()).map(|s| Matrix3::from_fn(|r, c| (s * 9 + r * 3 + c) as f64 * 0.1)).collect();
        let x = vec![Vector3::new(1.0, 2.0, 3.0), Vector3::new(-1.0, 0.5, 0.0), Vector3::new(0.0, 0.0, 2.0)];
        let mut y = vec![Vector3::zeros(); 3];
        p.multiply(&a, &x, &mut y);
        let mut dense = nalgebra::DMatrix::<f64>::zeros(9, 9);
        for i in 0..3 {
            for s in p.row(i) {
                dense.view_mut((3 * i, 3 * p.column(s)), (3, 3)).copy_from(&a[s]);
            }
        }
        let flat = nalgebra::DVector::from_iterator(9, x.iter().flat_map(|v| v.iter().copied()));
        let expected = dense * flat;
        for (i, yi) in y.iter().enumerate() {
            assert!((yi - expected.fixed_rows::<3>(3 * i)).norm() < 1e-12);
        }
    }

    #[test]
    fn row_products_are_each_row_product_to_the_bit() {
        let p = BlockPattern::new(4, [[0, 1], [1, 2], [2, 3], [0, 3]]);
        let a: Vec<Matrix3<f64>> =
            (0..p.stored_blocks()).map(|s| Matrix3::from_fn(|r, c| ((s * 9 + r * 3 + c) as f64).sin())).collect();
        let x: Vec<Vector3<f64>> = (0..4).map(|i| Vector3::new(0.1, -0.7, 1.3) * (i as f64 + 0.3).cos()).collect();
        let y: Vec<Vector3<f64>> = (0..4).map(|i| Vector3::new(2.9, 0.01, -5.0) * (i as f64).exp()).collect();
        for i in 0..4 {
            let (ax, ay) = p.row_products(&a, (&x, &y), i);
            assert_eq!(ax.map(f64::to_bits), p.row_product(&a, &x, i).map(f64::to_bits));
            assert_eq!(ay.map(f64::to_bits), p.row_product(&a, &y, i).map(f64::to_bits));
        }
    }
}
