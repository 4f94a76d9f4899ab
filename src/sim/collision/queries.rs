//! Broad-phase queries run in parallel and gathered in a fixed order: each
//! parallel task keeps its own hit and pair buffers from call to call, and
//! the pairs come out in the order of the triangles queried, whatever the
//! thread count (the bake is the same bit for bit at any thread count).

use rayon::prelude::*;

/// Moved triangles per parallel task of a broad-phase query.
const QUERIES_PER_CHUNK: usize = 32;

/// One parallel task's buffers for hierarchy queries.
#[derive(Clone, Debug, Default)]
pub(super) struct QueryChunk {
    hits: Vec<u32>,
    pairs: Vec<(u32, u32)>,
}

/// Runs `query` for every triangle of `triangles` in parallel chunks (each
/// with its own hit and pair buffers, kept in `chunks` from call to call) and
/// appends the pairs to `out` in the order of `triangles`, whatever the
/// thread count.
pub(super) fn parallel_queries(
    triangles: &[u32],
    chunks: &mut Vec<QueryChunk>,
    out: &mut Vec<(u32, u32)>,
    query: impl Fn(u32, &mut Vec<u32>, &mut Vec<(u32, u32)>) + Sync,
) {
    out.clear();
    let count = triangles.len().div_ceil(QUERIES_PER_CHUNK);
    if chunks.len() < count {
        chunks.resize_with(count, QueryChunk::default);
    }
    triangles.par_chunks(QUERIES_PER_CHUNK).zip(chunks[..count].par_iter_mut()).for_each(|(triangles, chunk)| {
        chunk.pairs.clear();
        for &t in triangles {
            query(t, &mut chunk.hits, &mut chunk.pairs);
        }
    });
    for chunk in &chunks[..count] {
        out.extend_from_slice(&chunk.pairs);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairs `(t, k)` for `k < t % 5`: a query whose output size varies.
    fn varying_query(t: u32, _hits: &mut Vec<u32>, pairs: &mut Vec<(u32, u32)>) {
        pairs.extend((0..t % 5).map(|k| (t, k)));
    }

    #[test]
    fn parallel_queries_keep_the_order_of_the_triangles_at_any_thread_count() {
        let triangles: Vec<u32> = (0..500).map(|t| t * 3).collect();
        let expected: Vec<(u32, u32)> = triangles.iter().flat_map(|&t| (0..t % 5).map(move |k| (t, k))).collect();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a thread pool");
            let mut chunks = Vec::new();
            let mut out = vec![(9, 9)];
            pool.install(|| parallel_queries(&triangles, &mut chunks, &mut out, varying_query));
            assert_eq!(out, expected, "{threads} threads");
            // Reused buffers, fewer triangles: nothing of the last call is left.
            pool.install(|| parallel_queries(&triangles[..7], &mut chunks, &mut out, varying_query));
            assert_eq!(out, expected[..expected.iter().filter(|p| p.0 < 21).count()], "{threads} threads");
        }
    }
}
