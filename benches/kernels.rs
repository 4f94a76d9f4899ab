//! Micro-benchmarks of the hot kernels, on the standard `drape_sphere` cloth
//! (64 × 64 vertices) settled on its sphere after 0.5 s, and on the demo body:
//!
//! - force and Jacobian assembly (springs, then the block matrix and right-hand side),
//! - one preconditioned conjugate-gradient iteration, and the Cholesky factor it uses
//!   and one application of it (its two triangular solves),
//! - the swept-box hierarchy's refit and its self-collision broad phase,
//! - continuous collision detection of one vertex-triangle and one edge-edge pair,
//! - skinning the walking body at one time.
//!
//! Run with `cargo bench --bench kernels` (release profile; criterion reports
//! each kernel's time with its confidence interval and the change since the
//! last run).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;

use drape::io::fbx::read_fbx;
use drape::scene::Scene;
use drape::sim::Simulator;
use drape::sim::cholesky::LaggedCholesky;
use drape::sim::collision::bvh::{Box3, SweptBvh};
use drape::sim::collision::ccd::{self, Path};
use drape::sim::constraint::Constraint;
use drape::sim::implicit::{
    AssemblyInput, ParticleCoefficients, SpringCoefficients, SystemBuffers, SystemLayout, assemble, evaluate_springs,
};
use drape::sim::pcg::{self, FilteredSystem, PcgSettings, PcgWorkspace, PreconditionerKind, Preconditioning};

/// Steps before measuring: 0.5 s at the scene's 2 steps per 1/30 s frame, the
/// cloth settled over the sphere with folds.
const SETTLING_STEPS: usize = 30;
/// Collision thickness the boxes are grown by, m.
const THICKNESS_M: f64 = 0.0025;

/// `drape_sphere` after [`SETTLING_STEPS`] steps, and its step (s).
fn draped_simulator() -> (Simulator, f64) {
    let scene = Scene::load(&drape::bench::standard_scene("drape_sphere")).expect("the standard scene loads");
    let mut simulator = scene.simulator().expect("the standard scene simulates");
    for _ in 0..SETTLING_STEPS {
        simulator.step(scene.step_duration()).expect("the standard scene steps");
    }
    (simulator, scene.step_duration())
}

/// Every triangle's box swept from `start` to `end`, grown by the thickness.
fn swept_triangle_boxes(triangles: &[[u32; 3]], start: &[Vector3<f64>], end: &[Vector3<f64>], out: &mut Vec<Box3>) {
    out.clear();
    out.extend(triangles.iter().map(|t| {
        t.iter().fold(Box3::empty(), |b, &i| b.with(&start[i as usize]).with(&end[i as usize])).grown(THICKNESS_M)
    }));
}

/// Assembly, the factor and one PCG iteration on the settled cloth. The
/// solve's constraints are all free (the contacts' filter changes the
/// factor's values, not its cost).
fn solver(c: &mut Criterion) {
    let (simulator, step_s) = draped_simulator();
    let cloth = simulator.cloth();
    let n = cloth.vertex_count();
    let layout = SystemLayout::new(cloth);
    let (particles, springs) = (ParticleCoefficients::new(cloth), SpringCoefficients::new(cloth));
    let mut buffers = SystemBuffers::default();
    let input = AssemblyInput { x: simulator.positions(), v: simulator.velocities(), h: step_s };
    c.bench_function(&format!("springs: forces and Jacobians (drape_sphere, {n} vertices)"), |b| {
        b.iter(|| evaluate_springs(cloth, &springs, black_box(&input), &mut buffers))
    });
    c.bench_function("assembly: block matrix and right-hand side (drape_sphere)", |b| {
        b.iter(|| assemble(&layout, &particles, black_box(&input), &mut buffers))
    });

    // Assembled here too: criterion may skip the benches above (a filter).
    evaluate_springs(cloth, &springs, &input, &mut buffers);
    assemble(&layout, &particles, &input, &mut buffers);
    let constraints = vec![Constraint::Free; n];
    let typical: Vec<Vector3<f64>> =
        particles.mass.iter().map(|m| Vector3::new(0.0, -9.81 * m * step_s, 0.0)).collect();
    let mut cholesky = LaggedCholesky::new(&layout.pattern.all, &cloth.spring_ends, &cloth.rest_positions)
        .expect("the pattern analyses");

    c.bench_function("cholesky: numeric factor (drape_sphere)", |b| {
        b.iter(|| cholesky.refactor(black_box(buffers.system_matrix(&layout)), &constraints))
    });

    cholesky.refactor(buffers.system_matrix(&layout), &constraints).expect("the system is positive definite");
    let mut z = vec![Vector3::zeros(); n];
    c.bench_function("cholesky: one application, both triangular solves (drape_sphere)", |b| {
        b.iter(|| cholesky.apply(black_box(&buffers.rhs), &mut z))
    });
    let system = FilteredSystem {
        matrix: buffers.system_matrix(&layout),
        b: &buffers.rhs,
        typical: &typical,
        constraints: &constraints,
        positions: simulator.positions(),
    };
    let one_iteration = PcgSettings { tolerance: 0.0, max_iterations: 1, preconditioner: PreconditionerKind::Cholesky };
    let mut workspace = PcgWorkspace::default();
    let mut x = vec![Vector3::zeros(); n];
    c.bench_function("pcg: one iteration with its start, Cholesky-preconditioned (drape_sphere)", |b| {
        b.iter(|| {
            x.iter_mut().for_each(|xi| *xi = Vector3::zeros());
            pcg::solve(system, &mut x, one_iteration, Preconditioning::Cholesky(&mut cholesky), &mut workspace)
        })
    });
}

/// The swept-box hierarchy over the settled cloth's triangles, swept over
/// one step at their current velocities.
fn hierarchy(c: &mut Criterion) {
    let (simulator, step_s) = draped_simulator();
    let triangles = &simulator.cloth().triangles;
    let start = simulator.positions().to_vec();
    let end: Vec<Vector3<f64>> = start.iter().zip(simulator.velocities()).map(|(x, v)| x + v * step_s).collect();
    let mut boxes = Vec::new();
    swept_triangle_boxes(triangles, &start, &end, &mut boxes);
    let mut bvh = SweptBvh::new(&boxes);
    let mut pairs = Vec::new();

    c.bench_function(&format!("bvh: swept boxes and refit (drape_sphere, {} triangles)", triangles.len()), |b| {
        b.iter(|| {
            swept_triangle_boxes(triangles, &start, &end, &mut boxes);
            bvh.update(black_box(&boxes));
        })
    });
    // As the solver runs it: triangles that share a vertex come from lists,
    // not from the traversal.
    let apart = |a: u32, b: u32| {
        let (a, b) = (triangles[a as usize], triangles[b as usize]);
        !a.iter().any(|v| b.contains(v))
    };
    c.bench_function("bvh: self-collision broad phase (drape_sphere)", |b| {
        b.iter(|| {
            bvh.self_pairs(apart, &mut pairs);
            pairs.len()
        })
    });
}

/// A point moving from `start` to `end` (m) over the step.
fn path(start: [f64; 3], end: [f64; 3]) -> Path {
    Path { start: Vector3::from(start), end: Vector3::from(end) }
}

/// Vertex-triangle and edge-edge CCD of one pair, hit and miss.
fn continuous_collision(c: &mut Criterion) {
    // A vertex falling through the middle of a still triangle, and one
    // passing beside it (the cubic's roots exist but the point is outside).
    let (a, b, tri_c) = (
        path([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        path([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        path([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
    );
    let through = path([0.2, 0.1, 0.2], [0.2, -0.1, 0.2]);
    let beside = path([2.0, 0.1, 2.0], [2.0, -0.1, 2.0]);
    c.bench_function("ccd: vertex-triangle pair, hit", |bench| {
        bench.iter(|| ccd::vertex_triangle(black_box(&through), &a, &b, &tri_c, THICKNESS_M))
    });
    c.bench_function("ccd: vertex-triangle pair, miss", |bench| {
        bench.iter(|| ccd::vertex_triangle(black_box(&beside), &a, &b, &tri_c, THICKNESS_M))
    });
    // Two edges crossing, one sweeping down through the other; and a pair
    // whose lines cross outside the segments.
    let (p, q) = (path([-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]), path([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]));
    let (r, s) = (path([0.0, 0.1, -1.0], [0.0, -0.1, -1.0]), path([0.0, 0.1, 1.0], [0.0, -0.1, 1.0]));
    let (r_far, s_far) = (path([3.0, 0.1, -1.0], [3.0, -0.1, -1.0]), path([3.0, 0.1, 1.0], [3.0, -0.1, 1.0]));
    c.bench_function("ccd: edge-edge pair, hit", |bench| {
        bench.iter(|| ccd::edge_edge(black_box(&p), &q, &r, &s, THICKNESS_M))
    });
    c.bench_function("ccd: edge-edge pair, miss", |bench| {
        bench.iter(|| ccd::edge_edge(black_box(&p), &q, &r_far, &s_far, THICKNESS_M))
    });
}

/// Posing and skinning the demo body at one time of its walk.
fn skinning(c: &mut Criterion) {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/bodies/female_walk.fbx");
    let body = read_fbx(&file).expect("the demo body loads");
    let motion = body.motion.clone().expect("the demo body walks");
    let mut posed = Vec::new();
    let name = format!("skinning: pose and blend the walking body ({} vertices)", body.mesh.vertex_count());
    c.bench_function(&name, |b| b.iter(|| body.pose_into(&motion, black_box(0.4), &mut posed)));
}

criterion_group!(kernels, solver, hierarchy, continuous_collision, skinning);
criterion_main!(kernels);
