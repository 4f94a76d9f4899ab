//! The standard collision scenes of `SCENES.md`, baked in the test and checked
//! at every frame end by the independent checker (`metrics`), which shares no
//! code with the solver's collision pipeline.
//!
//! Resolutions are reduced from the benchmark sizes (noted per test) so the
//! suite stays within the CI budget; the scene, its colliders, fabric, step
//! and duration are the standard ones.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use drape::bake::{self, FrameRecord};
use drape::scene::Scene;
use drape::scene::file::{MeshSpec, SceneFile};
use drape::sim::collision::CollisionSettings;
use nalgebra::Vector3;

fn standard(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes").join(format!("{name}.toml"))
}

/// A standard scene with its garment meshed more coarsely.
fn reduced(name: &str, resolution: usize) -> Scene {
    reduced_with(name, resolution, |_| {})
}

/// A standard scene with its garment meshed more coarsely and `edit` made
/// to its file.
fn reduced_with(name: &str, resolution: usize, edit: impl FnOnce(&mut SceneFile)) -> Scene {
    Scene::load_edited(&standard(name), |file: &mut SceneFile| {
        match &mut file.garments[0].mesh {
            MeshSpec::Grid { resolution: n, .. } => *n = resolution,
            MeshSpec::Tube { around, along, .. } => (*around, *along) = (resolution, resolution),
            other => panic!("{name}: unexpected mesh {other:?}"),
        }
        edit(file);
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Bakes the whole scene, handing every frame (with frame 0) to `check`.
fn bake_all(scene: &Scene, mut check: impl FnMut(&FrameRecord, &[Vector3<f64>])) -> Vec<FrameRecord> {
    let (records, failure) = bake::run(scene, scene.frame_count, &AtomicBool::new(false), |sim, record| {
        check(record, sim.positions());
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    assert!(failure.is_none(), "{}: {failure:?}", scene.name);
    assert_eq!(records.len(), scene.frame_count);
    records
}

/// Bakes `scene` and asserts zero intersecting triangle pairs (cloth-cloth and
/// cloth-collider) and zero penetrating vertices at every frame end.
fn assert_never_intersects(scene: &Scene) -> Vec<FrameRecord> {
    bake_all(scene, |record, _| {
        let found = record.intersections;
        assert_eq!(
            (found.cloth_pairs, found.collider_pairs, found.penetrating_vertices),
            (0, 0, 0),
            "{}: frame {} ends with intersections",
            scene.name,
            record.frame
        );
    })
}

/// Sharp edges and an apex (PAPER Experiment 3); 48 × 48 instead of 128 × 128.
#[test]
fn pillars_never_intersect() {
    let records = assert_never_intersects(&reduced("pillars", 48));
    assert!(records.iter().any(|r| r.triangle_contacts > 0), "the cloth met the pillars' sharp features");
}

/// A tablecloth folding over the table's edges onto itself; 48 × 48 instead
/// of 96 × 96, self-collision on (the default).
#[test]
fn drape_table_with_self_collision_never_intersects() {
    let scene = reduced("drape_table", 48);
    assert!(scene.garments[0].self_collision);
    assert_never_intersects(&scene);
}

/// A ball at 8 m/s (0.27 m per frame, more than its diameter) is stopped by
/// the cloth, never crosses it; full resolution.
#[test]
fn projectile_is_caught_not_crossed() {
    let scene = Scene::load(&standard("projectile")).unwrap();
    let (radius, rest_height) = (0.1, 1.0);
    let ball_centre = |t: f64| 1.35 - 8.0 * t.min(0.05);
    let mut lowest_cloth = f64::INFINITY;
    bake_all(&scene, |record, x| {
        assert_eq!(record.intersections.pairs() + record.intersections.penetrating_vertices, 0, "{record:?}");
        let centre = ball_centre(record.time_s);
        // Particles within 5 cm of the ball's axis lie under its lower cap
        // (at most centre - sqrt(r² - 0.05²)) whenever the ball presses on them.
        let cap = centre - (radius * radius - 0.05f64.powi(2)).sqrt();
        for p in x.iter().filter(|p| p.x.hypot(p.z) < 0.05) {
            assert!(p.y < cap, "frame {}: a particle at {p} is above the ball's lower cap {cap}", record.frame);
        }
        lowest_cloth = x.iter().map(|p| p.y).fold(lowest_cloth, f64::min);
    });
    // The ball ends with its centre 5 cm below the rest height, so the cloth
    // under it has been carried down at least that far plus the cap.
    assert!(lowest_cloth < rest_height - 0.05 - 0.08, "the cloth's lowest point was {lowest_cloth} m");
}

/// Extreme self-contact: a tube wrung two turns each way; 32 × 32 instead
/// of 64 × 64.
#[test]
fn twist_never_intersects() {
    let records = assert_never_intersects(&reduced("twist", 32));
    let contacts: u32 = records.iter().map(|r| r.triangle_contacts).sum();
    assert!(contacts > 10_000, "the tube collapsed onto itself: {contacts} contacts");
}

/// A bed of 3 mm needles: no vertex or edge passes one, and the cloth
/// pierced between them never passes itself; full resolution (96 × 96), the
/// size at which a particle moved after the pipeline's last check once left
/// two triangle pairs crossed for good. The cloth rests on the tips within
/// its strain limit (cotton's 1 %, plus a point): held off needles thinner
/// than its edges, where each pass's projection pulling it back round the
/// tips left 190 %. The tips' springs carry it in the solve: with the
/// edges' weaker springs it sank round the tips every step and the passes'
/// projections lifted it back, taking three Newton iterations for every
/// two they take now.
#[test]
fn needles_are_never_passed_and_the_tips_carry_the_cloth() {
    let bake = |edit: &dyn Fn(&mut SceneFile)| {
        let scene = Scene::load_edited(&standard("needles"), edit).unwrap_or_else(|e| panic!("{e}"));
        assert_never_intersects(&scene)
    };
    let records = bake(&|_| {});
    assert!(records.iter().any(|r| r.triangle_contacts > 0), "the cloth met the needles' tips");
    let worst = records.iter().max_by(|a, b| a.max_free_strain.total_cmp(&b.max_free_strain)).expect("frames");
    assert!(
        worst.max_free_strain <= 0.0201,
        "frame {} ends at {:.2} % strain",
        worst.frame,
        100.0 * worst.max_free_strain
    );
    let edges = CollisionSettings::default().feature_repulsion_stiffness;
    let sagging = bake(&|file| file.collision.tip_repulsion_stiffness_n_per_m = edges);
    let projection = |records: &[FrameRecord]| records.iter().map(|r| u64::from(r.projection_iterations)).sum::<u64>();
    let (held, sank) = (projection(&records), projection(&sagging));
    assert!(held * 4 < sank * 3, "{held} projection iterations on the tips' springs, {sank} on the edges'");
}

/// Friction carries the cloth round with a spinning sphere: after 2 s of
/// spinning (two turns of the sphere) the cloth on top has turned at least
/// 90° with it; 32 × 32 instead of 64 × 64.
#[test]
fn spin_sphere_turns_the_cloth_by_friction() {
    let scene = reduced("spin_sphere", 32);
    let centre = Vector3::new(0.0, 0.5, 0.0);
    // Particles resting on the sphere's upper half at the start of the spin,
    // and the unwrapped angle each has turned about Y since.
    let mut tracked: Vec<(usize, f64, f64)> = Vec::new();
    let mut turned = 0.0;
    bake_all(&scene, |record, x| {
        assert_eq!(record.intersections.pairs() + record.intersections.penetrating_vertices, 0, "{record:?}");
        let angle = |p: &Vector3<f64>| p.z.atan2(p.x);
        if (record.time_s - 1.0).abs() < 1e-9 {
            tracked = (0..x.len())
                .filter(|&i| (x[i] - centre).norm() < 0.31 && x[i].y > 0.6 && x[i].xz().norm() > 0.05)
                .map(|i| (i, angle(&x[i]), 0.0))
                .collect();
        }
        for (i, last, total) in &mut tracked {
            let now = angle(&x[*i]);
            let step = (now - *last + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            (*last, *total) = (now, *total + step);
        }
        if !tracked.is_empty() {
            turned = tracked.iter().map(|t| t.2).sum::<f64>() / tracked.len() as f64;
        }
    });
    assert!(tracked.len() > 20, "cloth rests on the sphere when it starts spinning");
    // The sphere spins at +360°/s about Y, which takes atan2(z, x) negative.
    assert!(-turned.to_degrees() >= 90.0, "the cloth turned {:.1}° in 2 s", -turned.to_degrees());
}

/// A coarse, broken garment (4.5-6.4 cm triangles) on a 15 cm sphere: its
/// faces would bow ~4.5 mm into the sphere between particles held 2.5 mm off
/// it, so the sphere carries a surface lattice and no face may cross it; full
/// size.
#[test]
fn a_coarse_cloth_does_not_bow_into_a_small_sphere() {
    let scene = Scene::load(&standard("bad_mesh")).unwrap_or_else(|e| panic!("{e}"));
    let records = assert_never_intersects(&scene);
    assert!(records.iter().any(|r| r.triangle_contacts > 0), "the cloth's faces met the sphere's lattice");
    let settled = records.last().map(|r| r.max_strain).unwrap_or(f64::NAN);
    assert!(settled < 0.011, "the lattice holds the faces without stretching the cloth: {settled}");
}

/// `drape_sphere` (N = 40 instead of 64): the folds that rest on
/// themselves are pushed apart inside the implicit solve, so the steps'
/// first detections find far fewer self-contacts to answer than with the
/// repulsions off, and the cloth stays as free of intersections.
#[test]
fn resting_folds_are_pushed_apart_in_the_solve() {
    let contacts = |stiffness: f64| {
        let scene = reduced_with("drape_sphere", 40, |file| file.collision.repulsion_stiffness_n_per_m = stiffness);
        let records = assert_never_intersects(&scene);
        records.iter().map(|r| u64::from(r.triangle_contacts)).sum::<u64>()
    };
    let default = CollisionSettings::default().repulsion_stiffness;
    let (pushed, answered) = (contacts(default), contacts(0.0));
    assert!(answered > 1000, "the folds rest on themselves: {answered} contacts");
    assert!(pushed * 2 < answered, "{pushed} contacts with the repulsions, {answered} without");
}

/// `drape_table` (N = 48 instead of 96): the cloth drawn taut over the
/// table's edges rests on them, and the springs that push it off them in
/// the solve spare the steps a good part of the contacts along those edges
/// and of the projections that fought the impulses over them, the corners
/// keep their strain limit, and the cloth is as free of intersections.
#[test]
fn cloth_drawn_over_a_table_edge_is_pushed_off_it_in_the_solve() {
    let bake = |stiffness: f64| {
        let edit = |file: &mut SceneFile| file.collision.feature_repulsion_stiffness_n_per_m = stiffness;
        let scene = reduced_with("drape_table", 48, edit);
        let records = assert_never_intersects(&scene);
        let sum = |of: &dyn Fn(&FrameRecord) -> u32| records.iter().map(|r| u64::from(of(r))).sum::<u64>();
        let largest_strain = records.iter().map(|r| r.max_free_strain).fold(0.0, f64::max);
        (sum(&|r| r.triangle_contacts), sum(&|r| r.projection_iterations), largest_strain)
    };
    let default = CollisionSettings::default().feature_repulsion_stiffness;
    let ((pushed, pushed_projections, strain), (answered, fought, strain_without)) = (bake(default), bake(0.0));
    assert!(answered > 1000, "the cloth rests on the table's edges: {answered} contacts");
    assert!(pushed * 5 < answered * 4, "{pushed} contacts with the repulsions, {answered} without");
    let fewer = pushed_projections * 5 < fought * 4;
    assert!(fewer, "{pushed_projections} projection iterations with them, {fought} without");
    // Without them the corners used to stretch more than twice as far; the
    // correction after impact zones now holds their limit either way.
    let (with, without) = (strain * 1e2, strain_without * 1e2);
    assert!(strain <= 0.0101 + 1e-4, "the corners stretch {with:.2} % with them ({without:.2} % without)");
}

/// A table top as an OBJ mesh: a 1 m square slab, 4 cm thick, top at y = 0.
const SLAB_OBJ: &str = "v -0.5 -0.04 -0.5\nv 0.5 -0.04 -0.5\nv 0.5 -0.04 0.5\nv -0.5 -0.04 0.5\n\
v -0.5 0 -0.5\nv 0.5 0 -0.5\nv 0.5 0 0.5\nv -0.5 0 0.5\n\
f 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\nf 1 5 6\nf 1 6 2\nf 2 6 7\nf 2 7 3\nf 3 7 8\nf 3 8 4\nf 4 8 5\nf 4 5 1\n";

/// A cotton square settling on a table, as an analytic box and as a mesh:
/// the contact forces the fit map's pressure comes from add up to the
/// cloth's weight once it rests (the table holds it all up).
#[test]
fn the_contact_forces_on_a_resting_cloth_add_up_to_its_weight() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("slab.obj"), SLAB_OBJ).unwrap();
    let tables = [
        "shape = { box = { size_m = [1.0, 0.04, 1.0] } }\nposition_m = [0.0, 0.78, 0.0]",
        "shape = { mesh = { obj = \"slab.obj\" } }\nposition_m = [0.0, 0.8, 0.0]",
    ];
    for table in tables {
        let text = format!(
            "[time]\nfps = 30.0\nduration_s = 2.0\n[solver]\nsteps_per_frame = 2\n\
             [[garment]]\nname = \"cloth\"\npreset = \"cotton\"\nmesh = {{ grid = {{ size_m = 0.4, resolution = 16 }} }}\n\
             translation_m = [0.0, 0.82, 0.0]\n[[collider]]\nname = \"table\"\n{table}\n"
        );
        let path = dir.path().join("table.toml");
        std::fs::write(&path, text).unwrap();
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut baker = drape::bake::Baker::new(&scene).unwrap();
        while baker.frame() < scene.frame_count - 10 {
            baker.advance().unwrap();
        }
        baker.take_contact_forces(1);
        while baker.frame() < scene.frame_count {
            baker.advance().unwrap();
        }
        let held: f64 = baker.take_contact_forces(10).iter().map(|f| f64::from(*f)).sum();
        let fabric = &scene.garments[0].fabric;
        let weight = fabric.area_density_kg_per_m2 * 0.4 * 0.4 * 9.81;
        assert!((held / weight - 1.0).abs() < 0.05, "{table}: the table holds {held:.4} N of {weight:.4} N");
    }
}
