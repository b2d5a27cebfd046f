//! Yarn bending with jamming (seed 000 Eq. 1, §4.1).
//!
//! For two consecutive segments of a yarn meeting at angle θ, `V = k_b φ(θ)/Δu` with
//! `Δu = u₂ − u₀` the summed arc length of both segments (sliding changes it) and
//! `k_b = B π R²`. For small angles `φ = θ²`; past θ = π/2 the stiffness grows smoothly by
//! three orders of magnitude (bending jamming: loops of different rows touch). The stencil is
//! `rod::bending::AngleBending` (DOFs `(x₀, u₀, x₁, u₁, x₂, u₂)`); this module builds it.
//! The rest angle is zero: the paper's rest-shape bending compensation (§4.1) changes the
//! layout, not the bending rest shape ([`crate::rest_shape`]).

use crate::params::YarnParams;
use rod::bending::AngleBending;

/// The angle-bending stencil of `params`.
pub fn bending_stencil(params: &YarnParams) -> AngleBending {
    AngleBending {
        stiffness: params.bending_stiffness(),
        jamming: params.jamming,
    }
}
