//! The soak benchmark: a long run of a looped scene (by default 20,000
//! steps of `skirt_walk_loop`, the skirt on the in-place walk cycle), watching
//! for what only shows over time: energy creeping up or draining, memory
//! growing, intersections appearing.
//!
//! The cloth's energy (kinetic plus gravitational, J) is compared cycle
//! against cycle: the mean over each whole motion cycle, so the walk's own
//! swing cancels out and only a trend remains.

use std::fmt::Write as _;

use std::sync::atomic::AtomicBool;

use nalgebra::Vector3;

use super::BenchError;
use crate::bake::summary::median;
use crate::bake::{self, FrameRecord};

use crate::scene::Scene;
use crate::sim::Simulator;

/// Steps the issue asks the soak to run.
pub const SOAK_STEPS: usize = 20_000;

/// One sampled frame of the soak.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoakSample {
    /// Frame number.
    pub frame: usize,
    /// Simulated time, s.
    pub time_s: f64,
    /// Kinetic energy of the cloth, J.
    pub kinetic_j: f64,
    /// Gravitational potential energy of the cloth above y = 0, J.
    pub potential_j: f64,
    /// Resident memory of the process, MiB (Linux; 0 elsewhere).
    pub resident_mib: f64,
    /// Largest stretch strain at the frame end.
    pub max_strain: f64,
    /// Intersecting triangle pairs and penetrating vertices the independent
    /// checker found at the frame end.
    pub problems: u32,
    /// Wall time of the frame's simulation, ms.
    pub ms: f64,
}

/// The soak's verdicts.
#[derive(Clone, Debug, PartialEq)]
pub struct SoakReport {
    /// Scene name.
    pub scene: String,
    /// Solver steps run.
    pub steps: usize,
    /// Every frame.
    pub samples: Vec<SoakSample>,
    /// Frames per motion cycle (the energy is averaged over each).
    pub cycle_frames: usize,
    /// Mean energy of each whole cycle, J.
    pub cycle_energy_j: Vec<f64>,
    /// Steps rolled back and retried over the run.
    pub rollbacks: u32,
}

impl SoakReport {
    /// Change of the cycle-mean energy from the second cycle (the first
    /// holds the fall and the blend into the walk) to the last, relative
    /// to the second's.
    pub fn energy_drift(&self) -> f64 {
        match (self.cycle_energy_j.get(1), self.cycle_energy_j.last()) {
            (Some(&first), Some(&last)) if first.abs() > 0.0 => (last - first) / first.abs(),
            _ => 0.0,
        }
    }

    /// Resident memory at the end of the second cycle and at the end, MiB.
    pub fn memory_mib(&self) -> (f64, f64) {
        let at = |frame: usize| self.samples.get(frame.min(self.samples.len().saturating_sub(1)));
        let settled = at(2 * self.cycle_frames).map_or(0.0, |s| s.resident_mib);
        (settled, self.samples.last().map_or(0.0, |s| s.resident_mib))
    }

    /// Frames that ended with an intersection or a penetrating vertex.
    pub fn bad_frames(&self) -> usize {
        self.samples.iter().filter(|s| s.problems > 0).count()
    }

    /// The verdicts as Markdown.
    pub fn markdown(&self) -> String {
        let (settled, end) = self.memory_mib();
        let strain = self.samples.iter().map(|s| s.max_strain).fold(0.0, f64::max);
        let ms: Vec<f64> = self.samples.iter().map(|s| s.ms).collect();
        let mut out = format!(
            "| scene | steps | frames | cycles | energy drift, 2nd → last cycle | resident memory, 2nd cycle → end \
             | frames with intersections | max strain | rollbacks | ms/frame (median) |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n\
             | {} | {} | {} | {} | {:+.2} % | {settled:.0} → {end:.0} MiB | {} | {:.1} % | {} | {:.1} |\n\n",
            self.scene,
            self.steps,
            self.samples.len(),
            self.cycle_energy_j.len(),
            self.energy_drift() * 100.0,
            self.bad_frames(),
            strain * 100.0,
            self.rollbacks,
            median(&ms),
        );
        out += "Cycle-mean energy (kinetic + gravitational), J, every 10th cycle:\n\n";
        for (k, e) in self.cycle_energy_j.iter().enumerate().step_by(10) {
            let _ = write!(out, "{}: {e:.4}  ", k + 1);
        }
        out.push('\n');
        out
    }

    /// Every frame as CSV.
    pub fn csv(&self) -> String {
        let mut out = String::from("frame,time_s,kinetic_j,potential_j,resident_mib,max_strain,problems,ms\n");
        for s in &self.samples {
            let _ = writeln!(
                out,
                "{},{:.4},{:.6e},{:.6e},{:.1},{:.5},{},{:.2}",
                s.frame, s.time_s, s.kinetic_j, s.potential_j, s.resident_mib, s.max_strain, s.problems, s.ms
            );
        }
        out
    }
}

/// Gravitational potential energy of the cloth relative to the origin,
/// −Σ m g·x, J.
fn potential_energy(sim: &Simulator) -> f64 {
    let cloth = sim.cloth();
    let particles = sim.positions().iter().zip(&cloth.mass).enumerate();
    particles.map(|(i, (p, m))| -m * p.dot(&Vector3::from(cloth.fabric_of(i).gravity_m_per_s2))).sum()
}

/// Frames of one cycle of the scene's first cycling body motion.
pub fn cycle_frames(scene: &Scene) -> Option<usize> {
    let cycling = scene.mesh_colliders.iter().filter_map(|m| m.animation.as_deref()).find(|a| a.cycle)?;
    Some(cycling.frames.len() - cycling.lead_in.min(cycling.frames.len()))
}

/// Runs `scene` for `steps` solver steps (whole frames), however long its
/// own frame range, logging progress every 500 frames. Its energy is
/// averaged over each cycle of its body's motion (each second if none
/// cycles).
pub fn run(scene: &Scene, steps: usize, log: impl Fn(&str)) -> Result<SoakReport, BenchError> {
    let frames = steps.div_ceil(scene.steps_per_frame as usize);
    let mut long = scene.clone();
    long.frame_count = frames;
    let mut samples = Vec::with_capacity(frames);
    let sample = |sim: &Simulator, record: &FrameRecord| SoakSample {
        frame: record.frame,
        time_s: sim.time(),
        kinetic_j: sim.kinetic_energy(),
        potential_j: potential_energy(sim),
        resident_mib: super::memory::resident_mib().unwrap_or(0.0),
        max_strain: record.max_strain,
        problems: record.intersections.pairs() + record.intersections.penetrating_vertices,
        ms: record.timings.total().as_secs_f64() * 1e3,
    };
    let (records, failure) = bake::run(&long, frames, &AtomicBool::new(false), |sim, record| {
        if record.frame > 0 {
            samples.push(sample(sim, record));
        }
        if record.frame % 500 == 0 {
            log(&format!("soak: frame {} of {frames}", record.frame));
        }
        Ok(())
    })?;
    if let Some(failure) = failure {
        return Err(failure.into());
    }
    let cycle_frames = cycle_frames(scene).unwrap_or(scene.fps.round() as usize).max(1);
    let cycle_energy_j = samples
        .chunks_exact(cycle_frames)
        .map(|c| c.iter().map(|s| s.kinetic_j + s.potential_j).sum::<f64>() / c.len() as f64)
        .collect();
    Ok(SoakReport {
        scene: scene.name.clone(),
        steps: frames * scene.steps_per_frame as usize,
        samples,
        cycle_frames,
        cycle_energy_j,
        rollbacks: records.iter().map(|r| r.rollbacks).sum(),
    })
}
