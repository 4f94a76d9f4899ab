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

/// Runs `work` on a thread of the current pool (the global one when called
/// from outside any pool) and waits for it. A parallel loop started from
/// outside the pool hands its work over and sleeps until it is done, a
/// wake-up and a sleep of two threads per loop; started from a thread of
/// the pool, it runs there and lends work to the others. A step starts some
/// hundreds of loops: this one hand-over replaces theirs. Nothing it computes
/// depends on which thread runs it.
pub fn on_pool<R: Send>(work: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| work())
}

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

/// Sets every element of `v` from its index, then returns `Σᵢ term(i, vᵢ)`
/// of the values set: one parallel pass over the chunks of [`sum`], each
/// chunk set and then summed in order, so the same rounding as setting with
/// [`for_each_indexed`] and summing with [`sum`].
pub fn set_and_sum<T: Send + Sync>(
    v: &mut [T],
    partials: &mut Vec<f64>,
    set: impl Fn(usize, &mut T) + Sync,
    term: impl Fn(usize, &T) -> f64 + Sync,
) -> f64 {
    partials.resize(chunk_count(v.len()), 0.0);
    let chunk_sum = |c: usize, chunk: &mut [T]| -> f64 {
        for (k, e) in chunk.iter_mut().enumerate() {
            set(c * CHUNK + k, e);
        }
        chunk.iter().enumerate().map(|(k, e)| term(c * CHUNK + k, e)).sum()
    };
    if v.len() < PARALLEL_FROM {
        for (c, (chunk, slot)) in v.chunks_mut(CHUNK).zip(partials.iter_mut()).enumerate() {
            *slot = chunk_sum(c, chunk);
        }
    } else {
        v.par_chunks_mut(CHUNK)
            .zip(partials.par_iter_mut())
            .enumerate()
            .for_each(|(c, (chunk, slot))| *slot = chunk_sum(c, chunk));
    }
    partials.iter().sum()
}

/// [`set_and_sum`] on two slices at once: sets `a[i]` and `b[i]` together from
/// index `i` (one pass over whatever both are computed from), then returns
/// `(Σᵢ term_a(i, aᵢ), Σᵢ term_b(i, bᵢ))` with the chunks and the order of
/// [`set_and_sum`], so the same rounding as two calls of it.
pub fn set_and_sum_both<T: Send + Sync>(
    (a, b): (&mut [T], &mut [T]),
    partials: &mut Vec<f64>,
    set: impl Fn(usize, &mut T, &mut T) + Sync,
    (term_a, term_b): (impl Fn(usize, &T) -> f64 + Sync, impl Fn(usize, &T) -> f64 + Sync),
) -> (f64, f64) {
    assert_eq!(a.len(), b.len(), "two slices of one length");
    partials.resize(2 * chunk_count(a.len()), 0.0);
    let chunk_sums = |c: usize, (ca, cb): (&mut [T], &mut [T]), slots: &mut [f64]| {
        for (k, (ea, eb)) in ca.iter_mut().zip(cb.iter_mut()).enumerate() {
            set(c * CHUNK + k, ea, eb);
        }
        slots[0] = ca.iter().enumerate().map(|(k, e)| term_a(c * CHUNK + k, e)).sum();
        slots[1] = cb.iter().enumerate().map(|(k, e)| term_b(c * CHUNK + k, e)).sum();
    };
    if a.len() < PARALLEL_FROM {
        let chunks = a.chunks_mut(CHUNK).zip(b.chunks_mut(CHUNK));
        for (c, (pair, slots)) in chunks.zip(partials.chunks_mut(2)).enumerate() {
            chunk_sums(c, pair, slots);
        }
    } else {
        let chunks = a.par_chunks_mut(CHUNK).zip(b.par_chunks_mut(CHUNK));
        chunks.zip(partials.par_chunks_mut(2)).enumerate().for_each(|(c, (pair, slots))| chunk_sums(c, pair, slots));
    }
    (partials.iter().step_by(2).sum(), partials.iter().skip(1).step_by(2).sum())
}

/// `maxᵢ term(i)` over `0..len` (0 when empty). Exact in any order.
pub fn max(len: usize, term: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
    (0..len).into_par_iter().with_min_len(CHUNK).map(term).reduce(|| 0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Work handed to the pool from a thread outside it runs on one of the
    /// pool's threads, and its result comes back.
    #[test]
    fn work_on_the_pool_runs_on_a_pool_thread() {
        assert_eq!(rayon::current_thread_index(), None, "the test harness's thread is not the pool's");
        let (on_a_pool_thread, total) = on_pool(|| (rayon::current_thread_index().is_some(), max(5, |i| i as f64)));
        assert!(on_a_pool_thread);
        assert_eq!(total, 4.0);
    }

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
    fn set_and_sum_sets_like_for_each_and_sums_like_sum_on_any_thread_count() {
        for len in [100, 10_000] {
            let set = |i: usize, e: &mut f64| *e = ((i * 7919) % 1000) as f64 * 1e-3 + 1e-9 * i as f64;
            let run = |threads| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let mut values = vec![0.0; len];
                let total = pool.install(|| set_and_sum(&mut values, &mut Vec::new(), set, |_, v| v * v));
                (values, total)
            };
            let mut expected = vec![0.0; len];
            for_each_indexed(&mut expected, set);
            let expected_total = sum(len, &mut Vec::new(), |i| expected[i] * expected[i]);
            for threads in [1, 2] {
                let (values, total) = run(threads);
                assert_eq!(values, expected);
                assert_eq!(total.to_bits(), expected_total.to_bits());
            }
        }
    }

    #[test]
    fn set_and_sum_both_is_two_set_and_sums_to_the_bit_on_any_thread_count() {
        for len in [100, 10_000] {
            let first = |i: usize| ((i * 7919) % 1000) as f64 * 1e-3 + 1e-9 * i as f64;
            let second = |i: usize| ((i * 104_729) % 997) as f64 * 1e-2 - 3.0;
            let mut expected = (vec![0.0; len], vec![0.0; len]);
            let total_a = set_and_sum(&mut expected.0, &mut Vec::new(), |i, e| *e = first(i), |_, v| v * v);
            let total_b = set_and_sum(&mut expected.1, &mut Vec::new(), |i, e| *e = second(i), |_, v| v.abs());
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let (mut a, mut b) = (vec![0.0; len], vec![0.0; len]);
                let set = |i: usize, ea: &mut f64, eb: &mut f64| (*ea, *eb) = (first(i), second(i));
                let terms = (|_: usize, v: &f64| v * v, |_: usize, v: &f64| v.abs());
                let (sum_a, sum_b) = pool.install(|| set_and_sum_both((&mut a, &mut b), &mut Vec::new(), set, terms));
                assert_eq!((&a, &b), (&expected.0, &expected.1));
                assert_eq!((sum_a.to_bits(), sum_b.to_bits()), (total_a.to_bits(), total_b.to_bits()));
            }
        }
    }

    #[test]
    fn max_of_nothing_is_zero() {
        assert_eq!(max(0, |_| 5.0), 0.0);
        assert_eq!(max(1000, |i| i as f64), 999.0);
    }
}
