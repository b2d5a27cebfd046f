//! Jacobi-preconditioned conjugate gradients for the symmetric positive definite systems of
//! Newton's method (an alternative to the sparse Cholesky factorization for large problems).
//!
//! Solves `(A + μ I) x = b` for `A` given by its lower triangle in CSC form (the storage of
//! [`crate::Assembler`]), starting from `x₀ = 0` (Saad 2003, *Iterative Methods for Sparse
//! Linear Systems*, Alg. 9.1), with one of two preconditioners ([`Preconditioner`]):
//!
//! - Jacobi, `P = diag(A + μ I)`: parallel and cheap, but blind to the stiff couplings along
//!   a yarn;
//! - incomplete Cholesky without fill, IC(0) (Saad §10.3): `P = L̃ L̃ᵀ` with `L̃` on the
//!   lower-triangle pattern of `A`, factorized for every solve; if a pivot is not positive,
//!   the factorization is retried on `A + μI + σ diag(A + μI)` with `σ = 10⁻³, 10⁻², …, 1`
//!   (Manteuffel's shift). Its (left-looking) factorization and triangular solves are serial.
//!
//! **Warm start** ([`PcgSettings::warm_start`]): the iteration starts from the `x` passed in
//! (e.g. the previous time step's solution) instead of zero, `r₀ = b − (A + μI) x`. The
//! stopping test stays relative to `‖b‖₂`. A warm-started solution need not be a descent
//! direction of the quadratic model (Newton runs with a line search keep the default).
//!
//! It stops when `‖r_k‖₂ ≤ tol · ‖b‖₂` and fails loudly otherwise:
//!
//! - a non-positive diagonal entry or a direction with `pᵀ(A + μI)p ≤ 0` proves the matrix is
//!   not positive definite ([`PcgFailure::Indefinite`]; the direction stays available,
//!   [`Pcg::negative_curvature`]);
//! - no convergence within the iteration cap ([`PcgFailure::NotConverged`]).
//!
//! Started from zero, every CG iterate is a descent direction of the quadratic model, so a
//! Newton step from a converged solve is one as well.
//!
//! **Determinism.** The full symmetric pattern is built once (rows of `A` in CSR form, with the
//! index of each entry in the lower-triangle value array). The product `A p` is parallel over
//! fixed blocks of rows, each row summed serially; dot products are summed in fixed chunks,
//! whose partial sums are added serially in chunk order. Results are therefore bit-identical
//! for any rayon thread count.

use faer::sparse::SparseColMatRef;
use rayon::prelude::*;

use crate::SolveError;
use crate::pattern::counting_sort;

/// Row and column indices of the CG matrix and the IC(0) factor: 32 bits, so that every
/// product and triangular solve reads 8 + 4 instead of 8 + 8 bytes per stored entry;
/// [`Pcg::new`] rejects systems of more than `u32::MAX` unknowns.
type Index = u32;

/// Rows (or vector entries) per parallel task; fixed so that summation order, and hence the
/// result, does not depend on the thread count.
const CHUNK: usize = 4096;

/// The preconditioner of [`Pcg::solve`] (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preconditioner {
    /// `diag(A + μI)`.
    Jacobi,
    /// Incomplete Cholesky IC(0) on the pattern of `A` (with a diagonal shift on breakdown).
    IncompleteCholesky,
}

/// Stopping rule and preconditioner of [`Pcg::solve`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgSettings {
    /// Relative tolerance on the residual: stop when `‖b − A x‖₂ ≤ relative_tolerance ‖b‖₂`
    /// (dimensionless, in `(0, 1)`).
    pub relative_tolerance: f64,
    /// Iteration cap (≥ 1); reaching it without convergence is an error.
    pub max_iterations: usize,
    /// The preconditioner.
    pub preconditioner: Preconditioner,
    /// Start from the `x` passed to [`Pcg::solve`] instead of zero (module documentation).
    pub warm_start: bool,
}

impl PcgSettings {
    /// `relative_tolerance`, `max_iterations` and `preconditioner`, started from zero.
    pub fn new(
        relative_tolerance: f64,
        max_iterations: usize,
        preconditioner: Preconditioner,
    ) -> Self {
        Self {
            relative_tolerance,
            max_iterations,
            preconditioner,
            warm_start: false,
        }
    }

    /// Checks the ranges (`0 < relative_tolerance < 1`, `max_iterations ≥ 1`).
    pub fn validate(&self) -> Result<(), SolveError> {
        if !(self.relative_tolerance > 0.0 && self.relative_tolerance < 1.0) {
            return Err(SolveError::InvalidSettings(format!(
                "PCG relative tolerance must lie in (0, 1), got {}",
                self.relative_tolerance
            )));
        }
        if self.max_iterations == 0 {
            return Err(SolveError::InvalidSettings(
                "PCG iteration cap must be ≥ 1".into(),
            ));
        }
        Ok(())
    }
}

/// A converged PCG solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgReport {
    /// Number of CG iterations (matrix–vector products, the warm start's initial residual
    /// not counted).
    pub iterations: usize,
    /// Final relative residual `‖b − (A + μI) x‖₂ / ‖b‖₂` (recursively updated; 0 for `b = 0`).
    pub relative_residual: f64,
}

/// The bytes that [`Pcg::solve`] with the IC(0) preconditioner streams from and to memory at
/// least, for `n` unknowns whose lower triangle stores `lower_nnz` entries (diagonal
/// included): the memory roofline of the solve. Every stored value counts 8 bytes and every
/// row or column index 4 (an entry) or 8 (a pointer); every vector read or written once per
/// pass counts 8 bytes per unknown; the gather of `p` in the product and the updates of
/// earlier columns in the factorization count nothing (cached at best). So the counts are
/// lower bounds, split by the parts that run in parallel (the product, the vector updates and
/// dot products, the gather of the values) and those that run serially (the triangular solves
/// and the factorization), because one core streams more slowly than all of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgTraffic {
    /// Per CG iteration, parallel: the product `(A + μI) p` over the full symmetric matrix
    /// (`12 (2 lower_nnz − n) + 24 n`), the fused update of `x`, `r`, `z` (`64 n`), two dot
    /// products (`32 n`) and the update of `p` (`24 n`).
    pub iteration_parallel: f64,
    /// Per CG iteration, serial: the forward and backward substitutions with `L̃`
    /// (`2 (12 lower_nnz + 24 n)`) and the copy of `r` (`16 n`).
    pub iteration_serial: f64,
    /// Per solve, parallel: the gather of the full symmetric values (`24 (2 lower_nnz − n)`:
    /// source index, value, copy) and the Jacobi diagonal (`16 n`).
    pub solve_parallel: f64,
    /// Per solve, serial: the IC(0) factorization (`36 lower_nnz`: the copy of the values,
    /// the row indices of each column's scatter, and the read and write of its final
    /// scaling; the row lists and the updates from earlier columns are not counted).
    pub solve_serial: f64,
}

impl PcgTraffic {
    /// The counts for `n` unknowns and `lower_nnz` stored lower-triangle entries.
    pub fn incomplete_cholesky(n: usize, lower_nnz: usize) -> Self {
        let (n, lower) = (n as f64, lower_nnz as f64);
        let full = 2.0 * lower - n;
        Self {
            iteration_parallel: 12.0 * full + 24.0 * n + 64.0 * n + 32.0 * n + 24.0 * n,
            iteration_serial: 2.0 * (12.0 * lower + 24.0 * n) + 16.0 * n,
            solve_parallel: 24.0 * full + 16.0 * n,
            solve_serial: 36.0 * lower,
        }
    }

    /// The shortest time (s) of `iterations` CG iterations and `solves` solves at the
    /// bandwidths `parallel` (all threads) and `serial` (one thread), in bytes per second.
    pub fn seconds(&self, iterations: f64, solves: f64, parallel: f64, serial: f64) -> f64 {
        iterations * (self.iteration_parallel / parallel + self.iteration_serial / serial)
            + solves * (self.solve_parallel / parallel + self.solve_serial / serial)
    }
}

/// Why a PCG solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PcgFailure {
    /// The matrix is not positive definite: a diagonal entry or a curvature `pᵀAp` is not
    /// positive (or not finite).
    #[error("PCG: matrix is not positive definite ({0})")]
    Indefinite(String),
    /// The iteration cap was reached before the tolerance.
    #[error(
        "PCG did not converge in {iterations} iterations: relative residual {relative_residual:.3e} > tolerance {tolerance:.3e}"
    )]
    NotConverged {
        /// Iterations done.
        iterations: usize,
        /// Relative residual reached.
        relative_residual: f64,
        /// The requested tolerance.
        tolerance: f64,
    },
    /// The matrix pattern or a vector length differs from the workspace's.
    #[error("PCG: invalid input ({0})")]
    Input(String),
    /// The right-hand side or a matrix entry is not finite.
    #[error("PCG: non-finite input ({0})")]
    NonFinite(String),
}

/// Reusable PCG workspace for one sparsity pattern (`n × n`, lower triangle in CSC form).
#[derive(Clone, Debug)]
pub struct Pcg {
    n: usize,
    /// Stored entries of the lower triangle the workspace was built for.
    lower_nnz: usize,
    /// Full symmetric matrix in CSR form: row `i` has entries `row_ptr[i]..row_ptr[i + 1]`.
    row_ptr: Vec<usize>,
    /// Column of each entry (32-bit, see [`Index`]).
    col_idx: Vec<Index>,
    /// Index into the lower-triangle value array of each full entry.
    source: Vec<usize>,
    /// Index into the lower-triangle value array of each diagonal entry (`usize::MAX`: none).
    diag_source: Vec<usize>,
    values: Vec<f64>,
    inv_diag: Vec<f64>,
    /// IC(0) factor on the lower pattern (built on the first IC solve).
    ic: Option<IncompleteCholesky>,
    /// The Rayleigh quotient `pᵀ(A + μI)p / pᵀp ≤ 0` of the direction `p` (kept in `p`) at
    /// which the last solve stopped as indefinite; `None` after any other outcome.
    negative_curvature: Option<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
}

impl Pcg {
    /// Builds the full symmetric pattern of the square matrix whose lower triangle has the
    /// pattern of `lower` (entries above the diagonal are ignored).
    pub fn new(lower: SparseColMatRef<'_, usize, f64>) -> Result<Self, SolveError> {
        let n = lower.nrows();
        if n > Index::MAX as usize {
            return Err(SolveError::InvalidProblem(format!(
                "PCG supports at most {} unknowns, got {n}",
                Index::MAX
            )));
        }
        if lower.ncols() != n {
            return Err(SolveError::DimensionMismatch {
                what: "PCG matrix columns",
                expected: n,
                got: lower.ncols(),
            });
        }
        let col_ptr = lower.col_ptr();
        let row_idx = lower.row_idx();
        let mut count = vec![0usize; n + 1];
        let mut diag_source = vec![usize::MAX; n];
        for j in 0..n {
            for e in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[e];
                if i > j {
                    count[i + 1] += 1;
                    count[j + 1] += 1;
                } else if i == j {
                    count[i + 1] += 1;
                    diag_source[i] = e;
                }
            }
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let row_ptr = count.clone();
        let nnz = row_ptr[n];
        let mut col_idx: Vec<Index> = vec![0; nnz];
        let mut source = vec![0usize; nnz];
        let mut next = count;
        // Columns in increasing order, so every row's entries come out sorted by column.
        for j in 0..n {
            for e in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[e];
                if i >= j {
                    col_idx[next[i]] = j as Index;
                    source[next[i]] = e;
                    next[i] += 1;
                }
            }
        }
        // Second pass: the mirrored entries (columns > row), appended to each row after its
        // lower part, again in increasing column order.
        for j in 0..n {
            for e in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[e];
                if i > j {
                    col_idx[next[j]] = i as Index;
                    source[next[j]] = e;
                    next[j] += 1;
                }
            }
        }
        Ok(Self {
            n,
            lower_nnz: col_ptr[n],
            row_ptr,
            col_idx,
            source,
            diag_source,
            values: vec![0.0; nnz],
            inv_diag: vec![0.0; n],
            ic: None,
            negative_curvature: None,
            r: vec![0.0; n],
            z: vec![0.0; n],
            p: vec![0.0; n],
            q: vec![0.0; n],
        })
    }

    /// Dimension of the system.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Solves `(A + μ I) x = b` (`A` = `lower`, the same pattern as in [`Pcg::new`]); `x` is
    /// overwritten, and read first as the start with [`PcgSettings::warm_start`]. See the
    /// [module documentation](self).
    pub fn solve(
        &mut self,
        lower: SparseColMatRef<'_, usize, f64>,
        mu: f64,
        b: &[f64],
        x: &mut [f64],
        settings: &PcgSettings,
    ) -> Result<PcgReport, PcgFailure> {
        self.check_input(lower, b, x)?;
        self.negative_curvature = None;
        self.load_matrix(lower, mu, b)?;
        if settings.preconditioner == Preconditioner::IncompleteCholesky {
            let ic = match &mut self.ic {
                Some(ic) => ic,
                None => self.ic.insert(IncompleteCholesky::new(lower)?),
            };
            ic.factorize(lower.val(), mu)?;
        }
        let b_norm = dot(b, b).sqrt();
        if b_norm == 0.0 {
            x.fill(0.0);
            return Ok(PcgReport {
                iterations: 0,
                relative_residual: 0.0,
            });
        }
        if settings.warm_start && x.iter().all(|v| v.is_finite()) {
            // r = b − (A + μI) x₀, through the product's workspace.
            self.p.copy_from_slice(x);
            self.multiply(mu);
            for ((r, &bi), &q) in self.r.iter_mut().zip(b).zip(&self.q) {
                *r = bi - q;
            }
        } else {
            x.fill(0.0);
            self.r.copy_from_slice(b);
        }
        let r_norm = dot(&self.r, &self.r).sqrt();
        if !r_norm.is_finite() {
            return Err(PcgFailure::NonFinite("initial residual".into()));
        }
        if r_norm <= settings.relative_tolerance * b_norm {
            return Ok(PcgReport {
                iterations: 0,
                relative_residual: r_norm / b_norm,
            });
        }
        for ((z, &r), &m) in self.z.iter_mut().zip(&self.r).zip(&self.inv_diag) {
            *z = m * r;
        }
        self.apply_incomplete_cholesky(settings);
        self.p.copy_from_slice(&self.z);
        let (iterations, relative_residual) = self.iterate(mu, b_norm, r_norm, x, settings)?;
        Ok(PcgReport {
            iterations,
            relative_residual,
        })
    }

    /// After a solve that stopped as indefinite at a direction `p` of non-positive curvature
    /// (a CG direction, or the unit vector of a non-positive diagonal entry): `p` and its
    /// Rayleigh quotient `pᵀ(A + μI)p / pᵀp` for that solve's shift `μ`. `None` after any
    /// other outcome and after [`Pcg::quadratic_form`] (which reuses the workspace).
    pub fn negative_curvature(&self) -> Option<(&[f64], f64)> {
        self.negative_curvature.map(|rho| (&self.p[..], rho))
    }

    /// `vᵀ A v` for `A` = `lower` (the same pattern as in [`Pcg::new`]; no shift), through the
    /// workspace's product (parallel, thread-count independent).
    pub fn quadratic_form(
        &mut self,
        lower: SparseColMatRef<'_, usize, f64>,
        v: &[f64],
    ) -> Result<f64, PcgFailure> {
        self.check_input(lower, v, v)?;
        self.negative_curvature = None;
        self.gather_values(lower);
        self.p.copy_from_slice(v);
        self.multiply(0.0);
        Ok(dot(&self.p, &self.q))
    }

    /// Checks that `lower` has the workspace's pattern size and `b`, `x` its dimension.
    fn check_input(
        &self,
        lower: SparseColMatRef<'_, usize, f64>,
        b: &[f64],
        x: &[f64],
    ) -> Result<(), PcgFailure> {
        let n = self.n;
        if lower.nrows() != n || lower.ncols() != n || lower.col_ptr()[n] != self.lower_nnz {
            return Err(PcgFailure::Input(format!(
                "matrix {} × {} with {} stored entries, workspace built for {n} × {n} with {}",
                lower.nrows(),
                lower.ncols(),
                lower.col_ptr()[lower.ncols()],
                self.lower_nnz
            )));
        }
        if b.len() != n || x.len() != n {
            return Err(PcgFailure::Input(format!(
                "vector lengths {} and {}, matrix dimension {n}",
                b.len(),
                x.len()
            )));
        }
        Ok(())
    }

    /// Gathers the full symmetric values of `lower` and the Jacobi preconditioner
    /// `diag(A + μI)⁻¹`, checking that the input is finite and the diagonal positive.
    fn load_matrix(
        &mut self,
        lower: SparseColMatRef<'_, usize, f64>,
        mu: f64,
        b: &[f64],
    ) -> Result<(), PcgFailure> {
        self.gather_values(lower);
        let lower_values = lower.val();
        if !self.values.iter().all(|v| v.is_finite()) || !mu.is_finite() {
            return Err(PcgFailure::NonFinite("matrix entry or shift".into()));
        }
        if !b.iter().all(|v| v.is_finite()) {
            return Err(PcgFailure::NonFinite("right-hand side".into()));
        }
        for i in 0..self.n {
            let d = match self.diag_source[i] {
                usize::MAX => 0.0,
                s => lower_values[s],
            } + mu;
            if d.is_nan() || d <= 0.0 {
                if !d.is_nan() {
                    // eᵢ is a direction of non-positive curvature.
                    self.p.fill(0.0);
                    self.p[i] = 1.0;
                    self.negative_curvature = Some(d);
                }
                return Err(PcgFailure::Indefinite(format!(
                    "diagonal entry {i} is {d:.3e}"
                )));
            }
            self.inv_diag[i] = 1.0 / d;
        }
        Ok(())
    }

    /// Gathers the full symmetric values of `lower` into the CSR workspace.
    fn gather_values(&mut self, lower: SparseColMatRef<'_, usize, f64>) {
        let lower_values = lower.val();
        self.values
            .par_chunks_mut(CHUNK)
            .zip(self.source.par_chunks(CHUNK))
            .for_each(|(v, s)| {
                for (vi, &si) in v.iter_mut().zip(s) {
                    *vi = lower_values[si];
                }
            });
    }

    /// With the IC(0) preconditioner, replaces `z` by `L̃⁻ᵀL̃⁻¹ r`; returns whether it did.
    fn apply_incomplete_cholesky(&mut self, settings: &PcgSettings) -> bool {
        match self
            .ic
            .as_ref()
            .filter(|_| settings.preconditioner == Preconditioner::IncompleteCholesky)
        {
            Some(ic) => {
                ic.apply(&self.r, &mut self.z);
                true
            }
            None => false,
        }
    }

    /// The CG iterations (Saad Alg. 9.1) from `x`, `r = b − (A + μI) x` (of norm `r_norm`),
    /// `z = p = P⁻¹ r`, until `‖r‖₂ ≤ tol · ‖b‖₂`; returns the iterations and the final
    /// relative residual.
    fn iterate(
        &mut self,
        mu: f64,
        b_norm: f64,
        mut r_norm: f64,
        x: &mut [f64],
        settings: &PcgSettings,
    ) -> Result<(usize, f64), PcgFailure> {
        let target = settings.relative_tolerance * b_norm;
        let mut rz = dot(&self.r, &self.z);
        for iteration in 1..=settings.max_iterations {
            self.multiply(mu);
            let curvature = dot(&self.p, &self.q);
            if curvature.is_nan() || curvature <= 0.0 {
                let pp = dot(&self.p, &self.p);
                if !curvature.is_nan() && pp > 0.0 {
                    self.negative_curvature = Some(curvature / pp);
                }
                return Err(PcgFailure::Indefinite(format!(
                    "pᵀAp = {curvature:.3e} at iteration {iteration}"
                )));
            }
            let alpha = rz / curvature;
            let (mut rz_new, rr) = self.advance(alpha, x);
            if self.apply_incomplete_cholesky(settings) {
                // Replace the Jacobi z computed above by the IC(0) one.
                rz_new = dot(&self.r, &self.z);
            }
            r_norm = rr.sqrt();
            if !r_norm.is_finite() {
                return Err(PcgFailure::NonFinite(format!(
                    "residual at iteration {iteration}"
                )));
            }
            if r_norm <= target {
                return Ok((iteration, r_norm / b_norm));
            }
            let beta = rz_new / rz;
            rz = rz_new;
            self.p
                .par_chunks_mut(CHUNK)
                .zip(self.z.par_chunks(CHUNK))
                .for_each(|(p, z)| {
                    for (pi, &zi) in p.iter_mut().zip(z) {
                        *pi = zi + beta * *pi;
                    }
                });
        }
        Err(PcgFailure::NotConverged {
            iterations: settings.max_iterations,
            relative_residual: r_norm / b_norm,
            tolerance: settings.relative_tolerance,
        })
    }

    /// `x += α p`, `r −= α q`, Jacobi `z = P⁻¹ r`, fused and parallel over fixed chunks;
    /// returns `(rᵀz, rᵀr)` summed chunk by chunk in order.
    fn advance(&mut self, alpha: f64, x: &mut [f64]) -> (f64, f64) {
        let partials: Vec<(f64, f64)> = x
            .par_chunks_mut(CHUNK)
            .zip(self.r.par_chunks_mut(CHUNK))
            .zip(self.z.par_chunks_mut(CHUNK))
            .zip(self.p.par_chunks(CHUNK))
            .zip(self.q.par_chunks(CHUNK))
            .zip(self.inv_diag.par_chunks(CHUNK))
            .map(|(((((x, r), z), p), q), m)| {
                let (mut rz, mut rr) = (0.0, 0.0);
                for i in 0..x.len() {
                    x[i] += alpha * p[i];
                    r[i] -= alpha * q[i];
                    z[i] = m[i] * r[i];
                    rz += r[i] * z[i];
                    rr += r[i] * r[i];
                }
                (rz, rr)
            })
            .collect();
        partials
            .iter()
            .fold((0.0, 0.0), |(a, b), &(c, d)| (a + c, b + d))
    }

    /// `q = (A + μ I) p`, parallel over fixed row blocks.
    fn multiply(&mut self, mu: f64) {
        let (row_ptr, col_idx, values, p) = (&self.row_ptr, &self.col_idx, &self.values, &self.p);
        self.q.par_chunks_mut(CHUNK).enumerate().for_each(|(c, q)| {
            let first = c * CHUNK;
            for (k, qi) in q.iter_mut().enumerate() {
                let i = first + k;
                let mut s = mu * p[i];
                for e in row_ptr[i]..row_ptr[i + 1] {
                    s += values[e] * p[col_idx[e] as usize];
                }
                *qi = s;
            }
        });
    }
}

/// `aᵀb`, summed in fixed chunks (thread-count independent).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let partials: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>())
        .collect();
    partials.iter().sum()
}

/// IC(0): `L̃` on the lower-triangle pattern of `A` (module documentation).
#[derive(Clone, Debug)]
struct IncompleteCholesky {
    col_ptr: Vec<usize>,
    row_idx: Vec<Index>,
    values: Vec<f64>,
    /// The strictly lower entries by row: row `j`'s are
    /// `row_entries[row_ptr[j]..row_ptr[j + 1]]`, each the value index `e` of `L̃[j, k]` and
    /// the end `col_ptr[k + 1]` of its column, in increasing `k`.
    row_ptr: Vec<usize>,
    row_entries: Vec<(usize, usize)>,
    /// `marker[i]`: value index of row `i` in the column being factorized (`usize::MAX`: none).
    marker: Vec<usize>,
}

impl IncompleteCholesky {
    /// Copies the pattern; every column must start with its diagonal entry.
    fn new(lower: SparseColMatRef<'_, usize, f64>) -> Result<Self, PcgFailure> {
        let n = lower.ncols();
        let col_ptr = lower.col_ptr()[..=n].to_vec();
        let row_idx: Vec<Index> = lower.row_idx()[..col_ptr[n]]
            .iter()
            .map(|&i| i as Index)
            .collect();
        for j in 0..n {
            let entries = &row_idx[col_ptr[j]..col_ptr[j + 1]];
            if entries.first() != Some(&(j as Index)) || entries.windows(2).any(|w| w[0] >= w[1]) {
                return Err(PcgFailure::Input(format!(
                    "IC(0) needs sorted lower-triangle columns starting with the diagonal \
                     (column {j})"
                )));
            }
        }
        // The strictly lower entries sorted by row (stably, so every row's come in increasing
        // column order), each with the end of its column.
        let strictly_lower = (0..n).flat_map(|k| col_ptr[k] + 1..col_ptr[k + 1]);
        let (row_ptr, by_row) = counting_sort(strictly_lower, n, |e| row_idx[e] as usize);
        let mut column_end = vec![0; col_ptr[n]];
        for k in 0..n {
            column_end[col_ptr[k]..col_ptr[k + 1]].fill(col_ptr[k + 1]);
        }
        let row_entries = by_row.into_iter().map(|e| (e, column_end[e])).collect();
        Ok(Self {
            values: vec![0.0; col_ptr[n]],
            marker: vec![usize::MAX; n],
            col_ptr,
            row_idx,
            row_ptr,
            row_entries,
        })
    }

    /// Factorizes `A + μI` (values of the lower triangle), shifting on breakdown.
    fn factorize(&mut self, lower_values: &[f64], mu: f64) -> Result<(), PcgFailure> {
        let n = self.col_ptr.len() - 1;
        for sigma in [0.0, 1e-3, 1e-2, 1e-1, 1.0] {
            let nnz = self.values.len();
            self.values.copy_from_slice(&lower_values[..nnz]);
            for j in 0..n {
                let d = &mut self.values[self.col_ptr[j]];
                *d = (*d + mu) * (1.0 + sigma);
            }
            if self.try_factorize() {
                return Ok(());
            }
        }
        Err(PcgFailure::Indefinite(
            "incomplete Cholesky broke down even with a diagonal shift of 100 %".into(),
        ))
    }

    /// Left-looking IC(0) in place; `false` on a non-positive pivot. Column `j` takes
    /// `L̃[i, j] −= L̃[i, k] L̃[j, k]` from every earlier column `k` with `L̃[j, k] ≠ 0` (rows
    /// `i ≥ j` of the pattern, `k` increasing), then its pivot. These are the right-looking
    /// updates in the same order, so the factor is the same bit for bit; but each column's
    /// pattern is scattered once, not once per column that updates it.
    fn try_factorize(&mut self) -> bool {
        let n = self.col_ptr.len() - 1;
        let (cp, ri) = (&self.col_ptr, &self.row_idx);
        let (values, marker) = (&mut self.values, &mut self.marker);
        for j in 0..n {
            for f in cp[j]..cp[j + 1] {
                marker[ri[f] as usize] = f;
            }
            for &(e, end) in &self.row_entries[self.row_ptr[j]..self.row_ptr[j + 1]] {
                let ljk = values[e];
                for e2 in e..end {
                    let f = marker[ri[e2] as usize];
                    if f != usize::MAX {
                        values[f] -= values[e2] * ljk;
                    }
                }
            }
            for f in cp[j]..cp[j + 1] {
                marker[ri[f] as usize] = usize::MAX;
            }
            let pivot = values[cp[j]];
            if !(pivot > 0.0 && pivot.is_finite()) {
                return false;
            }
            let ljj = pivot.sqrt();
            values[cp[j]] = ljj;
            for v in &mut values[cp[j] + 1..cp[j + 1]] {
                *v /= ljj;
            }
        }
        true
    }

    /// `z = (L̃ L̃ᵀ)⁻¹ r` (serial forward and backward substitution).
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = self.col_ptr.len() - 1;
        let (cp, ri, v) = (&self.col_ptr, &self.row_idx, &self.values);
        z.copy_from_slice(r);
        for j in 0..n {
            let zj = z[j] / v[cp[j]];
            z[j] = zj;
            for e in cp[j] + 1..cp[j + 1] {
                z[ri[e] as usize] -= v[e] * zj;
            }
        }
        for j in (0..n).rev() {
            let mut s = z[j];
            for e in cp[j] + 1..cp[j + 1] {
                s -= v[e] * z[ri[e] as usize];
            }
            z[j] = s / v[cp[j]];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, SymbolicSparseColMat};

    /// A sparse SPD-ish lower triangle: a banded random pattern with a dominant diagonal
    /// (`dominance` scales it; small values make IC(0) break down without a shift).
    fn random_lower(n: usize, seed: u64, dominance: f64) -> SparseColMat<usize, f64> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for j in 0..n {
            row_idx.push(j);
            values.push(dominance * (1.0 + next()));
            for i in j + 1..n.min(j + 12) {
                if next() < 0.5 {
                    row_idx.push(i);
                    values.push(next() - 0.5);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        SparseColMat::new(symbolic, values)
    }

    /// IC(0) the textbook way (Saad Alg. 10.1 for the symmetric case) on a dense copy: for
    /// `k = 0, 1, …`, take the pivot, scale column `k`, and subtract `L[i, k] L[j, k]` from
    /// every later entry `(i, j)` of the pattern.
    fn dense_ic0(lower: SparseColMatRef<'_, usize, f64>, mu: f64) -> Option<Vec<Vec<f64>>> {
        let n = lower.ncols();
        let mut a = vec![vec![0.0; n]; n];
        let mut pattern = vec![vec![false; n]; n];
        for j in 0..n {
            for e in lower.col_ptr()[j]..lower.col_ptr()[j + 1] {
                let i = lower.row_idx()[e];
                a[i][j] = lower.val()[e] + if i == j { mu } else { 0.0 };
                pattern[i][j] = true;
            }
        }
        for k in 0..n {
            if a[k][k].is_nan() || a[k][k] <= 0.0 {
                return None;
            }
            a[k][k] = a[k][k].sqrt();
            for i in k + 1..n {
                a[i][k] /= a[k][k];
            }
            for j in k + 1..n {
                for i in j..n {
                    if pattern[i][j] && pattern[i][k] && pattern[j][k] {
                        a[i][j] -= a[i][k] * a[j][k];
                    }
                }
            }
        }
        Some(a)
    }

    /// `lower` with its diagonal scaled by `1 + sigma`.
    fn diagonal_scaled(lower: &SparseColMat<usize, f64>, sigma: f64) -> SparseColMat<usize, f64> {
        let mut scaled = lower.clone();
        for j in 0..lower.ncols() {
            scaled.val_mut()[lower.col_ptr()[j]] *= 1.0 + sigma;
        }
        scaled
    }

    /// Every stored entry of `ic` equals the dense `reference` bit for bit.
    fn assert_factor_is(ic: &IncompleteCholesky, reference: &[Vec<f64>], case: &str) {
        for j in 0..ic.col_ptr.len() - 1 {
            for f in ic.col_ptr[j]..ic.col_ptr[j + 1] {
                let i = ic.row_idx[f] as usize;
                assert_eq!(ic.values[f], reference[i][j], "entry ({i}, {j}), {case}");
            }
        }
    }

    #[test]
    fn incomplete_cholesky_is_the_textbook_factor_bit_for_bit() {
        for (seed, dominance) in [(1, 4.0), (2, 2.0), (3, 8.0)] {
            let lower = random_lower(200, seed, dominance);
            let mu = 0.25;
            let reference = dense_ic0(lower.as_ref(), mu).expect("a positive factor");
            let mut ic = IncompleteCholesky::new(lower.as_ref()).unwrap();
            ic.factorize(lower.val(), mu).unwrap();
            assert_factor_is(&ic, &reference, &format!("seed {seed}"));
        }
        // A weak diagonal breaks the unshifted factorization down; the shifted retry is the
        // textbook factor of A + μI + σ diag(A + μI) for the first σ that works.
        let lower = random_lower(200, 4, 0.8);
        assert!(dense_ic0(lower.as_ref(), 0.0).is_none());
        let mut ic = IncompleteCholesky::new(lower.as_ref()).unwrap();
        ic.factorize(lower.val(), 0.0).unwrap();
        let reference = [1e-3, 1e-2, 1e-1, 1.0]
            .into_iter()
            .find_map(|sigma| dense_ic0(diagonal_scaled(&lower, sigma).as_ref(), 0.0))
            .expect("some shift works");
        assert_factor_is(&ic, &reference, "shifted");
    }

    #[test]
    fn the_traffic_model_counts_at_least_the_stored_arrays() {
        // Every pass over the workspace's stored arrays is counted at least once: the product
        // reads the full values and column indices, each substitution the factor's values and
        // row indices, the factorization writes and reads the factor's values.
        let lower = random_lower(300, 11, 4.0);
        let mut pcg = Pcg::new(lower.as_ref()).unwrap();
        let b = vec![1.0; 300];
        let mut x = vec![0.0; 300];
        let settings = PcgSettings::new(1e-8, 300, Preconditioner::IncompleteCholesky);
        pcg.solve(lower.as_ref(), 0.0, &b, &mut x, &settings)
            .unwrap();
        let ic = pcg.ic.as_ref().unwrap();
        let t = PcgTraffic::incomplete_cholesky(300, lower.col_ptr()[300]);
        let product = (8 * pcg.values.len() + 4 * pcg.col_idx.len()) as f64;
        let substitution = (8 * ic.values.len() + 4 * ic.row_idx.len()) as f64;
        assert!(
            t.iteration_parallel >= product,
            "{} < {product}",
            t.iteration_parallel
        );
        assert!(t.iteration_serial >= 2.0 * substitution);
        assert!(t.solve_serial >= 2.0 * 8.0 * ic.values.len() as f64);
        assert!(t.solve_parallel >= 16.0 * pcg.values.len() as f64);
        // Time: linear in the counts and inverse in the bandwidths.
        let one = t.seconds(1.0, 0.0, 1.0, 1.0);
        assert_eq!(one, t.iteration_parallel + t.iteration_serial);
        assert_eq!(
            t.seconds(3.0, 2.0, 2.0, 4.0),
            3.0 * (t.iteration_parallel / 2.0 + t.iteration_serial / 4.0)
                + 2.0 * (t.solve_parallel / 2.0 + t.solve_serial / 4.0)
        );
    }
}
