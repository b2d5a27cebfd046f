//! Newton minimization under linear equality constraints `C x = d`.
//!
//! **Method: KKT system with sparse LU.** Each Newton step solves the equality-constrained
//! quadratic model (Nocedal & Wright 2006, §16.1 and §18.1)
//!
//! ```text
//! ⎡ H + μI   Ĉᵀ ⎤ ⎡ Δx ⎤   ⎡    −g     ⎤
//! ⎣   Ĉ      0  ⎦ ⎣ λ̂  ⎦ = ⎣ S (d − Cx) ⎦ ,       Ĉ = S C,
//! ```
//!
//! where `S` scales each constraint row by the inverse of its largest absolute entry (this
//! changes neither the constraint set nor the step, only the multipliers' scaling, and keeps the
//! KKT matrix reasonably balanced). The KKT matrix is indefinite, so it is factorized with
//! faer's sparse LU (partial pivoting); its full sparsity pattern (both triangles of `H`, `Ĉ`
//! and `Ĉᵀ`) and symbolic analysis are built once. The right-hand side `d − Cx` also removes
//! rounding drift of the constraints. Every solve is followed by one step of iterative
//! refinement. A null-space method was not used because a sparse null-space basis of a general
//! `C` is expensive to build and destroys sparsity.
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
//! `Δx = argmin ‖Δx‖₂ s.t. C(x₀ + Δx) = d`, from the same KKT pattern with `H = I`. Since every
//! later step satisfies `C Δx = d − Cx`, all iterates stay feasible and the line search needs
//! only the energy.
//!
//! **Rank check.** `C` must have full row rank, or the KKT matrix is singular. When the solver is
//! built, the system `[I Ĉᵀ; Ĉ 0] z = [0; r]` is solved for a fixed pseudo-random `r`: if
//! `C` is rank deficient, `r` is almost surely outside the range of `Ĉ`, no `z` can have a
//! small residual, and the solver reports [`SolveError::RankDeficientConstraints`]. (Faer's LU
//! itself only detects structural singularity.)

use faer::sparse::SparseColMat;

use crate::SolveError;
use crate::assembly::{Assembler, Problem, check_len};
use crate::linalg::SparseLu;
use crate::newton::{
    LinearSolver, NewtonReport, NewtonSettings, NewtonSystem, SystemFailure, inf_norm, run_newton,
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

/// Marks "no second KKT slot" (diagonal entries of `H` appear once).
const NONE: usize = usize::MAX;

/// The KKT back end of the Newton driver.
struct KktSystem {
    constraints: LinearConstraints,
    n: usize,
    /// `S_rr = 1 / max_c |C_rc|`.
    row_scale: Vec<f64>,
    c_norm_inf: f64,
    kkt: SparseColMat<usize, f64>,
    /// KKT value indices of `(i, j)` and `(j, i)` for each stored value of `H`'s lower triangle.
    h_slots: Vec<[usize; 2]>,
    /// KKT value index of `H_ii`.
    h_diag_slots: Vec<usize>,
    /// KKT value indices of `(n + r, c)` and `(c, n + r)` for each constraint triplet.
    c_slots: Vec<[usize; 2]>,
    lu: SparseLu,
    rhs: Vec<f64>,
    sol: Vec<f64>,
    work: Vec<f64>,
    /// Cholesky factor of `ĈĈᵀ` (dense, `m ≤ MAX_DENSE_MULTIPLIERS`) for the least-squares
    /// multipliers of the stationarity test.
    normal: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
}

/// Largest constraint count for which the stationarity test fits its own multipliers (a dense
/// `m × m` factorization once per solver); above it, the KKT solve's multipliers are used.
const MAX_DENSE_MULTIPLIERS: usize = 1024;

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

        // Full KKT pattern: both triangles of H, then Ĉ and Ĉᵀ.
        let h = asm.hessian();
        let h_sym = h.symbolic();
        let mut coords = Vec::new();
        let mut h_entries = Vec::new(); // (first coord, second coord or NONE) per H value
        for j in 0..n {
            for &i in &h_sym.row_idx()[h_sym.col_range(j)] {
                let first = coords.len();
                coords.push((i, j));
                let second = if i != j {
                    coords.push((j, i));
                    coords.len() - 1
                } else {
                    NONE
                };
                h_entries.push([first, second]);
            }
        }
        let mut c_entries = Vec::new();
        for &(r, c, _) in &constraints.triplets {
            coords.push((n + r, c));
            coords.push((c, n + r));
            c_entries.push([coords.len() - 2, coords.len() - 1]);
        }
        let (symbolic, slot) = build_pattern(n + m, n + m, &coords);
        let map = |[a, b]: [usize; 2]| [slot[a], if b == NONE { NONE } else { slot[b] }];
        let h_slots: Vec<[usize; 2]> = h_entries.into_iter().map(map).collect();
        let c_slots = c_entries.into_iter().map(map).collect();
        let h_diag_slots = asm
            .diagonal_slots()
            .iter()
            .map(|&d| h_slots[d][0])
            .collect();
        let lu = SparseLu::new(symbolic.as_ref())?;
        let nnz = symbolic.row_idx().len();
        let mut system = Self {
            c_norm_inf: constraints.norm_inf(),
            constraints: constraints.clone(),
            n,
            row_scale,
            kkt: SparseColMat::new(symbolic, vec![0.0; nnz]),
            h_slots,
            h_diag_slots,
            c_slots,
            lu,
            rhs: vec![0.0; n + m],
            sol: vec![0.0; n + m],
            work: vec![0.0; n + m],
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

    /// Writes `[H + μI, Ĉᵀ; Ĉ, 0]` into the KKT values; `h = None` means `H = I`.
    fn fill(&mut self, h: Option<&[f64]>, mu: f64) {
        let values = self.kkt.val_mut();
        values.fill(0.0);
        match h {
            Some(h) => {
                for (&v, &[a, b]) in h.iter().zip(&self.h_slots) {
                    values[a] += v;
                    if b != NONE {
                        values[b] += v;
                    }
                }
            }
            None => self.h_diag_slots.iter().for_each(|&d| values[d] = 1.0),
        }
        for &d in &self.h_diag_slots {
            values[d] += mu;
        }
        for (&(r, _, v), &[a, b]) in self.constraints.triplets.iter().zip(&self.c_slots) {
            values[a] += v * self.row_scale[r];
            values[b] += v * self.row_scale[r];
        }
    }

    /// Solves `K sol = rhs` with the current factorization plus one step of iterative
    /// refinement; errors on non-finite results.
    fn solve_refined(&mut self) -> Result<(), String> {
        self.sol.copy_from_slice(&self.rhs);
        self.lu.solve_in_place(&mut self.sol)?;
        self.residual_into_work();
        self.lu.solve_in_place(&mut self.work)?;
        for (s, w) in self.sol.iter_mut().zip(&self.work) {
            *s += w;
        }
        if self.sol.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err("non-finite KKT solution (singular KKT matrix)".into())
        }
    }

    /// `work = rhs − K sol`.
    fn residual_into_work(&mut self) {
        self.work.copy_from_slice(&self.rhs);
        let k = self.kkt.as_ref();
        let (sym, values) = (k.symbolic(), k.val());
        for j in 0..self.sol.len() {
            let range = sym.col_range(j);
            for (&i, &v) in sym.row_idx()[range.clone()].iter().zip(&values[range]) {
                self.work[i] -= v * self.sol[j];
            }
        }
    }

    /// Rejects a rank-deficient `C` (see the module documentation).
    fn check_rank(&mut self) -> Result<(), SolveError> {
        let m = self.constraints.n_constraints();
        if m == 0 {
            return Ok(());
        }
        self.fill(None, 0.0);
        self.lu.factorize(self.kkt.as_ref()).map_err(|e| {
            SolveError::RankDeficientConstraints(format!("KKT matrix structurally singular ({e})"))
        })?;
        // Fixed xorshift sequence in [1, 2): generic, deterministic.
        let mut seed = 0x9E37_79B9_7F4A_7C15_u64;
        self.rhs[..self.n].fill(0.0);
        for r in self.rhs[self.n..].iter_mut() {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            *r = 1.0 + (seed >> 11) as f64 / (1u64 << 53) as f64;
        }
        let solved = self.solve_refined();
        self.residual_into_work();
        let residual = inf_norm(&self.work);
        let accurate = residual <= 1e-8 * inf_norm(&self.rhs); // false for NaN
        if solved.is_err() || !accurate {
            return Err(SolveError::RankDeficientConstraints(format!(
                "C has (numerically) dependent rows: a generic right-hand side leaves a KKT \
                 residual of {residual:.3e}"
            )));
        }
        Ok(())
    }

    /// Replaces `x` by its Euclidean projection onto `{Cx = d}`.
    fn restore_feasibility(&mut self, x: &mut [f64]) -> Result<(), SolveError> {
        self.fill(None, 0.0);
        self.lu
            .factorize(self.kkt.as_ref())
            .map_err(|e| SolveError::RankDeficientConstraints(e.to_string()))?;
        self.rhs[..self.n].fill(0.0);
        for r in 0..self.constraints.n_constraints() {
            self.rhs[self.n + r] = -self.row_scale[r] * self.constraints.row_residual(r, x);
        }
        self.solve_refined()
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
        self.fill(Some(asm.hessian().val()), mu);
        self.lu.factorize(self.kkt.as_ref())?;
        let gradient = asm.last_gradient();
        for (r, g) in self.rhs[..n].iter_mut().zip(gradient) {
            *r = -g;
        }
        for r in 0..self.constraints.n_constraints() {
            self.rhs[n + r] = -self.row_scale[r] * self.constraints.row_residual(r, x);
        }
        self.solve_refined()?;
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
}

/// A reusable equality-constrained Newton minimizer for one problem structure and one
/// constraint matrix (the KKT pattern, its symbolic LU and the rank check are done once).
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
                "constrained Newton solves its KKT system by sparse LU; choose \
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
        )
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
