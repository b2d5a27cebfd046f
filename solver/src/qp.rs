//! Small convex quadratic programs through the interior-point solver `clarabel`, with an
//! exact active-set polish.
//!
//! [`nonnegative_least_squares`] solves `min ½ |A x + b|²` subject to `x ≥ 0` (the
//! compression estimate of seed 000 Eqs. 3–4 for any stack size). clarabel works on
//! `min ½ xᵀ P x + qᵀ x` subject to `G x + s = h`, `s ∈ K`; here `P = AᵀA` (its upper
//! triangle), `q = Aᵀb`, `G = −I`, `h = 0`, `K` the non-negative orthant. An interior-point
//! answer is accurate to its tolerances (about 1e-8 relative), so it is *polished*: the
//! coordinates it leaves clearly positive form the free set, the unconstrained least-squares
//! solution on that set is taken if it is non-negative and satisfies the optimality
//! conditions (the gradient `Aᵀ(Ax + b)` is zero on the free set and non-negative on the
//! rest), and then the result is exact to rounding, as an active-set method's would be.

use nalgebra::{DMatrix, DVector};

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};

/// A QP that could not be solved.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum QpError {
    /// The input has mismatched sizes or non-finite entries.
    #[error("invalid QP: {0}")]
    Invalid(String),
    /// clarabel did not reach a solution.
    #[error("clarabel stopped with status {0}")]
    Solver(String),
}

/// `argmin ½ |A x + b|²` subject to `x ≥ 0` (module documentation); `A` is `m × n`.
pub fn nonnegative_least_squares(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
) -> Result<DVector<f64>, QpError> {
    let (m, n) = a.shape();
    if b.len() != m {
        return Err(QpError::Invalid(format!(
            "A is {m} × {n} but b has {} entries",
            b.len()
        )));
    }
    if !a.iter().chain(b.iter()).all(|v| v.is_finite()) {
        return Err(QpError::Invalid("A or b has non-finite entries".into()));
    }
    if n == 0 {
        return Ok(DVector::zeros(0));
    }
    let ata = a.transpose() * a;
    let atb = a.transpose() * b;
    // Upper triangle of AᵀA in compressed columns.
    let (mut colptr, mut rowval, mut nzval) = (vec![0], vec![], vec![]);
    for j in 0..n {
        for i in 0..=j {
            rowval.push(i);
            nzval.push(ata[(i, j)]);
        }
        colptr.push(rowval.len());
    }
    let p = CscMatrix::new(n, n, colptr, rowval, nzval);
    let g = CscMatrix::new(n, n, (0..=n).collect(), (0..n).collect(), vec![-1.0; n]);
    let h = vec![0.0; n];
    let cones = [NonnegativeConeT(n)];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-12)
        .tol_gap_rel(1e-12)
        .tol_feas(1e-12)
        .max_iter(100)
        .build()
        .map_err(|e| QpError::Invalid(e.to_string()))?;
    let mut solver = DefaultSolver::new(&p, atb.as_slice(), &g, &h, &cones, settings)
        .map_err(|e| QpError::Invalid(format!("{e:?}")))?;
    solver.solve();
    let status = solver.solution.status;
    if !matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved) {
        return Err(QpError::Solver(format!("{status:?}")));
    }
    let x = DVector::from_iterator(n, solver.solution.x.iter().map(|v| v.max(0.0)));
    Ok(polish(a, b, &ata, &atb, x))
}

/// The exact solution near the interior-point answer `x` (module documentation): an
/// active-set refinement started from the coordinates `x` leaves clearly positive. A free
/// coordinate whose least-squares value is negative is bound, a bound one whose gradient is
/// negative is freed, until the optimality conditions hold (at most `2n` rounds, usually
/// none); `x` itself if they never do.
fn polish(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    ata: &DMatrix<f64>,
    atb: &DVector<f64>,
    x: DVector<f64>,
) -> DVector<f64> {
    let n = x.len();
    // The size of x the data imply (|Aᵀb| / max diag AᵀA), so that an all-but-zero
    // interior-point answer is not read as free.
    let diagonal = ata.diagonal().amax().max(f64::MIN_POSITIVE);
    let scale = x.amax().max(atb.amax() / diagonal).max(f64::MIN_POSITIVE);
    let mut free: Vec<bool> = x.iter().map(|&v| v > 1e-7 * scale).collect();
    let objective = |v: &DVector<f64>| 0.5 * (a * v + b).norm_squared();
    for _ in 0..2 * n + 1 {
        let columns: Vec<usize> = (0..n).filter(|&j| free[j]).collect();
        let mut exact = DVector::zeros(n);
        if !columns.is_empty() {
            let sub = a.select_columns(&columns);
            let Some(chol) = (sub.transpose() * &sub).cholesky() else {
                return x;
            };
            let y = chol.solve(&(-(sub.transpose() * b)));
            if y.iter().any(|v| *v < 0.0) {
                for (k, &j) in columns.iter().enumerate() {
                    if y[k] < 0.0 {
                        free[j] = false;
                    }
                }
                continue;
            }
            for (k, &j) in columns.iter().enumerate() {
                exact[j] = y[k];
            }
        }
        // The gradient AᵀA x + Aᵀb vanishes on the free set by construction; a negative one
        // on the bound set means that coordinate should be free.
        let gradient = ata * &exact + atb;
        let tol = 1e-9 * (atb.amax() + (ata * &exact).amax()).max(f64::MIN_POSITIVE);
        let worst = (0..n)
            .filter(|&j| !free[j] && gradient[j] < -tol)
            .min_by(|&i, &j| gradient[i].total_cmp(&gradient[j]));
        match worst {
            Some(j) => free[j] = true,
            None if objective(&exact) <= objective(&x) * (1.0 + 1e-12) + 1e-300 => return exact,
            None => return x,
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_meets_the_optimality_conditions() {
        // A 6 × 4 problem built around a known optimum: x* = (1, 0, 2, 0) with the gradient
        // g* = (0, 0.5, 0, 1.5) (zero on the free set, positive on the bound one), i.e.
        // b = −A x* + A (AᵀA)⁻¹ g*.
        let a = DMatrix::from_fn(6, 4, |i, j| {
            ((i * 7 + j * 3) % 5) as f64 - 1.5 + 0.1 * j as f64
        });
        let x_star = DVector::from_column_slice(&[1.0, 0.0, 2.0, 0.0]);
        let g_star = DVector::from_column_slice(&[0.0, 0.5, 0.0, 1.5]);
        let ata = a.transpose() * &a;
        let b = -(&a * &x_star) + &a * ata.cholesky().unwrap().solve(&g_star);
        let x = nonnegative_least_squares(&a, &b).unwrap();
        assert!((&x - &x_star).amax() < 1e-12, "{x}");
        let gradient = a.transpose() * (&a * &x + &b);
        for j in 0..4 {
            assert!(x[j] >= 0.0);
            if x[j] > 0.0 {
                assert!(gradient[j].abs() < 1e-10, "{j}: {}", gradient[j]);
            } else {
                assert!(gradient[j] > -1e-10, "{j}: {}", gradient[j]);
            }
        }
        assert_eq!((x[1], x[3]), (0.0, 0.0), "polished to the bound exactly");
        // b = 0: the optimum is x = 0.
        let zero = nonnegative_least_squares(&a, &DVector::zeros(6)).unwrap();
        assert_eq!(zero, DVector::zeros(4));
        assert!(nonnegative_least_squares(&a, &DVector::zeros(5)).is_err());
        let mut bad = a.clone();
        bad[(0, 0)] = f64::NAN;
        assert!(nonnegative_least_squares(&bad, &b).is_err());
    }
}
