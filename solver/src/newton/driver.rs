//! The Newton loop shared by the unconstrained and the constrained solvers: the back-end
//! trait, the loop with adaptive regularization, and the backtracking line search.

use crate::SolveError;
use crate::assembly::{Assembler, Problem};

use super::{NewtonReport, NewtonSettings, NewtonTimings, Termination};

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

/// The Newton loop shared by [`super::NewtonSolver`] and [`crate::ConstrainedNewtonSolver`].
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
