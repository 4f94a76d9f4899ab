//! Backward Euler for the mass-spring cloth (PAPER eq. 3-5, Baraff and Witkin
//! 1998): one linearised implicit step
//!
//! ```text
//! A Δv = b,   A = M − h ∂f/∂v − h² ∂f/∂x,   b = h (f₀ + h ∂f/∂x v₀)
//! ```
//!
//! with forces from springs (elastic and damping), bending hinges, gravity and
//! air damping (`f = −d m v`). The matrix is assembled into a fixed block
//! pattern: each spring's 3×3 block is computed once, then every row gathers its
//! springs and hinges in a fixed order, so assembly is parallel and
//! deterministic.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::cloth::Cloth;
use super::forces::{SpringStiffness, spring_damping_matrix, spring_force, spring_stiffness_definite};
use super::parallel::CHUNK;
use super::sparse::{BlockPattern, SystemMatrix, SystemPattern};

/// Per-particle coefficients, refreshed from the fabrics whenever they change.
#[derive(Clone, Debug, Default)]
pub struct ParticleCoefficients {
    /// Mass, kg.
    pub mass: Vec<f64>,
    /// Air damping, 1/s.
    pub air_damping: Vec<f64>,
    /// Flexural rigidity of the particle's garment, N·m.
    pub bend_stiffness: Vec<f64>,
    /// Bending damping of the particle's garment, N·m·s.
    pub bend_damping: Vec<f64>,
    /// Gravity, m/s².
    pub gravity: Vec<Vector3<f64>>,
}

/// Per-spring coefficients, refreshed from the fabrics whenever they change.
#[derive(Clone, Debug, Default)]
pub struct SpringCoefficients {
    /// Stiffness, N/m.
    pub stiffness: Vec<SpringStiffness>,
    /// Damping, N·s/m.
    pub damping: Vec<f64>,
}

impl ParticleCoefficients {
    /// Coefficients of every particle of `cloth`.
    pub fn new(cloth: &Cloth) -> Self {
        let n = cloth.vertex_count();
        let per_vertex =
            |f: &dyn Fn(&super::fabric::Fabric) -> f64| (0..n).map(|i| f(cloth.fabric_of(i))).collect::<Vec<f64>>();
        ParticleCoefficients {
            mass: cloth.mass.clone(),
            air_damping: per_vertex(&|f| f.air_damping_per_s),
            bend_stiffness: per_vertex(&|f| f.bend_stiffness_n_m),
            bend_damping: per_vertex(&|f| f.bend_damping_n_m_s),
            gravity: (0..n).map(|i| Vector3::from(cloth.fabric_of(i).gravity_m_per_s2)).collect(),
        }
    }
}

impl SpringCoefficients {
    /// Coefficients of every spring of `cloth`.
    pub fn new(cloth: &Cloth) -> Self {
        let (stiffness, damping) = cloth
            .garments
            .iter()
            .flat_map(|g| g.springs.clone().map(move |s| cloth.spring_coefficients(s, &g.fabric)))
            .unzip();
        SpringCoefficients { stiffness, damping }
    }
}

/// The fixed structure of the system: block pattern, which springs land in
/// which block, and the constant bending couplings.
#[derive(Clone, Debug)]
pub struct SystemLayout {
    /// Pattern of `A`: full blocks on the diagonal and where springs join two
    /// particles, multiples of the identity where only hinges do.
    pub pattern: SystemPattern,
    /// Row of each full block.
    block_row: Vec<u32>,
    /// Per full block, the start of its entries in `block_springs`.
    block_spring_start: Vec<usize>,
    /// Springs contributing to each full block, as `2·spring + end`: for a
    /// diagonal block, `end` says which end of the spring the row's particle is.
    block_springs: Vec<u32>,
    /// Per full block, its `bend_coupling`, 1/m².
    block_bend_coupling: Vec<f64>,
    /// Per slot of `pattern.all`, `Σ wₐ w_b` over the hinges coupling the row
    /// and column particles, 1/m² (the bending matrix is this times the
    /// rigidity, ⊗ I).
    pub bend_coupling: Vec<f64>,
}

impl SystemLayout {
    /// Builds the layout of `cloth`.
    pub fn new(cloth: &Cloth) -> Self {
        let n = cloth.vertex_count();
        let hinge_pairs =
            cloth.hinge_vertices.iter().flat_map(|h| (0..4).flat_map(move |a| (a + 1..4).map(move |b| [h[a], h[b]])));
        let all = BlockPattern::new(n, cloth.spring_ends.iter().copied().chain(hinge_pairs));

        let mut bend_coupling = vec![0.0; all.stored_blocks()];
        for (ids, w) in cloth.hinge_vertices.iter().zip(&cloth.hinge_weights) {
            for a in 0..4 {
                for b in 0..4 {
                    if let Some(slot) = all.slot(ids[a] as usize, ids[b] as usize) {
                        bend_coupling[slot] += w[a] * w[b];
                    }
                }
            }
        }
        let pattern = SystemPattern::new(all, &cloth.spring_ends, |slot| bend_coupling[slot]);
        let blocks = &pattern.blocks;

        let mut per_block: Vec<Vec<u32>> = vec![Vec::new(); blocks.stored_blocks()];
        for (s, &[a, b]) in cloth.spring_ends.iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            let code = |end: u32| 2 * s as u32 + end;
            per_block[blocks.diagonal(a)].push(code(0));
            per_block[blocks.diagonal(b)].push(code(1));
            for (row, col) in [(a, b), (b, a)] {
                if let Some(block) = blocks.slot(row, col) {
                    per_block[block].push(code(0));
                }
            }
        }
        let mut block_spring_start = Vec::with_capacity(per_block.len() + 1);
        block_spring_start.push(0);
        for list in &per_block {
            block_spring_start.push(block_spring_start.last().copied().unwrap_or(0) + list.len());
        }
        let block_springs = per_block.concat();
        let block_row = (0..n).flat_map(|i| blocks.row(i).map(move |_| i as u32)).collect();
        let all = &pattern.all;
        let block_bend_coupling = (0..n)
            .flat_map(|i| blocks.row(i).map(move |b| (i, blocks.column(b))))
            .map(|(i, j)| all.slot(i, j).map_or(0.0, |slot| bend_coupling[slot]))
            .collect();
        SystemLayout { pattern, block_row, block_spring_start, block_springs, block_bend_coupling, bend_coupling }
    }

    fn springs_of_block(&self, block: usize) -> &[u32] {
        &self.block_springs[self.block_spring_start[block]..self.block_spring_start[block + 1]]
    }
}

/// Buffers the assembly writes: the matrix, the right-hand side, and each
/// spring's block and force term.
#[derive(Clone, Debug, Default)]
pub struct SystemBuffers {
    /// The full blocks of `A`, aligned with the layout's `pattern.blocks`.
    pub matrix: Vec<Matrix3<f64>>,
    /// Each row's scale of its isotropic (hinge-only) blocks: `h² k_b + h c_b`
    /// of its particle, N/m·m² (times a coupling, kg).
    pub isotropic_scale: Vec<f64>,
    /// Right-hand side `b`, N·s.
    pub rhs: Vec<Vector3<f64>>,
    spring_block: Vec<Matrix3<f64>>,
    spring_term: Vec<Vector3<f64>>,
}

impl SystemBuffers {
    /// The assembled `A`, on the layout's pattern.
    pub fn system_matrix<'a>(&'a self, layout: &'a SystemLayout) -> SystemMatrix<'a> {
        SystemMatrix { pattern: &layout.pattern, blocks: &self.matrix, isotropic_scale: &self.isotropic_scale }
    }
}

/// The state and step an assembly is for.
pub struct AssemblyInput<'a> {
    /// Positions, m.
    pub x: &'a [Vector3<f64>],
    /// Velocities, m/s.
    pub v: &'a [Vector3<f64>],
    /// Step, s.
    pub h: f64,
}

/// Computes every spring's system block `h C + h² K` and force term
/// `f − h K (v₀ − v₁)` (the spring's share of `f₀ + h ∂f/∂x v₀` on its first end).
pub fn evaluate_springs(cloth: &Cloth, coeffs: &SpringCoefficients, input: &AssemblyInput, out: &mut SystemBuffers) {
    let m = cloth.spring_count();
    out.spring_block.resize(m, Matrix3::zeros());
    out.spring_term.resize(m, Vector3::zeros());
    let h = input.h;
    out.spring_block.par_iter_mut().zip(out.spring_term.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(
        |(s, (block, term))| {
            let [a, b] = cloth.spring_ends[s].map(|i| i as usize);
            let d = input.x[a] - input.x[b];
            let dv = input.v[a] - input.v[b];
            let (k, c) = (coeffs.stiffness[s], coeffs.damping[s]);
            let stiffness = spring_stiffness_definite(&d, cloth.rest_length[s], k);
            *block = spring_damping_matrix(&d, c) * h + stiffness * (h * h);
            *term = spring_force(&d, &dv, cloth.rest_length[s], k, c) - stiffness * dv * h;
        },
    );
}

/// Fills `A` (one parallel pass over block slots) and `b` (one over rows) from
/// the spring terms, the bending couplings, masses, gravity and air damping.
pub fn assemble(
    layout: &SystemLayout,
    particles: &ParticleCoefficients,
    input: &AssemblyInput,
    out: &mut SystemBuffers,
) {
    let (blocks, all) = (&layout.pattern.blocks, &layout.pattern.all);
    let h = input.h;
    let bend_scale = |i: usize| h * h * particles.bend_stiffness[i] + h * particles.bend_damping[i];
    out.matrix.resize(blocks.stored_blocks(), Matrix3::zeros());
    out.isotropic_scale.resize(all.rows(), 0.0);
    out.rhs.resize(all.rows(), Vector3::zeros());
    let SystemBuffers { matrix, isotropic_scale, rhs, spring_block, spring_term } = out;

    matrix.par_iter_mut().enumerate().with_min_len(CHUNK).for_each(|(block, value)| {
        let i = layout.block_row[block] as usize;
        let springs: Matrix3<f64> =
            layout.springs_of_block(block).iter().map(|&code| spring_block[(code / 2) as usize]).sum();
        let bend = Matrix3::identity() * (bend_scale(i) * layout.block_bend_coupling[block]);
        *value = if block == blocks.diagonal(i) {
            let (m, air) = (particles.mass[i], particles.air_damping[i]);
            Matrix3::identity() * (m * (1.0 + h * air)) + springs + bend
        } else {
            bend - springs
        };
    });
    isotropic_scale.par_iter_mut().enumerate().with_min_len(CHUNK).for_each(|(i, scale)| *scale = bend_scale(i));

    rhs.par_iter_mut().enumerate().with_min_len(CHUNK).for_each(|(i, bi)| {
        let (m, air) = (particles.mass[i], particles.air_damping[i]);
        let (kb, cb) = (particles.bend_stiffness[i], particles.bend_damping[i]);
        let mut force = particles.gravity[i] * m - input.v[i] * (air * m);
        for &code in layout.springs_of_block(blocks.diagonal(i)) {
            let term = spring_term[(code / 2) as usize];
            force += if code % 2 == 0 { term } else { -term };
        }
        let qx = all.scalar_row_product(&layout.bend_coupling, i, input.x);
        let qv = all.scalar_row_product(&layout.bend_coupling, i, input.v);
        force -= qx * kb + qv * (cb + h * kb);
        *bi = force * h;
    });
}

/// Net force on every particle (springs with damping, bending with damping,
/// gravity, air damping), N. For diagnostics such as reaction forces at pins.
pub fn net_forces(
    cloth: &Cloth,
    layout: &SystemLayout,
    particles: &ParticleCoefficients,
    springs: &SpringCoefficients,
    x: &[Vector3<f64>],
    v: &[Vector3<f64>],
) -> Vec<Vector3<f64>> {
    let mut forces: Vec<Vector3<f64>> = (0..x.len())
        .map(|i| {
            let all = &layout.pattern.all;
            let bend = all.scalar_row_product(&layout.bend_coupling, i, x) * particles.bend_stiffness[i]
                + all.scalar_row_product(&layout.bend_coupling, i, v) * particles.bend_damping[i];
            (particles.gravity[i] - v[i] * particles.air_damping[i]) * particles.mass[i] - bend
        })
        .collect();
    for (s, &[a, b]) in cloth.spring_ends.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        let f = spring_force(
            &(x[a] - x[b]),
            &(v[a] - v[b]),
            cloth.rest_length[s],
            springs.stiffness[s],
            springs.damping[s],
        );
        forces[a] += f;
        forces[b] -= f;
    }
    forces
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::sim::fabric::tests::cotton;

    /// The assembled `A` equals `M − h ∂f/∂v − h² ∂f/∂x` and `b` equals
    /// `h (f + h ∂f/∂x v)`, with both derivatives taken by finite differences of
    /// [`net_forces`] on a stretched, moving cloth (where the definite and exact
    /// spring Jacobians agree).
    #[test]
    fn assembled_system_matches_finite_difference_derivatives_of_the_forces() {
        let mesh = generate::grid(0.3, 4);
        let cloth = Cloth::new([(&mesh, cotton())]);
        let layout = SystemLayout::new(&cloth);
        let particles = ParticleCoefficients::new(&cloth);
        let springs = SpringCoefficients::new(&cloth);
        let n = cloth.vertex_count();
        let x: Vec<Vector3<f64>> = cloth
            .rest_positions
            .iter()
            .enumerate()
            .map(|(i, p)| p * 1.02 + Vector3::new(0.0, 0.01 * (i as f64 * 1.3).sin(), 0.0))
            .collect();
        let v: Vec<Vector3<f64>> =
            (0..n).map(|i| Vector3::new((i as f64).cos(), 0.3, (i as f64 * 0.7).sin())).collect();
        let h = 0.01;
        let mut buffers = SystemBuffers::default();
        let input = AssemblyInput { x: &x, v: &v, h };
        evaluate_springs(&cloth, &springs, &input, &mut buffers);
        assemble(&layout, &particles, &input, &mut buffers);

        let f = |x: &[Vector3<f64>], v: &[Vector3<f64>]| net_forces(&cloth, &layout, &particles, &springs, x, v);
        let eps = 1e-7;
        let f0 = f(&x, &v);
        // (∂f/∂x) v as a directional derivative. The damping force's position
        // derivative is left out of the system, so differentiate the undamped forces.
        let shifted: Vec<_> = x.iter().zip(&v).map(|(xi, vi)| xi + vi * eps).collect();
        let back: Vec<_> = x.iter().zip(&v).map(|(xi, vi)| xi - vi * eps).collect();
        let mut undamped = springs.clone();
        undamped.damping.iter_mut().for_each(|c| *c = 0.0);
        let mut bare = particles.clone();
        bare.bend_damping.iter_mut().for_each(|c| *c = 0.0);
        let g = |x: &[Vector3<f64>]| net_forces(&cloth, &layout, &bare, &undamped, x, &v);
        let (gp, gm) = (g(&shifted), g(&back));
        for i in 0..n {
            let kv = (gp[i] - gm[i]) / (2.0 * eps);
            let expected = (f0[i] + kv * h) * h;
            assert!((buffers.rhs[i] - expected).norm() < 1e-6 * (1.0 + expected.norm()), "row {i}");
        }

        // Column j of A: M e_j − h ∂f/∂v e_j − h² ∂f/∂x e_j, by perturbing particle j.
        for j in [0, 5, 10] {
            for axis in 0..3 {
                let e = Vector3::ith(axis, eps);
                let perturb = |p: &[Vector3<f64>], sign: f64| {
                    let mut q = p.to_vec();
                    q[j] += e * sign;
                    q
                };
                let dfdx: Vec<_> = g(&perturb(&x, 1.0))
                    .iter()
                    .zip(g(&perturb(&x, -1.0)))
                    .map(|(a, b)| (a - b) / (2.0 * eps))
                    .collect();
                let dfdv: Vec<_> = f(&x, &perturb(&v, 1.0))
                    .iter()
                    .zip(f(&x, &perturb(&v, -1.0)))
                    .map(|(a, b)| (a - b) / (2.0 * eps))
                    .collect();
                for i in 0..n {
                    let mass = if i == j { Vector3::ith(axis, particles.mass[i]) } else { Vector3::zeros() };
                    let expected = mass - dfdv[i] * h - dfdx[i] * (h * h);
                    let matrix = buffers.system_matrix(&layout);
                    let got = layout
                        .pattern
                        .all
                        .slot(i, j)
                        .map_or(Vector3::zeros(), |s| matrix.block(i, s).column(axis).into());
                    assert!((got - expected).norm() < 1e-6, "A[{i},{j}] col {axis}: {got} vs {expected}");
                }
            }
        }
    }
}
