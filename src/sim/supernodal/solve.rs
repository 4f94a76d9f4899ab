//! The factor's triangular solves, `L y = b` up the tree and `Lᵀ x = y`
//! down it, independent subtrees in parallel (see [`super`]).

use super::*;

impl<T: Scalar> SupernodalFactor<T> {
    /// `rhs ← (L Lᵀ)⁻¹ rhs` with the last factor (`rhs` in the tree's order).
    pub fn solve_in_place(&mut self, tree: &SupernodalTree, rhs: &mut [T]) {
        let values = &self.values;
        let all = SolvePart { x: &mut *rhs, scratch: &mut self.scratch, from: 0 };
        forward_forest(tree, &tree.roots, values, all);
        let all = SolvePart { x: rhs, scratch: &mut self.scratch, from: 0 };
        backward_forest(tree, &tree.roots, values, all, None);
    }
}

/// The unknowns and scratch of the supernodes `from..` of a solve.
struct SolvePart<'a, T> {
    x: &'a mut [T],
    scratch: &'a mut [T],
    from: usize,
}

impl<T> SolvePart<'_, T> {
    /// The supernodes before `s` and those from `s` on.
    fn split_at(&mut self, tree: &SupernodalTree, s: usize) -> (SolvePart<'_, T>, SolvePart<'_, T>) {
        let column = tree.begin[s] - tree.begin[self.from];
        let value = tree.value_start[s] - tree.value_start[self.from];
        let (x0, x1) = self.x.split_at_mut(column);
        let (s0, s1) = self.scratch.split_at_mut(value);
        (SolvePart { x: x0, scratch: s0, from: self.from }, SolvePart { x: x1, scratch: s1, from: s })
    }

    /// The supernodes `from..to`.
    fn range(&mut self, tree: &SupernodalTree, from: usize, to: usize) -> SolvePart<'_, T> {
        let (column, value) = (tree.begin[self.from], tree.value_start[self.from]);
        SolvePart {
            x: &mut self.x[tree.begin[from] - column..tree.begin[to] - column],
            scratch: &mut self.scratch[tree.value_start[from] - value..tree.value_start[to] - value],
            from,
        }
    }
}

/// Values of the factor under the subtrees of `roots`.
fn forest_values(tree: &SupernodalTree, roots: &[u32]) -> usize {
    roots.iter().map(|&r| tree.value_start[r as usize + 1] - tree.value_start[tree.first[r as usize]]).sum()
}

/// Solves `L y = b` in the subtrees under `roots` (consecutive siblings):
/// `part.x` holds `b` on entry, `y` on return, and each supernode's scratch
/// the product of its rows below with its `y`.
fn forward_forest<T: Scalar>(tree: &SupernodalTree, roots: &[u32], values: &[T], mut part: SolvePart<'_, T>) {
    if roots.len() > 1 && forest_values(tree, roots) > PARALLEL_SOLVE_VALUES {
        let (left, right) = roots.split_at(roots.len() / 2);
        let (a, b) = part.split_at(tree, tree.first[right[0] as usize]);
        rayon::join(|| forward_forest(tree, left, values, a), || forward_forest(tree, right, values, b));
        return;
    }
    for &root in roots {
        let root = root as usize;
        forward_subtree(tree, root, values, part.range(tree, tree.first[root], root + 1));
    }
}

fn forward_subtree<T: Scalar>(tree: &SupernodalTree, root: usize, values: &[T], mut part: SolvePart<'_, T>) {
    if forest_values(tree, &[root as u32]) <= PARALLEL_SOLVE_VALUES {
        for s in tree.first[root]..=root {
            let (below, mut own) = part.split_at(tree, s);
            forward_supernode(tree, s, values, own.range(tree, s, s + 1), &below);
        }
        return;
    }
    let (mut below, own) = part.split_at(tree, root);
    forward_forest(tree, tree.children_of(root), values, below.range(tree, tree.first[root], root));
    forward_supernode(tree, root, values, own, &below);
}

/// `y_s = L_ss⁻¹ (b_s − Σ descendants' products)`, then its own product.
fn forward_supernode<T: Scalar>(
    tree: &SupernodalTree,
    s: usize,
    values: &[T],
    own: SolvePart<'_, T>,
    below: &SolvePart<'_, T>,
) {
    let (columns, rows) = (tree.columns(s), tree.rows(s));
    let SolvePart { x, scratch, .. } = own;
    let below_start = tree.value_start[below.from];
    for update in &tree.updates[tree.update_start[s]..tree.update_start[s + 1]] {
        let d = update.source as usize;
        let first = update.first_row as usize;
        let product = &below.scratch[tree.value_start[d] - below_start + first..][..update.columns as usize];
        let local = &tree.local[update.local_start as usize..][..update.columns as usize];
        for (&row, &p) in local.iter().zip(product) {
            x[row as usize] -= p;
        }
    }
    let l = MatRef::from_column_major_slice(&values[tree.value_start[s]..tree.value_start[s + 1]], rows, columns);
    let (top, bottom) = l.split_at_row(columns);
    solve_lower_triangular_in_place(top, MatMut::from_column_major_slice_mut(&mut *x, columns, 1), Par::Seq);
    let below_rows = rows - columns;
    matmul(
        MatMut::from_column_major_slice_mut(&mut scratch[..below_rows], below_rows, 1),
        Accum::Replace,
        bottom,
        MatRef::from_column_major_slice(&*x, columns, 1),
        T::from_f64_impl(1.0),
        Par::Seq,
    );
}

/// The solved unknowns of a subtree's ancestors: the columns from `start`
/// in `x`, then those further up.
struct Ancestors<'a, T> {
    start: usize,
    x: &'a [T],
    up: Option<&'a Ancestors<'a, T>>,
}

/// Solves `Lᵀ x = y` in the subtrees under `roots`, whose ancestors'
/// unknowns are solved in `above`: `part.x` holds `y` on entry, `x` on
/// return.
fn backward_forest<T: Scalar>(
    tree: &SupernodalTree,
    roots: &[u32],
    values: &[T],
    mut part: SolvePart<'_, T>,
    above: Option<&Ancestors<'_, T>>,
) {
    if roots.len() > 1 && forest_values(tree, roots) > PARALLEL_SOLVE_VALUES {
        let (left, right) = roots.split_at(roots.len() / 2);
        let (a, b) = part.split_at(tree, tree.first[right[0] as usize]);
        rayon::join(
            || backward_forest(tree, left, values, a, above),
            || backward_forest(tree, right, values, b, above),
        );
        return;
    }
    for &root in roots {
        let root = root as usize;
        backward_subtree(tree, root, values, part.range(tree, tree.first[root], root + 1), above);
    }
}

fn backward_subtree<T: Scalar>(
    tree: &SupernodalTree,
    root: usize,
    values: &[T],
    mut part: SolvePart<'_, T>,
    above: Option<&Ancestors<'_, T>>,
) {
    if forest_values(tree, &[root as u32]) <= PARALLEL_SOLVE_VALUES {
        // In reverse index order: ancestors first.
        for s in (tree.first[root]..=root).rev() {
            let (mut lower, upper) = part.split_at(tree, s + 1);
            let within = Ancestors { start: tree.begin[s + 1], x: &*upper.x, up: above };
            backward_supernode(tree, s, values, lower.range(tree, s, s + 1), &within);
        }
        return;
    }
    let (mut below, mut own) = part.split_at(tree, root);
    let ancestors = Ancestors { start: tree.begin[root + 1], x: &[], up: above };
    backward_supernode(tree, root, values, own.range(tree, root, root + 1), &ancestors);
    let link = Ancestors { start: tree.begin[root], x: &*own.x, up: above };
    backward_forest(tree, tree.children_of(root), values, below.range(tree, tree.first[root], root), Some(&link));
}

/// `x_s = L_ssᵀ⁻¹ (y_s − L_belowᵀ x_ancestors)`.
fn backward_supernode<T: Scalar>(
    tree: &SupernodalTree,
    s: usize,
    values: &[T],
    own: SolvePart<'_, T>,
    above: &Ancestors<'_, T>,
) {
    let (columns, rows) = (tree.columns(s), tree.rows(s));
    let SolvePart { x, scratch, .. } = own;
    let pattern = tree.pattern_of(s);
    let gathered = &mut scratch[..pattern.len()];
    let mut segment = above;
    for (g, &row) in gathered.iter_mut().zip(pattern) {
        let row = row as usize;
        while row >= segment.start + segment.x.len() {
            segment = segment.up.expect("every pattern row is an ancestor's column");
        }
        *g = segment.x[row - segment.start];
    }
    let l = MatRef::from_column_major_slice(&values[tree.value_start[s]..tree.value_start[s + 1]], rows, columns);
    let (top, bottom) = l.split_at_row(columns);
    let minus_one = T::from_f64_impl(-1.0);
    matmul(
        MatMut::from_column_major_slice_mut(&mut *x, columns, 1),
        Accum::Add,
        bottom.transpose(),
        MatRef::from_column_major_slice(&*gathered, pattern.len(), 1),
        minus_one,
        Par::Seq,
    );
    solve_upper_triangular_in_place(top.transpose(), MatMut::from_column_major_slice_mut(x, columns, 1), Par::Seq);
}
