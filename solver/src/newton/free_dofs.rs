//! The unconstrained back end of the Newton loop: sparse Cholesky or preconditioned CG on the
//! free DOFs.

use crate::SolveError;
use crate::assembly::Assembler;
use crate::linalg::{Factorization, SparseLlt};
use crate::pcg::{Pcg, PcgFailure, PcgSettings};

use super::driver::{NewtonSystem, SystemFailure};
use super::{LinearSolver, NewtonSettings};

/// How many directions of negative curvature the CG back end keeps (two per step on the
/// dressed sweater of `sim-persistent/examples/scaling.rs`: those of the attempts at `μ = 0`
/// and one rung below the accepted shift, so four cover the last two steps).
const KNOWN_DIRECTIONS: usize = 4;

/// The unconstrained back end: sparse Cholesky or preconditioned CG on `H_ff + μ I`.
///
/// **Known unstable directions (CG).** A CG solve that stops as indefinite leaves a direction
/// `v` (unit length) with `vᵀ(H + μI)v ≤ 0`; the back end keeps the last few. Before a solve
/// at shift `μ'` it evaluates `vᵀ H v` of each on the current Hessian (one product per
/// direction and Hessian) and, if some `vᵀ H v + μ' ≤ 0`, rejects the shift at once: `H + μ'I`
/// is provably not positive definite, so the attempt could only fail (or, should CG miss the
/// indefiniteness, return a step of an indefinite system). The Newton driver then escalates
/// as after a failed solve, without the factorization and iterations the attempt would cost.
/// Where the needed shift stays put from step to step, as on the dressed sweater, the
/// attempts below it are skipped instead of repeated every step.
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
    /// The last successful CG solution: the start of the next solve with
    /// [`PcgSettings::warm_start`] (zero before the first).
    last_solution: Vec<f64>,
    /// Directions of negative curvature found by earlier CG solves.
    unstable: UnstableDirections,
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
            last_solution: Vec::new(),
            unstable: UnstableDirections::default(),
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
                self.llt = Some(SparseLlt::new(
                    asm.hessian().symbolic(),
                    Factorization::Auto,
                    1,
                )?);
            }
            LinearSolver::ConjugateGradient(_) if self.pcg.is_none() => {
                self.pcg = Some(Pcg::new(asm.hessian())?);
                self.solution = vec![0.0; asm.n_free()];
                self.last_solution = vec![0.0; asm.n_free()];
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
        let rejected = self
            .unstable
            .rejects(pcg, asm, mu)
            .map_err(|e| SystemFailure::Retry(e.to_string()))?;
        if let Some(curvature) = rejected {
            return Err(SystemFailure::Indefinite(format!(
                "PCG: matrix is not positive definite (a direction of negative curvature \
                 found earlier has vᵀ(H + μI)v = {curvature:.3e})"
            )));
        }
        if settings.warm_start {
            self.solution.copy_from_slice(&self.last_solution);
        }
        match pcg.solve(asm.hessian(), mu, &self.rhs, &mut self.solution, settings) {
            Ok(r) => {
                self.linear_iterations = r.iterations;
                self.rhs.copy_from_slice(&self.solution);
                self.last_solution.copy_from_slice(&self.solution);
                Ok(())
            }
            Err(e @ PcgFailure::NotConverged { .. }) => Err(SystemFailure::Fatal(e.to_string())),
            Err(e) => {
                if let Some((p, rho)) = pcg.negative_curvature() {
                    // Its curvature on this Hessian is known: vᵀHv = ρ − μ.
                    self.unstable.record(p, rho - mu, asm.hessian_count());
                }
                Err(SystemFailure::Retry(e.to_string()))
            }
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

/// The directions of negative curvature at which earlier CG solves stopped (see
/// [`FreeDofSystem`]), with their curvatures on the current Hessian.
#[derive(Default)]
struct UnstableDirections {
    /// Unit 2-norm, free-DOF numbering, oldest first, at most [`KNOWN_DIRECTIONS`].
    directions: Vec<Vec<f64>>,
    /// `vᵀ H v` of every direction for the Hessian of assembly number `curvatures.0`
    /// (`None`: not computed for the current Hessian yet).
    curvatures: Option<(u64, Vec<f64>)>,
}

impl UnstableDirections {
    /// `Some(vᵀ(H + μI)v ≤ 0)` of a known direction if one proves `H + μI` (`H` the
    /// assembler's current Hessian) indefinite. The first call for a new Hessian evaluates
    /// every direction's curvature on it (one product each) and forgets those with
    /// `vᵀHv > 0`: no shift `μ ≥ 0` of this Hessian can be rejected by them, and a later
    /// Hessian that curves down along them again shows it by a failed solve.
    fn rejects(
        &mut self,
        pcg: &mut Pcg,
        asm: &Assembler,
        mu: f64,
    ) -> Result<Option<f64>, PcgFailure> {
        if self.directions.is_empty() {
            return Ok(None);
        }
        let current = asm.hessian_count();
        if self
            .curvatures
            .as_ref()
            .is_none_or(|(of, _)| *of != current)
        {
            let mut curvatures = Vec::with_capacity(self.directions.len());
            for v in &self.directions {
                curvatures.push(pcg.quadratic_form(asm.hessian(), v)?);
            }
            let mut kept = curvatures.iter().map(|&c| c <= 0.0);
            self.directions.retain(|_| kept.next() == Some(true));
            curvatures.retain(|&c| c <= 0.0);
            self.curvatures = Some((current, curvatures));
        }
        let curvatures = self.curvatures.as_ref().map_or(&[][..], |(_, c)| &c[..]);
        Ok(curvatures.iter().map(|&c| c + mu).find(|&c| c <= 0.0))
    }

    /// Keeps the direction `p` (any length; stored normalized) of curvature `vᵀHv =
    /// curvature` on the Hessian of assembly number `hessian`, dropping the oldest beyond
    /// [`KNOWN_DIRECTIONS`].
    fn record(&mut self, p: &[f64], curvature: f64, hessian: u64) {
        let norm = p.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return;
        }
        if self.directions.is_empty() {
            self.curvatures = Some((hessian, Vec::new()));
        }
        // The oldest direction's buffer is reused once the set is full.
        let mut v = if self.directions.len() == KNOWN_DIRECTIONS {
            if let Some((_, c)) = &mut self.curvatures {
                c.remove(0);
            }
            self.directions.remove(0)
        } else {
            Vec::with_capacity(p.len())
        };
        v.clear();
        v.extend(p.iter().map(|x| x / norm));
        self.directions.push(v);
        match &mut self.curvatures {
            Some((of, c)) if *of == hessian => c.push(curvature),
            _ => self.curvatures = None,
        }
    }
}
