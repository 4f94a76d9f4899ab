//! One step's stages in order (see the module documentation of
//! [`super`]): springs, assembly, solve with contacts, constraints,
//! collisions, finish.

use super::*;

/// The time since `clock`, which is set to now.
fn lap(clock: &mut Instant) -> Duration {
    let now = Instant::now();
    let elapsed = now - *clock;
    *clock = now;
    elapsed
}

/// Strain past the limits (unitless: 1 point) within which a step's first
/// projection that ran out of Newton iterations and was finished by
/// clamping still counts as reaching the limits where pins drive the cloth:
/// the projections between collision passes and the correction after zones
/// go on, so the pins do not win alone. With every fallback counted as
/// giving up, `pull_through_funnel`'s frame 58 (clamped to 0.4 %) went
/// through its passes and zones unprojected and ended at 487 %, which no
/// later step undid. Without pins a fallback still turns them off: on
/// `pillars` (cloth tented on cone tips) projecting after the few
/// fallbacks clamped within a point cost 40 % of its frame time.
const CLAMPED_WITHIN: f64 = 0.01;

/// Newton iterations in which the strain projection of a correction after
/// impact zones ([`ResponseStage::AfterZones`]) must meet the limits for
/// the correction (its passes and zones) to be made. The corrections that
/// met them took 1-11 (`sleeve_elbow` 1-3, `pinch_drag` 7-9, `needles`
/// 7-11, with the zones' points fixed in them); on `pillars`, whose cloth
/// is tented on cone tips, most ran to the 30 of a projection between
/// passes and fell short, and the corrections made from their partial
/// results cost the bake 90 % of its frame time for no less strain; on
/// `twist`, whose pins make the limits unreachable, corrections kept from
/// partial results made its first second 85 % slower.
const CORRECTION_NEWTON_ITERATIONS: u32 = 12;

impl Simulator {
    /// Where pin `k` must be at time `t`, m.
    fn pin_target(&self, k: usize, t: f64) -> Vector3<f64> {
        let rest = self.pin_rest[k];
        match &self.pins[k].target {
            PinTarget::Still => rest,
            PinTarget::Moving(m) => (m.world_from_rest(t) * Point3::from(rest)).coords,
            PinTarget::OnMesh { mesh, triangle, weights, offset_m } => {
                let mesh = &self.attachment_meshes[*mesh as usize];
                let world_from_local = mesh.placement.world_from_local(t);
                let [a, b, c] = mesh.triangles[*triangle as usize]
                    .map(|v| (world_from_local * Point3::from(mesh.local_vertex(v as usize, t))).coords);
                a * weights[0] + b * weights[1] + c * weights[2] + triangle_frame(&a, &b, &c) * offset_m
            }
        }
    }

    /// Advances by one backward-Euler step of `h` seconds, on a thread of
    /// the rayon pool ([`parallel::on_pool`]).
    pub fn step(&mut self, h: f64) -> Result<StepReport, StepError> {
        parallel::on_pool(|| self.step_on_pool(h))
    }

    /// [`Self::step`], on the thread it runs on.
    fn step_on_pool(&mut self, h: f64) -> Result<StepReport, StepError> {
        if let Some(ramp) = &mut self.ramp
            && !ramp.advance(&mut self.particles, &mut self.springs, self.strain_limits.as_mut())
        {
            self.ramp = None;
        }
        let window = StepWindow { t0: self.time, t1: self.time + h };
        let mut report = StepReport::default();
        // The obstacles of the step (a body's skin at its start and end,
        // their boxes and hierarchy) do not depend on the solve: they are
        // made on the other core while it runs, in the frame that the
        // cloth's start velocities carry it by, and only near the ends
        // those velocities predict; then the cloth's broad phase is
        // speculated there from those ends.
        let mut pipeline = self.collision.take();
        self.ws.repulsion = pipeline.as_mut().and_then(|p| p.repulsion(&self.x, window.t0, h, &mut self.ws.resting));
        let shift = carried_displacement(&self.v, h);
        let (mut start, mut predicted) =
            (std::mem::take(&mut self.ws.speculative_start), std::mem::take(&mut self.ws.predicted_end));
        if pipeline.is_some() {
            start.clone_from(&self.x);
            predicted.clear();
            predicted.extend(self.x.iter().zip(&self.v).map(|(x, v)| x + v * h));
        }
        rayon::join(
            || self.solve_velocity_change(window, h, &mut report),
            || {
                if let Some(pipeline) = pipeline.as_mut() {
                    pipeline.frame_obstacles_near(window, shift, (&start, &predicted));
                    pipeline.speculate(window, &start, &predicted);
                }
            },
        );
        (self.ws.speculative_start, self.ws.predicted_end) = (start, predicted);
        self.collision = pipeline;
        let mut clock = Instant::now();

        self.integrate(h);
        if let Some(limits) = &mut self.strain_limits {
            report.projection = limits.project(ProjectedState {
                x: &mut self.ws.next_x,
                v: &mut self.ws.next_v,
                constraints: &self.ws.constraints,
                mass: &self.particles.mass,
                h,
            });
        }
        report.timings.constraints = lap(&mut clock);
        report.contacts = self.collide_with_colliders(window);
        report.timings.contacts = lap(&mut clock);
        if let Some(pipeline) = &mut self.collision {
            let cloth = ClothState {
                start: &self.x,
                end: &mut self.ws.next_x,
                velocity: &mut self.ws.next_v,
                mass: &self.particles.mass,
            };
            let (limits, constraints, mass) = (&mut self.strain_limits, &self.ws.constraints, &self.particles.mass);
            let projection = &mut report.projection;
            let paths = ColliderPaths::new(&self.x, &self.fixed, &self.surfaces, &self.colliders, window);
            let (contacts, resting_on) = (&mut self.ws.contacts, &mut self.resting_on);
            let before_projection = &mut self.ws.before_projection;
            let (holds, frozen_constraints) = (&mut self.ws.holds, &mut self.ws.frozen_constraints);
            let pushed = &mut self.ws.pushed_by_colliders;
            pushed.resize(self.x.len(), Vector3::zeros());
            // Limits that pins make unreachable (the first projection
            // stalled) are still approached after every pass, keeping
            // partial results; a stall without pins (cloth tented on a
            // sharp apex) leaves the passes unprojected, as the partial
            // projections stretched `pillars`' cone apex further. After
            // impact zones (unless the step's projection gave up already:
            // there the zones after a correction did not clear, and cost
            // `pillars` half its frame time) the cloth, the zones' points
            // with it, is projected again where that meets the limits soon,
            // and every later pass's projection keeps what it gains.
            let pinned = !self.pins.is_empty();
            let pulled_apart = projection.stalled && pinned;
            let mut after_zones = false;
            let mut after_pass = |pass: PassState| {
                let PassState { end, velocity, moved, pushed_off, stage, frozen } = pass;
                let clamped_short = projection.fell_back && !(pinned && projection.excess_strain <= CLAMPED_WITHIN);
                let gave_up = projection.abandoned || clamped_short || (projection.stalled && !pulled_apart);
                let may_project = match stage {
                    ResponseStage::ImpactZones => false,
                    ResponseStage::AfterZones => !gave_up,
                    ResponseStage::Impulses => after_zones || !gave_up,
                };
                let correcting = stage == ResponseStage::AfterZones && may_project;
                // The particles the response fixed after zones are fixed in
                // the projections too.
                let constraints = match frozen {
                    [_, ..] if may_project => {
                        frozen_constraints.clone_from(constraints);
                        frozen.iter().for_each(|&i| frozen_constraints[i as usize] = Constraint::Fixed);
                        &frozen_constraints[..]
                    }
                    _ => constraints,
                };
                let mut projected = false;
                before_projection.clear();
                if let Some(limits) = limits.as_mut()
                    && may_project
                    && limits.excess_strain(end) > STRAIN_TOLERANCE
                {
                    before_projection.extend_from_slice(end);
                    holds.clear();
                    if stage == ResponseStage::Impulses {
                        holds.extend(normalised_pushes(pushed_off));
                    }
                    let state = ProjectedState { x: end, v: velocity, constraints, mass, h };
                    let report = if correcting {
                        limits.project_if_met_within(state, CORRECTION_NEWTON_ITERATIONS)
                    } else if pulled_apart || after_zones {
                        limits.project_partial(state, holds)
                    } else {
                        limits.project_holding(state, holds)
                    };
                    // A correction after zones that does not meet the limits
                    // soon is not made: the step goes on as the zones left
                    // it, its projection's standing unchanged.
                    if correcting && report.abandoned {
                        projection.add_work(&report);
                        return false;
                    }
                    projection.add(&report);
                    projected = !report.abandoned;
                }
                after_zones |= correcting;
                // What the response or the projection moved goes through the
                // analytic colliders again, before the next detection sees it.
                let before = &*before_projection;
                let again = |i: usize, end: &Vector3<f64>| moved[i] || (projected && before[i] != *end);
                let (_, collided) = paths.resolve(end, velocity, again, contacts, resting_on, pushed);
                // Friction or a push-off after the projection may stretch an
                // edge: the projection again, holding what the colliders
                // pushed off along their normals, so a stretching friction
                // gives way (the cloth slips), and the colliders again for
                // what that moved.
                let mut reprojected = false;
                if let Some(limits) = limits.as_mut()
                    && collided
                    && may_project
                    && limits.excess_strain(end) > STRAIN_TOLERANCE
                {
                    before_projection.clear();
                    before_projection.extend_from_slice(end);
                    holds.clear();
                    holds.extend(normalised_pushes(pushed));
                    let report =
                        limits.project_holding(ProjectedState { x: end, v: velocity, constraints, mass, h }, holds);
                    projection.add(&report);
                    if !report.abandoned {
                        let before = &*before_projection;
                        paths.resolve(end, velocity, |i, end| before[i] != *end, contacts, resting_on, pushed);
                        reprojected = true;
                    }
                }
                projected || collided || reprojected
            };
            report.collision = pipeline.resolve(cloth, window, &mut after_pass);
            // Corrections after impact zones whose own zones left the cloth
            // more stretched than the first zones did are not kept.
            if let (Some(limits), Some((end, velocity))) = (&self.strain_limits, pipeline.before_last_correction())
                && limits.excess_strain(end) < limits.excess_strain(&self.ws.next_x)
            {
                self.ws.next_x.copy_from_slice(end);
                self.ws.next_v.copy_from_slice(velocity);
                report.collision.corrections_undone += 1;
            }
            for (total, taken) in self.contact_impulse.iter_mut().zip(pipeline.obstacle_impulses()) {
                *total += taken;
            }
            let c = &report.collision;
            report.timings.refit = c.refit;
            report.timings.broad = c.broad;
            report.timings.narrow = c.narrow;
            report.timings.response = c.response;
            lap(&mut clock);
        }

        for k in 0..self.pins.len() {
            let i = self.pins[k].vertex as usize;
            self.ws.next_x[i] = self.pin_target(k, window.t1);
        }
        let bad = |v: &[Vector3<f64>]| v.par_iter().position_first(|p| !p.iter().all(|c| c.is_finite()));
        if let Some(particle) = bad(&self.ws.next_x).or_else(|| bad(&self.ws.next_v)) {
            self.ws.velocity_change.iter_mut().for_each(|d| *d = Vector3::zeros());
            return Err(StepError::NonFinite { time: window.t1, particle });
        }
        report.local_error = LocalError::of_step(h, &self.v, &self.ws.next_v, &self.fixed);
        self.last_step = report.local_error;
        std::mem::swap(&mut self.x, &mut self.ws.next_x);
        std::mem::swap(&mut self.v, &mut self.ws.next_v);
        for (total, force) in self.contact_impulse.iter_mut().zip(&self.normal_force) {
            *total += force * h;
        }
        self.time = window.t1;
        self.measure_strain(&mut report);
        report.timings.finish = lap(&mut clock);
        Ok(report)
    }

    /// The implicit velocity update of one step (PAPER eq. 3-5): assembles
    /// the system, sets each particle's constraint and solves, again while
    /// the solution predicts new collider contacts, for a step of `h`
    /// seconds over `window`. Fills the report's solver figures and its
    /// springs, assembly and solve times.
    fn solve_velocity_change(&mut self, window: StepWindow, h: f64, report: &mut StepReport) {
        let n = self.x.len();
        let mut clock = Instant::now();
        let input = AssemblyInput { x: &self.x, v: &self.v, h };
        evaluate_springs(&self.cloth, &self.springs, &input, &mut self.ws.system);
        report.timings.springs = lap(&mut clock);
        assemble(&self.layout, &self.particles, &input, &mut self.ws.system);
        if let Some(repulsion) = &self.ws.repulsion {
            repulsion.add_to(&self.ws.resting, &self.layout.pattern.blocks, &mut self.ws.system);
        }
        report.timings.assembly = lap(&mut clock);

        self.ws.velocity_change.resize(n, Vector3::zeros());
        report.resting_contacts = self.prepare_constraints(window);
        let (mass, gravity) = (&self.particles.mass, &self.particles.gravity);
        self.ws.weight_impulse.clear();
        self.ws.weight_impulse.extend((0..n).map(|i| gravity[i] * (mass[i] * h)));
        loop {
            let system = FilteredSystem {
                matrix: self.ws.system.system_matrix(&self.layout),
                b: &self.ws.system.rhs,
                typical: &self.ws.weight_impulse,
                constraints: &self.ws.constraints,
                positions: &self.x,
            };
            // After the first solve only new contacts' constraints change.
            let change = if report.solves == 0 { SystemChange::Matrix } else { SystemChange::Constraints };
            let (solve, factored) = self.preconditioner.solve(
                system,
                &mut self.ws.velocity_change,
                self.settings,
                &mut self.ws.pcg,
                change,
            );
            report.factorizations += factored;
            report.solver = PcgReport { iterations: report.solver.iterations + solve.iterations, ..solve };
            report.solves += 1;
            if report.solves == CONTACT_PASSES || self.colliders.is_empty() {
                break;
            }
            let (new_contacts, significant) = self.predict_contacts(window);
            report.resting_contacts += new_contacts;
            if significant == 0 {
                break;
            }
        }
        self.record_contact_forces(h);
        report.timings.solve = lap(&mut clock);
    }

    /// Sets each particle's constraint for the solve and the prescribed part of
    /// its velocity change: pins move to their target; a particle resting on a
    /// collider (and not released) keeps the surface's normal velocity, and its
    /// friction joins the system as a tangential damping. Returns the number of
    /// resting contacts.
    fn prepare_constraints(&mut self, window: StepWindow) -> u32 {
        let n = self.x.len();
        let h = window.h();
        let ws = &mut self.ws;
        ws.constraints.resize(n, Constraint::Free);
        ws.surface_contacts.resize(n, None);
        let (x, v, colliders, surfaces) = (&self.x, &self.v, &self.colliders, &self.surfaces);
        let (resting_on, released, fixed, normal_force) =
            (&self.resting_on, &self.released, &self.fixed, &self.normal_force);
        ws.constraints
            .par_iter_mut()
            .zip(ws.surface_contacts.par_iter_mut())
            .zip(ws.velocity_change.par_iter_mut().zip(ws.system.rhs.par_iter_mut()))
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(i, ((constraint, contact), (dv, rhs)))| {
                *contact = None;
                *constraint = if fixed[i] { Constraint::Fixed } else { Constraint::Free };
                if fixed[i] || released[i] || resting_on[i] == NO_COLLIDER {
                    return;
                }
                let surface = SurfaceContact::resting(&x[i], colliders, resting_on[i], window);
                let mu = colliders[surface.collider as usize].friction.unwrap_or(surfaces[i].friction);
                let (_, force) = surface.friction_damping(&v[i], normal_force[i], mu);
                *rhs += force * h;
                *constraint = surface.constraint();
                *dv = surface.prescribe(&v[i], dv);
                *contact = Some(surface);
            });
        // The damping's Jacobian joins the diagonal blocks.
        for i in 0..n {
            if let Some(surface) = &self.ws.surface_contacts[i] {
                let mu = self.colliders[surface.collider as usize].friction.unwrap_or(self.surfaces[i].friction);
                let (damping, _) = surface.friction_damping(&self.v[i], self.normal_force[i], mu);
                self.ws.system.matrix[self.layout.pattern.blocks.diagonal(i)] += damping * h;
            }
        }
        for k in 0..self.pins.len() {
            let i = self.pins[k].vertex as usize;
            let target = self.pin_target(k, window.t1);
            self.ws.velocity_change[i] = (target - self.x[i]) / h - self.v[i];
        }
        self.ws.surface_contacts.par_iter().filter(|c| c.is_some()).count() as u32
    }

    /// One detect pass: every particle still free whose solved path would
    /// reach a collider becomes constrained to arrive at its surface. Returns
    /// the number of new contacts, and how many of them change their particle's
    /// path by more than a fraction of the thickness (only those are worth
    /// solving again for; the rest are particles creeping onto a surface).
    fn predict_contacts(&mut self, window: StepWindow) -> (u32, u32) {
        let ws = &mut self.ws;
        let (x, v, colliders, surfaces) = (&self.x, &self.v, &self.colliders, &self.surfaces);
        ws.constraints
            .par_iter_mut()
            .zip(ws.surface_contacts.par_iter_mut())
            .zip(ws.velocity_change.par_iter_mut())
            .enumerate()
            .with_min_len(CHUNK)
            .map(|(i, ((constraint, contact), dv))| {
                if *constraint != Constraint::Free {
                    return (0, 0);
                }
                let end = x[i] + (v[i] + *dv) * window.h();
                let thickness = surfaces[i].thickness;
                let Some(surface) = SurfaceContact::predicted(&x[i], &end, thickness, colliders, window) else {
                    return (0, 0);
                };
                let corrected = surface.prescribe(&v[i], dv);
                let shift = (corrected - *dv).norm() * window.h();
                *constraint = surface.constraint();
                *dv = corrected;
                *contact = Some(surface);
                (1, u32::from(shift > RESOLVE_SHIFT * thickness))
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
    }

    /// Reads each contact's normal impulse from the final solve: the surface
    /// supplies what the system lacks, `A Δv − b` (N·s), along the normal.
    /// Its force drives the friction of the next step; a pulling contact is
    /// released for the next step instead.
    fn record_contact_forces(&mut self, h: f64) {
        let ws = &mut self.ws;
        let any_contact = ws.surface_contacts.iter().any(Option::is_some);
        if any_contact {
            ws.residual.resize(self.x.len(), Vector3::zeros());
            ws.system.system_matrix(&self.layout).multiply(&ws.velocity_change, &mut ws.residual);
        }
        let (contacts, product, rhs) = (&ws.surface_contacts, &ws.residual, &ws.system.rhs);
        self.normal_force.par_iter_mut().zip(self.released.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(
            |(i, (force, released))| {
                let impulse = contacts[i].as_ref().map_or(0.0, |c| (product[i] - rhs[i]).dot(&c.normal));
                *released = impulse < 0.0;
                *force = impulse.max(0.0) / h;
            },
        );
    }

    /// `v ← v + Δv`, `x ← x + h v` into the next-state buffers.
    fn integrate(&mut self, h: f64) {
        let n = self.x.len();
        let ws = &mut self.ws;
        ws.next_x.resize(n, Vector3::zeros());
        ws.next_v.resize(n, Vector3::zeros());
        let (x, v, dv) = (&self.x, &self.v, &ws.velocity_change);
        ws.next_x.par_iter_mut().zip(ws.next_v.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(
            |(i, (next_x, next_v))| {
                *next_v = v[i] + dv[i];
                *next_x = x[i] + *next_v * h;
            },
        );
    }

    /// Each free particle's path from its position to the next-state buffers
    /// against the analytic colliders, noting which collider it ends resting
    /// on. Returns the contact count.
    fn collide_with_colliders(&mut self, window: StepWindow) -> u32 {
        self.ws.contacts.resize(self.x.len(), 0);
        self.ws.pushed_by_colliders.resize(self.x.len(), Vector3::zeros());
        let paths = ColliderPaths::new(&self.x, &self.fixed, &self.surfaces, &self.colliders, window);
        let ws = &mut self.ws;
        let (contacts, _) = paths.resolve(
            &mut ws.next_x,
            &mut ws.next_v,
            |_, _| true,
            &mut ws.contacts,
            &mut self.resting_on,
            &mut ws.pushed_by_colliders,
        );
        contacts
    }
}

/// The unit directions of the pushes in `pushed` (sums of normals, one per
/// particle), with their particles: the holds of a projection after them.
fn normalised_pushes(pushed: &[Vector3<f64>]) -> impl Iterator<Item = (u32, Vector3<f64>)> + '_ {
    pushed.iter().enumerate().filter_map(|(i, n)| n.try_normalize(PUSH_SUM_MIN).map(|n| (i as u32, n)))
}
