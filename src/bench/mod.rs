//! Benchmarks: speed of the simulation alone (no I/O) on the standard scenes,
//! always reported with the strain it reached and its error against a
//! reference run ([`accuracy`]), as CSV, Markdown and charts.

pub mod accuracy;
pub mod memory;
pub mod peers;
pub mod plots;
pub mod report;
pub mod soak;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use self::accuracy::{ErrorMeasure, Reference, RunErrors};
use crate::bake::summary::BakeSummary;
use crate::bake::{self, BakeError};

use crate::scene::file::MeshSpec;
use crate::scene::{Scene, SceneError};
use crate::sim::inextensibility::StrainLimiting;

/// One measured case.
#[derive(Clone, Debug)]
pub struct BenchResult {
    /// Scene and variant, e.g. `drape_sphere N=64`.
    pub case: String,
    /// Its summary (speed, stages, solver effort, strain).
    pub summary: BakeSummary,
    /// Peak resident memory of the process while it ran, MiB (Linux only);
    /// it includes the reference's kept frames (a few MiB at most).
    pub peak_memory_mib: Option<f64>,
    /// Its errors against the reference run, if measured.
    pub errors: Option<RunErrors>,
    /// The suites whose tables list it (`--suite all` runs a case shared by
    /// several suites once).
    pub suites: Vec<Suite>,
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A standard scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A case failed.
    #[error(transparent)]
    Bake(#[from] BakeError),
    /// A peer's frames could not be read.
    #[error(transparent)]
    Sequence(#[from] crate::metrics::sequence::SequenceError),
    /// The peer comparison could not run.
    #[error("peer comparison: {0}")]
    Peer(String),
}

/// Path of a standard scene: `assets/scenes/<name>.toml`, looked up in the
/// current folder, then in the source tree drape was built from.
pub fn standard_scene(name: &str) -> PathBuf {
    let relative = Path::new("assets/scenes").join(format!("{name}.toml"));
    if relative.exists() { relative } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(relative) }
}

/// Which cases `drape bench` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Suite {
    /// The paper's experiments of SCENES.md as the files have them
    /// (`drape_sphere` also at N = 128).
    Paper,
    /// The hard cases of SCENES.md (stability and robustness).
    Hard,
    /// The hard cases where contact and a driver pull the cloth against
    /// each other (`docs/hard-cases.md`): a cloth pulled through a funnel,
    /// gripped by a sphere that starts spinning, pinched and dragged between
    /// jaws, a sleeve on a bending arm.
    Tension,
    /// Speed against error on `drape_sphere` (contact window and end state),
    /// `drape_table` and `skirt_walk` (contact window): 1, 2, 4, 8 steps per
    /// frame × tolerances 1e-2, 1e-3, 1e-4 against the 16× reference (as
    /// `drape bench accuracy`).
    Accuracy,
    /// The solver on `drape_sphere` at N = 64 and N = 128, self-collision
    /// off (the core issue's measure). Like every suite but scaling, each
    /// case first runs its 16× reference for the error column, which takes
    /// longer than the case itself.
    Core,
    /// The collision scenes of SCENES.md at their standard sizes.
    Collisions,
    /// `drape_sphere`, `stiff` and `large_step` with the strain limits
    /// enforced by fast projection, by per-edge clamping, and not at all.
    Constraints,
    /// `drape_sphere` at N = 32, 64, 128, 256, with and without
    /// self-collision: how time and memory grow with the vertex count.
    Scaling,
    /// drape against Blender's cloth (`benches/peers/blender_cloth.py`, needs
    /// `bpy`) on `drape_sphere` and `drape_table`.
    Peers,
    /// The soak: 20,000 steps of `skirt_walk_loop` (`--frames` sets another
    /// length), watching energy, memory and intersections over time; about
    /// 20 minutes, so not part of `all`.
    Soak,
    /// All of them but the soak.
    All,
}

impl Suite {
    /// The suite's name on the command line and in `bench.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Suite::Paper => "paper",
            Suite::Hard => "hard",
            Suite::Tension => "tension",
            Suite::Accuracy => "accuracy",
            Suite::Core => "core",
            Suite::Collisions => "collisions",
            Suite::Constraints => "constraints",
            Suite::Scaling => "scaling",
            Suite::Peers => "peers",
            Suite::Soak => "soak",
            Suite::All => "all",
        }
    }

    /// The suites whose cases this one runs: itself, or each of them for `all`.
    fn parts(self) -> Vec<Suite> {
        match self {
            Suite::All => {
                vec![
                    Suite::Paper,
                    Suite::Hard,
                    Suite::Tension,
                    Suite::Core,
                    Suite::Collisions,
                    Suite::Constraints,
                    Suite::Scaling,
                ]
            }
            suite => vec![suite],
        }
    }
}

/// One benchmark case: a standard scene, edited.
#[derive(Clone, Copy, Debug)]
struct Case {
    scene: &'static str,
    /// Grid resolution (`None`: as the scene file has it).
    resolution: Option<usize>,
    self_collision: bool,
    /// Strain limiting (`None`: as the scene file has it).
    limiting: Option<StrainLimiting>,
    /// Which errors against a reference run to measure (`None`: none).
    error: Option<ErrorMeasure>,
}

impl Case {
    /// A case measured over its contact window against the reference.
    const fn new(scene: &'static str, resolution: Option<usize>, self_collision: bool) -> Self {
        Case { scene, resolution, self_collision, limiting: None, error: Some(ErrorMeasure::ContactWindow) }
    }

    /// The same case, its error measured as `error`.
    const fn with_error(self, error: Option<ErrorMeasure>) -> Self {
        Case { error, ..self }
    }

    /// The case's name in tables, e.g. `drape_sphere N=64 (no self-collision)`.
    fn name(&self, scene: &Scene) -> String {
        let mut name = scene.name.clone();
        if let Some(n) = self.resolution {
            name += &format!(" N={n}");
        }
        if !self.self_collision {
            name += " (no self-collision)";
        }
        if let Some(limiting) = self.limiting {
            name += &format!(" [{}]", limiting.name());
        }
        name
    }

    fn load(&self) -> Result<Scene, SceneError> {
        Scene::load_edited(&standard_scene(self.scene), |file| {
            for garment in &mut file.garments {
                garment.self_collision &= self.self_collision;
            }
            if let (Some(n), Some(MeshSpec::Grid { resolution, .. })) =
                (self.resolution, file.garments.first_mut().map(|g| &mut g.mesh))
            {
                *resolution = n;
            }
            if let Some(limiting) = self.limiting {
                file.solver.strain_limiting = limiting;
            }
        })
    }
}

/// Standard scenes of the collision suite, at the sizes to run them.
const COLLISION_CASES: [Case; 6] = [
    Case::new("drape_table", None, true),
    Case::new("drape_sphere", None, true).with_error(Some(ErrorMeasure::WithEndState)),
    Case::new("pillars", None, true),
    Case::new("projectile", None, true),
    Case::new("needles", None, true),
    Case::new("twist", None, true),
];

/// The paper's experiments (SCENES.md).
const PAPER_CASES: [Case; 7] = [
    Case::new("drape_sphere", None, true).with_error(Some(ErrorMeasure::WithEndState)),
    Case::new("drape_sphere", Some(128), true),
    Case::new("drape_table", None, true),
    Case::new("pillars", None, true),
    Case::new("skirt_walk", None, true),
    Case::new("skirt_tiered_walk", None, true),
    Case::new("motion_reuse", None, true),
];

/// The hard cases (SCENES.md).
const HARD_CASES: [Case; 8] = [
    Case::new("large_step", None, true),
    Case::new("stiff", None, true),
    Case::new("projectile", None, true),
    Case::new("spin_sphere", None, true),
    Case::new("twist", None, true),
    Case::new("needles", None, true),
    Case::new("fast_body", None, true),
    Case::new("bad_mesh", None, true),
];

/// The hard cases of tension through contact, each against its reference
/// but the funnel: crumpled in the neck it takes ~0.8 s a frame, and its
/// 16× reference would take half an hour.
const TENSION_CASES: [Case; 4] = [
    Case::new("pull_through_funnel", None, true).with_error(None),
    Case::new("spin_sphere_grip", None, true),
    Case::new("pinch_drag", None, true),
    Case::new("sleeve_elbow", None, true),
];

/// Scenes of the accuracy suite, with the errors each is measured by: the
/// static `drape_sphere` also at its end state.
pub const ACCURACY_SCENES: [(&str, ErrorMeasure); 3] = [
    ("drape_sphere", ErrorMeasure::WithEndState),
    ("drape_table", ErrorMeasure::ContactWindow),
    ("skirt_walk", ErrorMeasure::ContactWindow),
];
/// Steps per frame the accuracy suite sweeps.
pub const ACCURACY_STEPS: [u32; 4] = [1, 2, 4, 8];
/// Linear-solver tolerances the accuracy suite sweeps.
pub const ACCURACY_TOLERANCES: [f64; 3] = [1e-2, 1e-3, 1e-4];

/// Grid sizes of the scaling suite, vertices per side.
const SCALING_SIZES: [usize; 4] = [32, 64, 128, 256];

/// The cases of `suite`. Every case but the scaling suite's (whose
/// references at N = 256 would take hours) is measured against its reference
/// over the contact window; `drape_sphere` at N = 64, a static scene, also
/// at its end state (at N = 128 that reference would take ~10 minutes).
fn cases(suite: Suite) -> Vec<Case> {
    let end_state = Some(ErrorMeasure::WithEndState);
    let core =
        [Case::new("drape_sphere", Some(64), false).with_error(end_state), Case::new("drape_sphere", Some(128), false)];
    let limitings = [StrainLimiting::Projection, StrainLimiting::Clamp, StrainLimiting::Off];
    let constraints = ["drape_sphere", "stiff", "large_step"]
        .into_iter()
        .flat_map(|scene| limitings.map(|limiting| Case { limiting: Some(limiting), ..Case::new(scene, None, true) }))
        .map(|case| if case.scene == "drape_sphere" { case.with_error(end_state) } else { case });
    let scaling = SCALING_SIZES
        .into_iter()
        .flat_map(|n| [true, false].map(|own| Case::new("drape_sphere", Some(n), own).with_error(None)));
    match suite {
        Suite::Core => core.to_vec(),
        Suite::Collisions => COLLISION_CASES.to_vec(),
        Suite::Constraints => constraints.collect(),
        Suite::Scaling => scaling.collect(),
        Suite::Paper => PAPER_CASES.to_vec(),
        Suite::Hard => HARD_CASES.to_vec(),
        Suite::Tension => TENSION_CASES.to_vec(),
        Suite::Accuracy | Suite::Peers | Suite::Soak | Suite::All => Vec::new(),
    }
}

/// Runs `suite`, logging each case as it starts: its reference run first
/// (if it is measured against one; a reference that fails is logged and the
/// case runs without an error figure), then the case itself. A case whose
/// simulation stops is logged with the reason and kept, measured over the
/// frames before the stop and named so in every table; the suite goes on.
/// A case that several of `all`'s suites list (the same name) runs once,
/// measured as its first suite asks, and is tagged with each of them.
pub fn run(suite: Suite, frames: Option<usize>, log: impl Fn(&str)) -> Result<Vec<BenchResult>, BenchError> {
    let mut results: Vec<BenchResult> = Vec::new();
    let mut names = Vec::new();
    for part in suite.parts() {
        for case in cases(part) {
            let scene = case.load()?;
            let name = case.name(&scene);
            if let Some(k) = names.iter().position(|n| *n == name) {
                results[k].suites.push(part);
                continue;
            }
            names.push(name.clone());
            results.push(run_case(&case, &scene, name, frames, &log)?.in_suite(part));
        }
    }
    Ok(results)
}

/// Runs one case of `scene`: its reference first when it is measured
/// against one, then the case, named `name` (with the frames it reached if
/// it stopped).
fn run_case(
    case: &Case,
    scene: &Scene,
    name: String,
    frames: Option<usize>,
    log: &impl Fn(&str),
) -> Result<BenchResult, BenchError> {
    let length = frames.map_or(scene.frame_count, |n| n.min(scene.frame_count));
    let reference = case.error.and_then(|error| {
        log(&format!("running {name}: its reference ..."));
        Reference::run(scene, length, error)
            .inspect_err(|failure| log(&format!("{name}: the reference run failed ({failure}); no error measured")))
            .ok()
    });
    log(&format!("running {name} ..."));
    memory::reset_peak();
    let (summary, errors) = measure(scene, frames, reference.as_ref())?;
    let case = match &summary.stopped {
        Some(why) => {
            log(&format!("{name}: {why}; measured over the frames before"));
            format!("{name} (stopped after {} frames)", summary.frames - 1)
        }
        None => name,
    };
    Ok(BenchResult { summary, case, peak_memory_mib: memory::peak_mib(), errors, suites: Vec::new() })
}

impl BenchResult {
    /// The result, listed in `suite`'s tables.
    fn in_suite(mut self, suite: Suite) -> Self {
        self.suites.push(suite);
        self
    }
}

/// Runs `scene` (the first `frames` frames, or all) and summarises it, with
/// its errors against `reference` when one is given. A simulation that stops
/// is summarised up to the stop, with the reason in the summary's `stopped`.
pub fn measure(
    scene: &Scene,
    frames: Option<usize>,
    reference: Option<&Reference>,
) -> Result<(BakeSummary, Option<RunErrors>), BakeError> {
    let frames = frames.map_or(scene.frame_count, |n| n.min(scene.frame_count));
    let mut meter = reference.map(Reference::meter);
    let (records, failure) = bake::run(scene, frames, &AtomicBool::new(false), |sim, record| {
        if let Some(meter) = &mut meter {
            meter.record(record.frame, sim.positions());
        }
        Ok(())
    })?;
    let stopped = failure.map(|failure| failure.to_string());
    Ok((BakeSummary::new(scene, &records, frames, stopped), meter.map(|m| m.errors())))
}

/// A relative error (a fraction of the cloth's diagonal) in the accuracy
/// tables' notation, `-` if absent.
fn relative(error: Option<f64>) -> String {
    error.map_or("-".into(), |e| format!("{e:.2e}"))
}

/// Names of the step's stages, in pipeline order.
fn stage_names() -> impl Iterator<Item = &'static str> {
    crate::sim::step::StageTimings::default().stages().into_iter().map(|(name, _)| name)
}

/// The results as a Markdown table.
pub fn markdown_table(results: &[BenchResult]) -> String {
    let mut out = String::from("| case | vertices | threads | ms/frame (median) |");
    for stage in stage_names() {
        let _ = write!(out, " {stage} |");
    }
    out += " CG it/step | max strain | error, contact window | error, end |\n|---|---:|---:|---:|";
    for _ in stage_names() {
        out += "---:|";
    }
    out += "---:|---:|---:|---:|\n";
    for r in results {
        let s = &r.summary;
        let _ = write!(out, "| {} | {} | {} | {:.2} |", r.case, s.vertices, s.threads, s.ms_per_frame_median);
        for stage in stage_names() {
            let _ = write!(out, " {:.2} |", s.stage_ms_per_frame_median.get(stage).copied().unwrap_or(0.0));
        }
        let _ = writeln!(
            out,
            " {:.1} | {:.3} % | {} | {} |",
            s.cg_iterations_per_step_mean,
            s.max_strain * 100.0,
            relative(r.errors.and_then(|e| e.contact)),
            relative(r.errors.and_then(|e| e.end))
        );
    }
    out
}

/// The collision figures of the results as a Markdown table: collision
/// stages (median ms per frame), the most triangle contacts in a frame,
/// elementary tests per frame with and without representative triangles,
/// steps that needed impact zones, and what the independent checker found.
pub fn collision_table(results: &[BenchResult]) -> String {
    let mut out = String::from(
        "| case | vertices | ms/frame | refit | broad | narrow | response | triangle contacts (max) \
         | tests/frame | without ownership | saved | zone steps | intersections | penetrating |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in results {
        let s = &r.summary;
        let stage = |name: &str| s.stage_ms_per_frame_median.get(name).copied().unwrap_or(0.0);
        let frames = s.frames.max(1) as f64;
        let (tests, without) = (s.collision_tests as f64 / frames, s.collision_tests_without_ownership as f64 / frames);
        let saved = if without > 0.0 { format!("{:.0} %", 100.0 * (1.0 - tests / without)) } else { "-".into() };
        let contacts = s.per_frame.iter().map(|f| f.triangle_contacts).max().unwrap_or(0);
        let _ = writeln!(
            out,
            "| {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {:.0} | {:.0} | {} | {} | {} | {} |",
            r.case,
            s.vertices,
            s.ms_per_frame_median,
            stage("refit"),
            stage("broad"),
            stage("narrow"),
            stage("response"),
            contacts,
            tests,
            without,
            saved,
            s.impact_zone_steps,
            s.intersections_total,
            s.penetrations_total
        );
    }
    out
}

/// The strain-limit figures of the results as a Markdown table: time, the
/// projection's share and effort, and the strain (largest, largest off the
/// edges pinned at both ends, mean) and intersections reached.
pub fn constraints_table(results: &[BenchResult]) -> String {
    let mut out = String::from(
        "| case | vertices | ms/frame | constraints ms/frame | Newton it/step | clamp fallbacks | rollbacks \
         | max strain | not between pins | mean strain (last) | intersections |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in results {
        let s = &r.summary;
        let _ = writeln!(
            out,
            "| {} | {} | {:.1} | {:.2} | {:.2} | {} | {} | {:.3} % | {:.3} % | {:.3} % | {} |",
            r.case,
            s.vertices,
            s.ms_per_frame_median,
            s.stage_ms_per_frame_median.get("constraints").copied().unwrap_or(0.0),
            s.projection_iterations_per_step_mean,
            s.projection_fallbacks,
            s.rollbacks,
            s.max_strain * 100.0,
            s.max_free_strain * 100.0,
            s.mean_strain_last * 100.0,
            s.intersections_total
        );
    }
    out
}

/// The results as CSV, one row per case.
pub fn csv(results: &[BenchResult]) -> String {
    let mut out =
        String::from("case,suites,vertices,threads,frames,steps_per_frame,ms_per_frame_median,ms_per_frame_p95");
    for stage in stage_names() {
        let _ = write!(out, ",{stage}_ms");
    }
    out += ",cg_iterations_per_step,max_strain,max_free_strain,contacts_max,collision_tests,\
            collision_tests_without_ownership,impact_zone_steps,intersections_total,penetrations_total,projection_iterations_per_step,\
            projection_fallbacks,rollbacks,peak_memory_mib,error_contact_window,error_end\n";
    for r in results {
        let s = &r.summary;
        let _ = write!(
            out,
            "{},{},{},{},{},{},{:.4},{:.4}",
            r.case,
            r.suites.iter().map(|suite| suite.name()).collect::<Vec<_>>().join(";"),
            s.vertices,
            s.threads,
            s.frames,
            s.steps_per_frame,
            s.ms_per_frame_median,
            s.ms_per_frame_p95
        );
        for stage in stage_names() {
            let _ = write!(out, ",{:.4}", s.stage_ms_per_frame_median.get(stage).copied().unwrap_or(0.0));
        }
        let error = |value: Option<f64>| value.map_or(String::new(), |v| format!("{v:.6e}"));
        let _ = writeln!(
            out,
            ",{:.2},{:.6},{:.6},{},{},{},{},{},{},{:.2},{},{},{},{},{}",
            s.cg_iterations_per_step_mean,
            s.max_strain,
            s.max_free_strain,
            s.contacts_max,
            s.collision_tests,
            s.collision_tests_without_ownership,
            s.impact_zone_steps,
            s.intersections_total,
            s.penetrations_total,
            s.projection_iterations_per_step_mean,
            s.projection_fallbacks,
            s.rollbacks,
            r.peak_memory_mib.map_or(String::new(), |m| format!("{m:.1}")),
            error(r.errors.and_then(|e| e.contact)),
            error(r.errors.and_then(|e| e.end))
        );
    }
    out
}

/// Least-squares slope of `ln y` against `ln x`: the exponent `p` of `y ∝ xᵖ`.
pub fn power_law_exponent(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> =
        points.iter().filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| (x.ln(), y.ln())).collect();
    if logs.len() < 2 {
        return None;
    }
    let n = logs.len() as f64;
    let (mx, my) = (logs.iter().map(|p| p.0).sum::<f64>() / n, logs.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The results grouped by case without its size (`drape_sphere N=64 (no
/// self-collision)` → `drape_sphere (no self-collision)`): time and memory
/// against the vertex count, and the exponent of time per frame in it.
pub fn scaling_table(results: &[BenchResult]) -> String {
    let group_of = |case: &str| case.split(' ').filter(|w| !w.starts_with("N=")).collect::<Vec<_>>().join(" ");
    let mut groups: Vec<String> = Vec::new();
    for r in results {
        let group = group_of(&r.case);
        if !groups.contains(&group) {
            groups.push(group);
        }
    }
    let mut out = String::from(
        "| case | vertices | ms/frame (median) | peak memory (MiB) | KiB per vertex | time exponent |\n\
         |---|---:|---:|---:|---:|---:|\n",
    );
    for group in groups {
        let members: Vec<&BenchResult> = results.iter().filter(|r| group_of(&r.case) == group).collect();
        let points: Vec<(f64, f64)> =
            members.iter().map(|r| (r.summary.vertices as f64, r.summary.ms_per_frame_median)).collect();
        let exponent = power_law_exponent(&points).map_or("-".into(), |p| format!("{p:.2}"));
        for (k, r) in members.iter().enumerate() {
            let memory = r.peak_memory_mib.map_or("-".into(), |m| format!("{m:.0}"));
            let per_vertex =
                r.peak_memory_mib.map_or("-".into(), |m| format!("{:.1}", m * 1024.0 / r.summary.vertices as f64));
            let shown = if k == 0 { exponent.as_str() } else { "" };
            let _ = writeln!(
                out,
                "| {} | {} | {:.1} | {memory} | {per_vertex} | {shown} |",
                r.case, r.summary.vertices, r.summary.ms_per_frame_median
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::file::{SceneFile, SceneKind};

    /// Every hard case among the standard scenes is benchmarked: in the hard
    /// suite or, where contact and a driver pull the cloth at once, in the
    /// tension suite; `all` runs both.
    #[test]
    fn every_hard_case_scene_is_in_the_hard_or_the_tension_suite() {
        let suites = [Suite::Hard, Suite::Tension];
        assert!(suites.iter().all(|suite| Suite::All.parts().contains(suite)));
        let benchmarked: Vec<&str> = suites.into_iter().flat_map(cases).map(|case| case.scene).collect();
        let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
        let mut hard_cases = 0;
        for entry in std::fs::read_dir(&folder).expect("the scenes folder") {
            let path = entry.expect("a scene").path();
            let text = std::fs::read_to_string(&path).expect("a readable scene");
            let file: SceneFile = toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let name = path.file_stem().and_then(|stem| stem.to_str()).expect("a name");
            if file.kind == SceneKind::HardCase {
                assert!(benchmarked.contains(&name), "{name} is a hard case no suite runs");
                hard_cases += 1;
            }
        }
        assert_eq!(hard_cases, benchmarked.len(), "each benchmarked once: {benchmarked:?}");
    }

    #[test]
    fn the_exponent_of_a_power_law_is_its_log_log_slope() {
        let cubic: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0].iter().map(|&x| (x, 3.0 * x * x * x)).collect();
        assert!((power_law_exponent(&cubic).unwrap() - 3.0).abs() < 1e-12);
        assert_eq!(power_law_exponent(&cubic[..1]), None);
    }
}
