//! Yarn bending at an interior vertex `x₁` between edges `e⁰ = x₁ − x₀` and `e¹ = x₂ − x₁`.
//!
//! - [`AngleBending`] — seed 000, Eq. 1: `V = k_b φ(θ)/Δu`, θ the angle between the two
//!   segments and `Δu = u₂ − u₀` the summed (sliding) arc length of both segments, with the
//!   bending-jamming stiffening of §4.1 built into φ.
//! - [`BinormalBending`] — Bergou 2008 curvature-binormal energy without rest curvature:
//!   `W = k_b |κb|² / (L_a + L_b)`, the special case κ̄ = 0 of seed 002 Eq. 6.
//!
//! Both are functions of the cosine `ĉ = e⁰·e¹/(|e⁰||e¹|)` of the turning angle only
//! (`|κb|² = 4 tan²(θ/2) = 4(1 − ĉ)/(1 + ĉ)` and `θ = acos ĉ`), which makes them smooth at
//! θ = 0 (a straight rod) where the angle itself is not differentiable. The chain rule
//! through ĉ lives in one place, [`cosine_function_derivatives`].

use crate::geometry::{CosineDerivatives, V3};
use crate::stencil::{Evaluation, Stencil};
use nalgebra::{SMatrix, SVector};

/// Gradient and Hessian w.r.t. `(x₀, x₁, x₂)` of `F(ĉ(x))`, given `F'(ĉ)` and `F''(ĉ)`.
pub fn cosine_function_derivatives(
    x0: &V3,
    x1: &V3,
    x2: &V3,
    f1: f64,
    f2: f64,
) -> (SVector<f64, 9>, SMatrix<f64, 9, 9>) {
    let cd = CosineDerivatives::new(&(x1 - x0), &(x2 - x1));
    // Derivatives w.r.t. the edges (e⁰, e¹).
    let mut dc = SVector::<f64, 6>::zeros();
    dc.fixed_rows_mut::<3>(0).copy_from(&cd.da);
    dc.fixed_rows_mut::<3>(3).copy_from(&cd.db);
    let mut ddc = SMatrix::<f64, 6, 6>::zeros();
    ddc.fixed_view_mut::<3, 3>(0, 0).copy_from(&cd.daa);
    ddc.fixed_view_mut::<3, 3>(0, 3).copy_from(&cd.dab);
    ddc.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&cd.dab.transpose());
    ddc.fixed_view_mut::<3, 3>(3, 3).copy_from(&cd.dbb);
    let g_e = f1 * dc;
    let h_e = f2 * dc * dc.transpose() + f1 * ddc;
    // e = B x with e⁰ = x₁ − x₀, e¹ = x₂ − x₁.
    let mut b = SMatrix::<f64, 6, 9>::zeros();
    for k in 0..3 {
        b[(k, k)] = -1.0;
        b[(k, 3 + k)] = 1.0;
        b[(3 + k, 3 + k)] = -1.0;
        b[(3 + k, 6 + k)] = 1.0;
    }
    (b.transpose() * g_e, b.transpose() * h_e * b)
}

/// Smooth bending-jamming profile of seed 000 §4.1: the bending stiffness grows smoothly by
/// `factor` (×1000 in the paper) once the bend angle passes `angle` (π/2 in the paper).
///
/// The energy shape is `φ(θ) = θ² + 2 (factor − 1) J(θ − angle)` with `J'' = S`, `S` the
/// quintic smoothstep that rises from 0 to 1 over `width` radians. Hence the stiffness
/// `φ''(θ) = 2 (1 + (factor − 1) S)` goes from `2` to `2·factor` without a jump in force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jamming {
    /// Angle θ_j (rad) where stiffening starts. Default π/2 (seed 000).
    pub angle: f64,
    /// Angular width (rad) of the smooth transition. Default 0.1 rad (not given in the paper).
    pub width: f64,
    /// Stiffness multiplier once jammed. Default 1000 (seed 000: "three orders of magnitude").
    pub factor: f64,
}

impl Default for Jamming {
    fn default() -> Self {
        Self {
            angle: std::f64::consts::FRAC_PI_2,
            width: 0.1,
            factor: 1000.0,
        }
    }
}

impl Jamming {
    /// No stiffening (`φ = θ²`).
    pub fn none() -> Self {
        Self {
            factor: 1.0,
            ..Self::default()
        }
    }

    /// `(J, J', J'')` of the twice-integrated smoothstep at `x = θ − angle`.
    fn integrated_smoothstep(&self, x: f64) -> (f64, f64, f64) {
        let w = self.width;
        if x <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if x < w {
            let t = x / w;
            let (t2, t3) = (t * t, t * t * t);
            (
                w * w * t2 * t3 * (0.5 - 0.5 * t + t2 / 7.0),
                w * t2 * t2 * (2.5 - 3.0 * t + t2),
                t3 * (10.0 - 15.0 * t + 6.0 * t2),
            )
        } else {
            let y = x - w;
            (w * w / 7.0 + 0.5 * w * y + 0.5 * y * y, 0.5 * w + y, 1.0)
        }
    }

    /// `(φ, φ', φ'')` at bend angle θ (rad).
    pub fn profile(&self, theta: f64) -> (f64, f64, f64) {
        let (j, dj, ddj) = self.integrated_smoothstep(theta - self.angle);
        let a = 2.0 * (self.factor - 1.0);
        (theta * theta + a * j, 2.0 * theta + a * dj, 2.0 + a * ddj)
    }
}

/// Seed 000, Eq. 1 with bending jamming: `V = k_b φ(θ)/Δu`, `Δu = u₂ − u₀`.
///
/// DOFs `(x₀, u₀, x₁, u₁, x₂, u₂)` (12; `u₁` does not enter the energy). `k_b = B π R²`
/// (N·m², B the bending modulus in Pa, R the yarn radius in m). Undefined when the rod folds
/// back fully (θ = π) or an edge has zero length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleBending {
    /// Bending stiffness k_b (N·m²).
    pub stiffness: f64,
    /// Jamming profile.
    pub jamming: Jamming,
}

impl AngleBending {
    /// `(H, H', H'')` for `H(ĉ) = φ(acos ĉ)`, from the sine and cosine of θ.
    fn shape_of_cosine(&self, s: f64, c: f64) -> (f64, f64, f64) {
        let theta = s.atan2(c);
        let (phi, dphi, ddphi) = self.jamming.profile(theta);
        if theta < 1e-3 && theta <= self.jamming.angle {
            // φ = θ² here; use series of −2θ/sin θ and 2(sin θ − θ cos θ)/sin³ θ to avoid
            // cancellation (and 0/0 at θ = 0).
            let t2 = theta * theta;
            return (
                phi,
                -2.0 * (1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0),
                2.0 / 3.0 + 4.0 * t2 / 15.0,
            );
        }
        (phi, -dphi / s, ddphi / (s * s) - dphi * c / (s * s * s))
    }

    fn sine_cosine(x0: &V3, x1: &V3, x2: &V3) -> (f64, f64) {
        let (e0, e1) = (x1 - x0, x2 - x1);
        let n = e0.norm() * e1.norm();
        (e0.cross(&e1).norm() / n, e0.dot(&e1) / n)
    }
}

fn positions_12(q: &SVector<f64, 12>) -> (V3, V3, V3, f64) {
    (
        q.fixed_rows::<3>(0).into(),
        q.fixed_rows::<3>(4).into(),
        q.fixed_rows::<3>(8).into(),
        q[11] - q[3],
    )
}

impl Stencil<12> for AngleBending {
    fn energy(&self, q: &SVector<f64, 12>) -> f64 {
        let (x0, x1, x2, du) = positions_12(q);
        let (s, c) = Self::sine_cosine(&x0, &x1, &x2);
        self.stiffness * self.jamming.profile(s.atan2(c)).0 / du
    }

    fn eval(&self, q: &SVector<f64, 12>) -> Evaluation<12> {
        let (x0, x1, x2, du) = positions_12(q);
        let (s, c) = Self::sine_cosine(&x0, &x1, &x2);
        let (h, h1, h2) = self.shape_of_cosine(s, c);
        let (gx, hx) = cosine_function_derivatives(&x0, &x1, &x2, h1, h2);
        let k = self.stiffness;
        // V = k H / U with U = u₂ − u₀.
        let mut out = Evaluation::<12>::zero();
        out.energy = k * h / du;
        let pos = [0usize, 4, 8];
        let (iu0, iu2) = (3usize, 11usize);
        let v_u = -k * h / (du * du);
        let v_uu = 2.0 * k * h / (du * du * du);
        for (a, &ia) in pos.iter().enumerate() {
            let ga = gx.fixed_rows::<3>(3 * a);
            out.gradient
                .fixed_rows_mut::<3>(ia)
                .copy_from(&(k / du * ga));
            let cross = -k / (du * du) * ga;
            for (iu, sgn) in [(iu0, -1.0), (iu2, 1.0)] {
                out.hessian
                    .fixed_view_mut::<3, 1>(ia, iu)
                    .copy_from(&(sgn * cross));
                out.hessian
                    .fixed_view_mut::<1, 3>(iu, ia)
                    .copy_from(&(sgn * cross.transpose()));
            }
            for (b, &ib) in pos.iter().enumerate() {
                out.hessian
                    .fixed_view_mut::<3, 3>(ia, ib)
                    .copy_from(&(k / du * hx.fixed_view::<3, 3>(3 * a, 3 * b)));
            }
        }
        out.gradient[iu0] = -v_u;
        out.gradient[iu2] = v_u;
        out.hessian[(iu0, iu0)] = v_uu;
        out.hessian[(iu2, iu2)] = v_uu;
        out.hessian[(iu0, iu2)] = -v_uu;
        out.hessian[(iu2, iu0)] = -v_uu;
        out
    }
}

/// Curvature-binormal bending without rest curvature (Bergou 2008; seed 002 Eq. 6 with
/// κ̄ = 0): `W = k_b |κb|²/(L_a + L_b)`, `|κb|² = 4(1 − ĉ)/(1 + ĉ)`.
///
/// DOFs `(x₀, x₁, x₂)` (9). `k_b = E I` (N·m²); `L_a`, `L_b` are the rest lengths (m) of the
/// two edges. For a smooth rod this discretizes `½ ∫ k_b κ² ds`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BinormalBending {
    /// Bending stiffness k_b (N·m²).
    pub stiffness: f64,
    /// Rest lengths `(L_a, L_b)` of the two edges (m).
    pub rest_lengths: (f64, f64),
}

impl BinormalBending {
    fn weight(&self) -> f64 {
        self.stiffness / (self.rest_lengths.0 + self.rest_lengths.1)
    }
}

fn positions_9(q: &SVector<f64, 9>) -> (V3, V3, V3) {
    (
        q.fixed_rows::<3>(0).into(),
        q.fixed_rows::<3>(3).into(),
        q.fixed_rows::<3>(6).into(),
    )
}

impl Stencil<9> for BinormalBending {
    fn energy(&self, q: &SVector<f64, 9>) -> f64 {
        let (x0, x1, x2) = positions_9(q);
        self.weight() * crate::geometry::curvature_binormal(&(x1 - x0), &(x2 - x1)).norm_squared()
    }

    fn eval(&self, q: &SVector<f64, 9>) -> Evaluation<9> {
        let (x0, x1, x2) = positions_9(q);
        let (e0, e1) = (x1 - x0, x2 - x1);
        let c = e0.dot(&e1) / (e0.norm() * e1.norm());
        let w = self.weight();
        // g(ĉ) = 4(1 − ĉ)/(1 + ĉ), g' = −8/(1 + ĉ)², g'' = 16/(1 + ĉ)³.
        let p = 1.0 + c;
        let (g1, g2) = (-8.0 / (p * p), 16.0 / (p * p * p));
        let (gx, hx) = cosine_function_derivatives(&x0, &x1, &x2, g1, g2);
        Evaluation {
            energy: w * crate::geometry::curvature_binormal(&e0, &e1).norm_squared(),
            gradient: w * gx,
            hessian: w * hx,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jamming_profile_is_c2_and_stiffens_by_factor() {
        let j = Jamming::default();
        // Across [x − δ, x + δ] a C² function changes by at most 2δ·max|derivative|.
        let delta = 1e-9;
        for x in [j.angle, j.angle + j.width] {
            let a = j.profile(x - delta);
            let b = j.profile(x + delta);
            assert!((a.0 - b.0).abs() <= 2.0 * delta * a.1.max(b.1) * 1.001);
            assert!((a.1 - b.1).abs() <= 2.0 * delta * 2.0 * j.factor * 1.001);
            assert!(
                (a.2 - b.2).abs() < 1e-6 * j.factor,
                "stiffness jumps at {x}"
            );
        }
        assert_eq!(j.profile(1.0).2, 2.0);
        assert!((j.profile(2.0).2 - 2.0 * j.factor).abs() < 1e-9);
    }

    #[test]
    fn straight_rod_has_zero_force_and_finite_hessian() {
        let b = AngleBending {
            stiffness: 1e-6,
            jamming: Jamming::default(),
        };
        let q = SVector::<f64, 12>::from_column_slice(&[
            0.0, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.01, 0.02, 0.0, 0.0, 0.02,
        ]);
        let e = b.eval(&q);
        assert_eq!(e.energy, 0.0);
        assert!(e.gradient.norm() < 1e-18);
        assert!(e.hessian.iter().all(|v| v.is_finite()));
        assert!(e.hessian.norm() > 0.0);
    }
}
