use super::*;
use crate::sim::sparse::SystemPattern;
use nalgebra::{DMatrix, DVector};

use crate::sim::test_grid::{quad_grid, ring_positions};

/// The couplings of the ring of `n` particles to their neighbours at
/// ±1 and ±2.
fn ring_pairs(n: usize) -> Vec<[u32; 2]> {
    (0..n as u32).flat_map(|i| [[i, (i + 1) % n as u32], [i, (i + 2) % n as u32]]).collect()
}

/// A random SPD block system on a ring of `n` particles (couplings ±1, ±2).
fn ring(n: usize, seed: u64) -> (BlockPattern, Vec<Matrix3<f64>>) {
    let pattern = BlockPattern::new(n, ring_pairs(n));
    let mut a = vec![Matrix3::zeros(); pattern.stored_blocks()];
    let mut state = seed;
    let mut rand = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) as f64 / (1u64 << 31) as f64 - 0.5
    };
    for i in 0..n {
        a[pattern.diagonal(i)] += Matrix3::identity() * 0.01;
        for j in [(i + 1) % n, (i + 2) % n] {
            let u = Vector3::new(rand(), rand(), rand());
            let k = u * u.transpose() * 100.0;
            for (r, c, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                a[pattern.slot(r, c).unwrap()] += k * sign;
            }
        }
    }
    (pattern, a)
}

fn dense(pattern: &BlockPattern, blocks: impl Fn(usize, usize) -> Matrix3<f64>) -> DMatrix<f64> {
    let n = pattern.rows();
    let mut m = DMatrix::zeros(3 * n, 3 * n);
    for i in 0..n {
        for s in pattern.row(i) {
            let j = pattern.column(s);
            m.view_mut((3 * i, 3 * j), (3, 3)).copy_from(&blocks(s, i));
        }
    }
    m
}

/// Refactors `cholesky` for the full blocks `a` on `pattern`.
fn refactor_blocks(
    cholesky: &mut LaggedCholesky,
    pattern: &BlockPattern,
    a: &[Matrix3<f64>],
    constraints: &[Constraint],
) -> Result<(), CholeskyError> {
    let system = SystemPattern::blocks_only(pattern.clone());
    cholesky.refactor(SystemMatrix { pattern: &system, blocks: a, isotropic_scale: &[] }, constraints)
}

fn flatten(v: &[Vector3<f64>]) -> DVector<f64> {
    DVector::from_iterator(3 * v.len(), v.iter().flat_map(|x| x.iter().copied()))
}

/// The factor inverts `S A S + c (I − S)` exactly: checked against a dense
/// solve of the same matrix, with pinned, contact and free particles.
#[test]
fn factor_solves_the_filtered_system() {
    let (pattern, a) = ring(12, 7);
    let mut constraints = vec![Constraint::Free; 12];
    constraints[3] = Constraint::Fixed;
    constraints[8] = Constraint::Normal(Vector3::new(1.0, 2.0, 2.0) / 3.0);
    let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(12), &ring_positions(12)).unwrap();
    assert!(!cholesky.begin_solve(), "no factor yet");
    refactor_blocks(&mut cholesky, &pattern, &a, &constraints).unwrap();

    let filtered = dense(&pattern, |s, i| {
        let j = pattern.column(s);
        let (si, sj) = (constraints[i].filter_matrix(), constraints[j].filter_matrix());
        let fill = if i == j { (Matrix3::identity() - si) * (a[s].trace() / 3.0) } else { Matrix3::zeros() };
        si * a[s] * sj + fill
    });
    let r: Vec<Vector3<f64>> = (0..12).map(|i| Vector3::new(i as f64, 1.0, -(i as f64) * 0.5)).collect();
    let expected = filtered.cholesky().unwrap().solve(&flatten(&r));
    let error = |cholesky: &mut LaggedCholesky| {
        let mut z = vec![Vector3::zeros(); 12];
        cholesky.apply(&r, &mut z);
        (flatten(&z) - &expected).norm() / expected.norm()
    };
    // Single precision loses about the condition number (here ~1e4) times
    // f32's 6e-8.
    let single = error(&mut cholesky);
    assert!(single < 1e-3, "single precision: relative error {single:e}");
    cholesky.use_double_precision();
    refactor_blocks(&mut cholesky, &pattern, &a, &constraints).unwrap();
    let double = error(&mut cholesky);
    assert!(double < 1e-12, "double precision: relative error {double:e}");
}

/// With the ±2 couplings dropped, the factored matrix `P` is the system
/// plus a positive semi-definite compensation: `P − A ⪰ 0`, and `P` is
/// not `A` (something was dropped).
#[test]
fn dropped_blocks_leave_a_factor_of_a_larger_matrix() {
    // Long enough for separators: the ±2 couplings across them would fill in.
    let (excess, scale) = factored_minus_system(48);
    assert!(excess.min() > -1e-9 * scale, "P − A has eigenvalue {:e}", excess.min());
    assert!(excess.max() > 1e-3 * scale, "the ±2 couplings across separators were dropped");
}

/// Besides the springs, the factor keeps exactly the blocks whose
/// entries the springs' factor stores anyway: it stores as many values
/// as the springs' alone, and on a quad grid that keeps some, not all,
/// of the couplings two particles apart (where a quad mesh's hinges join).
#[test]
fn blocks_the_factor_stores_anyway_are_kept_at_no_fill() {
    let n = 24;
    let (springs, positions) = quad_grid(n);
    let id = |r: usize, c: usize| (r * n + c) as u32;
    let two_apart: Vec<[u32; 2]> = (0..n)
        .flat_map(|r| (0..n).map(move |c| (r, c)))
        .flat_map(|(r, c)| {
            [(r + 2 < n).then(|| [id(r, c), id(r + 2, c)]), (c + 2 < n).then(|| [id(r, c), id(r, c + 2)])]
        })
        .flatten()
        .collect();
    let pattern = BlockPattern::new(n * n, springs.iter().chain(&two_apart).copied());
    let cholesky = LaggedCholesky::new(&pattern, &springs, &positions).unwrap();

    let (order, position) = dissection_order(n * n, &springs, &positions);
    let springs_only = LowerTriangle::new(&pattern, &kept_slots(&pattern, &springs)).reordered(&order, &position);
    let springs_values = symbolic_tree(&springs_only.analysis().unwrap(), &springs_only).unwrap().value_count();
    assert_eq!(cholesky.tree.value_count(), springs_values);
    let kept_two_apart =
        two_apart.iter().filter(|&&[a, b]| cholesky.kept[pattern.slot(a as usize, b as usize).unwrap()]).count();
    assert!(kept_two_apart > two_apart.len() / 4, "{kept_two_apart} of {} kept", two_apart.len());
    assert!(kept_two_apart < two_apart.len(), "every coupling two apart kept: nothing crosses a separator");
}

/// The eigenvalues of `P − A` for the factored matrix `P` of a ring of
/// `n` particles whose factor keeps the ±1 couplings, and `‖A‖`.
fn factored_minus_system(n: usize) -> (DVector<f64>, f64) {
    let (pattern, a) = ring(n, 11);
    let neighbours: Vec<[u32; 2]> = (0..n as u32).map(|i| [i, (i + 1) % n as u32]).collect();
    let mut cholesky = LaggedCholesky::new(&pattern, &neighbours, &ring_positions(n)).unwrap();
    cholesky.use_double_precision();
    let free = vec![Constraint::Free; n];
    refactor_blocks(&mut cholesky, &pattern, &a, &free).unwrap();

    // P⁻¹ column by column, then P.
    let mut inverse = DMatrix::zeros(3 * n, 3 * n);
    for k in 0..3 * n {
        let mut unit = vec![Vector3::zeros(); n];
        unit[k / 3][k % 3] = 1.0;
        let mut column = vec![Vector3::zeros(); n];
        cholesky.apply(&unit, &mut column);
        inverse.set_column(k, &flatten(&column));
    }
    let factored = inverse.try_inverse().unwrap();
    let system = dense(&pattern, |s, _| a[s]);
    ((&factored - &system).symmetric_eigenvalues(), system.norm())
}

/// The factor is analysed in nested-dissection order: on a grid it fills
/// in less than the grid's own row-by-row order, and its tree is
/// balanced: most of the work lies off the longest chain of supernodes,
/// in subtrees that factor in parallel.
#[test]
fn the_dissection_order_fills_in_little_and_balances_the_tree() {
    let side = 24u32;
    let at = |x: u32, y: u32| y * side + x;
    let mut pairs = Vec::new();
    for y in 0..side {
        for x in 0..side {
            let neighbours = [(1, 0), (0, 1), (1, 1)].into_iter().chain((x > 0).then_some((-1, 1)));
            for (dx, dy) in neighbours {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < side as i64 && ny < side as i64 {
                    pairs.push([at(x, y), at(nx as u32, ny as u32)]);
                }
            }
        }
    }
    let positions: Vec<_> =
        (0..side * side).map(|k| Vector3::new((k % side) as f64, 0.0, (k / side) as f64) * 0.01).collect();
    let pattern = BlockPattern::new((side * side) as usize, pairs.iter().copied());
    let natural = LowerTriangle::new(&pattern, &kept_slots(&pattern, &pairs));
    let unordered = symbolic_tree(&natural.analysis().unwrap(), &natural).unwrap().value_count();
    let cholesky = LaggedCholesky::new(&pattern, &pairs, &positions).unwrap();
    let dissected = cholesky.tree.value_count();
    assert!(dissected < unordered, "dissection fills {dissected} entries, the grid order {unordered}");
    let (longest_chain, total) = cholesky.tree.critical_path_flops();
    assert!(longest_chain < 0.4 * total, "{longest_chain:e} of {total:e} flops on one chain");
}

#[test]
fn the_norm_bound_is_exact_for_multiples_of_the_identity_and_never_below_the_norm() {
    assert_eq!(spectral_norm_bound(&(Matrix3::identity() * -2.5)), 2.5);
    let mut state = 3u64;
    let mut rand = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) as f64 / (1u64 << 31) as f64 - 0.5
    };
    for _ in 0..200 {
        let d = Matrix3::from_fn(|_, _| rand());
        let largest = d.singular_values().max();
        assert!(spectral_norm_bound(&d) >= largest * (1.0 - 1e-12), "{d}");
    }
}

#[test]
fn the_single_precision_allowance_grows_with_the_digits_asked_for() {
    assert_eq!(single_precision_allowance(1e-3), 6);
    assert_eq!(single_precision_allowance(1e-10), 20);
    assert_eq!(single_precision_allowance(0.5), 2, "at least one digit's worth");
    assert_eq!(single_precision_allowance(0.0), 12, "f32's 6 digits when asked for exactness");
}

/// After a stale factor fails, stale factors are skipped for
/// [`RETRY_STALE_AFTER`] solves, then tried again.
#[test]
fn failed_stale_factors_are_retried_later() {
    let (pattern, a) = ring(6, 5);
    let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(6), &ring_positions(6)).unwrap();
    cholesky.begin_solve();
    refactor_blocks(&mut cholesky, &pattern, &a, &[Constraint::Free; 6]).unwrap();
    assert!(cholesky.begin_solve(), "a kept factor is tried");
    cholesky.stale_failed();
    let tries: Vec<bool> = (0..RETRY_STALE_AFTER).map(|_| cholesky.begin_solve()).collect();
    assert_eq!(tries.iter().filter(|&&t| t).count(), 1);
    assert!(*tries.last().unwrap());
}

/// An indefinite matrix is reported, not factored, and leaves no factor
/// (even after falling back to double precision).
#[test]
fn indefinite_matrix_is_rejected() {
    let (pattern, mut a) = ring(6, 3);
    a[pattern.diagonal(2)] = -Matrix3::identity();
    let mut cholesky = LaggedCholesky::new(&pattern, &ring_pairs(6), &ring_positions(6)).unwrap();
    let free = vec![Constraint::Free; 6];
    assert_eq!(refactor_blocks(&mut cholesky, &pattern, &a, &free), Err(CholeskyError::NotPositiveDefinite));
    assert!(!cholesky.begin_solve(), "no factor is left to try");
}
