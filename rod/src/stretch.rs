//! Yarn stretch.
//!
//! A stretch law gives the energy per unit rest length `ψ(ε)` (J/m = N) as a function of the
//! axial strain `ε = l/L − 1`, `l` the current and `L` the rest (material) length of a segment.
//! The segment energy is `W = L ψ(ε)`. Two laws:
//!
//! - [`StretchLaw::Linear`]: `ψ = ½ k ε²`, with `k = Y π R²` (N) for Young's modulus Y and
//!   yarn radius R.
//! - [`StretchLaw::TwoPhase`] (seed 002, Eq. 5): soft stiffness `k₁` for `0 ≤ ε ≤ ε̄`, stiff
//!   `k₂` beyond the onset `ε̄` and in compression; C¹ at both kinks.
//!
//! Two stencils use a law:
//! - [`Segment`]: fixed rest length L, DOFs `(x₀, x₁)` (6).
//! - [`SlidingSegment`] (seed 000 §3.2, physics notes): the rest length is the material
//!   length `Δu = u₁ − u₀` between the arc-length coordinates of the end nodes, which are
//!   DOFs: `(x₀, u₀, x₁, u₁)` (8). Sliding changes which material sits in the segment.

use crate::geometry::{M3, V3};
use crate::stencil::{Evaluation, Stencil};
use nalgebra::{SVector, Vector3};

/// Energy per unit rest length as a function of axial strain (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StretchLaw {
    /// `ψ = ½ k ε²`; `k` in N.
    Linear {
        /// Stretch stiffness `Y π R²` (N).
        k: f64,
    },
    /// Seed 002, Eq. 5: `ψ = ½ k₂ ε²` for `ε ≤ 0`; `½ k₁ ε²` for `0 ≤ ε ≤ ε̄`;
    /// `½ (k₂ (ε − ε̄)² + k₁ ε̄ (2ε − ε̄))` for `ε ≥ ε̄`.
    TwoPhase {
        /// Soft (low-stretch) stiffness (N).
        k1: f64,
        /// Stiff stiffness past the onset and in compression (N).
        k2: f64,
        /// Onset strain ε̄ ≥ 0 of the stiff regime (unitless).
        onset: f64,
    },
}

impl StretchLaw {
    /// `(ψ, ψ', ψ'')` at strain `eps`.
    pub fn eval(&self, eps: f64) -> (f64, f64, f64) {
        match *self {
            StretchLaw::Linear { k } => (0.5 * k * eps * eps, k * eps, k),
            StretchLaw::TwoPhase { k1, k2, onset } => {
                if eps <= 0.0 {
                    (0.5 * k2 * eps * eps, k2 * eps, k2)
                } else if eps <= onset {
                    (0.5 * k1 * eps * eps, k1 * eps, k1)
                } else {
                    let d = eps - onset;
                    (
                        0.5 * (k2 * d * d + k1 * onset * (2.0 * eps - onset)),
                        k2 * d + k1 * onset,
                        k2,
                    )
                }
            }
        }
    }
}

/// Length `l = |d|`, unit direction `t`, and the Hessian of `l` w.r.t. `d`: `(I − t tᵀ)/l`.
fn length_derivatives(d: &V3) -> (f64, V3, M3) {
    let l = d.norm();
    let t = d / l;
    (l, t, (M3::identity() - t * t.transpose()) / l)
}

/// A yarn segment with fixed rest length; DOFs `(x₀, x₁)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Rest length L (m), > 0.
    pub rest_length: f64,
    /// Stretch law.
    pub law: StretchLaw,
}

impl Stencil<6> for Segment {
    fn energy(&self, q: &SVector<f64, 6>) -> f64 {
        let d = q.fixed_rows::<3>(3) - q.fixed_rows::<3>(0);
        let l0 = self.rest_length;
        l0 * self.law.eval(d.norm() / l0 - 1.0).0
    }

    fn eval(&self, q: &SVector<f64, 6>) -> Evaluation<6> {
        let d: V3 = q.fixed_rows::<3>(3) - q.fixed_rows::<3>(0);
        let l0 = self.rest_length;
        let (l, t, dt) = length_derivatives(&d);
        let (psi, dpsi, ddpsi) = self.law.eval(l / l0 - 1.0);
        // W = L ψ(l/L − 1): ∂W/∂l = ψ', ∂²W/∂l² = ψ''/L.
        let g = dpsi * t;
        let h = ddpsi / l0 * t * t.transpose() + dpsi * dt;
        let mut out = Evaluation::<6>::zero();
        out.energy = l0 * psi;
        out.gradient.fixed_rows_mut::<3>(0).copy_from(&-g);
        out.gradient.fixed_rows_mut::<3>(3).copy_from(&g);
        out.hessian.fixed_view_mut::<3, 3>(0, 0).copy_from(&h);
        out.hessian.fixed_view_mut::<3, 3>(3, 3).copy_from(&h);
        out.hessian.fixed_view_mut::<3, 3>(0, 3).copy_from(&-h);
        out.hessian.fixed_view_mut::<3, 3>(3, 0).copy_from(&-h);
        out
    }
}

/// A segment between two sliding nodes; DOFs `(x₀, u₀, x₁, u₁)` with `u` the arc-length
/// (material) coordinate of each end (m). Energy `W = Δu ψ(|x₁ − x₀|/Δu − 1)`, `Δu = u₁ − u₀`.
///
/// With `r = l/Δu`: `∂W/∂l = ψ'`, `∂W/∂Δu = ψ − r ψ'`, `∂²W/∂l² = ψ''/Δu`,
/// `∂²W/∂l∂Δu = −r ψ''/Δu`, `∂²W/∂Δu² = r² ψ''/Δu`. Requires `Δu > 0` and `l > 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlidingSegment {
    /// Stretch law.
    pub law: StretchLaw,
}

impl Stencil<8> for SlidingSegment {
    fn energy(&self, q: &SVector<f64, 8>) -> f64 {
        let d = q.fixed_rows::<3>(4) - q.fixed_rows::<3>(0);
        let du = q[7] - q[3];
        du * self.law.eval(d.norm() / du - 1.0).0
    }

    fn eval(&self, q: &SVector<f64, 8>) -> Evaluation<8> {
        let d: V3 = q.fixed_rows::<3>(4) - q.fixed_rows::<3>(0);
        let du = q[7] - q[3];
        let (l, t, dt) = length_derivatives(&d);
        let r = l / du;
        let (psi, dpsi, ddpsi) = self.law.eval(r - 1.0);
        let w_l = dpsi;
        let w_u = psi - r * dpsi;
        let (w_ll, w_lu, w_uu) = (ddpsi / du, -r * ddpsi / du, r * r * ddpsi / du);

        // Local variables y = (d, Δu); then map d = x₁ − x₀, Δu = u₁ − u₀.
        let g_d = w_l * t;
        let h_dd = w_ll * t * t.transpose() + w_l * dt;
        let h_du: Vector3<f64> = w_lu * t;
        // Selector rows: x₀ → −1 on d, u₀ → −1 on Δu, x₁ → +1 on d, u₁ → +1 on Δu.
        let mut out = Evaluation::<8>::zero();
        out.energy = du * psi;
        for (bx, bu, s) in [(0usize, 3usize, -1.0), (4, 7, 1.0)] {
            out.gradient.fixed_rows_mut::<3>(bx).copy_from(&(s * g_d));
            out.gradient[bu] = s * w_u;
            for (cx, cu, r2) in [(0usize, 3usize, -1.0), (4, 7, 1.0)] {
                let ss = s * r2;
                out.hessian
                    .fixed_view_mut::<3, 3>(bx, cx)
                    .copy_from(&(ss * h_dd));
                out.hessian
                    .fixed_view_mut::<3, 1>(bx, cu)
                    .copy_from(&(ss * h_du));
                out.hessian
                    .fixed_view_mut::<1, 3>(bu, cx)
                    .copy_from(&(ss * h_du.transpose()));
                out.hessian[(bu, cu)] = ss * w_uu;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_phase_law_is_c1_and_matches_eq5_pieces() {
        let law = StretchLaw::TwoPhase {
            k1: 2.0,
            k2: 50.0,
            onset: 0.1,
        };
        for x in [0.0, 0.1] {
            let (a, da, _) = law.eval(x - 1e-12);
            let (b, db, _) = law.eval(x + 1e-12);
            assert!(
                (a - b).abs() < 1e-10 && (da - db).abs() < 1e-9,
                "kink at {x}"
            );
        }
        // Past the onset the slope is k2.
        let (_, d1, _) = law.eval(0.2);
        let (_, d2, _) = law.eval(0.3);
        assert!(((d2 - d1) / 0.1 - 50.0).abs() < 1e-9);
    }

    #[test]
    fn sliding_segment_at_rest_has_zero_force() {
        let s = SlidingSegment {
            law: StretchLaw::Linear { k: 10.0 },
        };
        let q = SVector::<f64, 8>::from_column_slice(&[0.0, 0.0, 0.0, 0.2, 0.5, 0.0, 0.0, 0.7]);
        let e = s.eval(&q);
        assert!(e.energy.abs() < 1e-15 && e.gradient.norm() < 1e-12);
    }
}
