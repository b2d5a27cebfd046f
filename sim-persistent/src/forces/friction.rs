//! Sliding friction with anchored springs (seed 000 Eq. 5, §4.4; woven-cloth formulation).
//!
//! Coulomb friction on a sliding coordinate `u` is modelled by a spring to an anchor `ū`:
//!
//! ```text
//! F_u = −k_f (u − ū)              if stick (|k_f (u − ū)| ≤ F_max)
//! F_u = −sign(u − ū) F_max        if slip                                  (Eq. 5)
//! ```
//!
//! During a step the spring `V = ½ k_f (u − ū)²` acts with a fixed anchor (a smooth, convex
//! term for Newton); after the step, a coordinate whose spring force exceeds `F_max` slips:
//! its anchor moves to the maximal stick position `ū = u − sign(u − ū) F_max/k_f` ("we adjust
//! each anchor point according to the deviation of the corresponding sliding coordinate from
//! its maximal stick position"). Slipping dissipates energy and leaves plastic deformation.
//!
//! This slice implements the non-parallel case (each yarn's sliding coordinate has its own
//! spring). In the paper `F_max = μ λ` with λ the contact compression of Eqs. 3–4; until
//! compression estimation is implemented `F_max` is a constant parameter
//! ([`crate::params::YarnParams::friction_max_force`]). Parallel stacked yarns (a spring on
//! `uᵢ − uᵢ₊₁`) come with stacked stitches.

use nalgebra::{SMatrix, SVector};
use rod::{Evaluation, Stencil};

/// An anchored friction spring on one sliding coordinate (DOF `u`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnchoredSpring {
    /// Stick stiffness `k_f` (N/m).
    pub stiffness: f64,
    /// Anchor `ū` (m).
    pub anchor: f64,
}

impl AnchoredSpring {
    /// The stick/slip update of Eq. 5 after a step at sliding coordinate `u` (m) with slip
    /// force `max_force` (N, ≥ 0). Returns whether the coordinate slipped.
    pub fn update_anchor(&mut self, u: f64, max_force: f64) -> bool {
        let stretch = u - self.anchor;
        if self.stiffness * stretch.abs() <= max_force {
            return false;
        }
        self.anchor = u - stretch.signum() * max_force / self.stiffness;
        true
    }
}

impl Stencil<1> for AnchoredSpring {
    fn energy(&self, q: &SVector<f64, 1>) -> f64 {
        let d = q[0] - self.anchor;
        0.5 * self.stiffness * d * d
    }

    fn eval(&self, q: &SVector<f64, 1>) -> Evaluation<1> {
        let d = q[0] - self.anchor;
        Evaluation {
            energy: 0.5 * self.stiffness * d * d,
            gradient: SVector::<f64, 1>::new(self.stiffness * d),
            hessian: SMatrix::<f64, 1, 1>::new(self.stiffness),
        }
    }
}
