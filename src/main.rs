//! The `drape` command: parse, dispatch, map errors to exit codes
//! (0 ok, 1 bad input, 2 internal failure, 3 a check found problems,
//! 130 cancelled by Ctrl-C).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod cli;

use clap::{Parser, Subcommand};

use drape::bench;
use drape::bench::accuracy::ErrorMeasure;
use drape::fabric_lab;
use drape::scene::Scene;
use drape::scene::summary::summary;

#[derive(Parser)]
#[command(name = "drape", version, about = "Cloth animation: simulate garments on colliders, bake and export frames")]
struct Cli {
    /// Solver threads (default: one per core). Results are identical at any count.
    #[arg(long, global = true)]
    threads: Option<usize>,
    /// What to do (default: open the editor on the default scene).
    #[command(subcommand)]
    command: Option<Command>,
}

/// The built-in default scene: the skirt on the walking body.
const DEFAULT_SCENE: &str = "skirt_walk.toml";

/// The editor's quality, as the live benchmark names it.
#[derive(Clone, Copy, clap::ValueEnum)]
enum LiveQuality {
    Preview,
    Balanced,
    Final,
}

impl LiveQuality {
    fn quality(self) -> drape::app::Quality {
        match self {
            LiveQuality::Preview => drape::app::Quality::Preview,
            LiveQuality::Balanced => drape::app::Quality::Balanced,
            LiveQuality::Final => drape::app::Quality::Final,
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Open the editor (a window): tune the fabric while the cloth simulates,
    /// bake, play back, export. `drape` alone opens it on the default scene.
    Edit {
        /// Scene file (TOML); default: the skirt on the walking body.
        scene: Option<PathBuf>,
        /// Write the window's image to this PNG once the scene is shown, then
        /// close (smoke tests, screenshots for documentation).
        #[arg(long, hide = true)]
        screenshot: Option<PathBuf>,
        /// With --screenshot: simulate this many frames live first (at most the
        /// scene's range).
        #[arg(long, hide = true, default_value_t = 0)]
        screenshot_after: usize,
        /// With --screenshot: simulate at this quality, and print how many
        /// frames per second came while the window drew (the live benchmark).
        #[arg(long, hide = true)]
        screenshot_quality: Option<LiveQuality>,
    },
    /// Simulate a scene without a window and write its frames: OBJ sequence, PC2
    /// point caches, summary.json.
    Bake {
        /// Scene file (TOML), e.g. assets/scenes/drape_sphere.toml.
        scene: PathBuf,
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Bake only the first N frames of the scene's range.
        #[arg(long)]
        frames: Option<usize>,
        /// Go on with the unfinished bake in --out (stopped by Ctrl-C, a
        /// crash or a kill) after its last finished frame; the result is the
        /// same, bit for bit, as a bake that never stopped.
        #[arg(long)]
        resume: bool,
        /// Once the bake is complete, also export it: `usd`, `gltf`, `mdd`,
        /// comma separated (the files go into --out, named after the scene).
        #[arg(long, value_name = "FORMATS")]
        export: Option<String>,
    },
    /// Export a finished bake folder for other tools: USD (.usda: Maya,
    /// Houdini, Unreal, Omniverse, Blender), glTF (.glb: browsers, three.js,
    /// Blender) or MDD (one per garment: Marvelous Designer, Houdini, Modo),
    /// with the body it was simulated on.
    Export {
        /// The bake folder (from `drape bake`).
        dir: PathBuf,
        /// `usd`, `gltf` or `mdd` (several, comma separated, without --out).
        #[arg(long)]
        format: String,
        /// The file to write (the folder for MDD); default: in DIR, named after the scene.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Frames to export, `A..B` (both included) or one frame `N` (default: all).
        #[arg(long)]
        frames: Option<String>,
        /// Leave the body out (garments and colliders only).
        #[arg(long)]
        no_body: bool,
        /// glTF: a morph target every K frames, weights animated linearly between them.
        #[arg(long, default_value_t = 1)]
        every: usize,
        /// glTF: positions and normals as 16-bit integers (KHR_mesh_quantization).
        #[arg(long)]
        quantize: bool,
        /// The scene the bake was made from (default: the one its summary.json names).
        #[arg(long)]
        scene: Option<PathBuf>,
    },
    /// Write a sweep's variants (one resolved scene each, with its key) and
    /// manifest into a sweep folder, for `drape farm run`.
    Sweep {
        /// The sweep file (TOML), e.g. assets/sweeps/fabrics.toml.
        spec: PathBuf,
        /// The sweep folder (created; variants whose key did not change keep their bakes).
        #[arg(long)]
        out: PathBuf,
    },
    /// Bake a sweep's variants on a farm (Slurm job arrays) or here, and
    /// gather what they gave.
    #[command(subcommand)]
    Farm(FarmCommand),
    /// Validate a scene and its assets, and print what they contain.
    Check {
        /// Scene file (TOML).
        scene: PathBuf,
    },
    /// Count intersecting triangles and penetrating vertices in every frame of
    /// an OBJ sequence (a bake of ours or another program's export), with the
    /// independent checker. Exit code 3 when any are found.
    CheckBake {
        /// Folder of numbered OBJ frames (frame_0000.obj, ...).
        dir: PathBuf,
        /// Scene whose colliders to check against (default: the scene named in
        /// DIR/summary.json, if any; without one only the cloth is checked).
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Also write the per-frame counts to this JSON file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Render PNG frames offscreen (no window, no GPU needed: Mesa's lavapipe
    /// works): a scene is simulated on the fly, a bake folder is read from its
    /// point caches. Make a video with
    /// `ffmpeg -framerate 30 -i DIR/frame_%04d.png -pix_fmt yuv420p out.mp4`.
    Render {
        /// Scene file (TOML) or bake folder (from `drape bake`).
        source: PathBuf,
        /// Output folder for frame_NNNN.png (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Frames to render, `A..B` (both included) or one frame `N`
        /// (default: all; frame 0 is the initial state).
        #[arg(long)]
        frames: Option<String>,
        /// Light rig: studio, daylight, overcast, evening, or a rig TOML file.
        #[arg(long, default_value = "studio")]
        light: String,
        /// Image size, WIDTHxHEIGHT pixels.
        #[arg(long, default_value = "1280x720")]
        size: String,
        /// Turn the camera once around the scene in this many seconds
        /// (overrides the scene's camera.turntable_period_s).
        #[arg(long)]
        turntable: Option<f64>,
        /// For a bake folder: the scene it was baked from (default: the one
        /// named in its summary.json).
        #[arg(long)]
        scene: Option<PathBuf>,
    },
    /// Read a character (FBX 7, binary or ASCII) and report its meshes (skinned,
    /// rigid or static), nodes, animation stacks and motion; with --motion, how
    /// another file's motion fits this body's bones. A file without a mesh is
    /// described as a motion. Prints the time to skin one frame.
    Body {
        /// The body's FBX file.
        body: PathBuf,
        /// Drive the body with this file's motion instead of its own.
        #[arg(long)]
        motion: Option<PathBuf>,
        /// The animation stack to use (of the --motion file when given);
        /// default: the first.
        #[arg(long)]
        stack: Option<String>,
    },
    /// Bake a body's motion into a binary motion cache (the skinned mesh frame
    /// by frame): simulating against it is then a copy per frame.
    ImportMotion {
        /// The body's FBX file.
        body: PathBuf,
        /// Drive the body with this FBX file's motion (bones matched by name).
        #[arg(long)]
        motion: Option<PathBuf>,
        /// The animation stack to use (of the --motion file when given);
        /// default: the first.
        #[arg(long)]
        stack: Option<String>,
        /// Frames per second of the cache.
        #[arg(long, default_value_t = 30.0)]
        fps: f64,
        /// Mark the motion as a cycle (it repeats in scenes).
        #[arg(long)]
        cycle: bool,
        /// The cache file to write (e.g. walk.motion).
        #[arg(long)]
        out: PathBuf,
    },
    /// Measure simulation speed (ms per frame, per stage) with strain, on the
    /// standard scenes.
    Bench {
        /// `accuracy SCENE`: speed against error instead of the suites.
        #[command(subcommand)]
        sweep: Option<BenchSweep>,
        /// Which cases: the paper's experiments, the hard cases, speed against
        /// error on drape_sphere (accuracy), the solver alone on drape_sphere
        /// (core), the collision scenes, the strain limits (projection,
        /// clamping, off), time and memory against the vertex count
        /// (scaling), drape against Blender's cloth (peers; needs bpy), or all.
        #[arg(long, value_enum, default_value = "core")]
        suite: bench::Suite,
        /// Frames per case (default: each scene's full range).
        #[arg(long)]
        frames: Option<usize>,
        /// Folder for bench.csv and bench.md.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The virtual fabric lab: test presets as a fabric kit would, or fit a
    /// preset to measurements.
    Fabric {
        /// Test presets, or fit one.
        #[command(subcommand)]
        command: FabricCommand,
    },
}

/// The virtual fabric lab.
#[derive(Subcommand)]
enum FarmCommand {
    /// Run the variants not yet finished: `--slurm` submits a job array
    /// (arguments after `--` go to sbatch: partition, account, time limit),
    /// `--local` runs them here.
    Run {
        /// The sweep folder (from `drape sweep`).
        dir: PathBuf,
        /// Submit an sbatch job array (one task per variant).
        #[arg(long, conflicts_with = "local", required_unless_present = "local")]
        slurm: bool,
        /// Run the tasks on this machine.
        #[arg(long)]
        local: bool,
        /// With --local: tasks at a time (the cores are shared between them).
        #[arg(short = 'j', long, default_value_t = 1)]
        jobs: usize,
        /// Run the variants whose simulation stopped again too.
        #[arg(long)]
        retry_failed: bool,
        /// Extra sbatch arguments (after `--`).
        #[arg(last = true)]
        sbatch: Vec<String>,
    },
    /// Bake one variant (what each farm task runs): resumes a started bake,
    /// does nothing for a finished one.
    Task {
        /// The sweep folder.
        dir: PathBuf,
        /// The variant's index (the array task id).
        index: usize,
    },
    /// Each variant's state: finished, failed (with why), started, pending,
    /// or Slurm's state of its task.
    Status {
        /// The sweep folder.
        dir: PathBuf,
    },
    /// One table of every variant's summary (report.csv, report.md) and a
    /// contact sheet of one frame of each (contact_sheet.png).
    Collect {
        /// The sweep folder.
        dir: PathBuf,
        /// The frame on the contact sheet (default: the last).
        #[arg(long)]
        frame: Option<usize>,
        /// Light rig of the contact sheet.
        #[arg(long, default_value = "studio")]
        light: String,
        /// Where to write (default: the sweep folder).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(Subcommand)]
enum FabricCommand {
    /// Run the virtual cantilever (ASTM D1388) and Cusick drape tests on
    /// presets: bending length, flexural rigidity, drape coefficient, nodes.
    /// Exit code 3 when a bending length misses its target by more than 5 %.
    Test {
        /// Built-in preset names or preset files (default: every built-in preset).
        presets: Vec<String>,
        /// Skip the drape test (the slower one).
        #[arg(long)]
        no_drape: bool,
        /// Vertices across the drape specimen (41: 7.5 mm elements).
        #[arg(long, default_value_t = drape::fabric_lab::cusick::STANDARD_ACROSS)]
        across: usize,
        /// Write each drape test's shadow, seen from above, to DIR/<preset>_drape.png.
        #[arg(long, value_name = "DIR")]
        pictures: Option<PathBuf>,
    },
    /// Fit bend (and shear) parameters to measured values and write a preset.
    Fit {
        /// Measured cantilever bending length, cm.
        #[arg(long)]
        bending_length: f64,
        /// Measured area density, g/m².
        #[arg(long)]
        area_density: f64,
        /// Measured Cusick drape coefficient (0..1): fits the shear stiffness too.
        #[arg(long)]
        drape_coefficient: Option<f64>,
        /// Preset the other parameters come from (name or file).
        #[arg(long, default_value = "cotton")]
        base: String,
        /// Name of the new preset (default: the output file's stem).
        #[arg(long)]
        name: Option<String>,
        /// Vertices across the drape specimens (41: 7.5 mm elements).
        #[arg(long, default_value_t = drape::fabric_lab::cusick::STANDARD_ACROSS)]
        across: usize,
        /// The preset file to write (TOML).
        #[arg(long)]
        out: PathBuf,
    },
}

/// Sweeps of `drape bench`.
#[derive(Subcommand)]
enum BenchSweep {
    /// Speed against error: run SCENE at each steps-per-frame and tolerance,
    /// compare each run with a reference of 16x smaller steps and tolerance
    /// 1e-10 (RMS error over the rest diagonal, over the 0.5 s after first
    /// contact, and at the end with --end-state), and print the table with
    /// the Pareto front.
    Accuracy {
        /// The scene file.
        scene: PathBuf,
        /// Steps per frame to try.
        #[arg(long, value_delimiter = ',', default_value = "1,2,4,8")]
        steps: Vec<u32>,
        /// Linear-solver tolerances to try.
        #[arg(long, value_delimiter = ',', default_value = "1e-2,1e-3,1e-4")]
        tolerances: Vec<f64>,
        /// Frames per run at most (default: the scene's full range; runs
        /// stop at the end of the contact window unless --end-state).
        #[arg(long)]
        frames: Option<usize>,
        /// Also compare the last frame (the end state of a static scene):
        /// every run, the reference too, covers the whole range.
        #[arg(long)]
        end_state: bool,
        /// Folder for accuracy.csv, accuracy.md and the chart.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// Turns off Mesa's Vulkan device-select layer where there is no desktop
/// session (`XDG_RUNTIME_DIR` unset: root on a headless machine, a CI
/// runner). The layer asks the Wayland compositor which GPU drives the
/// display, and without a session libwayland prints "error: XDG_RUNTIME_DIR
/// is invalid or not set" on every adapter query though nothing failed;
/// with no session there is no display to match, and wgpu picks the
/// adapter itself. `NODEVICE_SELECT` is the layer's own off switch (its
/// manifest's `disable_environment`); one the user set is left alone.
fn without_display_server_probe() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: the first thing `main` does, before any other thread
        // exists to read the environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// How a command failed, which decides the exit code.
pub(crate) enum Failure {
    /// Bad input: a file, a value, an unwritable output (exit 1).
    Input(String),
    /// The simulation or the program failed (exit 2).
    Internal(String),
    /// Ctrl-C (exit 130).
    Cancelled(String),
    /// A check ran and found problems (exit 3).
    Found(String),
}

/// Ends the process quietly when its output is a pipe that closed
/// (`drape body F | head -1`), as `cat` and `ls` do, instead of a panic
/// from the print that could not be written.
fn quiet_on_closed_pipe() {
    // SAFETY: restoring the default disposition of one signal, before any
    // other thread exists.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
}

fn main() -> ExitCode {
    without_display_server_probe();
    quiet_on_closed_pipe();
    // A command line we cannot read is bad input (exit 1), like a bad file;
    // clap's own convention (2) would say the simulation failed.
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(u8::from(e.use_stderr()));
        }
    };
    if let Some(threads) = cli.threads
        && let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(threads).build_global()
    {
        eprintln!("error: cannot start {threads} threads: {e}");
        return ExitCode::from(2);
    }
    let command = cli.command.unwrap_or(Command::Edit {
        scene: None,
        screenshot: None,
        screenshot_after: 0,
        screenshot_quality: None,
    });
    let result = match command {
        Command::Edit { scene, screenshot, screenshot_after, screenshot_quality } => {
            let quality = screenshot_quality.map(LiveQuality::quality);
            let screenshot =
                screenshot.map(|path| drape::app::Screenshot { path, after_frames: screenshot_after, quality });
            run_edit(scene, screenshot)
        }
        Command::Bake { scene, out, frames, resume, export } => cli::bake::run_bake(&scene, &out, frames, resume)
            .and_then(|()| match export {
                Some(formats) => {
                    let options = cli::export::ExportOptions {
                        out: None,
                        frames: None,
                        no_body: false,
                        every: 1,
                        quantize: false,
                        scene: None,
                    };
                    cli::export::run_export(&out, &cli::export::parse_formats(&formats)?, &options)
                }
                None => Ok(()),
            }),
        Command::Export { dir, format, out, frames, no_body, every, quantize, scene } => {
            let options = cli::export::ExportOptions {
                out: out.as_deref(),
                frames: frames.as_deref(),
                no_body,
                every,
                quantize,
                scene: scene.as_deref(),
            };
            cli::export::parse_formats(&format).and_then(|formats| cli::export::run_export(&dir, &formats, &options))
        }
        Command::Check { scene } => run_check(&scene),
        Command::CheckBake { dir, scene, json } => cli::bake::run_check_bake(&dir, scene.as_deref(), json.as_deref()),
        Command::Bench {
            sweep: Some(BenchSweep::Accuracy { scene, steps, tolerances, frames, end_state, out }),
            ..
        } => {
            let measure = if end_state { ErrorMeasure::WithEndState } else { ErrorMeasure::ContactWindow };
            cli::bench::run_accuracy(&[(scene, measure)], &steps, &tolerances, frames, out.as_deref())
        }
        Command::Bench { sweep: None, suite, frames, out } => cli::bench::run_bench(suite, frames, out.as_deref()),
        Command::Fabric { command: FabricCommand::Test { presets, no_drape, across, pictures } } => {
            cli::fabric::run_fabric_test(&presets, !no_drape, across, pictures.as_deref())
        }
        Command::Fabric {
            command: FabricCommand::Fit { bending_length, area_density, drape_coefficient, base, name, across, out },
        } => {
            let measured = fabric_lab::fit::Measured {
                bending_length_cm: bending_length,
                area_density_gsm: area_density,
                drape_coefficient,
            };
            cli::fabric::run_fabric_fit(&measured, &base, name.as_deref(), across, &out)
        }
        Command::Body { body, motion, stack } => cli::body::run_body(&body, motion.as_deref(), stack.as_deref()),
        Command::Sweep { spec, out } => cli::farm::run_sweep(&spec, &out),
        Command::Farm(FarmCommand::Run { dir, slurm, jobs, retry_failed, sbatch, .. }) => {
            let runner = if slurm { cli::farm::Runner::Slurm(sbatch) } else { cli::farm::Runner::Local(jobs) };
            cli::farm::run_farm(&dir, &runner, retry_failed)
        }
        Command::Farm(FarmCommand::Task { dir, index }) => cli::farm::run_task(&dir, index),
        Command::Farm(FarmCommand::Status { dir }) => cli::farm::run_status(&dir),
        Command::Farm(FarmCommand::Collect { dir, frame, light, out }) => {
            cli::farm::run_collect(&dir, frame.unwrap_or(usize::MAX), &light, out.as_deref())
        }
        Command::ImportMotion { body, motion, stack, fps, cycle, out } => {
            cli::body::run_import_motion(&body, motion.as_deref(), stack.as_deref(), fps, cycle, &out)
        }
        Command::Render { source, out, frames, light, size, turntable, scene } => {
            let request = cli::render::RenderRequest { frames, light, size, turntable, scene };
            cli::render::run_render(&source, &out, &request)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(message)) => {
            eprintln!("error: {message}");
            ExitCode::from(1)
        }
        Err(Failure::Internal(message)) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
        Err(Failure::Cancelled(message)) => {
            eprintln!("{message}");
            ExitCode::from(130)
        }
        Err(Failure::Found(message)) => {
            eprintln!("{message}");
            ExitCode::from(3)
        }
    }
}

pub(crate) fn input(e: impl std::fmt::Display) -> Failure {
    Failure::Input(e.to_string())
}

/// Loads a scene, printing its garments' warnings.
fn load_scene(path: &Path) -> Result<Scene, Failure> {
    let scene = Scene::load(path).map_err(input)?;
    for g in &scene.garments {
        for warning in g.report.warnings().iter().chain(&g.warnings) {
            eprintln!("warning: garment '{}': {warning}", g.name);
        }
    }
    Ok(scene)
}

/// The default scene, among the shipped examples (in the working folder,
/// else where drape was built).
fn default_scene() -> PathBuf {
    drape::app::examples::examples_folder().join(DEFAULT_SCENE)
}

fn run_edit(scene: Option<PathBuf>, screenshot: Option<drape::app::Screenshot>) -> Result<(), Failure> {
    let path = scene.unwrap_or_else(default_scene);
    let scene = load_scene(&path)?;
    drape::app::run(scene, screenshot).map_err(|e| match e {
        drape::app::AppError::Window(_) => input(e),
        drape::app::AppError::Graphics(_) => Failure::Internal(e.to_string()),
    })
}

fn run_check(path: &Path) -> Result<(), Failure> {
    let scene = Scene::load(path).map_err(input)?;
    scene.simulator().map_err(input)?;
    print!("{}", summary(&scene));
    println!("ok: the scene is valid");
    Ok(())
}
