//! A nested-dissection order of a cloth's particles, for the sparse
//! Cholesky factor of its springs' system ([`super::cholesky`]).
//!
//! Recursive coordinate bisection: a set of particles is split at the median
//! of its longest extent (rest positions, m). Of the two halves, the particles
//! that touch the other half, on the side where there are fewer of them, form
//! the separator, numbered after both halves, and the halves are ordered the
//! same way down to [`LEAF`] particles. A cloth's springs join only near
//! neighbours, so a plane cuts one row of particles: the factor fills in
//! little, and its elimination tree is balanced, two halves under each
//! separator that factor independently ([`super::supernodal`] runs them in
//! parallel). Approximate minimum degree fills in about as little on a cloth,
//! but its tree is a long chain, most of which factors on one core.
//!
//! The order is then made a postorder of its elimination tree
//! ([`elimination_postorder`]), which the supernodal factor needs: every
//! subtree is then a contiguous range of the order.

use nalgebra::Vector3;

/// Sets of at most this many particles are not split further: their order
/// hardly changes the fill, and smaller supernodes factor slower.
pub const LEAF: usize = 16;

/// The symmetric couplings of a set of particles, in compressed rows.
#[derive(Clone, Debug)]
pub struct Adjacency {
    start: Vec<u32>,
    neighbours: Vec<u32>,
}

impl Adjacency {
    /// The adjacency of `particles` particles joined by `couplings` (each
    /// pair once or more, in any order; a particle's coupling to itself is
    /// ignored).
    pub fn new(particles: usize, couplings: &[[u32; 2]]) -> Self {
        let mut lists = vec![Vec::new(); particles];
        for &[a, b] in couplings.iter().filter(|[a, b]| a != b) {
            lists[a as usize].push(b);
            lists[b as usize].push(a);
        }
        let mut start = Vec::with_capacity(particles + 1);
        let mut neighbours = Vec::new();
        start.push(0);
        for mut list in lists {
            list.sort_unstable();
            list.dedup();
            neighbours.extend(list);
            start.push(neighbours.len() as u32);
        }
        Adjacency { start, neighbours }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The particles coupled to `particle`, in increasing order.
    pub fn of(&self, particle: usize) -> &[u32] {
        &self.neighbours[self.start[particle] as usize..self.start[particle + 1] as usize]
    }
}

/// The nested-dissection order of the particles at `positions` (m) coupled
/// by `adjacency`, postordered along its elimination tree: entry `k` is the
/// particle eliminated `k`-th.
pub fn nested_dissection(adjacency: &Adjacency, positions: &[Vector3<f64>]) -> Vec<u32> {
    let mut order = Vec::with_capacity(adjacency.len());
    let mut side = vec![Side::Outside; adjacency.len()];
    dissect(adjacency, positions, (0..adjacency.len() as u32).collect(), &mut side, &mut order);
    elimination_postorder(adjacency, &order)
}

/// Where a particle stands in the bisection under way.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    Outside,
    Lower,
    Upper,
    Separator,
}

/// Appends the order of `set` to `order`. `side` is all `Outside` on entry
/// and on return.
fn dissect(
    adjacency: &Adjacency,
    positions: &[Vector3<f64>],
    mut set: Vec<u32>,
    side: &mut [Side],
    order: &mut Vec<u32>,
) {
    if set.len() <= LEAF {
        order.extend(set);
        return;
    }
    let axis = longest_axis(positions, &set);
    set.sort_unstable_by(|&a, &b| positions[a as usize][axis].total_cmp(&positions[b as usize][axis]).then(a.cmp(&b)));
    let half = set.len() / 2;
    for (k, &p) in set.iter().enumerate() {
        side[p as usize] = if k < half { Side::Lower } else { Side::Upper };
    }
    let touching = |from: Side, to: Side, side: &[Side]| -> Vec<u32> {
        let on = set.iter().copied().filter(|&p| side[p as usize] == from);
        on.filter(|&p| adjacency.of(p as usize).iter().any(|&q| side[q as usize] == to)).collect()
    };
    let (lower, upper) = (touching(Side::Lower, Side::Upper, side), touching(Side::Upper, Side::Lower, side));
    let separator = if lower.len() <= upper.len() { lower } else { upper };
    for &p in &separator {
        side[p as usize] = Side::Separator;
    }
    let of_side = |wanted: Side, side: &[Side]| -> Vec<u32> {
        set.iter().copied().filter(|&p| side[p as usize] == wanted).collect()
    };
    let (lower, upper) = (of_side(Side::Lower, side), of_side(Side::Upper, side));
    for &p in &set {
        side[p as usize] = Side::Outside;
    }
    dissect(adjacency, positions, lower, side, order);
    dissect(adjacency, positions, upper, side, order);
    order.extend(separator);
}

/// The axis (0, 1, 2) along which the particles of `set` spread the most.
fn longest_axis(positions: &[Vector3<f64>], set: &[u32]) -> usize {
    let first = positions[set[0] as usize];
    let (lower, upper) = set.iter().fold((first, first), |(lo, hi), &p| {
        let x = positions[p as usize];
        (lo.inf(&x), hi.sup(&x))
    });
    (upper - lower).imax()
}

/// `order` made a postorder of its elimination tree (Liu's algorithm, on the
/// particles: each particle's three unknowns form a chain): a particle's
/// descendants come right before it. Eliminating in this order fills in
/// exactly as `order` does.
pub fn elimination_postorder(adjacency: &Adjacency, order: &[u32]) -> Vec<u32> {
    const NONE: u32 = u32::MAX;
    let n = order.len();
    let mut position = vec![0u32; n];
    for (k, &p) in order.iter().enumerate() {
        position[p as usize] = k as u32;
    }
    let (mut parent, mut ancestor) = (vec![NONE; n], vec![NONE; n]);
    for (k, &p) in order.iter().enumerate() {
        let k = k as u32;
        for &q in adjacency.of(p as usize) {
            let mut i = position[q as usize];
            if i >= k {
                continue;
            }
            while ancestor[i as usize] != NONE && ancestor[i as usize] != k {
                let next = ancestor[i as usize];
                ancestor[i as usize] = k;
                i = next;
            }
            if ancestor[i as usize] == NONE {
                ancestor[i as usize] = k;
                parent[i as usize] = k;
            }
        }
    }
    // Children in increasing order, as linked lists built from the last.
    let (mut first_child, mut next_sibling) = (vec![NONE; n], vec![NONE; n]);
    for i in (0..n).rev() {
        if parent[i] != NONE {
            next_sibling[i] = first_child[parent[i] as usize];
            first_child[parent[i] as usize] = i as u32;
        }
    }
    let mut postorder = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n as u32).filter(|&i| parent[i as usize] == NONE) {
        stack.push(root);
        while let Some(&top) = stack.last() {
            let child = first_child[top as usize];
            if child == NONE {
                postorder.push(order[top as usize]);
                stack.pop();
            } else {
                first_child[top as usize] = next_sibling[child as usize];
                stack.push(child);
            }
        }
    }
    postorder
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The adjacency and positions of an `n × n` quad cloth.
    fn grid(n: usize) -> (Adjacency, Vec<Vector3<f64>>) {
        let (edges, positions) = crate::sim::test_grid::quad_grid(n);
        (Adjacency::new(n * n, &edges), positions)
    }

    /// Parent of each position of `order` in its elimination tree, by brute
    /// force: the symbolic elimination of the graph.
    fn elimination_tree(adjacency: &Adjacency, order: &[u32]) -> Vec<Option<usize>> {
        let n = order.len();
        let mut position = vec![0usize; n];
        for (k, &p) in order.iter().enumerate() {
            position[p as usize] = k;
        }
        let mut rows: Vec<std::collections::BTreeSet<usize>> = (0..n)
            .map(|k| adjacency.of(order[k] as usize).iter().map(|&q| position[q as usize]).filter(|&i| i > k).collect())
            .collect();
        let mut parent = vec![None; n];
        for k in 0..n {
            parent[k] = rows[k].first().copied();
            if let Some(p) = parent[k] {
                let fill: Vec<usize> = rows[k].iter().copied().filter(|&i| i != p).collect();
                rows[p].extend(fill);
            }
        }
        parent
    }

    #[test]
    fn the_order_is_a_permutation_and_a_postorder_of_its_elimination_tree() {
        let (adjacency, positions) = grid(23);
        let order = nested_dissection(&adjacency, &positions);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..23 * 23).collect::<Vec<u32>>());
        // In a postorder, each subtree is the contiguous range that ends at
        // its root.
        let parent = elimination_tree(&adjacency, &order);
        let mut size = vec![1usize; order.len()];
        let mut first = (0..order.len()).collect::<Vec<_>>();
        for k in 0..order.len() {
            if let Some(p) = parent[k] {
                size[p] += size[k];
                first[p] = first[p].min(first[k]);
            }
        }
        for k in 0..order.len() {
            assert_eq!(k + 1 - first[k], size[k], "the subtree at {k} is not contiguous");
        }
    }

    #[test]
    fn the_first_separator_is_one_line_of_the_grid() {
        // On a 32 × 32 grid the last particles eliminated are the first
        // separator: one straight row or column of 32 (the elimination tree's root
        // chain), with nothing else coupled across it.
        let n = 32;
        let (adjacency, positions) = grid(n);
        let order = nested_dissection(&adjacency, &positions);
        let root: Vec<u32> = order[order.len() - n..].to_vec();
        let rows: std::collections::BTreeSet<usize> = root.iter().map(|&p| p as usize / n).collect();
        let columns: std::collections::BTreeSet<usize> = root.iter().map(|&p| p as usize % n).collect();
        assert!(rows.len() == 1 || columns.len() == 1, "separator spans rows {rows:?} and columns {columns:?}");
        let parent = elimination_tree(&adjacency, &order);
        let chain = (order.len() - n..order.len() - 1).all(|k| parent[k] == Some(k + 1));
        assert!(chain, "the separator is the root chain of the elimination tree");
    }

    #[test]
    fn disconnected_pieces_and_small_sets_keep_every_particle() {
        let (adjacency, positions) = grid(3);
        assert_eq!(nested_dissection(&adjacency, &positions).len(), 9);
        let two = Adjacency::new(40, &[[0, 1], [20, 21], [5, 5]]);
        let positions: Vec<_> = (0..40).map(|k| Vector3::new(k as f64, 0.0, 0.0)).collect();
        let mut order = nested_dissection(&two, &positions);
        order.sort_unstable();
        assert_eq!(order, (0..40).collect::<Vec<u32>>());
    }
}
