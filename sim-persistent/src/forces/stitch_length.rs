//! Length of stitch contacts (seed 000 Eq. 6, §4.5).
//!
//! When one end node of a stitch contact slides, the other should slide too, so that the
//! material length of the contact is preserved. For a yarn through the contact's nodes
//! `q₀`, `q₁` (in yarn order) with arc length `l = u₁ − u₀` and rest length `L`:
//!
//! ```text
//! V = ½ k_l L (l/L − 1)²            (Eq. 6)
//! ```
//!
//! with `k_l` the stiffness (N). DOFs `(u₀, u₁)` of that yarn; one stencil per yarn and contact.

use nalgebra::SVector;
use rod::{Evaluation, Stencil};

/// Eq. 6 for one yarn of one stitch contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StitchLength {
    /// Stiffness `k_l` (N).
    pub stiffness: f64,
    /// Rest length `L` of the contact (m), > 0.
    pub rest_length: f64,
}

impl Stencil<2> for StitchLength {
    fn energy(&self, q: &SVector<f64, 2>) -> f64 {
        let strain = (q[1] - q[0]) / self.rest_length - 1.0;
        0.5 * self.stiffness * self.rest_length * strain * strain
    }

    fn eval(&self, q: &SVector<f64, 2>) -> Evaluation<2> {
        let strain = (q[1] - q[0]) / self.rest_length - 1.0;
        let k = self.stiffness;
        let g = k * strain; // ∂V/∂l
        let h = k / self.rest_length; // ∂²V/∂l²
        Evaluation {
            energy: 0.5 * k * self.rest_length * strain * strain,
            gradient: SVector::<f64, 2>::new(-g, g),
            hessian: nalgebra::SMatrix::<f64, 2, 2>::new(h, -h, -h, h),
        }
    }
}
