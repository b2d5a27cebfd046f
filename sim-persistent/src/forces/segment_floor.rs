//! A floor on the material length of a segment (ours, not the paper's).
//!
//! Sliding moves yarn material between the segments of a yarn. Nothing in seed 000's
//! potential stops a segment from draining completely: its stretch energy
//! `½ k_s L (l/L − 1)²` stays finite as its material length `L = u₁ − u₀` and its length `l`
//! go to zero together; its two contact nodes then meet, the stretch and bending stencils
//! degenerate, and a Newton solve that crosses `L = 0` finds an energy unbounded below
//! (residuals of 1e21 N and more). Physically the yarns crossing at two consecutive
//! contacts of a yarn have volume, so the yarn keeps some material between them. We add a
//! one-sided cubic penalty below a floor `L_min`:
//!
//! ```text
//! V = k_m/3 · p³,     p = max(0, L_min − (u₁ − u₀))
//! ```
//!
//! C² at the onset like [`super::loop_contact`], with `L_min = R/2` and
//! `k_m = k_s / L_min²` (the force reaches `k_s/4` at `L = L_min/2`)
//! ([`SegmentFloor::for_yarn`]). The layout's shortest segments are `R` long, so the floor
//! is inactive in the layout. DOFs `(u₀, u₁)` of one segment. On by default
//! ([`super::ForceSet::segment_floor`]).
//!
//! **Measured** (`examples/stability.rs`, 6 × 6 garter; `examples/friction_dt.rs`):
//!
//! | run | without the floor | with it |
//! |---|---|---|
//! | stretched scene, largest stable step | 2 ms (5, 10, 20 ms diverge at 0.23–0.30 s) | 20 ms (every step of the list) |
//! | hanging scene, largest stable step | 5 ms | 5 ms (unchanged) |
//! | quasi-static wale stretch, 1 % increments | fails at 30 % | 100 % |
//! | driven wale stretch at 1 ms | 81 % (84 steps halved) | 100 % (none halved) |
//! | 4 × 4 rib pulled with the friction return mapping | segments drained to 8 µm, failed at 1.9 mm | completes |
//!
//! The figures of the paper's model (rib stretch, curl, plasticity, patterns on a sphere)
//! are bit-identical with and without it: the floor never engages there.

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
