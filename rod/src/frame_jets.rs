//! Closed-form jets (value, gradient, Hessian) of the per-edge quantities shared by the
//! material-frame terms ([`crate::material_bending`], [`crate::twist`]), and the map from the
//! stencil's reduced variables to its 11 DOFs.
//!
//! **Transported reference frame.** In the orthonormal base frame `B = (u, v, w)` of an edge's
//! stored reference frame (`u = t₀`, `v = d₁`, `w = d₂`) write the current unit tangent as
//! `τ = Bᵀt = (α, β, γ)`. The minimal rotation taking `u` to `t` (Rodrigues,
//! `R = I + [k]× + [k]×²/(1 + α)`, `k = u × t`) maps `v` and `w` to
//!
//! ```text
//! d₁ = B (−β, 1 − β² s, −βγ s),   d₂ = B (−γ, −βγ s, 1 − γ² s),   s = 1/(1 + α),
//! ```
//!
//! rational functions of `τ` whose first and second derivatives are written out below. They
//! are chained to the edge vector `e` through `t = e/ℓ`, `ℓ = |e|`, `P = I − t tᵀ`:
//! `∂t/∂e = P/ℓ` and `∂²tᵢ/∂eⱼ∂eₖ = −(tⱼPᵢₖ + tₖPᵢⱼ + tᵢPⱼₖ)/ℓ²`, so for a scalar `φ(τ)` with
//! gradient `g` and Hessian `H` in `τ`:
//!
//! ```text
//! ∇ₑφ = Jᵀg,   ∇²ₑφ = JᵀHJ − (t (Pp)ᵀ + (Pp) tᵀ + (t·p) P)/ℓ²,   J = BᵀP/ℓ,  p = B g.
//! ```
//!
//! This is the same function as [`crate::geometry::parallel_transport`] of the stored frame
//! (the tests compare with hyper-dual derivatives of that formula), at a fraction of the cost.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::Evaluation;
use crate::geometry::Frame;
use crate::hyperdual::Vec3;
use crate::jet::Jet;

type V3 = Vector3<f64>;
type M3 = Matrix3<f64>;

/// A scalar function of `τ` (value, gradient, Hessian in `τ`).
struct TauFn {
    v: f64,
    g: V3,
    h: M3,
}

/// Chains functions of `τ = Bᵀ e/|e|` to jets in `e`.
struct TangentChain {
    t: V3,
    ell: f64,
    p: M3,
    /// `J = ∂τ/∂e = BᵀP/ℓ`.
    j: M3,
    b: M3,
}

impl TangentChain {
    fn new(e: &V3, reference: &Frame) -> Self {
        let ell = e.norm();
        let t = e / ell;
        let p = M3::identity() - t * t.transpose();
        let b = M3::from_columns(&[reference.t, reference.d1, reference.d2]);
        Self {
            t,
            ell,
            p,
            j: b.transpose() * p / ell,
            b,
        }
    }

    fn tau(&self) -> V3 {
        self.b.transpose() * self.t
    }

    /// `φ(τ(e))` as a jet in `e`.
    fn chain(&self, f: &TauFn) -> Jet<3> {
        let grad = self.j.transpose() * f.g;
        let p = self.b * f.g;
        let pp = self.p * p;
        let tp = self.t.dot(&p);
        let hess = self.j.transpose() * f.h * self.j
            - (self.t * pp.transpose() + pp * self.t.transpose() + self.p * tp)
                / (self.ell * self.ell);
        jet3(f.v, &grad, &hess)
    }

    /// A unit-tangent component `tᵢ` as a jet in `e`.
    fn tangent(&self, i: usize) -> Jet<3> {
        let grad: V3 = self.p.row(i).transpose() / self.ell;
        let pi = self.p.column(i);
        let hess = -(self.t * pi.transpose() + pi * self.t.transpose() + self.p * self.t[i])
            / (self.ell * self.ell);
        jet3(self.t[i], &grad, &hess)
    }
}

fn jet3(v: f64, g: &V3, h: &M3) -> Jet<3> {
    let mut out = Jet::<3>::var(0, v);
    out.g = [g.x, g.y, g.z];
    out.h = std::array::from_fn(|i| std::array::from_fn(|j| h[(i, j)]));
    out
}

/// The unit tangent `t` and the stored reference directors transported onto edge `e`,
/// `(t, d₁, d₂)`, as jets in `e` (module docs).
pub(crate) fn transported_frame_jets(e: &V3, reference: &Frame) -> [Vec3<Jet<3>>; 3] {
    let chain = TangentChain::new(e, reference);
    let tau = chain.tau();
    let (a, b, c) = (tau.x, tau.y, tau.z);
    let s = 1.0 / (1.0 + a);
    let (s2, s3) = (s * s, s * s * s);
    let m3 = |rows: [[f64; 3]; 3]| M3::from_fn(|i, j| rows[i][j]);
    // d₁ and d₂ in base coordinates, with gradients and Hessians in τ = (α, β, γ).
    let bc = TauFn {
        v: -b * c * s,
        g: V3::new(b * c * s2, -c * s, -b * s),
        h: m3([
            [-2.0 * b * c * s3, c * s2, b * s2],
            [c * s2, 0.0, -s],
            [b * s2, -s, 0.0],
        ]),
    };
    let d1 = [
        TauFn {
            v: -b,
            g: V3::new(0.0, -1.0, 0.0),
            h: M3::zeros(),
        },
        TauFn {
            v: 1.0 - b * b * s,
            g: V3::new(b * b * s2, -2.0 * b * s, 0.0),
            h: m3([
                [-2.0 * b * b * s3, 2.0 * b * s2, 0.0],
                [2.0 * b * s2, -2.0 * s, 0.0],
                [0.0, 0.0, 0.0],
            ]),
        },
        bc,
    ];
    let d2_first = TauFn {
        v: -c,
        g: V3::new(0.0, 0.0, -1.0),
        h: M3::zeros(),
    };
    let d2_third = TauFn {
        v: 1.0 - c * c * s,
        g: V3::new(c * c * s2, 0.0, -2.0 * c * s),
        h: m3([
            [-2.0 * c * c * s3, 0.0, 2.0 * c * s2],
            [0.0, 0.0, 0.0],
            [2.0 * c * s2, 0.0, -2.0 * s],
        ]),
    };
    let base1: [Jet<3>; 3] = std::array::from_fn(|k| chain.chain(&d1[k]));
    let base2 = [chain.chain(&d2_first), base1[2], chain.chain(&d2_third)];
    // World coordinates: d = B d_base.
    let world = |base: &[Jet<3>; 3]| {
        Vec3(std::array::from_fn(|i| {
            base[0].scale(chain.b[(i, 0)])
                + base[1].scale(chain.b[(i, 1)])
                + base[2].scale(chain.b[(i, 2)])
        }))
    };
    [
        Vec3(std::array::from_fn(|i| chain.tangent(i))),
        world(&base1),
        world(&base2),
    ]
}

/// The material directors `(m₁, m₂) = (cos θ d₁ + sin θ d₂, cos θ d₂ − sin θ d₁)` of edge `e`
/// as jets in `(e, θ)` (variables 0–2 and 3).
pub(crate) fn material_frame_jets(
    e: &V3,
    reference: &Frame,
    theta: f64,
) -> (Vec3<Jet<4>>, Vec3<Jet<4>>) {
    let [_, d1, d2] = transported_frame_jets(e, reference);
    let (s, c) = theta.sin_cos();
    // Rotation by θ: ∂θ m₁ = m₂, ∂θ m₂ = −m₁, so ∂²θθ m = −m and ∂e∂θ m₁ = ∇ₑm₂.
    // m = ca a + cb b and ∂θm = dca a + dcb b (sinusoids in θ, so ∂²θθ m = −m).
    let rotate = |a: &Jet<3>, b: &Jet<3>, [ca, cb, dca, dcb]: [f64; 4]| -> Jet<4> {
        let m: Jet<3> = a.scale(ca) + b.scale(cb);
        let dm: Jet<3> = a.scale(dca) + b.scale(dcb);
        let mut out = m.embed::<4>([0, 1, 2]);
        out.g[3] = dm.v;
        out.h[3][3] = -m.v;
        for k in 0..3 {
            out.h[k][3] = dm.g[k];
            out.h[3][k] = dm.g[k];
        }
        out
    };
    let m1 = Vec3(std::array::from_fn(|i| {
        rotate(&d1.0[i], &d2.0[i], [c, s, -s, c])
    }));
    let m2 = Vec3(std::array::from_fn(|i| {
        rotate(&d2.0[i], &d1.0[i], [c, -s, -s, -c])
    }));
    (m1, m2)
}

/// The curvature binormal `(κb) = 2 e × f / (|e||f| + e·f)` as jets in `(e, f)` (variables
/// 0–2 and 3–5), in closed form: `N = e × f` is bilinear (`∂²Nₖ/∂eᵢ∂fⱼ = εₖᵢⱼ`), and
/// `D = |e||f| + e·f` has `∇ₑD = |f| tₑ + f`, `∇²ₑₑD = |f| Pₑ/|e|`, `∇²ₑ_fD = tₑt_fᵀ + I`.
pub(crate) fn curvature_binormal_jets(e: &V3, f: &V3) -> Vec3<Jet<6>> {
    let (le, lf) = (e.norm(), f.norm());
    let (te, tf) = (e / le, f / lf);
    let mut d = Jet::<6>::var(0, le * lf + e.dot(f));
    let (ge, gf) = (te * lf + f, tf * le + e);
    let (pe, pf) = (
        (M3::identity() - te * te.transpose()) * (lf / le),
        (M3::identity() - tf * tf.transpose()) * (le / lf),
    );
    let cross = te * tf.transpose() + M3::identity();
    for i in 0..3 {
        d.g[i] = ge[i];
        d.g[3 + i] = gf[i];
        for j in 0..3 {
            d.h[i][j] = pe[(i, j)];
            d.h[3 + i][3 + j] = pf[(i, j)];
            d.h[i][3 + j] = cross[(i, j)];
            d.h[3 + j][i] = cross[(i, j)];
        }
    }
    let scale = <Jet<6> as crate::hyperdual::Real>::cst(2.0) / d;
    let n = e.cross(f);
    Vec3(std::array::from_fn(|k| {
        // Nₖ = eᵢfⱼ − eⱼfᵢ with (k, i, j) cyclic.
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let mut nk = Jet::<6>::var(0, n[k]);
        nk.g = [0.0; 6];
        nk.g[i] = f[j];
        nk.g[j] = -f[i];
        nk.g[3 + j] = e[i];
        nk.g[3 + i] = -e[j];
        nk.h[i][3 + j] = 1.0;
        nk.h[3 + j][i] = 1.0;
        nk.h[j][3 + i] = -1.0;
        nk.h[3 + i][j] = -1.0;
        nk * scale
    }))
}

/// The two edges `e = x₁ − x₀`, `f = x₂ − x₁` of an 11-DOF stencil `(x₀, x₁, x₂, θᵉ, θᶠ)`.
pub(crate) fn edges(q: &SVector<f64, 11>) -> (V3, V3) {
    let x = |k: usize| V3::new(q[3 * k], q[3 * k + 1], q[3 * k + 2]);
    (x(1) - x(0), x(2) - x(1))
}

/// Embeds each component of a vector of jets (see [`Jet::embed`]).
pub(crate) fn embed3<const N: usize, const M: usize>(
    v: &Vec3<Jet<N>>,
    map: [usize; N],
) -> Vec3<Jet<M>> {
    Vec3(std::array::from_fn(|i| v.0[i].embed(map)))
}

/// Energy, gradient and Hessian in the 11 DOFs `(x₀, x₁, x₂, θᵉ, θᶠ)` from a jet in the
/// reduced variables `z = (e, f, θᵉ, θᶠ)`, `e = x₁ − x₀`, `f = x₂ − x₁`: `∇_q = Aᵀ∇_z`,
/// `∇²_q = Aᵀ ∇²_z A` with the constant, sparse `A = ∂z/∂q`.
pub(crate) fn pull_back(w: &Jet<8>) -> Evaluation<11> {
    // Column k of A as (z index, coefficient) pairs: q index → the z entries it moves.
    let column = |k: usize| -> [(usize, f64); 2] {
        match k {
            0..=2 => [(k, -1.0), (k, 0.0)],
            3..=5 => [(k - 3, 1.0), (k, -1.0)],
            _ => [(k - 3, 1.0), (k - 3, 0.0)],
        }
    };
    let mut gradient = SVector::<f64, 11>::zeros();
    let mut hessian = SMatrix::<f64, 11, 11>::zeros();
    for k in 0..11 {
        gradient[k] = column(k).iter().map(|&(a, c)| c * w.g[a]).sum();
        for l in k..11 {
            let mut s = 0.0;
            for &(a, ca) in &column(k) {
                for &(b, cb) in &column(l) {
                    s += ca * cb * w.hessian(a, b);
                }
            }
            hessian[(k, l)] = s;
            hessian[(l, k)] = s;
        }
    }
    Evaluation {
        energy: w.v,
        gradient,
        hessian,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hyperdual::{Real, gradient_and_hessian};
    use crate::material_bending::transported_material_frame;

    /// Closed-form frame jets against hyper-dual derivatives of the generic transport.
    #[test]
    fn closed_form_frames_equal_hyper_dual_transport() {
        let reference = Frame::new(&V3::new(0.3, -0.2, 1.0), &V3::new(1.0, 0.4, 0.1)).unwrap();
        for (e, theta) in [
            (V3::new(0.2, 0.1, 0.9), 0.4),
            (V3::new(-0.7, 0.5, 0.4), -2.0),
            (V3::new(0.9, -0.8, -0.1), 1.3),
        ] {
            let (m1, m2) = material_frame_jets(&e, &reference, theta);
            let [t, d1, _] = transported_frame_jets(&e, &reference);
            let q = nalgebra::Vector4::new(e.x, e.y, e.z, theta);
            for i in 0..3 {
                for (what, jet, pick) in [("m1", m1.0[i], 1usize), ("m2", m2.0[i], 2)] {
                    let (v, g, h) = gradient_and_hessian(&q, |x| {
                        let frame =
                            transported_material_frame(&Vec3([x[0], x[1], x[2]]), &reference, x[3]);
                        [frame.0, frame.1, frame.2][pick].0[i]
                    });
                    assert!((jet.v - v).abs() < 1e-13, "{what}[{i}]");
                    for a in 0..4 {
                        assert!((jet.g[a] - g[a]).abs() < 1e-12, "{what}[{i}] g{a}");
                        for b in 0..4 {
                            assert!(
                                (jet.hessian(a, b) - h[(a, b)]).abs() < 1e-11,
                                "{what}[{i}] h{a}{b}: {} vs {}",
                                jet.hessian(a, b),
                                h[(a, b)]
                            );
                        }
                    }
                }
                // θ = 0 directors and the tangent.
                for (what, jet, pick) in [("t", t.0[i], 0usize), ("d1", d1.0[i], 1)] {
                    let q3 = nalgebra::Vector3::new(e.x, e.y, e.z);
                    let (v, g, h) = gradient_and_hessian(&q3, |x| {
                        let frame = transported_material_frame(
                            &Vec3([x[0], x[1], x[2]]),
                            &reference,
                            Real::cst(0.0),
                        );
                        [frame.0, frame.1][pick].0[i]
                    });
                    assert!((jet.v - v).abs() < 1e-13, "{what}[{i}]");
                    for a in 0..3 {
                        assert!((jet.g[a] - g[a]).abs() < 1e-12, "{what}[{i}] g{a}");
                        for b in 0..3 {
                            assert!(
                                (jet.hessian(a, b) - h[(a, b)]).abs() < 1e-11,
                                "{what}[{i}] h{a}{b}"
                            );
                        }
                    }
                }
            }
        }
    }
}
