//! What a step reports: its stages' times and its counts.

use super::*;

/// Wall time spent in each stage of a step (or summed over steps).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StageTimings {
    /// Spring forces and blocks.
    pub springs: Duration,
    /// Matrix and right-hand side.
    pub assembly: Duration,
    /// Linear solves (with contact passes). The obstacles' placement,
    /// boxes and hierarchy for the step are made on another thread
    /// meanwhile, and counted nowhere.
    pub solve: Duration,
    /// Inextensibility projection.
    pub constraints: Duration,
    /// Particles against analytic colliders (before the triangle
    /// collisions; their corrections within those count as `response`).
    pub contacts: Duration,
    /// Loading the collision step: the cloth's points, boxes and hierarchy
    /// refits.
    pub refit: Duration,
    /// Collision broad phase.
    pub broad: Duration,
    /// Collision narrow phase.
    pub narrow: Duration,
    /// Collision response (impulses, constraint set, impact zones, and the
    /// strain projection and analytic colliders after each pass).
    pub response: Duration,
    /// Pins, checks, commit, strain.
    pub finish: Duration,
}

impl StageTimings {
    /// Stage names and durations, in pipeline order.
    pub fn stages(&self) -> [(&'static str, Duration); 10] {
        [
            ("springs", self.springs),
            ("assembly", self.assembly),
            ("solve", self.solve),
            ("constraints", self.constraints),
            ("contacts", self.contacts),
            ("refit", self.refit),
            ("broad", self.broad),
            ("narrow", self.narrow),
            ("response", self.response),
            ("finish", self.finish),
        ]
    }

    /// Sum of all stages.
    pub fn total(&self) -> Duration {
        self.stages().iter().map(|(_, d)| *d).sum()
    }

    /// Stage-wise sum.
    pub fn add(&mut self, other: &StageTimings) {
        let fields = [
            (&mut self.springs, other.springs),
            (&mut self.assembly, other.assembly),
            (&mut self.solve, other.solve),
            (&mut self.constraints, other.constraints),
            (&mut self.contacts, other.contacts),
            (&mut self.refit, other.refit),
            (&mut self.broad, other.broad),
            (&mut self.narrow, other.narrow),
            (&mut self.response, other.response),
            (&mut self.finish, other.finish),
        ];
        for (mine, theirs) in fields {
            *mine += theirs;
        }
    }
}

/// What one step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Time per stage.
    pub timings: StageTimings,
    /// Linear solver outcome.
    pub solver: PcgReport,
    /// Largest stretch of a stretch spring after the step, (l − l₀) / l₀
    /// (0 when none is longer than at rest): what a strain limit bounds.
    pub max_strain: f64,
    /// [`Self::max_strain`] over the stretch springs with an end that is not
    /// pinned: what the solver and the strain limits control. A spring
    /// between two pinned particles is as long as its pins make it (a
    /// waistband glued to skin that stretches).
    pub max_free_strain: f64,
    /// Mean stretch-spring strain |l − l₀| / l₀ after the step.
    pub mean_strain: f64,
    /// The inextensibility projection.
    pub projection: ProjectionReport,
    /// Particle-collider contacts handled.
    pub contacts: u32,
    /// Particles held to a collider's surface in the solve.
    pub resting_contacts: u32,
    /// Linear solves run (one, plus one per detect → respond pass that found
    /// new contacts).
    pub solves: u32,
    /// Cholesky factors built for the solves (the factor is kept across steps
    /// until it goes stale).
    pub factorizations: u32,
    /// Triangle collisions (self, meshes, sharp features).
    pub collision: CollisionReport,
    /// Backward Euler's local error estimate of the step.
    pub local_error: LocalError,
}
