//! The multipliers of one Newton iteration: `(J W Jᵀ) μ = C` by conjugate
//! gradients, applied matrix-free and preconditioned by a sparse Cholesky
//! factor of `J W Jᵀ` on the active edges when one can be had.

use nalgebra::Vector3;

use super::*;

/// `p · q`, in order.
fn dot(p: &[f64], q: &[f64]) -> f64 {
    p.iter().zip(q).map(|(a, b)| a * b).sum()
}

impl StrainLimits {
    /// Solves `(J W Jᵀ) μ = C` on the active edges by conjugate gradients
    /// preconditioned by a factor of `J W Jᵀ` on those edges, with which
    /// they converge in one or two iterations: a fresh factor at each new
    /// linearisation or active set, the kept one after holds were released at
    /// the same linearisation (refactored unless it converges within
    /// [`KEPT_FACTOR_BUDGET`]). Where no factor can be had, Jacobi up to
    /// [`CG_ITERATIONS`].
    pub(super) fn solve_multipliers(
        &mut self,
        constraints: &[Constraint],
        mass: &[f64],
        linearisation: Linearisation,
        report: &mut ProjectionReport,
    ) {
        let kept = self.ws.factored
            && linearisation == Linearisation::Same
            && matches!(&self.direct, DirectSolver::Ready(system) if system.is_factored_for(&self.ws.active_list));
        if kept {
            let (iterations, converged) =
                self.conjugate_gradients(constraints, mass, Preconditioning::Factor, KEPT_FACTOR_BUDGET);
            report.cg_iterations += iterations;
            if converged {
                return;
            }
        }
        self.ws.factored = self.factor(constraints, mass);
        let preconditioning = if self.ws.factored { Preconditioning::Factor } else { Preconditioning::Jacobi };
        report.factorizations += u32::from(self.ws.factored);
        report.cg_iterations += self.conjugate_gradients(constraints, mass, preconditioning, CG_ITERATIONS).0;
    }

    /// The direct solver, made on first use.
    fn direct_solver(&mut self, vertex_count: usize) -> &mut DirectSolver {
        if matches!(self.direct, DirectSolver::NotNeededYet) {
            self.direct = match EdgeSystem::new(vertex_count, &self.edges.ends) {
                Ok(system) => DirectSolver::Ready(Box::new(system)),
                Err(_) => DirectSolver::Unavailable,
            };
        }
        &mut self.direct
    }

    /// Factors `J W Jᵀ` on the active edges at the current linearisation;
    /// false when no factor can be had (the analysis or the factor failed).
    fn factor(&mut self, constraints: &[Constraint], mass: &[f64]) -> bool {
        self.direct_solver(mass.len());
        let DirectSolver::Ready(system) = &mut self.direct else { return false };
        let (ws, edges) = (&self.ws, &self.ws.linearised.states);
        let row = |e: usize| EdgeRow { direction: edges[e].direction, diagonal: edges[e].diagonal };
        system.factor(&ws.active_list, &ws.active, row, constraints, mass).is_ok()
    }

    /// `preconditioned ← P⁻¹ residual` on the active edges.
    fn precondition(&mut self, preconditioning: Preconditioning) {
        let ws = &mut self.ws;
        match (preconditioning, &mut self.direct) {
            (Preconditioning::Factor, DirectSolver::Ready(system)) => {
                system.solve(&ws.residual, &mut ws.preconditioned);
            }
            _ => {
                for (i, &e) in ws.active_list.iter().enumerate() {
                    ws.preconditioned[i] = ws.residual[i] / ws.linearised.states[e as usize].diagonal;
                }
            }
        }
    }

    /// Solves `(J W Jᵀ) μ = C` on the active edges by preconditioned CG,
    /// matrix-free and on the calling thread (a sequential loop is the same
    /// at any thread count), for at most `cap` iterations. Returns the
    /// iterations and whether they reached [`CG_TOLERANCE`].
    fn conjugate_gradients(
        &mut self,
        constraints: &[Constraint],
        mass: &[f64],
        preconditioning: Preconditioning,
        cap: u32,
    ) -> (u32, bool) {
        let ws = &mut self.ws;
        let k = ws.active_list.len();
        for v in [&mut ws.multiplier, &mut ws.residual, &mut ws.preconditioned, &mut ws.search, &mut ws.product] {
            v.resize(k, 0.0);
        }
        for (i, &e) in ws.active_list.iter().enumerate() {
            ws.multiplier[i] = 0.0;
            ws.residual[i] = ws.linearised.states[e as usize].violation;
        }
        let norm_b = dot(&ws.residual, &ws.residual).sqrt();
        if norm_b == 0.0 {
            return (0, true);
        }
        self.precondition(preconditioning);
        let ws = &mut self.ws;
        ws.search.copy_from_slice(&ws.preconditioned);
        let mut rz = dot(&ws.residual, &ws.preconditioned);
        for iteration in 1..=cap {
            self.gather_active(Compact::Search);
            self.multiply(constraints, mass);
            let ws = &mut self.ws;
            let pq = dot(&ws.search, &ws.product);
            if pq <= 0.0 {
                return (iteration, true);
            }
            let alpha = rz / pq;
            for i in 0..k {
                ws.multiplier[i] += alpha * ws.search[i];
                ws.residual[i] -= alpha * ws.product[i];
            }
            if dot(&ws.residual, &ws.residual).sqrt() <= CG_TOLERANCE * norm_b {
                return (iteration, true);
            }
            self.precondition(preconditioning);
            let ws = &mut self.ws;
            let rz_next = dot(&ws.residual, &ws.preconditioned);
            let beta = rz_next / rz;
            rz = rz_next;
            for i in 0..k {
                ws.search[i] = ws.preconditioned[i] + beta * ws.search[i];
            }
        }
        (cap, false)
    }

    /// `gathered_v ← Σ_e ±u_e y_e` over the active edges at each touched
    /// particle, for the compact edge vector `y` (`Jᵀ y`).
    pub(super) fn gather_active(&mut self, which: Compact) {
        let ws = &mut self.ws;
        for &v in &ws.touched {
            ws.gathered[v as usize] = Vector3::zeros();
        }
        let values = match which {
            Compact::Search => &ws.search,
            Compact::Multiplier => &ws.multiplier,
        };
        for (i, &e) in ws.active_list.iter().enumerate() {
            let [a, b] = self.edges.ends[e as usize];
            let force = ws.linearised.states[e as usize].direction * values[i];
            ws.gathered[a as usize] += force;
            ws.gathered[b as usize] -= force;
        }
    }

    /// `product ← J W gathered`, on the active edges. Leaves `W gathered`
    /// in `gathered` (each touched particle weighted once, not once per edge).
    fn multiply(&mut self, constraints: &[Constraint], mass: &[f64]) {
        let ws = &mut self.ws;
        for &v in &ws.touched {
            let v = v as usize;
            ws.gathered[v] = constraints[v].filter(ws.gathered[v]) / mass[v];
        }
        let weighted = &ws.gathered;
        for (i, &e) in ws.active_list.iter().enumerate() {
            let [a, b] = self.edges.ends[e as usize];
            let edge = &ws.linearised.states[e as usize];
            ws.product[i] = edge.direction.dot(&(weighted[a as usize] - weighted[b as usize]));
        }
    }
}
