//! The factor's pattern: the lower triangle of the kept blocks under the
//! nested-dissection order, its symbolic analysis, and which hinge blocks
//! the springs' factor stores anyway.

use super::*;

/// The scalar lower triangle of a 3×3-block symmetric matrix in compressed
/// columns, with the map from its entries back to the blocks, in an order of
/// its own: scalar unknown `k` of the triangle is unknown `system[k]`
/// (`3 particle + axis`) of the system.
#[derive(Clone, Debug)]
pub(super) struct LowerTriangle {
    pub(super) dimension: usize,
    column_start: Vec<u32>,
    row_index: Vec<u32>,
    /// Where each entry comes from: entry `(c, r)` of block slot `s` of the
    /// block pattern (row `j`, column `i ≥ j`: the transpose of block
    /// `(i, j)`), as its place `9 s + 3 r + c` among the blocks' values read
    /// as one array of column-major 3×3 blocks. The factor reads every entry
    /// through this one index.
    source: Vec<u32>,
    pub(super) system: Vec<u32>,
}

impl LowerTriangle {
    /// The pattern of the lower triangle of the scalar matrix of the `kept`
    /// slots of `pattern`.
    pub(super) fn new(pattern: &BlockPattern, kept: &[bool]) -> Self {
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
    pub(super) fn reordered(&self, order: &[u32], position: &[u32]) -> Self {
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
    pub(super) fn analysis(&self) -> Result<SymbolicCholesky<u32>, CholeskyError> {
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
    pub(super) fn entry<T: Precision>(&self, filtered: &[f64], e: usize) -> T {
        T::from_f64(filtered[self.source[e] as usize])
    }
}

/// The supernodal tree of `symbolic` (an analysis of a triangle of the same
/// order whose pattern holds `lower`'s), with `lower`'s entries placed in it.
pub(super) fn symbolic_tree(
    symbolic: &SymbolicCholesky<u32>,
    lower: &LowerTriangle,
) -> Result<SupernodalTree, CholeskyError> {
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
pub(super) fn without_fill(
    pattern: &BlockPattern,
    mut kept: Vec<bool>,
    tree: &SupernodalTree,
    position: &[u32],
) -> Vec<bool> {
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
pub(super) fn filtered_block(row: &Constraint, a: &Matrix3<f64>, column: &Constraint, diagonal: bool) -> Matrix3<f64> {
    if *row == Constraint::Free && *column == Constraint::Free {
        return *a;
    }
    let filter_row = row.filter_matrix();
    let block = filter_row * a * column.filter_matrix();
    if diagonal { block + (Matrix3::identity() - filter_row) * (a.trace() / 3.0) } else { block }
}

/// The row of each stored slot of `pattern`.
pub(super) fn slot_rows(pattern: &BlockPattern) -> Vec<u32> {
    (0..pattern.rows()).flat_map(|j| pattern.row(j).map(move |_| j as u32)).collect()
}

/// The scalar unknowns of `particles` particles in the nested-dissection
/// order of their `couplings` at `positions` (each particle's three axes
/// together), and the position of each unknown in that order.
pub(super) fn dissection_order(
    particles: usize,
    couplings: &[[u32; 2]],
    positions: &[Vector3<f64>],
) -> (Vec<u32>, Vec<u32>) {
    let by_particle = nested_dissection(&Adjacency::new(particles, couplings), positions);
    let order: Vec<u32> = by_particle.iter().flat_map(|&p| [3 * p, 3 * p + 1, 3 * p + 2]).collect();
    let mut position = vec![0u32; order.len()];
    for (k, &unknown) in order.iter().enumerate() {
        position[unknown as usize] = k as u32;
    }
    (order, position)
}

/// Slots of `pattern` the factor keeps: the diagonal and the blocks of `couplings`.
pub(super) fn kept_slots(pattern: &BlockPattern, couplings: &[[u32; 2]]) -> Vec<bool> {
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
