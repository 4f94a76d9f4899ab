//! Sorting a broad phase's pairs of leaf indices in linear time, and
//! merging two sorted lists of them.
//!
//! A step's broad phase hands over tens of thousands of pairs (55,000 self
//! pairs per step on `skirt_walk`) in traversal order; the detections need
//! them sorted, to merge and deduplicate them and to give the narrow phase
//! the same order at any thread count. A comparison sort took twice as long
//! as the traversal that found them. Leaf indices are dense and each leaf
//! overlaps only its neighbours, so the pairs are counted into one run per
//! first index, and each short run is then sorted by its second. Sorted
//! lists from different sources (the speculation's confirmed pairs and the
//! escaped triangles' queries, the hierarchy's pairs and the adjacent
//! triangles') are merged into one ([`merge_sorted`]).

/// Scratch for [`PairSorter::sort`], kept from call to call so that a step
/// allocates nothing once running.
#[derive(Clone, Debug, Default)]
pub struct PairSorter {
    /// Per first index, where its run ends once the pairs are placed.
    run_end: Vec<u32>,
    /// The pairs in their runs, swapped with the caller's.
    placed: Vec<(u32, u32)>,
}

impl PairSorter {
    /// Sorts `pairs` in increasing order, as `sort_unstable` would, in time
    /// linear in their number and in their largest first index.
    pub fn sort(&mut self, pairs: &mut Vec<(u32, u32)>) {
        let Some(largest) = pairs.iter().map(|&(first, _)| first).max() else {
            return;
        };
        let run_end = &mut self.run_end;
        run_end.clear();
        run_end.resize(largest as usize + 1, 0);
        for &(first, _) in pairs.iter() {
            run_end[first as usize] += 1;
        }
        // Exclusive prefix sums: each run's start, advanced as it fills.
        let mut start = 0;
        for slot in run_end.iter_mut() {
            (*slot, start) = (start, start + *slot);
        }
        self.placed.clear();
        self.placed.resize(pairs.len(), (0, 0));
        for &pair in pairs.iter() {
            let slot = &mut run_end[pair.0 as usize];
            self.placed[*slot as usize] = pair;
            *slot += 1;
        }
        let mut begin = 0;
        for &end in run_end.iter() {
            self.placed[begin..end as usize].sort_unstable_by_key(|&(_, second)| second);
            begin = end as usize;
        }
        std::mem::swap(pairs, &mut self.placed);
    }
}

/// The union of the sorted sequences `first` and `second` into `out`,
/// sorted, each pair once.
pub(super) fn merge_sorted(first: impl Iterator<Item = (u32, u32)>, second: &[(u32, u32)], out: &mut Vec<(u32, u32)>) {
    out.clear();
    let mut rest = second.iter().copied().peekable();
    for pair in first {
        while let Some(next) = rest.next_if(|&next| next <= pair) {
            if out.last() != Some(&next) {
                out.push(next);
            }
        }
        if out.last() != Some(&pair) {
            out.push(pair);
        }
    }
    for next in rest {
        if out.last() != Some(&next) {
            out.push(next);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_merge_of_sorted_pairs_is_their_sorted_union() {
        let mut out = Vec::new();
        merge_sorted([(0, 1), (0, 3), (2, 5)].into_iter(), &[(0, 2), (0, 3), (4, 4)], &mut out);
        assert_eq!(out, vec![(0, 1), (0, 2), (0, 3), (2, 5), (4, 4)]);
    }

    #[test]
    fn no_pairs_stay_none_and_one_run_is_sorted_by_its_second_index() {
        let mut sorter = PairSorter::default();
        let mut pairs = Vec::new();
        sorter.sort(&mut pairs);
        assert!(pairs.is_empty());
        pairs = vec![(0, 9), (0, 2), (0, 5)];
        sorter.sort(&mut pairs);
        assert_eq!(pairs, vec![(0, 2), (0, 5), (0, 9)]);
    }

    proptest! {
        /// Any pairs, repeated ones and gaps in the first indices included,
        /// come out as a comparison sort leaves them; the scratch of an
        /// earlier, larger call leaves no trace.
        #[test]
        fn sorts_as_a_comparison_sort_does(
            earlier in prop::collection::vec((0u32..300, 0u32..300), 0..400),
            pairs in prop::collection::vec((0u32..60, 0u32..1_000_000), 0..400),
        ) {
            let mut sorter = PairSorter::default();
            let mut scratch = earlier;
            sorter.sort(&mut scratch);
            let mut expected = pairs.clone();
            expected.sort_unstable();
            let mut sorted = pairs;
            sorter.sort(&mut sorted);
            prop_assert_eq!(sorted, expected);
        }
    }
}
