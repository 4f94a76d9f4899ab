use super::super::adjacent::share_a_vertex;
use super::super::obstacles::ClothScale;
use super::super::{ClothState, CollisionSettings};
use super::narrow::AdjacentCull;
use super::*;
use crate::mesh::generate;

/// A flat cloth shaken by less than its 5 mm thickness has no feature
/// pair to test between triangles that share a vertex: every such pair
/// fails the coarse test, and none reaches the narrow phase, though they
/// are most of the pairs whose boxes overlap.
#[test]
fn a_flat_cloth_sends_no_adjacent_pair_to_the_narrow_phase() {
    let grid = generate::grid(1.0, 16);
    let start = grid.positions.clone();
    let shake = |i: usize, k: usize| 0.002 * ((i * 3 + k) as f64 * 12.9898).sin();
    let mut end: Vec<Vector3<f64>> =
        start.iter().enumerate().map(|(i, p)| p + Vector3::from_fn(|k, _| shake(i, k))).collect();
    let mut velocity = vec![Vector3::zeros(); start.len()];
    let (mass, count) = (vec![1e-3; start.len()], grid.triangles.len());
    let particles = vec![ParticleCollision { thickness: 0.005, friction: 0.3, pinned: None }; start.len()];
    let obstacles = Obstacles::new(&[], &[], ClothScale { longest_edge_m: 0.01, thinnest_m: 0.005 });
    let settings = CollisionSettings::default();
    let mut pipeline =
        CollisionPipeline::new(grid.triangles.clone(), vec![0; count], vec![true], particles, obstacles, settings)
            .expect("a pipeline");
    let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
    pipeline.load(&cloth, StepWindow { t0: 0.0, t1: 0.01 });
    pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
    assert!(pipeline.ws.contacts.is_empty(), "{} contacts", pipeline.ws.contacts.len());

    let shares = |a: usize, b: usize| share_a_vertex(&grid.triangles[a], &grid.triangles[b]);
    let jobs = &pipeline.ws.jobs;
    let adjacent_job = |job: &Job| matches!(*job, Job::Cloth(a, b) if shares(a as usize, b as usize));
    assert!(!jobs.iter().any(adjacent_job), "an adjacent pair is a job");
    let ws = &pipeline.ws;
    let (feature_box, triangle_box, point_slabs) = (&ws.feature_box, &ws.triangle_box, &ws.point_slabs);
    let (triangles, triangle_slabs) = (&pipeline.triangles, &ws.triangle_slabs);
    let cull = AdjacentCull { triangles, feature_box, triangle_box, point_slabs, triangle_slabs };
    let boxes = &pipeline.ws.triangle_box;
    let overlapping: Vec<(usize, usize)> = (0..count)
        .flat_map(|a| (a + 1..count).map(move |b| (a, b)))
        .filter(|&(a, b)| boxes[a].overlaps(&boxes[b]))
        .collect();
    let adjacent: Vec<&(usize, usize)> = overlapping.iter().filter(|&&(a, b)| shares(a, b)).collect();
    assert!(adjacent.len() * 5 > overlapping.len() * 4, "{} of {} pairs", adjacent.len(), overlapping.len());
    for &&(a, b) in &adjacent {
        let sharing = Sharing::of(grid.triangles[a], grid.triangles[b]);
        assert!(!cull.may_meet(a, b, sharing), "triangles {a} and {b} pass the coarse test");
    }
}
