//! Bending with rest curvature in the material frame — seed 002, Eq. 6, after Bergou et al.
//! 2008/2010 (*Discrete Elastic Rods*, *Discrete Viscous Threads*).
//!
//! At a vertex between edges `e` (incoming) and `f` (outgoing) with material frames
//! `(m₁ᵉ, m₂ᵉ)`, `(m₁ᶠ, m₂ᶠ)` the material curvature is
//! `κ₁ = ½ (m₂ᵉ + m₂ᶠ)·(κb)`, `κ₂ = −½ (m₁ᵉ + m₁ᶠ)·(κb)` and the energy
//! `W = ½ · 2/(L_a + L_b) · k_b ‖κ − κ̄‖²` (Eq. 6; isotropic, rest curvature κ̄).
//!
//! DOFs `(x₀, x₁, x₂, θᵉ, θᶠ)` (11): positions (m) and the twist angles (rad) of the material
//! frames relative to the edges' reference frames. The reference frames are stored with the
//! stencil (from the previous configuration) and, as in DER, follow the edges by time-parallel
//! transport: the energy is `W(q)` with the stored frames transported onto the current edges,
//! a smooth function of `q` (away from antiparallel edge flips). A solver re-bases the stored
//! frames between Newton iterations.
//!
//! Derivatives: the gradient and Hessian of that function are exact (to round-off), computed
//! in one pass of second-order jets ([`crate::jet`]) structured by dependence: each transported
//! material frame is a closed-form `Jet<4>` in its edge and twist angle, the curvature
//! binormal a closed-form `Jet<6>` in the two edges (the crate-private `frame_jets` module), and only the
//! final dot products run in the 8 reduced variables `(e, f, θᵉ, θᶠ)`, mapped to the 11 DOFs
//! by `e = x₁ − x₀`, `f = x₂ − x₁`. The same energy written over any [`Real`] ([`MaterialBending::energy_generic`])
//! gives the hyper-dual reference the jets are tested against.
//! Why not DER's closed-form Hessian (Bergou 2010, Jawed et al.)? It drops the second variation
//! of the transported reference frame, so it is a symmetric approximation, not the Hessian of
//! any function: our finite-difference check rejects it by 4–20 % on random configurations.

use crate::frame_jets::{curvature_binormal_jets, edges, material_frame_jets, pull_back};
use crate::geometry::Frame;
use crate::hyperdual::{Real, Vec3};
use crate::jet::Jet;
use crate::{Evaluation, Stencil};
use nalgebra::{SVector, Vector2};

/// Seed 002 Eq. 6 bending with rest curvature; see the module doc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialBending {
    /// Bending stiffness k_b (N·m²).
    pub stiffness: f64,
    /// Rest lengths `(L_a, L_b)` of the two edges (m).
    pub rest_lengths: (f64, f64),
    /// Rest curvature κ̄ = (κ̄₁, κ̄₂) in the material frame (unitless, like κb).
    pub rest_curvature: Vector2<f64>,
    /// Reference frames of the incoming and outgoing edge (from the previous configuration).
    pub reference: (Frame, Frame),
}

/// The reference frame `frame` parallel-transported onto `edge`, rotated by the twist angle
/// `theta`: returns `(t, m₁, m₂)`. Generic over [`Real`] so the same code yields exact
/// derivatives; Rodrigues form of [`crate::geometry::parallel_transport`].
pub(crate) fn transported_material_frame<T: Real>(
    edge: &Vec3<T>,
    frame: &Frame,
    theta: T,
) -> (Vec3<T>, Vec3<T>, Vec3<T>) {
    let t = edge.scale(T::cst(1.0) / edge.norm());
    let d1 = transport(&Vec3::cst(&frame.d1), &Vec3::cst(&frame.t), &t);
    let d2 = t.cross(&d1);
    let (s, c) = theta.sin_cos();
    (t, d1.scale(c) + d2.scale(s), d2.scale(c) - d1.scale(s))
}

/// Parallel transport of `v` from unit tangent `t0` to unit tangent `t1`:
/// `c v + b × v + (b·v) b / (1 + c)` with `b = t0 × t1`, `c = t0·t1`.
pub(crate) fn transport<T: Real>(v: &Vec3<T>, t0: &Vec3<T>, t1: &Vec3<T>) -> Vec3<T> {
    let b = t0.cross(t1);
    let c = t0.dot(t1);
    v.scale(c) + b.cross(v) + b.scale(b.dot(v) / (T::cst(1.0) + c))
}

impl MaterialBending {
    fn weight(&self) -> f64 {
        self.stiffness / (self.rest_lengths.0 + self.rest_lengths.1)
    }

    /// Material curvature `(κ₁, κ₂)` over any [`Real`]: the stored reference frames
    /// transported onto the current edges, rotated by the twist angles.
    fn curvature_generic<T: Real>(&self, q: &[T; 11]) -> (T, T) {
        let x = |k: usize| Vec3([q[3 * k], q[3 * k + 1], q[3 * k + 2]]);
        let (e, f) = (x(1) - x(0), x(2) - x(1));
        let (_, m1e, m2e) = transported_material_frame(&e, &self.reference.0, q[9]);
        let (_, m1f, m2f) = transported_material_frame(&f, &self.reference.1, q[10]);
        let kb = e
            .cross(&f)
            .scale(T::cst(2.0) / (e.norm() * f.norm() + e.dot(&f)));
        (
            (m2e + m2f).dot(&kb) * T::cst(0.5),
            -((m1e + m1f).dot(&kb) * T::cst(0.5)),
        )
    }

    /// Material curvature `(κ₁, κ₂)` at `q` (for diagnostics and rest-shape estimation).
    pub fn curvature(&self, q: &SVector<f64, 11>) -> Vector2<f64> {
        let (k1, k2) = self.curvature_generic(&std::array::from_fn(|k| q[k]));
        Vector2::new(k1, k2)
    }
}

impl MaterialBending {
    /// Eq. 6, `k_b / (L_a + L_b) · ‖κ − κ̄‖²`, over any [`Real`] (the hyper-dual reference).
    pub fn energy_generic<T: Real>(&self, q: &[T; 11]) -> T {
        let (k1, k2) = self.curvature_generic(q);
        let d1 = k1 - T::cst(self.rest_curvature.x);
        let d2 = k2 - T::cst(self.rest_curvature.y);
        (d1 * d1 + d2 * d2) * T::cst(self.weight())
    }

    /// The energy as a jet in the reduced variables `(e, f, θᵉ, θᶠ)` (module docs).
    fn energy_jet(&self, q: &SVector<f64, 11>) -> Jet<8> {
        // W = w (r₁² + r₂²), rᵢ = κᵢ − κ̄ᵢ, so ∇²W = 2w (∇κ₁∇κ₁ᵀ + ∇κ₂∇κ₂ᵀ + ∇²s) with
        // s = r₁κ₁ + r₂κ₂ at fixed rᵢ: one jet product per component for the curvature terms,
        // first derivatives only for the Gauss–Newton terms.
        const E_VARS: [usize; 4] = [0, 1, 2, 6];
        const F_VARS: [usize; 4] = [3, 4, 5, 7];
        let (e, f) = edges(q);
        let (m1e, m2e) = material_frame_jets(&e, &self.reference.0, q[9]);
        let (m1f, m2f) = material_frame_jets(&f, &self.reference.1, q[10]);
        let kb = curvature_binormal_jets(&e, &f);
        let dot = |a: &Vec3<Jet<4>>, b: &Vec3<Jet<4>>| -> f64 {
            (0..3).map(|k| (a.0[k].v + b.0[k].v) * kb.0[k].v).sum()
        };
        let k1 = 0.5 * dot(&m2e, &m2f);
        let k2 = -0.5 * dot(&m1e, &m1f);
        let (r1, r2) = (k1 - self.rest_curvature.x, k2 - self.rest_curvature.y);
        // ∇κ in the 8 reduced variables, from first derivatives only.
        let gradient = |me: &Vec3<Jet<4>>, mf: &Vec3<Jet<4>>, sign: f64| -> [f64; 8] {
            let mut g = [0.0; 8];
            for k in 0..3 {
                let (b, a) = (kb.0[k], me.0[k].v + mf.0[k].v);
                for v in 0..4 {
                    g[E_VARS[v]] += 0.5 * sign * b.v * me.0[k].g[v];
                    g[F_VARS[v]] += 0.5 * sign * b.v * mf.0[k].g[v];
                }
                for v in 0..6 {
                    g[v] += 0.5 * sign * a * b.g[v];
                }
            }
            g
        };
        let (g1, g2) = (gradient(&m2e, &m2f, 1.0), gradient(&m1e, &m1f, -1.0));
        // s = Σₖ cₖ (κb)ₖ with cₖ = ½ (r₁ m₂ₖ − r₂ m₁ₖ), both edges.
        let mut s = Jet::<8>::cst(0.0);
        for k in 0..3 {
            let half = |m2: &Jet<4>, m1: &Jet<4>| m2.scale(0.5 * r1) - m1.scale(0.5 * r2);
            let c = half(&m2e.0[k], &m1e.0[k]).embed::<8>(E_VARS)
                + half(&m2f.0[k], &m1f.0[k]).embed::<8>(F_VARS);
            s = s + c * kb.0[k].embed::<8>([0, 1, 2, 3, 4, 5]);
        }
        let w = self.weight();
        let mut out = Jet::<8>::cst(w * (r1 * r1 + r2 * r2));
        for i in 0..8 {
            out.g[i] = 2.0 * w * s.g[i];
            for j in 0..8 {
                out.h[i][j] = 2.0 * w * (g1[i] * g1[j] + g2[i] * g2[j] + s.h[i][j]);
            }
        }
        out
    }
}

impl Stencil<11> for MaterialBending {
    fn energy(&self, q: &SVector<f64, 11>) -> f64 {
        self.energy_generic(&std::array::from_fn(|k| q[k]))
    }

    fn eval(&self, q: &SVector<f64, 11>) -> Evaluation<11> {
        pull_back(&self.energy_jet(q))
    }
}
