//! Stitch wrapping (seed 000 Eq. 2, §4.2; Appendix Eqs. 7–13).
//!
//! At a stitch contact with nodes `q₀`, `q₁` the yarns are wrapped around each other around
//! the central axis `e = (x₁ − x₀)/‖x₁ − x₀‖` (Eq. 7). For a pair of opposite segments — the
//! segment of one yarn from `q₀` to its neighbour `q₄` and the segment of the other yarn from
//! `q₁` to its neighbour `q₃` (Fig. 8) — the triangles `(q₀, q₁, q₄)` and `(q₀, q₃, q₁)` have
//! normals along
//!
//! ```text
//! v_a = (x₄ − x₁) × (x₀ − x₁),      v_b = (x₀ − x₁) × (x₃ − x₁)       (Eqs. 9–10)
//! ```
//!
//! and the wrapping angle ψ is the angle between them, with `e` as the hinge (Eq. 13). The
//! energy is
//!
//! ```text
//! V = ½ k_w L (ψ − ψ₀)²                                                (Eq. 2)
//! ```
//!
//! with `L` the rest length of the stitch contact and ψ₀ = π/2 in the paper.
//!
//! **Signed angle.** Eq. 13 takes `ψ = arccos(n_a·n_b) ∈ [0, π]`, whose derivative is
//! singular where the triangles are coplanar (ψ = 0 or π; a flat layout starts at ψ ≈ 0).
//! We use the signed angle from `n_a` to `n_b` about `e`,
//! `ψ = atan2(e · (v_a × v_b), v_a · v_b) ∈ (−π, π]`, whose magnitude is Eq. 13's angle and
//! which is smooth through ψ = 0; the sign of ψ₀ then selects the sense of wrapping
//! (opposite for knit and purl stitches, which are mirror images through the fabric plane).
//!
//! **Derivatives.** Exact, by hyper-dual numbers (`rod::hyperdual`); the closed-form forces
//! and Jacobians of the Appendix (Eqs. 14–16) would be faster and are future work.
//!
//! **Status.** The stencil and the node pairs ([`wrap_pairs`]) are tested, but the term is
//! not assembled by [`crate::forces::build_terms`] yet. The flat layout of
//! [`crate::layout`] starts every contact unwrapped (|ψ| ≤ 4° for stockinette and garter),
//! so ψ₀ = ±π/2 would twist every contact by a quarter turn at once; the layout has to start
//! wrapped, and the sign of ψ₀ per stitch has to be validated against the curl directions of
//! Figs. 5 and 7, before the term is switched on.

use crate::topology::{StitchContact, Topology};
use rod::hyperdual::{GenericEnergy, Real, Vec3};

/// Eq. 2 for one pair of opposite segments. DOFs `(x₀, x₁, x₄, x₃)` (12): the stitch
/// contact's nodes `q₀`, `q₁`, the neighbour `q₄` of `q₀` on one yarn and the neighbour `q₃`
/// of `q₁` on the other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StitchWrap {
    /// Wrapping stiffness `k_w` (N; Table 1: 1e-2).
    pub stiffness: f64,
    /// Rest length `L` of the stitch contact (m).
    pub rest_length: f64,
    /// Rest angle ψ₀ (rad; ±π/2 in the paper).
    pub rest_angle: f64,
}

impl StitchWrap {
    /// The signed wrapping angle ψ (rad) of the module documentation over any scalar.
    pub fn angle<T: Real>(q: &[T; 12]) -> T {
        let x = |k: usize| Vec3([q[3 * k], q[3 * k + 1], q[3 * k + 2]]);
        let (x0, x1, x4, x3) = (x(0), x(1), x(2), x(3));
        let va = (x4 - x1).cross(&(x0 - x1)); // Eq. 9
        let vb = (x0 - x1).cross(&(x3 - x1)); // Eq. 10
        let axis = x1 - x0; // Eq. 7 (unnormalized; atan2 is scale invariant)
        let sin = axis.dot(&va.cross(&vb));
        let cos = axis.norm() * va.dot(&vb);
        sin.atan2(cos)
    }
}

impl GenericEnergy<12> for StitchWrap {
    fn energy_generic<T: Real>(&self, q: &[T; 12]) -> T {
        let d = Self::angle(q) - T::cst(self.rest_angle);
        T::cst(0.5 * self.stiffness * self.rest_length) * d * d
    }
}

/// The two pairs of opposite segments of a stitch contact as node quadruples
/// `[q₀, q₁, q₄, q₃]` for [`StitchWrap`] (Fig. 8): the upper yarn's neighbour before `q₀`
/// with the lower yarn's neighbour after `q₁`, and — the same with the roles of the two
/// contact nodes swapped — the upper yarn's neighbour after `q₁` with the lower yarn's
/// neighbour before `q₀`. `None` if a yarn ends at the contact.
pub fn wrap_pairs(topology: &Topology, contact: &StitchContact) -> Option<[[usize; 4]; 2]> {
    let [q0, q1] = contact.nodes;
    let [upper, lower] = contact.yarns;
    let neighbour = |yarn: usize, node: usize, offset: isize| -> Option<usize> {
        let i = topology.pass_index(node, yarn)?;
        let j = i.checked_add_signed(offset)?;
        topology.yarns[yarn].passes.get(j).map(|p| p.node)
    };
    Some([
        [q0, q1, neighbour(upper, q0, -1)?, neighbour(lower, q1, 1)?],
        [q1, q0, neighbour(upper, q1, 1)?, neighbour(lower, q0, -1)?],
    ])
}
