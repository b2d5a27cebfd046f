//! Twist of a discrete elastic rod (Bergou et al. 2008/2010) at the vertex between edges `e`
//! (incoming) and `f` (outgoing).
//!
//! The twist is `m = θᶠ − θᵉ + m_ref`, θ the material-frame angles of the two edges and
//! `m_ref` the reference twist: the angle from the incoming reference director, transported
//! across the vertex onto `f`, to the outgoing reference director. The energy is
//! `W = k_t (m − m̄)² / (L_a + L_b)` (`½ k_t (m − m̄)²/l̄` with the Voronoi length
//! `l̄ = (L_a + L_b)/2`), `k_t = GJ` (N·m²).
//!
//! Like [`crate::material_bending`], the stencil stores the reference frames of a base
//! configuration and transports them onto the current edges, so `W(q)` is a smooth function of
//! `(x₀, x₁, x₂, θᵉ, θᶠ)`; the reference twist continues from its base value
//! (`reference_twist`, e.g. the `*RefT` block of a `.pyp` tile) without 2π jumps. Exact
//! derivatives by hyper-dual differentiation.

use crate::geometry::Frame;
use crate::hyperdual::{GenericEnergy, Real, Vec3};
use crate::material_bending::{transport, transported_material_frame};
use nalgebra::SVector;
use std::f64::consts::TAU;

/// DER twist energy at one vertex; DOFs `(x₀, x₁, x₂, θᵉ, θᶠ)` (11).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Twist {
    /// Twist stiffness k_t = GJ (N·m²).
    pub stiffness: f64,
    /// Rest lengths `(L_a, L_b)` of the two edges (m).
    pub rest_lengths: (f64, f64),
    /// Rest twist m̄ (rad).
    pub rest_twist: f64,
    /// Reference frames of the incoming and outgoing edge at the base configuration.
    pub reference: (Frame, Frame),
    /// Reference twist at the base configuration (rad).
    pub reference_twist: f64,
}

/// Signed angle from `u` to `v` about `n` over any [`Real`].
fn signed_angle<T: Real>(u: &Vec3<T>, v: &Vec3<T>, n: &Vec3<T>) -> T {
    u.cross(v).dot(n).atan2(u.dot(v))
}

impl Twist {
    /// The angle whose change is the change of reference twist, for edges `e`, `f`.
    fn transport_angle<T: Real>(&self, e: &Vec3<T>, f: &Vec3<T>) -> T {
        let (te, d1e, _) = transported_material_frame(e, &self.reference.0, T::cst(0.0));
        let (tf, d1f, _) = transported_material_frame(f, &self.reference.1, T::cst(0.0));
        let moved = transport(&d1e, &te, &tf);
        signed_angle(&moved, &d1f, &tf)
    }

    /// Total twist `m = θᶠ − θᵉ + m_ref` over any [`Real`].
    fn twist_generic<T: Real>(&self, q: &[T; 11]) -> T {
        let x = |k: usize| Vec3([q[3 * k], q[3 * k + 1], q[3 * k + 2]]);
        let (e, f) = (x(1) - x(0), x(2) - x(1));
        let base = self.transport_angle::<f64>(
            &Vec3::cst(&self.reference.0.t),
            &Vec3::cst(&self.reference.1.t),
        );
        let angle = self.transport_angle(&e, &f);
        // Continue from the base reference twist without 2π jumps.
        let wraps = ((angle.value() - base) / TAU).round();
        let m_ref = angle + T::cst(self.reference_twist - base - wraps * TAU);
        q[10] - q[9] + m_ref
    }

    /// Current total twist `m = θᶠ − θᵉ + m_ref` (rad).
    pub fn twist(&self, q: &SVector<f64, 11>) -> f64 {
        self.twist_generic(&std::array::from_fn(|k| q[k]))
    }
}

impl GenericEnergy<11> for Twist {
    /// `k_t (m − m̄)² / (L_a + L_b)`.
    fn energy_generic<T: Real>(&self, q: &[T; 11]) -> T {
        let m = self.twist_generic(q) - T::cst(self.rest_twist);
        m * m * T::cst(self.stiffness / (self.rest_lengths.0 + self.rest_lengths.1))
    }
}
