//! The one finite-difference derivative-check harness of the workspace.
//!
//! Central differences of the energy are compared with the analytic gradient, and central
//! differences of the analytic gradient with the analytic Hessian. Errors are measured in the
//! max norm relative to the larger of the two vectors (or matrix columns), plus an absolute
//! floor, so near-zero entries do not produce spurious failures:
//!
//! `‖fd − analytic‖∞ ≤ rtol · max(‖fd‖∞, ‖analytic‖∞) + atol`.
//!
//! With a central step `h`, truncation error is `O(h²)` and round-off `O(ε/h)`; the default
//! relative step `1e-6` (times the configuration's length scale) balances the two at about
//! `1e-9` relative, far below the default `rtol = 1e-6`.

use crate::stencil::Stencil;
use nalgebra::SVector;
use std::fmt;

/// Options of a derivative check.
#[derive(Clone, Copy, Debug)]
pub struct FdOptions {
    /// Absolute central-difference step, in the units of the DOFs.
    pub step: f64,
    /// Relative tolerance (see the module doc).
    pub rtol: f64,
    /// Absolute tolerance floor, in the units of the compared quantity.
    pub atol: f64,
}

impl FdOptions {
    /// Defaults for a configuration of characteristic length `scale` (m): step `1e-6·scale`,
    /// `rtol = 1e-6`, `atol = 1e-10` × the typical magnitude `typical` of the compared values.
    pub fn for_scale(scale: f64, typical: f64) -> Self {
        Self {
            step: 1e-6 * scale,
            rtol: 1e-6,
            atol: 1e-10 * typical.abs().max(f64::MIN_POSITIVE),
        }
    }
}

/// Which derivative failed and by how much.
#[derive(Clone, Debug)]
pub struct FdMismatch {
    /// "gradient" or "Hessian column j".
    pub what: String,
    /// Index of the worst entry.
    pub index: usize,
    /// Analytic value at that entry.
    pub analytic: f64,
    /// Finite-difference value at that entry.
    pub finite_difference: f64,
    /// Max-norm error and the tolerance it exceeded.
    pub error: f64,
    /// Tolerance that was exceeded.
    pub tolerance: f64,
}

impl fmt::Display for FdMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} mismatch at entry {}: analytic {:.12e}, finite difference {:.12e} \
             (max-norm error {:.3e} > tolerance {:.3e})",
            self.what,
            self.index,
            self.analytic,
            self.finite_difference,
            self.error,
            self.tolerance
        )
    }
}

impl std::error::Error for FdMismatch {}

/// Worst relative error seen by a passing check (for reporting).
#[derive(Clone, Copy, Debug, Default)]
pub struct FdReport {
    /// Largest `‖fd − analytic‖∞ / max(‖fd‖∞, ‖analytic‖∞)` over the gradient.
    pub gradient_rel_error: f64,
    /// Same over all Hessian columns.
    pub hessian_rel_error: f64,
}

fn compare(
    what: String,
    analytic: &[f64],
    fd: &[f64],
    opts: &FdOptions,
) -> Result<f64, FdMismatch> {
    let scale = analytic
        .iter()
        .chain(fd)
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let (mut worst, mut index) = (0.0f64, 0);
    for (i, (a, b)) in analytic.iter().zip(fd).enumerate() {
        let e = (a - b).abs();
        // NaN counts as the worst error, so a NaN derivative never passes.
        if e > worst || e.is_nan() {
            worst = e;
            index = i;
        }
    }
    let tolerance = opts.rtol * scale + opts.atol;
    if worst > tolerance || worst.is_nan() {
        return Err(FdMismatch {
            what,
            index,
            analytic: analytic[index],
            finite_difference: fd[index],
            error: worst,
            tolerance,
        });
    }
    Ok(if scale > 0.0 { worst / scale } else { 0.0 })
}

/// Checks `gradient` against central differences of `energy` at `q`.
pub fn check_gradient(
    energy: impl Fn(&[f64]) -> f64,
    gradient: &[f64],
    q: &[f64],
    opts: &FdOptions,
) -> Result<f64, FdMismatch> {
    let mut qp = q.to_vec();
    let fd: Vec<f64> = (0..q.len())
        .map(|i| {
            qp[i] = q[i] + opts.step;
            let ep = energy(&qp);
            qp[i] = q[i] - opts.step;
            let em = energy(&qp);
            qp[i] = q[i];
            (ep - em) / (2.0 * opts.step)
        })
        .collect();
    compare("gradient".into(), gradient, &fd, opts)
}

/// Checks the column-major `hessian` against central differences of `gradient` at `q`.
pub fn check_hessian(
    gradient: impl Fn(&[f64]) -> Vec<f64>,
    hessian: &[f64],
    q: &[f64],
    opts: &FdOptions,
) -> Result<f64, FdMismatch> {
    let n = q.len();
    let mut qp = q.to_vec();
    let mut worst = 0.0f64;
    for j in 0..n {
        qp[j] = q[j] + opts.step;
        let gp = gradient(&qp);
        qp[j] = q[j] - opts.step;
        let gm = gradient(&qp);
        qp[j] = q[j];
        let fd: Vec<f64> = gp
            .iter()
            .zip(&gm)
            .map(|(a, b)| (a - b) / (2.0 * opts.step))
            .collect();
        let col = &hessian[n * j..n * (j + 1)];
        worst = worst.max(compare(format!("Hessian column {j}"), col, &fd, opts)?);
    }
    // The Hessian must also be symmetric to the same tolerance.
    let transposed: Vec<f64> = (0..n * n).map(|k| hessian[(k / n) + n * (k % n)]).collect();
    compare("Hessian symmetry".into(), hessian, &transposed, opts)?;
    Ok(worst)
}

/// Checks both derivatives of a [`Stencil`] at `q`.
pub fn check_stencil<const N: usize, S: Stencil<N>>(
    stencil: &S,
    q: &SVector<f64, N>,
    gradient_opts: &FdOptions,
    hessian_opts: &FdOptions,
) -> Result<FdReport, FdMismatch> {
    let eval = stencil.eval(q);
    let energy_only = stencil.energy(q);
    let consistency = FdOptions {
        rtol: 1e-12,
        ..*gradient_opts
    };
    compare(
        "energy() vs eval().energy".into(),
        &[eval.energy],
        &[energy_only],
        &consistency,
    )?;
    let as_vec = |x: &[f64]| SVector::<f64, N>::from_column_slice(x);
    let gradient_rel_error = check_gradient(
        |x| stencil.energy(&as_vec(x)),
        eval.gradient.as_slice(),
        q.as_slice(),
        gradient_opts,
    )?;
    let hessian_rel_error = check_hessian(
        |x| stencil.eval(&as_vec(x)).gradient.as_slice().to_vec(),
        eval.hessian.as_slice(),
        q.as_slice(),
        hessian_opts,
    )?;
    Ok(FdReport {
        gradient_rel_error,
        hessian_rel_error,
    })
}

/// Panics with a readable message when [`check_stencil`] fails; for tests.
#[track_caller]
pub fn assert_stencil_derivatives<const N: usize, S: Stencil<N>>(
    stencil: &S,
    q: &SVector<f64, N>,
    scale: f64,
) -> FdReport {
    let eval = stencil.eval(q);
    let g_typ = eval.gradient.amax();
    let h_typ = eval.hessian.amax();
    let go = FdOptions::for_scale(scale, g_typ.max(eval.energy.abs() / scale));
    let ho = FdOptions::for_scale(scale, h_typ.max(g_typ / scale));
    match check_stencil(stencil, q, &go, &ho) {
        Ok(r) => r,
        Err(e) => panic!("{e}\n  at q = {:?}", q.as_slice()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn harness_catches_a_wrong_gradient() {
        let energy = |x: &[f64]| x[0] * x[0] * x[1];
        let q = [0.7, -1.3];
        let good = [2.0 * q[0] * q[1], q[0] * q[0]];
        let bad = [2.0 * q[0] * q[1] * 1.001, q[0] * q[0]];
        let o = FdOptions::for_scale(1.0, 1.0);
        assert!(check_gradient(energy, &good, &q, &o).is_ok());
        let err = check_gradient(energy, &bad, &q, &o).unwrap_err();
        assert_eq!(err.index, 0);
    }

    #[test]
    fn harness_catches_a_wrong_or_asymmetric_hessian() {
        let grad = |x: &[f64]| vec![2.0 * x[0] * x[1], x[0] * x[0]];
        let q = [0.7, -1.3];
        let o = FdOptions::for_scale(1.0, 1.0);
        let good = [2.0 * q[1], 2.0 * q[0], 2.0 * q[0], 0.0];
        assert!(check_hessian(grad, &good, &q, &o).is_ok());
        let bad = [2.0 * q[1], 2.0 * q[0], 2.0 * q[0], 1e-3];
        assert!(check_hessian(grad, &bad, &q, &o).is_err());
    }
}
