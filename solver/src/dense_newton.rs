//! A small dense Newton method for `N` equations in `N` unknowns
//!
//! [`newton_dense`] solves `r(x) = 0` for `r: ℝᴺ → ℝᴺ` with `N` small (a few unknowns, every
//! residual perhaps an expensive nonlinear solve). Iteration `k`:
//!
//! 1. evaluate `r(x)` ([`Probe::Point`]); converged when `max_i |r_i| ≤ residual_tol`;
//! 2. the Jacobian is the evaluation's own ([`DenseEval::jacobian`]) or, without one,
//!    forward differences: column `j` is `(r(x + h e_j) − r(x)) / h` with `h = fd_step`
//!    (`N` more evaluations, [`Probe::Column`]`(j)`, so a caller can warm-start them from
//!    the state at `x`);
//! 3. the Newton step `d = −J⁻¹ r` (nalgebra's `try_inverse`, closed form for `N ≤ 4`) is
//!    damped to `max_i |d_i| ≤ max_step`: `x ← x + min(1, max_step / max_i |d_i|) · d`.
//!
//! **Failure** is loud: a singular Jacobian or a non-finite step is
//! [`DenseNewtonError::Singular`], a non-finite residual [`DenseNewtonError::NonFinite`],
//! `max_iterations` residual evaluations at iterates without convergence
//! [`DenseNewtonError::NotConverged`] — each with a [`DenseNewtonReport`]; the user
//! function's error is [`DenseNewtonError::Eval`].

use nalgebra::{SMatrix, SVector};

/// What an evaluation of [`newton_dense`] is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probe {
    /// The residual at an iterate.
    Point,
    /// A finite-difference probe `x + h e_j` of Jacobian column `j` around the last iterate.
    Column(usize),
}

/// One evaluation: the residual, optionally its Jacobian, and the caller's data.
#[derive(Clone, Debug)]
pub struct DenseEval<T, const N: usize> {
    /// `r(x)`.
    pub residual: [f64; N],
    /// `∂r/∂x` (`J[(i, j)] = ∂r_i/∂x_j`) if known; finite differences otherwise.
    pub jacobian: Option<SMatrix<f64, N, N>>,
    /// What the evaluation produced besides `r` (returned with the root).
    pub data: T,
}

/// Settings of [`newton_dense`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DenseNewtonSettings {
    /// Converged when `max_i |r_i| ≤ residual_tol` (units of `r`, ≥ 0).
    pub residual_tol: f64,
    /// Most residual evaluations at iterates.
    pub max_iterations: usize,
    /// Forward-difference step `h` of the Jacobian (units of `x`, > 0).
    pub fd_step: f64,
    /// Largest component of a step (units of `x`, > 0; `∞` for undamped Newton).
    pub max_step: f64,
}

/// A root found by [`newton_dense`].
#[derive(Clone, Debug)]
pub struct DenseRoot<T, const N: usize> {
    /// The root.
    pub x: [f64; N],
    /// The residual there (within tolerance).
    pub residual: [f64; N],
    /// The evaluation's data there.
    pub data: T,
    /// Newton steps taken before it (0: the start was a root).
    pub iterations: usize,
}

/// The state of a failed [`newton_dense`] iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DenseNewtonReport<const N: usize> {
    /// Residual evaluations at iterates.
    pub iterations: usize,
    /// The last iterate.
    pub x: [f64; N],
    /// `max_i |r_i|` there.
    pub residual_norm: f64,
}

/// Errors of [`newton_dense`] (`NotConverged` reports the last evaluated iterate).
#[derive(Debug, thiserror::Error)]
pub enum DenseNewtonError<E, const N: usize> {
    /// Invalid settings or start point.
    #[error("invalid dense Newton input: {0}")]
    InvalidInput(String),
    /// The Jacobian is singular (or the step is not finite).
    #[error("singular Jacobian at x = {:?} (|r| = {:.3e})", .0.x, .0.residual_norm)]
    Singular(DenseNewtonReport<N>),
    /// A residual (or Jacobian) entry is not finite.
    #[error("non-finite residual at x = {:?}", .0.x)]
    NonFinite(DenseNewtonReport<N>),
    /// No convergence within the iteration limit.
    #[error(
        "dense Newton not converged in {} iterations (|r| = {:.3e} at x = {:?})",
        .0.iterations, .0.residual_norm, .0.x
    )]
    NotConverged(DenseNewtonReport<N>),
    /// The user function failed.
    #[error("function evaluation failed at x = {x:?}")]
    Eval {
        /// Where.
        x: [f64; N],
        /// The user function's error.
        source: E,
    },
}

/// `max_i |v_i|`.
fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m: f64, e| m.max(e.abs()))
}

/// Solves `r(x) = 0` from `x0` (module documentation). `f(x, probe)` evaluates `r`.
pub fn newton_dense<T, E, const N: usize>(
    x0: [f64; N],
    settings: &DenseNewtonSettings,
    mut f: impl FnMut(&[f64; N], Probe) -> Result<DenseEval<T, N>, E>,
) -> Result<DenseRoot<T, N>, DenseNewtonError<E, N>> {
    let DenseNewtonSettings {
        residual_tol,
        max_iterations,
        fd_step: h,
        max_step,
    } = *settings;
    if !(residual_tol >= 0.0 && h.is_finite() && h > 0.0 && max_step > 0.0) {
        return Err(DenseNewtonError::InvalidInput(format!(
            "need residual_tol ≥ 0, a finite fd_step > 0 and max_step > 0 (got {settings:?})"
        )));
    }
    if x0.iter().any(|v| !v.is_finite()) {
        return Err(DenseNewtonError::InvalidInput(format!(
            "start {x0:?} is not finite"
        )));
    }
    let mut x = x0;
    // The last evaluated iterate and its residual norm, for the failure report.
    let mut last = (x0, f64::NAN);
    let mut eval = |x: &[f64; N], probe| {
        f(x, probe).map_err(|source| DenseNewtonError::Eval { x: *x, source })
    };
    for iteration in 0..max_iterations {
        let DenseEval {
            residual: r,
            jacobian,
            data,
        } = eval(&x, Probe::Point)?;
        let report = |residual_norm| DenseNewtonReport {
            iterations: iteration + 1,
            x,
            residual_norm,
        };
        if r.iter().any(|v| !v.is_finite()) {
            return Err(DenseNewtonError::NonFinite(report(f64::NAN)));
        }
        let norm = max_abs(&r);
        last = (x, norm);
        if norm <= residual_tol {
            return Ok(DenseRoot {
                x,
                residual: r,
                data,
                iterations: iteration,
            });
        }
        drop(data);
        let jac = match jacobian {
            Some(j) => j,
            None => {
                let mut jac = SMatrix::<f64, N, N>::zeros();
                for k in 0..N {
                    let mut probe = x;
                    probe[k] += h;
                    let e = eval(&probe, Probe::Column(k))?;
                    for i in 0..N {
                        jac[(i, k)] = (e.residual[i] - r[i]) / h;
                    }
                }
                jac
            }
        };
        if jac.iter().any(|v| !v.is_finite()) {
            return Err(DenseNewtonError::NonFinite(report(norm)));
        }
        let step = jac
            .try_inverse()
            .map(|inv| -(inv * SVector::<f64, N>::from(r)))
            .filter(|d| d.iter().all(|v| v.is_finite()))
            .ok_or_else(|| DenseNewtonError::Singular(report(norm)))?;
        let scale = (max_step / step.amax()).min(1.0);
        for (xi, di) in x.iter_mut().zip(step.iter()) {
            *xi += scale * di;
        }
    }
    Err(DenseNewtonError::NotConverged(DenseNewtonReport {
        iterations: max_iterations,
        x: last.0,
        residual_norm: last.1,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::convert::Infallible;

    fn settings() -> DenseNewtonSettings {
        DenseNewtonSettings {
            residual_tol: 1e-12,
            max_iterations: 30,
            fd_step: 1e-7,
            max_step: f64::INFINITY,
        }
    }

    /// Circle ∩ line: x² + y² = 4, y = x − 1 … roots ((1 ± √7)/2, (−1 ± √7)/2).
    fn circle_line(v: &[f64; 2]) -> [f64; 2] {
        [v[0] * v[0] + v[1] * v[1] - 4.0, v[1] - v[0] + 1.0]
    }

    #[test]
    fn finite_differences_and_analytic_jacobians_converge() {
        let exact = [(1.0 + 7f64.sqrt()) / 2.0, (-1.0 + 7f64.sqrt()) / 2.0];
        let mut probes = vec![];
        let fd = newton_dense([2.0, 1.0], &settings(), |v, probe| {
            probes.push(probe);
            Ok::<_, Infallible>(DenseEval {
                residual: circle_line(v),
                jacobian: None,
                data: (),
            })
        })
        .unwrap();
        assert!((fd.x[0] - exact[0]).abs() < 1e-10 && (fd.x[1] - exact[1]).abs() < 1e-10);
        assert_eq!(
            probes[..3],
            [Probe::Point, Probe::Column(0), Probe::Column(1)]
        );
        let analytic = newton_dense([2.0, 1.0], &settings(), |v, _| {
            Ok::<_, Infallible>(DenseEval {
                residual: circle_line(v),
                jacobian: Some(SMatrix::<f64, 2, 2>::new(2.0 * v[0], 2.0 * v[1], -1.0, 1.0)),
                data: v[0] + v[1],
            })
        })
        .unwrap();
        assert!(analytic.iterations <= 6, "{}", analytic.iterations);
        assert!((analytic.data - 7f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn steps_are_damped_to_max_step() {
        let mut points = vec![];
        let damped = DenseNewtonSettings {
            max_step: 0.05,
            ..settings()
        };
        newton_dense([0.0], &damped, |v, probe| {
            if probe == Probe::Point {
                points.push(v[0]);
            }
            Ok::<_, Infallible>(DenseEval {
                residual: [v[0] - 1.0],
                jacobian: Some(SMatrix::<f64, 1, 1>::new(1.0)),
                data: (),
            })
        })
        .unwrap();
        assert!(points.windows(2).all(|w| w[1] - w[0] <= 0.05 + 1e-15));
        assert_eq!(points.len(), 21);
    }

    #[test]
    fn singular_nonconverged_nonfinite_and_user_errors_are_reported() {
        let flat = newton_dense([1.0, 1.0], &settings(), |_, _| {
            Ok::<_, Infallible>(DenseEval {
                residual: [1.0, 1.0],
                jacobian: None,
                data: (),
            })
        });
        assert!(matches!(flat, Err(DenseNewtonError::Singular(_))));
        let few = DenseNewtonSettings {
            max_iterations: 2,
            max_step: 0.01,
            ..settings()
        };
        match newton_dense([2.0, 1.0], &few, |v, _| {
            Ok::<_, Infallible>(DenseEval {
                residual: circle_line(v),
                jacobian: None,
                data: (),
            })
        }) {
            Err(DenseNewtonError::NotConverged(r)) => {
                assert_eq!(r.iterations, 2);
                assert!(r.residual_norm > 0.1);
            }
            other => panic!("{other:?}"),
        }
        let nan = newton_dense([0.0], &settings(), |_, _| {
            Ok::<_, Infallible>(DenseEval {
                residual: [f64::NAN],
                jacobian: None,
                data: (),
            })
        });
        assert!(matches!(nan, Err(DenseNewtonError::NonFinite(_))));
        let failed = newton_dense([0.0], &settings(), |_, _| {
            Err::<DenseEval<(), 1>, _>("no equilibrium")
        });
        assert!(matches!(
            failed,
            Err(DenseNewtonError::Eval {
                source: "no equilibrium",
                ..
            })
        ));
    }
}
