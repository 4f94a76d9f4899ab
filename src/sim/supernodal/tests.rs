use faer::Side;
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use nalgebra::{DMatrix, DVector, Vector3};

use super::*;
use crate::sim::dissection::{Adjacency, nested_dissection};

/// A sparse symmetric positive definite matrix in compressed lower
/// columns, with its supernodal tree.
struct System {
    dense: DMatrix<f64>,
    column_start: Vec<u32>,
    row_index: Vec<u32>,
    tree: SupernodalTree,
}

impl System {
    fn entry_count(&self) -> usize {
        self.row_index.len()
    }

    fn entry(&self, e: usize) -> f64 {
        let column = self.column_start.partition_point(|&s| s as usize <= e) - 1;
        self.dense[(self.row_index[e] as usize, column)]
    }
}

/// A spring-like system on an `n × n` grid of particles (edges and
/// diagonals), three unknowns each, numbered in nested-dissection order:
/// `mass I + Σ k (eᵢ − eⱼ)(eᵢ − eⱼ)ᵀ ⊗ u uᵀ` with random spring axes `u`.
fn grid_system(n: usize, mass: f64) -> System {
    let (couplings, positions) = crate::sim::test_grid::quad_grid(n);
    let order = nested_dissection(&Adjacency::new(n * n, &couplings), &positions);
    let mut position = vec![0usize; n * n];
    for (k, &p) in order.iter().enumerate() {
        position[p as usize] = k;
    }
    let size = 3 * n * n;
    let mut dense = DMatrix::identity(size, size) * mass;
    let mut state = 12345u64;
    let mut random = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) as f64 / (1u64 << 31) as f64 - 0.5
    };
    for &[a, b] in &couplings {
        let u = Vector3::new(random(), random(), random()).normalize();
        let k = u * u.transpose() * (100.0 + 50.0 * random());
        let (a, b) = (3 * position[a as usize], 3 * position[b as usize]);
        for (r, c, sign) in [(a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)] {
            let mut block = dense.view_mut((r, c), (3, 3));
            block += k * sign;
        }
    }
    // The block pattern (3 × 3 blocks wherever particles couple), lower
    // and upper.
    let mut lower: Vec<Vec<u32>> = vec![Vec::new(); size];
    for column in 0..size {
        for row in column..size {
            if dense[(row, column)] != 0.0 || (row / 3 == column / 3) || couples(&dense, row, column) {
                lower[column].push(row as u32);
            }
        }
    }
    let column_start: Vec<u32> = std::iter::once(0)
        .chain(lower.iter().scan(0u32, |total, rows| {
            *total += rows.len() as u32;
            Some(*total)
        }))
        .collect();
    let row_index: Vec<u32> = lower.concat();
    let mut upper: Vec<Vec<u32>> = vec![Vec::new(); size];
    for (column, rows) in lower.iter().enumerate() {
        for &row in rows {
            upper[row as usize].push(column as u32);
        }
    }
    let upper_start: Vec<u32> = std::iter::once(0)
        .chain(upper.iter().scan(0u32, |total, rows| {
            *total += rows.len() as u32;
            Some(*total)
        }))
        .collect();
    let upper_rows = upper.concat();
    let pattern = SymbolicSparseColMatRef::new_checked(size, size, &upper_start, None, &upper_rows);
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let symbolic = factorize_symbolic_cholesky(pattern, Side::Upper, SymmetricOrdering::Identity, params).unwrap();
    let SymbolicCholeskyRaw::Supernodal(supernodal) = symbolic.raw() else { panic!("not supernodal") };
    let tree = SupernodalTree::new(supernodal, &column_start, &row_index).unwrap();
    System { dense, column_start, row_index, tree }
}

/// True when the particles of unknowns `row` and `column` are coupled.
fn couples(dense: &DMatrix<f64>, row: usize, column: usize) -> bool {
    dense.view((row / 3 * 3, column / 3 * 3), (3, 3)).iter().any(|&v| v != 0.0)
}

fn solve(system: &System, rhs: &DVector<f64>) -> (Vec<f64>, Vec<f64>) {
    let mut factor = SupernodalFactor::<f64>::new(&system.tree);
    factor.factor(&system.tree, |e| system.entry(e)).unwrap();
    let mut x: Vec<f64> = rhs.iter().copied().collect();
    factor.solve_in_place(&system.tree, &mut x);
    (factor.values().to_vec(), x)
}

#[test]
fn the_factor_solves_the_system() {
    let system = grid_system(9, 0.01);
    let rhs = DVector::from_fn(system.dense.nrows(), |i, _| ((i * 7919) % 13) as f64 - 6.0);
    let (_, x) = solve(&system, &rhs);
    let residual = &system.dense * DVector::from_vec(x) - &rhs;
    assert!(residual.norm() < 1e-9 * rhs.norm(), "relative residual {:e}", residual.norm() / rhs.norm());
}

#[test]
fn the_factor_is_the_same_to_the_bit_on_one_thread_and_on_several() {
    // Large enough to split into parallel tasks, in the factor and both solves.
    let system = grid_system(32, 0.01);
    assert!(system.tree.subtree_flops.iter().any(|&f| f > 8.0 * PARALLEL_FACTOR_FLOPS));
    assert!(system.tree.value_count() > 4 * PARALLEL_SOLVE_VALUES, "{}", system.tree.value_count());
    let rhs = DVector::from_fn(system.dense.nrows(), |i, _| ((i * 104729) % 17) as f64 - 8.0);
    let on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| solve(&system, &rhs))
    };
    let (one, four) = (on(1), on(4));
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&one.0), bits(&four.0), "factor values");
    assert_eq!(bits(&one.1), bits(&four.1), "solution");
}

#[test]
fn an_indefinite_matrix_is_refused() {
    let system = grid_system(5, 0.01);
    let mut factor = SupernodalFactor::<f64>::new(&system.tree);
    let flipped = |e: usize| {
        let value = system.entry(e);
        if e == system.entry_count() - 1 { -value } else { value }
    };
    assert_eq!(factor.factor(&system.tree, flipped), Err(NotPositiveDefinite));
}
