//! A thin wrapper around faer's sparse Cholesky factorization with a fixed sparsity pattern.
//!
//! The symbolic analysis (fill-reducing ordering, elimination tree, supernodes) is done once in
//! `new`; `factorize` only redoes the numeric part for new values on the same pattern. The
//! caller chooses between faer's simplicial and supernodal numeric factorizations
//! ([`Factorization`]). All workspace is allocated up front. Everything runs with
//! [`Par::Seq`], so results never depend on the rayon thread count (the assembly is where the
//! parallelism is).

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::SolveError;

/// Which numeric factorization [`SparseLlt`] runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Factorization {
    /// faer's choice: supernodal (dense blocks) when the symbolic analysis counts more than
    /// 40 flops per stored factor entry, simplicial (one column at a time) otherwise.
    Auto,
    /// Always supernodal: for factors that are dense or nearly so, where faer's count still
    /// picks the simplicial method (see `constrained.rs`).
    Supernodal,
}

/// Sparse Cholesky `A = L Lᵀ` of a symmetric positive definite matrix given by its lower
/// triangle (rows ≥ columns), with AMD ordering.
pub(crate) struct SparseLlt {
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    /// Most right-hand sides the workspace holds.
    max_columns: usize,
    factorized: bool,
}

impl SparseLlt {
    /// Symbolic analysis of the lower-triangular pattern `lower`, with workspace for solves
    /// of up to `max_columns` right-hand sides at once.
    pub(crate) fn new(
        lower: SymbolicSparseColMatRef<'_, usize>,
        factorization: Factorization,
        max_columns: usize,
    ) -> Result<Self, SolveError> {
        let max_columns = max_columns.max(1);
        let supernodal_flop_ratio_threshold = match factorization {
            Factorization::Auto => SupernodalThreshold::AUTO,
            Factorization::Supernodal => SupernodalThreshold::FORCE_SUPERNODAL,
        };
        let symbolic = factorize_symbolic_cholesky(
            lower,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold,
                ..CholeskySymbolicParams::default()
            },
        )
        .map_err(|e| SolveError::LinearAlgebra(format!("symbolic Cholesky: {e:?}")))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(max_columns, Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req).map_err(|_| {
            SolveError::LinearAlgebra("out of memory for Cholesky workspace".into())
        })?;
        let l_values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            symbolic,
            l_values,
            mem,
            max_columns,
            factorized: false,
        })
    }

    /// Numeric factorization of `a` (same pattern as in `new`, lower triangle). Fails if a pivot
    /// is not positive (the matrix is not numerically positive definite).
    pub(crate) fn factorize(&mut self, a: SparseColMatRef<'_, usize, f64>) -> Result<(), String> {
        self.factorized = false;
        self.symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| format!("Cholesky: {e:?}"))?;
        self.factorized = true;
        Ok(())
    }

    /// Overwrites `rhs` with `A⁻¹ rhs` using the last successful factorization.
    pub(crate) fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), String> {
        self.solve_columns_in_place(rhs, 1)
    }

    /// Overwrites the `columns` right-hand sides stored one after another in `rhs` (column
    /// major, `columns ≤ max_columns` of [`SparseLlt::new`]) with `A⁻¹ rhs`, in one blocked
    /// solve.
    pub(crate) fn solve_columns_in_place(
        &mut self,
        rhs: &mut [f64],
        columns: usize,
    ) -> Result<(), String> {
        if !self.factorized {
            return Err("solve requested without a valid factorization".into());
        }
        if columns == 0 {
            return Ok(());
        }
        if columns > self.max_columns || !rhs.len().is_multiple_of(columns) {
            return Err(format!(
                "solve of {} values as {columns} columns (workspace for {})",
                rhs.len(),
                self.max_columns
            ));
        }
        let n = rhs.len() / columns;
        LltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, columns),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        Ok(())
    }
}

/// `out ← out − H x` for a symmetric `H` stored as one triangle (either), column by column.
pub(crate) fn symmetric_multiply_sub(
    h: SparseColMatRef<'_, usize, f64>,
    x: &[f64],
    out: &mut [f64],
) {
    let (sym, values) = (h.symbolic(), h.val());
    for (j, &xj) in x.iter().enumerate() {
        let range = sym.col_range(j);
        for (&i, &v) in sym.row_idx()[range.clone()].iter().zip(&values[range]) {
            out[i] -= v * xj;
            if i != j {
                out[j] -= v * x[i];
            }
        }
    }
}

/// `vᵀHv` for a symmetric `H` stored as one triangle (either).
pub(crate) fn symmetric_quadratic_form(h: SparseColMatRef<'_, usize, f64>, v: &[f64]) -> f64 {
    let (sym, values) = (h.symbolic(), h.val());
    let mut sum = 0.0;
    for (j, &vj) in v.iter().enumerate() {
        let range = sym.col_range(j);
        for (&i, &hij) in sym.row_idx()[range.clone()].iter().zip(&values[range]) {
            let w = hij * v[i] * vj;
            sum += if i == j { w } else { 2.0 * w };
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pattern::build_pattern;
    use faer::sparse::SparseColMat;

    /// A symmetric positive definite test matrix: a tridiagonal band plus a dense first row
    /// and column (the shape of a periodic tile's zero-mean constraint rows), lower triangle.
    fn banded_with_dense_row(n: usize) -> SparseColMat<usize, f64> {
        let mut entries = Vec::new();
        for i in 0..n {
            entries.push((i, i, 4.0 + i as f64 * 0.01));
            if i + 1 < n {
                entries.push((i + 1, i, -1.0));
            }
            if i > 1 {
                entries.push((i, 0, 0.1));
            }
        }
        let coords: Vec<(usize, usize)> = entries.iter().map(|&(i, j, _)| (i, j)).collect();
        let (symbolic, slot) = build_pattern(n, n, &coords);
        let mut values = vec![0.0; symbolic.row_idx().len()];
        for (&(_, _, v), &s) in entries.iter().zip(&slot) {
            values[s] += v;
        }
        SparseColMat::new(symbolic, values)
    }

    /// `A x` for the lower triangle `a` of a symmetric matrix.
    fn apply(a: &SparseColMat<usize, f64>, x: &[f64]) -> Vec<f64> {
        let mut minus = vec![0.0; x.len()];
        symmetric_multiply_sub(a.as_ref(), x, &mut minus);
        minus.iter().map(|v| -v).collect()
    }

    /// Each factorization runs the method asked for (faer's own choice is simplicial on this
    /// sparse matrix), both solve one and several right-hand sides to rounding, a blocked solve
    /// equals column-by-column solves, and a solve wider than the workspace is an error.
    #[test]
    fn simplicial_and_supernodal_solves_agree_with_the_matrix() {
        let n = 40;
        let a = banded_with_dense_row(n);
        let columns = 3;
        let x: Vec<f64> = (0..n * columns)
            .map(|k| ((k * 7) % 11) as f64 - 5.0)
            .collect();
        let b: Vec<f64> = x.chunks(n).flat_map(|c| apply(&a, c)).collect();
        for kind in [Factorization::Auto, Factorization::Supernodal] {
            let mut llt = SparseLlt::new(a.symbolic(), kind, columns).unwrap();
            let supernodal = matches!(
                llt.symbolic.raw(),
                faer::sparse::linalg::cholesky::SymbolicCholeskyRaw::Supernodal(_)
            );
            assert_eq!(supernodal, kind == Factorization::Supernodal, "{kind:?}");
            llt.factorize(a.as_ref()).unwrap();
            let mut blocked = b.clone();
            llt.solve_columns_in_place(&mut blocked, columns).unwrap();
            for (k, column) in b.chunks(n).enumerate() {
                let mut single = column.to_vec();
                llt.solve_in_place(&mut single).unwrap();
                for i in 0..n {
                    let exact = x[k * n + i];
                    assert!((single[i] - exact).abs() < 1e-12, "{kind:?}: {single:?}");
                    assert!((blocked[k * n + i] - single[i]).abs() < 1e-13, "{kind:?}");
                }
            }
            let mut too_wide = vec![0.0; n * (columns + 1)];
            assert!(
                llt.solve_columns_in_place(&mut too_wide, columns + 1)
                    .is_err()
            );
            assert!(
                llt.solve_columns_in_place(&mut vec![0.0; n + 1], 2)
                    .is_err()
            );
        }
    }
}
