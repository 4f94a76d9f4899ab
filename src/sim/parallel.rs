//! Parallel loops whose results do not depend on the thread count.
//!
//! Work is cut into fixed-size chunks; every chunk's result lands in its own
//! slot and slots are combined in chunk order, so a sum has the same rounding
//! with one thread or many.

use rayon::prelude::*;

/// Elements per parallel chunk: large enough to amortise scheduling, small
/// enough to balance two cores on a 4k-vertex cloth.
pub const CHUNK: usize = 256;

/// Loops over fewer elements than this run on the calling thread: waking the
/// pool costs more than the work (the coarse levels of the multigrid).
pub const PARALLEL_FROM: usize = 4 * CHUNK;

/// Sets every element of `v` from its index: in parallel chunks when `v` is
/// long enough to pay for it, on the calling thread otherwise. The result does
/// not depend on which.
pub fn for_each_indexed<T: Send>(v: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    if v.len() < PARALLEL_FROM {
        v.iter_mut().enumerate().for_each(|(i, e)| f(i, e));
        return;
    }
    v.par_chunks_mut(CHUNK).enumerate().for_each(|(c, chunk)| {
        for (k, e) in chunk.iter_mut().enumerate() {
            f(c * CHUNK + k, e);
        }
    });
}

/// Number of chunks covering `len` elements.
pub fn chunk_count(len: usize) -> usize {
    len.div_ceil(CHUNK)
}

/// `Σᵢ term(i)` over `0..len`, summed per chunk in parallel and then over chunks
/// in order. `partials` is scratch space (resized once, then reused).
pub fn sum(len: usize, partials: &mut Vec<f64>, term: impl Fn(usize) -> f64 + Sync) -> f64 {
    partials.resize(chunk_count(len), 0.0);
    for_each_indexed(partials, |c, slot| {
        let range = c * CHUNK..((c + 1) * CHUNK).min(len);
        *slot = range.map(&term).sum();
    });
    partials.iter().sum()
}

/// `maxᵢ term(i)` over `0..len` (0 when empty). Exact in any order.
pub fn max(len: usize, term: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
    (0..len).into_par_iter().with_min_len(CHUNK).map(term).reduce(|| 0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sum_is_identical_on_one_and_two_threads() {
        let values: Vec<f64> = (0..10_000).map(|i| ((i * 7919) % 1000) as f64 * 1e-3 + 1e-9 * i as f64).collect();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| sum(values.len(), &mut Vec::new(), |i| values[i] * values[i]))
        };
        assert_eq!(run(1).to_bits(), run(2).to_bits());
        let exact: f64 = values.iter().map(|v| v * v).sum();
        assert!((run(2) - exact).abs() < 1e-9 * exact);
    }

    #[test]
    fn max_of_nothing_is_zero() {
        assert_eq!(max(0, |_| 5.0), 0.0);
        assert_eq!(max(1000, |i| i as f64), 999.0);
    }
}
