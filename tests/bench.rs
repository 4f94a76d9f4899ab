//! The benchmark harness on a tiny scene: what it writes, and that its error
//! metric measures what it says.

use drape::bench::accuracy::{self, ErrorMeasure, Reference};
use drape::bench::report::{write_accuracy, write_results};
use drape::bench::{BenchResult, Suite, measure, standard_scene};
use drape::scene::Scene;
use drape::scene::file::MeshSpec;

/// `drape_sphere` at 12 × 12 vertices, the first `frames` frames of it.
fn tiny_drape_sphere() -> Scene {
    Scene::load_edited(&standard_scene("drape_sphere"), |file| {
        if let Some(MeshSpec::Grid { resolution, .. }) = file.garments.first_mut().map(|g| &mut g.mesh) {
            *resolution = 12;
        }
    })
    .unwrap()
}

#[test]
fn bench_writes_a_full_csv_the_report_and_non_empty_charts() {
    let scene = tiny_drape_sphere();
    let reference = Reference::run(&scene, 12, ErrorMeasure::WithEndState).unwrap();
    let (summary, errors) = measure(&scene, Some(12), Some(&reference)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let result =
        BenchResult { case: "tiny".into(), summary, peak_memory_mib: Some(120.0), errors, suites: vec![Suite::Paper] };
    write_results(dir.path(), &[result]).unwrap();

    let csv = std::fs::read_to_string(dir.path().join("bench.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 2, "{csv}");
    let columns = lines[0].split(',').count();
    assert_eq!(lines[1].split(',').count(), columns, "every column filled: {csv}");
    assert!(lines[1].starts_with("tiny,paper,"), "the case and the suites listing it: {csv}");
    for column in [
        "ms_per_frame_median",
        "ms_per_frame_p95",
        "max_strain",
        "intersections_total",
        "cg_iterations_per_step",
        "solve_ms",
        "peak_memory_mib",
        "error_contact_window",
        "error_end",
    ] {
        assert!(lines[0].split(',').any(|c| c == column), "{column} missing: {}", lines[0]);
    }
    let report = std::fs::read_to_string(dir.path().join("bench.md")).unwrap();
    assert!(report.contains("| tiny |") && report.contains("strain_over_time.png"), "{report}");
    for chart in ["strain_over_time", "time_per_stage"] {
        let png = image::open(dir.path().join(format!("{chart}.png"))).unwrap().to_luma8();
        // Something besides the white background is drawn (axes, lines, text).
        let inked = png.pixels().filter(|p| p.0[0] < 128).count();
        assert!(inked > 1000, "{chart}.png is nearly blank ({inked} dark pixels)");
        let svg = std::fs::read_to_string(dir.path().join(format!("{chart}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.contains("tiny"), "{chart}.svg");
    }
}

/// Results of several suites (`--suite all`) also get each suite's charts, in
/// a folder named after it, drawn from that suite's cases only.
#[test]
fn results_of_several_suites_get_each_suites_charts() {
    let scene = tiny_drape_sphere();
    let (summary, _) = measure(&scene, Some(6), None).unwrap();
    let case = |name: &str, suites| BenchResult {
        case: name.into(),
        summary: summary.clone(),
        peak_memory_mib: None,
        errors: None,
        suites,
    };
    let results = [case("shared", vec![Suite::Paper, Suite::Collisions]), case("hard only", vec![Suite::Hard])];
    let dir = tempfile::tempdir().unwrap();
    write_results(dir.path(), &results).unwrap();
    for (suite, has, lacks) in
        [("paper", "shared", "hard only"), ("collisions", "shared", "hard only"), ("hard", "hard only", "shared")]
    {
        let svg = std::fs::read_to_string(dir.path().join(suite).join("strain_over_time.svg")).unwrap();
        assert!(svg.contains(has) && !svg.contains(lacks), "{suite}'s chart");
        assert!(dir.path().join(suite).join("time_per_stage.png").exists());
    }
}

#[test]
fn the_error_is_zero_against_itself_and_grows_with_the_step() {
    let scene = tiny_drape_sphere();
    let frames = 30; // past the first contact (frame ~7) and its window
    let reference = Reference::run(&scene, frames, ErrorMeasure::WithEndState).unwrap();
    let window = reference.contact_window();
    assert!(*window.start() > 0 && *window.end() < frames, "contact starts and its window ends: {window:?}");
    assert_eq!(reference.frames_needed(), frames, "the end state is the last frame");

    let errors_at = |steps: u32, tolerance: f64| {
        let run = accuracy::variant(&scene, steps, tolerance);
        measure(&run, Some(frames), Some(&reference)).unwrap().1.unwrap()
    };
    let itself = errors_at(2 * accuracy::REFERENCE_REFINEMENT, accuracy::REFERENCE_TOLERANCE);
    assert_eq!((itself.contact, itself.end), (Some(0.0), Some(0.0)));
    let contact = |steps: u32| errors_at(steps, 1e-6).contact.unwrap();
    let (coarse, medium, fine) = (contact(1), contact(2), contact(4));
    assert!(coarse > medium && medium > fine && fine > 0.0, "{coarse} {medium} {fine}");
    assert!(errors_at(4, 1e-6).end.is_some_and(|e| e > 0.0));
}

#[test]
fn a_contact_window_reference_stops_at_the_end_of_the_window() {
    let scene = tiny_drape_sphere();
    let reference = Reference::run(&scene, 40, ErrorMeasure::ContactWindow).unwrap();
    let window = reference.contact_window();
    // 0.5 s at 30 frames per second after the first contact.
    assert_eq!(window.clone().count(), 16, "{window:?}");
    assert_eq!(reference.frames_needed(), *window.end());
    // A run that stops inside the window has no contact-window error.
    let (_, short) = measure(&scene, Some(*window.end() - 1), Some(&reference)).unwrap();
    assert_eq!(short.unwrap().contact, None);
}

#[test]
fn the_speed_against_error_chart_is_drawn() {
    let points = vec![
        accuracy::AccuracyPoint {
            steps_per_frame: 1,
            tolerance: 1e-3,
            ms_per_frame: 10.0,
            contact_error: 3e-2,
            end_error: Some(1e-2),
            max_strain: 0.01,
            pareto: true,
        },
        accuracy::AccuracyPoint {
            steps_per_frame: 4,
            tolerance: 1e-3,
            ms_per_frame: 40.0,
            contact_error: 5e-3,
            end_error: None,
            max_strain: 0.01,
            pareto: true,
        },
    ];
    let dir = tempfile::tempdir().unwrap();
    write_accuracy(dir.path(), &[("tiny".into(), points)]).unwrap();
    let png = image::open(dir.path().join("speed_against_error.png")).unwrap().to_luma8();
    assert!(png.pixels().filter(|p| p.0[0] < 128).count() > 1000);
    assert!(std::fs::read_to_string(dir.path().join("accuracy.md")).unwrap().contains("speed_against_error.png"));
}
