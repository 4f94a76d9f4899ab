use std::collections::BTreeSet;

use nalgebra::{Isometry3, Vector3};

use super::obstacles::{ClothScale, MeshCollider};

/// A cloth fine enough that no curved collider needs surface features.
const FINE_CLOTH: ClothScale = ClothScale { longest_edge_m: 0.01, thinnest_m: THICKNESS };
use super::*;
use crate::mesh::{TriMesh, generate};
use crate::sim::colliders::{Collider, Shape};

const THICKNESS: f64 = 0.005;

/// A deterministic value in [−1, 1] for index `i` and axis `k`.
fn wobble(i: usize, k: usize) -> f64 {
    ((i * 3 + k) as f64 * 12.9898).sin() * 43_758.545 % 1.0
}

/// A cloth folded onto itself 4 mm apart and shaken by up to 6 mm over
/// the step, lying on a box's sharp edge and a mesh tetrahedron: its
/// pipeline with the step loaded, and the cloth's vertex count.
fn crumpled(representative_triangles: bool) -> (CollisionPipeline, usize) {
    crumpled_by(representative_triangles, 0.006)
}

/// [`crumpled`], shaken by up to `shake` (m) over the step.
fn crumpled_by(representative_triangles: bool, shake: f64) -> (CollisionPipeline, usize) {
    let grid = generate::grid(1.0, 16);
    let start: Vec<Vector3<f64>> =
        grid.positions.iter().map(|p| if p.x > 0.0 { Vector3::new(-p.x, 0.004, p.z) } else { *p }).collect();
    let end: Vec<Vector3<f64>> =
        start.iter().enumerate().map(|(i, p)| p + Vector3::from_fn(|k, _| shake * wobble(i, k))).collect();
    let h = 0.01;
    let mut velocity: Vec<Vector3<f64>> = start.iter().zip(&end).map(|(a, b)| (b - a) / h).collect();
    let mut end_mut = end.clone();
    let mass = vec![1e-3; start.len()];
    let at = |x: f64, y: f64, z: f64| Placement { rest_pose: Isometry3::translation(x, y, z), motion: None };
    let blade = Collider {
        name: "blade".into(),
        shape: Shape::Box { half_extents: Vector3::new(0.3, 0.01, 0.01) },
        placement: at(-0.25, -0.012, 0.0),
        friction: None,
    };
    let tetrahedron = MeshCollider {
        name: "tetrahedron".into(),
        vertices: vec![Vector3::zeros(), Vector3::x() * 0.2, Vector3::z() * 0.2, Vector3::new(0.05, -0.1, 0.05)],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        placement: at(-0.3, -0.001, -0.3),
        friction: None,
        animation: None,
    };
    let particles = vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; start.len()];
    let settings = CollisionSettings { representative_triangles, ..Default::default() };
    let obstacles = Obstacles::new(&[blade], &[tetrahedron], FINE_CLOTH);
    let triangle_count = grid.triangles.len();
    let mut pipeline =
        CollisionPipeline::new(grid.triangles, vec![0; triangle_count], vec![true], particles, obstacles, settings)
            .unwrap();
    let cloth = ClothState { start: &start, end: &mut end_mut, velocity: &mut velocity, mass: &mass };
    pipeline.load(&cloth, StepWindow { t0: 0.0, t1: h });
    (pipeline, start.len())
}

/// The contacts one detection of [`crumpled`] finds and its test counts.
fn detect_crumpled(representative_triangles: bool) -> (BTreeSet<[u32; 5]>, CollisionReport, u32) {
    let (mut pipeline, n) = crumpled(representative_triangles);
    let mut report = CollisionReport::default();
    pipeline.detect(Detection::Proximity, Scope::All, &mut report);
    (pipeline.ws.contacts.iter().map(Contact::key).collect(), report, n as u32)
}

/// Every contact of a pipeline's last detection, with its hit, as text.
fn contact_set(pipeline: &CollisionPipeline) -> BTreeSet<String> {
    pipeline.ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect()
}

/// After a response pass and a pass hook that moved other points, the
/// incremental detection finds exactly the contacts (and hits) a full
/// detection of the same state finds, for both kinds of detection.
#[test]
fn detecting_again_after_a_response_equals_a_full_detection_and_reboxes_only_what_moved() {
    for detection in [Detection::Proximity, Detection::Crossings] {
        let (mut pipeline, n) = crumpled(true);
        let mut report = CollisionReport::default();
        pipeline.detect(Detection::Proximity, Scope::All, &mut report);
        let (_, acted) = pipeline.respond_pass(0.01);
        let mut lift = |pass: PassState| {
            pass.end.iter_mut().step_by(7).for_each(|p| p.y += 0.001);
            true
        };
        assert!(acted);
        pipeline.run_hook(&mut lift, ResponseStage::Impulses);
        let moved = pipeline.ws.moved.iter().filter(|&&m| m).count();
        assert!(moved > n / 7 && moved < n, "points moved, not all: {moved} of {n}");
        let mut full = pipeline.clone();
        full.detect(detection, Scope::All, &mut report);
        pipeline.detect_again(detection, &mut report);
        // Only the moved points' boxes were made again, and they are all
        // as a full detection makes them.
        assert_eq!(pipeline.ws.node_box, full.ws.node_box);
        assert_eq!(pipeline.ws.feature_box, full.ws.feature_box);
        assert_eq!(pipeline.ws.triangle_box, full.ws.triangle_box);
        assert_eq!(pipeline.ws.point_slabs, full.ws.point_slabs);
        assert_eq!(pipeline.ws.triangle_slabs, full.ws.triangle_slabs);
        let (again, full) = (contact_set(&pipeline), contact_set(&full));
        assert!(!full.is_empty());
        let only_again: Vec<_> = again.difference(&full).collect();
        let only_full: Vec<_> = full.difference(&again).collect();
        assert!(only_again.is_empty() && only_full.is_empty(), "{detection:?}: {only_again:?} vs {only_full:?}");
    }
}

/// The pass hook runs after every impulse pass and every impact-zone
/// round with the points the response moved; a point it moves after a
/// round (as an analytic collider pushing it out would) keeps that
/// position, held, while the zones go on around it; and the crossings the
/// pipeline reports are those of its final positions.
#[test]
fn zone_rounds_are_corrected_by_the_hook_and_hold_what_it_moved() {
    let (mut pipeline, n) = crumpled(true);
    pipeline.settings.passes = 1;
    let start = pipeline.ws.start[..n].to_vec();
    let mut end = pipeline.ws.end[..n].to_vec();
    let mut velocity = pipeline.ws.velocity[..n].to_vec();
    let mass = vec![1e-3; n];
    let window = StepWindow { t0: 0.0, t1: 0.01 };
    let mut stages = Vec::new();
    let mut pushed: HashMap<usize, (u32, Vector3<f64>)> = HashMap::new();
    let mut hook = |pass: PassState| {
        stages.push(pass.stage);
        if pass.stage == ResponseStage::Impulses {
            return false;
        }
        for (i, p) in pass.end.iter_mut().enumerate().filter(|(i, _)| pass.moved[*i]) {
            p.y += 5e-4;
            let entry = pushed.entry(i).or_insert((0, *p));
            *entry = (entry.0 + 1, *p);
        }
        pass.moved.iter().any(|&m| m)
    };
    let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
    let report = pipeline.resolve(cloth, window, &mut hook);
    assert_eq!(stages[0], ResponseStage::Impulses);
    assert!(stages.contains(&ResponseStage::ImpactZones) && !pushed.is_empty(), "{stages:?}");
    for (i, (times, at)) in &pushed {
        assert_eq!(*times, 1, "point {i} was pushed once, then held");
        assert_eq!(end[*i], *at, "point {i} ends where the hook put it");
    }
    let (mut check, _) = crumpled(true);
    let cloth = ClothState { start: &start, end: &mut end.clone(), velocity: &mut velocity, mass: &mass };
    check.load(&cloth, window);
    check.detect(Detection::Crossings, Scope::All, &mut CollisionReport::default());
    assert_eq!(report.unresolved as usize, check.ws.contacts.len(), "the report is the final positions'");
}

/// The passes stop at the first one whose contacts all hold without an
/// impulse, and the hook does not run after it: it has nothing new to
/// correct, and what it corrected the pass before is what that pass's
/// detection checked.
#[test]
fn passes_end_at_the_first_that_needs_no_impulse_without_the_hook() {
    let (mut pipeline, n) = crumpled(true);
    pipeline.settings.passes = 50;
    let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
    let mut velocity = pipeline.ws.velocity[..n].to_vec();
    let mass = vec![1e-3; n];
    let mut hooked = 0;
    let mut hook = |pass: PassState| {
        hooked += u32::from(pass.stage == ResponseStage::Impulses);
        false
    };
    let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
    let report = pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut hook);
    assert!(report.passes > 1 && report.passes < 50, "{report:?}");
    assert_eq!(hooked, report.passes - 1, "the hook ran after every pass but the last");
}

/// A hook that undoes every pass (as strain limits pulling a cloth back
/// over a table's corner can) leaves the contacts as short as before:
/// the passes stop after the first, where without the progress check
/// they would run to their limit, and the impact zones still end the
/// step with nothing crossing.
#[test]
fn passes_stop_when_the_hook_undoes_them() {
    let run = |pass_progress: f64| {
        let (mut pipeline, n) = crumpled(true);
        pipeline.settings.pass_progress = pass_progress;
        let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
        let mut velocity = pipeline.ws.velocity[..n].to_vec();
        let (proposed_end, proposed_velocity) = (end.clone(), velocity.clone());
        let mass = vec![1e-3; n];
        let mut undo = |pass: PassState| {
            if pass.stage != ResponseStage::Impulses {
                return false;
            }
            pass.end.copy_from_slice(&proposed_end);
            pass.velocity.copy_from_slice(&proposed_velocity);
            true
        };
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut undo)
    };
    let (checked, unchecked) = (run(0.3), run(0.0));
    assert_eq!(checked.passes, 1, "{checked:?}");
    assert_eq!(unchecked.passes, CollisionSettings::default().passes, "{unchecked:?}");
    assert_eq!(checked.unresolved, 0, "{checked:?}");
}

/// After impact zones that left nothing crossing, the hook runs once more
/// and may move the points the zones moved (an edge between two of them is
/// as stretched as the zones left it), all but those an obstacle carries,
/// which end the step where the zones put them; what it moves goes through
/// the passes and zones again, so nothing crosses.
#[test]
fn the_correction_after_zones_may_move_the_zones_points_and_nothing_crosses() {
    let (mut pipeline, n) = crumpled(true);
    pipeline.settings.pass_progress = 0.3;
    let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
    let mut velocity = pipeline.ws.velocity[..n].to_vec();
    let (proposed_end, proposed_velocity) = (end.clone(), velocity.clone());
    let mass = vec![1e-3; n];
    let (mut zone_moved, mut frozen_at) = (Vec::new(), Vec::new());
    let mut hook = |pass: PassState| match pass.stage {
        ResponseStage::Impulses if zone_moved.is_empty() => {
            pass.end.copy_from_slice(&proposed_end);
            pass.velocity.copy_from_slice(&proposed_velocity);
            true
        }
        ResponseStage::AfterZones if zone_moved.is_empty() => {
            // Only the points carried by an obstacle stay frozen.
            let frozen = |i: usize| pass.frozen.contains(&(i as u32));
            frozen_at = pass.frozen.iter().map(|&i| (i as usize, pass.end[i as usize])).collect();
            zone_moved = (0..n).filter(|&i| pass.end[i] != proposed_end[i] && !frozen(i)).collect();
            zone_moved.iter().for_each(|&i| pass.end[i].y += 1e-4);
            !zone_moved.is_empty()
        }
        _ => false,
    };
    let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
    let report = pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut hook);
    assert!(report.zone_rounds > 0 && report.zone_corrections > 0, "{report:?}");
    assert!(!zone_moved.is_empty(), "the zones moved free points, and they were not frozen");
    assert!(!frozen_at.is_empty(), "an obstacle carried points");
    for (i, at) in frozen_at {
        assert_eq!(end[i], at, "carried particle {i} left where the zones put it");
    }
    assert_eq!(report.unresolved, 0, "{report:?}");
}

/// A cloth folded onto itself and shaken, with no obstacle, its whole
/// motion over the step offset by `carried` (m): the contacts it finds
/// and the detection's report.
fn detect_folded(carried: Vector3<f64>) -> (BTreeSet<[u32; 5]>, CollisionReport) {
    let (pipeline, n) = crumpled(true);
    let (start, mut end) = (pipeline.ws.start[..n].to_vec(), pipeline.ws.end[..n].to_vec());
    end.iter_mut().for_each(|p| *p += carried);
    let mut velocity = vec![Vector3::zeros(); n];
    let particles = pipeline.particles.clone();
    let triangles = pipeline.triangles.clone();
    let count = triangles.len();
    let obstacles = Obstacles::new(&[], &[], FINE_CLOTH);
    let mut folded =
        CollisionPipeline::new(triangles, vec![0; count], vec![true], particles, obstacles, Default::default())
            .unwrap();
    let mass = vec![1e-3; n];
    let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
    folded.load(&cloth, StepWindow { t0: 0.0, t1: 0.01 });
    let mut report = CollisionReport::default();
    folded.detect(Detection::Proximity, Scope::All, &mut report);
    (folded.ws.contacts.iter().map(Contact::key).collect(), report)
}

/// Every feature pair within the thickness at an end of the step, or
/// crossing during it, by brute force over all pairs of the crumpled
/// cloth (vertex-triangle and edge-edge within the cloth, against the
/// tetrahedron's triangles, edges and vertices, and against the blade's
/// sharp edges and vertices): the contacts a detection finds through its
/// boxes, hierarchies and owned features are exactly these.
#[test]
fn a_detection_finds_every_contact_a_brute_force_over_all_feature_pairs_finds() {
    let (found, expected, n) = detected_and_brute_force(crumpled(true));
    assert!(expected.len() > 100 && expected.iter().any(|k| k[4] >= n as u32), "the fold and the obstacles touch");
    assert_eq!(found, expected);
}

/// The same, with the cloth shaken by most of an edge over the step:
/// triangles that share a vertex fold onto each other all over it.
#[test]
fn a_cloth_shaken_by_an_edge_finds_every_contact_a_brute_force_finds() {
    let (found, expected, _) = detected_and_brute_force(crumpled_by(true, 0.05));
    assert!(expected.len() > 1000, "{} contacts", expected.len());
    assert_eq!(found, expected);
}

/// The contacts one detection of a loaded `pipeline` (with `n` cloth
/// points) finds, and those a brute force over all feature pairs finds.
fn detected_and_brute_force(
    (mut pipeline, n): (CollisionPipeline, usize),
) -> (BTreeSet<[u32; 5]>, BTreeSet<[u32; 5]>, usize) {
    use super::ccd::{Path, edge_edge, vertex_triangle};
    pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
    let found: BTreeSet<[u32; 5]> = pipeline.ws.contacts.iter().map(Contact::key).collect();

    let ws = &pipeline.ws;
    let path = |i: u32| Path { start: ws.start[i as usize], end: ws.end[i as usize] };
    let edges_of = |triangles: &[[u32; 3]]| -> BTreeSet<[u32; 2]> {
        let edge = |t: &[u32; 3], k: usize| [t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])];
        triangles.iter().flat_map(|t| (0..3).map(move |k| edge(t, k))).collect()
    };
    let offset = |v: u32| v + n as u32;
    let cloth_triangles = pipeline.triangles.clone();
    let obstacle_triangles: Vec<[u32; 3]> = pipeline.obstacles.triangles.iter().map(|t| t.map(offset)).collect();
    let cloth_edges = edges_of(&cloth_triangles);
    let mut obstacle_edges = edges_of(&obstacle_triangles);
    obstacle_edges.extend(pipeline.obstacles.feature_edges.iter().map(|e| e.map(offset)));
    let mut obstacle_vertices: BTreeSet<u32> = obstacle_triangles.iter().flatten().copied().collect();
    obstacle_vertices.extend(pipeline.obstacles.feature_vertices.iter().map(|&v| offset(v)));

    let mut expected = BTreeSet::new();
    let mut vertex_against = |v: u32, tri: [u32; 3]| {
        if !tri.contains(&v)
            && vertex_triangle(&path(v), &path(tri[0]), &path(tri[1]), &path(tri[2]), THICKNESS).is_some()
        {
            let mut sorted = tri;
            sorted.sort_unstable();
            expected.insert([0, v, sorted[0], sorted[1], sorted[2]]);
        }
    };
    for v in 0..n as u32 {
        cloth_triangles.iter().chain(&obstacle_triangles).for_each(|&tri| vertex_against(v, tri));
    }
    for &v in &obstacle_vertices {
        cloth_triangles.iter().for_each(|&tri| vertex_against(v, tri));
    }
    let mut edge_against = |a: [u32; 2], b: [u32; 2]| {
        if !a.iter().any(|v| b.contains(v))
            && edge_edge(&path(a[0]), &path(a[1]), &path(b[0]), &path(b[1]), THICKNESS).is_some()
        {
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            expected.insert([1, lo[0], lo[1], hi[0], hi[1]]);
        }
    };
    for &a in &cloth_edges {
        cloth_edges.range(a..).chain(&obstacle_edges).for_each(|&b| edge_against(a, b));
    }
    // Triangles that share a vertex touch (at the fold, or where shaken):
    // the hierarchy leaves those pairs to the adjacent triangles' lists.
    let joined = |a: u32, b: u32| cloth_edges.contains(&[a.min(b), a.max(b)]);
    let adjacent = |k: &[u32; 5]| k[0] == 0 && k[2..].iter().any(|&corner| joined(k[1], corner));
    assert!(expected.iter().any(adjacent), "adjacent triangles touch");
    (found, expected, n)
}

/// Boxes are taken in a frame moving with the cloth's mean displacement:
/// a cloth carried 0.3 m in a step (50 times its own shaking) finds the
/// same contacts, after as many box tests, as the same cloth not carried.
#[test]
fn a_carried_cloth_finds_the_same_contacts_after_as_many_tests() {
    let (still, still_report) = detect_folded(Vector3::zeros());
    let (carried, carried_report) = detect_folded(Vector3::new(0.3, -0.1, 0.05));
    assert!(still.len() > 100, "the fold touches: {}", still.len());
    assert_eq!(still, carried);
    let (a, b) = (still_report.tests as f64, carried_report.tests as f64);
    assert!((a - b).abs() <= 0.01 * a, "{a} tests at rest, {b} carried");
}

/// The frame the boxes are taken in changes which boxes overlap, never
/// the contacts: framed by the cloth's mean displacement (as `resolve`
/// does unaided), by none, or by a far-off shift (as a simulator's
/// prediction from the start velocities might be), one detection finds
/// the same contacts, with the same hits, in the same order.
#[test]
fn any_frame_for_the_boxes_gives_the_same_contacts_in_the_same_order() {
    let contacts = |shift: Option<Vector3<f64>>| {
        let (mut pipeline, _) = crumpled(true);
        if let Some(shift) = shift {
            pipeline.frame_obstacles(StepWindow { t0: 0.0, t1: 0.01 }, shift);
        }
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        pipeline.ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect::<Vec<_>>()
    };
    let by_mean_displacement = contacts(None);
    assert!(by_mean_displacement.len() > 100, "the fold touches: {}", by_mean_displacement.len());
    for shift in [Vector3::zeros(), Vector3::new(0.3, -0.2, 0.1)] {
        assert_eq!(contacts(Some(shift)), by_mean_displacement, "framed by {shift:?}");
    }
}

/// How a test predicts the end of cloth point `i` from its start and
/// real end, m.
type Prediction = fn(usize, &Vector3<f64>, &Vector3<f64>) -> Vector3<f64>;

/// [`crumpled`] with its motion over the step scaled by `scale`, its
/// broad phase speculated from `prediction` (if any), and its cloth's
/// start, end and velocity.
fn speculated(scale: f64, prediction: Option<Prediction>) -> (CollisionPipeline, [Vec<Vector3<f64>>; 3]) {
    let (mut pipeline, n) = crumpled(true);
    let ws = &mut pipeline.ws;
    for i in 0..n {
        ws.end[i] = ws.start[i] + (ws.end[i] - ws.start[i]) * scale;
    }
    let (start, end, velocity) = (ws.start[..n].to_vec(), ws.end[..n].to_vec(), ws.velocity[..n].to_vec());
    if let Some(predict) = prediction {
        let predicted: Vec<Vector3<f64>> = (0..n).map(|i| predict(i, &start[i], &end[i])).collect();
        pipeline.speculate(StepWindow { t0: 0.0, t1: 0.01 }, &start, &predicted);
        assert!(pipeline.ws.speculative, "the obstacles are framed for the step");
    }
    (pipeline, [start, end, velocity])
}

/// Predictions of a cloth's ends: exact, no motion, off by up to 3 cm,
/// and backwards.
const PREDICTIONS: [(Prediction, &str); 4] = [
    (|_, _, end| *end, "exact"),
    (|_, start, _| *start, "no motion"),
    (|i, _, end| end + Vector3::from_fn(|k, _| 0.03 * wobble(i + 7, k)), "off by up to 3 cm"),
    (|_, start, end| start * 2.0 - end, "backwards"),
];

/// However good the prediction the broad phase was speculated from, the
/// first detection finds the same pairs and the same contacts, with the
/// same hits, in the same order, as one without; where the prediction
/// is poor, triangles escape their speculative boxes (the fold moves up
/// to 24 mm, beyond the margin).
#[test]
fn a_speculated_broad_phase_gives_the_same_contacts_in_the_same_order_for_any_prediction() {
    let detect = |prediction: Option<Prediction>| {
        let (mut pipeline, _) = speculated(4.0, prediction);
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        let ws = &pipeline.ws;
        let contacts: Vec<String> = ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect();
        (contacts, ws.pairs.clone(), ws.mesh_pairs.clone(), ws.moved_list.len(), pipeline.triangles.len())
    };
    let (contacts, pairs, mesh_pairs, _, triangles) = detect(None);
    assert!(contacts.len() > 100 && !mesh_pairs.is_empty(), "the fold touches, and the tetrahedron is near");
    for (k, (prediction, name)) in PREDICTIONS.into_iter().enumerate() {
        let (speculated_contacts, speculated_pairs, speculated_mesh_pairs, escaped, _) = detect(Some(prediction));
        assert_eq!(speculated_contacts, contacts, "contacts, {name}");
        assert_eq!((speculated_pairs, speculated_mesh_pairs), (pairs.clone(), mesh_pairs.clone()), "pairs, {name}");
        match k {
            0 => assert_eq!(escaped, 0, "{name}"),
            _ => assert!(escaped > 0 && escaped < triangles, "{name}: {escaped} of {triangles} escape"),
        }
    }
}

/// A whole step's response ends in the same bits whether its first
/// broad phase was speculated or not: the later detections, whose
/// hierarchy keeps the speculative (larger) boxes of the triangles that
/// did not move, find the same pairs too (the last one's are counted).
#[test]
fn a_speculated_step_ends_where_an_unspeculated_one_does() {
    let resolve = |prediction: Option<Prediction>| {
        let (mut pipeline, [start, mut end, mut velocity]) = speculated(2.0, prediction);
        let mass = vec![1e-3; start.len()];
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        let report = pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut |_: PassState| false);
        (end, velocity, report.passes, report.contacts, report.pairs)
    };
    let unspeculated = resolve(None);
    assert!(unspeculated.2 > 1, "several passes: {}", unspeculated.2);
    for (prediction, name) in PREDICTIONS {
        assert!(resolve(Some(prediction)) == unspeculated, "{name}");
    }
}

/// After a speculated first detection, later detections read the moved
/// triangles' leaf partners instead of querying the hierarchy; they
/// find the same pairs, body pairs and contacts, in the same order, as
/// the queries of an unspeculated step, pass after pass: when the
/// response moved the points a little (each triangle stays in its
/// leaf), further than the margin (they escape, get new leaves and are
/// queried from then on), and then only points away from those (their
/// triangles must find the escaped ones in their lists).
#[test]
fn later_detections_from_leaf_partners_find_what_queries_find() {
    let passes = |prediction: Option<Prediction>| {
        let (mut pipeline, _) = speculated(2.0, prediction);
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        let n = pipeline.particles.len();
        let mut far_moved = vec![false; n];
        let mut found = Vec::new();
        for (pass, stride, reach) in [(1, 4, 0.001), (2, 29, 0.2), (3, 3, 0.0005)] {
            let ws = &mut pipeline.ws;
            for i in (pass..n).step_by(stride).filter(|&i| !far_moved[i]) {
                ws.end[i] += Vector3::from_fn(|k, _| reach * wobble(i + pass, k));
                ws.moved[i] = true;
            }
            pipeline.detect(Detection::Proximity, Scope::Moved, &mut CollisionReport::default());
            let ws = &pipeline.ws;
            let contacts: Vec<String> = ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect();
            found.push((ws.pairs.clone(), ws.mesh_pairs.clone(), contacts, ws.escaping.len()));
            if pass == 2 {
                for &t in &ws.moved_list {
                    pipeline.triangles[t as usize].iter().for_each(|&v| far_moved[v as usize] = true);
                }
            }
        }
        (found, pipeline.ws.partners.valid())
    };
    let (queried, listed) = passes(None);
    assert!(!listed, "without speculation nothing is listed");
    for (pairs, mesh_pairs, contacts, _) in &queried {
        assert!(pairs.len() > 20 && !mesh_pairs.is_empty() && !contacts.is_empty(), "{}", pairs.len());
    }
    for (prediction, name) in PREDICTIONS {
        let (found, listed) = passes(Some(prediction));
        assert!(listed, "{name}: the partners are listed");
        for (pass, (got, want)) in found.iter().zip(&queried).enumerate() {
            assert_eq!((&got.0, &got.1, &got.2), (&want.0, &want.1, &want.2), "{name}, pass {}", pass + 1);
        }
        let escaping: Vec<usize> = found.iter().map(|f| f.3).collect();
        assert!(escaping[1] > 0, "{name}: 20 cm moves escape the leaves ({escaping:?})");
    }
}

/// Two cloth triangles 30 cm apart, the first sliding onto the second
/// and onto a floor patch 3 mm below it within the step, speculated as
/// if nothing moved: the first escapes its speculative box, and only
/// its own queries find the pairs its real box meets.
#[test]
fn an_escaped_triangle_finds_the_pairs_its_real_box_meets() {
    let detect = |speculate: bool| {
        let triangle =
            |x: f64, y: f64| [Vector3::new(x, y, 0.0), Vector3::new(x + 0.1, y, 0.0), Vector3::new(x, y, 0.1)];
        let start: Vec<Vector3<f64>> = [triangle(0.0, 0.0), triangle(0.3, 0.002)].concat();
        let mut end = start.clone();
        end[..3].iter_mut().for_each(|p| p.x += 0.3);
        let floor = MeshCollider {
            placement: Placement { rest_pose: Isometry3::translation(0.35, -0.003, 0.05), motion: None },
            ..floor_below()
        };
        let floor = MeshCollider {
            vertices: generate::grid(0.1, 2).positions,
            triangles: generate::grid(0.1, 2).triangles,
            ..floor
        };
        let particles = vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; 6];
        let obstacles = Obstacles::new(&[], &[floor], FINE_CLOTH);
        let mut pipeline = CollisionPipeline::new(
            vec![[0, 1, 2], [3, 4, 5]],
            vec![0, 0],
            vec![true],
            particles,
            obstacles,
            Default::default(),
        )
        .unwrap();
        let (mut velocity, mass) = (vec![Vector3::zeros(); 6], vec![1e-3; 6]);
        let window = StepWindow { t0: 0.0, t1: 0.01 };
        pipeline
            .load(&ClothState { start: &start, end: &mut end.clone(), velocity: &mut velocity, mass: &mass }, window);
        if speculate {
            pipeline.speculate(window, &start, &start);
        }
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        let ws = &pipeline.ws;
        (ws.pairs.clone(), ws.mesh_pairs.len(), ws.contacts.len(), ws.moved_list.clone())
    };
    let (pairs, mesh_pairs, contacts, _) = detect(false);
    assert_eq!(pairs, vec![(0, 1)]);
    assert!(mesh_pairs > 0 && contacts > 0, "{mesh_pairs} body pairs, {contacts} contacts");
    assert_eq!(detect(true), (pairs, mesh_pairs, contacts, vec![0]));
}

/// A 1.2 m square floor mesh 4 mm below a grid cloth at rest.
fn floor_below() -> MeshCollider {
    let floor = generate::grid(1.2, 23);
    MeshCollider {
        name: "floor".into(),
        vertices: floor.positions,
        triangles: floor.triangles,
        placement: Placement { rest_pose: Isometry3::translation(0.05, -0.004, 0.0), motion: None },
        friction: None,
        animation: None,
    }
}

/// The pipeline of cloth `mesh`, without self-collision, against `obstacles`.
fn without_self_collision(mesh: TriMesh, obstacles: Obstacles) -> CollisionPipeline {
    let particles = vec![ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None }; mesh.positions.len()];
    let count = mesh.triangles.len();
    CollisionPipeline::new(mesh.triangles, vec![0; count], vec![false], particles, obstacles, Default::default())
        .unwrap()
}

/// A cloth falling 6 cm in a step through a mesh floor 4 cm below it,
/// with its obstacles framed for a cloth predicted not to move: every
/// floor triangle lies beyond the region the obstacles are boxed in and
/// is parked, and the first detection boxes those near the cloth's real
/// boxes before its broad phase. It finds the same pairs and contacts, in
/// the same order, as with every triangle boxed; the floor's far parts
/// stay parked.
#[test]
fn parked_obstacle_triangles_are_boxed_when_the_cloth_reaches_them() {
    let window = StepWindow { t0: 0.0, t1: 0.01 };
    let detect = |near: bool| {
        let grid = generate::grid(0.3, 7);
        let start = grid.positions.clone();
        let mut end: Vec<Vector3<f64>> = start.iter().map(|p| p - Vector3::y() * 0.06).collect();
        let mut velocity = vec![Vector3::y() * -6.0; start.len()];
        let mut floor = floor_below();
        floor.placement.rest_pose = Isometry3::translation(0.0, -0.04, 0.0);
        let mut pipeline = without_self_collision(grid, Obstacles::new(&[], &[floor], FINE_CLOTH));
        let mass = vec![1e-3; start.len()];
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        pipeline.load(&cloth, window);
        let parked = |pipeline: &CollisionPipeline| pipeline.ws.obstacle_box.iter().filter(|b| b.is_empty()).count();
        if near {
            pipeline.frame_obstacles_near(window, Vector3::zeros(), (&start, &start));
            assert_eq!(parked(&pipeline), pipeline.obstacles.triangles.len(), "the whole floor is parked");
            pipeline.speculate(window, &start, &start);
        }
        pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
        let contacts: Vec<String> = pipeline.ws.contacts.iter().map(|c| format!("{:?} {:?}", c.key(), c.hit)).collect();
        (contacts, pipeline.ws.mesh_pairs.clone(), parked(&pipeline), pipeline.obstacles.triangles.len())
    };
    let (contacts, pairs, parked, _) = detect(false);
    assert!(contacts.len() > 40 && parked == 0, "the cloth goes through the floor: {} contacts", contacts.len());
    let (near_contacts, near_pairs, near_parked, floor) = detect(true);
    assert_eq!((near_contacts, near_pairs), (contacts, pairs));
    assert!(near_parked > floor / 2 && near_parked < floor, "{near_parked} of {floor} floor triangles parked");
}

/// The mesh colliders' hierarchy and the cloth's, traversed together,
/// give exactly the (obstacle, cloth) triangle pairs whose boxes
/// overlap; after a response, the moved cloth triangles' queries give
/// exactly those of them that hold a moved triangle.
#[test]
fn mesh_collider_pairs_are_every_overlapping_pair() {
    let grid = generate::grid(1.0, 16);
    let start = grid.positions.clone();
    let end: Vec<Vector3<f64>> =
        start.iter().enumerate().map(|(i, p)| p + Vector3::from_fn(|k, _| 0.006 * wobble(i, k))).collect();
    let mut velocity = vec![Vector3::zeros(); start.len()];
    let mut pipeline = without_self_collision(grid, Obstacles::new(&[], &[floor_below()], FINE_CLOTH));
    let mass = vec![1e-3; start.len()];
    let cloth = ClothState { start: &start, end: &mut end.clone(), velocity: &mut velocity, mass: &mass };
    pipeline.load(&cloth, StepWindow { t0: 0.0, t1: 0.01 });
    let overlapping = |ws: &Workspace, wanted: &dyn Fn(usize) -> bool| {
        let mut pairs = Vec::new();
        for (t, obstacle) in ws.obstacle_box.iter().enumerate() {
            let hits = ws.triangle_box.iter().enumerate().filter(|(h, b)| wanted(*h) && b.overlaps(obstacle));
            pairs.extend(hits.map(|(h, _)| (t as u32, h as u32)));
        }
        pairs
    };
    pipeline.detect(Detection::Proximity, Scope::All, &mut CollisionReport::default());
    let all = overlapping(&pipeline.ws, &|_| true);
    assert!(all.len() > 1000, "the cloth lies on the floor: {} pairs", all.len());
    assert_eq!(pipeline.ws.mesh_pairs, all);
    pipeline.ws.moved.iter_mut().step_by(5).for_each(|m| *m = true);
    pipeline.detect(Detection::Proximity, Scope::Moved, &mut CollisionReport::default());
    let moved_triangle = pipeline.ws.moved_triangle.clone();
    let moved = overlapping(&pipeline.ws, &|h| moved_triangle[h]);
    assert!(!moved.is_empty() && moved.len() < all.len(), "{} of {}", moved.len(), all.len());
    assert_eq!(pipeline.ws.mesh_pairs, moved);
}

/// A 1 m cloth falling 1 cm in a step from 4 mm above `analytic` and
/// `meshes`: what the hook sees after the first impulse pass, per
/// particle: the normal it was pushed off a mesh along, and whether the
/// pass moved it.
fn first_pass_pushes(analytic: &[Collider], meshes: &[MeshCollider]) -> (Vec<Vector3<f64>>, Vec<bool>) {
    let grid = generate::grid(1.0, 16);
    let start = grid.positions.clone();
    let mut end: Vec<Vector3<f64>> = start.iter().map(|p| p - Vector3::new(0.0, 0.01, 0.0)).collect();
    let mut velocity = vec![Vector3::new(0.0, -1.0, 0.0); start.len()];
    let mut pipeline = without_self_collision(grid, Obstacles::new(analytic, meshes, FINE_CLOTH));
    let mass = vec![1e-3; start.len()];
    let mut first_pass = None;
    let mut hook = |pass: PassState| {
        if first_pass.is_none() {
            first_pass = Some((pass.pushed_off.to_vec(), pass.moved.to_vec()));
        }
        false
    };
    let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
    pipeline.resolve(cloth, StepWindow { t0: 0.0, t1: 0.01 }, &mut hook);
    first_pass.expect("the cloth hits the obstacle")
}

/// The hook learns which particles this pass's impulses pushed off a
/// mesh collider, and which way: a cloth falling through a floor is
/// pushed up. Pushes off an analytic collider's sharp edge, around which
/// the cloth wraps, do not count; off a rod thinner than the cloth's
/// edges, which the cloth cannot wrap, they do.
#[test]
fn the_hook_sees_what_was_pushed_off_a_mesh_and_which_way() {
    let (pushed_off, moved) = first_pass_pushes(&[], &[floor_below()]);
    for (i, n) in pushed_off.iter().enumerate() {
        assert!(moved[i] && n.normalize().y > 0.99, "particle {i} falls through the floor: {n}");
    }
    // A bar along X of square section `side` m, its top 4 mm below the cloth.
    let bar = |side: f64| Collider {
        name: "bar".into(),
        shape: Shape::Box { half_extents: Vector3::new(0.3, side / 2.0, side / 2.0) },
        placement: Placement { rest_pose: Isometry3::translation(-0.25, -0.004 - side / 2.0, 0.0), motion: None },
        friction: None,
    };
    let (pushed_off, moved) = first_pass_pushes(&[bar(0.02)], &[]);
    assert!(moved.iter().any(|&m| m), "the blade's edges push the cloth");
    assert!(pushed_off.iter().all(|n| *n == Vector3::zeros()));
    let rod = bar(0.008);
    let (pushed_off, moved) = first_pass_pushes(&[rod], &[]);
    let held: Vec<usize> = (0..pushed_off.len()).filter(|&i| pushed_off[i] != Vector3::zeros()).collect();
    assert!(!held.is_empty(), "an 8 mm rod under a 10 mm cloth holds what it pushes");
    for i in held {
        assert!(moved[i] && pushed_off[i].y > 0.0, "particle {i} pushed along {}", pushed_off[i]);
    }
}

/// PAPER Algorithm 1: owning each feature once finds exactly the contacts
/// that testing every feature of every triangle finds, with fewer tests.
#[test]
fn representative_triangles_find_the_same_contacts_with_fewer_tests() {
    let (owned, with, cloth_vertices) = detect_crumpled(true);
    let (all, without, _) = detect_crumpled(false);
    assert!(owned.len() > 200, "a crumpled cloth has many contacts: {}", owned.len());
    assert!(owned.iter().any(|k| k[0] == 0) && owned.iter().any(|k| k[0] == 1), "both kinds");
    assert!(owned.iter().any(|k| k[1..].iter().any(|&v| v >= cloth_vertices)), "obstacle contacts too");
    assert_eq!(owned, all);
    assert_eq!(with.tests_without_ownership, without.tests, "the count without ownership is what it would run");
    assert!((with.tests as f64) < 0.6 * without.tests as f64, "{} vs {}", with.tests, without.tests);
}
