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
//! derivatives in one pass of jets ([`crate::jet`]): each edge's transported reference frame is
//! a `Jet<3>` in its edge, the reference twist a `Jet<6>` in both edges, and the energy a
//! `Jet<8>` in `(e, f, θᵉ, θᶠ)` (see [`crate::material_bending`]); the same energy over any
//! [`Real`] ([`Twist::energy_generic`]) is the hyper-dual reference of the tests.

use crate::frame_jets::{edges, embed3, pull_back, transported_frame_jets};
use crate::geometry::Frame;
use crate::hyperdual::{Real, Vec3};
use crate::jet::Jet;
use crate::material_bending::{transport, transported_material_frame};
use crate::{Evaluation, Stencil};
use nalgebra::SVector;

type V3 = nalgebra::Vector3<f64>;
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
        angle_across(&te, &d1e, &tf, &d1f)
    }

    /// The reference twist from the transport angle at the current edges, continued from the
    /// base reference twist without 2π jumps.
    fn reference_twist_from<T: Real>(&self, angle: T) -> T {
        let base = self.transport_angle::<f64>(
            &Vec3::cst(&self.reference.0.t),
            &Vec3::cst(&self.reference.1.t),
        );
        let wraps = ((angle.value() - base) / TAU).round();
        angle + T::cst(self.reference_twist - base - wraps * TAU)
    }

    /// Total twist `m = θᶠ − θᵉ + m_ref` over any [`Real`].
    fn twist_generic<T: Real>(&self, q: &[T; 11]) -> T {
        let x = |k: usize| Vec3([q[3 * k], q[3 * k + 1], q[3 * k + 2]]);
        let (e, f) = (x(1) - x(0), x(2) - x(1));
        q[10] - q[9] + self.reference_twist_from(self.transport_angle(&e, &f))
    }

    /// Current total twist `m = θᶠ − θᵉ + m_ref` (rad).
    pub fn twist(&self, q: &SVector<f64, 11>) -> f64 {
        self.twist_generic(&std::array::from_fn(|k| q[k]))
    }

    /// `k_t (m − m̄)² / (L_a + L_b)` over any [`Real`] (the hyper-dual reference).
    pub fn energy_generic<T: Real>(&self, q: &[T; 11]) -> T {
        let m = self.twist_generic(q) - T::cst(self.rest_twist);
        m * m * T::cst(self.weight())
    }

    fn weight(&self) -> f64 {
        self.stiffness / (self.rest_lengths.0 + self.rest_lengths.1)
    }

    /// The energy as a jet in `(e, f, θᵉ, θᶠ)`.
    fn energy_jet(&self, q: &SVector<f64, 11>) -> Jet<8> {
        let (e, f) = edges(q);
        let m_ref = self
            .reference_twist_by_holonomy(&e, &f)
            .unwrap_or_else(|| self.reference_twist_by_transport(&e, &f));
        let m = Jet::var(7, q[10]) - Jet::var(6, q[9]) + m_ref.embed([0, 1, 2, 3, 4, 5])
            - Jet::cst(self.rest_twist);
        (m * m).scale(self.weight())
    }

    /// The reference twist as a jet in `(e, f)` by transporting the incoming director across
    /// the vertex in `Jet<6>` arithmetic (the definition, always valid).
    fn reference_twist_by_transport(&self, e: &V3, f: &V3) -> Jet<6> {
        let frame = |edge: &V3, reference: &Frame, map| {
            let [t, d1, _] = transported_frame_jets(edge, reference);
            (embed3(&t, map), embed3(&d1, map))
        };
        let (te, d1e) = frame(e, &self.reference.0, [0, 1, 2]);
        let (tf, d1f) = frame(f, &self.reference.1, [3, 4, 5]);
        self.reference_twist_from(angle_across::<Jet<6>>(&te, &d1e, &tf, &d1f))
    }

    /// The same jet, split by the holonomy of transport: carrying the incoming reference
    /// director from its base tangent `u` to `tₑ` and on to `t_f` ends rotated about `t_f`,
    /// against carrying it from `u` to `t_f` directly, by the solid angle `Ω` of the spherical
    /// triangle `(u, tₑ, t_f)`, `tan(Ω/2) = u·(tₑ × t_f) / (1 + u·tₑ + tₑ·t_f + t_f·u)`
    /// (Van Oosterom & Strackee 1983). So `m_ref = A(t_f) − Ω(tₑ, t_f) + const`, where `A` is
    /// the angle about `t_f` between the two reference directors transported directly onto
    /// `t_f` (a `Jet<3>` in `f`) and `Ω` needs only dot and cross products of the tangents.
    /// `None` when `t_f` is nearly opposite to `u` (then the direct transport degenerates);
    /// the caller falls back to [`Twist::reference_twist_by_transport`].
    fn reference_twist_by_holonomy(&self, e: &V3, f: &V3) -> Option<Jet<6>> {
        let u = self.reference.0.t;
        if 1.0 + u.dot(&f.normalize()) < 0.1 {
            return None;
        }
        let [te, _, _] = transported_frame_jets(e, &self.reference.0);
        let [tf, d1f, _] = transported_frame_jets(f, &self.reference.1);
        let [_, d1e_on_f, _] = transported_frame_jets(f, &self.reference.0);
        let direct = signed_angle(&d1e_on_f, &d1f, &tf).embed::<6>([3, 4, 5]);
        let (te, tf) = (
            embed3::<3, 6>(&te, [0, 1, 2]),
            embed3::<3, 6>(&tf, [3, 4, 5]),
        );
        let u = Vec3::<Jet<6>>::cst(&u);
        let n = te.dot(&tf.cross(&u));
        let d = Jet::cst(1.0) + u.dot(&te) + te.dot(&tf) + tf.dot(&u);
        let mut m_ref = direct - n.atan2(d).scale(2.0);
        // The value (with its 2π continuation) from the definition.
        m_ref.v =
            self.reference_twist_from(self.transport_angle::<f64>(&Vec3::cst(e), &Vec3::cst(f)));
        Some(m_ref)
    }
}

/// The signed angle about `tf` from `d1e` transported across the vertex (from `te` to `tf`)
/// to `d1f`.
fn angle_across<T: Real>(te: &Vec3<T>, d1e: &Vec3<T>, tf: &Vec3<T>, d1f: &Vec3<T>) -> T {
    let moved = transport(d1e, te, tf);
    signed_angle(&moved, d1f, tf)
}

impl Stencil<11> for Twist {
    fn energy(&self, q: &SVector<f64, 11>) -> f64 {
        self.energy_generic(&std::array::from_fn(|k| q[k]))
    }

    fn eval(&self, q: &SVector<f64, 11>) -> Evaluation<11> {
        pull_back(&self.energy_jet(q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holonomy_split_equals_transport_across_the_vertex() {
        let reference = (
            Frame::new(&V3::new(1.0, 0.1, 0.0), &V3::new(0.0, 0.0, 1.0)).unwrap(),
            Frame::new(&V3::new(0.8, 0.5, 0.1), &V3::new(0.1, 0.0, 1.0)).unwrap(),
        );
        let twist = Twist {
            stiffness: 1.0,
            rest_lengths: (1.0, 1.0),
            rest_twist: 0.0,
            reference,
            reference_twist: 0.4,
        };
        for (e, f) in [
            (V3::new(1.0, 0.2, 0.1), V3::new(0.7, 0.6, -0.2)),
            (V3::new(0.3, 0.9, 0.4), V3::new(-0.2, 1.0, 0.5)),
            (V3::new(1.2, -0.7, 0.3), V3::new(0.2, -0.9, 0.8)),
        ] {
            let a = twist.reference_twist_by_holonomy(&e, &f).unwrap();
            let b = twist.reference_twist_by_transport(&e, &f);
            assert!((a.v - b.v).abs() < 1e-12);
            for i in 0..6 {
                assert!(
                    (a.g[i] - b.g[i]).abs() < 1e-10,
                    "g{i}: {} vs {}",
                    a.g[i],
                    b.g[i]
                );
                for j in 0..6 {
                    assert!((a.h[i][j] - b.h[i][j]).abs() < 1e-9, "h{i}{j}");
                }
            }
        }
        // Outgoing edge turned against the incoming base tangent: no holonomy split.
        assert!(
            twist
                .reference_twist_by_holonomy(&V3::new(1.0, 0.0, 0.0), &V3::new(-1.0, 0.05, 0.0))
                .is_none()
        );
    }
}
