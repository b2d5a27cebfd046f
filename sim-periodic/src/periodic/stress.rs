//! The gathered stress `∂Ψ/∂F₂` (seed 002 Eq. 10).

use super::PeriodicTile;
use nalgebra::{Matrix2, Vector3};
use solver::MAX_TERM_DOFS;

impl PeriodicTile<'_> {
    /// `∂Ψ/∂F₂` (Pa·m = N/m) gathered from the stencil forces (seed 002 Eq. 10): with positions
    /// `x̄(Y_k) + R ũ` and `p = F Y_k`, `∂E/∂F = Σ_k (J_kᵀ g_k) Y_kᵀ` by the chain rule, `J_k` the
    /// Jacobian of `p ↦ φ(p) + R(p) ũ` ([`crate::coarse::Coarse::map_jacobian`], the identity when flat); at
    /// equilibrium (∂E/∂ũ = 0) it is the derivative of the equilibrium energy density with
    /// respect to `F` at fixed curvature.
    pub fn stress(&self, x: &[f64]) -> Matrix2<f64> {
        let mut p = Matrix2::zeros();
        let mut g = [0.0; MAX_TERM_DOFS];
        for k in 0..self.terms.len() {
            let dofs = self.terms.dofs(k);
            // The stencil's gradient with respect to its local vector (point positions, then
            // twists).
            let q = self.local_positions(k, x);
            let g = &mut g[..q.len()];
            self.terms.term(k).local_eval(&q, g, None);
            for (i, &(v, shift)) in self.points[k].iter().enumerate() {
                let y = self.tile.positions[v] + self.tile.period_offset(shift);
                let u = Vector3::new(x[dofs[3 * i]], x[dofs[3 * i + 1]], x[dofs[3 * i + 2]]);
                // ∂x/∂F_rc = J e_r Y_c with J the Jacobian of p ↦ φ(p) + R(p) ũ (I when flat).
                let gj = self.coarse.map_jacobian(&y, &u).transpose()
                    * Vector3::new(g[3 * i], g[3 * i + 1], g[3 * i + 2]);
                for r in 0..2 {
                    for c in 0..2 {
                        p[(r, c)] += gj[r] * y[c];
                    }
                }
            }
        }
        p / self.area()
    }
}
