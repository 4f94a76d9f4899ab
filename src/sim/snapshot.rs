//! The whole state a simulation carries from one step to the next, as plain
//! data, so a bake can stop and later go on exactly where it was
//! ([`super::Simulator::snapshot`], [`super::Simulator::resume_from`]).
//!
//! Positions and velocities are not enough for a bit-identical continuation:
//! the solver also carries its resting contacts, their normal forces, the
//! warm start of the next linear solve, the kept Cholesky factor and its
//! schedule, and the collision pipeline's contact influences (eq. 16). A
//! snapshot holds all of them; everything else a simulator holds is either
//! rebuilt from the scene or scratch space.

use nalgebra::Vector3;

use super::cholesky::{CholeskyError, FactorState};

/// A simulator's state between two steps.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Snapshot {
    /// Simulated time, s.
    pub time_s: f64,
    /// Particle positions, m.
    pub positions: Vec<[f64; 3]>,
    /// Particle velocities, m/s.
    pub velocities: Vec<[f64; 3]>,
    /// Collider each particle rested on after the last step (`u32::MAX`: none).
    pub resting_on: Vec<u32>,
    /// Particles whose contact pulled in the last solve.
    pub released: Vec<bool>,
    /// Normal force of each particle's contact in the last solve, N.
    pub normal_force_n: Vec<f64>,
    /// The local error estimate of the last step, which decides the length
    /// of the next ([`super::adaptive`]); none in snapshots from before it.
    #[serde(default)]
    pub last_step: super::local_error::LocalError,
    /// The last solve's velocity change, the next solve's first guess, m/s.
    pub warm_start: Vec<[f64; 3]>,
    /// The collision pipeline's remembered contacts: feature key, influence
    /// (unitless, eq. 16), seen in the last pass.
    pub contact_influence: Vec<([u32; 5], f64, bool)>,
    /// The kept Cholesky factor, when the solver keeps one.
    pub factor: Option<FactorState>,
}

/// Why a snapshot cannot be taken or restored.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SnapshotError {
    /// A fabric change is still being blended in (live tuning); bakes never
    /// have one.
    #[error("a fabric change is still being blended in; snapshots are taken between steps of a bake")]
    TuningInProgress,
    /// The snapshot was taken from a simulation of another cloth or solver.
    #[error("the saved state is for {saved}, but this simulation has {expected}")]
    Mismatch {
        /// What the snapshot holds, e.g. "4096 particles".
        saved: String,
        /// What this simulator has.
        expected: String,
    },
    /// The saved factor could not be rebuilt.
    #[error("the saved solver state cannot be rebuilt: {0}")]
    Factor(#[from] CholeskyError),
    /// A saved value is NaN or infinite.
    #[error("the saved state holds a non-finite {what}")]
    NonFinite {
        /// Which quantity.
        what: &'static str,
    },
}

impl Snapshot {
    /// Checks that the snapshot fits a simulator of `particles` particles and
    /// `colliders` analytic colliders that keeps a factor or not
    /// (`keeps_factor`), and that its values are finite.
    pub fn check(&self, particles: usize, colliders: usize, keeps_factor: bool) -> Result<(), SnapshotError> {
        let lengths = [
            self.positions.len(),
            self.velocities.len(),
            self.resting_on.len(),
            self.released.len(),
            self.normal_force_n.len(),
            self.warm_start.len(),
        ];
        if let Some(&wrong) = lengths.iter().find(|&&l| l != particles) {
            return Err(SnapshotError::Mismatch {
                saved: format!("{wrong} particles"),
                expected: format!("{particles} particles"),
            });
        }
        if self.factor.is_some() != keeps_factor {
            let kind = |keeps: bool| if keeps { "a solver that keeps a factor" } else { "a solver without one" };
            return Err(SnapshotError::Mismatch {
                saved: kind(self.factor.is_some()).into(),
                expected: kind(keeps_factor).into(),
            });
        }
        if let Some(&c) = self.resting_on.iter().find(|&&c| c != u32::MAX && c as usize >= colliders) {
            return Err(SnapshotError::Mismatch {
                saved: format!("a particle resting on collider {c}"),
                expected: format!("{colliders} colliders"),
            });
        }
        let finite = |v: &[[f64; 3]]| v.iter().flatten().all(|c| c.is_finite());
        let checks = [
            ("time", self.time_s.is_finite()),
            ("step error", self.last_step.step_s.is_finite() && self.last_step.error_m.is_finite()),
            ("position", finite(&self.positions)),
            ("velocity", finite(&self.velocities)),
            ("normal force", self.normal_force_n.iter().all(|f| f.is_finite())),
            ("warm start", finite(&self.warm_start)),
            ("contact influence", self.contact_influence.iter().all(|c| c.1.is_finite())),
        ];
        match checks.iter().find(|(_, ok)| !ok) {
            Some(&(what, _)) => Err(SnapshotError::NonFinite { what }),
            None => Ok(()),
        }
    }
}

/// `v` as plain arrays.
pub fn to_arrays(v: &[Vector3<f64>]) -> Vec<[f64; 3]> {
    v.iter().map(|p| [p.x, p.y, p.z]).collect()
}

/// Plain arrays as vectors, into `out` (reusing its storage).
pub fn from_arrays(arrays: &[[f64; 3]], out: &mut Vec<Vector3<f64>>) {
    out.clear();
    out.extend(arrays.iter().map(|&a| Vector3::from(a)));
}
