//! Safeguarded one-dimensional root finding in a sign-change bracket
//!
//! [`find_root`] solves `f(x) = 0` for a scalar `f` given a bracket `[lo, hi]` with
//! `f(lo)` and `f(hi)` of opposite signs. Every evaluation shrinks the bracket (the evaluated
//! point replaces the endpoint whose value has its sign), so the root stays bracketed:
//!
//! - with a derivative `f'(x)` ([`RootEval::with_derivative`]) the next point is the Newton
//!   point `x − f/f'` when it lies strictly inside the bracket, the bracket midpoint otherwise
//!   (safeguarded Newton: quadratic near a simple root, never worse than bisection);
//! - without one ([`RootEval::value`]) the next point is the bracket midpoint (bisection:
//!   the bracket halves per evaluation).
//!
//! **Convergence** (checked after each evaluation, in this order):
//!
//! 1. `f(x) = 0` exactly, or `|f(x)| ≤ f_atol`;
//! 2. the bracket is narrow: `hi − lo ≤ x_atol + x_rtol · max(|lo|, |hi|)`;
//! 3. with a derivative of the bracket's orientation (`f' > 0` when `f(lo) < 0`), the Newton
//!    correction is small: `|f/f'| ≤ newton_rtol · |x|`;
//! 4. no floating-point number lies strictly inside the bracket (the midpoint rounds to an
//!    endpoint): the midpoint is returned — the root to the last bit.
//!
//! In cases 1–3 the returned root is the last iterate plus its Newton correction when a
//! derivative of the bracket's orientation is known (`x − f/f'`, one more Newton step for
//! free), the last iterate otherwise.
//!
//! **Failure.** Not converging within `max_iterations` evaluations is
//! [`RootError::NotConverged`] with a [`RootReport`]; a bracket without a sign change,
//! non-finite input, a NaN value of `f`, or an error of the user function are `Err`s too.
//!
//! Without a bracket, [`secant()`] starts from one point (secant steps, or Newton's where an
//! evaluation brings its derivative; Illinois-safeguarded regula falsi once a sign change is
//! found).

mod secant;

pub use secant::{SecantError, SecantEval, SecantReport, SecantRoot, SecantSettings, secant};

/// One evaluation of the function: its value and, optionally, its derivative.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootEval {
    /// `f(x)`.
    pub f: f64,
    /// `f'(x)`, if known (enables Newton steps).
    pub df: Option<f64>,
}

impl RootEval {
    /// A value without derivative (bisection steps).
    pub fn value(f: f64) -> Self {
        Self { f, df: None }
    }

    /// A value with its derivative (safeguarded Newton steps).
    pub fn with_derivative(f: f64, df: f64) -> Self {
        Self { f, df: Some(df) }
    }
}

/// A sign-change bracket: `lo < hi` and `f(lo)`, `f(hi)` nonzero with opposite signs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bracket {
    /// Lower end (units of `x`).
    pub lo: f64,
    /// Upper end (units of `x`).
    pub hi: f64,
    /// `f(lo)`.
    pub f_lo: f64,
    /// `f(hi)`.
    pub f_hi: f64,
}

/// Tolerances and limits of [`find_root`] (module documentation for the tests).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootSettings {
    /// Absolute bracket-width tolerance (units of `x`). Default 0.
    pub x_atol: f64,
    /// Relative bracket-width tolerance (unitless). Default `4 ε ≈ 8.9e-16`.
    pub x_rtol: f64,
    /// Absolute tolerance on `|f|` (units of `f`). Default 0 (only exact zeros).
    pub f_atol: f64,
    /// Relative tolerance on the Newton correction `|f/f'| / |x|` (unitless). Default `4 ε`.
    pub newton_rtol: f64,
    /// Most evaluations of `f` (the bracket ends given are not counted). Default 200.
    pub max_iterations: usize,
}

impl Default for RootSettings {
    fn default() -> Self {
        Self {
            x_atol: 0.0,
            x_rtol: 4.0 * f64::EPSILON,
            f_atol: 0.0,
            newton_rtol: 4.0 * f64::EPSILON,
            max_iterations: 200,
        }
    }
}

/// A root found by [`find_root`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Root {
    /// The root (units of `x`).
    pub x: f64,
    /// The state of the iteration when it stopped.
    pub report: RootReport,
}

/// The state of a [`find_root`] iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootReport {
    /// Evaluations of `f` made.
    pub iterations: usize,
    /// Last evaluated point (units of `x`).
    pub x: f64,
    /// `f` there.
    pub f: f64,
    /// The bracket `[lo, hi]` at the end (units of `x`).
    pub bracket: [f64; 2],
}

/// Errors of [`find_root`].
#[derive(Debug, thiserror::Error)]
pub enum RootError<E> {
    /// The bracket or start point is invalid (non-finite, `lo ≥ hi`, start outside).
    #[error("invalid root-finding input: {0}")]
    InvalidInput(String),
    /// `f(lo)` and `f(hi)` do not have opposite signs (or one of them is NaN).
    #[error("no sign change in the bracket [{lo}, {hi}]: f(lo) = {f_lo}, f(hi) = {f_hi}")]
    NoSignChange {
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
        /// `f(lo)`.
        f_lo: f64,
        /// `f(hi)`.
        f_hi: f64,
    },
    /// `f` was NaN at an iterate, or the returned root is not finite.
    #[error("non-finite value at x = {}", .0.x)]
    NonFinite(RootReport),
    /// No convergence test passed within the iteration limit.
    #[error(
        "root not converged in {} evaluations (bracket [{}, {}], f = {:.3e} at x = {})",
        .0.iterations, .0.bracket[0], .0.bracket[1], .0.f, .0.x
    )]
    NotConverged(RootReport),
    /// The user function failed.
    #[error("function evaluation failed at x = {x}: {source}")]
    Eval {
        /// Where.
        x: f64,
        /// The user function's error.
        source: E,
    },
}

/// Finds a root of `f` in `bracket` (module documentation), starting at `x0` (the bracket
/// midpoint when `None`).
pub fn find_root<E>(
    bracket: Bracket,
    x0: Option<f64>,
    settings: &RootSettings,
    mut f: impl FnMut(f64) -> Result<RootEval, E>,
) -> Result<Root, RootError<E>> {
    let Bracket {
        mut lo,
        mut hi,
        f_lo,
        f_hi,
    } = bracket;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(RootError::InvalidInput(format!(
            "bracket [{lo}, {hi}] must be finite with lo < hi"
        )));
    }
    let increasing = f_lo < 0.0 && f_hi > 0.0;
    if !(increasing || (f_lo > 0.0 && f_hi < 0.0)) {
        return Err(RootError::NoSignChange { lo, hi, f_lo, f_hi });
    }
    let mut x = x0.unwrap_or(0.5 * (lo + hi));
    if !(x >= lo && x <= hi) {
        return Err(RootError::InvalidInput(format!(
            "start {x} outside the bracket [{lo}, {hi}]"
        )));
    }
    let report = |iterations, x, f, lo, hi| RootReport {
        iterations,
        x,
        f,
        bracket: [lo, hi],
    };
    let mut fx = f64::NAN;
    for iteration in 1..=settings.max_iterations {
        let RootEval { f: value, df } = f(x).map_err(|source| RootError::Eval { x, source })?;
        fx = value;
        if fx.is_nan() {
            return Err(RootError::NonFinite(report(iteration, x, fx, lo, hi)));
        }
        if (fx < 0.0) == increasing {
            lo = x;
        } else {
            hi = x;
        }
        // A derivative of the bracket's orientation: its Newton correction points inward.
        let oriented = df.filter(|&d| if increasing { d > 0.0 } else { d < 0.0 });
        let converged = fx == 0.0
            || fx.abs() <= settings.f_atol
            || hi - lo <= settings.x_atol + settings.x_rtol * lo.abs().max(hi.abs())
            || oriented.is_some_and(|d| (fx / d).abs() <= settings.newton_rtol * x.abs());
        if converged {
            let root = x - oriented.map_or(0.0, |d| fx / d);
            let r = report(iteration, x, fx, lo, hi);
            return if root.is_finite() {
                Ok(Root { x: root, report: r })
            } else {
                Err(RootError::NonFinite(r))
            };
        }
        let newton = df.map(|d| x - fx / d).filter(|&n| n > lo && n < hi);
        x = match newton {
            Some(n) => n,
            None => {
                let mid = 0.5 * (lo + hi);
                if !(mid > lo && mid < hi) {
                    return Ok(Root {
                        x: mid,
                        report: report(iteration, x, fx, lo, hi),
                    });
                }
                mid
            }
        };
    }
    Err(RootError::NotConverged(report(
        settings.max_iterations,
        x,
        fx,
        lo,
        hi,
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::convert::Infallible;

    fn cubic(x: f64) -> f64 {
        // Roots 1, 2, 3.
        (x - 1.0) * (x - 2.0) * (x - 3.0)
    }

    fn bracket(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> Bracket {
        Bracket {
            lo,
            hi,
            f_lo: f(lo),
            f_hi: f(hi),
        }
    }

    #[test]
    fn bisection_finds_the_root_to_the_last_bit() {
        let root = find_root(
            bracket(cubic, 1.5, 2.7),
            None,
            &RootSettings {
                x_rtol: 0.0,
                ..RootSettings::default()
            },
            |x| Ok::<_, Infallible>(RootEval::value(cubic(x))),
        )
        .unwrap();
        assert!((root.x - 2.0).abs() <= f64::EPSILON * 2.0, "{root:?}");
        // Roughly one bit per evaluation.
        assert!((45..=60).contains(&root.report.iterations), "{root:?}");
    }

    #[test]
    fn newton_converges_quadratically_on_a_decreasing_function() {
        // f(x) = 2 − x² on [0, 3]: decreasing, root √2.
        let mut evaluations = 0;
        let root = find_root(
            bracket(|x| 2.0 - x * x, 0.0, 3.0),
            None,
            &RootSettings::default(),
            |x| {
                evaluations += 1;
                Ok::<_, Infallible>(RootEval::with_derivative(2.0 - x * x, -2.0 * x))
            },
        )
        .unwrap();
        assert!(
            (root.x - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON,
            "{root:?}"
        );
        assert!(evaluations <= 8, "{evaluations}");
    }

    #[test]
    fn newton_steps_leaving_the_bracket_fall_back_to_bisection() {
        // atan: Newton from far out overshoots wildly; the bracket keeps it safe.
        let root = find_root(
            bracket(f64::atan, -1.0, 20.0),
            Some(15.0),
            &RootSettings::default(),
            |x| Ok::<_, Infallible>(RootEval::with_derivative(x.atan(), 1.0 / (1.0 + x * x))),
        )
        .unwrap();
        assert!(root.x.abs() < 1e-15, "{root:?}");
    }

    #[test]
    fn tolerances_in_x_and_f_stop_early() {
        let loose = |settings: RootSettings| {
            find_root(bracket(cubic, 2.5, 3.7), None, &settings, |x| {
                Ok::<_, Infallible>(RootEval::value(cubic(x)))
            })
            .unwrap()
        };
        let by_x = loose(RootSettings {
            x_atol: 1e-3,
            ..RootSettings::default()
        });
        assert!(by_x.report.bracket[1] - by_x.report.bracket[0] <= 1e-3);
        assert!((by_x.x - 3.0).abs() <= 1e-3);
        let by_f = loose(RootSettings {
            f_atol: 1e-2,
            ..RootSettings::default()
        });
        assert!(cubic(by_f.x).abs() <= 1e-2 && by_f.report.iterations < 20);
    }

    #[test]
    fn bad_brackets_are_errors() {
        let run = |b: Bracket| {
            find_root(b, None, &RootSettings::default(), |x| {
                Ok::<_, Infallible>(RootEval::value(cubic(x)))
            })
        };
        assert!(matches!(
            run(bracket(cubic, 1.5, 1.8)),
            Err(RootError::NoSignChange { .. })
        ));
        assert!(matches!(
            run(bracket(cubic, 2.5, 1.5)),
            Err(RootError::InvalidInput(_))
        ));
        assert!(matches!(
            run(bracket(cubic, f64::NAN, 2.5)),
            Err(RootError::InvalidInput(_))
        ));
    }

    #[test]
    fn iteration_limit_nan_and_user_errors_are_reported() {
        let b = bracket(cubic, 1.5, 2.7);
        let few = RootSettings {
            max_iterations: 3,
            ..RootSettings::default()
        };
        let err = find_root(b, None, &few, |x| {
            Ok::<_, Infallible>(RootEval::value(cubic(x)))
        })
        .unwrap_err();
        match err {
            RootError::NotConverged(r) => {
                assert_eq!(r.iterations, 3);
                assert!(r.bracket[0] <= 2.0 && 2.0 <= r.bracket[1]);
            }
            e => panic!("{e}"),
        }
        let nan = find_root(b, None, &RootSettings::default(), |_| {
            Ok::<_, Infallible>(RootEval::value(f64::NAN))
        });
        assert!(matches!(nan, Err(RootError::NonFinite(_))));
        let failed = find_root(b, None, &RootSettings::default(), |_| Err("no equilibrium"));
        assert!(matches!(
            failed,
            Err(RootError::Eval {
                source: "no equilibrium",
                ..
            })
        ));
    }
}
