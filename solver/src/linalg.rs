//! A thin wrapper around faer's sparse Cholesky factorization with a fixed sparsity pattern.
//!
//! The symbolic analysis (fill-reducing ordering, elimination tree, supernodes) is done once in
//! `new`; `factorize` only redoes the numeric part for new values on the same pattern. The
//! caller chooses between faer's simplicial and supernodal numeric factorizations
//! ([`Factorization`]). All
//! workspace is allocated up front. Everything runs with [`Par::Seq`], so results never depend
//! on the rayon thread count (the assembly is where the parallelism is).

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

/// Sparse Cholesky `A = L Lᵀ` of a symmetric positive definite matrix given by its lower
/// triangle (rows ≥ columns), with AMD ordering.
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

pub(crate) struct SparseLlt {
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
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
            symbolic.solve_in_place_scratch::<f64>(max_columns.max(1), Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req).map_err(|_| {
            SolveError::LinearAlgebra("out of memory for Cholesky workspace".into())
        })?;
        let l_values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            symbolic,
            l_values,
            mem,
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
