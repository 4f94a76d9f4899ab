//! Adaptive stepping and the safety net.
//!
//! A step that fails — a non-finite value, a linear solve that did not
//! converge, a largest strain past the blow-up bound that more than doubled
//! in the step, crossings the collision pipeline could not resolve, or,
//! beside a moving body, a rise of the cloth's own largest strain (over the
//! edges not pinned at both ends) by more than the snag strain — is rolled
//! back to the state before it and retried as two steps of half the length,
//! down to a floor of `nominal / 2^max_halvings`.
//! After a step succeeds the length doubles again, back to the nominal
//! step. When even the floor fails, advancing stops with the time, the step
//! and the cause, and the simulator keeps the last good state: a user never
//! sees a NaN or an explosion.
//!
//! A moving body snags cloth where a leg swings through a hem at 4 m/s: in
//! one 1/60 s step it carries a few particles 7 cm while their neighbours
//! stay, through the rigid impact zones that hold its skin, through
//! self-contact zones squeezed between the legs, or through impulses after
//! the strain projection gave up (400 % strain for a frame at worst). The
//! distance halves with the step, so such a step is retried shorter, but
//! only down to [`AdaptiveSettings::snag_halvings`]: past that it is
//! accepted as it is, never a reason to stop. A step that needed impact
//! zones is held to a tighter bound ([`ZONED_SNAG_STRAIN`]): what is left
//! after the zones' correction is edges its projection could not shorten
//! (round points a collider carries), which a shorter step shortens.
//!
//! A cloth at rest, or moving steadily, is stepped as accurately by longer
//! steps: when [`AdaptiveSettings::long_step_error`] is set, a step may
//! double past the nominal step, up to a whole frame, while the last step's
//! local error estimate ([`super::local_error`]), scaled to the doubled
//! length, stays under that fraction of the nominal step's error in free
//! fall. A longer step whose own estimate comes out over
//! it is rolled back and retried at half its length, and so is one that
//! leaves the cloth more than a tenth of a point of strain past its strain
//! limits, further than the step before it did (the estimate is a mean: a
//! leg that swings through a hem in a long step stretches it locally,
//! 1.14 % on `skirt_walk` against the 1.01 % its strain limits hold
//! otherwise), or that fails as above; the steps never shorten below the
//! nominal step for error. Beside an animated body steps stay nominal: a
//! limb can reach the cloth within any step, which the last step's estimate
//! does not foresee, and the walks gained little (`skirt_walk` 1.9 steps
//! per frame) for strain peaks that moved and grew (1.14-1.44 % against
//! 1.01 %; 723560f). The estimate is part of the simulator's state (checkpoints and
//! snapshots), so the lengths a bake takes are the same when it is resumed.
//!
//! Steps are counted in units of the floor step, so the halved, regrown and
//! lengthened steps of a frame add up to the frame exactly; a frame with no
//! failure and no lengthening runs the nominal steps, bit for bit as
//! without the safety net.

use super::local_error::free_fall_error_m;
use super::step::{Checkpoint, Simulator, StepError, StepReport};

/// The snag strain of a step beside a moving body that needed impact zones,
/// unitless (2 points): zones move their points rigidly, and the correction
/// after them ([`super::collision`]'s `after_zones`) is refused where its
/// projection does not meet the limits soon (`fast_body` frame 16, when the
/// zones' points were fixed in it: 6.8 % kept, against 2.1 % when that step
/// is retried shorter). Zone steps are rare, so the
/// retries cost little.
const ZONED_SNAG_STRAIN: f64 = 0.02;
/// A step that failed even at the shortest step the safety net allows; the
/// simulator keeps the state before it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("the step ending at t = {time:.4} s failed even at the shortest allowed step ({step_s:.2e} s): {cause}")]
pub struct Unrecoverable {
    /// End time of the failed step, s.
    pub time: f64,
    /// Its length, s.
    pub step_s: f64,
    /// Why it failed.
    pub cause: StepFailure,
}

/// Why a step was not accepted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepFailure {
    /// A position or velocity became NaN or infinite.
    #[error("particle {particle} became non-finite")]
    NonFinite {
        /// First offending particle.
        particle: usize,
    },
    /// The linear solve stopped at its iteration cap.
    #[error("the linear solve did not converge in {iterations} iterations")]
    Unconverged {
        /// Iterations run.
        iterations: u32,
    },
    /// A stretch edge lengthened past the blow-up bound, and the largest
    /// strain more than doubled in the step.
    #[error("a stretch edge reached {:.0} % strain (blow-up bound {:.0} %)", strain * 100.0, bound * 100.0)]
    BlowUp {
        /// The largest strain, unitless.
        strain: f64,
        /// The bound, unitless.
        bound: f64,
    },
    /// A step beside a moving body raised the cloth's own largest strain
    /// (over the edges not pinned at both ends) by more than the snag
    /// strain: the body carried some particles away from their neighbours
    /// faster than the step's collision response and strain projection
    /// could follow.
    #[error("it stretched the cloth from {:.0} % to {:.0} % strain (at most {:.0} points more)", before * 100.0, after * 100.0, bound * 100.0)]
    Snagged {
        /// The largest strain before the step, unitless.
        before: f64,
        /// The largest strain after it, unitless.
        after: f64,
        /// The snag strain: the largest rise allowed, unitless.
        bound: f64,
    },
    /// The collision pipeline left crossing triangle pairs.
    #[error("{count} crossings were left unresolved by the collision pipeline")]
    Crossings {
        /// Crossings left.
        count: u32,
    },
    /// A step longer than the nominal one was further off than allowed.
    #[error("a long step's estimated error {:.3} mm is over the allowed {:.3} mm", error_m * 1e3, allowed_m * 1e3)]
    Inaccurate {
        /// Its local error estimate, m.
        error_m: f64,
        /// What [`AdaptiveSettings::long_step_error`] allows, m.
        allowed_m: f64,
    },
    /// A step longer than the nominal one stretched the cloth past its
    /// strain limits, further than the steps before it had.
    #[error("a long step stretched the cloth {:.2} points past its limits (before it {:.2})", after * 100.0, before * 100.0)]
    Overstretched {
        /// The largest strain beyond its limit before the step, unitless.
        before: f64,
        /// After it, unitless.
        after: f64,
    },
}

impl StepFailure {
    /// Whether only a step longer than the nominal one fails this way: it is
    /// taken again shorter, not counted as a rollback of the safety net.
    fn is_long_step_rejection(&self) -> bool {
        matches!(self, StepFailure::Inaccurate { .. } | StepFailure::Overstretched { .. })
    }
}

/// How far past its strain limits a long step may leave the cloth, unitless
/// (a tenth of a point of strain: ten times what the limits' projection
/// leaves), unless the steps before it left it further.
const LONG_STEP_EXCESS_STRAIN: f64 = 1e-3;

/// How the safety net retries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Halvings of the nominal step before giving up (5: down to 1/32).
    pub max_halvings: u32,
    /// Strain past which a step that multiplied the largest strain by more
    /// than [`Self::blow_up_growth`] counts as a blow-up, unitless (10 =
    /// 1000 %).
    pub blow_up_strain: f64,
    /// The factor by which a blow-up multiplies the largest strain in one
    /// step, unitless: a cloth that diverges does; one that pins wring a
    /// little further each step past the blow-up strain does not.
    pub blow_up_growth: f64,
    /// The most a step beside a moving body may raise the cloth's own
    /// largest strain by (over the edges not pinned at both ends: a
    /// waistband glued to skin stretches with it), unitless (0.25 = 25
    /// points of strain), while the step has been halved fewer than
    /// [`Self::snag_halvings`] times.
    pub snag_strain: f64,
    /// Halvings a step may take to stay under [`Self::snag_strain`] (3: down
    /// to 1/8); fewer than `max_halvings`.
    pub snag_halvings: u32,
    /// The local error estimate a step longer than the nominal one may
    /// have, as a fraction of the nominal step's error in free fall
    /// ([`free_fall_error_m`]), unitless; 0 keeps every step at most
    /// nominal.
    pub long_step_error: f64,
}

impl AdaptiveSettings {
    /// Whether a step that took the largest strain from `before` to `after`
    /// (unitless) blew up: past the blow-up strain, and multiplied by more
    /// than the blow-up growth.
    pub fn blows_up(&self, before: f64, after: f64) -> bool {
        after > self.blow_up_strain && after > self.blow_up_growth * before
    }
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        AdaptiveSettings {
            max_halvings: 5,
            blow_up_strain: 10.0,
            blow_up_growth: 2.0,
            snag_strain: 0.25,
            snag_halvings: 3,
            long_step_error: 0.0,
        }
    }
}

/// What one [`Stepper::advance`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Advance {
    /// Steps accepted.
    pub steps: u32,
    /// Steps rolled back and retried shorter.
    pub rollbacks: u32,
    /// Shortest step taken, s.
    pub shortest_step_s: f64,
    /// Longest step taken, s.
    pub longest_step_s: f64,
    /// Long steps rolled back because their error estimate was over the
    /// allowed one or they stretched the cloth, and retried at half the
    /// length.
    pub long_steps_rejected: u32,
    /// Why the rolled-back steps failed.
    pub causes: RollbackCauses,
}

/// How many rolled-back steps failed for each reason, so a slow bake can say
/// why it slowed down.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RollbackCauses {
    /// A position or velocity became non-finite.
    pub non_finite: u32,
    /// The linear solve hit its iteration cap.
    pub unconverged: u32,
    /// A stretch edge passed the blow-up strain.
    pub blow_up: u32,
    /// The collision pipeline left crossings.
    pub crossings: u32,
    /// A step beside a moving body raised the largest strain by more than
    /// the snag strain (`dragged` in summaries written before it counted
    /// more than impact zones).
    #[serde(default, alias = "dragged")]
    pub snagged: u32,
}

impl RollbackCauses {
    /// Counts one failure.
    pub fn count(&mut self, failure: &StepFailure) {
        let counter = match failure {
            StepFailure::NonFinite { .. } => &mut self.non_finite,
            StepFailure::Unconverged { .. } => &mut self.unconverged,
            StepFailure::BlowUp { .. } => &mut self.blow_up,
            StepFailure::Crossings { .. } => &mut self.crossings,
            StepFailure::Snagged { .. } => &mut self.snagged,
            StepFailure::Inaccurate { .. } | StepFailure::Overstretched { .. } => return,
        };
        *counter += 1;
    }

    /// Adds another tally to this one.
    pub fn add(&mut self, other: &RollbackCauses) {
        self.non_finite += other.non_finite;
        self.unconverged += other.unconverged;
        self.blow_up += other.blow_up;
        self.crossings += other.crossings;
        self.snagged += other.snagged;
    }

    /// The causes that occurred, as "N cause" phrases (empty when none did).
    pub fn phrases(&self) -> Vec<String> {
        let kinds = [
            (self.non_finite, "non-finite"),
            (self.unconverged, "linear solve unconverged"),
            (self.blow_up, "strain blow-up"),
            (self.crossings, "crossings left"),
            (self.snagged, "snagged on a moving body"),
        ];
        kinds.iter().filter(|(n, _)| *n > 0).map(|(n, what)| format!("{n} {what}")).collect()
    }
}

/// Advances a simulator by whole frames with rollback and retry.
#[derive(Clone, Debug)]
pub struct Stepper {
    nominal_s: f64,
    settings: AdaptiveSettings,
    checkpoint: Checkpoint,
    /// The largest strain at the start of the step under way, unitless.
    start_strain: f64,
    /// The largest strain then of a stretch edge not pinned at both ends, unitless.
    start_free_strain: f64,
}

impl Stepper {
    /// A stepper whose normal step is `nominal_s` seconds.
    pub fn new(nominal_s: f64, settings: AdaptiveSettings) -> Self {
        Stepper { nominal_s, settings, checkpoint: Checkpoint::default(), start_strain: 0.0, start_free_strain: 0.0 }
    }

    /// How it retries, shortens and lengthens steps.
    pub fn settings(&self) -> AdaptiveSettings {
        self.settings
    }

    /// Advances `sim` by the time of `steps` nominal steps, handing each
    /// accepted step's report to `on_step`. On failure at the floor step the
    /// simulator is left at the state before that step.
    pub fn advance(
        &mut self,
        sim: &mut Simulator,
        steps: u32,
        mut on_step: impl FnMut(&StepReport),
    ) -> Result<Advance, Unrecoverable> {
        let nominal = 1u64 << self.settings.max_halvings;
        let mut units_left = u64::from(steps) * nominal;
        let mut units = self.lengthened(sim, nominal, self.units_of(sim.last_step().step_s), units_left);
        let mut advance = Advance { shortest_step_s: f64::INFINITY, ..Advance::default() };
        (self.start_strain, self.start_free_strain) = sim.largest_strains();
        while units_left > 0 {
            let h = self.seconds(units);
            sim.checkpoint(&mut self.checkpoint);
            match self.attempt(sim, h, nominal, units) {
                Ok(report) => {
                    (self.start_strain, self.start_free_strain) = (report.max_strain, report.max_free_strain);
                    on_step(&report);
                    advance.steps += 1;
                    advance.shortest_step_s = advance.shortest_step_s.min(h);
                    advance.longest_step_s = advance.longest_step_s.max(h);
                    units_left -= units;
                    units = if units < nominal {
                        // Grow back when the remaining time is a whole number of longer steps.
                        if units_left.is_multiple_of(units * 2) { units * 2 } else { units }
                    } else {
                        self.lengthened(sim, nominal, units, units_left)
                    };
                }
                Err(failure) if failure.is_long_step_rejection() => {
                    sim.restore(&self.checkpoint);
                    advance.long_steps_rejected += 1;
                    units /= 2;
                }
                Err(failure) => {
                    sim.restore(&self.checkpoint);
                    if units == 1 {
                        return Err(Unrecoverable { time: sim.time() + h, step_s: h, cause: failure });
                    }
                    advance.rollbacks += 1;
                    advance.causes.count(&failure);
                    units /= 2;
                }
            }
        }
        if advance.steps == 0 {
            advance.shortest_step_s = self.nominal_s;
        }
        Ok(advance)
    }

    /// The length of the next step, in floor steps, after one of `last`
    /// with `units_left` of the frame to go: the nominal step doubled while
    /// the last step's error estimate, scaled to the doubled length, allows
    /// it, up to one doubling past the last step and never past the frame's
    /// end. Without a long-step error, or beside an animated body (see the
    /// module documentation), nominal.
    fn lengthened(&self, sim: &Simulator, nominal: u64, last: u64, units_left: u64) -> u64 {
        let allowed = self.allowed_error_m();
        if allowed <= 0.0 || sim.has_animated_bodies() {
            return nominal;
        }
        let allows = |u: u64| {
            u <= units_left && units_left.is_multiple_of(u) && sim.last_step().predicted(self.seconds(u)) <= allowed
        };
        let mut length = nominal;
        while length <= last && allows(length * 2) {
            length *= 2;
        }
        length
    }

    /// The local error estimate a long step may have, m.
    fn allowed_error_m(&self) -> f64 {
        self.settings.long_step_error * free_fall_error_m(self.nominal_s)
    }

    /// A step of `units` floor steps, s.
    fn seconds(&self, units: u64) -> f64 {
        self.nominal_s * units as f64 / (1u64 << self.settings.max_halvings) as f64
    }

    /// The floor steps nearest to `step_s` seconds (0 for none).
    fn units_of(&self, step_s: f64) -> u64 {
        (step_s / self.seconds(1)).round() as u64
    }

    /// One step of `h` seconds, `units` floor steps of which `nominal` make
    /// a nominal step, judged.
    fn attempt(&self, sim: &mut Simulator, h: f64, nominal: u64, units: u64) -> Result<StepReport, StepFailure> {
        let (before, settings) = (self.start_strain, &self.settings);
        // Only a long step is judged by the strain past the limits.
        let excess_before = if units > nominal { sim.excess_strain() } else { 0.0 };
        let report =
            sim.step(h).map_err(|StepError::NonFinite { particle, .. }| StepFailure::NonFinite { particle })?;
        if !report.solver.converged {
            return Err(StepFailure::Unconverged { iterations: report.solver.iterations });
        }
        if settings.blows_up(before, report.max_strain) {
            return Err(StepFailure::BlowUp { strain: report.max_strain, bound: settings.blow_up_strain });
        }
        if report.collision.unresolved > 0 {
            return Err(StepFailure::Crossings { count: report.collision.unresolved });
        }
        // Only a moving body snags cloth; the edges between two pins stretch
        // as the pins make them, which no shorter step changes.
        let bound = match report.collision.zone_rounds {
            0 => settings.snag_strain,
            _ => settings.snag_strain.min(ZONED_SNAG_STRAIN),
        };
        let (before, after) = (self.start_free_strain, report.max_free_strain);
        if sim.has_animated_bodies() && after - before > bound && units << settings.snag_halvings > nominal {
            return Err(StepFailure::Snagged { before, after, bound });
        }
        if units > nominal {
            let (error_m, allowed_m) = (report.local_error.error_m, self.allowed_error_m());
            if error_m > allowed_m {
                return Err(StepFailure::Inaccurate { error_m, allowed_m });
            }
            let (before, after) = (excess_before, sim.excess_strain());
            if after > before.max(LONG_STEP_EXCESS_STRAIN) {
                return Err(StepFailure::Overstretched { before, after });
            }
        }
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rollback_causes_are_tallied_by_kind_and_named() {
        let mut causes = RollbackCauses::default();
        assert!(causes.phrases().is_empty());
        causes.count(&StepFailure::BlowUp { strain: 12.0, bound: 10.0 });
        causes.count(&StepFailure::BlowUp { strain: 11.0, bound: 10.0 });
        causes.count(&StepFailure::Crossings { count: 3 });
        causes.count(&StepFailure::Snagged { before: 0.01, after: 3.98, bound: 0.25 });
        let mut total = RollbackCauses { unconverged: 1, ..Default::default() };
        total.add(&causes);
        assert_eq!(total, RollbackCauses { non_finite: 0, unconverged: 1, blow_up: 2, crossings: 1, snagged: 1 });
        let phrases =
            ["1 linear solve unconverged", "2 strain blow-up", "1 crossings left", "1 snagged on a moving body"];
        assert_eq!(total.phrases(), phrases);
    }

    /// A summary written when only impact zones counted as snags still reads.
    #[test]
    fn summaries_that_counted_dragged_steps_read_them_as_snags() {
        let text = r#"{"non_finite": 0, "unconverged": 0, "blow_up": 1, "crossings": 0, "dragged": 2}"#;
        let causes: RollbackCauses = serde_json::from_str(text).expect("an older summary's tally");
        assert_eq!(causes, RollbackCauses { blow_up: 1, snagged: 2, ..Default::default() });
    }

    /// A cloth that diverges multiplies its strain in a step; one that pins
    /// wring a little further past the bound (`twist`: 9.97 → 11.0) does not.
    #[test]
    fn a_blow_up_is_a_jump_past_the_bound_not_a_creep() {
        let settings = AdaptiveSettings::default();
        assert!(settings.blows_up(0.4, 12.0));
        assert!(settings.blows_up(5.0, 10.5));
        assert!(!settings.blows_up(9.97, 11.0));
        assert!(!settings.blows_up(0.4, 9.9));
    }
}
