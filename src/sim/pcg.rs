//! Filtered preconditioned conjugate gradients (Baraff and Witkin 1998, §5.3).
//!
//! Solves `A x = b` for a symmetric positive-definite block matrix while
//! constrained rows keep part of the value they start with: the residual and
//! search directions are filtered (projected) there, so a pinned particle keeps
//! exactly its prescribed velocity change, and a particle in contact keeps its
//! prescribed velocity change along the contact normal while sliding freely
//! along the surface. The preconditioner is a lagged sparse Cholesky factor
//! ([`super::cholesky`]), a multigrid V-cycle ([`super::multigrid`]) or the
//! inverse of each 3×3 diagonal block; whichever, convergence is measured in the norm the inverse diagonal blocks define,
//! so the two stop at the same accuracy. All reductions go through [`super::parallel::sum`], so the
//! result is bit-identical at any thread count.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::cholesky::{CholeskyError, FactorState, LaggedCholesky, RESOLVE_BUDGET, STALE_BUDGET};
use super::constraint::Constraint;
use super::multigrid::Multigrid;
use super::parallel::{self, CHUNK, for_each_indexed as par_each};
use super::sparse::{BlockPattern, SystemMatrix};

/// Which preconditioner a simulation uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PreconditionerKind {
    /// A sparse Cholesky factor of the filtered system, kept across steps and
    /// rebuilt when it goes stale: one to a few iterations per solve. Its
    /// memory and factor time grow faster than the mesh (about N^1.5).
    #[default]
    Cholesky,
    /// A multigrid V-cycle with rigid-body coarse spaces: memory and time per
    /// iteration linear in the mesh, more iterations than a fresh factor.
    Multigrid,
    /// The inverse 3×3 diagonal blocks: cheap per iteration, but the count grows
    /// with stiffness, step and resolution.
    BlockJacobi,
}

/// The preconditioner of one solve.
pub enum Preconditioning<'a> {
    /// The inverse of each 3×3 diagonal block.
    BlockJacobi,
    /// A multigrid V-cycle, prepared for this matrix and these constraints
    /// ([`Multigrid::prepare`]).
    Multigrid(&'a mut Multigrid),
    /// A Cholesky factor of this or an earlier filtered system.
    Cholesky(&'a mut LaggedCholesky),
}

/// The preconditioner a simulation keeps from solve to solve.
#[derive(Clone, Debug)]
pub enum Preconditioner {
    /// See [`PreconditionerKind::BlockJacobi`].
    BlockJacobi,
    /// See [`PreconditionerKind::Multigrid`].
    Multigrid(Box<Multigrid>),
    /// See [`PreconditionerKind::Cholesky`].
    Cholesky(Box<LaggedCholesky>),
}

impl Preconditioner {
    /// The preconditioner of `kind` for matrices on `pattern`, whose springs
    /// join `edges` (a Cholesky factor keeps only their blocks and the
    /// diagonal, and orders the particles by their `positions`, m; multigrid
    /// aggregates along the springs).
    pub fn new(
        kind: PreconditionerKind,
        pattern: &BlockPattern,
        edges: &[[u32; 2]],
        positions: &[Vector3<f64>],
    ) -> Result<Self, CholeskyError> {
        Ok(match kind {
            PreconditionerKind::BlockJacobi => Preconditioner::BlockJacobi,
            PreconditionerKind::Multigrid => Preconditioner::Multigrid(Box::new(Multigrid::new(pattern, edges))),
            PreconditionerKind::Cholesky => {
                Preconditioner::Cholesky(Box::new(LaggedCholesky::new(pattern, edges, positions)?))
            }
        })
    }

    /// What it carries from solve to solve: a kept factor's state; block
    /// Jacobi and multigrid (rebuilt for every solve) carry nothing.
    pub fn state(&self) -> Option<FactorState> {
        match self {
            Preconditioner::Cholesky(cholesky) => Some(cholesky.state()),
            Preconditioner::BlockJacobi | Preconditioner::Multigrid(_) => None,
        }
    }

    /// Returns a kept factor to `state` (see [`LaggedCholesky::restore`]);
    /// nothing to do for the others.
    pub fn restore(&mut self, state: &FactorState) -> Result<(), CholeskyError> {
        match self {
            Preconditioner::Cholesky(cholesky) => cholesky.restore(state),
            Preconditioner::BlockJacobi | Preconditioner::Multigrid(_) => Ok(()),
        }
    }

    /// Solves `A x = b` under `constraints` like [`solve`], preparing the
    /// preconditioner first: a multigrid hierarchy is rebuilt for `a`; a kept
    /// Cholesky factor is tried on a small budget (larger when only
    /// constraints were added to the system it was made for, `change`) and
    /// rebuilt if that is not enough, the solve continuing from where the try left `x` (and a fresh
    /// factor that still needs several iterations moves the simulation to
    /// double-precision factors); block Jacobi stands in for a factor that
    /// cannot be built. Returns the outcome
    /// (iterations summed over tries) and the number of factors built.
    pub fn solve(
        &mut self,
        system: FilteredSystem,
        x: &mut [Vector3<f64>],
        settings: PcgSettings,
        ws: &mut PcgWorkspace,
        change: SystemChange,
    ) -> (PcgReport, u32) {
        let FilteredSystem { matrix, constraints, .. } = system;
        match self {
            Preconditioner::BlockJacobi => (solve(system, x, settings, Preconditioning::BlockJacobi, ws), 0),
            Preconditioner::Multigrid(multigrid) => {
                multigrid.prepare(matrix, constraints, system.positions);
                (solve(system, x, settings, Preconditioning::Multigrid(multigrid), ws), 0)
            }
            Preconditioner::Cholesky(cholesky) => {
                let mut spent = 0;
                let (worth_trying, budget) = match change {
                    SystemChange::Matrix => (cholesky.begin_solve(), STALE_BUDGET),
                    SystemChange::Constraints => (cholesky.begin_resolve(), RESOLVE_BUDGET),
                };
                if worth_trying {
                    let kept = PcgSettings { max_iterations: budget, ..settings };
                    let report = solve(system, x, kept, Preconditioning::Cholesky(cholesky), ws);
                    if report.converged {
                        return (report, 0);
                    }
                    if change == SystemChange::Matrix {
                        cholesky.stale_failed();
                    }
                    spent = report.iterations;
                }
                let factored = cholesky.refactor(matrix, constraints).is_ok();
                let preconditioning =
                    if factored { Preconditioning::Cholesky(cholesky) } else { Preconditioning::BlockJacobi };
                let report = solve(system, x, settings, preconditioning, ws);
                if factored {
                    cholesky.fresh_factor_needed(report.iterations, settings.tolerance);
                }
                (PcgReport { iterations: spent + report.iterations, ..report }, u32::from(factored))
            }
        }
    }
}

/// What changed in the system since the preconditioner's last solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SystemChange {
    /// The matrix (a new step), and with it anything else.
    Matrix,
    /// Only constraints, added to particles that came into contact: the
    /// same matrix, filtered in a few more rows.
    Constraints,
}

/// A linear system `A x = b` whose rows change only in the directions their
/// constraints leave free.
#[derive(Clone, Copy)]
pub struct FilteredSystem<'a> {
    /// The matrix `A`.
    pub matrix: SystemMatrix<'a>,
    /// Right-hand side.
    pub b: &'a [Vector3<f64>],
    /// A right-hand side of the size that matters, for the stopping test (see
    /// [`solve`]).
    pub typical: &'a [Vector3<f64>],
    /// What each row may change.
    pub constraints: &'a [Constraint],
    /// Particle positions (m), for preconditioners that need the geometry.
    pub positions: &'a [Vector3<f64>],
}

/// When to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgSettings {
    /// Stop when the preconditioned residual norm falls below this fraction of
    /// the reference: the larger of the right-hand side's norm and the
    /// `typical` right-hand side's (see [`solve`]), unitless.
    pub tolerance: f64,
    /// Stop after this many iterations even if not converged.
    pub max_iterations: u32,
    /// The preconditioner.
    pub preconditioner: PreconditionerKind,
}

/// How a solve ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PcgReport {
    /// Iterations run.
    pub iterations: u32,
    /// Final preconditioned residual norm over the right-hand side's, unitless.
    pub relative_residual: f64,
    /// True when the tolerance was reached.
    pub converged: bool,
}

/// Reusable buffers of the solver.
#[derive(Clone, Debug, Default)]
pub struct PcgWorkspace {
    residual: Vec<Vector3<f64>>,
    direction: Vec<Vector3<f64>>,
    product: Vec<Vector3<f64>>,
    preconditioned: Vec<Vector3<f64>>,
    inverse_diagonal: Vec<Matrix3<f64>>,
    partials: Vec<f64>,
}

impl PcgWorkspace {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.residual, &mut self.direction, &mut self.product, &mut self.preconditioned] {
            v.resize(n, Vector3::zeros());
        }
        self.inverse_diagonal.resize(n, Matrix3::zeros());
    }
}

/// Solves `A x = b` (block values `a` on `pattern`) starting from `x` (or from
/// its constrained part alone, if that is closer); row `i` changes only in the
/// directions `constraints[i]` leaves free.
///
/// `typical` is a right-hand side of the size that matters (for cloth, each
/// particle's weight over a step): near equilibrium `b` itself tends to zero,
/// and a tolerance relative to it alone would ask for ever more digits.
pub fn solve(
    system: FilteredSystem,
    x: &mut [Vector3<f64>],
    settings: PcgSettings,
    mut preconditioning: Preconditioning,
    ws: &mut PcgWorkspace,
) -> PcgReport {
    let FilteredSystem { matrix, b, typical, constraints, .. } = system;
    let n = b.len();
    ws.resize(n);
    ws.inverse_diagonal.par_iter_mut().enumerate().with_min_len(CHUNK).for_each(|(i, p)| {
        let block = *matrix.diagonal(i);
        *p = block.try_inverse().unwrap_or_else(|| Matrix3::from_diagonal(&block.diagonal().map(|d| 1.0 / d)));
    });
    let filter = |i: usize, v: Vector3<f64>| constraints[i].filter(v);
    let PcgWorkspace { residual, direction, product, preconditioned, inverse_diagonal, partials } = ws;
    // The squared norm of a filtered vector `v`, weighted by the inverse
    // diagonal: `Σᵢ norm_term(i, vᵢ)`.
    let norm_term = |i: usize, v: &Vector3<f64>| {
        let vi = filter(i, *v);
        vi.dot(&(inverse_diagonal[i] * vi))
    };
    let norm = |v: &[Vector3<f64>], partials: &mut Vec<f64>| parallel::sum(n, partials, |i| norm_term(i, &v[i]));
    let reference = norm(b, partials).max(norm(typical, partials));
    let threshold = settings.tolerance * settings.tolerance * reference;

    // Start from the given guess or from its prescribed part alone, whichever
    // leaves the smaller residual: the last step's answer is a good guess for a
    // cloth at rest and a poor one for a swinging cloth.
    par_each(preconditioned, |i, cold| *cold = x[i] - filter(i, x[i]));
    let guesses = (&*x, &preconditioned[..]);
    let (mut measure, cold_measure) = parallel::set_and_sum_both(
        (residual, direction),
        partials,
        |i, r, cold_r| {
            let (product, cold_product) = matrix.row_products(guesses, i);
            (*r, *cold_r) = (filter(i, b[i] - product), filter(i, b[i] - cold_product));
        },
        (norm_term, norm_term),
    );
    if cold_measure < measure {
        x.copy_from_slice(preconditioned);
        residual.copy_from_slice(direction);
        measure = cold_measure;
    }
    let mut delta = precondition(&mut preconditioning, inverse_diagonal, constraints, residual, direction, partials);
    let mut iterations = 0;
    // Each iteration is four passes over the particles besides the
    // preconditioner: the product with the direction and its curvature, the
    // residual and its norm, the preconditioned residual's dot with the
    // residual, and the step of `x` with the next direction.
    while measure > threshold && iterations < settings.max_iterations {
        let curvature = parallel::set_and_sum(
            product,
            partials,
            |i, q| *q = filter(i, matrix.row_product(direction, i)),
            |i, q| direction[i].dot(q),
        );
        if curvature <= 0.0 {
            break;
        }
        let alpha = delta / curvature;
        iterations += 1;
        measure = parallel::set_and_sum(residual, partials, |i, r| *r -= product[i] * alpha, norm_term);
        if measure <= threshold {
            par_each(x, |i, xi| *xi += direction[i] * alpha);
            break;
        }
        let previous = delta;
        delta = precondition(&mut preconditioning, inverse_diagonal, constraints, residual, preconditioned, partials);
        let beta = delta / previous;
        step_and_turn(x, direction, alpha, |i, d| filter(i, preconditioned[i] + d * beta));
    }
    let relative = if reference > 0.0 { (measure / reference).max(0.0).sqrt() } else { 0.0 };
    PcgReport { iterations, relative_residual: relative, converged: measure <= threshold }
}

/// `x ← x + α d`, then `d ← next(i, d)`, in one pass.
fn step_and_turn(
    x: &mut [Vector3<f64>],
    direction: &mut [Vector3<f64>],
    alpha: f64,
    next: impl Fn(usize, Vector3<f64>) -> Vector3<f64> + Sync,
) {
    x.par_chunks_mut(CHUNK).zip(direction.par_chunks_mut(CHUNK)).enumerate().for_each(|(c, (xs, ds))| {
        for (k, (xi, di)) in xs.iter_mut().zip(ds.iter_mut()).enumerate() {
            *xi += *di * alpha;
            *di = next(c * CHUNK + k, *di);
        }
    });
}

/// `z = S B r`: the preconditioner applied to `r`, then filtered; returns
/// `r · z`.
fn precondition(
    preconditioning: &mut Preconditioning,
    inverse_diagonal: &[Matrix3<f64>],
    constraints: &[Constraint],
    r: &[Vector3<f64>],
    z: &mut [Vector3<f64>],
    partials: &mut Vec<f64>,
) -> f64 {
    let dot = |i: usize, zi: &Vector3<f64>| r[i].dot(zi);
    let filter_in_place = |i: usize, zi: &mut Vector3<f64>| *zi = constraints[i].filter(*zi);
    match preconditioning {
        Preconditioning::BlockJacobi => {
            parallel::set_and_sum(z, partials, |i, zi| *zi = constraints[i].filter(inverse_diagonal[i] * r[i]), dot)
        }
        Preconditioning::Multigrid(multigrid) => {
            multigrid.apply(r, z);
            parallel::set_and_sum(z, partials, filter_in_place, dot)
        }
        Preconditioning::Cholesky(cholesky) => {
            cholesky.apply(r, z);
            parallel::set_and_sum(z, partials, filter_in_place, dot)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::sparse::SystemPattern;
    use nalgebra::{DMatrix, DVector};

    use crate::sim::test_grid::ring_positions;

    /// The couplings of a ring of `n` particles to ±1 and ±2.
    fn ring_pairs(n: usize) -> Vec<[u32; 2]> {
        (0..n as u32).flat_map(|i| [[i, (i + 1) % n as u32], [i, (i + 2) % n as u32]]).collect()
    }

    /// A random SPD block matrix on a ring of `n` particles (couplings to ±1, ±2).
    fn ring_system(n: usize) -> (BlockPattern, Vec<Matrix3<f64>>, Vec<Vector3<f64>>) {
        let pattern = BlockPattern::new(n, ring_pairs(n));
        let mut a = vec![Matrix3::zeros(); pattern.stored_blocks()];
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5
        };
        for i in 0..n {
            for j in [(i + 1) % n, (i + 2) % n] {
                // A spring-like PSD coupling K = u uᵀ s.
                let u = Vector3::new(rand(), rand(), rand());
                let k = u * u.transpose() * 10.0;
                for (r, c, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                    a[pattern.slot(r, c).unwrap()] += k * sign;
                }
            }
            a[pattern.diagonal(i)] += Matrix3::identity() * 0.05;
        }
        let b = (0..n).map(|_| Vector3::new(rand(), rand(), rand())).collect();
        (pattern, a, b)
    }

    fn dense(pattern: &BlockPattern, a: &[Matrix3<f64>]) -> DMatrix<f64> {
        let n = pattern.rows();
        let mut m = DMatrix::zeros(3 * n, 3 * n);
        for i in 0..n {
            for s in pattern.row(i) {
                m.view_mut((3 * i, 3 * pattern.column(s)), (3, 3)).copy_from(&a[s]);
            }
        }
        m
    }

    /// The matrix of full blocks `a` on `pattern`.
    fn blocks<'a>(pattern: &'a SystemPattern, a: &'a [Matrix3<f64>]) -> SystemMatrix<'a> {
        SystemMatrix { pattern, blocks: a, isotropic_scale: &[] }
    }

    /// A block-Jacobi solve of `A x = b` with every row free.
    fn solve_free(
        pattern: &BlockPattern,
        a: &[Matrix3<f64>],
        b: &[Vector3<f64>],
        x: &mut [Vector3<f64>],
        settings: PcgSettings,
    ) -> PcgReport {
        let (typical, free) = (vec![Vector3::zeros(); b.len()], vec![Constraint::Free; b.len()]);
        let whole = SystemPattern::blocks_only(pattern.clone());
        let system =
            FilteredSystem { matrix: blocks(&whole, a), b, typical: &typical, constraints: &free, positions: &[] };
        solve(system, x, settings, Preconditioning::BlockJacobi, &mut PcgWorkspace::default())
    }

    const TIGHT: PcgSettings =
        PcgSettings { tolerance: 1e-12, max_iterations: 1000, preconditioner: PreconditionerKind::BlockJacobi };

    #[test]
    fn pcg_matches_a_dense_cholesky_solve() {
        let (pattern, a, b) = ring_system(20);
        let mut x = vec![Vector3::zeros(); 20];
        let report = solve_free(&pattern, &a, &b, &mut x, TIGHT);
        assert!(report.converged, "{report:?}");
        let rhs = DVector::from_iterator(60, b.iter().flat_map(|v| v.iter().copied()));
        let exact = dense(&pattern, &a).cholesky().unwrap().solve(&rhs);
        for (i, xi) in x.iter().enumerate() {
            assert!((xi - exact.fixed_rows::<3>(3 * i)).norm() < 1e-8 * exact.norm());
        }
    }

    #[test]
    fn constrained_rows_keep_their_prescribed_part_and_the_rest_solve_the_system() {
        let n = 12;
        let (pattern, a, b) = ring_system(n);
        let mut constraints = vec![Constraint::Free; n];
        constraints[3] = Constraint::Fixed;
        constraints[7] = Constraint::Fixed;
        let normal = Vector3::new(1.0, 2.0, 2.0) / 3.0;
        constraints[9] = Constraint::Normal(normal);
        let prescribed = Vector3::new(0.25, -1.5, 3.0);
        let mut x = vec![Vector3::zeros(); n];
        x[3] = prescribed;
        x[9] = normal * 0.5;
        let whole = SystemPattern::blocks_only(pattern);
        solve(
            FilteredSystem {
                matrix: blocks(&whole, &a),
                b: &b,
                typical: &vec![Vector3::zeros(); n],
                constraints: &constraints,
                positions: &[],
            },
            &mut x,
            TIGHT,
            Preconditioning::BlockJacobi,
            &mut PcgWorkspace::default(),
        );
        assert_eq!(x[3], prescribed);
        assert_eq!(x[7], Vector3::zeros());
        assert!((x[9].dot(&normal) - 0.5).abs() < 1e-12, "the normal component is kept");
        // Every row satisfies its equation in the directions it was free in.
        let mut ax = vec![Vector3::zeros(); n];
        blocks(&whole, &a).multiply(&x, &mut ax);
        for i in 0..n {
            assert!(constraints[i].filter(ax[i] - b[i]).norm() < 1e-8, "row {i}");
        }
    }

    #[test]
    fn loose_tolerance_stops_early_and_says_so() {
        let (pattern, a, b) = ring_system(40);
        let mut x = vec![Vector3::zeros(); 40];
        let settings =
            PcgSettings { tolerance: 1e-2, max_iterations: 1000, preconditioner: PreconditionerKind::BlockJacobi };
        let report = solve_free(&pattern, &a, &b, &mut x, settings);
        assert!(report.converged && report.relative_residual <= 1e-2);
        let capped =
            PcgSettings { tolerance: 1e-14, max_iterations: 2, preconditioner: PreconditionerKind::BlockJacobi };
        let mut x = vec![Vector3::zeros(); 40];
        let report = solve_free(&pattern, &a, &b, &mut x, capped);
        assert_eq!(report.iterations, 2);
        assert!(!report.converged);
    }

    #[test]
    fn a_typical_right_hand_side_bounds_the_precision_asked_for() {
        let (pattern, a, b) = ring_system(40);
        let tiny: Vec<_> = b.iter().map(|v| v * 1e-9).collect();
        let settings =
            PcgSettings { tolerance: 1e-3, max_iterations: 1000, preconditioner: PreconditionerKind::BlockJacobi };
        let mut x = vec![Vector3::zeros(); 40];
        let free = [Constraint::Free; 40];
        let whole = SystemPattern::blocks_only(pattern);
        let report = solve(
            FilteredSystem { matrix: blocks(&whole, &a), b: &tiny, typical: &b, constraints: &free, positions: &[] },
            &mut x,
            settings,
            Preconditioning::BlockJacobi,
            &mut PcgWorkspace::default(),
        );
        assert_eq!(report.iterations, 0, "a residual of 1e-9 of the typical size is already converged");
    }

    /// The kept Cholesky factor: a fresh one solves in one or two; kept
    /// for a slightly different matrix it still converges within its budget
    /// without a new factor; for a very different one it is rebuilt, and the
    /// answer matches a dense solve either way.
    #[test]
    fn lagged_cholesky_is_kept_while_it_works_and_rebuilt_when_not() {
        let n = 30;
        let (pattern, a, b) = ring_system(n);
        let settings =
            PcgSettings { tolerance: 1e-8, max_iterations: 1000, preconditioner: PreconditionerKind::Cholesky };
        let free = vec![Constraint::Free; n];
        let mut preconditioner =
            Preconditioner::new(settings.preconditioner, &pattern, &ring_pairs(n), &ring_positions(n)).unwrap();
        let whole = SystemPattern::blocks_only(pattern.clone());
        let mut run = |a: &[Matrix3<f64>]| {
            let mut x = vec![Vector3::zeros(); n];
            let system =
                FilteredSystem { matrix: blocks(&whole, a), b: &b, typical: &b, constraints: &free, positions: &[] };
            let (report, factors) =
                preconditioner.solve(system, &mut x, settings, &mut PcgWorkspace::default(), SystemChange::Matrix);
            let rhs = DVector::from_iterator(3 * n, b.iter().flat_map(|v| v.iter().copied()));
            let exact = dense(&pattern, a).cholesky().unwrap().solve(&rhs);
            let error = (0..n).map(|i| (x[i] - exact.fixed_rows::<3>(3 * i)).norm()).fold(0.0, f64::max);
            assert!(report.converged && error < 1e-6 * exact.norm(), "{report:?}, error {error}");
            (report.iterations, factors)
        };
        // A single-precision factor is good to ~1e-4 here: two iterations
        // reach 1e-8.
        let (iterations, factors) = run(&a);
        assert_eq!(factors, 1);
        assert!(iterations <= 2, "a fresh factor solves in one or two iterations: {iterations}");
        let nudged: Vec<_> = a.iter().map(|m| m * 1.0001).collect();
        let (iterations, factors) = run(&nudged);
        assert_eq!(factors, 0, "a factor of a nearly equal matrix is kept");
        assert!(iterations <= STALE_BUDGET);
        let mut changed = a.clone();
        for i in (0..n).step_by(2) {
            changed[pattern.diagonal(i)] *= 50.0;
        }
        let (iterations, factors) = run(&changed);
        assert_eq!(factors, 1, "a factor of a very different matrix is rebuilt");
        assert!(iterations <= STALE_BUDGET + 2, "the stale try, then one or two iterations: {iterations}");
    }

    /// A solve of the same matrix with two particles newly held along a
    /// normal (contacts found after a solve) keeps the factor, reaches the
    /// answer a fresh factor gives, and keeps the held components.
    #[test]
    fn new_contacts_are_solved_with_the_kept_factor() {
        let n = 30;
        let (pattern, a, b) = ring_system(n);
        let mut changed = a.clone();
        for i in (0..n).step_by(2) {
            changed[pattern.diagonal(i)] *= 50.0;
        }
        let settings =
            PcgSettings { tolerance: 1e-8, max_iterations: 1000, preconditioner: PreconditionerKind::Cholesky };
        let preconditioner =
            || Preconditioner::new(settings.preconditioner, &pattern, &ring_pairs(n), &ring_positions(n)).unwrap();
        let whole = SystemPattern::blocks_only(pattern.clone());
        let system = |a, constraints| FilteredSystem {
            matrix: blocks(&whole, a),
            b: &b,
            typical: &b,
            constraints,
            positions: &[],
        };
        let ws = &mut PcgWorkspace::default();
        let mut kept = preconditioner();
        let mut x = vec![Vector3::zeros(); n];
        let free = vec![Constraint::Free; n];
        kept.solve(system(&a, &free), &mut x, settings, ws, SystemChange::Matrix);
        // A stale factor fails on the changed matrix, which is factored: stale
        // factors are not tried for a while, but this one is current.
        let (_, factors) = kept.solve(system(&changed, &free), &mut x, settings, ws, SystemChange::Matrix);
        assert_eq!(factors, 1);

        let normal = Vector3::new(1.0, 2.0, 2.0) / 3.0;
        let mut held = free.clone();
        for i in [4, 17] {
            held[i] = Constraint::Normal(normal);
            x[i] = held[i].filter(x[i]);
        }
        let mut fresh_x = x.clone();
        let (report, factors) = kept.solve(system(&changed, &held), &mut x, settings, ws, SystemChange::Constraints);
        assert!(report.converged && report.iterations <= RESOLVE_BUDGET, "{report:?}");
        assert_eq!(factors, 0, "the kept factor serves the new contacts");
        let fresh = preconditioner().solve(system(&changed, &held), &mut fresh_x, settings, ws, SystemChange::Matrix);
        assert!(fresh.0.converged);
        let scale = fresh_x.iter().map(|v| v.norm()).fold(0.0, f64::max);
        let error = x.iter().zip(&fresh_x).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max);
        assert!(error < 1e-6 * scale, "error {error} of {scale}");
        assert!([4, 17].iter().all(|&i| normal.dot(&x[i]).abs() < 1e-12 * scale));
    }

    /// A system too stiff for a single-precision factor (masses 1e-9 of the
    /// couplings) is still solved to the tolerance, and moves the simulation
    /// to double-precision factors.
    #[test]
    fn stiff_systems_get_double_precision_factors() {
        let n = 30;
        let (pattern, mut a, b) = ring_system(n);
        for i in 0..n {
            a[pattern.diagonal(i)] -= Matrix3::identity() * (1.0 - 1e-9);
        }
        let settings =
            PcgSettings { tolerance: 1e-10, max_iterations: 1000, preconditioner: PreconditionerKind::Cholesky };
        let free = vec![Constraint::Free; n];
        let mut preconditioner =
            Preconditioner::new(settings.preconditioner, &pattern, &ring_pairs(n), &ring_positions(n)).unwrap();
        let mut x = vec![Vector3::zeros(); n];
        let whole = SystemPattern::blocks_only(pattern);
        let system =
            FilteredSystem { matrix: blocks(&whole, &a), b: &b, typical: &b, constraints: &free, positions: &[] };
        let (report, _) =
            preconditioner.solve(system, &mut x, settings, &mut PcgWorkspace::default(), SystemChange::Matrix);
        assert!(report.converged, "{report:?}");
        let Preconditioner::Cholesky(cholesky) = &preconditioner else { unreachable!() };
        assert!(!cholesky.is_single_precision(), "{report:?}");
    }
}
