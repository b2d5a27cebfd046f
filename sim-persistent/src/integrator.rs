//! Implicit (backward) Euler time stepping as one Newton minimization per step (seed 000 §5:
//! "implicit-integration algorithm proposed in" ref. 6, Cirio et al. 2014; time step 1 ms).
//!
//! With step `h`, coordinates `qₙ`, velocities `vₙ`, Rayleigh damping `D = α M + β K` and the
//! potential `V` of [`crate::forces`], backward Euler
//!
//! ```text
//! M (vₙ₊₁ − vₙ)/h = −∇V(qₙ₊₁) − D vₙ₊₁,     qₙ₊₁ = qₙ + h vₙ₊₁
//! ```
//!
//! is the stationarity condition of the incremental potential
//!
//! ```text
//! Φ(q) = 1/(2h²) (q − q̂)ᵀ M (q − q̂) + 1/(2h) (q − qₙ)ᵀ D (q − qₙ) + V(q),   q̂ = qₙ + h vₙ,
//! ```
//!
//! which [`solver::NewtonSolver`] minimizes (backtracking line search, diagonal shift when
//! the Hessian is indefinite, Dirichlet DOFs for pinned positions and pinned sliding
//! coordinates; the sparsity pattern and symbolic factorization are built once and reused
//! every step).
//!
//! **Documented choices.**
//! - *Lagged mass matrix.* The state-dependent segment mass matrix
//!   ([`crate::state::segment_mass_matrix`]) is evaluated at `qₙ` and frozen over the step.
//! - *Velocity-quadratic terms dropped.* Lagrange's equations for `T = ½ q̇ᵀ M(q) q̇` add
//!   `Ṁ q̇ − ½ ∂(q̇ᵀ M q̇)/∂q`; we drop them. Their power is
//!   `q̇ᵀ(Ṁq̇ − ½ ∂(q̇ᵀMq̇)/∂q) = ½ q̇ᵀṀq̇`, exactly what `d/dt (½ q̇ᵀMq̇)` gains from the
//!   changing `M`, so without them `T + V` drifts at a rate cubic in the velocity (small at
//!   cloth speeds), on top of backward Euler's O(h) numerical dissipation. The free-swatch
//!   test measures the total drift and its decrease with `h`.
//! - *Friction.* The anchored springs of Eq. 5 with the slip force `μ λ`, λ *lagged*:
//!   estimated ([`crate::forces::compression`]) at the state at the start of the (sub)step,
//!   so that it does not change during the Newton solve (a static solve uses its
//!   equilibrium instead and always updates the anchors explicitly,
//!   [`Simulator::solve_static`]). By default the anchors move only after the step, as in
//!   the paper ([`crate::forces::friction::AnchoredSpring::update_anchor`]), and friction
//!   grows with the step. With [`StepSettings::friction_return_mapping`] > 0 the stick/slip
//!   decision is implicit, a return mapping: the step is re-solved with each coordinate
//!   either sticking (spring) or slipping (constant Coulomb force) until no coordinate
//!   changes mode ([`crate::forces::friction`]); then the slipped anchors move to their
//!   maximal stick positions.
//! - *Damping.* `D = α M(qₙ) + β K⁺(qₙ)`, with `K⁺` the per-stencil PSD-projected Hessian of
//!   the elastic terms at the start of the step (so damping is dissipative), both frozen over
//!   the step like `M`. Optionally `K⁺` is only recomputed every
//!   [`StepSettings::damping_refresh_steps`] steps (its per-stencil eigen-projections are
//!   the largest part of a step's setup).
//! - *Linear solver and linearization.* The Newton system is solved by sparse Cholesky
//!   (default) or preconditioned conjugate gradients (`StepSettings::newton.linear_solver`);
//!   [`StepSettings::linearized_implicit_euler`] stops after one Newton iteration without
//!   line search (linearized backward Euler, as in seed 000's ref. 6), reporting the
//!   residual it leaves.
//! - *Step halving.* A step whose Newton solve fails (far from the minimizer, e.g. the first
//!   undamped step from a layout that is not at rest) is replaced by two half steps,
//!   recursively ([`StepSettings::max_halvings`]); the state only changes on success.
//! - *Wrapping ramp.* The layout starts with unwrapped stitch contacts (ψ ≈ 0; a flat layout
//!   cannot be wrapped uniformly, see [`crate::forces::wrapping`]). Each wrapping term's rest
//!   angle therefore moves from the layout's angle ψ_L to its target ψ₀ as
//!   `ψ_L + s(t/T) (ψ₀ − ψ_L)`, `s(λ) = 3λ² − 2λ³` (smoothstep, no jump in the rest angle's
//!   rate at either end), `T` = [`StepSettings::wrapping_ramp_time`], evaluated at the end
//!   of each (sub)step; the wrapping energy is zero at the layout. Without the ramp (`T = 0`)
//!   every contact would get a quarter-turn torque at once.

use crate::forces::compression::{CompressionEstimator, NodeCompression, slip_forces};
use crate::forces::friction::AnchoredSpring;
use crate::forces::quadratic::Quadratic;
use crate::forces::wrapping::StitchWrap;
use crate::forces::{ForceSet, Potential, Term, TermKind, build_terms};
use crate::layout::Layout;
use crate::params::YarnParams;
use crate::state::{DofMap, State, gather, kinetic_energy, segment_mass_matrix};
use crate::topology::Topology;
use rayon::prelude::*;
use rod::geometry::V3;
use solver::{NewtonReport, NewtonSettings, NewtonSolver, SolveError, StepError};

/// Time-step parameters (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct StepSettings {
    /// Time step h (s). Default 1 ms (seed 000 §5).
    pub dt: f64,
    /// Rayleigh mass-damping coefficient α (1/s). Default 0 (Table 1 uses 2–10).
    pub rayleigh_alpha: f64,
    /// Rayleigh stiffness-damping coefficient β (s). Default 0 (Table 1 uses 0.01–0.1).
    pub rayleigh_beta: f64,
    /// Newton settings of each step. Default: `solver` defaults with a relative gradient
    /// tolerance of 1e-9, at most 100 iterations (a 10 ms step of the hanging swatch of
    /// `examples/stability.rs` needs 51–80) and no per-stencil SPD projection: the
    /// inertia term keeps the step's Hessian positive definite for cloth-sized steps, plain
    /// Newton then converges in 2–3 iterations where projection needs ≈ 5 (and projects
    /// every 8 × 8 and 12 × 12 block each iteration); the solver's diagonal shift still
    /// catches an indefinite Hessian. The linear solver of the Newton system is
    /// `newton.linear_solver` (sparse Cholesky by default, or preconditioned conjugate
    /// gradients); [`StepSettings::linearized_implicit_euler`] turns the step into a single
    /// Newton iteration.
    pub newton: NewtonSettings,
    /// How often a step whose Newton solve fails may be halved (recursively). Default 4
    /// (down to dt/16). A step is also a Newton minimization far from its start when the
    /// layout is not at rest (no rest-shape compensation yet) and damping is off.
    pub max_halvings: usize,
    /// Duration `T` (s) of the ramp of the stitch-wrapping rest angles from the layout's
    /// angles to ψ₀ (module documentation); `0` applies ψ₀ from the start. Default 0.1 s
    /// (100 steps of 1 ms), several periods of the slowest loop modes of a swatch of the
    /// Table 1 yarns, so that the contacts wrap up quasi-statically.
    pub wrapping_ramp_time: f64,
    /// Recompute the Rayleigh-β damping matrices `K⁺` every this many (sub)steps (≥ 1);
    /// in between they stay lagged (only their centres move to `qₙ`), like the lagged mass
    /// matrix. Default 1: every step (the per-stencil PSD projections of `K⁺` are the largest
    /// part of a step's setup).
    pub damping_refresh_steps: usize,
    /// At most this many re-solves of a step for the implicit stick/slip decision of friction
    /// (the return mapping of [`crate::forces::friction`], e.g. 20); `0` moves the anchors
    /// only after the step, as the paper does (explicit update: friction then grows with the
    /// step). Default 0, the paper's model: with Coulomb-consistent friction yarns slide
    /// freely through uncompressed contacts, and the return mapping needs
    /// [`crate::forces::ForceSet::segment_floor`] (default on) and, for consistent results,
    /// [`crate::forces::ForceSet::loop_contact`] (measured in [`crate::forces::friction`]). A
    /// step whose modes still change after the last re-solve is kept, its anchors get the
    /// explicit update, and [`StepReport::friction_unresolved`] counts it. With Rayleigh
    /// β > 0 the friction springs get no β-damping form under the return mapping (it would
    /// brake slipping coordinates by `β k_f u̇`). With
    /// [`StepSettings::linearized_implicit_euler`] each re-solve adds one more Newton
    /// iteration without line search, so the step is no longer a single linearized solve.
    pub friction_return_mapping: usize,
}

impl StepSettings {
    /// A re-solve budget for [`StepSettings::friction_return_mapping`] that the measured
    /// runs never exhausted in more than 1 % of their steps (3–11 re-solves per step while
    /// coordinates slip; `persistent-time-vs-error`, `rib-stretch`).
    pub const RETURN_MAPPING_RESOLVES: usize = 20;
}

impl Default for StepSettings {
    fn default() -> Self {
        Self {
            dt: 1e-3,
            rayleigh_alpha: 0.0,
            rayleigh_beta: 0.0,
            newton: NewtonSettings {
                max_iterations: 100,
                gradient_rel_tol: 1e-9,
                project_spd: false,
                ..NewtonSettings::default()
            },
            max_halvings: 4,
            wrapping_ramp_time: 0.1,
            damping_refresh_steps: 1,
            friction_return_mapping: 0,
        }
    }
}

impl StepSettings {
    /// Checks the ranges (`dt > 0`, `α, β ≥ 0`, valid Newton settings).
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(SimError::Invalid(format!(
                "dt must be > 0, got {}",
                self.dt
            )));
        }
        for (name, v) in [
            ("Rayleigh α", self.rayleigh_alpha),
            ("Rayleigh β", self.rayleigh_beta),
            ("wrapping ramp time", self.wrapping_ramp_time),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SimError::Invalid(format!("{name} must be ≥ 0, got {v}")));
            }
        }
        if self.damping_refresh_steps == 0 {
            return Err(SimError::Invalid(
                "damping_refresh_steps must be ≥ 1".into(),
            ));
        }
        self.newton.validate()?;
        Ok(())
    }

    /// These settings with *linearized* implicit Euler: one Newton iteration per step from
    /// `qₙ`, taken at full length without a line search (the integrator of seed 000's ref. 6,
    /// Cirio et al. 2014, i.e. Baraff & Witkin 1998's linearized backward Euler:
    /// `(M + h D + h² K) Δv = h (f − D vₙ − h K vₙ)`, which is exactly the first Newton step on
    /// the incremental potential). The step is not iterated to convergence; its Newton report
    /// ends with [`solver::Termination::IterationLimit`] and still records the gradient
    /// residual of the incremental potential after the iteration
    /// ([`NewtonReport::residual_history`]), so the linearization error stays visible. A
    /// step whose linear solve fails (or whose result is not finite) is halved as usual.
    pub fn linearized_implicit_euler(mut self) -> Self {
        self.newton.max_iterations = 1;
        self.newton.line_search = false;
        self.newton.accept_iteration_limit = true;
        self
    }
}

/// Errors of the simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// Invalid parameters, layout or pins.
    #[error("invalid simulation input: {0}")]
    Invalid(String),
    /// The Newton solve of a step (after all halvings) or of a static equilibrium failed.
    #[error("Newton solve failed (time step or static equilibrium): {0}")]
    Solve(#[from] SolveError),
}

/// What one step did.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// Newton iterations over all substeps.
    pub newton_iterations: usize,
    /// Number of backward Euler solves that succeeded (1 unless the step was halved).
    pub substeps: usize,
    /// Number of slips of sliding coordinates (friction anchors moved, Eq. 5), summed over
    /// the substeps.
    pub slipped: usize,
    /// The Newton report of the last successful substep.
    pub last_newton: Option<NewtonReport>,
    /// Wall time (s) spent preparing the backward Euler solves, summed over all attempted
    /// substeps (failed ones included): rest-angle ramp, lagged mass matrices, Rayleigh
    /// damping forms, `q̂`, and the one-off sparsity pattern and symbolic factorization when
    /// the Newton solver is (re)built. Timing only; it changes nothing in the step.
    pub setup_seconds: f64,
    /// Wall time (s) spent in the Newton minimizations (assembly, line searches, sparse
    /// Cholesky factorizations and solves), summed over all attempted substeps (failed
    /// ones included).
    pub newton_seconds: f64,
    /// Conjugate-gradient iterations over all accepted Newton iterations of all substeps
    /// (0 with the sparse Cholesky solver).
    pub linear_iterations: usize,
    /// Extra Newton solves of the friction return mapping over all substeps (0 when no
    /// coordinate changed between sticking and slipping, or with the explicit update).
    pub friction_resolves: usize,
    /// Substeps whose return mapping still changed modes after
    /// [`StepSettings::friction_return_mapping`] re-solves (kept with the explicit update).
    pub friction_unresolved: usize,
}

/// Moves a lagged damping form's centre to `qn` and rescales its matrix by `rescale` (if
/// any). Returns `false` for a term that is not a damping form.
fn recentre_damping_form(term: &mut Term, qn: &[f64], rescale: Option<f64>) -> bool {
    fn apply<const N: usize>(
        form: &mut Quadratic<N>,
        d: &[usize; N],
        qn: &[f64],
        rescale: Option<f64>,
    ) {
        form.center = gather(qn, d);
        if let Some(r) = rescale {
            form.matrix *= r;
        }
    }
    match term {
        Term::Damping1(f, d) => apply(f, d, qn, rescale),
        Term::Damping2(f, d) => apply(f, d, qn, rescale),
        Term::Damping8(f, d) => apply(f, d, qn, rescale),
        Term::Damping12(f, d) => apply(f, d, qn, rescale),
        _ => return false,
    }
    true
}

/// The friction springs among `terms`, each with the index of its sliding coordinate.
fn friction_springs(terms: &mut [Term]) -> impl Iterator<Item = (&mut AnchoredSpring, usize)> {
    terms.iter_mut().filter_map(|t| match t {
        Term::Friction(spring, d) => Some((spring, d[0])),
        _ => None,
    })
}

/// The return-mapping classification of every friction spring among `terms` at `q`
/// ([`AnchoredSpring::classify`]); returns how many changed mode.
fn classify_friction(terms: &mut [Term], q: &[f64], limits: &[f64]) -> usize {
    friction_springs(terms)
        .map(|(spring, i)| usize::from(spring.classify(q[i], limits[i])))
        .sum()
}

/// Ends a step at `q` for every friction spring among `terms`
/// ([`AnchoredSpring::finish_step`]); returns how many slipped.
fn finish_friction(terms: &mut [Term], q: &[f64], limits: &[f64]) -> usize {
    friction_springs(terms)
        .map(|(spring, i)| usize::from(spring.finish_step(q[i], limits[i])))
        .sum()
}

/// A fabric under implicit Euler time stepping (see the module documentation).
pub struct Simulator {
    topology: Topology,
    dofs: DofMap,
    params: YarnParams,
    settings: StepSettings,
    potential: Potential,
    /// Terms `0..n_static` are elastic and gravity; then one inertia term per segment
    /// (`segment_dofs`), then the damping terms of the elastic terms listed in `damped`.
    n_static: usize,
    segment_dofs: Vec<[usize; 8]>,
    damped: Vec<usize>,
    /// Wrapping terms under the rest-angle ramp: (term index, layout angle ψ_L, target ψ₀).
    wrap_ramp: Vec<(usize, f64, f64)>,
    fixed: Vec<bool>,
    state: State,
    solver: Option<NewtonSolver>,
    time: f64,
    /// The Rayleigh-β damping matrices: (number of (sub)steps they were used in, the
    /// factor β/h they hold); `None` before the first step.
    damping_built: Option<(usize, f64)>,
    /// Compression estimation for the Coulomb bound of friction (`None` without friction
    /// springs or with a constant slip force).
    compression: Option<CompressionEstimator>,
}

impl Simulator {
    /// A simulator at rest in `layout`, with the force terms `forces`. Sliding coordinates the
    /// topology pins (yarn ends, one-yarn nodes) are fixed; node positions are free until
    /// [`pin_nodes`](Self::pin_nodes).
    pub fn new(
        topology: Topology,
        layout: &Layout,
        params: YarnParams,
        forces: ForceSet,
        settings: StepSettings,
    ) -> Result<Self, SimError> {
        params.validate().map_err(SimError::Invalid)?;
        settings.validate()?;
        forces
            .crossing_shear_params
            .validate()
            .map_err(SimError::Invalid)?;
        topology
            .validate()
            .map_err(|e| SimError::Invalid(e.to_string()))?;
        let slots_match = layout.sliding.len() == topology.nodes.len()
            && topology
                .nodes
                .iter()
                .zip(&layout.sliding)
                .all(|(n, s)| n.passes.len() == s.len());
        if layout.positions.len() != topology.nodes.len() || !slots_match {
            return Err(SimError::Invalid(
                "layout does not match the topology".into(),
            ));
        }
        let dofs = DofMap::new(&topology);
        let state = State::from_layout(&topology, &dofs, layout);
        let mut terms = build_terms(&topology, &dofs, &params, &forces, &state.q);
        let n_static = terms.len();
        let mut wrap_ramp = Vec::new();
        for (k, term) in terms.iter_mut().enumerate() {
            if let Term::Wrapping(wrap, d) = term {
                let x: [f64; 12] = std::array::from_fn(|i| state.q[d[i]]);
                let start = StitchWrap::angle(&x);
                wrap_ramp.push((k, start, wrap.rest_angle));
                if settings.wrapping_ramp_time > 0.0 {
                    wrap.rest_angle = start;
                }
            }
        }
        let segment_dofs: Vec<[usize; 8]> = topology
            .segments()
            .map(|(y, i)| {
                let p = &topology.yarns[y].passes;
                dofs.segment_dofs(p[i], p[i + 1])
            })
            .collect();
        terms.extend(
            segment_dofs
                .iter()
                .map(|d| Term::Inertia(Box::new(Quadratic::zero()), *d)),
        );
        let mut damped = Vec::new();
        if settings.rayleigh_beta > 0.0 {
            for k in 0..n_static {
                // Under the return mapping a slipping coordinate feels only the Coulomb
                // force: a β-damping form of its spring would brake it by β k_f u̇.
                let friction = matches!(terms[k], Term::Friction(..));
                if friction && settings.friction_return_mapping > 0 {
                    continue;
                }
                if let Some(t) = terms[k].damping_form(&state.q, 0.0) {
                    damped.push(k);
                    terms.push(t);
                }
            }
        }
        let potential = Potential::new(dofs.n_dofs(), terms).map_err(SimError::Invalid)?;
        let has_friction = potential.terms[..n_static]
            .iter()
            .any(|t| matches!(t, Term::Friction(..)));
        let compression = if has_friction && params.friction_max_force.is_none() {
            Some(
                CompressionEstimator::new(&topology, &dofs)
                    .map_err(|e| SimError::Invalid(e.to_string()))?,
            )
        } else {
            None
        };
        let mut fixed = vec![false; dofs.n_dofs()];
        for (n, node) in topology.nodes.iter().enumerate() {
            for (s, p) in node.passes.iter().enumerate() {
                if p.sliding_pinned {
                    fixed[dofs.u(n, s)] = true;
                }
            }
        }
        Ok(Self {
            topology,
            dofs,
            params,
            settings,
            potential,
            n_static,
            segment_dofs,
            damped,
            wrap_ramp,
            fixed,
            state,
            solver: None,
            time: 0.0,
            damping_built: None,
            compression,
        })
    }

    /// Adds sphere and plane obstacles: one penalty-contact term per node and obstacle
    /// ([`crate::forces::obstacle`]), counted among the elastic terms (potential energy,
    /// clamp forces, static equilibrium). Without obstacles nothing is added, so a scene
    /// without obstacles makes no obstacle queries. Obstacle terms are not Rayleigh-β
    /// damped. Errors (and adds nothing) if an obstacle is invalid.
    pub fn add_obstacles(
        &mut self,
        obstacles: &[crate::forces::obstacle::Obstacle],
    ) -> Result<(), SimError> {
        if obstacles.is_empty() {
            return Ok(());
        }
        let terms =
            crate::forces::obstacle_terms(&self.topology, &self.dofs, &self.params, obstacles)
                .map_err(SimError::Invalid)?;
        // Inserted at the end of the elastic terms: the indices of the elastic terms
        // (wrapping ramp, damped terms) stay valid; inertia and damping terms shift.
        let at = self.n_static;
        self.n_static += terms.len();
        self.potential.terms.splice(at..at, terms);
        self.solver = None; // new stencils, new pattern
        Ok(())
    }

    /// Holds the positions of `nodes` fixed (Dirichlet DOFs) from now on.
    pub fn pin_nodes(&mut self, nodes: &[usize]) -> Result<(), SimError> {
        for &n in nodes {
            if n >= self.topology.nodes.len() {
                return Err(SimError::Invalid(format!("no node {n} to pin")));
            }
            let x = self.dofs.x(n);
            for i in x..x + 3 {
                self.fixed[i] = true;
                self.state.v[i] = 0.0;
            }
        }
        self.solver = None; // the pattern depends on the fixed DOFs
        Ok(())
    }

    /// Holds the sliding coordinates of every yarn through `nodes` fixed (Dirichlet DOFs)
    /// from now on: a clamp that grips the yarns, so that no yarn slides through it. With
    /// [`pin_nodes`](Self::pin_nodes) alone the yarns stay free to slide through pinned
    /// nodes, against friction only.
    pub fn pin_sliding(&mut self, nodes: &[usize]) -> Result<(), SimError> {
        for &n in nodes {
            if n >= self.topology.nodes.len() {
                return Err(SimError::Invalid(format!("no node {n} to pin")));
            }
            for s in 0..self.topology.nodes[n].passes.len() {
                let i = self.dofs.u(n, s);
                self.fixed[i] = true;
                self.state.v[i] = 0.0;
            }
        }
        self.solver = None; // the pattern depends on the fixed DOFs
        Ok(())
    }

    /// Static equilibrium under the current pins: minimizes the potential of the elastic
    /// terms and gravity (no inertia, no damping) from the current state with
    /// [`StepSettings::newton`] (iteration limit raised to 200, always iterated to
    /// convergence with a line search), sets the velocities to zero, and then updates the
    /// friction anchors (Eq. 5) as a step would. For quasi-static loading (driven clamps).
    /// Needs pins that remove the rigid motions; time does not advance, and the wrapping rest
    /// angles are those of the ramp at the current time ([`StepSettings::wrapping_ramp_time`]).
    pub fn solve_static(&mut self) -> Result<NewtonReport, SimError> {
        self.apply_wrapping_ramp(self.time);
        // Always a full Newton solve (with line search, to convergence), even when the
        // steps are linearized; the linear solver is the steps' one.
        let settings = NewtonSettings {
            max_iterations: 200,
            line_search: true,
            accept_iteration_limit: false,
            ..self.settings.newton.clone()
        };
        let mut q = self.state.q.clone();
        let potential = Potential::new(self.dofs.n_dofs(), self.static_terms().to_vec())
            .map_err(SimError::Invalid)?;
        let report = solver::minimize(&potential, &mut q, &self.fixed, &settings)?;
        // No time lag in a static solve: the anchors are checked against the compression
        // of the equilibrium they are checked at. No return mapping either: without inertia
        // a coordinate released to slide at the constant Coulomb force has nothing that
        // bounds its travel within the solve.
        let limits = self.slip_limits(&q)?;
        finish_friction(&mut self.potential.terms[..self.n_static], &q, &limits);
        self.state.q = q;
        self.state.v.fill(0.0);
        Ok(report)
    }

    /// Moves pinned nodes by `displacement` (m) before the next step: driven clamps. Their
    /// velocity stays zero (the move is a prescribed position, not a dynamic state). Errors
    /// if a node does not exist or is not pinned.
    pub fn displace_pinned_nodes(
        &mut self,
        nodes: &[usize],
        displacement: V3,
    ) -> Result<(), SimError> {
        for &n in nodes {
            if n >= self.topology.nodes.len() || !self.fixed[self.dofs.x(n)] {
                return Err(SimError::Invalid(format!("node {n} is not a pinned node")));
            }
        }
        for &n in nodes {
            let x = self.dofs.x(n);
            for k in 0..3 {
                self.state.q[x + k] += displacement[k];
            }
        }
        Ok(())
    }

    /// The total force (N) that the yarns (elastic terms and gravity) exert on `nodes`:
    /// `−Σ ∂V/∂x` over their positions. At equilibrium, a clamp holding pinned nodes applies
    /// the opposite force.
    pub fn force_on_nodes(&self, nodes: &[usize]) -> V3 {
        let g = crate::forces::gradient(self.static_terms(), &self.state.q, self.dofs.n_dofs());
        let mut f = V3::zeros();
        for &n in nodes {
            let x = self.dofs.x(n);
            f -= V3::new(g[x], g[x + 1], g[x + 2]);
        }
        f
    }

    /// Advances the state by one step of length `dt` (module documentation). If the Newton
    /// solve of a step fails, the step is replaced by two half steps, recursively, at most
    /// [`StepSettings::max_halvings`] times ([`solver::bisect`]); the state only changes on
    /// success.
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        let mut report = StepReport {
            newton_iterations: 0,
            substeps: 0,
            slipped: 0,
            last_newton: None,
            setup_seconds: 0.0,
            newton_seconds: 0.0,
            linear_iterations: 0,
            friction_resolves: 0,
            friction_unresolved: 0,
        };
        solver::bisect(
            self.settings.dt,
            self.settings.max_halvings,
            |&h| (0.5 * h, 0.5 * h),
            |&h, _| match self.solve_step(h, &mut report) {
                Ok(()) => Ok(()),
                // A Newton solve that ran and failed: retry with two half steps.
                Err(SimError::Solve(e)) if e.report().is_some() => {
                    Err(StepError::Halve(SimError::Solve(e)))
                }
                Err(e) => Err(StepError::Abort(e)),
            },
        )
        .map_err(|e| e.source)?;
        Ok(report)
    }

    /// Progress `s ∈ [0, 1]` of the wrapping rest-angle ramp at time `t` (s): the smoothstep
    /// of the module documentation (1 without a ramp).
    pub fn wrapping_ramp_progress(&self, t: f64) -> f64 {
        let duration = self.settings.wrapping_ramp_time;
        if duration <= 0.0 {
            return 1.0;
        }
        let l = (t / duration).clamp(0.0, 1.0);
        l * l * (3.0 - 2.0 * l)
    }

    /// Sets every wrapping term's rest angle to its value on the ramp at time `t` (s).
    fn apply_wrapping_ramp(&mut self, t: f64) {
        let s = self.wrapping_ramp_progress(t);
        for &(k, start, target) in &self.wrap_ramp {
            if let Term::Wrapping(wrap, _) = &mut self.potential.terms[k] {
                wrap.rest_angle = start + s * (target - start);
            }
        }
    }

    /// One backward Euler step of length `h`; commits the state only on success.
    fn solve_step(&mut self, h: f64, report: &mut StepReport) -> Result<(), SimError> {
        let setup_start = std::time::Instant::now();
        // Lagged Coulomb bound (Eq. 5): the compression of the state at the start of the step.
        let limits = self.slip_limits(&self.state.q)?;
        self.apply_wrapping_ramp(self.time + h);
        let (alpha, beta) = (self.settings.rayleigh_alpha, self.settings.rayleigh_beta);
        let qn = self.state.q.clone();
        let v = &self.state.v;
        let rho = self.params.linear_density;
        let inertia_scale = 1.0 / (h * h) + alpha / h;
        let (elastic, rest) = self.potential.terms.split_at_mut(self.n_static);
        let (inertia, damping) = rest.split_at_mut(self.segment_dofs.len());
        // Every form below is independent of the others (each task writes only its own
        // form), so they are built in parallel; the results do not depend on the threads.
        inertia
            .par_iter_mut()
            .zip(self.segment_dofs.par_iter())
            .for_each(|(term, d)| {
                if let Term::Inertia(form, _) = term {
                    let local = gather(&qn, d);
                    let q_hat = local + h * gather(v, d); // q̂ = qₙ + h vₙ
                    form.center = (q_hat + alpha * h * local) / (1.0 + alpha * h);
                    form.matrix = inertia_scale * segment_mass_matrix(rho, &local);
                }
            });
        // Rayleigh β forms: the per-stencil eigen-projections of K⁺ are the larger part of
        // the setup, so with `damping_refresh_steps > 1` they are only recomputed every so
        // many steps; in between the lagged matrices are rescaled to the current β/h and
        // recentred at qₙ.
        let factor = beta / h;
        let refresh = self
            .damping_built
            .is_none_or(|(uses, _)| uses >= self.settings.damping_refresh_steps);
        let rescale = match self.damping_built {
            Some((_, built)) if !refresh && built != factor && built > 0.0 => Some(factor / built),
            _ => None,
        };
        let elastic: &[Term] = elastic;
        damping
            .par_iter_mut()
            .zip(self.damped.par_iter())
            .for_each(|(target, &k)| {
                if refresh || !recentre_damping_form(target, &qn, rescale) {
                    let updated = elastic[k].update_damping_form(&qn, factor, target);
                    debug_assert!(
                        updated,
                        "damping term {k} out of step with its elastic term"
                    );
                }
            });
        self.damping_built = Some(match self.damping_built {
            Some((uses, _)) if !refresh => (uses + 1, factor),
            _ => (1, factor),
        });
        if self.solver.is_none() {
            self.solver = Some(NewtonSolver::new(&self.potential, &self.fixed)?);
        }
        let solver = self.solver.as_mut().expect("built above");
        let mut q = qn.clone();
        let newton_start = std::time::Instant::now();
        report.setup_seconds += (newton_start - setup_start).as_secs_f64();
        let (max_resolves, n_static) = (self.settings.friction_return_mapping, self.n_static);
        let mut resolves = 0;
        let outcome = loop {
            let newton = match solver.minimize(&self.potential, &mut q, &self.settings.newton) {
                Ok(newton) => newton,
                Err(e) => break Err(e),
            };
            let elastic = &mut self.potential.terms[..n_static];
            if max_resolves == 0 || classify_friction(elastic, &q, &limits) == 0 {
                break Ok(newton);
            }
            if resolves == max_resolves {
                report.friction_unresolved += 1;
                break Ok(newton);
            }
            resolves += 1;
            report.newton_iterations += newton.iterations;
            report.linear_iterations += newton.linear_iterations.iter().sum::<usize>();
        };
        report.newton_seconds += newton_start.elapsed().as_secs_f64();
        report.friction_resolves += resolves;
        let newton = match outcome {
            Ok(newton) => newton,
            Err(e) => {
                // The step is retried (halved) from the start state: no slip mode stays.
                for (spring, _) in friction_springs(&mut self.potential.terms[..self.n_static]) {
                    spring.slip = None;
                }
                return Err(e.into());
            }
        };
        for (i, v) in self.state.v.iter_mut().enumerate() {
            *v = if self.fixed[i] {
                0.0
            } else {
                (q[i] - qn[i]) / h
            };
        }
        report.slipped += finish_friction(&mut self.potential.terms[..self.n_static], &q, &limits);
        self.state.q = q;
        self.time += h;
        report.substeps += 1;
        report.newton_iterations += newton.iterations;
        report.linear_iterations += newton.linear_iterations.iter().sum::<usize>();
        report.last_newton = Some(newton);
        Ok(())
    }

    /// Slip force (N) of every DOF for the friction anchors (Eq. 5): the constant
    /// [`YarnParams::friction_max_force`] if set, else `μ λ` from the compression estimate at
    /// `q` ([`crate::forces::compression`]).
    fn slip_limits(&self, q: &[f64]) -> Result<Vec<f64>, SimError> {
        if let Some(f) = self.params.friction_max_force {
            return Ok(vec![f; self.dofs.n_dofs()]);
        }
        let Some(estimator) = &self.compression else {
            return Ok(vec![0.0; self.dofs.n_dofs()]);
        };
        let c = &self.params.compression;
        let estimates = estimator
            .estimate(self.static_terms(), q, &self.dofs, self.params.radius, c)
            .map_err(|e| SimError::Invalid(e.to_string()))?;
        Ok(slip_forces(
            &estimates,
            &self.dofs,
            self.params.friction_coefficient,
            c.solver,
        ))
    }

    /// The compression (Eqs. 3–4, both solvers) at every stacked node at the current state,
    /// with the current force terms. Errors if the topology has no compression rule (see
    /// [`CompressionEstimator::new`]) or the estimate fails.
    pub fn compression(&self) -> Result<Vec<NodeCompression>, SimError> {
        let built;
        let estimator = match &self.compression {
            Some(e) => e,
            None => {
                built = CompressionEstimator::new(&self.topology, &self.dofs)
                    .map_err(|e| SimError::Invalid(e.to_string()))?;
                &built
            }
        };
        estimator
            .estimate(
                self.static_terms(),
                &self.state.q,
                &self.dofs,
                self.params.radius,
                &self.params.compression,
            )
            .map_err(|e| SimError::Invalid(e.to_string()))
    }

    /// Kinetic energy `½ q̇ᵀ M(q) q̇` (J).
    pub fn kinetic_energy(&self) -> f64 {
        kinetic_energy(
            &self.topology,
            &self.dofs,
            self.params.linear_density,
            &self.state,
        )
    }

    /// Potential energy (J): elastic terms and gravity at the current state.
    pub fn potential_energy(&self) -> f64 {
        self.potential.terms[..self.n_static]
            .iter()
            .map(|t| t.energy(&self.state.q))
            .sum()
    }

    /// Energy (J) of each kind of elastic and gravity term at the current state (the per-term
    /// energy shares of the rib-stretch figure).
    pub fn energy_by_kind(&self) -> Vec<(TermKind, f64)> {
        crate::forces::energy_by_kind(self.static_terms(), &self.state.q)
    }

    /// The potential of the backward Euler step: the elastic and gravity terms followed by
    /// the inertia and damping terms of the last (sub)step (for inspection and timing of
    /// the assembly, e.g. with [`solver::Assembler`]).
    pub fn step_potential(&self) -> &Potential {
        &self.potential
    }

    /// The elastic and gravity terms (without the per-step inertia and damping).
    pub fn static_terms(&self) -> &[Term] {
        &self.potential.terms[..self.n_static]
    }

    /// The current state.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// Replaces the state (same DOF count required), e.g. to start with a velocity.
    pub fn set_state(&mut self, state: State) -> Result<(), SimError> {
        if state.q.len() != self.dofs.n_dofs() || state.v.len() != self.dofs.n_dofs() {
            return Err(SimError::Invalid(
                "state has the wrong number of DOFs".into(),
            ));
        }
        self.state = state;
        Ok(())
    }

    /// The topology.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// The DOF layout.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Which DOFs are held fixed.
    pub fn fixed(&self) -> &[bool] {
        &self.fixed
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The step settings.
    pub fn settings(&self) -> &StepSettings {
        &self.settings
    }

    /// Replaces the step settings from the next step on (e.g. a pull at another time step
    /// from a state settled at a reference one). The Rayleigh-β damping forms are rebuilt
    /// at the next step; a changed [`StepSettings::wrapping_ramp_time`] moves the wrapping
    /// rest angles to the new ramp's values at the current time (a jump if the ramp is
    /// still running). Errors (and changes nothing) if the settings are invalid, switch
    /// Rayleigh-β damping on or off, or, with β > 0, switch the friction return mapping on
    /// or off (the friction springs are β-damped only without it).
    pub fn set_settings(&mut self, settings: StepSettings) -> Result<(), SimError> {
        settings.validate()?;
        if settings.rayleigh_beta > 0.0
            && (settings.friction_return_mapping > 0) != (self.settings.friction_return_mapping > 0)
        {
            return Err(SimError::Invalid(
                "with Rayleigh β damping the friction return mapping cannot be switched on or \
                 off after construction (friction springs are β-damped only without it)"
                    .into(),
            ));
        }
        if (settings.rayleigh_beta > 0.0) != (self.settings.rayleigh_beta > 0.0) {
            // The Rayleigh-β damping terms exist only if β > 0 at construction.
            return Err(SimError::Invalid(
                "Rayleigh β damping cannot be switched on or off after construction".into(),
            ));
        }
        self.settings = settings;
        self.damping_built = None;
        Ok(())
    }
}

impl Clone for Simulator {
    /// An independent copy of the simulator in its current state (the Newton solver's
    /// cached sparsity pattern and factorization are rebuilt at the copy's first step).
    fn clone(&self) -> Self {
        Self {
            topology: self.topology.clone(),
            dofs: self.dofs.clone(),
            params: self.params,
            settings: self.settings.clone(),
            potential: self.potential.clone(),
            n_static: self.n_static,
            segment_dofs: self.segment_dofs.clone(),
            damped: self.damped.clone(),
            wrap_ramp: self.wrap_ramp.clone(),
            fixed: self.fixed.clone(),
            state: self.state.clone(),
            solver: None,
            time: self.time,
            damping_built: self.damping_built,
            compression: self.compression.clone(),
        }
    }
}
