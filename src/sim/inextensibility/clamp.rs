//! Per-edge clamping (Provot 1995): the fallback when the Newton iterations
//! run out while still progressing, and the cheap method for comparison.

use super::*;

impl StrainLimits {
    /// Per-edge clamping sweeps until the strain is within tolerance.
    pub(super) fn clamp(&mut self, state: &mut ProjectedState, report: &mut ProjectionReport) {
        self.linearise_all(state.x, state.constraints, state.mass);
        for _ in 0..CLAMP_SWEEPS {
            report.excess_strain = self.update_active_set();
            if report.excess_strain <= STRAIN_TOLERANCE {
                return;
            }
            report.clamp_sweeps += 1;
            self.clamp_sweep(state.constraints, state.mass);
            let ws = &mut self.ws;
            for &v in &ws.touched {
                let delta = ws.gathered[v as usize];
                state.x[v as usize] += delta;
                state.v[v as usize] += delta / state.h;
            }
            let particles = Particles { x: state.x, constraints: state.constraints, mass: state.mass };
            ws.linearised.update_at(&ws.touched, &self.edges, particles);
        }
        report.excess_strain = self.excess_strain(state.x);
    }

    /// One Jacobi clamping sweep into `gathered` (the position change of each
    /// touched particle): each over-long movable edge asks its ends to close
    /// the gap along it, in proportion to their inverse masses (the smallest
    /// mass-weighted move); each particle moves by the mean of what its edges ask.
    fn clamp_sweep(&mut self, constraints: &[Constraint], mass: &[f64]) {
        let ws = &mut self.ws;
        let (edges, incidence) = (&ws.linearised.states, &self.edges.incidence);
        for &v in &ws.touched {
            let (mut sum, mut count) = (Vector3::zeros(), 0.0);
            for (e, sign) in incidence.of(v as usize) {
                let edge = &edges[e];
                if edge.violation > 0.0 && edge.diagonal > 0.0 {
                    sum -= edge.direction * (sign * edge.violation / edge.diagonal);
                    count += 1.0;
                }
            }
            let v = v as usize;
            ws.gathered[v] =
                if count > 0.0 { constraints[v].filter(sum) / (mass[v] * count) } else { Vector3::zeros() };
        }
    }
}
