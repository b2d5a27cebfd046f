//! Fixed quadratic forms: the inertia and Rayleigh-damping terms of the implicit step
//! ([`crate::integrator`]).
//!
//! `V = ½ (q − c)ᵀ A (q − c)` with a symmetric matrix `A` and centre `c` that the integrator
//! sets once per time step:
//!
//! - inertia with mass damping: `A = (1/h² + α/h) M_seg(qₙ)`, `c = (q̂ + α h qₙ)/(1 + α h)`,
//!   `q̂ = qₙ + h vₙ` (per segment, `M_seg` from [`crate::state::segment_mass_matrix`]);
//! - stiffness damping: `A = (β/h) K⁺(qₙ)`, `c = qₙ`, with `K⁺` the PSD projection of an
//!   elastic stencil's Hessian at the start of the step (so damping never adds energy).

use nalgebra::{SMatrix, SVector};
use rod::{Evaluation, Stencil};

/// `V = ½ (q − c)ᵀ A (q − c)` on `N` DOFs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadratic<const N: usize> {
    /// The symmetric matrix A (J per DOF unit²).
    pub matrix: SMatrix<f64, N, N>,
    /// The centre c (DOF units).
    pub center: SVector<f64, N>,
}

impl<const N: usize> Quadratic<N> {
    /// The zero form (no energy) centred at the origin.
    pub fn zero() -> Self {
        Self {
            matrix: SMatrix::zeros(),
            center: SVector::zeros(),
        }
    }
}

impl<const N: usize> Stencil<N> for Quadratic<N> {
    fn energy(&self, q: &SVector<f64, N>) -> f64 {
        let d = q - self.center;
        0.5 * d.dot(&(self.matrix * d))
    }

    fn eval(&self, q: &SVector<f64, N>) -> Evaluation<N> {
        let d = q - self.center;
        let g = self.matrix * d;
        Evaluation {
            energy: 0.5 * d.dot(&g),
            gradient: g,
            hessian: self.matrix,
        }
    }
}

/// Boxed forms (as stored in [`crate::forces::Term`]) are stencils too.
impl<const N: usize> Stencil<N> for Box<Quadratic<N>> {
    fn energy(&self, q: &SVector<f64, N>) -> f64 {
        (**self).energy(q)
    }

    fn eval(&self, q: &SVector<f64, N>) -> Evaluation<N> {
        (**self).eval(q)
    }
}
