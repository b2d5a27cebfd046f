//! Gravity on a sliding segment (seed 000 §4: "for gravity … we use exactly the original
//! formulation for woven cloth").
//!
//! The potential of the material between the segment's ends, integrated with the linear
//! interpolation of [`crate::state`], is
//!
//! ```text
//! V = −ρ Δu g · (x₀ + x₁)/2,      Δu = u₁ − u₀,
//! ```
//!
//! so gravity depends on the sliding coordinates too: sliding moves material (mass) from one
//! segment into its neighbour. It is consistent with the segment mass matrix (the same ρ and
//! interpolation). DOFs `(x₀, u₀, x₁, u₁)`.

use nalgebra::SVector;
use rod::geometry::V3;
use rod::{Evaluation, Stencil};

/// Gravity on one segment (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gravity {
    /// Linear density ρ (kg/m).
    pub density: f64,
    /// Gravity acceleration g (m/s²).
    pub g: V3,
}

impl Stencil<8> for Gravity {
    fn energy(&self, q: &SVector<f64, 8>) -> f64 {
        let mid = 0.5 * (q.fixed_rows::<3>(0) + q.fixed_rows::<3>(4));
        -self.density * (q[7] - q[3]) * self.g.dot(&mid)
    }

    fn eval(&self, q: &SVector<f64, 8>) -> Evaluation<8> {
        let mid = 0.5 * (q.fixed_rows::<3>(0) + q.fixed_rows::<3>(4));
        let du = q[7] - q[3];
        let rho = self.density;
        let mut out = Evaluation::<8>::zero();
        out.energy = -rho * du * self.g.dot(&mid);
        // ∂V/∂xₖ = −ρ Δu g/2, ∂V/∂u₀ = ρ g·mid = −∂V/∂u₁; ∂²V/∂xₖ∂u₀ = ρ g/2 = −∂²V/∂xₖ∂u₁.
        let gx = -0.5 * rho * du * self.g;
        let gu = rho * self.g.dot(&mid);
        let hxu = 0.5 * rho * self.g;
        for bx in [0usize, 4] {
            out.gradient.fixed_rows_mut::<3>(bx).copy_from(&gx);
            for (bu, s) in [(3usize, 1.0), (7, -1.0)] {
                out.hessian
                    .fixed_view_mut::<3, 1>(bx, bu)
                    .copy_from(&(s * hxu));
                out.hessian
                    .fixed_view_mut::<1, 3>(bu, bx)
                    .copy_from(&(s * hxu.transpose()));
            }
        }
        out.gradient[3] = gu;
        out.gradient[7] = -gu;
        out
    }
}
