//! Secant root finding from one start point, without a bracket ([`secant`]).

use crate::continuation::StepError;

/// One evaluation of the function: value, tolerance and the caller's data at this point.
#[derive(Clone, Debug, PartialEq)]
pub struct SecantEval<T> {
    /// `f(x)`.
    pub f: f64,
    /// Converged when `|f(x)| ≤ f_tol` (units of `f`).
    pub f_tol: f64,
    /// What the evaluation produced besides `f` (returned with the root).
    pub data: T,
    /// `f′(x)`, where the caller has it (units of `f` per unit `x`): the next step is then
    /// Newton's from this point instead of the secant's (see [`secant`]).
    pub df: Option<f64>,
}

/// Settings of [`secant`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecantSettings {
    /// Distance of the second start point from the first, and the step taken when the
    /// secant is undefined (`f₁ = f₀`) (units of `x`, > 0).
    pub first_step: f64,
    /// Largest move of one secant step (units of `x`, > 0).
    pub max_step: f64,
    /// Smallest admissible point (units of `x`; may be `−∞`).
    pub lower: f64,
    /// Largest admissible point (units of `x`; may be `+∞`).
    pub upper: f64,
    /// Most secant steps after the two start points.
    pub max_iterations: usize,
    /// Retries of a failed evaluation at the midpoint toward the last point.
    pub max_retries: usize,
    /// Once the two points bracket a sign change, the newest point is also accepted when
    /// they are at most `x_tol` apart (units of `x`; `0` disables the test): the root is then
    /// located to `x_tol` even where `f` jumps across zero instead of passing through it.
    pub x_tol: f64,
}

/// A root found by [`secant`].
#[derive(Clone, Debug, PartialEq)]
pub struct SecantRoot<T> {
    /// The root (units of `x`): the last evaluated point.
    pub x: f64,
    /// `f` there: within its tolerance of 0, or, when the bracket closed to
    /// [`SecantSettings::x_tol`] first, the value on this side of a jump across zero.
    pub f: f64,
    /// The evaluation's data there.
    pub data: T,
    /// Secant steps taken (0: one of the two start points converged).
    pub iterations: usize,
}

/// The state of a [`secant`] iteration that failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecantReport {
    /// Secant steps taken.
    pub iterations: usize,
    /// Newest point (units of `x`).
    pub x: f64,
    /// `f` there.
    pub f: f64,
    /// The retained other point (units of `x`).
    pub x_other: f64,
    /// Its value (halved by the Illinois rule, possibly repeatedly).
    pub f_other: f64,
    /// Whether the two points bracket a sign change.
    pub bracketed: bool,
}

impl SecantReport {
    /// `min(|f|, |f_other|)`: the smaller residual of the two points.
    pub fn best_abs_f(&self) -> f64 {
        self.f.abs().min(self.f_other.abs())
    }
}

/// Errors of [`secant`].
#[derive(Debug, thiserror::Error)]
pub enum SecantError<E> {
    /// Invalid settings or start point.
    #[error("invalid secant input: {0}")]
    InvalidInput(String),
    /// `f` was NaN, or the secant point was not finite.
    #[error("non-finite secant iteration at x = {}", .0.x)]
    NonFinite(SecantReport),
    /// No convergence within the iteration limit.
    #[error(
        "secant not converged in {} steps (|f| = {:.3e} at x = {})",
        .0.iterations, .0.f.abs(), .0.x
    )]
    NotConverged(SecantReport),
    /// The user function failed (after its retries).
    #[error("function evaluation failed at x = {x}")]
    Eval {
        /// Where.
        x: f64,
        /// The user function's error.
        source: E,
    },
}

/// Finds a root of `f` starting at `x0`: solves `f(x) = 0` for a scalar `f` that is expensive (every evaluation a
/// nonlinear solve, say) and has no known sign-change bracket, only a good start `x₀`:
///
/// 1. `f(x₀)` is evaluated, then `f(x₁)` at `x₁ = x₀ + first_step` when `f(x₀) > 0`,
///    `x₀ − first_step` otherwise (toward the root of a *decreasing* function; for an
///    increasing one the first secant step turns around by itself).
/// 2. Each iteration first tests the newest point: converged when `|f(x₁)| ≤ f_tol`, where
///    `f_tol` comes with every evaluation ([`SecantEval`]), so it may depend on the point
///    (e.g. relative to another output of the same evaluation), or, once the root is
///    bracketed, when the bracket `|x₁ − x₀|` is at most `x_tol` (a function that jumps
///    across zero, as an equilibrium's stress where the state snaps to another branch, has
///    no point within `f_tol`; the bracket then locates the jump). The start point is tested
///    first: a start within its tolerance is the root, after one evaluation (a good
///    predictor, or a function that vanishes on a whole interval around the start, where no
///    second point would pass the test more reliably than the first).
/// 3. Otherwise the secant point `x₂ = x₁ − f₁ (x₁ − x₀)/(f₁ − f₀)` (`x₁ + first_step` when
///    `f₁ = f₀`) is clipped to `|x₂ − x₁| ≤ max_step`, then to `x₂ ≤ upper` and `x₂ ≥ lower`.
///    **With derivatives.** When the newest evaluation brings a finite, nonzero `f′(x₁)`
///    ([`SecantEval::df`]), Newton's point `x₁ − f₁/f′(x₁)` replaces the secant point, unless
///    the root is bracketed and Newton's point falls outside the bracket (then the bracket's
///    regula falsi point is kept). A start point with a derivative takes Newton's step as its
///    second point instead of `first_step` (clipped alike). Near a simple root this converges
///    quadratically instead of with the secant's order 1.6, and needs no second start point.
/// 4. An evaluation that fails with [`StepError::Halve`] is retried at the midpoint
///    `(x₁ + x₂)/2`, at most `max_retries` times; [`StepError::Abort`] (and any failure at the
///    two start points) stops at once.
/// 5. Until the values change sign the two newest points are kept (secant). Once they do, the
///    root stays bracketed by `x₁` and the retained end `x₀` (regula falsi) with the
///    **Illinois** safeguard: when the same end is retained twice in a row, its value is
///    halved, so that end moves too and convergence stays superlinear.
///
/// Sign tests use `f64::signum` (so `+0.0` counts as positive and `−0.0` as negative).
///
/// **Failure.** Not converging within `max_iterations` secant steps is
/// [`SecantError::NotConverged`]; a NaN value or a non-finite secant point is
/// [`SecantError::NonFinite`]; both carry a [`SecantReport`].
pub fn secant<T, E>(
    x0: f64,
    settings: &SecantSettings,
    mut f: impl FnMut(f64) -> Result<SecantEval<T>, StepError<E>>,
) -> Result<SecantRoot<T>, SecantError<E>> {
    let SecantSettings {
        first_step,
        max_step,
        lower,
        upper,
        max_iterations,
        max_retries,
        x_tol,
    } = *settings;
    if !(first_step.is_finite() && first_step > 0.0 && max_step.is_finite() && max_step > 0.0) {
        return Err(SecantError::InvalidInput(format!(
            "first_step {first_step} and max_step {max_step} must be finite and > 0"
        )));
    }
    if !(x0.is_finite() && lower <= x0 && x0 <= upper) {
        return Err(SecantError::InvalidInput(format!(
            "start {x0} must be finite and inside [{lower}, {upper}]"
        )));
    }
    let mut eval = |x: f64| -> Result<SecantEval<T>, SecantError<E>> {
        f(x).map_err(|e| SecantError::Eval {
            x,
            source: e.into_inner(),
        })
    };
    let start = eval(x0)?;
    if start.f.abs() <= start.f_tol {
        return Ok(SecantRoot {
            x: x0,
            f: start.f,
            data: start.data,
            iterations: 0,
        });
    }
    let (mut x0, mut f0) = (x0, start.f);
    let mut x1 = match newton_point(x0, f0, start.df) {
        Some(x) => x.clamp(x0 - max_step, x0 + max_step).min(upper).max(lower),
        None => x0 + if f0 > 0.0 { first_step } else { -first_step },
    };
    if x1 == x0 {
        // A Newton step clipped onto the start (the start on a bound): the plain second point.
        x1 = x0 + if f0 > 0.0 { first_step } else { -first_step };
    }
    let SecantEval {
        f: mut f1,
        f_tol: mut tol1,
        data: mut data1,
        df: mut df1,
    } = eval(x1)?;
    let mut bracketed = f0.signum() != f1.signum();
    let mut retained = false; // Illinois bookkeeping: the end x0 was retained last step
    let report = |iterations, x, f, x_other, f_other, bracketed| SecantReport {
        iterations,
        x,
        f,
        x_other,
        f_other,
        bracketed,
    };
    for iteration in 0..max_iterations {
        if f1.abs() <= tol1 || (bracketed && (x1 - x0).abs() <= x_tol) {
            return Ok(SecantRoot {
                x: x1,
                f: f1,
                data: data1,
                iterations: iteration,
            });
        }
        if f0.is_nan() || f1.is_nan() {
            return Err(SecantError::NonFinite(report(
                iteration, x1, f1, x0, f0, bracketed,
            )));
        }
        let denom = f1 - f0;
        let secant_point = if denom != 0.0 {
            x1 - f1 * (x1 - x0) / denom
        } else {
            x1 + first_step
        };
        // Newton's point where the derivative is known, if it stays inside a bracket.
        let inside = |x: f64| !bracketed || (x - x0) * (x - x1) < 0.0;
        let mut x2 = match newton_point(x1, f1, df1) {
            Some(x) if inside(x) => x,
            _ => secant_point,
        };
        // `min`/`max` (not `clamp`) so that a NaN secant point lands on `upper`.
        x2 = x2.clamp(x1 - max_step, x1 + max_step).min(upper).max(lower);
        if !x2.is_finite() {
            return Err(SecantError::NonFinite(report(
                iteration, x2, f1, x0, f0, bracketed,
            )));
        }
        let mut trial = f(x2);
        for _ in 0..max_retries {
            if !matches!(trial, Err(StepError::Halve(_))) {
                break;
            }
            x2 = 0.5 * (x1 + x2);
            trial = f(x2);
        }
        let SecantEval {
            f: f2,
            f_tol: tol2,
            data: data2,
            df: df2,
        } = trial.map_err(|e| SecantError::Eval {
            x: x2,
            source: e.into_inner(),
        })?;
        if bracketed {
            if f2.signum() == f1.signum() {
                // x0 retained: halve its value if it was retained last step too (Illinois).
                if retained {
                    f0 *= 0.5;
                }
                retained = true;
            } else {
                (x0, f0) = (x1, f1);
                retained = false;
            }
        } else {
            bracketed = f2.signum() != f1.signum();
            (x0, f0) = (x1, f1);
        }
        (x1, f1, tol1, data1, df1) = (x2, f2, tol2, data2, df2);
    }
    Err(SecantError::NotConverged(report(
        max_iterations,
        x1,
        f1,
        x0,
        f0,
        bracketed,
    )))
}

/// Newton's point `x − f/f′` from a finite, nonzero derivative (`None` otherwise).
fn newton_point(x: f64, f: f64, df: Option<f64>) -> Option<f64> {
    let df = df.filter(|d| d.is_finite() && *d != 0.0)?;
    Some(x - f / df).filter(|p| p.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::convert::Infallible;

    fn settings() -> SecantSettings {
        SecantSettings {
            first_step: 0.01,
            max_step: 0.2,
            lower: f64::NEG_INFINITY,
            upper: f64::INFINITY,
            max_iterations: 50,
            max_retries: 4,
            x_tol: 0.0,
        }
    }

    fn value(f: f64, tol: f64) -> Result<SecantEval<()>, StepError<Infallible>> {
        Ok(SecantEval {
            f,
            f_tol: tol,
            data: (),
            df: None,
        })
    }

    #[test]
    fn finds_roots_of_decreasing_and_increasing_functions() {
        // Decreasing: 0.3 − x³ − x, root near 0.2880.
        let dec = |x: f64| 0.3 - x * x * x - x;
        let r = secant(0.0, &settings(), |x| value(dec(x), 1e-14)).unwrap();
        assert!(dec(r.x).abs() <= 1e-14, "{r:?}");
        assert!(r.iterations < 10, "{r:?}");
        // Increasing: tanh(x − 0.7); the first step goes the wrong way and turns around.
        let inc = |x: f64| (x - 0.7).tanh();
        let r = secant(0.5, &settings(), |x| value(inc(x), 1e-13)).unwrap();
        assert!((r.x - 0.7).abs() <= 1e-12, "{r:?}");
    }

    #[test]
    fn illinois_keeps_a_bracket_and_converges_on_a_convex_function() {
        // exp(x) − 2 (convex): plain regula falsi would keep one end for ever.
        let f = |x: f64| x.exp() - 2.0;
        let mut points = vec![];
        let r = secant(1.0, &settings(), |x| {
            points.push(x);
            value(f(x), 1e-14)
        })
        .unwrap();
        assert!((r.x - 2f64.ln()).abs() <= 1e-13, "{r:?}");
        assert!(r.iterations < 15, "{r:?} {points:?}");
        // The max_step clip: no step longer than 0.2.
        assert!(
            points
                .windows(2)
                .all(|w| (w[1] - w[0]).abs() <= 0.2 + 1e-15)
        );
    }

    #[test]
    fn tolerance_and_data_come_from_the_evaluation() {
        // A start within its tolerance is the root, after one evaluation.
        let mut calls = 0;
        let r = secant(0.5, &settings(), |x| {
            calls += 1;
            Ok::<_, StepError<Infallible>>(SecantEval {
                f: 0.5 - x,
                f_tol: 1.0,
                data: calls,
                df: None,
            })
        })
        .unwrap();
        assert_eq!((r.x, r.data, r.iterations), (0.5, 1, 0));
        // The tolerance is the evaluation's own: 0.1 at x = 0.3 (f = 0.2, rejected), 0.5 at
        // the second point x = 0.31 (f = 0.19, accepted).
        let r = secant(0.3, &settings(), |x| {
            Ok::<_, StepError<Infallible>>(SecantEval {
                f: 0.5 - x,
                f_tol: if x == 0.3 { 0.1 } else { 0.5 },
                data: x,
                df: None,
            })
        })
        .unwrap();
        assert_eq!((r.x, r.data, r.iterations), (0.31, 0.31, 0));
    }

    #[test]
    fn derivatives_give_newton_steps_that_converge_in_fewer_evaluations() {
        // 0.3 − x³ − x from 0: the secant's evaluations against Newton's, same tolerance.
        let f = |x: f64| 0.3 - x * x * x - x;
        let df = |x: f64| -3.0 * x * x - 1.0;
        let count = |with_derivative: bool| {
            let mut calls = 0;
            let r = secant(0.0, &settings(), |x| {
                calls += 1;
                Ok::<_, StepError<Infallible>>(SecantEval {
                    f: f(x),
                    f_tol: 1e-14,
                    data: (),
                    df: with_derivative.then(|| df(x)),
                })
            })
            .unwrap();
            assert!(f(r.x).abs() <= 1e-14, "{r:?}");
            calls
        };
        let (plain, newton) = (count(false), count(true));
        // Newton from 0 (root 0.278418): 0.2 (its first step 0.3 clipped to max_step), then
        // quadratically: |f| 9e-2 at 0.2, then 5e-3, 1e-5, 7e-11, 0 — six evaluations in all.
        assert!(newton <= 6, "{newton} evaluations with derivatives");
        assert!(newton < plain, "{newton} with derivatives, {plain} without");
        // Newton points outside the bracket are not taken: with a derivative 10× too small,
        // every Newton step from tanh(x − 0.7)'s far side overshoots, and once 0.65 and 0.85
        // bracket the root the iteration goes on by regula falsi.
        let g = |x: f64| (x - 0.7).tanh();
        let mut points = vec![];
        let r = secant(0.45, &settings(), |x| {
            points.push(x);
            Ok::<_, StepError<Infallible>>(SecantEval {
                f: g(x),
                f_tol: 1e-13,
                data: (),
                df: Some(0.1 / (x - 0.7).cosh().powi(2)),
            })
        })
        .unwrap();
        assert!((r.x - 0.7).abs() <= 1e-12, "{r:?} {points:?}");
        assert!(
            points[3..].iter().all(|&x| (0.65..=0.85).contains(&x)),
            "{points:?}"
        );
    }

    #[test]
    fn a_jump_across_zero_is_located_to_the_bracket_tolerance() {
        // f jumps from −1 to +1 at x = 0.3 and has no root; without `x_tol` the iteration
        // runs out of steps, with it the bracket closes on the jump.
        let f = |x: f64| value(if x < 0.3 { -1.0 } else { 1.0 }, 1e-12);
        assert!(matches!(
            secant(0.2, &settings(), f),
            Err(SecantError::NotConverged(_))
        ));
        let mut points = vec![];
        let tol = SecantSettings {
            x_tol: 1e-9,
            ..settings()
        };
        let r = secant(0.2, &tol, |x| {
            points.push(x);
            f(x)
        })
        .unwrap();
        assert!((r.x - 0.3).abs() <= 1e-9, "{r:?}");
        assert_eq!(r.f.abs(), 1.0);
        // The bracket test needs a sign change: on a flat function it never fires.
        let flat = secant(0.2, &tol, |_| value(1.0, 1e-12));
        assert!(
            matches!(flat, Err(SecantError::NotConverged(_))),
            "{points:?}"
        );
    }

    #[test]
    fn failed_evaluations_are_retried_closer_and_bounds_clip() {
        // f fails beyond x = 0.3; the root 0.35 lies there, so the clip `upper = 0.3`
        // and the retries keep the iteration inside, and it ends without convergence.
        let f = |x: f64| {
            if x > 0.3 {
                Err(StepError::Halve("jammed"))
            } else {
                value(0.35 - x, 1e-12).map_err(|_| StepError::Abort("never"))
            }
        };
        let clipped = SecantSettings {
            upper: 0.3,
            max_iterations: 5,
            ..settings()
        };
        match secant(0.2, &clipped, f) {
            Err(SecantError::NotConverged(r)) => {
                assert_eq!(r.x, 0.3);
                assert!((r.best_abs_f() - 0.05).abs() < 1e-12, "{r:?}");
            }
            other => panic!("{other:?}"),
        }
        // Unclipped, the secant step to ≈ 0.35 fails and is retried at the midpoint toward
        // 0.21 (≈ 0.28), which succeeds; the root itself stays unreachable.
        let mut tried = vec![];
        let err = secant(0.2, &settings(), |x| {
            tried.push(x);
            f(x)
        });
        assert!((tried[2] - 0.35).abs() < 1e-12 && (tried[3] - 0.28).abs() < 1e-12);
        assert!(err.is_err(), "{tried:?}");
    }

    #[test]
    fn aborts_nan_and_bad_input_are_errors() {
        let abort = secant(0.0, &settings(), |x| {
            if x == 0.0 {
                value(1.0, 0.0).map_err(|_| StepError::Abort("x"))
            } else {
                Err(StepError::Abort("no equilibrium"))
            }
        });
        assert!(matches!(
            abort,
            Err(SecantError::Eval {
                source: "no equilibrium",
                ..
            })
        ));
        let nan = secant(0.0, &settings(), |_| value(f64::NAN, 1.0));
        assert!(matches!(nan, Err(SecantError::NonFinite(_))));
        let bad = SecantSettings {
            first_step: 0.0,
            ..settings()
        };
        assert!(matches!(
            secant(0.0, &bad, |x| value(x, 0.0)),
            Err(SecantError::InvalidInput(_))
        ));
    }
}
