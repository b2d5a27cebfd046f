//! The crate's error type.

use crate::newton::NewtonReport;

/// Everything that can go wrong in assembly or minimization.
///
/// Input errors (wrong lengths, out-of-range indices, changed stencil structure, invalid
/// settings) are reported before any work is done. Solver failures carry the full
/// [`NewtonReport`] of the run so that the caller can inspect the energy and residual histories;
/// [`SolveError::report`] gives uniform access to it.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// A slice argument has the wrong length.
    #[error("{what}: expected length {expected}, got {got}")]
    DimensionMismatch {
        /// Which argument.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// The problem is malformed (for example a stencil references a DOF that does not exist, or
    /// a stencil is too large for the SPD projection).
    #[error("invalid problem: {0}")]
    InvalidProblem(String),
    /// The problem's DOF count, stencil count or a stencil's DOF list differs from the one the
    /// assembler (and its sparsity pattern) was built for.
    #[error("problem structure changed since the sparsity pattern was built: {0}")]
    PatternChanged(String),
    /// A [`crate::NewtonSettings`] field is out of its valid range.
    #[error("invalid settings: {0}")]
    InvalidSettings(String),
    /// The linear constraints are malformed (index out of range, non-finite value).
    #[error("invalid constraints: {0}")]
    InvalidConstraints(String),
    /// The constraint matrix `C` does not have full row rank (a zero row, a repeated or
    /// linearly dependent row, or more constraints than the DOFs they touch).
    #[error("linear constraints are rank deficient: {0}")]
    RankDeficientConstraints(String),
    /// Symbolic analysis or workspace allocation in the sparse linear algebra failed.
    #[error("sparse linear algebra setup failed: {0}")]
    LinearAlgebra(String),
    /// The iteration limit was reached before the convergence test passed.
    #[error(
        "Newton did not converge in {} iterations (last residual {:.3e})",
        .0.iterations,
        .0.last_residual()
    )]
    NotConverged(Box<NewtonReport>),
    /// No step length satisfied the Armijo condition, even with the largest regularization.
    #[error(
        "line search failed at iteration {} (residual {:.3e})",
        .0.iterations,
        .0.last_residual()
    )]
    LineSearchFailed(Box<NewtonReport>),
    /// [`crate::NewtonSettings::stall_iterations`] iterations lowered neither the residual by
    /// half nor the energy beyond its rounding allowance.
    #[error(
        "Newton stalled at iteration {} (residual {:.3e}, unchanged beyond rounding over the \
         last iterations)",
        .0.iterations,
        .0.last_residual()
    )]
    Stalled(Box<NewtonReport>),
    /// The energy, gradient or Hessian was NaN or infinite at an accepted iterate.
    #[error("non-finite energy, gradient or Hessian at iteration {}", .0.iterations)]
    NonFinite(Box<NewtonReport>),
    /// The Newton system could not be factorized or solved, even with the largest
    /// regularization.
    #[error("factorization failed at iteration {}: {detail}", .report.iterations)]
    FactorizationFailed {
        /// The run up to the failure.
        report: Box<NewtonReport>,
        /// What the linear algebra reported for the last attempt.
        detail: String,
    },
    /// Implicit differentiation at a point whose reduced Hessian is not positive definite:
    /// not a strict constrained minimizer, so its sensitivities are not defined.
    #[error("sensitivities need a strict constrained minimizer: {0}")]
    NotAStrictMinimum(String),
}

impl SolveError {
    /// The report of the failed run, for the variants that carry one.
    pub fn report(&self) -> Option<&NewtonReport> {
        match self {
            Self::NotConverged(r)
            | Self::LineSearchFailed(r)
            | Self::NonFinite(r)
            | Self::Stalled(r) => Some(r),
            Self::FactorizationFailed { report, .. } => Some(report),
            _ => None,
        }
    }
}
