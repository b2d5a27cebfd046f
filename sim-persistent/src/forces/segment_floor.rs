//! A floor on the material length of a segment (ours, not the paper's).
//!
//! Sliding moves yarn material between the segments of a yarn. Nothing in seed 000's
//! potential stops a segment from draining completely: its stretch energy
//! `½ k_s L (l/L − 1)²` stays finite as its material length `L = u₁ − u₀` and its length `l`
//! go to zero together, and its two contact nodes then meet, where the stretch and bending
//! stencils degenerate and Newton fails. With the paper's explicit friction update this is
//! rare, because the anchored springs act as a stiff viscous brake on sliding (see
//! [`super::friction`]); with Coulomb-consistent friction (the return mapping) yarns slide
//! freely through uncompressed contacts and free swatches and rib pulls drained segments to
//! below 10 µm within 20 ms (measured). Physically the yarns crossing at two consecutive
//! contacts of a yarn have volume, so that yarn keeps some material between them. We add a
//! one-sided cubic penalty below a floor `L_min`:
//!
//! ```text
//! V = k_m/3 · p³,     p = max(0, L_min − (u₁ − u₀))
//! ```
//!
//! C² at the onset like [`super::loop_contact`], with `L_min = R/2` and
//! `k_m = k_s / L_min²` (the force reaches `k_s/4` at `L = L_min/2`) by default
//! ([`SegmentFloor::for_yarn`]). The layout's shortest segments are `R` long, so the floor
//! is inactive in the layout. DOFs `(u₀, u₁)` of one segment.

use crate::params::YarnParams;
use nalgebra::{SMatrix, SVector};
use rod::{Evaluation, Stencil};

/// The material-length floor of one segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentFloor {
    /// Stiffness `k_m` (N/m²).
    pub stiffness: f64,
    /// Floor `L_min` (m) > 0.
    pub floor: f64,
}

impl SegmentFloor {
    /// The default floor of a yarn: `L_min = R/2`, `k_m = k_s / L_min²`.
    pub fn for_yarn(params: &YarnParams) -> Self {
        let floor = 0.5 * params.radius;
        Self {
            stiffness: params.stretch_stiffness() / (floor * floor),
            floor,
        }
    }
}

impl Stencil<2> for SegmentFloor {
    fn energy(&self, q: &SVector<f64, 2>) -> f64 {
        let p = (self.floor - (q[1] - q[0])).max(0.0);
        self.stiffness / 3.0 * p * p * p
    }

    fn eval(&self, q: &SVector<f64, 2>) -> Evaluation<2> {
        let p = (self.floor - (q[1] - q[0])).max(0.0);
        let k = self.stiffness;
        // dV/dL = −k p², d²V/dL² = 2 k p, with L = u₁ − u₀.
        let g = -k * p * p;
        let h = 2.0 * k * p;
        Evaluation {
            energy: k / 3.0 * p * p * p,
            gradient: SVector::<f64, 2>::new(-g, g),
            hessian: SMatrix::<f64, 2, 2>::new(h, -h, -h, h),
        }
    }
}
