//! Newton minimization under linear equality constraints `C x = d`.
//!
//! **Method: augmented KKT system, range-space solve.** Each Newton step solves the
//! equality-constrained quadratic model (Nocedal & Wright 2006, §16.1 and §18.1)
//!
//! ```text
//! ⎡ H + μI   Ĉᵀ ⎤ ⎡ Δx ⎤   ⎡    −g     ⎤
//! ⎣   Ĉ      0  ⎦ ⎣ λ̂  ⎦ = ⎣ r = S (d − Cx) ⎦ ,       Ĉ = S C,
//! ```
//!
//! where `S` scales each constraint row by the inverse of its largest absolute entry (this
//! changes neither the constraint set nor the step, only the multipliers' scaling). Adding
//! `ρĈᵀ(ĈΔx − r) = 0` to the first block row gives the same solution with the *augmented*
//! matrix `K = H + μI + ρĈᵀĈ` (the augmented Lagrangian's Hessian, N&W §17.3), which is
//! positive definite exactly when `H + μI` is positive definite on the null space of `C`, for
//! `ρ` large enough (Debreu 1952). So `K` is factorized by sparse Cholesky (faer, AMD
//! ordering, supernodal, symbolic analysis once per solver), and the step follows from the
//! Schur complement on the constraints, with `Y = K⁻¹Ĉᵀ` (one solve of `m` columns) and the
//! dense `m × m` `Ŝ = ĈY`:
//!
//! ```text
//! w = K⁻¹(−g + ρĈᵀr),    λ̂ = Ŝ⁻¹(Ĉw − r),    Δx = w − Yλ̂ .
//! ```
//!
//! `ρ = 100 max_i |H_ii|` (the constant `AUGMENTATION` times the Hessian's scale). One step of
//! iterative refinement against the unaugmented KKT matrix follows every solve; the
//! right-hand side `r` also removes rounding drift of the constraints. `ρ` must exceed
//! Debreu's threshold, or a positive definite reduced Hessian still fails the factorization
//! and the shift grows for nothing: with `ρ = max_i |H_ii|`, a taut plain weave (sx = 1,
//! sa = 0.175, sy = 0.7) kept a shift of 824 (`K` had an eigenvalue of −172 along a mode
//! sliding two yarns against their no-sliding anchors) and stalled at a residual of 3e-6;
//! with 100× it converges in 8 iterations, and its 9³ database (the `periodic-databases`
//! benchmark) went from 6 unsolved samples in 11.3 s to none in 2.0 s (10⁴× gave the same).
//!
//! *Why this and not a factorization of the indefinite KKT matrix.* A failed Cholesky
//! factorization is an inertia test: it says that the reduced Hessian (plus shift) is not
//! positive definite, and the driver raises `μ` as in the unconstrained case, so every
//! accepted step is a descent direction of a convex model (IPOPT's inertia correction,
//! Wächter & Biegler 2006, §3.1). The earlier sparse LU of the KKT matrix took any
//! nonsingular indefinite system, and its steps towards saddles stalled in jammed yarn
//! contacts (the `periodic-databases` benchmark measures the database times). The fill of
//! `ĈᵀĈ` is the square of each row's length (the zero-mean
//! rows of a periodic tile couple all vertices), so the method suits few or short
//! constraint rows; its cost grows with `m` through the `m` columns of `Y`.
//!
//! *Dense rows.* The zero-mean and twist-drift rows of a periodic tile couple all its
//! vertices, so the factor of a small tile's `K` is dense or nearly so. faer's own choice
//! would factorize such a `K` column by column (simplicial: its flop count per stored entry
//! stays under its threshold), which on the fit's small tiles spent much of a Newton
//! iteration in the factorization and the solves. So `K` is always factorized supernodally
//! (dense blocks, `linalg::Factorization::Supernodal`), and the `m` columns of `Y` are one
//! blocked solve. A Woodbury treatment of the dense rows (`K` factorized without their
//! `ρĉĉᵀ`, corrected by a low-rank capacitance) was exact on small tests but not kept: it fell
//! back often and lost accuracy to cancellation in the pinned matrix's soft modes. The
//! measurements are in `reports/yarn-fit/NOTES.md`.
//!
//! **Convergence** uses the Lagrangian gradient `‖g + Cᵀλ‖∞ = ‖g + Ĉᵀλ̂‖∞` (zero exactly at a
//! KKT point) in place of `‖g_f‖∞`, with the least-squares multipliers `λ̂ = −(ĈĈᵀ)⁻¹Ĉg` (the
//! gradient projected onto the null space of `C`; `ĈĈᵀ` is factorized once, for up to 1024
//! constraints, else the KKT solve's multipliers are used). The KKT solve's own multipliers
//! depend on `H`: near a singular or indefinite `H` they can be inaccurate enough to keep the
//! test from passing at a stationary point, plus feasibility `‖Cx − d‖∞ ≤ constraint_tol · (‖C‖∞ ‖x‖∞ +
//! ‖d‖∞)`; the line search, regularization and error handling are those of
//! [`crate::newton`].
//!
//! **Feasibility restoration.** If the start `x₀` is infeasible, it is first replaced by its
//! Euclidean projection onto `{x : Cx = d}`, the minimum-norm correction
//! `Δx = argmin ‖Δx‖₂ s.t. C(x₀ + Δx) = d`, from the same solve with `H = I`. Since every
//! later step satisfies `C Δx = d − Cx`, all iterates stay feasible and the line search needs
//! only the energy.
//!
//! **Rank check.** `C` must have full row rank, or the KKT matrix is singular. When the solver is
//! built, the system `[I Ĉᵀ; Ĉ 0] z = [0; r]` is solved for a fixed pseudo-random `r`: if
//! `C` is rank deficient, `Ŝ` is singular (its Cholesky factorization fails) or `r` is almost
//! surely outside the range of `Ĉ` and no `z` has a small residual; either way the solver
//! reports [`SolveError::RankDeficientConstraints`].

use faer::sparse::{SparseColMat, SparseColMatRef};

use crate::SolveError;
use crate::assembly::{Assembler, Problem, check_len};
use crate::linalg::{Factorization, SparseLlt, symmetric_multiply_sub, symmetric_quadratic_form};
use crate::newton::{
    InitialShift, LinearSolver, NewtonReport, NewtonSettings, NewtonSystem, SystemFailure,
    inf_norm, run_newton,
};
use crate::pattern::build_pattern;

/// Linear equality constraints `C x = d`, with `C` (`m × n_dofs`) given as `(row, col, value)`
/// triplets (duplicates are summed) and `d` of length `m`.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearConstraints {
    n_dofs: usize,
    /// Triplets sorted by (row, col); row `r` is `triplets[row_ptr[r]..row_ptr[r + 1]]`.
    triplets: Vec<(usize, usize, f64)>,
    row_ptr: Vec<usize>,
    rhs: Vec<f64>,
}

impl LinearConstraints {
    /// Builds `C x = d` on `n_dofs` DOFs, with `m = rhs.len()` constraints. Errors on an
    /// out-of-range row or column or a non-finite value.
    pub fn new(
        n_dofs: usize,
        triplets: &[(usize, usize, f64)],
        rhs: &[f64],
    ) -> Result<Self, SolveError> {
        let m = rhs.len();
        for &(r, c, v) in triplets {
            if r >= m || c >= n_dofs {
                return Err(SolveError::InvalidConstraints(format!(
                    "triplet ({r}, {c}) outside the {m} × {n_dofs} constraint matrix"
                )));
            }
            if !v.is_finite() {
                return Err(SolveError::InvalidConstraints(format!(
                    "non-finite coefficient at ({r}, {c})"
                )));
            }
        }
        if let Some(r) = rhs.iter().position(|d| !d.is_finite()) {
            return Err(SolveError::InvalidConstraints(format!("non-finite d[{r}]")));
        }
        let mut sorted = triplets.to_vec();
        sorted.sort_by_key(|&(r, c, _)| (r, c));
        let mut row_ptr = vec![0; m + 1];
        for &(r, _, _) in &sorted {
            row_ptr[r + 1] += 1;
        }
        for r in 0..m {
            row_ptr[r + 1] += row_ptr[r];
        }
        Ok(Self {
            n_dofs,
            triplets: sorted,
            row_ptr,
            rhs: rhs.to_vec(),
        })
    }

    /// Constraints `x[dofs[i]] = values[i]` ("pins"), equivalent to Dirichlet conditions.
    pub fn pin(n_dofs: usize, dofs: &[usize], values: &[f64]) -> Result<Self, SolveError> {
        check_len("pin values", dofs.len(), values.len())?;
        let triplets: Vec<_> = dofs.iter().enumerate().map(|(r, &c)| (r, c, 1.0)).collect();
        Self::new(n_dofs, &triplets, values)
    }

    /// Number of DOFs `n` (columns of `C`).
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    /// Number of constraints `m` (rows of `C`).
    pub fn n_constraints(&self) -> usize {
        self.rhs.len()
    }

    /// The triplets of `C`, sorted by (row, column).
    pub fn triplets(&self) -> &[(usize, usize, f64)] {
        &self.triplets
    }

    /// The right-hand side `d`.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }

    /// `‖C x − d‖∞`.
    pub fn violation(&self, x: &[f64]) -> Result<f64, SolveError> {
        check_len("x", self.n_dofs, x.len())?;
        Ok(self.violation_unchecked(x))
    }

    /// `ĈĈᵀ = S C Cᵀ S` (dense) for the row scales `S = diag(row_scale)`; each entry merges the two rows' column-sorted triplets (linear in the
    /// row lengths, so the dense zero-mean rows of a large problem stay cheap).
    fn scaled_gram(&self, row_scale: &[f64]) -> nalgebra::DMatrix<f64> {
        let c = self;
        let m = c.n_constraints();
        let row = |k: usize| &c.triplets[c.row_ptr[k]..c.row_ptr[k + 1]];
        let mut gram = nalgebra::DMatrix::zeros(m, m);
        for r in 0..m {
            for s in r..m {
                let (a, b) = (row(r), row(s));
                let (mut i, mut j, mut dot) = (0, 0, 0.0);
                while i < a.len() && j < b.len() {
                    match a[i].1.cmp(&b[j].1) {
                        std::cmp::Ordering::Less => i += 1,
                        std::cmp::Ordering::Greater => j += 1,
                        std::cmp::Ordering::Equal => {
                            // Duplicate triplets of one column are summed.
                            let col = a[i].1;
                            let (mut sa, mut sb) = (0.0, 0.0);
                            while i < a.len() && a[i].1 == col {
                                sa += a[i].2;
                                i += 1;
                            }
                            while j < b.len() && b[j].1 == col {
                                sb += b[j].2;
                                j += 1;
                            }
                            dot += sa * sb;
                        }
                    }
                }
                let v = dot * row_scale[r] * row_scale[s];
                gram[(r, s)] = v;
                gram[(s, r)] = v;
            }
        }
        gram
    }

    /// `(C x)_r − d_r` (no length check).
    fn row_residual(&self, r: usize, x: &[f64]) -> f64 {
        let row = &self.triplets[self.row_ptr[r]..self.row_ptr[r + 1]];
        row.iter().map(|&(_, c, v)| v * x[c]).sum::<f64>() - self.rhs[r]
    }

    fn violation_unchecked(&self, x: &[f64]) -> f64 {
        (0..self.n_constraints()).fold(0.0, |m, r| m.max(self.row_residual(r, x).abs()))
    }

    /// `‖C‖∞` (largest absolute row sum).
    fn norm_inf(&self) -> f64 {
        (0..self.n_constraints())
            .map(|r| {
                self.triplets[self.row_ptr[r]..self.row_ptr[r + 1]]
                    .iter()
                    .map(|t| t.2.abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }
}

/// The KKT back end of the Newton driver: the augmented matrix `K = H + μI + ρĈᵀĈ`, its
/// sparse Cholesky factor, and the range-space (Schur complement) solve.
struct KktSystem {
    constraints: LinearConstraints,
    n: usize,
    /// `S_rr = 1 / max_c |C_rc|`.
    row_scale: Vec<f64>,
    c_norm_inf: f64,
    /// `K`'s lower triangle: the pattern of `H` united with that of `ĈᵀĈ`.
    k: SparseColMat<usize, f64>,
    /// `K` value index of each stored value of `H`'s lower triangle.
    h_slots: Vec<usize>,
    /// `K` value index of each diagonal entry.
    diag_slots: Vec<usize>,
    /// `(K value index, (ĈᵀĈ) value)` of the augmentation, summed over the rows of `Ĉ`.
    gram: Vec<(usize, f64)>,
    llt: SparseLlt,
    /// `Y = K⁻¹Ĉᵀ`, column-major `n × m`.
    y: Vec<f64>,
    /// Cholesky factor of the Schur complement `ĈK⁻¹Ĉᵀ` (`None` when `m = 0`).
    schur: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    /// `ρ` of the current factorization.
    rho: f64,
    /// Shift `μ` of the current factorization.
    mu: f64,
    /// Step `[Δx; λ̂]`, the right-hand side, and scratch of the same length (`work` for the
    /// factored solve, `saved_rhs` for the right-hand side during refinement).
    sol: Vec<f64>,
    work: Vec<f64>,
    rhs: Vec<f64>,
    saved_rhs: Vec<f64>,
    /// Cholesky factor of `ĈĈᵀ` (dense, `m ≤ MAX_DENSE_MULTIPLIERS`) for the least-squares
    /// multipliers of the stationarity test.
    normal: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
}

/// Largest constraint count for which the stationarity test fits its own multipliers (a dense
/// `m × m` factorization once per solver); above it, the KKT solve's multipliers are used.
const MAX_DENSE_MULTIPLIERS: usize = 1024;

/// The augmentation weight `ρ` relative to `max_i |H_ii|` (see the module documentation).
const AUGMENTATION: f64 = 100.0;

impl KktSystem {
    fn new(asm: &Assembler, constraints: &LinearConstraints) -> Result<Self, SolveError> {
        let n = asm.n_dofs();
        let m = constraints.n_constraints();
        let mut row_scale = vec![0.0; m];
        for &(r, _, v) in &constraints.triplets {
            row_scale[r] = f64::max(row_scale[r], v.abs());
        }
        if let Some(r) = row_scale.iter().position(|&s| s == 0.0) {
            return Err(SolveError::RankDeficientConstraints(format!(
                "row {r} of C is zero"
            )));
        }
        for s in &mut row_scale {
            *s = 1.0 / *s;
        }

        // Lower-triangle pattern of K: H's, then every pair of columns sharing a row of C.
        let h = asm.hessian();
        let h_sym = h.symbolic();
        let mut coords = Vec::new();
        for j in 0..n {
            for &i in &h_sym.row_idx()[h_sym.col_range(j)] {
                coords.push((i.max(j), i.min(j)));
            }
        }
        let n_h = coords.len();
        let diag_first = coords.len();
        coords.extend((0..n).map(|i| (i, i)));
        let mut gram_values = Vec::new();
        for r in 0..m {
            let row = &constraints.triplets[constraints.row_ptr[r]..constraints.row_ptr[r + 1]];
            let scale2 = row_scale[r] * row_scale[r];
            for &(_, a, va) in row {
                for &(_, b, vb) in row {
                    if a >= b {
                        coords.push((a, b));
                        gram_values.push(scale2 * va * vb);
                    }
                }
            }
        }
        let (symbolic, slot) = build_pattern(n, n, &coords);
        let h_slots = slot[..n_h].to_vec();
        let diag_slots = slot[diag_first..diag_first + n].to_vec();
        let gram = slot[diag_first + n..]
            .iter()
            .copied()
            .zip(gram_values)
            .collect();
        let llt = SparseLlt::new(symbolic.as_ref(), Factorization::Supernodal, m)?;
        let nnz = symbolic.row_idx().len();
        let mut system = Self {
            c_norm_inf: constraints.norm_inf(),
            constraints: constraints.clone(),
            n,
            row_scale,
            k: SparseColMat::new(symbolic, vec![0.0; nnz]),
            h_slots,
            diag_slots,
            gram,
            llt,
            y: vec![0.0; n * m],
            schur: None,
            rho: 0.0,
            mu: 0.0,
            saved_rhs: vec![0.0; n + m],
            sol: vec![0.0; n + m],
            work: vec![0.0; n + m],
            rhs: vec![0.0; n + m],
            normal: None,
        };
        system.check_rank()?;
        if m <= MAX_DENSE_MULTIPLIERS {
            system.normal = nalgebra::Cholesky::new(constraints.scaled_gram(&system.row_scale));
        }
        Ok(system)
    }

    /// `‖g + Ĉᵀλ‖∞` with the least-squares multipliers `λ = −(ĈĈᵀ)⁻¹Ĉg`: the norm of the
    /// gradient projected onto the constraints' null space, independent of `H`.
    fn projected_gradient_norm(&self, gradient: &[f64]) -> Option<f64> {
        let normal = self.normal.as_ref()?;
        let c = &self.constraints;
        let mut y = nalgebra::DVector::zeros(c.n_constraints());
        for &(r, col, v) in &c.triplets {
            y[r] += self.row_scale[r] * v * gradient[col];
        }
        let lambda = -normal.solve(&y);
        let mut r = gradient.to_vec();
        for &(row, col, v) in &c.triplets {
            r[col] += self.row_scale[row] * v * lambda[row];
        }
        Some(inf_norm(&r))
    }

    /// Factorizes `K = A + μI + ρĈᵀĈ` with `A = H` (`h = Some`) or `A = I`, `ρ` =
    /// [`AUGMENTATION`] `· max_i |A_ii|`, and the Schur complement `ĈK⁻¹Ĉᵀ`. Fails when either
    /// is not numerically positive definite.
    fn factorize(&mut self, h: Option<&[f64]>, mu: f64) -> Result<(), String> {
        let (n, m) = (self.n, self.constraints.n_constraints());
        let values = self.k.val_mut();
        values.fill(0.0);
        match h {
            Some(h) => {
                for (&v, &slot) in h.iter().zip(&self.h_slots) {
                    values[slot] += v;
                }
            }
            None => self.diag_slots.iter().for_each(|&d| values[d] = 1.0),
        }
        let scale = self
            .diag_slots
            .iter()
            .map(|&d| values[d].abs())
            .fold(0.0, f64::max);
        self.rho = AUGMENTATION
            * if scale > 0.0 && scale.is_finite() {
                scale
            } else {
                1.0
            };
        for &d in &self.diag_slots {
            values[d] += mu;
        }
        for &(slot, g) in &self.gram {
            values[slot] += self.rho * g;
        }
        self.mu = mu;
        self.schur = None;
        self.llt.factorize(self.k.as_ref())?;
        // Y = K⁻¹Ĉᵀ, then the Schur complement ĈY.
        self.y.fill(0.0);
        for &(r, c, v) in &self.constraints.triplets {
            self.y[r * n + c] += self.row_scale[r] * v;
        }
        self.llt.solve_columns_in_place(&mut self.y, m)?;
        if m == 0 {
            return Ok(());
        }
        let mut s = nalgebra::DMatrix::zeros(m, m);
        for &(r, c, v) in &self.constraints.triplets {
            let w = self.row_scale[r] * v;
            for q in 0..m {
                s[(r, q)] += w * self.y[q * n + c];
            }
        }
        let s = (&s + s.transpose()) * 0.5;
        self.schur = Some(
            nalgebra::Cholesky::new(s).ok_or("Schur complement ĈK⁻¹Ĉᵀ not positive definite")?,
        );
        Ok(())
    }

    /// Solves `[A + μI, Ĉᵀ; Ĉ, 0] [δ; η] = [p; q]` (`rhs = [p; q]`) with the current factors:
    /// `w = K⁻¹(p + ρĈᵀq)`, `η = S⁻¹(Ĉw − q)`, `δ = w − Yη`. Writes `[δ; η]` into `work`.
    fn solve_factored(&mut self) -> Result<(), String> {
        let n = self.n;
        let m = self.constraints.n_constraints();
        let (w, eta) = self.work.split_at_mut(n);
        w.copy_from_slice(&self.rhs[..n]);
        for &(r, c, v) in &self.constraints.triplets {
            w[c] += self.rho * self.row_scale[r] * v * self.rhs[n + r];
        }
        self.llt.solve_in_place(w)?;
        if let Some(schur) = &self.schur {
            let mut t = nalgebra::DVector::from_column_slice(&self.rhs[n..]);
            t.neg_mut();
            for &(r, c, v) in &self.constraints.triplets {
                t[r] += self.row_scale[r] * v * w[c];
            }
            let lambda = schur.solve(&t);
            eta.copy_from_slice(lambda.as_slice());
            for (q, &l) in lambda.iter().enumerate() {
                for (wi, yi) in w.iter_mut().zip(&self.y[q * n..(q + 1) * n]) {
                    *wi -= yi * l;
                }
            }
        } else {
            debug_assert_eq!(m, 0);
        }
        Ok(())
    }

    /// Solves the KKT system for `rhs` into `sol`, plus one step of iterative refinement;
    /// errors on non-finite results.
    fn solve_refined(&mut self, h: Option<SparseColMatRef<'_, usize, f64>>) -> Result<(), String> {
        self.solve_factored()?;
        self.sol.copy_from_slice(&self.work);
        self.saved_rhs.copy_from_slice(&self.rhs);
        self.residual_into_rhs(h);
        self.solve_factored()?;
        for (s, w) in self.sol.iter_mut().zip(&self.work) {
            *s += w;
        }
        std::mem::swap(&mut self.rhs, &mut self.saved_rhs);
        if self.sol.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err("non-finite KKT solution (singular KKT matrix)".into())
        }
    }

    /// `rhs ← rhs − [A + μI, Ĉᵀ; Ĉ, 0] sol` for the `A` of the current factorization.
    fn residual_into_rhs(&mut self, h: Option<SparseColMatRef<'_, usize, f64>>) {
        let n = self.n;
        let (x, lambda) = self.sol.split_at(n);
        let (p, q) = self.rhs.split_at_mut(n);
        match h {
            Some(h) => symmetric_multiply_sub(h, x, p),
            None => p.iter_mut().zip(x).for_each(|(pi, xi)| *pi -= xi),
        }
        for (pi, xi) in p.iter_mut().zip(x) {
            *pi -= self.mu * xi;
        }
        for &(r, c, v) in &self.constraints.triplets {
            let w = self.row_scale[r] * v;
            p[c] -= w * lambda[r];
            q[r] -= w * x[c];
        }
    }

    /// Rejects a rank-deficient `C` (see the module documentation).
    fn check_rank(&mut self) -> Result<(), SolveError> {
        let m = self.constraints.n_constraints();
        if m == 0 {
            return Ok(());
        }
        let dependent = |detail: String| {
            SolveError::RankDeficientConstraints(format!(
                "C has (numerically) dependent rows: {detail}"
            ))
        };
        self.factorize(None, 0.0).map_err(dependent)?;
        // A fixed pseudo-random right-hand side in [1, 2): generic, deterministic.
        self.rhs[..self.n].fill(0.0);
        pseudo_random(0x9E37_79B9_7F4A_7C15, 1.0, &mut self.rhs[self.n..]);
        let solved = self.solve_refined(None);
        let norm = inf_norm(&self.rhs);
        self.residual_into_rhs(None);
        let residual = inf_norm(&self.rhs);
        let accurate = residual <= 1e-8 * norm; // false for NaN
        if solved.is_err() || !accurate {
            return Err(dependent(format!(
                "a generic right-hand side leaves a KKT residual of {residual:.3e}"
            )));
        }
        Ok(())
    }

    /// Replaces `x` by its Euclidean projection onto `{Cx = d}`.
    fn restore_feasibility(&mut self, x: &mut [f64]) -> Result<(), SolveError> {
        self.factorize(None, 0.0)
            .map_err(SolveError::RankDeficientConstraints)?;
        self.rhs[..self.n].fill(0.0);
        for r in 0..self.constraints.n_constraints() {
            self.rhs[self.n + r] = -self.row_scale[r] * self.constraints.row_residual(r, x);
        }
        self.solve_refined(None)
            .map_err(SolveError::RankDeficientConstraints)?;
        for (xi, di) in x.iter_mut().zip(&self.sol) {
            *xi += di;
        }
        Ok(())
    }

    fn feasible(&self, x: &[f64], violation: f64, settings: &NewtonSettings) -> bool {
        let scale = self.c_norm_inf * inf_norm(x) + inf_norm(&self.constraints.rhs);
        violation <= settings.constraint_tol * scale
    }
}

impl NewtonSystem for KktSystem {
    fn residual_before_solve(&self, gradient: &[f64]) -> Option<f64> {
        self.projected_gradient_norm(gradient)
    }

    fn solve(
        &mut self,
        asm: &mut Assembler,
        x: &[f64],
        mu: f64,
        dx: &mut [f64],
    ) -> Result<f64, SystemFailure> {
        let n = self.n;
        let h = asm.hessian();
        self.factorize(Some(h.val()), mu)?;
        let gradient = asm.last_gradient();
        for (r, g) in self.rhs[..n].iter_mut().zip(gradient) {
            *r = -g;
        }
        for r in 0..self.constraints.n_constraints() {
            self.rhs[n + r] = -self.row_scale[r] * self.constraints.row_residual(r, x);
        }
        self.solve_refined(Some(h))?;
        dx.copy_from_slice(&self.sol[..n]);
        // Lagrangian gradient g + Ĉᵀλ̂, in `work[..n]`.
        self.work[..n].copy_from_slice(gradient);
        for &(r, c, v) in &self.constraints.triplets {
            self.work[c] += v * self.row_scale[r] * self.sol[n + r];
        }
        Ok(inf_norm(&self.work[..n]))
    }

    fn violation(&self, x: &[f64], settings: &NewtonSettings) -> Option<(bool, f64)> {
        let v = self.constraints.violation_unchecked(x);
        Some((self.feasible(x, v, settings), v))
    }

    fn negative_curvature(&mut self, asm: &Assembler, direction: &mut [f64]) -> Option<f64> {
        let n = self.n;
        // Inverse iteration with the shifted factorization, projected onto the null space
        // of C: converges to the eigenvector of the lowest eigenvalue of the reduced H.
        // A fixed start in [−½, ½): generic, deterministic.
        pseudo_random(0x2545_F491_4F6C_DD1D, -0.5, &mut self.rhs[..n]);
        self.rhs[n..].fill(0.0);
        let mut curvature = f64::NAN;
        for _ in 0..CURVATURE_SEARCH {
            self.solve_factored().ok()?;
            let norm = self.work[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(norm > 0.0 && norm.is_finite()) {
                return None;
            }
            for (r, w) in self.rhs[..n].iter_mut().zip(&self.work[..n]) {
                *r = w / norm;
            }
            // Any direction of negative curvature will do: stop at the first.
            curvature = symmetric_quadratic_form(asm.hessian(), &self.rhs[..n]);
            if curvature < 0.0 {
                break;
            }
        }
        direction.copy_from_slice(&self.rhs[..n]);
        Some(curvature)
    }
}

/// Inverse iterations of [`NewtonSystem::negative_curvature`] (a search of 128 when the run
/// stalled made the basket weave's 5³ database 3× slower and left a sample unsolved).
const CURVATURE_SEARCH: usize = 16;

/// Fills `out` with a fixed xorshift sequence, uniform in `[offset, offset + 1)`.
fn pseudo_random(mut seed: u64, offset: f64, out: &mut [f64]) {
    for v in out {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        *v = offset + (seed >> 11) as f64 / (1u64 << 53) as f64;
    }
}

/// Shifts (relative to `max_i |H_ii|`) tried by [`ConstrainedNewtonSolver::sensitivities`]:
/// none, then tiny ones for a semidefinite reduced Hessian.
const SENSITIVITY_SHIFTS: [f64; 4] = [0.0, 1e-10, 1e-8, 1e-6];

/// A reusable equality-constrained Newton minimizer for one problem structure and one
/// constraint matrix (the augmented pattern, its symbolic Cholesky and the rank check are done
/// once).
pub struct ConstrainedNewtonSolver {
    assembler: Assembler,
    system: KktSystem,
}

impl ConstrainedNewtonSolver {
    /// Prepares a solver for `problem` under `constraints`. Errors with
    /// [`SolveError::RankDeficientConstraints`] if `C` does not have full row rank.
    pub fn new<P: Problem + ?Sized>(
        problem: &P,
        constraints: &LinearConstraints,
    ) -> Result<Self, SolveError> {
        check_len("constraint columns", problem.n_dofs(), constraints.n_dofs())?;
        let assembler = Assembler::new(problem)?;
        let system = KktSystem::new(&assembler, constraints)?;
        Ok(Self { assembler, system })
    }

    /// Minimizes the energy subject to `C x = d`, starting from `x` (projected onto the
    /// constraints first if infeasible) and overwriting it with the minimizer. See the
    /// [module documentation](self).
    pub fn minimize<P: Problem + ?Sized>(
        &mut self,
        problem: &P,
        x: &mut [f64],
        settings: &NewtonSettings,
    ) -> Result<NewtonReport, SolveError> {
        settings.validate()?;
        if settings.linear_solver != LinearSolver::Cholesky {
            return Err(SolveError::InvalidSettings(
                "constrained Newton solves its KKT system by sparse Cholesky; choose \
                 LinearSolver::Cholesky (the default)"
                    .into(),
            ));
        }
        check_len("x", self.assembler.n_dofs(), x.len())?;
        let v0 = self.system.constraints.violation_unchecked(x);
        if !self.system.feasible(x, v0, settings) {
            self.system.restore_feasibility(x)?;
        }
        run_newton(
            problem,
            x,
            settings,
            &mut self.assembler,
            &mut self.system,
            v0,
            InitialShift {
                value: 0.0,
                start_at_value: false,
            },
        )
    }

    /// Implicit differentiation at a constrained minimizer `x`: solves
    ///
    /// ```text
    /// [H Cᵀ; C 0] [y; η] = [b; 0]
    /// ```
    ///
    /// for every `b` of `rhs`, with `H` the Hessian at `x`. If a parameter `θ` moves the
    /// gradient by `∂g/∂θ` (leaving `C` and `d` alone), the minimizer moves by `dx/dθ = y` for
    /// `b = −∂g/∂θ`, and a quantity `Q(x, θ)` changes by `dQ/dθ = ∂Q/∂θ + ∂Q/∂x · y`; read
    /// as an adjoint (the matrix is symmetric), one solve with `b = ∂Q/∂x` serves every
    /// parameter. The factorization is the Newton step's without shift, with one refinement
    /// step per right-hand side. A reduced Hessian that is only semidefinite (a zero-energy
    /// mode) is shifted by the smallest of `1e-10`, `1e-8`, `1e-6` × `max_i |H_ii|` that
    /// factorizes; errors with [`SolveError::NotAStrictMinimum`] when none does (a saddle).
    pub fn sensitivities<P: Problem + ?Sized>(
        &mut self,
        problem: &P,
        x: &[f64],
        rhs: &[Vec<f64>],
    ) -> Result<Vec<Vec<f64>>, SolveError> {
        let n = self.assembler.n_dofs();
        check_len("x", n, x.len())?;
        for b in rhs {
            check_len("right-hand side", n, b.len())?;
        }
        self.assembler.assemble(problem, x, false)?;
        let h = self.assembler.hessian();
        // A positive semidefinite reduced Hessian (a zero-energy mode, e.g. a yarn free to
        // slide) gets the smallest of a few tiny shifts that factorizes: the derivative is
        // then the regularized system's, close to the minimum-norm one.
        let scale = self.assembler.diagonal_scale();
        let mut factorized = Err(String::new());
        for shift in SENSITIVITY_SHIFTS {
            factorized = self.system.factorize(Some(h.val()), shift * scale);
            if factorized.is_ok() {
                break;
            }
        }
        factorized.map_err(SolveError::NotAStrictMinimum)?;
        let mut out = Vec::with_capacity(rhs.len());
        for b in rhs {
            self.system.rhs[..n].copy_from_slice(b);
            self.system.rhs[n..].fill(0.0);
            self.system
                .solve_refined(Some(h))
                .map_err(SolveError::NotAStrictMinimum)?;
            out.push(self.system.sol[..n].to_vec());
        }
        Ok(out)
    }

    /// The assembler (pattern, last gradient and Hessian).
    pub fn assembler(&self) -> &Assembler {
        &self.assembler
    }
}

/// Minimizes `problem`'s energy subject to `constraints`, starting from `x` (overwritten with
/// the minimizer). One-shot convenience for [`ConstrainedNewtonSolver::new`] followed by
/// [`ConstrainedNewtonSolver::minimize`].
pub fn minimize_constrained<P: Problem + ?Sized>(
    problem: &P,
    x: &mut [f64],
    constraints: &LinearConstraints,
    settings: &NewtonSettings,
) -> Result<NewtonReport, SolveError> {
    ConstrainedNewtonSolver::new(problem, constraints)?.minimize(problem, x, settings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_gram_matches_the_dense_product_with_duplicate_triplets() {
        // Row 0 has column 1 twice (summed), rows share columns 1 and 3 only.
        let triplets = [
            (0, 1, 2.0),
            (0, 3, -1.0),
            (0, 1, 0.5),
            (1, 0, 4.0),
            (1, 1, 1.0),
            (1, 3, 3.0),
            (2, 2, 1.0),
        ];
        let c = LinearConstraints::new(4, &triplets, &[0.0; 3]).unwrap();
        let scale = [0.5, 2.0, 1.0];
        let mut dense = nalgebra::DMatrix::<f64>::zeros(3, 4);
        for &(r, col, v) in &triplets {
            dense[(r, col)] += scale[r] * v;
        }
        let want = &dense * dense.transpose();
        let got = c.scaled_gram(&scale);
        assert!((got - want).amax() < 1e-14);
    }
}
