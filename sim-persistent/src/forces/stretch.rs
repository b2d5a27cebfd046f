//! Yarn stretch on sliding segments (seed 000 §4, "yarn stretch (governed by the Elastic
//! modulus Y)", the woven-cloth formulation; physics notes).
//!
//! A segment between passes with arc-length coordinates `u₀ < u₁` holds the material length
//! `Δu = u₁ − u₀`, its rest length; the strain is `ε = |x₁ − x₀|/Δu − 1` and the energy
//! `V = Δu · ½ k_s ε²` with `k_s = Y π R²`. The stencil is `rod::stretch::SlidingSegment`
//! (DOFs `(x₀, u₀, x₁, u₁)`); this module only builds it from the yarn parameters.

use crate::params::YarnParams;
use rod::stretch::SlidingSegment;

/// The sliding-segment stretch stencil of `params`: linear with `k_s = Y π R²`, or
/// bi-phasic ([`YarnParams::stretch_law`]).
pub fn stretch_stencil(params: &YarnParams) -> SlidingSegment {
    SlidingSegment {
        law: params.stretch_law(),
    }
}
