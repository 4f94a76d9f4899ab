//! The numbers of a supernodal Cholesky factor `L Lᵀ`, factored and solved
//! subtree by subtree, independent subtrees in parallel.
//!
//! faer analyses the matrix (supernodes, their rows) and supplies the dense
//! kernels; this module runs the supernodes. faer's own supernodal factor
//! runs them one after the other, on one core, while a cloth's factor under
//! a nested-dissection order ([`super::dissection`]) is a balanced tree:
//! the supernodes under one separator never read each other, so the two
//! halves of each separator are factored at once, and so on down to
//! subtrees too small to be worth a task. Each supernode is computed by the
//! same arithmetic in the same order whichever thread runs it, so the factor
//! and its solves are the same to the bit at any thread count.
//!
//! A supernode `s` holds columns `begin[s]..begin[s + 1]`: a dense block of
//! `rows × columns` values, column-major, whose first `columns` rows are the
//! diagonal block and the others the rows of its pattern (ancestors'
//! columns). It is factored left-looking: the matrix's entries, minus the
//! products of every descendant `d` whose pattern meets its columns (an
//! *update*), then a dense `L Lᵀ` of the diagonal block and a triangular
//! solve of the rows below. The solves pull in the same way: going up, a
//! supernode subtracts the products its descendants left in their scratch;
//! going down, it gathers the values of its ancestors along the chain of
//! slices that holds them.

mod solve;

use std::mem::MaybeUninit;

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::traits::{ComplexField, RealField};
use faer::{Accum, MatMut, MatRef, Par};

/// A subtree of the factor is split into parallel tasks only above this many
/// floating-point operations (about 20 µs here): below, a task costs more than
/// it saves.
const PARALLEL_FACTOR_FLOPS: f64 = 4e5;

/// A subtree of a solve is split into parallel tasks only above this many
/// stored values of the factor.
const PARALLEL_SOLVE_VALUES: usize = 40_000;

/// A floating-point type a factor is kept in (`f32` or `f64`).
pub trait Scalar: RealField + ComplexField<Real = Self> + Copy + Send + Sync + std::ops::SubAssign {}

impl<T> Scalar for T where T: RealField + ComplexField<Real = T> + Copy + Send + Sync + std::ops::SubAssign {}

/// The matrix given to [`SupernodalFactor::factor`] is not numerically
/// positive definite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NotPositiveDefinite;

/// A descendant's product into a supernode: rows `first_row..` of the
/// descendant's pattern, of which the first `columns` are the supernode's
/// columns; their places in the supernode are `local[local_start..]`, in
/// `run_count` runs of consecutive places, `runs[run_start..]`.
#[derive(Clone, Copy, Debug)]
struct Update {
    source: u32,
    first_row: u32,
    columns: u32,
    local_start: u32,
    run_start: u32,
    run_count: u32,
}

/// The structure of a supernodal factor and its task tree.
#[derive(Clone, Debug)]
pub struct SupernodalTree {
    /// First column of each supernode, then the dimension.
    begin: Vec<usize>,
    /// Start of each supernode's rows in `pattern`, then their total.
    pattern_start: Vec<usize>,
    /// The rows below each supernode's diagonal block, increasing.
    pattern: Vec<u32>,
    /// Start of each supernode's values, then their total.
    value_start: Vec<usize>,
    /// Start of each supernode's dense-factor scratch bytes, then their total.
    byte_start: Vec<usize>,
    /// First (lowest) supernode of the subtree under each supernode.
    first: Vec<usize>,
    /// Children of each supernode in increasing order, compressed; then the roots.
    child_start: Vec<usize>,
    children: Vec<u32>,
    roots: Vec<u32>,
    /// Floating-point operations of the factor of each supernode's subtree.
    subtree_flops: Vec<f64>,
    /// The updates into each supernode, by increasing source.
    update_start: Vec<usize>,
    updates: Vec<Update>,
    local: Vec<u32>,
    /// Runs of consecutive places in `local`: an update's first place of the
    /// run (counted from its `local_start`) and the run's length. Subtracting a product run by run is a
    /// vector operation, place by place it is not.
    runs: Vec<[u32; 2]>,
    /// For each stored entry of the matrix's lower triangle (compressed
    /// columns, in the order analysed), its place among the factor's values;
    /// the entries of supernode `s`'s columns are `entry_start[s]..entry_start[s + 1]`.
    entry_place: Vec<u32>,
    entry_start: Vec<usize>,
}

/// Why a [`SupernodalTree`] cannot be made from an analysis.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TreeError {
    /// A subtree's supernodes are not contiguous: the order analysed is not a
    /// postorder of its elimination tree.
    #[error("the order is not a postorder of its elimination tree (supernode {0})")]
    NotPostordered(usize),
}

impl SupernodalTree {
    /// The tree of `symbolic`, a supernodal analysis of the lower triangle
    /// whose compressed columns are `column_start` and `row_index`.
    pub fn new<I: faer::Index>(
        symbolic: &SymbolicSupernodalCholesky<I>,
        column_start: &[u32],
        row_index: &[u32],
    ) -> Result<Self, TreeError> {
        let count = symbolic.n_supernodes();
        let mut begin: Vec<usize> = symbolic.supernode_begin().iter().map(|b| b.zx()).collect();
        begin.push(symbolic.nrows());
        let pattern_start: Vec<usize> = symbolic.col_ptr_for_row_idx().iter().map(|p| p.zx()).collect();
        let pattern: Vec<u32> = symbolic.row_idx().iter().map(|r| r.zx() as u32).collect();
        let value_start: Vec<usize> = symbolic.col_ptr_for_val().iter().map(|p| p.zx()).collect();
        let mut tree = SupernodalTree {
            begin,
            pattern_start,
            pattern,
            value_start,
            byte_start: Vec::new(),
            first: Vec::new(),
            child_start: Vec::new(),
            children: Vec::new(),
            roots: Vec::new(),
            subtree_flops: Vec::new(),
            update_start: Vec::new(),
            updates: Vec::new(),
            local: Vec::new(),
            runs: Vec::new(),
            entry_place: Vec::new(),
            entry_start: Vec::new(),
        };
        tree.link_subtrees(count)?;
        tree.find_updates(count);
        tree.place_entries(count, column_start, row_index);
        Ok(tree)
    }

    /// Number of supernodes.
    fn count(&self) -> usize {
        self.begin.len() - 1
    }

    /// Columns of supernode `s`.
    fn columns(&self, s: usize) -> usize {
        self.begin[s + 1] - self.begin[s]
    }

    /// The rows below supernode `s`'s diagonal block.
    fn pattern_of(&self, s: usize) -> &[u32] {
        &self.pattern[self.pattern_start[s]..self.pattern_start[s + 1]]
    }

    /// The supernode holding `column`.
    fn supernode_of(&self, column: u32) -> usize {
        self.begin.partition_point(|&b| b <= column as usize) - 1
    }

    /// Whether the factor stores entry (`row`, `column`), `row ≥ column`.
    pub fn stores(&self, row: u32, column: u32) -> bool {
        let s = self.supernode_of(column);
        (row as usize) < self.begin[s + 1] || self.pattern_of(s).binary_search(&row).is_ok()
    }

    /// Rows (diagonal block and below) of supernode `s`.
    fn rows(&self, s: usize) -> usize {
        self.columns(s) + self.pattern_of(s).len()
    }

    fn children_of(&self, s: usize) -> &[u32] {
        &self.children[self.child_start[s]..self.child_start[s + 1]]
    }

    /// Total number of values of the factor.
    pub fn value_count(&self) -> usize {
        self.value_start[self.count()]
    }

    /// The floating-point operations of a factor along the tree's costliest
    /// chain of supernodes from a leaf to a root (what no number of cores
    /// can run at once), and in all.
    #[cfg(test)]
    pub(crate) fn critical_path_flops(&self) -> (f64, f64) {
        let mut chain = vec![0.0f64; self.count()];
        for s in 0..self.count() {
            let own = supernode_flops(self.columns(s), self.pattern_of(s).len());
            chain[s] = own + self.children_of(s).iter().map(|&c| chain[c as usize]).fold(0.0, f64::max);
        }
        let longest = self.roots.iter().map(|&r| chain[r as usize]).fold(0.0, f64::max);
        (longest, self.roots.iter().map(|&r| self.subtree_flops[r as usize]).sum())
    }

    /// Parents, children, subtree ranges and work; checks every subtree is
    /// contiguous.
    fn link_subtrees(&mut self, count: usize) -> Result<(), TreeError> {
        let parent: Vec<Option<usize>> =
            (0..count).map(|s| self.pattern_of(s).first().map(|&r| self.supernode_of(r))).collect();
        let mut first: Vec<usize> = (0..count).collect();
        let mut size = vec![1usize; count];
        let mut flops: Vec<f64> =
            (0..count).map(|s| supernode_flops(self.columns(s), self.pattern_of(s).len())).collect();
        let mut child_count = vec![0usize; count];
        for s in 0..count {
            if let Some(p) = parent[s] {
                first[p] = first[p].min(first[s]);
                size[p] += size[s];
                flops[p] += flops[s];
                child_count[p] += 1;
            }
        }
        if let Some(s) = (0..count).find(|&s| s + 1 - first[s] != size[s]) {
            return Err(TreeError::NotPostordered(s));
        }
        self.child_start = std::iter::once(0)
            .chain(child_count.iter().scan(0, |total, &c| {
                *total += c;
                Some(*total)
            }))
            .collect();
        let mut next = self.child_start.clone();
        self.children = vec![0; self.child_start[count]];
        for (s, parent) in parent.iter().enumerate() {
            match *parent {
                Some(p) => {
                    self.children[next[p]] = s as u32;
                    next[p] += 1;
                }
                None => self.roots.push(s as u32),
            }
        }
        self.first = first;
        self.subtree_flops = flops;
        Ok(())
    }

    /// Every descendant's update into each supernode, and where its rows land.
    fn find_updates(&mut self, count: usize) {
        let mut into: Vec<Vec<(Update, Vec<u32>)>> = vec![Vec::new(); count];
        for d in 0..count {
            let rows = self.pattern_of(d);
            let mut k = 0;
            while k < rows.len() {
                let s = self.supernode_of(rows[k]);
                let end = rows[k..].partition_point(|&r| (r as usize) < self.begin[s + 1]) + k;
                let target = self.pattern_of(s);
                let mut local = Vec::with_capacity(rows.len() - k);
                local.extend(rows[k..end].iter().map(|&r| r - self.begin[s] as u32));
                // The rows past the supernode's columns are rows of its pattern.
                let mut t = 0;
                for &r in &rows[end..] {
                    while target[t] < r {
                        t += 1;
                    }
                    local.push((self.columns(s) + t) as u32);
                }
                let update = Update {
                    source: d as u32,
                    first_row: k as u32,
                    columns: (end - k) as u32,
                    local_start: 0,
                    run_start: 0,
                    run_count: 0,
                };
                into[s].push((update, local));
                k = end;
            }
        }
        self.update_start = vec![0];
        for list in into {
            for (mut update, local) in list {
                update.local_start = self.local.len() as u32;
                update.run_start = self.runs.len() as u32;
                let mut start = 0;
                for i in 1..=local.len() {
                    if i == local.len() || local[i] != local[i - 1] + 1 {
                        self.runs.push([start as u32, (i - start) as u32]);
                        start = i;
                    }
                }
                update.run_count = self.runs.len() as u32 - update.run_start;
                self.local.extend(local);
                self.updates.push(update);
            }
            self.update_start.push(self.updates.len());
        }
    }

    /// Where each entry of the matrix lands among the factor's values, and
    /// the bytes of each supernode's dense-factor scratch.
    fn place_entries(&mut self, count: usize, column_start: &[u32], row_index: &[u32]) {
        self.entry_place = vec![0; row_index.len()];
        self.entry_start = Vec::with_capacity(count + 1);
        for s in 0..count {
            self.entry_start.push(column_start[self.begin[s]] as usize);
            let (columns, rows) = (self.columns(s), self.rows(s));
            let pattern = &self.pattern[self.pattern_start[s]..self.pattern_start[s + 1]];
            for j in self.begin[s]..self.begin[s + 1] {
                let entries = column_start[j] as usize..column_start[j + 1] as usize;
                for (place, &i) in self.entry_place[entries.clone()].iter_mut().zip(&row_index[entries]) {
                    let i = i as usize;
                    let row = if i < self.begin[s + 1] {
                        i - self.begin[s]
                    } else {
                        columns + pattern.partition_point(|&r| (r as usize) < i)
                    };
                    *place = (self.value_start[s] + (j - self.begin[s]) * rows + row) as u32;
                }
            }
        }
        self.entry_start.push(row_index.len());
        self.byte_start = std::iter::once(0)
            .chain((0..count).scan(0, |total, s| {
                let req = cholesky_in_place_scratch::<f64>(self.columns(s), Par::Seq, Default::default());
                *total += req.unaligned_bytes_required();
                Some(*total)
            }))
            .collect();
    }
}

/// Floating-point operations of factoring a supernode of `columns` columns
/// with `below` rows under its diagonal block (its own part only).
fn supernode_flops(columns: usize, below: usize) -> f64 {
    let (c, r) = (columns as f64, below as f64);
    c * c * c / 3.0 + c * c * r + c * r * r
}

/// The values of a factor of a [`SupernodalTree`] in precision `T`, with the
/// scratch space of its factorisation and solves.
#[derive(Clone)]
pub struct SupernodalFactor<T> {
    values: Vec<T>,
    /// One region per supernode, the size of its values: descendants'
    /// products while factoring, its own product while solving.
    scratch: Vec<T>,
    /// The dense factor's scratch, per supernode.
    bytes: Vec<MaybeUninit<u8>>,
}

impl<T: Scalar> SupernodalFactor<T> {
    /// Space for a factor of `tree`.
    pub fn new(tree: &SupernodalTree) -> Self {
        let zero = T::from_f64_impl(0.0);
        SupernodalFactor {
            values: vec![zero; tree.value_count()],
            scratch: vec![zero; tree.value_count()],
            bytes: vec![MaybeUninit::uninit(); tree.byte_start[tree.count()]],
        }
    }

    /// Factors the matrix whose lower-triangle entry `e` (in the order the
    /// tree was made from) is `entry(e)`.
    pub fn factor(
        &mut self,
        tree: &SupernodalTree,
        entry: impl Fn(usize) -> T + Sync,
    ) -> Result<(), NotPositiveDefinite> {
        let all = FactorPart { values: &mut self.values, scratch: &mut self.scratch, bytes: &mut self.bytes, from: 0 };
        factor_forest(tree, &tree.roots, all, &entry)
    }

    /// The factor's values, supernode by supernode (column-major blocks).
    #[cfg(test)]
    fn values(&self) -> &[T] {
        &self.values
    }
}

/// The values, scratch and bytes of the supernodes `from..` of a factor.
struct FactorPart<'a, T> {
    values: &'a mut [T],
    scratch: &'a mut [T],
    bytes: &'a mut [MaybeUninit<u8>],
    from: usize,
}

impl<T> FactorPart<'_, T> {
    /// The supernodes before `s` and those from `s` on.
    fn split_at(&mut self, tree: &SupernodalTree, s: usize) -> (FactorPart<'_, T>, FactorPart<'_, T>) {
        let (value, byte) =
            (tree.value_start[s] - tree.value_start[self.from], tree.byte_start[s] - tree.byte_start[self.from]);
        let (v0, v1) = self.values.split_at_mut(value);
        let (s0, s1) = self.scratch.split_at_mut(value);
        let (b0, b1) = self.bytes.split_at_mut(byte);
        (
            FactorPart { values: v0, scratch: s0, bytes: b0, from: self.from },
            FactorPart { values: v1, scratch: s1, bytes: b1, from: s },
        )
    }

    /// The supernodes `from..to`.
    fn range(&mut self, tree: &SupernodalTree, from: usize, to: usize) -> FactorPart<'_, T> {
        let value =
            tree.value_start[from] - tree.value_start[self.from]..tree.value_start[to] - tree.value_start[self.from];
        let byte = tree.byte_start[from] - tree.byte_start[self.from]..tree.byte_start[to] - tree.byte_start[self.from];
        FactorPart {
            values: &mut self.values[value.clone()],
            scratch: &mut self.scratch[value],
            bytes: &mut self.bytes[byte],
            from,
        }
    }
}

/// Factors the subtrees under `roots` (consecutive siblings, in order), all
/// of whose supernodes `part` holds.
fn factor_forest<T: Scalar>(
    tree: &SupernodalTree,
    roots: &[u32],
    mut part: FactorPart<'_, T>,
    entry: &(impl Fn(usize) -> T + Sync),
) -> Result<(), NotPositiveDefinite> {
    let flops: f64 = roots.iter().map(|&r| tree.subtree_flops[r as usize]).sum();
    if roots.len() > 1 && flops > PARALLEL_FACTOR_FLOPS {
        let (left, right) = roots.split_at(roots.len() / 2);
        let (a, b) = part.split_at(tree, tree.first[right[0] as usize]);
        let (left, right) =
            rayon::join(|| factor_forest(tree, left, a, entry), || factor_forest(tree, right, b, entry));
        return left.and(right);
    }
    for &root in roots {
        let root = root as usize;
        factor_subtree(tree, root, part.range(tree, tree.first[root], root + 1), entry)?;
    }
    Ok(())
}

/// Factors the subtree under `root`, all of whose supernodes `part` holds.
fn factor_subtree<T: Scalar>(
    tree: &SupernodalTree,
    root: usize,
    mut part: FactorPart<'_, T>,
    entry: &(impl Fn(usize) -> T + Sync),
) -> Result<(), NotPositiveDefinite> {
    if tree.subtree_flops[root] <= PARALLEL_FACTOR_FLOPS {
        // In index order, a postorder.
        for s in tree.first[root]..=root {
            let (below, mut own) = part.split_at(tree, s);
            factor_supernode(tree, s, own.range(tree, s, s + 1), &below, entry)?;
        }
        return Ok(());
    }
    let (mut below, own) = part.split_at(tree, root);
    factor_forest(tree, tree.children_of(root), below.range(tree, tree.first[root], root), entry)?;
    factor_supernode(tree, root, own, &below, entry)
}

/// Factors supernode `s` (`own`), all of whose descendants `below` holds,
/// factored.
fn factor_supernode<T: Scalar>(
    tree: &SupernodalTree,
    s: usize,
    own: FactorPart<'_, T>,
    below: &FactorPart<'_, T>,
    entry: &(impl Fn(usize) -> T + Sync),
) -> Result<(), NotPositiveDefinite> {
    let (columns, rows) = (tree.columns(s), tree.rows(s));
    let FactorPart { values, scratch, bytes, .. } = own;
    values.fill(T::from_f64_impl(0.0));
    for e in tree.entry_start[s]..tree.entry_start[s + 1] {
        values[tree.entry_place[e] as usize - tree.value_start[s]] = entry(e);
    }
    let below_start = tree.value_start[below.from];
    for update in &tree.updates[tree.update_start[s]..tree.update_start[s + 1]] {
        let d = update.source as usize;
        let (d_columns, d_rows) = (tree.columns(d), tree.rows(d));
        let d_values = &below.values[tree.value_start[d] - below_start..tree.value_start[d + 1] - below_start];
        let l = MatRef::from_column_major_slice(d_values, d_rows, d_columns);
        let first = d_columns + update.first_row as usize;
        let (m, c) = (d_rows - first, update.columns as usize);
        let product = &mut scratch[..m * c];
        let one = T::from_f64_impl(1.0);
        matmul(
            MatMut::from_column_major_slice_mut(&mut *product, m, c),
            Accum::Replace,
            l.subrows(first, m),
            l.subrows(first, c).transpose(),
            one,
            Par::Seq,
        );
        let local = &tree.local[update.local_start as usize..][..m];
        let runs = &tree.runs[update.run_start as usize..][..update.run_count as usize];
        for (j, &column) in local[..c].iter().enumerate() {
            let target = &mut values[column as usize * rows..][..rows];
            let product = &product[j * m..(j + 1) * m];
            // The lower triangle: rows from j on.
            for &[start, length] in runs.iter().filter(|&&[start, length]| (start + length) as usize > j) {
                let (from, to) = ((start as usize).max(j), (start + length) as usize);
                let row = local[from] as usize;
                for (t, &p) in target[row..row + to - from].iter_mut().zip(&product[from..to]) {
                    *t -= p;
                }
            }
        }
    }
    let l = MatMut::from_column_major_slice_mut(values, rows, columns);
    let (mut top, bottom) = l.split_at_row_mut(columns);
    cholesky_in_place(top.rb_mut(), Default::default(), Par::Seq, MemStack::new(bytes), Default::default())
        .map_err(|_| NotPositiveDefinite)?;
    solve_lower_triangular_in_place(top.rb(), bottom.transpose_mut(), Par::Seq);
    Ok(())
}

#[cfg(test)]
mod tests;
