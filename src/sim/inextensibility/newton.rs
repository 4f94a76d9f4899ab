//! The fast projection's Newton loop: each iteration linearises the active
//! edges, solves for the multipliers, and moves the touched particles by a
//! line search that must lower the total squared excess; the active set and
//! the holds change between iterations (one-sided, released when they push).

use nalgebra::Vector3;

use super::*;

impl StrainLimits {
    /// Newton iterations of fast projection until the strain is within
    /// tolerance; sets `fell_back` when they run out. Each Newton step is
    /// shortened (halved, up to [`BACKTRACKS`] times) until it reduces the
    /// total squared excess: far from the constraints a full step can
    /// overshoot where the edges turn.
    pub(super) fn fast_projection(&mut self, state: &mut ProjectedState, report: &mut ProjectionReport) {
        let mut held = std::mem::take(&mut self.held);
        held.clear();
        if !self.holds.is_empty() {
            held.extend_from_slice(state.constraints);
            for &(v, n) in &self.holds {
                held[v as usize] = held[v as usize].held_along(n);
            }
        }
        self.newton_iterations(state, &mut held, report);
        self.held = held;
    }

    /// The Newton iterations of [`Self::fast_projection`], with the
    /// particles' constraints `held` while holds apply (empty otherwise).
    fn newton_iterations(
        &mut self,
        state: &mut ProjectedState,
        held: &mut [Constraint],
        report: &mut ProjectionReport,
    ) {
        let mut stalled = 0;
        self.ws.failed_holds = None;
        let holding = !held.is_empty();
        let constraints: &[Constraint] = if holding { held } else { state.constraints };
        self.linearise_all(state.x, constraints, state.mass);
        // Progress is judged on the movable edges' excess: the edges between
        // two pins keep theirs whatever a step does.
        let initial = self.ws.linearised.squared_movable_excess();
        let mut latest = initial;
        // Stalled short of half the starting excess: the limits are out of reach.
        let unreachable = |latest: f64| latest > UNREACHABLE_SHARE * initial;
        let own = self.newton_iterations[usize::from(holding)];
        let most = self.newton_budget.map_or(own, |budget| budget.min(own));
        for _ in 0..=most {
            report.excess_strain = self.update_active_set();
            if report.excess_strain <= STRAIN_TOLERANCE {
                return;
            }
            if stalled == STALLED_ITERATIONS && unreachable(latest) {
                report.stalled = true;
                return;
            }
            if report.newton_iterations == most {
                break;
            }
            let before = self.ws.linearised.squared_excess();
            let constraints: &[Constraint] = if holding { held } else { state.constraints };
            self.solve_multipliers(constraints, state.mass, Linearisation::New, report);
            let rounds = if self.release == Release::PushingEdges { RELEASE_ROUNDS } else { 0 };
            for _ in 0..rounds {
                if !self.release_pushing_edges() {
                    break;
                }
                self.solve_multipliers(constraints, state.mass, Linearisation::Same, report);
            }
            if holding {
                for _ in 0..RELEASE_ROUNDS {
                    self.gather_active(Compact::Multiplier);
                    if !self.release_holds(held, state.constraints, state.x, state.mass) {
                        break;
                    }
                    self.solve_multipliers(held, state.mass, Linearisation::Same, report);
                }
            }
            let constraints: &[Constraint] = if holding { held } else { state.constraints };
            report.newton_iterations += 1;
            self.gather_active(Compact::Multiplier);
            // After the releases: a released hold makes its edges movable.
            let movable_before = self.ws.linearised.squared_movable_excess();
            let after = self.line_search(before, constraints, state);
            let movable_after = self.ws.linearised.squared_movable_excess();
            stalled = if movable_after > STALL_RATIO * movable_before { stalled + 1 } else { 0 };
            latest = movable_after;
            if after < before {
                self.ws.failed_holds = None;
            } else if self.repeats_failed_search() {
                // Every later iteration would repeat this one, each one
                // more stalled: end as they would.
                let stalls_to_go = STALLED_ITERATIONS.checked_sub(stalled);
                if unreachable(latest) && stalls_to_go.is_some_and(|n| report.newton_iterations + n <= most) {
                    report.stalled = true;
                    return;
                }
                break;
            }
        }
        report.fell_back = true;
    }

    /// After a Newton iteration whose line search found no shorter step (the
    /// particles are where the iteration found them): whether the one right
    /// before ended the same way from the same active edges and holds (a
    /// step taken in between forgets the failure). Nothing then
    /// differs between them, so every later iteration would repeat it, each
    /// for a factor of `J W Jᵀ`. (Measured: `twist`'s first 30 frames take
    /// 33.2 Newton iterations per step instead of 36.6, to the same bits;
    /// with `pillars`' sharp features held, a scratch switch, 117 of its
    /// first 203 held iterations were such repeats.)
    fn repeats_failed_search(&mut self) -> bool {
        let ws = &mut self.ws;
        if ws.failed_holds == Some(self.holds.len()) && ws.failed_active == ws.active_list {
            return true;
        }
        ws.failed_holds = Some(self.holds.len());
        ws.failed_active.clone_from(&ws.active_list);
        false
    }

    /// Releases every hold whose particle the multipliers just solved
    /// would move away from its obstacle (the correction `−W Jᵀ μ` without
    /// the hold has a positive component along `n`): a hold only keeps a
    /// particle from moving towards the obstacle. A released particle gets
    /// its own constraint from `free` back, and its edges are linearised
    /// again under it (their `J W Jᵀ` diagonals grow: a factor made with the
    /// held ones is not positive definite). Returns whether any was released
    /// (the multipliers must then be solved again).
    fn release_holds(
        &mut self,
        held: &mut [Constraint],
        free: &[Constraint],
        x: &[Vector3<f64>],
        mass: &[f64],
    ) -> bool {
        let ws = &mut self.ws;
        ws.relinearise.clear();
        let (is_touched, gathered, released) = (&ws.is_touched, &ws.gathered, &mut ws.relinearise);
        self.holds.retain(|&(v, n)| {
            let away = is_touched[v as usize] && n.dot(&gathered[v as usize]) < 0.0;
            if away {
                held[v as usize] = free[v as usize];
                released.push(v);
            }
            !away
        });
        let particles = Particles { x, constraints: held, mass };
        ws.linearised.update_at(&ws.relinearise, &self.edges, particles);
        !ws.relinearise.is_empty()
    }

    /// Takes out of the active set every edge within its limit whose
    /// multiplier would push its ends apart (μ < 0): a strain limit only ever
    /// pulls. (An edge over its limit stays: it must shorten whatever the
    /// linearisation says.) Returns whether any left (the multipliers must
    /// then be solved again).
    fn release_pushing_edges(&mut self) -> bool {
        let ws = &mut self.ws;
        let before = ws.active_list.len();
        let mut kept = 0;
        for i in 0..before {
            let e = ws.active_list[i];
            if ws.multiplier[i] < 0.0 && ws.linearised.states[e as usize].violation <= 0.0 {
                ws.active[e as usize] = false;
            } else {
                ws.active_list[kept] = e;
                kept += 1;
            }
        }
        ws.active_list.truncate(kept);
        kept < before
    }

    /// Linearises every edge at `x` under `constraints`.
    pub(super) fn linearise_all(&mut self, x: &[Vector3<f64>], constraints: &[Constraint], mass: &[f64]) {
        self.ws.linearised.linearise_all(&self.edges, Particles { x, constraints, mass });
    }

    /// Brings the active set up to the current linearisation: movable edges
    /// within [`NEAR_LIMIT`](super::limit_edges::NEAR_LIMIT) of their limit
    /// join it and stay, unless the projection holds instead of releasing
    /// ([`Release::Never`]): then an edge leaves once it is further from its
    /// limit than that. Returns the largest strain beyond the limit among
    /// movable edges.
    pub(super) fn update_active_set(&mut self) -> f64 {
        let ws = &mut self.ws;
        let holding = self.release == Release::Never;
        let mut dropped = false;
        for (e, &near) in ws.linearised.near.iter().enumerate() {
            if holding && ws.active[e] && !near {
                ws.active[e] = false;
                dropped = true;
            }
            if !ws.active[e] && near {
                ws.active[e] = true;
                ws.active_list.push(e as u32);
                for v in self.edges.ends[e] {
                    if !ws.is_touched[v as usize] {
                        ws.is_touched[v as usize] = true;
                        ws.touched.push(v);
                    }
                }
            }
        }
        if dropped {
            let active = &ws.active;
            ws.active_list.retain(|&e| active[e as usize]);
        }
        ws.active_list.sort_unstable();
        ws.linearised.largest_movable_excess()
    }

    /// Moves the touched particles along the Newton step `−W gathered` by
    /// the longest of 1, ½, ¼, … ([`BACKTRACKS`] halvings) that lowers the
    /// total squared excess below `before`; returns the excess it leaves.
    /// After a try that does not, the particles are put back exactly where
    /// they were: a step from a nearly singular multiplier system can be
    /// 10¹⁷ m long, and subtracting it again would leave metres of
    /// round-off (a strain correction on `pillars` left an edge at
    /// about 13,400 % that way).
    pub(super) fn line_search(&mut self, before: f64, constraints: &[Constraint], state: &mut ProjectedState) -> f64 {
        let ws = &mut self.ws;
        ws.before_step.clear();
        ws.before_step.extend(ws.touched.iter().map(|&v| (state.x[v as usize], state.v[v as usize])));
        let mut step = 1.0;
        for _ in 0..BACKTRACKS {
            self.move_touched(-step, constraints, state);
            let after = self.ws.linearised.squared_excess();
            if after < before {
                return after;
            }
            let ws = &mut self.ws;
            for (&v, &(x, velocity)) in ws.touched.iter().zip(&ws.before_step) {
                (state.x[v as usize], state.v[v as usize]) = (x, velocity);
            }
            let particles = Particles { x: state.x, constraints, mass: state.mass };
            ws.linearised.update_at(&ws.touched, &self.edges, particles);
            step *= 0.5;
        }
        before
    }

    /// `x += scale · W gathered`, `v += scale · W gathered / h` on the
    /// touched particles, and linearises their edges again.
    fn move_touched(&mut self, scale: f64, constraints: &[Constraint], state: &mut ProjectedState) {
        let ws = &mut self.ws;
        for &v in &ws.touched {
            let v = v as usize;
            let delta = constraints[v].filter(ws.gathered[v]) * (scale / state.mass[v]);
            state.x[v] += delta;
            state.v[v] += delta / state.h;
        }
        let particles = Particles { x: state.x, constraints, mass: state.mass };
        ws.linearised.update_at(&ws.touched, &self.edges, particles);
    }
}
