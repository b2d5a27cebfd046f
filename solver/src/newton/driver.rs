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

    /// After a successful solve with a positive shift: a unit direction (2-norm, feasible
    /// for the constraints' null space) along which the unshifted Hessian curves down, and
    /// its curvature `dᵀHd < 0`; `None` when none was found or the back end cannot tell.
    fn negative_curvature(&mut self, _asm: &Assembler, _direction: &mut [f64]) -> Option<f64> {
        None
    }

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
    /// The shift was rejected without a solve: a known direction of negative curvature
    /// proves `H + μI` indefinite (retry with a larger shift, as after a failed solve).
    Indefinite(String),
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

/// A run stalls when its residual fell by less than half over this many iterations.
const STALL_WINDOW: usize = 3;

/// Outcome of one line search.
enum LineSearch {
    Accepted { alpha: f64, backtracks: usize },
    Failed { backtracks: usize },
}

/// How one Newton iteration ends.
enum Iteration {
    /// Take the step `alpha · dx`, found with diagonal shift `mu`.
    Step { alpha: f64, mu: f64 },
    /// End the run with this termination and failure detail.
    Stop(Termination, String),
}

/// The energy side of the current iterate.
struct Iterate {
    /// Energy at the iterate.
    energy: f64,
    /// Whether the energy, gradient (and Hessian, when assembled) are finite.
    finite: bool,
    /// Rounding level of the energy (`energy_noise_tolerance · Σ|eᵢ|`).
    noise: f64,
    /// Whether the constraints hold (always, unconstrained).
    feasible: bool,
}

/// The state of one Newton run: the problem and back end, the scratch vectors and the
/// report being filled.
struct NewtonRun<'a, P: Problem + ?Sized, S: NewtonSystem> {
    problem: &'a P,
    settings: &'a NewtonSettings,
    asm: &'a mut Assembler,
    system: &'a mut S,
    /// The Newton step.
    dx: Vec<f64>,
    /// Line-search scratch.
    x_trial: Vec<f64>,
    report: NewtonReport,
    /// The first stationarity residual (the scale of the relative tolerance).
    residual0: Option<f64>,
    /// Shift that worked in the previous iteration; the next escalation starts near it.
    last_mu: f64,
    /// The first iteration starts its escalation at `last_mu` itself, without the unshifted
    /// attempt and the one below it ([`NewtonSettings::carried_shift_probe_interval`]).
    start_at_last_mu: bool,
    /// Termination at the iteration limit.
    limit: Termination,
}

/// The diagonal shift a run starts from ([`NewtonSettings::warm_start_regularization`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct InitialShift {
    /// The shift carried in (0: none).
    pub value: f64,
    /// Start the first escalation at `value` itself
    /// ([`NewtonSettings::carried_shift_probe_interval`]).
    pub start_at_value: bool,
}

/// The Newton loop shared by [`super::NewtonSolver`] and [`crate::ConstrainedNewtonSolver`].
pub(crate) fn run_newton<P: Problem + ?Sized, S: NewtonSystem>(
    problem: &P,
    x: &mut [f64],
    settings: &NewtonSettings,
    asm: &mut Assembler,
    system: &mut S,
    initial_constraint_violation: f64,
    initial_shift: InitialShift,
) -> Result<NewtonReport, SolveError> {
    let mut run = NewtonRun {
        problem,
        settings,
        asm,
        system,
        dx: vec![0.0; x.len()],
        x_trial: vec![0.0; x.len()],
        report: empty_report(initial_constraint_violation),
        residual0: None,
        last_mu: initial_shift.value,
        start_at_last_mu: initial_shift.start_at_value && initial_shift.value > 0.0,
        limit: if settings.accept_iteration_limit {
            Termination::IterationLimit
        } else {
            Termination::MaxIterations
        },
    };
    loop {
        if settings.accept_iteration_limit
            && !settings.final_residual
            && run.report.iterations > 0
            && run.report.iterations >= settings.max_iterations
        {
            return finish(run.report, Termination::IterationLimit, String::new());
        }
        let iterate = run.evaluate(x)?;
        if !iterate.finite {
            return finish(run.report, Termination::NonFinite, String::new());
        }
        let residual_pre = run.system.residual_before_solve(run.asm.last_gradient());
        if let Some(r) = residual_pre
            && let Some(stop) = run.check_residual(r, &iterate)
        {
            return finish(run.report, stop, String::new());
        }
        match run.regularized_step(x, &iterate, residual_pre.is_some())? {
            Iteration::Step { alpha, mu } => run.take_step(x, alpha, mu),
            Iteration::Stop(termination, detail) => {
                return finish(run.report, termination, detail);
            }
        }
    }
}

/// A report with no iterations yet.
fn empty_report(initial_constraint_violation: f64) -> NewtonReport {
    NewtonReport {
        iterations: 0,
        energy_history: Vec::new(),
        residual_history: Vec::new(),
        constraint_violation_history: Vec::new(),
        initial_constraint_violation,
        step_lengths: Vec::new(),
        regularizations: Vec::new(),
        line_search_backtracks: 0,
        linear_solves: 0,
        shifts_skipped: 0,
        linear_iterations: Vec::new(),
        timings: NewtonTimings::default(),
        termination: Termination::MaxIterations,
    }
}

/// Ends the run: the report with its termination, as `Ok` for the successful terminations
/// and as the matching [`SolveError`] otherwise.
fn finish(
    mut report: NewtonReport,
    termination: Termination,
    detail: String,
) -> Result<NewtonReport, SolveError> {
    report.termination = termination;
    let report = Box::new(report);
    match termination {
        Termination::GradientTolerance
        | Termination::StepTolerance
        | Termination::IterationLimit => Ok(*report),
        Termination::MaxIterations => Err(SolveError::NotConverged(report)),
        Termination::LineSearchFailed => Err(SolveError::LineSearchFailed(report)),
        Termination::Stalled => Err(SolveError::Stalled(report)),
        Termination::NonFinite => Err(SolveError::NonFinite(report)),
        Termination::FactorizationFailed => Err(SolveError::FactorizationFailed { report, detail }),
    }
}

impl<P: Problem + ?Sized, S: NewtonSystem> NewtonRun<'_, P, S> {
    /// Assembles energy, gradient and (unless only the residual is left to compute at the
    /// iteration limit) the Hessian at `x`, and records the energy and constraint violation.
    fn evaluate(&mut self, x: &[f64]) -> Result<Iterate, SolveError> {
        let settings = self.settings;
        // At the iteration limit the residual is all that is left to compute: skip the
        // Hessian when the system can give the residual without a solve.
        let last = self.report.iterations >= settings.max_iterations
            && self.system.residual_without_solve();
        let assembly_start = std::time::Instant::now();
        let (energy, finite) = if last {
            let (energy, gradient) = self.asm.gradient(self.problem, x)?;
            (
                energy,
                energy.is_finite() && gradient.iter().all(|g| g.is_finite()),
            )
        } else {
            let assembled = self.asm.assemble(self.problem, x, settings.project_spd)?;
            let energy = assembled.energy;
            let finite = energy.is_finite()
                && assembled.gradient.iter().all(|g| g.is_finite())
                && assembled.hessian.val().iter().all(|h| h.is_finite());
            (energy, finite)
        };
        self.report.timings.assembly += assembly_start.elapsed().as_secs_f64();
        let noise = settings.energy_noise_tolerance * self.asm.energy_abs_sum();
        self.report.energy_history.push(energy);
        let violation = self.system.violation(x, settings);
        let feasible = violation.is_none_or(|(ok, _)| ok);
        if let Some((_, v)) = violation {
            self.report.constraint_violation_history.push(v);
        }
        Ok(Iterate {
            energy,
            finite,
            noise,
            feasible,
        })
    }

    /// Records the stationarity residual `r` of the iterate; the termination if it passes the
    /// gradient test (feasible iterates only), the run has stalled
    /// ([`NewtonSettings::stall_iterations`]) or the iteration limit is reached.
    fn check_residual(&mut self, r: f64, iterate: &Iterate) -> Option<Termination> {
        let settings = self.settings;
        self.report.residual_history.push(r);
        let r0 = *self.residual0.get_or_insert(r);
        if iterate.feasible
            && r <= settings
                .gradient_abs_tol
                .max(settings.gradient_rel_tol * r0)
        {
            return Some(Termination::GradientTolerance);
        }
        if self.stalled(iterate.noise) {
            return Some(Termination::Stalled);
        }
        (self.report.iterations >= settings.max_iterations).then_some(self.limit)
    }

    /// Whether the last [`NewtonSettings::stall_iterations`] iterations lowered neither the
    /// residual by half nor the energy by more than `noise` (always `false` when the setting
    /// is 0).
    fn stalled(&self, noise: f64) -> bool {
        let n = self.settings.stall_iterations;
        let energies = &self.report.energy_history;
        n > 0
            && energies.len() > n
            && fell_by_less_than_half(&self.report.residual_history, n)
            && energies[energies.len() - 1 - n] - energies[energies.len() - 1] <= noise
    }

    /// Solves for the Newton step and line-searches along it, escalating the diagonal shift
    /// on failure; checks the residual from the first solve unless `residual_checked`.
    fn regularized_step(
        &mut self,
        x: &[f64],
        iterate: &Iterate,
        mut residual_checked: bool,
    ) -> Result<Iteration, SolveError> {
        let settings = self.settings;
        let scale = self.asm.diagonal_scale();
        let (first, base) = if std::mem::take(&mut self.start_at_last_mu) {
            (1, self.last_mu)
        } else {
            (
                0,
                (settings.regularization_initial * scale)
                    .max(self.last_mu / settings.regularization_growth),
            )
        };
        let mut failure = (
            Termination::FactorizationFailed,
            String::from("no attempt made"),
        );
        for attempt in first..=settings.max_regularization_attempts {
            let mu = match attempt {
                0 => 0.0,
                k => base * settings.regularization_growth.powi(k as i32 - 1),
            };
            let solve_start = std::time::Instant::now();
            let solved = self.system.solve(self.asm, x, mu, &mut self.dx);
            self.report.timings.linear_solve += solve_start.elapsed().as_secs_f64();
            match solved {
                Err(SystemFailure::Indefinite(_)) => self.report.shifts_skipped += 1,
                _ => self.report.linear_solves += 1,
            }
            let residual = match solved {
                Ok(r) => r,
                Err(SystemFailure::Fatal(msg)) => {
                    return Ok(Iteration::Stop(
                        Termination::FactorizationFailed,
                        format!("{msg} (shift μ = {mu:.3e})"),
                    ));
                }
                Err(SystemFailure::Retry(msg) | SystemFailure::Indefinite(msg)) => {
                    failure = (
                        Termination::FactorizationFailed,
                        format!("{msg} (shift μ = {mu:.3e})"),
                    );
                    continue;
                }
            };
            if !residual_checked {
                residual_checked = true;
                if let Some(stop) = self.check_residual(residual, iterate) {
                    return Ok(Iteration::Stop(stop, String::new()));
                }
            }
            if mu == 0.0 && iterate.feasible && inf_norm(&self.dx) <= settings.step_tol {
                return Ok(Iteration::Stop(Termination::StepTolerance, String::new()));
            }
            if mu > 0.0 && !settings.project_spd {
                self.add_negative_curvature(iterate.noise);
            }
            match self.step_length(x, iterate)? {
                Some(alpha) => {
                    let alpha = self.extend_along_negative_curvature(x, iterate, alpha)?;
                    return Ok(Iteration::Step { alpha, mu });
                }
                None => failure = (Termination::LineSearchFailed, String::new()),
            }
        }
        Ok(Iteration::Stop(failure.0, failure.1))
    }

    /// Saddle escape: when the full step was accepted but the (unshifted) model curves down
    /// along it, `ΔxᵀHΔx < 0`, the energy keeps falling beyond it; doubles the step while
    /// the energy decreases (within the admissible bound, at most 2¹⁰). Without this, a
    /// shifted step near a saddle moves by about `g/μ` per iteration and the escape takes
    /// hundreds of iterations.
    fn extend_along_negative_curvature(
        &mut self,
        x: &[f64],
        iterate: &Iterate,
        alpha: f64,
    ) -> Result<f64, SolveError> {
        // SPD-projected Hessians have ΔxᵀHΔx ≥ 0: skip the product.
        if !self.settings.line_search
            || self.settings.project_spd
            || alpha < 1.0
            || quadratic_form(self.asm, &self.dx) >= 0.0
        {
            return Ok(alpha);
        }
        let alpha_max = self.problem.max_step(x, &self.dx);
        let energy_at = |run: &mut Self, a: f64| -> Result<f64, SolveError> {
            for ((t, &xi), &di) in run.x_trial.iter_mut().zip(x).zip(&run.dx) {
                *t = if di != 0.0 { xi + a * di } else { xi };
            }
            run.asm.energy(run.problem, &run.x_trial)
        };
        let (mut best, mut best_energy) = (alpha, energy_at(self, alpha)?);
        for _ in 0..10 {
            let a = 2.0 * best;
            if a.partial_cmp(&alpha_max) == Some(std::cmp::Ordering::Greater) || alpha_max.is_nan()
            {
                break;
            }
            let e = energy_at(self, a)?;
            if !(e.is_finite() && e < best_energy - iterate.noise) {
                break;
            }
            (best, best_energy) = (a, e);
        }
        Ok(best)
    }

    /// Adds to the shifted step `Δx` a direction `v` of negative curvature `θ = vᵀHv < 0`
    /// (unit 2-norm), signed downhill (`gᵀv ≤ 0`), when the back end finds one. A shifted
    /// Newton step cannot leave a saddle whose unstable mode has no gradient component (e.g.
    /// a tile kept symmetric): the iterates converge to the saddle, linearly, at the shift's
    /// rate. Moré & Sorensen (1979) combine the two directions the same way; the step doubling
    /// of [`Self::extend_along_negative_curvature`] then grows the escape. `v` gets the length
    /// `‖Δx‖₂`; when the run stalls (residual down by less than half in [`STALL_WINDOW`]
    /// iterations), at least the `t` at which the model's decrease `½|θ|t²` is a thousand
    /// times the energy's rounding level `noise` (near a saddle `Δx` itself vanishes, and so
    /// would an escape scaled by it).
    fn add_negative_curvature(&mut self, noise: f64) {
        // Stalled: the residual fell by less than half over the last few iterations.
        let stalled = fell_by_less_than_half(&self.report.residual_history, STALL_WINDOW);
        let mut v = std::mem::take(&mut self.x_trial);
        if let Some(curvature) = self.system.negative_curvature(self.asm, &mut v)
            && curvature < 0.0
        {
            let mut length = self.dx.iter().map(|d| d * d).sum::<f64>().sqrt();
            if stalled {
                length = length.max((2e3 * noise / -curvature).sqrt());
            }
            let slope: f64 = self
                .asm
                .last_gradient()
                .iter()
                .zip(&v)
                .map(|(g, d)| g * d)
                .sum();
            let sign = if slope > 0.0 { -1.0 } else { 1.0 };
            for (d, vi) in self.dx.iter_mut().zip(&v) {
                *d += sign * length * vi;
            }
        }
        self.x_trial = v;
    }

    /// The step length along `dx`: the full admissible step without a line search, else the
    /// backtracking line search's; `None` when no step is acceptable.
    fn step_length(&mut self, x: &[f64], iterate: &Iterate) -> Result<Option<f64>, SolveError> {
        let slope: f64 = self
            .asm
            .last_gradient()
            .iter()
            .zip(&self.dx)
            .map(|(g, d)| g * d)
            .sum();
        if !self.settings.line_search {
            // Full step (within the admissible bound), no energy evaluation.
            let alpha_max = self.problem.max_step(x, &self.dx);
            if alpha_max.is_nan() || alpha_max <= 0.0 {
                return Ok(None);
            }
            return Ok(Some(alpha_max.min(1.0)));
        }
        let search_start = std::time::Instant::now();
        let searched = line_search(
            self.problem,
            self.asm,
            x,
            &self.dx,
            iterate.energy,
            slope,
            iterate.noise,
            self.settings,
            &mut self.x_trial,
        );
        self.report.timings.line_search += search_start.elapsed().as_secs_f64();
        Ok(match searched? {
            LineSearch::Accepted { alpha, backtracks } => {
                self.report.line_search_backtracks += backtracks;
                Some(alpha)
            }
            LineSearch::Failed { backtracks } => {
                self.report.line_search_backtracks += backtracks;
                None
            }
        })
    }

    /// Moves `x` by `alpha · dx` and records the step taken with shift `mu`.
    fn take_step(&mut self, x: &mut [f64], alpha: f64, mu: f64) {
        self.last_mu = mu;
        // Entries with a zero step (the Dirichlet DOFs) are left bit-for-bit untouched.
        for (xi, &di) in x.iter_mut().zip(&self.dx) {
            if di != 0.0 {
                *xi += alpha * di;
            }
        }
        self.report.iterations += 1;
        self.report.step_lengths.push(alpha);
        self.report.regularizations.push(mu);
        self.report
            .linear_iterations
            .push(self.system.last_linear_iterations());
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

/// `ΔxᵀHΔx` with the assembled (unshifted, lower-triangle) Hessian on the free DOFs.
fn quadratic_form(asm: &Assembler, dx: &[f64]) -> f64 {
    let mut v = vec![0.0; asm.n_free()];
    for (dof, &d) in dx.iter().enumerate() {
        if let Some(f) = asm.free_index(dof) {
            v[f] = d;
        }
    }
    crate::linalg::symmetric_quadratic_form(asm.hessian(), &v)
}

/// Whether the last entry of `history` is more than half the one `window` entries before it
/// (`false` while the history is shorter than that).
fn fell_by_less_than_half(history: &[f64], window: usize) -> bool {
    history.len() > window && history[history.len() - 1] > 0.5 * history[history.len() - 1 - window]
}

/// `‖v‖∞`.
pub(crate) fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}
