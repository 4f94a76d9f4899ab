//! Inextensibility constraints (PAPER eq. 1, 2 and 6): a stretch edge of a
//! garment whose fabric sets a strain limit `ε` may lengthen to at most
//! `(1 + ε) L` (its rest length `L`); shortening is left to the springs.
//!
//! After the implicit velocity update has produced the unconstrained end
//! positions `x̂`, they are projected onto the constraints by *fast projection*
//! (Goldenthal et al. 2007). With `C_e(x) = |x_a − x_b| − (1 + ε) L` on every
//! active edge, each Newton iteration solves
//!
//! ```text
//! (J W Jᵀ) μ = C(x_j),    x_{j+1} = x_j − W Jᵀ μ
//! ```
//!
//! the smallest mass-weighted correction that zeroes the linearised
//! constraints: eq. 6 with `Δt² λ = −μ` and `W = M⁻¹`. Pinned particles do not
//! move (`W = 0`); a particle held on a collider's surface slides along it
//! (`W = M⁻¹ (I − n nᵀ)`). `J W Jᵀ` couples edges that share a particle; it is
//! applied matrix-free inside a conjugate-gradient solve, preconditioned by
//! a sparse Cholesky factor of `J W Jᵀ` on the active edges
//! ([`super::edge_system`]), rebuilt at each Newton iteration.
//! Velocities change with positions (`Δv = Δx / h`), so the step stays
//! consistent. The inequality is an active set: an edge joins when it exceeds
//! its limit, and leaves when its multiplier would push its ends apart (a
//! limit only pulls) — otherwise a slack edge that was momentarily over its
//! limit would be held at it, and a cloth at rest would never settle.
//!
//! Between collision passes the projection also must not undo what the
//! pass's impulses did: a particle pushed off an obstacle it cannot wrap round
//! (the body, a needle: [`super::collision::obstacles::Obstacles::holds`]) is held
//! along the push's normal, so the limits are met by sliding it and moving
//! its neighbours rather than by pulling it back into the obstacle's
//! thickness, which the next pass would push out again. The hold is
//! one-sided, the same active-set rule as the edges' own: released as soon
//! as the multipliers would move the particle away from the obstacle. Where
//! the holds leave the limits unmet, what the projection reached is kept
//! (it never moves a held particle back), and the next pass goes on from it.
//! So is it, with or without holds, when the step's first projection found
//! limits that pins make unreachable (a waistband glued to the moving skin
//! pulling the cloth apart): a result that must miss them is no reason to
//! undo the rest.
//!
//! [`StrainLimiting::Clamp`] is the cheap per-edge alternative (Provot 1995,
//! mass-weighted and averaged per particle): every over-long edge is shortened
//! on its own, over and over. It converges slowly on fine meshes and is kept as
//! the fallback when the projection does not converge, and for comparison.
//!
//! Each edge's linearisation ([`super::limit_edges`]) is taken over every edge
//! once per projection, in parallel chunks, and after each Newton move only at
//! the particles that moved. Its sums run per chunk and over chunks in a fixed
//! order, and the conjugate-gradient solve runs on the calling thread, so the
//! result is bit-identical at any thread count.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::cloth::{Cloth, SpringKind};
use super::constraint::Constraint;
use super::edge_system::{EdgeRow, EdgeSystem};
use super::limit_edges::{EdgeSet, LinearisedEdges, Particles};
use super::parallel;
use super::pin_reach::{PinReach, ReachEdges};

mod clamp;
mod multipliers;
mod newton;

/// Strain at which the constraints count as met: 0.01 % beyond the limit.
pub const STRAIN_TOLERANCE: f64 = 1e-4;

/// Newton iterations of one projection before it falls back to clamping,
/// on a cloth up to [`BUDGETED_SPAN`] edges across.
const NEWTON_ITERATIONS: u32 = 30;

/// Newton iterations of a projection that holds particles a collision pass
/// pushed off, before it keeps what it reached. A pass whose impulses throw
/// a few particles far (a leg through `skirt_walk`'s hem: edges 60-110 %
/// beyond their limit) needs 33-55, most halved by the line search; 30
/// left such edges 1-10 % over at the step's end. (The same 60 for every
/// projection made `twist`, whose pins pull it apart, 20 % slower.)
const HOLDING_NEWTON_ITERATIONS: u32 = 60;

/// Edges across the widest piece of cloth that [`NEWTON_ITERATIONS`] and
/// [`HOLDING_NEWTON_ITERATIONS`] were set on: the 128 × 128 grids of
/// `pillars` and `drape_sphere` at N = 128. A Newton iteration carries a
/// pull about one ring of edges further (an edge joins the active set once
/// it is near its limit), so a cloth that spans more edges gets budgets in
/// proportion ([`scaled_budget`]): at N = 256 (510 edges across) the landing
/// on the sphere ran out of 30 iterations, clamping finished it, and the
/// frame ended at 2.28 %; with 61 every frame ends within 1.02 %.
const BUDGETED_SPAN: u32 = 254;

/// `budget` Newton iterations for a cloth `span` edges across (see
/// [`BUDGETED_SPAN`]): the same up to that span, in proportion beyond it.
fn scaled_budget(budget: u32, span: u32) -> u32 {
    let scaled = (u64::from(budget) * u64::from(span)).div_ceil(u64::from(BUDGETED_SPAN));
    budget.max(u32::try_from(scaled).unwrap_or(u32::MAX))
}

/// Rounds per Newton iteration of releasing edges whose multiplier pushes
/// and solving again (a primal active-set method on the inequalities).
const RELEASE_ROUNDS: u32 = 4;

/// Halvings of a Newton step that does not reduce the excess.
const BACKTRACKS: u32 = 6;

/// A Newton iteration that leaves more than this fraction of the squared
/// excess of the movable edges makes no real progress; after
/// [`STALLED_ITERATIONS`] of them in a row the limits are taken as
/// unreachable (pins pulling the cloth apart), unless [`UNREACHABLE_SHARE`]
/// says the projection is merely slow. (Counting the edges between two pins
/// too, which keep their excess whatever a step does, a waistband the body
/// stretched 10 % made `fast_body`'s held projections stop at 1.5 % over
/// after four iterations that each removed half of the rest.)
const STALL_RATIO: f64 = 0.9;

/// See [`STALL_RATIO`].
const STALLED_ITERATIONS: u32 = 3;

/// A stalled projection counts as unreachable only if it has not removed at
/// least half of the movable edges' squared excess it started with; one
/// that has (a hard impact, far from the limits) is slow, not stuck, and
/// goes on.
const UNREACHABLE_SHARE: f64 = 0.5;

/// Conjugate-gradient iterations of one multiplier solve at most.
const CG_ITERATIONS: u32 = 400;

/// Iterations preconditioned by a kept factor (made for the same
/// linearisation and active edges, before holds were released) before it
/// is rebuilt.
pub const KEPT_FACTOR_BUDGET: u32 = 6;

/// Relative residual at which a Newton iteration's linear solve stops.
const CG_TOLERANCE: f64 = 1e-4;

/// Per-edge clamping sweeps (the fallback, or the method when chosen).
const CLAMP_SWEEPS: u32 = 200;

/// How a simulation keeps stretch edges within their fabric's strain limit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StrainLimiting {
    /// Fast projection (eq. 6): a few Newton iterations, each a sparse solve.
    #[default]
    Projection,
    /// Per-edge clamping sweeps (Provot 1995): cheap, converges badly on fine meshes.
    Clamp,
    /// No constraints: the springs alone resist stretch.
    Off,
}

impl StrainLimiting {
    /// The name used in scene files.
    pub fn name(self) -> &'static str {
        match self {
            StrainLimiting::Projection => "projection",
            StrainLimiting::Clamp => "clamp",
            StrainLimiting::Off => "off",
        }
    }
}

/// What one projection did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectionReport {
    /// Edges held at their limit.
    pub active_edges: u32,
    /// Newton iterations (linear solves).
    pub newton_iterations: u32,
    /// Conjugate-gradient iterations over all Newton iterations.
    pub cg_iterations: u32,
    /// Factors of `J W Jᵀ` built to precondition them.
    pub factorizations: u32,
    /// Clamping sweeps (the fallback, or the chosen method).
    pub clamp_sweeps: u32,
    /// Largest strain beyond the limit left afterwards (0 when met), unitless.
    pub excess_strain: f64,
    /// Whether the Newton iterations ran out while still progressing and
    /// clamping took over.
    pub fell_back: bool,
    /// Whether the Newton iterations stopped making progress: the limits
    /// cannot be met (pins pulling the cloth apart).
    pub stalled: bool,
    /// Whether the projection was undone: between collision passes
    /// ([`StrainLimits::project_if_met`]) it stalled or missed its tolerance.
    pub abandoned: bool,
    /// Whether a projection between passes ([`StrainLimits::project_holding`]
    /// with holds, or [`StrainLimits::project_partial`]) kept a result short
    /// of the limits (its Newton iterations ran out or stalled, or the holds
    /// immobilised an edge over its limit).
    pub partial: bool,
}

impl ProjectionReport {
    /// Folds in a later projection of the same step (after collision
    /// impulses): iterations add up, the excess left is the later one.
    pub fn add(&mut self, later: &ProjectionReport) {
        self.add_work(later);
        self.active_edges = self.active_edges.max(later.active_edges);
        self.excess_strain = later.excess_strain;
        self.fell_back |= later.fell_back;
        self.stalled |= later.stalled;
        self.abandoned |= later.abandoned;
        self.partial |= later.partial;
    }

    /// Folds in only the work of a later projection whose result was not
    /// kept (iterations, factors, sweeps): what the step's projection
    /// reached stands as it was.
    pub fn add_work(&mut self, later: &ProjectionReport) {
        self.newton_iterations += later.newton_iterations;
        self.cg_iterations += later.cg_iterations;
        self.factorizations += later.factorizations;
        self.clamp_sweeps += later.clamp_sweeps;
    }
}

/// One step's particle state as the projection changes it.
pub struct ProjectedState<'a> {
    /// End-of-step positions, m: `x̂` in, projected out.
    pub x: &'a mut [Vector3<f64>],
    /// End-of-step velocities, m/s: changed by `Δx / h`.
    pub v: &'a mut [Vector3<f64>],
    /// What each particle may do (pinned, on a surface, free).
    pub constraints: &'a [Constraint],
    /// Particle masses, kg.
    pub mass: &'a [f64],
    /// Step, s.
    pub h: f64,
}

/// Reusable buffers of a projection.
#[derive(Clone, Debug, Default)]
struct Workspace {
    /// Every edge linearised at the current iterate.
    linearised: LinearisedEdges,
    /// Per edge: in the active set.
    active: Vec<bool>,
    /// The active edges, ascending.
    active_list: Vec<u32>,
    /// Particles at the ends of active edges, each once.
    touched: Vec<u32>,
    /// Per particle: listed in `touched`.
    is_touched: Vec<bool>,
    /// Per active edge (compact): multipliers μ, m·kg and the CG vectors.
    multiplier: Vec<f64>,
    residual: Vec<f64>,
    preconditioned: Vec<f64>,
    search: Vec<f64>,
    product: Vec<f64>,
    /// Per particle: Σ_e ±u_e y_e of an edge vector y (only touched particles are valid).
    gathered: Vec<Vector3<f64>>,
    /// Positions and velocities kept by [`StrainLimits::project_if_met`].
    saved: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// The touched particles' positions and velocities before a Newton
    /// step's line search.
    before_step: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// The active edges (after releases) and the number of holds of the
    /// last Newton iteration, when its line search found no shorter step.
    failed_active: Vec<u32>,
    failed_holds: Option<usize>,
    /// Whether this projection has a factor of `J W Jᵀ` to precondition with.
    factored: bool,
    /// Particles whose edges are to be linearised again: those whose holds
    /// the last round released, or every held one after a held projection.
    relinearise: Vec<u32>,
}

/// The direct solver of `J W Jᵀ`, made the first time a projection needs it.
#[derive(Clone, Debug)]
enum DirectSolver {
    NotNeededYet,
    Ready(Box<EdgeSystem>),
    /// The mesh's elimination order could not be had: conjugate gradients alone.
    Unavailable,
}

/// The inextensibility constraints of a cloth and the solver that enforces them.
#[derive(Clone, Debug)]
pub struct StrainLimits {
    method: StrainLimiting,
    /// The stretch edges and their maximal lengths.
    edges: EdgeSet,
    /// Garment of each edge.
    edge_garment: Vec<u32>,
    ws: Workspace,
    /// The factorable `J W Jᵀ`, made the first time a projection needs it.
    direct: DirectSolver,
    /// Whether the projection under way releases pushing edges.
    release: Release,
    /// Newton iterations a projection may take, and one that holds
    /// particles: [`NEWTON_ITERATIONS`] and [`HOLDING_NEWTON_ITERATIONS`]
    /// scaled to the cloth's span ([`scaled_budget`]).
    newton_iterations: [u32; 2],
    /// Newton iterations the projection under way may take, when fewer
    /// than its kind's own ([`Self::project_if_met_within`]).
    newton_budget: Option<u32>,
    /// Particles the projection under way may not move towards an obstacle
    /// (see [`StrainLimits::project_holding`]), with the unit normal
    /// pointing away from it.
    holds: Vec<(u32, Vector3<f64>)>,
    /// The particles' constraints with the holds that still apply, scratch.
    held: Vec<Constraint>,
}

impl StrainLimits {
    /// The constraints of `cloth`: its stretch springs, limited where their
    /// garment's fabric sets a strain limit (the others get an infinite
    /// maximal length, so a limit can be set while the cloth runs). `None`
    /// when no garment has a limit, or `method` is [`StrainLimiting::Off`]:
    /// the scene then pays nothing for them.
    pub fn new(cloth: &Cloth, method: StrainLimiting) -> Option<Self> {
        let any_limit = cloth.garments.iter().any(|g| g.fabric.strain_limit.is_some());
        if method == StrainLimiting::Off || !any_limit {
            return None;
        }
        let (mut ends, mut rest_length, mut edge_garment) = (Vec::new(), Vec::new(), Vec::new());
        for (g, garment) in cloth.garments.iter().enumerate() {
            for s in garment.springs.clone() {
                if cloth.spring_kind[s] == SpringKind::Stretch {
                    ends.push(cloth.spring_ends[s]);
                    rest_length.push(cloth.rest_length[s]);
                    edge_garment.push(g as u32);
                }
            }
        }
        let edges = EdgeSet::new(cloth.vertex_count(), ends, rest_length);
        let span = edges.span_in_edges();
        let mut limits = StrainLimits {
            method,
            newton_iterations: [NEWTON_ITERATIONS, HOLDING_NEWTON_ITERATIONS].map(|b| scaled_budget(b, span)),
            edges,
            edge_garment,
            ws: Workspace::default(),
            direct: DirectSolver::NotNeededYet,
            release: Release::PushingEdges,
            newton_budget: None,
            holds: Vec::new(),
            held: Vec::new(),
        };
        limits.edges.max_length = limits.max_lengths_for(cloth);
        Some(limits)
    }

    /// Each edge's maximal length under `cloth`'s current fabrics, m
    /// (infinite where the garment has no limit).
    pub fn max_lengths_for(&self, cloth: &Cloth) -> Vec<f64> {
        let limit = |e: usize| cloth.garments[self.edge_garment[e] as usize].fabric.strain_limit;
        (0..self.edges.ends.len())
            .map(|e| limit(e).map_or(f64::INFINITY, |l| (1.0 + l) * self.edges.rest_length[e]))
            .collect()
    }

    /// The reaches between the pinned particles `pins` under the limits of
    /// `cloth`'s current fabrics ([`super::pin_reach`]); `fixed` marks
    /// every pinned particle.
    pub fn pin_reach(&self, cloth: &Cloth, fixed: &[bool], pins: &[u32]) -> PinReach {
        let max_length = self.max_lengths_for(cloth);
        let (ends, rest_length) = (&self.edges.ends, &self.edges.rest_length);
        PinReach::new(
            &ReachEdges { vertex_count: fixed.len(), ends, rest_length, max_length: &max_length, fixed },
            pins,
        )
    }

    /// Each edge's maximal length in use, m.
    pub fn max_lengths(&self) -> &[f64] {
        &self.edges.max_length
    }

    /// Sets each edge's maximal length (m) from its index.
    pub fn set_max_lengths(&mut self, length: impl Fn(usize) -> f64) {
        for (e, l) in self.edges.max_length.iter_mut().enumerate() {
            *l = length(e);
        }
    }

    /// Each edge's length at `x`, m.
    pub fn lengths<'a>(&'a self, x: &'a [Vector3<f64>]) -> impl Iterator<Item = f64> + 'a {
        self.edges.ends.iter().map(move |[a, b]| (x[*a as usize] - x[*b as usize]).norm())
    }

    /// Number of constrained edges.
    pub fn edge_count(&self) -> usize {
        self.edges.ends.len()
    }

    /// Largest strain beyond its limit of any constrained edge at `x` (0 when
    /// all are within), unitless.
    pub fn excess_strain(&self, x: &[Vector3<f64>]) -> f64 {
        let (ends, max_length, rest) = (&self.edges.ends, &self.edges.max_length, &self.edges.rest_length);
        parallel::max(ends.len(), |e| {
            let [a, b] = ends[e];
            ((x[a as usize] - x[b as usize]).norm() - max_length[e]).max(0.0) / rest[e]
        })
    }

    /// Moves `state` onto the constraints (see the module documentation).
    /// When the Newton iterations run out while still progressing, clamping
    /// takes over. When they stall, the limits cannot be met (pins pulling
    /// the cloth apart) and the iterations stop where they are: each one
    /// lowered the total squared excess, so `state` keeps what the cloth
    /// could give, and the edges nothing can shorten stay as they are.
    pub fn project(&mut self, state: ProjectedState) -> ProjectionReport {
        self.project_keeping(state, true, None)
    }

    /// The projection between collision passes. Like [`Self::project`], but
    /// without clamping: the result is kept only when it meets the limits,
    /// and otherwise `state` is left as it was (`abandoned`), because a
    /// partial answer would fight the impulses. Edges near their limit are
    /// held at it rather than released when their multiplier pushes (see
    /// [`Release`]): each release round costs a solve, often a factor, and
    /// after an impulse pass they are most of the projection's time.
    pub fn project_if_met(&mut self, state: ProjectedState) -> ProjectionReport {
        self.project_keeping(state, false, None)
    }

    /// [`Self::project_if_met`] in at most `newton_iterations`: for a
    /// correction worth making only where the limits are met quickly
    /// (otherwise `state` is left as it was, `abandoned`).
    pub fn project_if_met_within(&mut self, state: ProjectedState, newton_iterations: u32) -> ProjectionReport {
        self.project_keeping(state, false, Some(newton_iterations))
    }

    /// The projection between collision passes that does not move the
    /// particles of `holds` towards the obstacles the pass just pushed them
    /// off: each `(particle, n)` may slide across the unit normal `n`
    /// (pointing away from the obstacle) and move along it, but not against
    /// it. A hold is a one-sided constraint: a particle is held along `n`
    /// until a Newton iteration's multipliers would move it along `n`, and is
    /// then released. Without holds, this is [`Self::project_if_met`].
    ///
    /// Unlike that, the result is kept when it falls short of the limits
    /// (`partial`): each Newton iteration lowered the total squared excess
    /// and none moved a held particle towards its obstacle, so a partial
    /// answer does not fight the impulses, and what is left is for the next
    /// pass's projection or the next step's. (Undoing it and projecting
    /// without the holds meets the limits by pulling the cloth back into the
    /// body, which the next pass pushes out again: measured on `skirt_walk`,
    /// a mean frame of 122-125 ms against 93-97 ms, and 6 steps rolled back
    /// against none.)
    pub fn project_holding(&mut self, state: ProjectedState, holds: &[(u32, Vector3<f64>)]) -> ProjectionReport {
        if holds.is_empty() {
            return self.project_if_met(state);
        }
        self.project_partial(state, holds)
    }

    /// The projection between collision passes after the step's first
    /// projection stalled on limits the pins make unreachable (a waistband
    /// ring glued to the skin, stretched by it): like [`Self::project_holding`]
    /// with holds, it keeps what it gains when it falls short, with or
    /// without holds. [`Self::project_if_met`] would be undone every time,
    /// so every edge a pass stretched would stay stretched for the step: on
    /// `skirt_tiered_walk` that left 85 % strain in the tiers below the
    /// waistband and 15 steps rolled back; with this, 28 % and none.
    pub fn project_partial(&mut self, mut state: ProjectedState, holds: &[(u32, Vector3<f64>)]) -> ProjectionReport {
        self.holds.clear();
        self.holds.extend_from_slice(holds);
        self.release = Release::Never;
        self.newton_budget = None;
        let mut report = self.run(&mut state, false);
        // The holds' own excess leaves out the edges they immobilised: their
        // edges are linearised again without the holds that still apply.
        let particles = Particles { x: state.x, constraints: state.constraints, mass: state.mass };
        self.ws.relinearise.clear();
        self.ws.relinearise.extend(self.holds.iter().map(|(v, _)| *v));
        self.ws.linearised.update_at(&self.ws.relinearise, &self.edges, particles);
        report.excess_strain = self.ws.linearised.largest_movable_excess();
        self.holds.clear();
        report.partial = report.excess_strain > STRAIN_TOLERANCE;
        (report.fell_back, report.stalled) = (false, false);
        report
    }

    /// Runs the projection on `state` in at most `newton_budget` Newton
    /// iterations (its kind's own when `None`); between collision passes
    /// (without `fallback`) undoes it when it stalls or misses its tolerance.
    fn project_keeping(
        &mut self,
        mut state: ProjectedState,
        fallback: bool,
        newton_budget: Option<u32>,
    ) -> ProjectionReport {
        let mut saved = std::mem::take(&mut self.ws.saved);
        saved.clear();
        saved.extend(state.x.iter().zip(state.v.iter()).map(|(x, v)| (*x, *v)));
        self.release = if fallback { Release::PushingEdges } else { Release::Never };
        self.newton_budget = newton_budget;
        let mut report = self.run(&mut state, fallback);
        let missed = !fallback && report.excess_strain > STRAIN_TOLERANCE;
        if (report.stalled && !fallback) || missed {
            for (i, (x, v)) in saved.iter().enumerate() {
                (state.x[i], state.v[i]) = (*x, *v);
            }
            report.abandoned = true;
            report.excess_strain = self.excess_strain(state.x);
        }
        self.ws.saved = saved;
        report
    }

    /// The chosen method, and clamping after a failed projection when `fallback`.
    fn run(&mut self, state: &mut ProjectedState, fallback: bool) -> ProjectionReport {
        let ws = &mut self.ws;
        ws.factored = false;
        ws.active.clear();
        ws.active.resize(self.edges.ends.len(), false);
        ws.active_list.clear();
        ws.is_touched.clear();
        ws.is_touched.resize(state.x.len(), false);
        ws.touched.clear();
        ws.gathered.resize(state.x.len(), Vector3::zeros());
        let mut report = ProjectionReport::default();
        if self.method == StrainLimiting::Projection {
            self.fast_projection(state, &mut report);
        }
        if self.method == StrainLimiting::Clamp || (report.fell_back && fallback) {
            self.clamp(state, &mut report);
        }
        report.active_edges = self.ws.active_list.len() as u32;
        report
    }
}

/// How the multiplier solve is preconditioned.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Preconditioning {
    /// By the diagonal of `J W Jᵀ`.
    Jacobi,
    /// By a factor of `J W Jᵀ` ([`EdgeSystem`]).
    Factor,
}

/// What a projection does with an active edge within its limit whose
/// multiplier would push its ends apart.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Release {
    /// Takes it out and solves again, up to [`RELEASE_ROUNDS`] times per
    /// Newton iteration: the exact inequality projection, for the projection
    /// after the implicit solve, whose result the cloth keeps.
    PushingEdges,
    /// Holds it at its limit while it stays within [`NEAR_LIMIT`](super::limit_edges::NEAR_LIMIT) of it (it
    /// leaves at a linearisation that finds it further), so this lengthens
    /// an edge by at most that strain, and the next step's projection starts
    /// afresh: the cloth still settles. Used between collision passes.
    Never,
}

/// Whether a solve follows a new linearisation of the constraints, or
/// edges released at the same one.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Linearisation {
    /// The first solve of a Newton iteration.
    New,
    /// A solve after edges left the active set.
    Same,
}

/// Which compact edge vector to gather.
#[derive(Clone, Copy)]
enum Compact {
    Search,
    Multiplier,
}

#[cfg(test)]
mod tests;
