//! Newton minimization with a backtracking line search and Dirichlet DOFs.
//!
//! Each iteration (Nocedal & Wright 2006, §3.1 and §3.4) assembles the energy `E`, gradient
//! `g` and (optionally SPD-projected) Hessian `H` at the current `x`, solves
//!
//! ```text
//! (H_ff + μ I) Δx_f = −g_f
//! ```
//!
//! on the free DOFs `f` (the Dirichlet DOFs keep their values, so their rows and columns are
//! simply left out of the system: `Δx` is zero there and no right-hand-side correction is
//! needed), and takes the step `x ← x + α Δx` with the largest `α = β^j` (`j = 0, 1, …`)
//! satisfying the Armijo condition
//!
//! ```text
//! E(x + α Δx) ≤ E(x) + c α gᵀΔx + ε_E,       ε_E = energy_noise_tolerance · Σ_k |E_k(x)|.
//! ```
//!
//! The search starts at `α = min(1, α_max)` with `α_max` from [`Problem::max_step`] (a
//! problem-defined admissibility filter, e.g. continuous collision detection; `+∞` by default).
//!
//! `ε_E` is a rounding allowance in the spirit of the "approximate Wolfe" condition of Hager &
//! Zhang (2006, *ACM TOMS* 32(1)): close to the minimum, true energy decreases fall below the
//! rounding error of the summed energy, and a strict test would reject good Newton steps.
//!
//! **Regularization.** Every iteration first tries `μ = 0` (except the first iteration of a
//! run that starts at a carried shift, below). If the sparse Cholesky
//! factorization fails (the Hessian is not positive definite: no projection, or a
//! PSD-but-singular projected Hessian), the solve is non-finite, or the line search fails, the
//! iteration is retried with `μ = b, b γ, b γ², …`, up to `max_regularization_attempts` times;
//! then the solve returns an error. Here `b = max(μ₀ s, μ_prev / γ)`, `s = max_i |H_ii|`,
//! `μ₀ = regularization_initial`, `γ = regularization_growth`, and `μ_prev` is the shift the
//! previous iteration ended with, so that a run through an indefinite region does not repeat
//! the whole escalation every iteration (as in IPOPT's inertia correction, Wächter & Biegler
//! 2006, §3.1). With [`NewtonSettings::warm_start_regularization`], a [`NewtonSolver`] also
//! carries `μ_prev` from the end of one [`NewtonSolver::minimize`] to the first iteration of
//! the next (the next time step of a simulation through the same indefinite region), instead
//! of escalating from `μ₀ s` again; `μ = 0` is still tried first, unless
//! [`NewtonSettings::carried_shift_probe_interval`] is set: then a run that carries a shift
//! starts at that shift itself, and only every `n`-th run (every `n`-th
//! [`NewtonSolver::minimize`] call, failed ones included) probes from `μ = 0`. The accepted
//! shift then matches a cold start's up to the scale `s` of the new Hessian whenever the needed shift
//! has not fallen by more than `γ` since the last run; where it has, the warm run takes a
//! more strongly shifted (shorter) step. Shifting the diagonal is the textbook "Hessian modification" (Nocedal & Wright
//! Alg. 3.3).
//!
//! **Saddle escape.** When the full step is accepted but the unshifted model curves down along
//! it (`ΔxᵀHΔx < 0`: the iterate is near a saddle of a nonconvex energy, e.g. jammed yarn
//! contacts with exact Hessians), the step is doubled while the energy keeps decreasing (within
//! `α_max`, at most 2¹⁰). A shifted step moves only about `g/μ` there, so without this the
//! escape takes hundreds of iterations. With SPD-projected Hessians `ΔxᵀHΔx ≥ 0` and nothing
//! changes.
//!
//! **Convergence** is declared when the ∞-norm of the gradient on the free DOFs satisfies
//! `‖g_f‖∞ ≤ max(gradient_abs_tol, gradient_rel_tol · ‖g_f(x₀)‖∞)`, or when an unregularized
//! Newton step satisfies `‖Δx‖∞ ≤ step_tol`. Everything else (iteration limit, line-search
//! failure, non-finite values, factorization failure) is an `Err` that carries the report.
//!
//! **Stall.** Where no step can make progress — the line search accepts only steps at the
//! rounding level of the energy, for example `α = β^max_backtracks` against jammed contacts,
//! or full steps at a residual that rounding keeps above the tolerance — the iterate no
//! longer changes measurably and the run would spend every remaining iteration (each with its
//! full line search) before failing. With [`NewtonSettings::stall_iterations`] `= n > 0` it
//! fails at once with [`SolveError::Stalled`] when, over the last `n` iterations, the residual
//! fell by less than half and the energy by no more than `ε_E`. A run that would have climbed
//! out of a flat stretch longer than `n` iterations (slowly growing steps behind a large
//! shift look the same from inside the window) fails instead, so `n` should exceed the
//! longest flat stretch of the runs that converge; `sim_periodic::periodic::STALL_ITERATIONS`
//! records how it was measured for the periodic solves.
//!
//! **Linear solver** ([`NewtonSettings::linear_solver`]). The default is the sparse
//! Cholesky factorization above; [`LinearSolver::ConjugateGradient`] instead solves the same
//! shifted system with Jacobi-preconditioned conjugate gradients ([`crate::pcg`]) to a
//! relative residual tolerance. A CG solve that meets a non-positive curvature is treated like
//! a failed factorization (the shift escalates); one that reaches its iteration cap is a hard
//! [`Termination::FactorizationFailed`] whose detail names the CG residual. The CG iteration
//! count of each accepted step is reported in [`NewtonReport::linear_iterations`]. The CG back
//! end keeps the last few directions of negative curvature its failed solves stopped at and
//! rejects, without a solve, every shift `μ` for which one of them has `vᵀ(H + μI)v ≤ 0` on
//! the current Hessian (`H + μI` is then provably indefinite): the escalation goes on as
//! after a failed solve, to the same accepted shift, and the skipped attempts are counted in
//! [`NewtonReport::shifts_skipped`]. With [`crate::PcgSettings::warm_start`] each CG solve
//! starts from the last successful solve's solution (meant for fixed-iteration runs such as
//! linearized time steps, whose consecutive solutions are close; a warm-started solution
//! need not be a descent direction).
//!
//! **Fixed-iteration mode.** With `line_search = false` every step is taken at full length
//! `α = min(1, α_max)` without the Armijo test, and with `accept_iteration_limit = true`
//! reaching `max_iterations` ends the run successfully with
//! [`Termination::IterationLimit`] (not converged; the residual at the final iterate is
//! still computed and reported, unless [`NewtonSettings::final_residual`] is `false`).
//! `max_iterations = 1` with both gives one linearized Newton step, e.g. the linearized
//! implicit Euler of Baraff & Witkin (1998).
//!
//! The symbolic factorization is computed once per [`NewtonSolver`] (on the first Cholesky
//! solve); all numeric work other than the stencil evaluations and the conjugate gradients
//! runs sequentially, and the conjugate gradients sum in fixed chunks, so results do not
//! depend on the thread count.

use crate::SolveError;
use crate::assembly::{Assembler, Problem, check_len};
use crate::pcg::PcgSettings;

mod driver;
mod free_dofs;

pub(crate) use driver::{InitialShift, NewtonSystem, SystemFailure, inf_norm, run_newton};
use free_dofs::FreeDofSystem;

/// How the Newton system `(H_ff + μ I) Δx_f = −g_f` is solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LinearSolver {
    /// Sparse Cholesky `L Lᵀ` with AMD ordering (faer, supernodal); the symbolic analysis is
    /// computed once per solver and reused. Exact up to rounding.
    Cholesky,
    /// Jacobi-preconditioned conjugate gradients ([`crate::pcg`]) to the given relative
    /// residual tolerance and iteration cap. Unconstrained solves only.
    ConjugateGradient(PcgSettings),
}

/// Parameters of [`minimize`] and [`crate::minimize_constrained`]. `Default` gives the values
/// documented on each field.
#[derive(Clone, Debug, PartialEq)]
pub struct NewtonSettings {
    /// Maximum number of Newton steps. Default `100`.
    pub max_iterations: usize,
    /// Absolute tolerance on the ∞-norm of the free-DOF gradient (for constrained problems,
    /// of the Lagrangian gradient `g + Cᵀλ`), in energy units per DOF unit (N for positions in
    /// m). Default `1e-10`.
    pub gradient_abs_tol: f64,
    /// Tolerance on the same norm relative to its value at the initial iterate. Default `1e-10`.
    pub gradient_rel_tol: f64,
    /// Convergence is also declared when an unregularized Newton step has
    /// `‖Δx‖∞ ≤ step_tol` (DOF units, m for positions); `0` disables the test. Default `1e-14`.
    pub step_tol: f64,
    /// Armijo sufficient-decrease constant `c ∈ (0, 1)`. Default `1e-4`.
    pub armijo: f64,
    /// Backtracking factor `β ∈ (0, 1)`. Default `0.5`.
    pub backtrack_factor: f64,
    /// Maximum number of step halvings (reductions by `β`) per line search. Default `40`.
    pub max_backtracks: usize,
    /// Relative rounding allowance `ε_E / Σ_k |E_k|` in the Armijo test (see the module
    /// documentation); `0` gives the strict test. Default `1e-12`.
    pub energy_noise_tolerance: f64,
    /// Project every local Hessian onto the PSD cone before assembly. Default `true`.
    pub project_spd: bool,
    /// First diagonal shift, relative to `max_i |H_ii|` (see module docs). Default `1e-8`.
    pub regularization_initial: f64,
    /// Growth factor `γ > 1` of the shift between attempts. Default `10`.
    pub regularization_growth: f64,
    /// Number of regularized retries per iteration before giving up. Default `14` (largest
    /// shift `1e5 · max_i |H_ii|` with the defaults above).
    pub max_regularization_attempts: usize,
    /// Constrained solves only: the iterate is feasible when
    /// `‖Cx − d‖∞ ≤ constraint_tol · (‖C‖∞ ‖x‖∞ + ‖d‖∞)` (a rounding-level test in the units
    /// of `d`), and convergence requires feasibility. Default `1e-12`.
    pub constraint_tol: f64,
    /// Linear solver of the Newton system. Default [`LinearSolver::Cholesky`].
    pub linear_solver: LinearSolver,
    /// [`NewtonSolver`] only: start the regularization of a run from the shift the previous
    /// run of the same solver ended with (module documentation). Default `false`.
    pub warm_start_regularization: bool,
    /// With [`NewtonSettings::warm_start_regularization`]: a run that carries a shift starts
    /// its first iteration at that shift itself, without the unshifted attempt and the one a
    /// factor below, except every `n`-th run of the solver (`n` this interval; runs are
    /// [`NewtonSolver::minimize`] calls, failed ones and retries included), which probes
    /// from `μ = 0` as usual so that the shift can fall. Where a simulation needs the same
    /// shift step after step, this saves the two failing solves of every step, and the steps
    /// are identical to [`NewtonSettings::warm_start_regularization`]'s alone; where a
    /// smaller shift would do, the steps between probes take the larger one (shorter, more
    /// strongly damped steps). `0` (the default): every run probes.
    pub carried_shift_probe_interval: usize,
    /// Backtracking line search (Armijo). With `false`, every step is taken at
    /// `α = min(1, α_max)` without evaluating the energy along it. Default `true`.
    pub line_search: bool,
    /// When `true`, reaching `max_iterations` without convergence ends the run with `Ok`
    /// and [`Termination::IterationLimit`] instead of an error. Default `false`.
    pub accept_iteration_limit: bool,
    /// With [`NewtonSettings::accept_iteration_limit`]: evaluate the gradient at the iterate
    /// the limit stops at, to report its residual (the last entry of
    /// [`NewtonReport::residual_history`], e.g. a linearized time step's linearization error)
    /// and to check that it is finite. Default `true`. With `false` the run ends at the
    /// limit without that evaluation, one gradient evaluation fewer per run: the iterate is
    /// the same bit for bit, the residual and energy histories end before the last step, and
    /// the final iterate's finiteness rests on the line search's energy test (so `false`
    /// needs [`NewtonSettings::line_search`]). A run limited to no step still evaluates its
    /// start.
    pub final_residual: bool,
    /// Stop a stalled run early (module documentation): with `n > 0`, the run fails with
    /// [`SolveError::Stalled`] once the last `n` iterations lowered neither the residual by
    /// half nor the energy by more than its rounding allowance `ε_E`. `0` (the default): runs
    /// stop at convergence, a failure or `max_iterations` only.
    pub stall_iterations: usize,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            gradient_abs_tol: 1e-10,
            gradient_rel_tol: 1e-10,
            step_tol: 1e-14,
            armijo: 1e-4,
            backtrack_factor: 0.5,
            max_backtracks: 40,
            energy_noise_tolerance: 1e-12,
            project_spd: true,
            regularization_initial: 1e-8,
            regularization_growth: 10.0,
            max_regularization_attempts: 14,
            constraint_tol: 1e-12,
            linear_solver: LinearSolver::Cholesky,
            warm_start_regularization: false,
            carried_shift_probe_interval: 0,
            line_search: true,
            accept_iteration_limit: false,
            final_residual: true,
            stall_iterations: 0,
        }
    }
}

impl NewtonSettings {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), SolveError> {
        let bad = |msg: &str| Err(SolveError::InvalidSettings(msg.to_owned()));
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !nonneg(self.gradient_abs_tol) || !nonneg(self.gradient_rel_tol) {
            return bad("gradient tolerances must be finite and ≥ 0");
        }
        if !nonneg(self.step_tol) || !nonneg(self.energy_noise_tolerance) {
            return bad("step_tol and energy_noise_tolerance must be finite and ≥ 0");
        }
        if !(self.armijo > 0.0 && self.armijo < 1.0) {
            return bad("armijo must lie in (0, 1)");
        }
        if !(self.backtrack_factor > 0.0 && self.backtrack_factor < 1.0) {
            return bad("backtrack_factor must lie in (0, 1)");
        }
        if !(self.regularization_initial > 0.0 && self.regularization_initial.is_finite()) {
            return bad("regularization_initial must be finite and > 0");
        }
        if !(self.regularization_growth > 1.0 && self.regularization_growth.is_finite()) {
            return bad("regularization_growth must be finite and > 1");
        }
        if !nonneg(self.constraint_tol) {
            return bad("constraint_tol must be finite and ≥ 0");
        }
        if let LinearSolver::ConjugateGradient(pcg) = &self.linear_solver {
            pcg.validate()?;
        }
        if !self.final_residual && !self.line_search {
            return bad(
                "final_residual = false needs the line search (its energy test is then the only \
                 check that the final iterate is finite)",
            );
        }
        if self.carried_shift_probe_interval > 0 && !self.warm_start_regularization {
            return bad("carried_shift_probe_interval needs warm_start_regularization");
        }
        Ok(())
    }
}

/// Why a Newton run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// Converged: the gradient test passed.
    GradientTolerance,
    /// Converged: an unregularized Newton step was below `step_tol`.
    StepTolerance,
    /// Failed: `max_iterations` steps taken without convergence.
    MaxIterations,
    /// Failed: no step length satisfied the Armijo condition at any regularization.
    LineSearchFailed,
    /// Failed: non-finite energy, gradient or Hessian.
    NonFinite,
    /// Failed: the Newton system could not be factorized or solved at any regularization,
    /// or the conjugate gradients did not reach their tolerance.
    FactorizationFailed,
    /// Stopped after `max_iterations` steps without convergence, accepted because
    /// [`NewtonSettings::accept_iteration_limit`] is set (not converged, but not an error).
    IterationLimit,
    /// Failed: [`NewtonSettings::stall_iterations`] iterations without progress.
    Stalled,
}

impl Termination {
    /// Whether this is a successful termination.
    pub fn is_converged(self) -> bool {
        matches!(self, Self::GradientTolerance | Self::StepTolerance)
    }
}

/// History of a Newton run. Returned on success and attached to every solver error.
///
/// Index `i` of the `*_history` vectors refers to iterate `x_i` (`x_0` is the input, after
/// feasibility restoration for constrained solves); the per-step vectors have one entry per
/// accepted step.
#[derive(Clone, Debug, PartialEq)]
pub struct NewtonReport {
    /// Number of accepted Newton steps.
    pub iterations: usize,
    /// Energy at each iterate.
    pub energy_history: Vec<f64>,
    /// Stationarity residual at each iterate: `‖g_f‖∞` (unconstrained) or `‖g + Cᵀλ‖∞`
    /// (constrained). May be one shorter than `energy_history` if the last solve failed.
    pub residual_history: Vec<f64>,
    /// Constrained solves: `‖Cx − d‖∞` at each iterate; empty for unconstrained solves.
    pub constraint_violation_history: Vec<f64>,
    /// Constrained solves: `‖Cx₀ − d‖∞` of the input, before feasibility restoration.
    pub initial_constraint_violation: f64,
    /// Accepted step length `α` of each step.
    pub step_lengths: Vec<f64>,
    /// Diagonal shift `μ` used for each step (0 when the plain Newton system worked).
    pub regularizations: Vec<f64>,
    /// Total number of rejected trial steps over all line searches.
    pub line_search_backtracks: usize,
    /// Linear solves of the Newton system attempted, the failed regularization attempts
    /// included (a run that never needs a shift has one per iteration); shifts rejected
    /// without a solve are counted in `shifts_skipped` instead.
    pub linear_solves: usize,
    /// Diagonal shifts rejected without a solve because a direction of negative curvature
    /// found by an earlier CG solve proves `H + μI` indefinite (not in `linear_solves`; see
    /// the CG back end's known unstable directions).
    pub shifts_skipped: usize,
    /// Conjugate-gradient iterations of each accepted step's linear solve (0 for Cholesky).
    pub linear_iterations: Vec<usize>,
    /// Where the run's wall time went (diagnostics only; not deterministic).
    pub timings: NewtonTimings,
    /// Why the run stopped.
    pub termination: Termination,
}

impl NewtonReport {
    /// Whether the run converged.
    pub fn converged(&self) -> bool {
        self.termination.is_converged()
    }

    /// The last recorded residual (`NaN` if none).
    pub fn last_residual(&self) -> f64 {
        self.residual_history.last().copied().unwrap_or(f64::NAN)
    }

    /// The last recorded energy (`NaN` if none).
    pub fn last_energy(&self) -> f64 {
        self.energy_history.last().copied().unwrap_or(f64::NAN)
    }
}

/// Wall time (s) of the phases of a Newton run, summed over all iterations and attempts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NewtonTimings {
    /// Energy, gradient and Hessian assembly at the iterates (stencil evaluation and scatter).
    pub assembly: f64,
    /// Linear solves: numeric factorizations and triangular solves, or conjugate gradients
    /// (the first Cholesky solve of a solver includes no symbolic analysis: that is built
    /// before the run).
    pub linear_solve: f64,
    /// Line searches (energy evaluations at trial points) and step-bound queries.
    pub line_search: f64,
}
/// A reusable Newton minimizer for one problem structure and one set of Dirichlet DOFs.
///
/// Building it computes the sparsity pattern once; the symbolic Cholesky factorization (or
/// the conjugate-gradient workspace) is built on the first [`minimize`](Self::minimize) that
/// needs it. [`minimize`](Self::minimize) can be called many times (e.g. once per time step)
/// on problems with the same stencils.
pub struct NewtonSolver {
    assembler: Assembler,
    system: FreeDofSystem,
    /// The shift the last run ended with ([`NewtonSettings::warm_start_regularization`]).
    last_shift: f64,
    /// Runs so far ([`NewtonSettings::carried_shift_probe_interval`]).
    runs: usize,
}

impl NewtonSolver {
    /// Prepares a solver for `problem` with Dirichlet DOFs `fixed` (`fixed.len() == n_dofs`;
    /// pass all `false` for none).
    pub fn new<P: Problem + ?Sized>(problem: &P, fixed: &[bool]) -> Result<Self, SolveError> {
        let assembler = Assembler::with_fixed_dofs(problem, fixed)?;
        let system = FreeDofSystem::new(&assembler);
        Ok(Self {
            assembler,
            system,
            last_shift: 0.0,
            runs: 0,
        })
    }

    /// Minimizes the problem's energy over the free DOFs, starting from and overwriting `x`;
    /// the fixed DOFs keep their values in `x`. See the [module documentation](self).
    pub fn minimize<P: Problem + ?Sized>(
        &mut self,
        problem: &P,
        x: &mut [f64],
        settings: &NewtonSettings,
    ) -> Result<NewtonReport, SolveError> {
        settings.validate()?;
        check_len("x", self.assembler.n_dofs(), x.len())?;
        self.system
            .prepare(&self.assembler, settings.linear_solver)?;
        let start = if settings.warm_start_regularization {
            self.last_shift
        } else {
            0.0
        };
        let interval = settings.carried_shift_probe_interval;
        // `validate` ensures the warm start whenever the interval is set.
        let at_carried = interval > 0 && !self.runs.is_multiple_of(interval);
        self.runs += 1;
        let result = run_newton(
            problem,
            x,
            settings,
            &mut self.assembler,
            &mut self.system,
            0.0,
            InitialShift {
                value: start,
                start_at_value: at_carried,
            },
        );
        if let Ok(report) = &result {
            self.last_shift = report.regularizations.last().copied().unwrap_or(start);
        }
        result
    }

    /// The assembler (pattern, last gradient and Hessian).
    pub fn assembler(&self) -> &Assembler {
        &self.assembler
    }
}

/// Minimizes `problem`'s energy starting from `x` (overwritten with the minimizer), holding the
/// DOFs with `fixed[dof] == true` at their current values. One-shot convenience for
/// [`NewtonSolver::new`] followed by [`NewtonSolver::minimize`].
pub fn minimize<P: Problem + ?Sized>(
    problem: &P,
    x: &mut [f64],
    fixed: &[bool],
    settings: &NewtonSettings,
) -> Result<NewtonReport, SolveError> {
    NewtonSolver::new(problem, fixed)?.minimize(problem, x, settings)
}
