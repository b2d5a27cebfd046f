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
//! **Regularization.** Every iteration first tries `μ = 0`. If the sparse Cholesky
//! factorization fails (the Hessian is not positive definite: no projection, or a
//! PSD-but-singular projected Hessian), the solve is non-finite, or the line search fails, the
//! iteration is retried with `μ = b, b γ, b γ², …`, up to `max_regularization_attempts` times;
//! then the solve returns an error. Here `b = max(μ₀ s, μ_prev / γ)`, `s = max_i |H_ii|`,
//! `μ₀ = regularization_initial`, `γ = regularization_growth`, and `μ_prev` is the shift the
//! previous iteration ended with, so that a run through an indefinite region does not repeat
//! the whole escalation every iteration (as in IPOPT's inertia correction, Wächter & Biegler
//! 2006, §3.1). Shifting the diagonal is the textbook "Hessian modification" (Nocedal & Wright
//! Alg. 3.3).
//!
//! **Convergence** is declared when the ∞-norm of the gradient on the free DOFs satisfies
//! `‖g_f‖∞ ≤ max(gradient_abs_tol, gradient_rel_tol · ‖g_f(x₀)‖∞)`, or when an unregularized
//! Newton step satisfies `‖Δx‖∞ ≤ step_tol`. Everything else (iteration limit, line-search
//! failure, non-finite values, factorization failure) is an `Err` that carries the report.
//!
//! **Linear solver** ([`NewtonSettings::linear_solver`]). The default is the sparse
//! Cholesky factorization above; [`LinearSolver::ConjugateGradient`] instead solves the same
//! shifted system with Jacobi-preconditioned conjugate gradients ([`crate::pcg`]) to a
//! relative residual tolerance. A CG solve that meets a non-positive curvature is treated like
//! a failed factorization (the shift escalates); one that reaches its iteration cap is a hard
//! [`Termination::FactorizationFailed`] whose detail names the CG residual. The CG iteration
//! count of each accepted step is reported in [`NewtonReport::linear_iterations`].
//!
//! **Fixed-iteration mode.** With `line_search = false` every step is taken at full length
//! `α = min(1, α_max)` without the Armijo test, and with `accept_iteration_limit = true`
//! reaching `max_iterations` ends the run successfully with
//! [`Termination::IterationLimit`] (not converged; the residual at the final iterate is
//! still computed and reported). `max_iterations = 1` with both gives one linearized Newton
//! step, e.g. the linearized implicit Euler of Baraff & Witkin (1998).
//!
//! The symbolic factorization is computed once per [`NewtonSolver`] (on the first Cholesky
//! solve); all numeric work other than the stencil evaluations and the conjugate gradients
//! runs sequentially, and the conjugate gradients sum in fixed chunks, so results do not
//! depend on the thread count.

use crate::SolveError;
use crate::assembly::{Assembler, Problem, check_len};
use crate::linalg::SparseLlt;
use crate::pcg::{Pcg, PcgFailure, PcgSettings};

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
    /// Backtracking line search (Armijo). With `false`, every step is taken at
    /// `α = min(1, α_max)` without evaluating the energy along it. Default `true`.
    pub line_search: bool,
    /// When `true`, reaching `max_iterations` without convergence ends the run with `Ok`
    /// and [`Termination::IterationLimit`] instead of an error. Default `false`.
    pub accept_iteration_limit: bool,
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
            line_search: true,
            accept_iteration_limit: false,
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

/// What the Newton driver needs from a linear-algebra back end (plain Cholesky on the free DOFs,
/// or the constrained KKT system).
pub(crate) trait NewtonSystem {
    /// The stationarity residual, if it can be computed without solving (unconstrained case).
    fn residual_before_solve(&self, gradient: &[f64]) -> Option<f64>;

    /// Factorizes the system for the assembler's current Hessian with diagonal shift `mu` and
    /// writes the Newton step into `dx` (length `n_dofs`). Returns the stationarity residual,
    /// or a description of the failure.
    fn solve(
        &mut self,
        asm: &mut Assembler,
        x: &[f64],
        mu: f64,
        dx: &mut [f64],
    ) -> Result<f64, SystemFailure>;

    /// `Some(feasible, ‖Cx − d‖∞)` for constrained systems.
    fn violation(&self, x: &[f64], settings: &NewtonSettings) -> Option<(bool, f64)>;

    /// Iterations of the last successful linear solve (0 for direct solvers).
    fn last_linear_iterations(&self) -> usize {
        0
    }

    /// Whether [`NewtonSystem::residual_before_solve`] gives the residual (then the final
    /// iterate of a run stopped by the iteration limit needs no Hessian).
    fn residual_without_solve(&self) -> bool {
        false
    }
}

/// Why a linear solve of the Newton system failed.
pub(crate) enum SystemFailure {
    /// Worth retrying with a larger diagonal shift (failed factorization, indefiniteness).
    Retry(String),
    /// Not worth retrying (the conjugate gradients ran out of iterations): fail the run.
    Fatal(String),
}

impl From<String> for SystemFailure {
    fn from(msg: String) -> Self {
        Self::Retry(msg)
    }
}

impl From<&str> for SystemFailure {
    fn from(msg: &str) -> Self {
        Self::Retry(msg.to_owned())
    }
}

/// Outcome of one line search.
enum LineSearch {
    Accepted { alpha: f64, backtracks: usize },
    Failed { backtracks: usize },
}

/// The Newton loop shared by [`NewtonSolver`] and [`crate::ConstrainedNewtonSolver`].
pub(crate) fn run_newton<P: Problem + ?Sized, S: NewtonSystem>(
    problem: &P,
    x: &mut [f64],
    settings: &NewtonSettings,
    asm: &mut Assembler,
    system: &mut S,
    initial_constraint_violation: f64,
) -> Result<NewtonReport, SolveError> {
    let n = x.len();
    let mut dx = vec![0.0; n];
    let mut x_trial = vec![0.0; n];
    let mut report = NewtonReport {
        iterations: 0,
        energy_history: Vec::new(),
        residual_history: Vec::new(),
        constraint_violation_history: Vec::new(),
        initial_constraint_violation,
        step_lengths: Vec::new(),
        regularizations: Vec::new(),
        line_search_backtracks: 0,
        linear_iterations: Vec::new(),
        timings: NewtonTimings::default(),
        termination: Termination::MaxIterations,
    };
    let mut residual0 = None;
    // Shift that worked in the previous iteration; the next escalation starts near it.
    let mut last_mu: f64 = 0.0;
    let finish = |mut report: NewtonReport, termination: Termination, detail: String| {
        report.termination = termination;
        let report = Box::new(report);
        match termination {
            Termination::GradientTolerance
            | Termination::StepTolerance
            | Termination::IterationLimit => Ok(*report),
            Termination::MaxIterations => Err(SolveError::NotConverged(report)),
            Termination::LineSearchFailed => Err(SolveError::LineSearchFailed(report)),
            Termination::NonFinite => Err(SolveError::NonFinite(report)),
            Termination::FactorizationFailed => {
                Err(SolveError::FactorizationFailed { report, detail })
            }
        }
    };

    let limit = if settings.accept_iteration_limit {
        Termination::IterationLimit
    } else {
        Termination::MaxIterations
    };
    loop {
        // At the iteration limit the residual is all that is left to compute: skip the
        // Hessian when the system can give the residual without a solve.
        let last = report.iterations >= settings.max_iterations && system.residual_without_solve();
        let assembly_start = std::time::Instant::now();
        let (energy, finite) = if last {
            let (energy, gradient) = asm.gradient(problem, x)?;
            (
                energy,
                energy.is_finite() && gradient.iter().all(|g| g.is_finite()),
            )
        } else {
            let assembled = asm.assemble(problem, x, settings.project_spd)?;
            let energy = assembled.energy;
            let finite = energy.is_finite()
                && assembled.gradient.iter().all(|g| g.is_finite())
                && assembled.hessian.val().iter().all(|h| h.is_finite());
            (energy, finite)
        };
        report.timings.assembly += assembly_start.elapsed().as_secs_f64();
        let noise = settings.energy_noise_tolerance * asm.energy_abs_sum();
        report.energy_history.push(energy);
        let violation = system.violation(x, settings);
        let feasible = violation.is_none_or(|(ok, _)| ok);
        if let Some((_, v)) = violation {
            report.constraint_violation_history.push(v);
        }
        if !finite {
            return finish(report, Termination::NonFinite, String::new());
        }
        let converged = |r: f64, r0: f64| {
            feasible
                && r <= settings
                    .gradient_abs_tol
                    .max(settings.gradient_rel_tol * r0)
        };

        let residual_pre = system.residual_before_solve(asm.last_gradient());
        if let Some(r) = residual_pre {
            report.residual_history.push(r);
            let r0 = *residual0.get_or_insert(r);
            if converged(r, r0) {
                return finish(report, Termination::GradientTolerance, String::new());
            }
            if report.iterations >= settings.max_iterations {
                return finish(report, limit, String::new());
            }
        }

        // Solve and line-search, escalating the diagonal shift on failure.
        let scale = diagonal_scale(asm);
        let base =
            (settings.regularization_initial * scale).max(last_mu / settings.regularization_growth);
        let mut failure = (
            Termination::FactorizationFailed,
            String::from("no attempt made"),
        );
        let mut residual_checked = residual_pre.is_some();
        let mut accepted = None;
        for attempt in 0..=settings.max_regularization_attempts {
            let mu = match attempt {
                0 => 0.0,
                k => base * settings.regularization_growth.powi(k as i32 - 1),
            };
            let solve_start = std::time::Instant::now();
            let solved = system.solve(asm, x, mu, &mut dx);
            report.timings.linear_solve += solve_start.elapsed().as_secs_f64();
            let residual = match solved {
                Ok(r) => r,
                Err(SystemFailure::Fatal(msg)) => {
                    return finish(
                        report,
                        Termination::FactorizationFailed,
                        format!("{msg} (shift μ = {mu:.3e})"),
                    );
                }
                Err(SystemFailure::Retry(msg)) => {
                    failure = (
                        Termination::FactorizationFailed,
                        format!("{msg} (shift μ = {mu:.3e})"),
                    );
                    continue;
                }
            };
            if !residual_checked {
                residual_checked = true;
                report.residual_history.push(residual);
                let r0 = *residual0.get_or_insert(residual);
                if converged(residual, r0) {
                    return finish(report, Termination::GradientTolerance, String::new());
                }
                if report.iterations >= settings.max_iterations {
                    return finish(report, limit, String::new());
                }
            }
            if mu == 0.0 && feasible && inf_norm(&dx) <= settings.step_tol {
                return finish(report, Termination::StepTolerance, String::new());
            }
            let slope: f64 = asm
                .last_gradient()
                .iter()
                .zip(&dx)
                .map(|(g, d)| g * d)
                .sum();
            if !settings.line_search {
                // Full step (within the admissible bound), no energy evaluation.
                let alpha_max = problem.max_step(x, &dx);
                if alpha_max.is_nan() || alpha_max <= 0.0 {
                    failure = (Termination::LineSearchFailed, String::new());
                    continue;
                }
                accepted = Some((alpha_max.min(1.0), mu));
                break;
            }
            let search_start = std::time::Instant::now();
            let searched = line_search(
                problem,
                asm,
                x,
                &dx,
                energy,
                slope,
                noise,
                settings,
                &mut x_trial,
            );
            report.timings.line_search += search_start.elapsed().as_secs_f64();
            match searched? {
                LineSearch::Accepted { alpha, backtracks } => {
                    report.line_search_backtracks += backtracks;
                    accepted = Some((alpha, mu));
                    break;
                }
                LineSearch::Failed { backtracks } => {
                    report.line_search_backtracks += backtracks;
                    failure = (Termination::LineSearchFailed, String::new());
                }
            }
        }
        let Some((alpha, mu)) = accepted else {
            return finish(report, failure.0, failure.1);
        };
        last_mu = mu;
        // Entries with a zero step (the Dirichlet DOFs) are left bit-for-bit untouched.
        for (xi, &di) in x.iter_mut().zip(&dx) {
            if di != 0.0 {
                *xi += alpha * di;
            }
        }
        report.iterations += 1;
        report.step_lengths.push(alpha);
        report.regularizations.push(mu);
        report
            .linear_iterations
            .push(system.last_linear_iterations());
    }
}

/// Backtracking line search on the energy along `dx` from `x` (see the module docs). Leaves `x`
/// untouched; `x_trial` is scratch.
#[allow(clippy::too_many_arguments)]
fn line_search<P: Problem + ?Sized>(
    problem: &P,
    asm: &mut Assembler,
    x: &[f64],
    dx: &[f64],
    energy: f64,
    slope: f64,
    noise: f64,
    settings: &NewtonSettings,
    x_trial: &mut [f64],
) -> Result<LineSearch, SolveError> {
    // A direction of non-negative slope is only acceptable when the predicted change is at
    // rounding level (then the gradient test decides); otherwise it is not a descent direction.
    let descent = slope < 0.0;
    let negligible = slope.abs() <= noise;
    if !descent && !negligible {
        return Ok(LineSearch::Failed { backtracks: 0 });
    }
    // Checked before `min`, which would turn a NaN bound into 1.
    let alpha_max = problem.max_step(x, dx);
    if alpha_max.is_nan() || alpha_max <= 0.0 {
        return Ok(LineSearch::Failed { backtracks: 0 });
    }
    let mut alpha = alpha_max.min(1.0);
    for backtracks in 0..=settings.max_backtracks {
        for ((t, &xi), &di) in x_trial.iter_mut().zip(x).zip(dx) {
            *t = if di != 0.0 { xi + alpha * di } else { xi };
        }
        let trial = asm.energy(problem, x_trial)?;
        if trial.is_finite() && trial <= energy + settings.armijo * alpha * slope + noise {
            return Ok(LineSearch::Accepted { alpha, backtracks });
        }
        alpha *= settings.backtrack_factor;
    }
    Ok(LineSearch::Failed {
        backtracks: settings.max_backtracks + 1,
    })
}

/// `max_i |H_ii|` of the assembled Hessian, or 1 if that is zero (the scale of the shift).
fn diagonal_scale(asm: &mut Assembler) -> f64 {
    let (values, diag) = asm.hessian_values_and_diagonal();
    let s = diag.iter().map(|&d| values[d].abs()).fold(0.0, f64::max);
    if s > 0.0 && s.is_finite() { s } else { 1.0 }
}

/// `‖v‖∞`.
pub(crate) fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// The unconstrained back end: sparse Cholesky or preconditioned CG on `H_ff + μ I`.
struct FreeDofSystem {
    /// Built on the first Cholesky solve (symbolic analysis once per solver).
    llt: Option<SparseLlt>,
    /// Built on the first CG solve.
    pcg: Option<Pcg>,
    /// The linear solver of the current run (set by [`NewtonSolver::minimize`]).
    linear_solver: LinearSolver,
    /// CG iterations of the last successful solve (0 for Cholesky).
    linear_iterations: usize,
    /// Hessian row of each DOF (`None` if fixed).
    free_index: Vec<Option<usize>>,
    rhs: Vec<f64>,
    solution: Vec<f64>,
    diag_backup: Vec<f64>,
}

impl FreeDofSystem {
    /// Builds the back end `linear_solver` needs for `asm`'s pattern, if not yet built.
    fn prepare(&mut self, asm: &Assembler, linear_solver: LinearSolver) -> Result<(), SolveError> {
        self.linear_solver = linear_solver;
        if asm.n_free() == 0 {
            return Ok(());
        }
        match linear_solver {
            LinearSolver::Cholesky if self.llt.is_none() => {
                self.llt = Some(SparseLlt::new(asm.hessian().symbolic())?);
            }
            LinearSolver::ConjugateGradient(_) if self.pcg.is_none() => {
                self.pcg = Some(Pcg::new(asm.hessian())?);
                self.solution = vec![0.0; asm.n_free()];
            }
            _ => {}
        }
        Ok(())
    }

    /// `H_ff + μ I` solved by Cholesky for `self.rhs` (in place).
    fn solve_cholesky(&mut self, asm: &mut Assembler, mu: f64) -> Result<(), SystemFailure> {
        let llt = self
            .llt
            .as_mut()
            .ok_or("Cholesky solve requested before its symbolic analysis")?;
        // Shift the diagonal in place, factorize, and restore it.
        let (values, diag) = asm.hessian_values_and_diagonal();
        for (b, &d) in self.diag_backup.iter_mut().zip(diag) {
            *b = values[d];
            values[d] += mu;
        }
        let factorized = llt.factorize(asm.hessian());
        let (values, diag) = asm.hessian_values_and_diagonal();
        for (&b, &d) in self.diag_backup.iter().zip(diag) {
            values[d] = b;
        }
        factorized?;
        llt.solve_in_place(&mut self.rhs)?;
        self.linear_iterations = 0;
        Ok(())
    }

    /// `H_ff + μ I` solved by PCG for `self.rhs` (in place).
    fn solve_pcg(
        &mut self,
        asm: &Assembler,
        mu: f64,
        settings: &PcgSettings,
    ) -> Result<(), SystemFailure> {
        let pcg = self
            .pcg
            .as_mut()
            .ok_or("CG solve requested before its workspace was built")?;
        match pcg.solve(asm.hessian(), mu, &self.rhs, &mut self.solution, settings) {
            Ok(r) => {
                self.linear_iterations = r.iterations;
                self.rhs.copy_from_slice(&self.solution);
                Ok(())
            }
            Err(e @ PcgFailure::NotConverged { .. }) => Err(SystemFailure::Fatal(e.to_string())),
            Err(e) => Err(SystemFailure::Retry(e.to_string())),
        }
    }
}

impl NewtonSystem for FreeDofSystem {
    fn residual_before_solve(&self, gradient: &[f64]) -> Option<f64> {
        Some(
            gradient
                .iter()
                .zip(&self.free_index)
                .filter(|(_, f)| f.is_some())
                .fold(0.0, |m, (g, _)| m.max(g.abs())),
        )
    }

    fn solve(
        &mut self,
        asm: &mut Assembler,
        _x: &[f64],
        mu: f64,
        dx: &mut [f64],
    ) -> Result<f64, SystemFailure> {
        dx.fill(0.0);
        if self.rhs.is_empty() {
            return Ok(0.0); // no free DOFs: nothing to solve
        }
        let gradient = asm.last_gradient();
        for (dof, f) in self.free_index.iter().enumerate() {
            if let Some(i) = *f {
                self.rhs[i] = -gradient[dof];
            }
        }
        match self.linear_solver {
            LinearSolver::Cholesky => self.solve_cholesky(asm, mu)?,
            LinearSolver::ConjugateGradient(settings) => self.solve_pcg(asm, mu, &settings)?,
        }
        if !self.rhs.iter().all(|v| v.is_finite()) {
            return Err("non-finite Newton step".into());
        }
        for (dof, f) in self.free_index.iter().enumerate() {
            if let Some(i) = *f {
                dx[dof] = self.rhs[i];
            }
        }
        Ok(self
            .residual_before_solve(asm.last_gradient())
            .unwrap_or(0.0))
    }

    fn violation(&self, _x: &[f64], _settings: &NewtonSettings) -> Option<(bool, f64)> {
        None
    }

    fn last_linear_iterations(&self) -> usize {
        self.linear_iterations
    }

    fn residual_without_solve(&self) -> bool {
        true
    }
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
}

impl NewtonSolver {
    /// Prepares a solver for `problem` with Dirichlet DOFs `fixed` (`fixed.len() == n_dofs`;
    /// pass all `false` for none).
    pub fn new<P: Problem + ?Sized>(problem: &P, fixed: &[bool]) -> Result<Self, SolveError> {
        let assembler = Assembler::with_fixed_dofs(problem, fixed)?;
        let n_free = assembler.n_free();
        let free_index = (0..assembler.n_dofs())
            .map(|d| assembler.free_index(d))
            .collect();
        Ok(Self {
            assembler,
            system: FreeDofSystem {
                llt: None,
                pcg: None,
                linear_solver: LinearSolver::Cholesky,
                linear_iterations: 0,
                free_index,
                rhs: vec![0.0; n_free],
                solution: Vec::new(),
                diag_backup: vec![0.0; n_free],
            },
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
        run_newton(
            problem,
            x,
            settings,
            &mut self.assembler,
            &mut self.system,
            0.0,
        )
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
