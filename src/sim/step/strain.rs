//! The cloth's strain as the step measures and reports it.

use super::*;

/// Strain of spring `spring` at positions `x`, (l − l₀) / l₀, unitless.
fn spring_strain(cloth: &Cloth, x: &[Vector3<f64>], spring: u32) -> f64 {
    let [a, b] = cloth.spring_ends[spring as usize];
    let rest = cloth.rest_length[spring as usize];
    ((x[a as usize] - x[b as usize]).norm() - rest) / rest
}

impl Simulator {
    /// Largest stretch of a stretch spring now, (l − l₀) / l₀, unitless (0
    /// when none is longer than at rest): what [`StepReport::max_strain`]
    /// reports after a step.
    pub fn largest_strain(&self) -> f64 {
        let (cloth, x, stretch) = (&self.cloth, &self.x, &self.stretch_springs);
        parallel::max(stretch.len(), |k| spring_strain(cloth, x, stretch[k]).max(0.0))
    }

    /// The largest strain now and the largest over the stretch springs with
    /// an end that is not pinned, unitless: what a step's report would say.
    pub fn largest_strains(&self) -> (f64, f64) {
        let largest = self.largest_strain();
        (largest, self.largest_free_strain_or(largest))
    }

    /// [`Self::largest_strain`] over the stretch springs with an end that is
    /// not pinned: what [`StepReport::max_free_strain`] reports. Without
    /// pins it is the largest strain, and `largest` is returned as it is.
    fn largest_free_strain_or(&self, largest: f64) -> f64 {
        if self.pins.is_empty() {
            return largest;
        }
        let (cloth, x, stretch, fixed) = (&self.cloth, &self.x, &self.stretch_springs, &self.fixed);
        parallel::max(stretch.len(), |k| {
            let [a, b] = cloth.spring_ends[stretch[k] as usize];
            if fixed[a as usize] && fixed[b as usize] { 0.0 } else { spring_strain(cloth, x, stretch[k]).max(0.0) }
        })
    }

    /// Writes the stretch springs' strains into `report`: the largest
    /// (l − l₀) / l₀, the largest of those not pinned at both ends, and the
    /// mean |l − l₀| / l₀.
    pub(super) fn measure_strain(&mut self, report: &mut StepReport) {
        report.max_strain = self.largest_strain();
        report.max_free_strain = self.largest_free_strain_or(report.max_strain);
        let (cloth, x, stretch) = (&self.cloth, &self.x, &self.stretch_springs);
        let total = parallel::sum(stretch.len(), &mut self.ws.partials, |k| spring_strain(cloth, x, stretch[k]).abs());
        report.mean_strain = total / stretch.len().max(1) as f64;
    }

    /// Largest strain beyond its limit of an edge the strain limits hold
    /// now, unitless (0 when all are within, or without limits).
    pub fn excess_strain(&self) -> f64 {
        self.strain_limits.as_ref().map_or(0.0, |limits| limits.excess_strain(&self.x))
    }
}
