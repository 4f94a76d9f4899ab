//! Live parameter changes: a garment's fabric replaced between two steps,
//! with no rebuild of topology.
//!
//! Changing stiffness, mass or a strain limit at once would jerk the cloth
//! (a tighter limit snaps every over-long edge back in one step; a stiffer
//! spring releases its stored energy). So the mechanical coefficients —
//! masses, stretch, shear and bending stiffness and damping, air damping,
//! gravity and the edges' maximal lengths — move linearly from their values
//! at the change to the new ones over [`RAMP_STEPS`] steps. Collision
//! thickness and friction take effect at once: they store no energy.

use nalgebra::Vector3;

use super::implicit::{ParticleCoefficients, SpringCoefficients};
use super::inextensibility::StrainLimits;

/// Steps over which a change of fabric is blended in.
pub const RAMP_STEPS: u32 = 10;

/// A change of coefficients in progress.
#[derive(Clone, Debug)]
pub struct Ramp {
    from: (ParticleCoefficients, SpringCoefficients, Vec<f64>),
    to: (ParticleCoefficients, SpringCoefficients, Vec<f64>),
    /// Steps already blended.
    done: u32,
}

impl Ramp {
    /// A ramp from the coefficients in use to `to` (particles, springs, and
    /// each constrained edge's maximal length in m, infinite for none). An
    /// edge gaining a limit starts from its length at `x` (when longer), so
    /// it is drawn in, not snapped.
    pub fn new(
        particles: &ParticleCoefficients,
        springs: &SpringCoefficients,
        limits: Option<&StrainLimits>,
        x: &[Vector3<f64>],
        to: (ParticleCoefficients, SpringCoefficients, Vec<f64>),
    ) -> Self {
        let lengths = limits.map_or_else(Vec::new, |l| {
            let now = l.lengths(x);
            l.max_lengths()
                .iter()
                .zip(&to.2)
                .zip(now)
                .map(|((&old, &new), length)| if old.is_finite() { old } else { length.max(new) })
                .collect()
        });
        Ramp { from: (particles.clone(), springs.clone(), lengths), to, done: 0 }
    }

    /// Writes the coefficients of the next step into `particles`, `springs`
    /// and `limits`. Returns whether the ramp has more steps.
    pub fn advance(
        &mut self,
        particles: &mut ParticleCoefficients,
        springs: &mut SpringCoefficients,
        limits: Option<&mut StrainLimits>,
    ) -> bool {
        self.done += 1;
        let s = f64::from(self.done) / f64::from(RAMP_STEPS);
        let lerp = |a: f64, b: f64| if s >= 1.0 { b } else { a + (b - a) * s };
        let ((p0, s0, l0), (p1, s1, l1)) = (&self.from, &self.to);
        let blend = |out: &mut [f64], a: &[f64], b: &[f64]| {
            for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
                *o = lerp(*a, *b);
            }
        };
        blend(&mut particles.mass, &p0.mass, &p1.mass);
        blend(&mut particles.air_damping, &p0.air_damping, &p1.air_damping);
        blend(&mut particles.bend_stiffness, &p0.bend_stiffness, &p1.bend_stiffness);
        blend(&mut particles.bend_damping, &p0.bend_damping, &p1.bend_damping);
        for ((g, a), b) in particles.gravity.iter_mut().zip(&p0.gravity).zip(&p1.gravity) {
            *g = a.zip_map(b, lerp);
        }
        for ((k, a), b) in springs.stiffness.iter_mut().zip(&s0.stiffness).zip(&s1.stiffness) {
            (k.tension, k.compression) = (lerp(a.tension, b.tension), lerp(a.compression, b.compression));
        }
        blend(&mut springs.damping, &s0.damping, &s1.damping);
        if let Some(limits) = limits {
            limits.set_max_lengths(|e| lerp(l0[e], l1[e]));
        }
        self.done < RAMP_STEPS
    }
}
