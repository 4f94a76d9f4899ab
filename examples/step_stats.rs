//! What a scene's steps are made of: the simulation of `drape bake` without
//! its checks and files, step by step, for profiling and for A/B
//! comparisons of a change.
//!
//!     cargo run --release --example step_stats -- assets/scenes/drape_table.toml 91
//!     cargo run --release --example step_stats -- SCENE FRAMES --steps
//!
//! Prints the median ms per frame (frame 1 left out: it builds the factors
//! and hierarchies) and each stage's mean; with `--steps`, first one line per
//! accepted step: the implicit solve (conjugate-gradient iterations,
//! factors), the strain projection (Newton and conjugate-gradient
//! iterations, `J W Jᵀ` factors, whether it stalled or fell back to
//! clamping, the excess it left), the collision response (passes, impact-zone
//! rounds, the eq. 16 constraint set, triangle contacts), the stage times and
//! the largest free strain.

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use drape::scene::Scene;
use drape::sim::StepReport;
use drape::sim::adaptive::Stepper;
use drape::sim::step::StageTimings;

/// The command line.
#[derive(Parser)]
struct Args {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Frames to simulate.
    frames: u32,
    /// Print one line per step as well.
    #[arg(long)]
    steps: bool,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let scene = Scene::load(&args.scene)?;
    let mut sim = scene.simulator()?;
    let mut stepper = Stepper::new(scene.step_duration(), scene.adaptive_settings());
    let mut frames = Vec::new();
    for frame in 1..=args.frames {
        let mut timings = StageTimings::default();
        let mut step = 0;
        stepper
            .advance(&mut sim, scene.steps_per_frame, |report| {
                if args.steps {
                    println!("f{frame} s{step} {}", step_line(report));
                }
                timings.add(&report.timings);
                step += 1;
            })
            .with_context(|| format!("frame {frame}"))?;
        frames.push(timings);
    }
    print_summary(&frames[1.min(frames.len())..]);
    Ok(())
}

/// One step's report on one line.
fn step_line(r: &StepReport) -> String {
    let (p, c, t) = (&r.projection, &r.collision, &r.timings);
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    format!(
        "cg {} fac {} | proj newton {} cg {} fac {} stalled {} fell_back {} excess {:.3} | passes {} zones {} \
         set {} contacts {} | solve {:.2} refit {:.2} broad {:.2} narrow {:.2} response {:.2} ms | strain {:.2} %",
        r.solver.iterations,
        r.factorizations,
        p.newton_iterations,
        p.cg_iterations,
        p.factorizations,
        p.stalled,
        p.fell_back,
        p.excess_strain,
        c.passes,
        format!("{}+{}c{}u", c.zone_rounds, c.zone_corrections, c.corrections_undone),
        c.constraint_set,
        c.contacts,
        ms(t.solve),
        ms(t.refit),
        ms(t.broad),
        ms(t.narrow),
        ms(t.response),
        r.max_free_strain * 100.0,
    )
}

/// The median frame and each stage's mean over `frames`, ms.
fn print_summary(frames: &[StageTimings]) {
    let mut totals: Vec<f64> = frames.iter().map(|f| f.total().as_secs_f64() * 1e3).collect();
    totals.sort_by(f64::total_cmp);
    let Some(median) = totals.get(totals.len() / 2) else { return println!("no frame to measure") };
    println!("median {median:.2} ms/frame over {} frames", totals.len());
    let mut sum = StageTimings::default();
    frames.iter().for_each(|f| sum.add(f));
    for (name, duration) in sum.stages() {
        println!("  {name}: {:.2} ms/frame (mean)", duration.as_secs_f64() * 1e3 / totals.len() as f64);
    }
}
