//! Bounded Levenberg–Marquardt for small nonlinear least-squares problems
//!
//! ```text
//! min_p  C(p) = ‖r(p)‖²   subject to  lower ≤ p ≤ upper  (and optional further constraints)
//! ```
//!
//! over `N` parameters (a handful: material fits) with `m` residuals whose Jacobian
//! `J = ∂r/∂p` (m × N) the caller supplies (analytic, adjoint, or finite differences — the
//! routine does not care), with every evaluation or, where it is costly, only for the points
//! that lower the cost (`commit` of [`bounded_lm`]).
//!
//! **Iteration.** In scaled parameters `p̃_k = p_k / scale_k` (so that differently sized
//! parameters are damped alike) with `J̃ = J diag(scale)`, each iteration solves Marquardt's
//! damped normal equations
//!
//! ```text
//! (J̃ᵀJ̃ + λ diag(max(J̃ᵀJ̃_kk, 1e-12))) δ̃ = −J̃ᵀr,     p_trial = Π(p + diag(scale) δ̃)
//! ```
//!
//! where `Π` clamps onto the box `[lower, upper]` and then applies the caller's `constrain`
//! (further constraints, e.g. `|kxy| ≤ 0.95 √(kxx kyy)`). Parameters that are `fixed`, or sit on
//! a bound with the descent direction `−J̃ᵀr` pointing outward (an active set), are held: their
//! rows and columns of the system are replaced by the identity with a zero right-hand side.
//! A trial point with a lower cost is accepted (`λ ← max(λ/3, 1e-12)`); a trial point with a
//! higher cost, or whose evaluation or `commit` fails, is rejected (`λ ← 4λ`). `λ` starts at
//! `1e-3`.
//!
//! **Stopping rules** ([`LmTermination`]): iteration limit (accepted and rejected iterations),
//! all residuals at most `residual_tol`, gradient `‖J̃ᵀr‖_∞ ≤ 1e-14 √C` (rounding level), the
//! largest scaled move of a trial point at most `step_tol`, an accepted relative cost decrease
//! below `cost_rtol`, or `λ > 1e12` (no further decrease possible). Reaching any of them is
//! an `Ok` outcome that records which one: a least-squares fit has no "converged" point that
//! could be tested independently of the data, so the caller judges the
//! [`LmOutcome::termination`]. Only a failed evaluation at the initial point, or invalid input,
//! is an `Err`.

use nalgebra::{DMatrix, DVector};

/// Stopping rules of [`bounded_lm`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmSettings {
    /// Maximum iterations (accepted or rejected).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction (unitless).
    pub cost_rtol: f64,
    /// Stop when the largest scaled move `|Δp_k| / scale_k` of a trial point is at most this
    /// (unitless).
    pub step_tol: f64,
    /// Stop when every residual is at most this in magnitude (units of the residuals; `≤ 0`:
    /// never).
    pub residual_tol: f64,
}

/// The box, held parameters and scales of a [`bounded_lm`] problem with `N` parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmBounds<const N: usize> {
    /// Lower bounds (units of the parameters; may be `-∞`).
    pub lower: [f64; N],
    /// Upper bounds (units of the parameters; may be `+∞`).
    pub upper: [f64; N],
    /// Parameters held at their (projected) initial value.
    pub fixed: [bool; N],
    /// Positive, finite scale of each parameter (units of the parameters): damping and the
    /// step tolerance act on `p_k / scale_k`.
    pub scale: [f64; N],
}

/// Why [`bounded_lm`] stopped. `Display` gives a short English description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LmTermination {
    /// [`LmSettings::max_iterations`] iterations were taken.
    IterationLimit,
    /// Every residual is at most [`LmSettings::residual_tol`].
    ResidualTolerance,
    /// The scaled gradient `J̃ᵀr` is at rounding level.
    GradientRoundoff,
    /// The trial point moved by at most [`LmSettings::step_tol`] (scaled).
    StepTolerance,
    /// An accepted step lowered the cost by less than [`LmSettings::cost_rtol`].
    CostDecrease,
    /// The damping grew past `1e12` without a decrease.
    DampingLimit,
}

impl std::fmt::Display for LmTermination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::IterationLimit => "iteration limit",
            Self::ResidualTolerance => "residuals below tolerance",
            Self::GradientRoundoff => "gradient at rounding level",
            Self::StepTolerance => "step below tolerance",
            Self::CostDecrease => "cost decrease below tolerance",
            Self::DampingLimit => "damping limit (no further decrease)",
        })
    }
}

/// Result of [`bounded_lm`].
#[derive(Clone, Debug, PartialEq)]
pub struct LmOutcome<const N: usize> {
    /// Final (last accepted) parameters.
    pub p: [f64; N],
    /// Final cost `‖r‖²` (squared units of the residuals).
    pub cost: f64,
    /// Cost after every accepted step (first: the initial guess).
    pub history: Vec<f64>,
    /// Iterations (accepted and rejected).
    pub iterations: usize,
    /// Why it stopped.
    pub termination: LmTermination,
}

/// Errors of [`bounded_lm`].
#[derive(Debug, thiserror::Error)]
pub enum LmError<E> {
    /// Bounds, scales or settings are invalid (reported before any evaluation).
    #[error("invalid Levenberg–Marquardt input: {0}")]
    InvalidInput(String),
    /// The evaluation at the (projected) initial point failed.
    #[error("evaluation at the initial point failed: {0}")]
    InitialEvaluation(E),
}

/// One residual evaluation for [`bounded_lm`]: residuals `r` (length `m`), Jacobian `∂r/∂p`
/// (`m × N`) and a state handed to `commit` if the point is accepted (`commit` may complete
/// the Jacobian then).
pub type LmEval<S> = (DVector<f64>, DMatrix<f64>, S);

/// The residual function of [`bounded_lm`]: parameters → [`LmEval`], or the caller's error.
pub type LmFn<'a, const N: usize, S, E> = dyn FnMut(&[f64; N]) -> Result<LmEval<S>, E> + 'a;

/// The commit callback of [`bounded_lm`]: the state and the Jacobian of a point about to be
/// accepted, or the caller's error (which rejects the point).
pub type LmCommit<'a, S, E> = dyn FnMut(S, &mut DMatrix<f64>) -> Result<(), E> + 'a;

/// Progress callback: `(iteration, cost)` after each accepted step.
pub type LmProgress<'a> = &'a mut dyn FnMut(usize, f64);

/// Bounded Levenberg–Marquardt (module documentation) from `p0`.
///
/// `eval` returns the residuals, their Jacobian and a state at a parameter vector, or an error
/// (for example a failed equilibrium inside a simulation-in-the-loop fit): a failure at a trial
/// point rejects the point, a failure at the initial point is
/// [`LmError::InitialEvaluation`]. `commit` receives the state and the Jacobian of the initial
/// point and of every point with a lower cost, in order, before the Jacobian is used: it may
/// complete the Jacobian there (columns too costly to compute at trial points that may be
/// rejected). A point whose `commit` fails is rejected like a failed evaluation (at the
/// initial point: [`LmError::InitialEvaluation`]); every other one is accepted.
pub fn bounded_lm<const N: usize, S, E>(
    p0: [f64; N],
    bounds: &LmBounds<N>,
    settings: &LmSettings,
    constrain: &dyn Fn(&mut [f64; N]),
    eval: &mut LmFn<'_, N, S, E>,
    commit: &mut LmCommit<'_, S, E>,
    mut progress: Option<LmProgress<'_>>,
) -> Result<LmOutcome<N>, LmError<E>> {
    check_input(p0, bounds)?;
    let mut p = p0;
    project(&mut p, bounds, constrain);
    let (mut r, mut jac, state) = eval(&p).map_err(LmError::InitialEvaluation)?;
    if jac.nrows() != r.len() || jac.ncols() != N {
        return Err(LmError::InvalidInput(format!(
            "Jacobian is {} × {}, expected {} × {N}",
            jac.nrows(),
            jac.ncols(),
            r.len()
        )));
    }
    commit(state, &mut jac).map_err(LmError::InitialEvaluation)?;
    let mut cost = r.norm_squared();
    let mut history = vec![cost];
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut termination = LmTermination::IterationLimit;
    while iterations < settings.max_iterations {
        if settings.residual_tol > 0.0 && r.amax() <= settings.residual_tol {
            termination = LmTermination::ResidualTolerance;
            break;
        }
        iterations += 1;
        let (jtj, jtr) = scaled_normal_equations(&jac, &r, bounds);
        if jtr.amax() <= 1e-14 * cost.max(f64::MIN_POSITIVE).sqrt() {
            termination = LmTermination::GradientRoundoff;
            break;
        }
        let Some(step) = damped_step(&jtj, &jtr, &p, bounds, lambda) else {
            lambda *= 4.0;
            continue;
        };
        let mut trial = p;
        for k in 0..N {
            trial[k] += step[k] * bounds.scale[k];
        }
        project(&mut trial, bounds, constrain);
        let moved = (0..N)
            .map(|k| ((trial[k] - p[k]) / bounds.scale[k]).abs())
            .fold(0.0, f64::max);
        if moved <= settings.step_tol {
            termination = LmTermination::StepTolerance;
            break;
        }
        let accepted = evaluate_trial(eval, &trial, cost)
            .and_then(|(rt, mut jt, st, ct)| commit(st, &mut jt).ok().map(|()| (rt, jt, ct)));
        match accepted {
            Some((rt, jt, ct)) => {
                let decrease = (cost - ct) / cost.max(f64::MIN_POSITIVE);
                p = trial;
                r = rt;
                jac = jt;
                cost = ct;
                history.push(cost);
                lambda = (lambda / 3.0).max(1e-12);
                if let Some(cb) = progress.as_mut() {
                    cb(iterations, cost);
                }
                if decrease < settings.cost_rtol {
                    termination = LmTermination::CostDecrease;
                    break;
                }
            }
            None => {
                lambda *= 4.0;
                if lambda > 1e12 {
                    termination = LmTermination::DampingLimit;
                    break;
                }
            }
        }
    }
    Ok(LmOutcome {
        p,
        cost,
        history,
        iterations,
        termination,
    })
}

/// Checks that the bounds are intervals, the scales finite and positive, and `p0` finite.
fn check_input<const N: usize, E>(p0: [f64; N], bounds: &LmBounds<N>) -> Result<(), LmError<E>> {
    let LmBounds {
        lower,
        upper,
        scale,
        ..
    } = *bounds;
    if let Some(k) = (0..N).find(|&k| lower[k].is_nan() || upper[k].is_nan() || lower[k] > upper[k])
    {
        return Err(LmError::InvalidInput(format!(
            "parameter {k}: bounds [{}, {}] are not an interval",
            lower[k], upper[k]
        )));
    }
    if let Some(k) = (0..N).find(|&k| !(scale[k].is_finite() && scale[k] > 0.0)) {
        return Err(LmError::InvalidInput(format!(
            "parameter {k}: scale must be finite and > 0, got {}",
            scale[k]
        )));
    }
    if !p0.iter().all(|v| v.is_finite()) {
        return Err(LmError::InvalidInput(format!(
            "initial parameters must be finite, got {p0:?}"
        )));
    }
    Ok(())
}

/// `Π`: clamps `p` onto the box, then applies the caller's further constraints.
fn project<const N: usize>(
    p: &mut [f64; N],
    bounds: &LmBounds<N>,
    constrain: &dyn Fn(&mut [f64; N]),
) {
    for k in 0..N {
        p[k] = p[k].clamp(bounds.lower[k], bounds.upper[k]);
    }
    constrain(p);
}

/// `J̃ᵀJ̃` and `J̃ᵀr` of the scaled Jacobian `J̃ = J diag(scale)`, with the columns of fixed
/// parameters zeroed.
fn scaled_normal_equations<const N: usize>(
    jac: &DMatrix<f64>,
    r: &DVector<f64>,
    bounds: &LmBounds<N>,
) -> (DMatrix<f64>, DVector<f64>) {
    let j = DMatrix::from_fn(jac.nrows(), N, |row, k| {
        if bounds.fixed[k] {
            0.0
        } else {
            jac[(row, k)] * bounds.scale[k]
        }
    });
    (j.transpose() * &j, j.transpose() * r)
}

/// The scaled step `δ̃` of Marquardt's damped normal equations at `p` with damping `lambda`,
/// the held parameters (fixed, or on a bound with `−J̃ᵀr` pointing outward) replaced by
/// identity rows; `None` if the system is singular.
fn damped_step<const N: usize>(
    jtj: &DMatrix<f64>,
    jtr: &DVector<f64>,
    p: &[f64; N],
    bounds: &LmBounds<N>,
    lambda: f64,
) -> Option<DVector<f64>> {
    let LmBounds {
        lower,
        upper,
        fixed,
        ..
    } = *bounds;
    let held: [bool; N] = std::array::from_fn(|k| {
        fixed[k] || (p[k] <= lower[k] && jtr[k] > 0.0) || (p[k] >= upper[k] && jtr[k] < 0.0)
    });
    let mut a = jtj.clone();
    let mut rhs = -jtr;
    for k in 0..N {
        a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
        if held[k] {
            for l in 0..N {
                a[(k, l)] = 0.0;
                a[(l, k)] = 0.0;
            }
            a[(k, k)] = 1.0;
            rhs[k] = 0.0;
        }
    }
    a.lu().solve(&rhs)
}

/// An accepted trial point: residuals, Jacobian, state and cost.
type AcceptedTrial<S> = (DVector<f64>, DMatrix<f64>, S, f64);

/// Evaluates the trial point: its residuals, Jacobian, state and cost if the evaluation
/// succeeds with a consistent Jacobian and lowers the cost below `cost`, else `None`.
fn evaluate_trial<const N: usize, S, E>(
    eval: &mut LmFn<'_, N, S, E>,
    trial: &[f64; N],
    cost: f64,
) -> Option<AcceptedTrial<S>> {
    match eval(trial) {
        Ok((rt, jt, st)) if jt.nrows() == rt.len() && jt.ncols() == N => {
            let ct = rt.norm_squared();
            if ct < cost {
                Some((rt, jt, st, ct))
            } else {
                None
            }
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::convert::Infallible;

    fn settings() -> LmSettings {
        LmSettings {
            max_iterations: 200,
            cost_rtol: 0.0,
            step_tol: 1e-14,
            residual_tol: 0.0,
        }
    }

    fn free<const N: usize>() -> LmBounds<N> {
        LmBounds {
            lower: [f64::NEG_INFINITY; N],
            upper: [f64::INFINITY; N],
            fixed: [false; N],
            scale: [1.0; N],
        }
    }

    /// [`bounded_lm`] on two unbounded parameters with [`settings`], no further constraints
    /// and no progress callback.
    fn unbounded<S, E>(
        p0: [f64; 2],
        eval: &mut LmFn<'_, 2, S, E>,
        commit: &mut LmCommit<'_, S, E>,
    ) -> Result<LmOutcome<2>, LmError<E>> {
        bounded_lm(p0, &free(), &settings(), &|_| {}, eval, commit, None)
    }

    /// Rosenbrock as least squares: r = (10 (y − x²), 1 − x).
    fn rosenbrock(p: &[f64; 2]) -> Result<LmEval<()>, Infallible> {
        let [x, y] = *p;
        let r = DVector::from_vec(vec![10.0 * (y - x * x), 1.0 - x]);
        let j = DMatrix::from_row_slice(2, 2, &[-20.0 * x, 10.0, -1.0, 0.0]);
        Ok((r, j, ()))
    }

    #[test]
    fn unconstrained_rosenbrock_reaches_its_minimum() {
        let out = unbounded([-1.2, 1.0], &mut rosenbrock, &mut |_, _| Ok(())).unwrap();
        assert!(
            (out.p[0] - 1.0).abs() < 1e-8 && (out.p[1] - 1.0).abs() < 1e-8,
            "{out:?}"
        );
        assert!(out.history.windows(2).all(|w| w[1] < w[0]));
    }

    /// With `x ≤ 0.5` the constrained minimum of Rosenbrock is on the bound: `x = 0.5`,
    /// `y = x² = 0.25` (the first residual vanishes, the second is minimal at the bound).
    #[test]
    fn bounded_rosenbrock_stops_on_the_active_bound() {
        let mut bounds = free::<2>();
        bounds.upper[0] = 0.5;
        let out = bounded_lm(
            [-1.2, 1.0],
            &bounds,
            &settings(),
            &|_| {},
            &mut rosenbrock,
            &mut |_, _| Ok(()),
            None,
        )
        .unwrap();
        assert_eq!(out.p[0], 0.5, "{out:?}");
        assert!((out.p[1] - 0.25).abs() < 1e-8, "{out:?}");
        assert!((out.cost - 0.25).abs() < 1e-12);
    }

    /// Linear least squares `r = A p − b` with the unconstrained solution `(1, −2)`; the bound
    /// `p₁ ≥ 0` is active (the gradient pushes `p₁` down), so the solution is `p₁ = 0` and the
    /// `p₀` minimizing with `p₁ = 0`.
    #[test]
    fn linear_least_squares_with_an_active_bound() {
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let b = &a * DVector::from_vec(vec![1.0, -2.0]);
        let mut eval = |p: &[f64; 2]| -> Result<LmEval<()>, Infallible> {
            let r = &a * DVector::from_column_slice(p) - &b;
            Ok((r, a.clone(), ()))
        };
        let mut bounds = free::<2>();
        bounds.lower[1] = 0.0;
        let out = bounded_lm(
            [3.0, 3.0],
            &bounds,
            &settings(),
            &|_| {},
            &mut eval,
            &mut |_, _| Ok(()),
            None,
        )
        .unwrap();
        // At p₁ = 0: r = (p₀ − 1, 2, p₀ + 1), minimal at p₀ = 0 with cost 6.
        assert_eq!(out.p[1], 0.0);
        assert!(out.p[0].abs() < 1e-10, "{out:?}");
        assert!((out.cost - 6.0).abs() < 1e-10);
    }

    #[test]
    fn fixed_parameters_are_held_and_commit_sees_accepted_states() {
        let mut bounds = free::<2>();
        bounds.fixed[1] = true;
        let mut commits = 0;
        let out = bounded_lm(
            [-1.2, 2.0],
            &bounds,
            &settings(),
            &|_| {},
            &mut rosenbrock,
            &mut |_, _| {
                commits += 1;
                Ok(())
            },
            None,
        )
        .unwrap();
        assert_eq!(out.p[1], 2.0);
        assert_eq!(commits, out.history.len());
    }

    #[test]
    fn failed_trial_points_are_rejected_and_a_failed_start_is_an_error() {
        // Evaluations fail for x > 0.5: the iteration must stay below.
        let mut eval = |p: &[f64; 2]| {
            if p[0] > 0.5 {
                Err("no equilibrium")
            } else {
                Ok(rosenbrock(p).unwrap())
            }
        };
        let out = unbounded([-1.2, 1.0], &mut eval, &mut |_, _| Ok(())).unwrap();
        assert!(out.p[0] <= 0.5);
        let err = unbounded([1.0, 1.0], &mut eval, &mut |_, _| Ok(())).unwrap_err();
        assert!(matches!(err, LmError::InitialEvaluation("no equilibrium")));
    }

    /// A Jacobian supplied by `commit` at the points with a lower cost only (the evaluation
    /// returns zeros) gives the same iterates as one supplied with every evaluation; a failed
    /// `commit` rejects its point (here: every point with x > 0.5) like a failed evaluation.
    #[test]
    fn commit_may_supply_the_jacobian_and_a_failed_commit_rejects_the_point() {
        let eager = unbounded([-1.2, 1.0], &mut rosenbrock, &mut |_, _| Ok(())).unwrap();
        let mut evaluations = 0;
        let mut lazy_eval = |p: &[f64; 2]| -> Result<LmEval<[f64; 2]>, &str> {
            evaluations += 1;
            let (r, j, ()) = rosenbrock(p).unwrap();
            Ok((r, DMatrix::zeros(j.nrows(), j.ncols()), *p))
        };
        let mut commits = 0;
        let lazy = unbounded(
            [-1.2, 1.0],
            &mut lazy_eval,
            &mut |p: [f64; 2], j: &mut DMatrix<f64>| {
                commits += 1;
                *j = rosenbrock(&p).unwrap().1;
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(lazy, eager);
        assert_eq!(commits, lazy.history.len());
        assert!(commits < evaluations, "{commits} of {evaluations}");
        let mut eval = |p: &[f64; 2]| -> Result<LmEval<f64>, &str> {
            let (r, j, ()) = rosenbrock(p).unwrap();
            Ok((r, j, p[0]))
        };
        let mut committed = Vec::new();
        let capped = unbounded(
            [-1.2, 1.0],
            &mut eval,
            &mut |x: f64, _: &mut DMatrix<f64>| {
                if x > 0.5 {
                    return Err("no sensitivities");
                }
                committed.push(x);
                Ok(())
            },
        )
        .unwrap();
        assert!(capped.p[0] <= 0.5, "{capped:?}");
        assert_eq!(committed.len(), capped.history.len());
        let err = unbounded(
            [1.0, 1.0],
            &mut eval,
            &mut |x: f64, _: &mut DMatrix<f64>| {
                if x > 0.5 {
                    Err("no sensitivities")
                } else {
                    Ok(())
                }
            },
        )
        .unwrap_err();
        assert!(matches!(
            err,
            LmError::InitialEvaluation("no sensitivities")
        ));
    }

    #[test]
    fn invalid_bounds_and_scales_are_errors() {
        let mut bounds = free::<2>();
        bounds.lower[0] = 1.0;
        bounds.upper[0] = 0.0;
        let run = |bounds: &LmBounds<2>| {
            bounded_lm(
                [0.0, 0.0],
                bounds,
                &settings(),
                &|_| {},
                &mut rosenbrock,
                &mut |_, _| Ok(()),
                None,
            )
        };
        assert!(matches!(run(&bounds), Err(LmError::InvalidInput(_))));
        let mut bounds = free::<2>();
        bounds.scale[1] = 0.0;
        assert!(matches!(run(&bounds), Err(LmError::InvalidInput(_))));
    }

    #[test]
    fn termination_strings_are_stable() {
        assert_eq!(LmTermination::IterationLimit.to_string(), "iteration limit");
        assert_eq!(
            LmTermination::DampingLimit.to_string(),
            "damping limit (no further decrease)"
        );
    }
}
