//! The chain rule on a bent coarse surface: stencil positions `x̄ + R ũ` with a local frame
//! `R` per point ([`crate::coarse::Coarse::frame`]).

use super::PeriodicTile;
use nalgebra::Vector3;
use solver::LocalVector;

/// The largest stencil of a tile (an edge–edge contact: 4 points).
pub(super) const MAX_LOCAL: usize = 12;

impl PeriodicTile<'_> {
    /// The stencil's local vector `q`: point positions `x̄ + R ũ` followed by its twist DOFs
    /// (`x̄ + ũ` when flat).
    pub(super) fn local_positions(&self, k: usize, x: &[f64]) -> LocalVector {
        let mut q = self.terms.gather(k, x);
        let dofs = self.terms.dofs(k);
        let offset = self
            .terms
            .offset(k)
            .expect("set_coarse gives every stencil its offset");
        for (i, r) in self.frames[k].iter().enumerate() {
            let u = Vector3::new(x[dofs[3 * i]], x[dofs[3 * i + 1]], x[dofs[3 * i + 2]]);
            let p = r * u;
            for c in 0..3 {
                q[3 * i + c] = offset[3 * i + c] + p[c];
            }
        }
        q
    }

    /// [`solver::Problem::eval_stencil`] on a bent coarse surface: chain rule through the
    /// point frames, `∂/∂ũ_i = R_iᵀ ∂/∂x_i` and Hessian blocks `R_iᵀ H_ij R_j` (twist DOFs
    /// unrotated).
    pub(super) fn eval_bent(
        &self,
        k: usize,
        x: &[f64],
        grad: &mut [f64],
        hess: Option<&mut [f64]>,
    ) -> f64 {
        let frames = &self.frames[k];
        let q = self.local_positions(k, x);
        let n = q.len();
        let (mut g, mut h) = ([0.0; MAX_LOCAL], [0.0; MAX_LOCAL * MAX_LOCAL]);
        let (g, h) = (&mut g[..n], &mut h[..n * n]);
        let energy = self
            .terms
            .term(k)
            .local_eval(&q, g, hess.is_some().then_some(&mut *h));
        let np = frames.len();
        // Block-diagonal T with R_i for the points and 1 for twist DOFs: grad = Tᵀ g.
        let t = |row: usize, col: usize| -> f64 {
            if row / 3 < np && col / 3 < np {
                if row / 3 == col / 3 {
                    frames[row / 3][(row % 3, col % 3)]
                } else {
                    0.0
                }
            } else if row == col {
                1.0
            } else {
                0.0
            }
        };
        for j in 0..n {
            grad[j] = (0..n).map(|i| t(i, j) * g[i]).sum();
        }
        if let Some(hout) = hess {
            // H' = Tᵀ H T (column-major n × n).
            let mut ht = [0.0; MAX_LOCAL * MAX_LOCAL];
            for c in 0..n {
                for r in 0..n {
                    let lo = if c / 3 < np { 3 * (c / 3) } else { c };
                    let hi = if c / 3 < np { lo + 3 } else { c + 1 };
                    ht[r + n * c] = (lo..hi).map(|m| h[r + n * m] * t(m, c)).sum();
                }
            }
            for c in 0..n {
                for r in 0..n {
                    let lo = if r / 3 < np { 3 * (r / 3) } else { r };
                    let hi = if r / 3 < np { lo + 3 } else { r + 1 };
                    hout[r + n * c] = (lo..hi).map(|m| t(m, r) * ht[m + n * c]).sum();
                }
            }
        }
        energy
    }
}
