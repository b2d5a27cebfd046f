//! Implicit differentiation of an equilibrium: total derivatives of the gathered stress
//! (seed 002 Eq. 10) with respect to the coarse map and to parameters of the energy, for the
//! gradient-based step of the yarn fit ([`crate::fit`]).
//!
//! At an equilibrium `ũ*(θ)` of `E(ũ; θ)` under the linear constraints `C ũ = d` (which do not
//! depend on `θ`),
//!
//! ```text
//! [H Cᵀ; C 0] [dũ/dθ; ·] = [−∂g/∂θ; 0],      dP/dθ = ∂P/∂θ + ∂P/∂ũ · dũ/dθ
//! ```
//!
//! ([`solver::ConstrainedNewtonSolver::sensitivities`]), with `g = ∂E/∂ũ` and the partial
//! derivatives taken at fixed `ũ` ([`Partial`]). For a flat coarse map every stencil point sits
//! at `x = F Y + ũ`, so the mixed derivatives come exactly from the stencils' Hessians `H_k`:
//!
//! ```text
//! ∂g/∂F : δF  = Σ_k scatter(H_k w_k),                 w_k = (δF Y_{k,i})_i  (twists 0)
//! ∂P_rc/∂F : δF = 1/A Σ_k Σ_i (H_k w_k)_{i,r} Y_{k,i,c}
//! ∂P_rc/∂ũ · y  = 1/A Σ_k Σ_i (H_k y_k)_{i,r} Y_{k,i,c}   (y_k: y gathered on the stencil)
//! ```
//!
//! Pairs are those of the equilibrium (contact pairs do not change under an infinitesimal
//! perturbation unless two edges sit exactly at the cutoff, where the barrier is C²-flat).

use super::{Equilibrium, PeriodicError, PeriodicTile, YarnModel};
use nalgebra::{Matrix2, Matrix3, Vector3};
use solver::{ConstrainedNewtonSolver, MAX_TERM_DOFS, Problem};
use yarn_pattern::tile::Tile;

/// The partial derivatives of a perturbation `θ` at fixed `ũ`: of the energy gradient
/// (`∂g/∂θ`, one entry per DOF) and of the gathered stress (`∂P/∂θ`, N/m per unit `θ`).
#[derive(Clone, Debug, PartialEq)]
pub struct Partial {
    /// `∂g/∂θ`.
    pub gradient: Vec<f64>,
    /// `∂P/∂θ`.
    pub stress: Matrix2<f64>,
}

/// `(H d, ∂P/∂· d)` of one direction `d`.
type Product = (Vec<f64>, Matrix2<f64>);

/// A direction for [`PeriodicTile::hessian_products`].
enum Direction<'a> {
    /// A change `δF` of the (flat) coarse map.
    Coarse(Matrix2<f64>),
    /// A change of the DOFs.
    Dofs(&'a [f64]),
}

impl PeriodicTile<'_> {
    /// The energy gradient (one entry per DOF) and the gathered stress at `x`.
    pub fn gradient_and_stress(
        &self,
        x: &[f64],
    ) -> Result<(Vec<f64>, Matrix2<f64>), PeriodicError> {
        let mut asm = solver::Assembler::new(self)?;
        let (_, g) = asm.gradient(self, x)?;
        Ok((g.to_vec(), self.stress(x)))
    }

    /// The partial derivatives at `x` along a change `δF` of the coarse map (flat only).
    pub fn coarse_partial(&self, x: &[f64], df: &Matrix2<f64>) -> Result<Partial, PeriodicError> {
        let mut out = self.hessian_products(x, &[Direction::Coarse(*df)])?;
        let (gradient, stress) = out.pop().expect("one direction");
        Ok(Partial { gradient, stress })
    }

    /// `(H d, ∂P/∂· d)` for each direction `d` (module documentation), from one evaluation of
    /// every stencil Hessian. Flat coarse maps only.
    fn hessian_products(
        &self,
        x: &[f64],
        directions: &[Direction<'_>],
    ) -> Result<Vec<Product>, PeriodicError> {
        if self.coarse.curvature.is_some_and(|c| c.kappa != 0.0) {
            return Err(PeriodicError::Invalid(
                "stress sensitivities are implemented for flat coarse maps only".into(),
            ));
        }
        let n = self.n_dofs();
        let mut out: Vec<Product> = directions
            .iter()
            .map(|_| (vec![0.0; n], Matrix2::zeros()))
            .collect();
        let mut g = [0.0; MAX_TERM_DOFS];
        let mut h = vec![0.0; MAX_TERM_DOFS * MAX_TERM_DOFS];
        let mut w = [0.0; MAX_TERM_DOFS];
        for k in 0..self.terms.len() {
            let dofs = self.terms.dofs(k);
            let nl = dofs.len();
            let (g, h) = (&mut g[..nl], &mut h[..nl * nl]);
            h.fill(0.0);
            self.terms.eval_stencil(k, x, g, Some(&mut h[..]));
            let mut ys = [Vector3::zeros(); MAX_TERM_DOFS / 3];
            let ys = &mut ys[..self.points[k].len()];
            for (y, &(v, shift)) in ys.iter_mut().zip(&self.points[k]) {
                *y = self.tile.positions[v] + self.tile.period_offset(shift);
            }
            for (direction, (hd, dp)) in directions.iter().zip(&mut out) {
                let w = &mut w[..nl];
                w.fill(0.0);
                match direction {
                    Direction::Coarse(df) => {
                        let mut f3 = Matrix3::zeros();
                        f3.fixed_view_mut::<2, 2>(0, 0).copy_from(df);
                        for (i, y) in ys.iter().enumerate() {
                            let d = f3 * y;
                            w[3 * i..3 * i + 3].copy_from_slice(d.as_slice());
                        }
                    }
                    Direction::Dofs(y) => {
                        for (wi, &dof) in w.iter_mut().zip(dofs) {
                            *wi = y[dof];
                        }
                    }
                }
                // H_k w (column-major, symmetric).
                for (j, &wj) in w.iter().enumerate() {
                    if wj == 0.0 {
                        continue;
                    }
                    let column = &h[j * nl..(j + 1) * nl];
                    for (i, &hij) in column.iter().enumerate() {
                        let v = hij * wj;
                        hd[dofs[i]] += v;
                        if i < 3 * ys.len() {
                            let (point, r) = (i / 3, i % 3);
                            if r < 2 {
                                for c in 0..2 {
                                    dp[(r, c)] += v * ys[point][c];
                                }
                            }
                        }
                    }
                }
            }
        }
        let area = self.area();
        for (_, dp) in &mut out {
            *dp /= area;
        }
        Ok(out)
    }
}

/// The problem of the equilibrium `eq` of `tile` under `model` (its coarse map and contact
/// pairs), for [`PeriodicTile::coarse_partial`] and [`stress_sensitivities`].
pub fn equilibrium_problem<'t>(
    tile: &'t Tile,
    model: &YarnModel,
    eq: &Equilibrium,
) -> Result<PeriodicTile<'t>, PeriodicError> {
    PeriodicTile::new(tile, *model, eq.coarse, eq.pairs.clone())
}

/// Total derivatives `dP/dθ` (N/m per unit `θ`) of the gathered stress at the equilibrium
/// DOFs `x` of `problem` ([`equilibrium_problem`]), one per [`Partial`] (module
/// documentation). Flat coarse maps only; errors with the solver's `NotAStrictMinimum` when
/// `x` is not a strict constrained minimum.
pub fn stress_sensitivities(
    problem: &PeriodicTile<'_>,
    x: &[f64],
    partials: &[Partial],
) -> Result<Vec<Matrix2<f64>>, PeriodicError> {
    let constraints = problem.constraints()?;
    let mut solver = ConstrainedNewtonSolver::new(problem, &constraints)?;
    let rhs: Vec<Vec<f64>> = partials
        .iter()
        .map(|p| p.gradient.iter().map(|g| -g).collect())
        .collect();
    let moves = solver.sensitivities(problem, x, &rhs)?;
    let directions: Vec<Direction<'_>> = moves.iter().map(|y| Direction::Dofs(y)).collect();
    let products = problem.hessian_products(x, &directions)?;
    Ok(partials
        .iter()
        .zip(products)
        .map(|(p, (_, dp))| p.stress + dp)
        .collect())
}
