//! The response passes of one step: load the step's particles, respond to
//! the contacts pass after pass with the hook's correction between them,
//! and detect again only what moved.

use super::after_zones::CORRECTION_PASSES;
use super::*;

impl CollisionPipeline {
    /// Runs the pass hook after `stage` on the cloth's end positions and
    /// velocities and marks the points it moved. Returns whether it moved any.
    pub(super) fn run_hook(&mut self, hook: PassHook, stage: ResponseStage) -> bool {
        let n = self.particles.len();
        let ws = &mut self.ws;
        ws.before_hook.clear();
        ws.before_hook.extend_from_slice(&ws.end[..n]);
        let state = PassState {
            end: &mut ws.end[..n],
            velocity: &mut ws.velocity[..n],
            moved: &ws.moved[..n],
            pushed_off: &ws.pushed_off[..n],
            stage,
            frozen: &ws.frozen,
        };
        if !hook(state) {
            return false;
        }
        let hold = stage == ResponseStage::ImpactZones;
        let mut any = false;
        for (i, (before, after)) in ws.before_hook.iter().zip(&ws.end[..n]).enumerate() {
            if before != after {
                ws.moved[i] = true;
                any = true;
                if hold {
                    ws.held[i] = Some(Kinematic::Deforming);
                    ws.inverse_mass[i] = 0.0;
                }
            }
        }
        any
    }

    /// Detect → respond passes until nothing needs an impulse, the passes
    /// run out (after a correction after zones, [`CORRECTION_PASSES`]) or
    /// (with `pass_progress`) stop gaining, each followed by the pass hook.
    /// The step's first detection is full, later ones only of what moved.
    /// Returns whether the last detection found no contact at all (nothing
    /// is left for the impact zones).
    pub(super) fn impulse_passes(
        &mut self,
        window: StepWindow,
        after_pass: PassHook,
        report: &mut CollisionReport,
    ) -> bool {
        let mut last_shortfall = f64::INFINITY;
        let passes =
            if self.ws.correction_kept { CORRECTION_PASSES.min(self.settings.passes) } else { self.settings.passes };
        for _ in 0..passes {
            if self.ws.fresh {
                self.detect(Detection::Proximity, Scope::All, report);
                report.contacts = self.ws.contacts.len() as u32;
                self.ws.fresh = false;
            } else {
                self.detect_again(Detection::Proximity, report);
            }
            if self.ws.contacts.is_empty() {
                return true;
            }
            let progress = self.settings.pass_progress;
            if progress > 0.0 {
                let shortfall = self.total_shortfall(window.h());
                if shortfall > (1.0 - progress) * last_shortfall {
                    break;
                }
                last_shortfall = shortfall;
            }
            let clock = Instant::now();
            report.passes += 1;
            let (constraint_set, acted) = self.respond_pass(window.h());
            report.constraint_set = constraint_set;
            // Every contact within reach was already satisfied, so nothing
            // moved and detecting again would find the same contacts; what
            // the hook corrected after the last pass is what this detection
            // checked. That does not prove nothing crosses (the deficit is
            // linearised along the hit normal), so the impact zones still
            // look for crossings.
            if acted {
                self.run_hook(&mut *after_pass, ResponseStage::Impulses);
            }
            report.response += clock.elapsed();
            if !acted {
                break;
            }
        }
        false
    }

    /// A detection after a response that gives the same contacts as a full
    /// one: the pairs with a point moved since the last proximity detection
    /// go through the broad phase again; of the others, only the feature
    /// pairs that were in contact can be now (each test is a function of its
    /// points' paths, and whatever a crossing detection finds, a proximity
    /// detection found too), so those alone are tested again.
    pub(super) fn detect_again(&mut self, detection: Detection, report: &mut CollisionReport) {
        let ws = &mut self.ws;
        let moved = &ws.moved;
        ws.kept.clear();
        ws.kept.extend(ws.contacts.iter().filter(|c| c.nodes.iter().all(|&i| !moved[i as usize])));
        self.detect(detection, Scope::Moved, report);
        let Workspace { contacts, found, kept, .. } = &mut self.ws;
        found.clear();
        contacts.retain(|c| found.insert(c.key()));
        kept.clear();
    }

    /// Copies the cloth and obstacle points into the workspace, framing the
    /// obstacles for `window` unless that was done.
    pub(super) fn load(&mut self, cloth: &ClothState, window: StepWindow) {
        if self.framed != Some(window) {
            self.frame_obstacles(window, detect::mean_displacement(cloth.start, cloth.end));
        }
        let ws = &mut self.ws;
        ws.start.clear();
        ws.start.extend_from_slice(cloth.start);
        ws.start.extend_from_slice(&ws.obstacle_start);
        ws.end.clear();
        ws.end.extend_from_slice(cloth.end);
        ws.end.extend_from_slice(&ws.obstacle_end);
        ws.velocity.clear();
        ws.velocity.extend_from_slice(cloth.velocity);
        ws.velocity.extend(ws.obstacle_start.iter().zip(&ws.obstacle_end).map(|(a, b)| (b - a) / window.h()));
        ws.inverse_mass.clear();
        ws.inverse_mass.extend(
            cloth.mass.iter().zip(&self.particles).map(|(m, p)| if p.pinned.is_some() { 0.0 } else { 1.0 / m }),
        );
        ws.inverse_mass.resize(ws.start.len(), 0.0);
        ws.moved.clear();
        ws.moved.resize(ws.start.len(), false);
        ws.pushed_off.clear();
        ws.pushed_off.resize(self.particles.len(), Vector3::zeros());
        ws.obstacle_impulse.clear();
        ws.obstacle_impulse.resize(self.particles.len(), 0.0);
        ws.held.clear();
        ws.held.resize(cloth.start.len(), None);
        ws.frozen.clear();
        ws.correction_kept = false;
        ws.fresh = true;
    }

    /// How far short of their thickness the contacts would end the step,
    /// summed in thicknesses.
    pub(super) fn total_shortfall(&self, h: f64) -> f64 {
        let ws = &self.ws;
        ws.contacts.iter().map(|c| c.shortfall(&ws.velocity, h) / c.thickness).sum()
    }

    /// One pass of impulses over every contact, then sweeps over the
    /// constraint set. Returns the constraint set's size, and whether any
    /// contact needed an impulse.
    pub(super) fn respond_pass(&mut self, h: f64) -> (u32, bool) {
        let (a, threshold) = (self.settings.influence_decay, self.settings.influence_threshold);
        for entry in self.influence.values_mut() {
            entry.1 = false;
        }
        let Workspace { contacts, constraint_set, .. } = &mut self.ws;
        constraint_set.clear();
        for (k, c) in contacts.iter().enumerate() {
            let entry = self.influence.entry(c.key()).or_insert((0.0, false));
            entry.0 = a * entry.0 + 1.0;
            entry.1 = true;
            if entry.0 >= threshold {
                constraint_set.push(k);
            }
        }
        self.influence.retain(|_, (e, seen)| {
            if !*seen {
                *e *= a;
            }
            *e >= FORGOTTEN
        });
        let ws = &mut self.ws;
        let mut points = Points {
            start: &ws.start,
            end: &mut ws.end,
            velocity: &mut ws.velocity,
            inverse_mass: &ws.inverse_mass,
            moved: &mut ws.moved,
            h,
        };
        let n = self.particles.len();
        let holds = &self.obstacles.holds;
        ws.pushed_off.iter_mut().for_each(|p| *p = Vector3::zeros());
        let (pushed_off, obstacle_impulse) = (&mut ws.pushed_off, &mut ws.obstacle_impulse);
        let mut respond = |c: &Contact| {
            let Some(impulse) = points.respond(c) else { return false };
            let cloth_nodes = || c.nodes.iter().zip(&c.hit.weights).filter(|(i, _)| (**i as usize) < n);
            if c.nodes.iter().any(|&i| i as usize >= n) {
                for (&i, &w) in cloth_nodes() {
                    obstacle_impulse[i as usize] += w.abs() * impulse;
                }
            }
            if c.nodes.iter().any(|&i| (i as usize).checked_sub(n).is_some_and(|o| holds[o])) {
                for (&i, &w) in cloth_nodes() {
                    pushed_off[i as usize] += c.hit.normal * w;
                }
            }
            true
        };
        let acted = ws.contacts.iter().fold(false, |acted, c| respond(c) | acted);
        for _ in 0..self.settings.constraint_sweeps {
            let changed = ws.constraint_set.iter().fold(false, |changed, &k| respond(&ws.contacts[k]) | changed);
            if !changed {
                break;
            }
        }
        (ws.constraint_set.len() as u32, acted)
    }
}
