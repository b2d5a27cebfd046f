//! The unconstrained back end of the Newton loop: sparse Cholesky or preconditioned CG on the
//! free DOFs.

use crate::SolveError;
use crate::assembly::Assembler;
use crate::linalg::SparseLlt;
use crate::pcg::{Pcg, PcgFailure, PcgSettings};

use super::driver::{NewtonSystem, SystemFailure};
use super::{LinearSolver, NewtonSettings};

/// The unconstrained back end: sparse Cholesky or preconditioned CG on `H_ff + μ I`.
pub(super) struct FreeDofSystem {
    /// Built on the first Cholesky solve (symbolic analysis once per solver).
    llt: Option<SparseLlt>,
    /// Built on the first CG solve.
    pcg: Option<Pcg>,
    /// The linear solver of the current run (set by [`super::NewtonSolver::minimize`]).
    linear_solver: LinearSolver,
    /// CG iterations of the last successful solve (0 for Cholesky).
    linear_iterations: usize,
    /// Hessian row of each DOF (`None` if fixed).
    free_index: Vec<Option<usize>>,
    rhs: Vec<f64>,
    solution: Vec<f64>,
    diag_backup: Vec<f64>,
}

impl FreeDofSystem {
    /// The back end for `assembler`'s free DOFs (factorizations built on first use).
    pub(super) fn new(assembler: &Assembler) -> Self {
        let n_free = assembler.n_free();
        let free_index = (0..assembler.n_dofs())
            .map(|d| assembler.free_index(d))
            .collect();
        Self {
            llt: None,
            pcg: None,
            linear_solver: LinearSolver::Cholesky,
            linear_iterations: 0,
            free_index,
            rhs: vec![0.0; n_free],
            solution: Vec::new(),
            diag_backup: vec![0.0; n_free],
        }
    }

    /// Builds the back end `linear_solver` needs for `asm`'s pattern, if not yet built.
    pub(super) fn prepare(
        &mut self,
        asm: &Assembler,
        linear_solver: LinearSolver,
    ) -> Result<(), SolveError> {
        self.linear_solver = linear_solver;
        if asm.n_free() == 0 {
            return Ok(());
        }
        match linear_solver {
            LinearSolver::Cholesky if self.llt.is_none() => {
                self.llt = Some(SparseLlt::new(asm.hessian().symbolic())?);
            }
            LinearSolver::ConjugateGradient(_) if self.pcg.is_none() => {
                self.pcg = Some(Pcg::new(asm.hessian())?);
                self.solution = vec![0.0; asm.n_free()];
            }
            _ => {}
        }
        Ok(())
    }

    /// `H_ff + μ I` solved by Cholesky for `self.rhs` (in place).
    fn solve_cholesky(&mut self, asm: &mut Assembler, mu: f64) -> Result<(), SystemFailure> {
        let llt = self
            .llt
            .as_mut()
            .ok_or("Cholesky solve requested before its symbolic analysis")?;
        // Shift the diagonal in place, factorize, and restore it.
        let (values, diag) = asm.hessian_values_and_diagonal();
        for (b, &d) in self.diag_backup.iter_mut().zip(diag) {
            *b = values[d];
            values[d] += mu;
        }
        let factorized = llt.factorize(asm.hessian());
        let (values, diag) = asm.hessian_values_and_diagonal();
        for (&b, &d) in self.diag_backup.iter().zip(diag) {
            values[d] = b;
        }
        factorized?;
        llt.solve_in_place(&mut self.rhs)?;
        self.linear_iterations = 0;
        Ok(())
    }

    /// `H_ff + μ I` solved by PCG for `self.rhs` (in place).
    fn solve_pcg(
        &mut self,
        asm: &Assembler,
        mu: f64,
        settings: &PcgSettings,
    ) -> Result<(), SystemFailure> {
        let pcg = self
            .pcg
            .as_mut()
            .ok_or("CG solve requested before its workspace was built")?;
        match pcg.solve(asm.hessian(), mu, &self.rhs, &mut self.solution, settings) {
            Ok(r) => {
                self.linear_iterations = r.iterations;
                self.rhs.copy_from_slice(&self.solution);
                Ok(())
            }
            Err(e @ PcgFailure::NotConverged { .. }) => Err(SystemFailure::Fatal(e.to_string())),
            Err(e) => Err(SystemFailure::Retry(e.to_string())),
        }
    }
}

impl NewtonSystem for FreeDofSystem {
    fn residual_before_solve(&self, gradient: &[f64]) -> Option<f64> {
        Some(
            gradient
                .iter()
                .zip(&self.free_index)
                .filter(|(_, f)| f.is_some())
                .fold(0.0, |m, (g, _)| m.max(g.abs())),
        )
    }

    fn solve(
        &mut self,
        asm: &mut Assembler,
        _x: &[f64],
        mu: f64,
        dx: &mut [f64],
    ) -> Result<f64, SystemFailure> {
        dx.fill(0.0);
        if self.rhs.is_empty() {
            return Ok(0.0); // no free DOFs: nothing to solve
        }
        let gradient = asm.last_gradient();
        for (dof, f) in self.free_index.iter().enumerate() {
            if let Some(i) = *f {
                self.rhs[i] = -gradient[dof];
            }
        }
        match self.linear_solver {
            LinearSolver::Cholesky => self.solve_cholesky(asm, mu)?,
            LinearSolver::ConjugateGradient(settings) => self.solve_pcg(asm, mu, &settings)?,
        }
        if !self.rhs.iter().all(|v| v.is_finite()) {
            return Err("non-finite Newton step".into());
        }
        for (dof, f) in self.free_index.iter().enumerate() {
            if let Some(i) = *f {
                dx[dof] = self.rhs[i];
            }
        }
        Ok(self
            .residual_before_solve(asm.last_gradient())
            .unwrap_or(0.0))
    }

    fn violation(&self, _x: &[f64], _settings: &NewtonSettings) -> Option<(bool, f64)> {
        None
    }

    fn last_linear_iterations(&self) -> usize {
        self.linear_iterations
    }

    fn residual_without_solve(&self) -> bool {
        true
    }
}
