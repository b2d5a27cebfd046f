//! The one contract every energy term in this crate fulfils.

use nalgebra::{SMatrix, SVector};

/// An energy term on a fixed-size stencil of `N` degrees of freedom.
///
/// The stencil's DOF vector `q` is laid out as documented on each implementor (for example
/// `(x₀, x₁)` for a stretch segment, `(x₀, u₀, x₁, u₁)` for a sliding segment). A term knows
/// nothing about the global system: the `solver` crate scatters its local gradient and Hessian.
///
/// Every implementor has an asserting finite-difference test of both derivatives through
/// [`crate::fd`].
pub trait Stencil<const N: usize> {
    /// Energy in joules (J). Cheap path used by line searches.
    fn energy(&self, q: &SVector<f64, N>) -> f64;

    /// Energy (J), gradient (J per DOF unit) and Hessian, evaluated together so that shared
    /// intermediate quantities are computed once. The Hessian is exact (not SPD-projected);
    /// see [`crate::spd`] for the projection Newton solvers use.
    fn eval(&self, q: &SVector<f64, N>) -> Evaluation<N>;

    /// Energy (J) and gradient without the Hessian (gradient-only evaluations of solvers).
    /// The default takes them from [`Stencil::eval`]; terms whose Hessian is expensive
    /// (the hyper-dual ones) override it.
    fn energy_and_gradient(&self, q: &SVector<f64, N>) -> (f64, SVector<f64, N>) {
        let e = self.eval(q);
        (e.energy, e.gradient)
    }
}

/// Energy, gradient and Hessian of a stencil at one configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation<const N: usize> {
    /// Energy (J).
    pub energy: f64,
    /// Gradient ∂W/∂q.
    pub gradient: SVector<f64, N>,
    /// Hessian ∂²W/∂q² (symmetric).
    pub hessian: SMatrix<f64, N, N>,
}

impl<const N: usize> Evaluation<N> {
    /// The zero evaluation (an inactive term).
    pub fn zero() -> Self {
        Self {
            energy: 0.0,
            gradient: SVector::zeros(),
            hessian: SMatrix::zeros(),
        }
    }
}

impl<const N: usize> std::ops::AddAssign for Evaluation<N> {
    fn add_assign(&mut self, rhs: Self) {
        self.energy += rhs.energy;
        self.gradient += rhs.gradient;
        self.hessian += rhs.hessian;
    }
}
