//! The in-plane material law of the thin shell: a pointwise energy density of the 2-D
//! deformation, knowing nothing about elements (seed 002, §5.1, Eq. 1).
//!
//! # Equations (all in one place)
//!
//! `F` maps the fabric's 2-D **material** coordinates (weft = material x, warp = material y, m)
//! to deformed positions (2-D or 3-D, m); `F` is `R × 2` with `R ∈ {2, 3}`. With the right
//! Cauchy–Green tensor `C = FᵀF` and the Green strain `E = ½(C − I)` in Voigt form
//! `ε = (E₁₁, E₂₂, 2E₁₂)`, the energy per unit **rest area** (J/m² = N/m) is
//!
//! ```text
//! Ψ_StVK = ½ εᵀ K ε,          K = [[kxx, kxy, 0], [kxy, kyy, 0], [0, 0, kss]]     (Eq. 1, first term)
//! Ψ      = Ψ_StVK + kn1 (J − 1)² + kn2 log² J,   J = √det C                        (Eq. 1)
//! ```
//!
//! All six stiffnesses are in N/m (membrane energy per area per unit squared strain). The area
//! ratio `J = √det C` equals `det F` for a non-inverted planar `F` and is the area stretch of a
//! triangle in 3-D. The augmented model has an infinite barrier at `J → 0` (`log² J → ∞` for
//! `kn2 > 0`); for `det C ≤ 0` (a degenerate element) its energy is `+∞` so that line searches
//! reject the step. [`Model::StVK`] drops the two area terms (the comparison model of Fig. 5).
//!
//! The law is written as a function of the three independent components `c = (C₁₁, C₂₂, C₁₂)`:
//! `∂Ψ/∂c` and `∂²Ψ/∂c²` are closed forms ([`Material::eval_c`]); the first Piola–Kirchhoff
//! stress `P = ∂Ψ/∂F` (N/m) and the tangent `∂P/∂F` follow by the chain rule through
//! `C₁₁ = f₁·f₁`, `C₂₂ = f₂·f₂`, `C₁₂ = f₁·f₂` (`f_a` the columns of `F`).
//!
//! Note that the energy is **linear in the six parameters**: `Ψ(p) = Σ_k p_k Ψ(e_k)`. The fit
//! uses this to get `∂(gradient)/∂p` exactly (see `fit`).

use nalgebra::{DMatrix, SMatrix};
use serde::{Deserialize, Serialize};

/// The six in-plane parameters `k_inplane = {kxx, kxy, kyy, kss, kn1, kn2}` of Eq. 1, all in
/// N/m (energy per rest area).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct InPlaneParams {
    /// Weft (material x) normal stiffness `kxx` (N/m).
    pub kxx: f64,
    /// Normal–normal coupling `kxy` (N/m); positive definiteness of `K` needs `kxy² < kxx kyy`.
    pub kxy: f64,
    /// Warp (material y) normal stiffness `kyy` (N/m).
    pub kyy: f64,
    /// Shear stiffness `kss` (N/m), acting on `2E₁₂`.
    pub kss: f64,
    /// Weight of the area term `(J − 1)²` (N/m).
    pub kn1: f64,
    /// Weight of the Neo-Hookean-style barrier `log² J` (N/m).
    pub kn2: f64,
}

impl InPlaneParams {
    /// Number of parameters.
    pub const LEN: usize = 6;
    /// Parameter names in [`to_array`](Self::to_array) order.
    pub const NAMES: [&'static str; 6] = ["kxx", "kxy", "kyy", "kss", "kn1", "kn2"];

    /// `[kxx, kxy, kyy, kss, kn1, kn2]` (N/m).
    pub fn to_array(&self) -> [f64; 6] {
        [self.kxx, self.kxy, self.kyy, self.kss, self.kn1, self.kn2]
    }

    /// Inverse of [`to_array`](Self::to_array).
    pub fn from_array(p: [f64; 6]) -> Self {
        Self {
            kxx: p[0],
            kxy: p[1],
            kyy: p[2],
            kss: p[3],
            kn1: p[4],
            kn2: p[5],
        }
    }

    /// The `k`-th unit parameter vector (energy `Ψ(e_k)` is the derivative of Ψ by `p_k`).
    pub fn unit(k: usize) -> Self {
        let mut p = [0.0; 6];
        p[k] = 1.0;
        Self::from_array(p)
    }

    /// A knit-like example (N/m): soft and anisotropic, warp stiffer than weft.
    pub fn example() -> Self {
        Self {
            kxx: 300.0,
            kxy: 60.0,
            kyy: 900.0,
            kss: 150.0,
            kn1: 40.0,
            kn2: 20.0,
        }
    }
}

/// Which energy density.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Model {
    /// Eq. 1: anisotropic StVK plus `kn1 (J − 1)² + kn2 log² J`.
    Augmented,
    /// Anisotropic StVK only (`kn1`, `kn2` ignored); inverts under strong uniaxial stretch.
    StVK,
}

/// A pointwise in-plane material: parameters plus model choice.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Stiffnesses (N/m).
    pub params: InPlaneParams,
    /// Energy density variant.
    pub model: Model,
}

/// Energy density and its derivatives with respect to `c = (C₁₁, C₂₂, C₁₂)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CEval {
    /// Ψ (J/m²); `+∞` for the augmented model when `det C ≤ 0`.
    pub psi: f64,
    /// `∂Ψ/∂c` (N/m); NaN where `psi` is infinite.
    pub grad: [f64; 3],
    /// `∂²Ψ/∂c²` (N/m), symmetric.
    pub hess: [[f64; 3]; 3],
}

impl Material {
    /// The augmented model of Eq. 1.
    pub fn augmented(params: InPlaneParams) -> Self {
        Self {
            params,
            model: Model::Augmented,
        }
    }

    /// Plain anisotropic StVK.
    pub fn stvk(params: InPlaneParams) -> Self {
        Self {
            params,
            model: Model::StVK,
        }
    }

    /// Ψ and its first two derivatives in `c = (C₁₁, C₂₂, C₁₂)` (see the module docs).
    pub fn eval_c(&self, c: [f64; 3]) -> CEval {
        let p = &self.params;
        // ε = T (c − (1, 1, 0)) with T = diag(½, ½, 1).
        let eps = [0.5 * (c[0] - 1.0), 0.5 * (c[1] - 1.0), c[2]];
        let k = [[p.kxx, p.kxy, 0.0], [p.kxy, p.kyy, 0.0], [0.0, 0.0, p.kss]];
        let t = [0.5, 0.5, 1.0];
        let mut psi = 0.0;
        let mut grad = [0.0; 3];
        let mut hess = [[0.0; 3]; 3];
        for a in 0..3 {
            let ke: f64 = (0..3).map(|b| k[a][b] * eps[b]).sum();
            psi += 0.5 * eps[a] * ke;
            grad[a] = t[a] * ke;
            for b in 0..3 {
                hess[a][b] = t[a] * k[a][b] * t[b];
            }
        }
        if self.model == Model::Augmented {
            // g(d) = kn1 (√d − 1)² + ¼ kn2 ln² d with d = det C = J².
            let d = c[0] * c[1] - c[2] * c[2];
            if d <= 0.0 || !d.is_finite() {
                return CEval {
                    psi: f64::INFINITY,
                    grad: [f64::NAN; 3],
                    hess: [[f64::NAN; 3]; 3],
                };
            }
            let (sd, ld) = (d.sqrt(), d.ln());
            let g0 = p.kn1 * (sd - 1.0).powi(2) + 0.25 * p.kn2 * ld * ld;
            let g1 = p.kn1 * (1.0 - 1.0 / sd) + 0.5 * p.kn2 * ld / d;
            let g2 = 0.5 * p.kn1 / (d * sd) + 0.5 * p.kn2 * (1.0 - ld) / (d * d);
            let dd = [c[1], c[0], -2.0 * c[2]];
            let ddd = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -2.0]];
            psi += g0;
            for a in 0..3 {
                grad[a] += g1 * dd[a];
                for b in 0..3 {
                    hess[a][b] += g2 * dd[a] * dd[b] + g1 * ddd[a][b];
                }
            }
        }
        CEval { psi, grad, hess }
    }

    /// Energy density Ψ(F) (J/m²) for an `R × 2` deformation gradient.
    pub fn energy<const R: usize>(&self, f: &SMatrix<f64, R, 2>) -> f64 {
        self.eval_c(cauchy_green(f)).psi
    }

    /// First Piola–Kirchhoff stress `P = ∂Ψ/∂F` (N/m), `R × 2`.
    pub fn first_piola<const R: usize>(&self, f: &SMatrix<f64, R, 2>) -> SMatrix<f64, R, 2> {
        let e = self.eval_c(cauchy_green(f));
        let (f1, f2) = (f.column(0), f.column(1));
        let mut p = SMatrix::<f64, R, 2>::zeros();
        // ∂C₁₁/∂f₁ = 2f₁, ∂C₂₂/∂f₂ = 2f₂, ∂C₁₂/∂f₁ = f₂, ∂C₁₂/∂f₂ = f₁.
        p.set_column(0, &(f1 * (2.0 * e.grad[0]) + f2 * e.grad[2]));
        p.set_column(1, &(f2 * (2.0 * e.grad[1]) + f1 * e.grad[2]));
        p
    }

    /// Tangent `∂P/∂F` (N/m) as a `2R × 2R` matrix over column-major `vec(F)`
    /// (entry `(i + R a, j + R b)` is `∂P_ia/∂F_jb`).
    pub fn tangent<const R: usize>(&self, f: &SMatrix<f64, R, 2>) -> DMatrix<f64> {
        let e = self.eval_c(cauchy_green(f));
        let n = 2 * R;
        // Jacobian of c by vec(F): 3 × 2R.
        let mut jc = DMatrix::<f64>::zeros(3, n);
        for i in 0..R {
            jc[(0, i)] = 2.0 * f[(i, 0)];
            jc[(1, i + R)] = 2.0 * f[(i, 1)];
            jc[(2, i)] = f[(i, 1)];
            jc[(2, i + R)] = f[(i, 0)];
        }
        let h = DMatrix::from_fn(3, 3, |a, b| e.hess[a][b]);
        let mut t = jc.transpose() * h * &jc;
        // Σ_k ∂Ψ/∂c_k ∂²c_k/∂F²: δ_ij times the 2 × 2 pattern below.
        let m = [[2.0 * e.grad[0], e.grad[2]], [e.grad[2], 2.0 * e.grad[1]]];
        for a in 0..2 {
            for b in 0..2 {
                for i in 0..R {
                    t[(i + R * a, i + R * b)] += m[a][b];
                }
            }
        }
        t
    }

    /// Uniaxial stretch stress `σ_s = uᵀ P u` (N/m) of `F = (1+s) u uᵀ + (1−c) v vᵀ`, the
    /// deformation of Eq. 3, with `u = (cos φ, sin φ)` in material coordinates.
    pub fn uniaxial_f(s: f64, c: f64, angle: f64) -> SMatrix<f64, 2, 2> {
        let (sn, cs) = angle.sin_cos();
        let u = nalgebra::Vector2::new(cs, sn);
        let v = nalgebra::Vector2::new(-sn, cs);
        u * u.transpose() * (1.0 + s) + v * v.transpose() * (1.0 - c)
    }
}

/// `c = (C₁₁, C₂₂, C₁₂)` of `C = FᵀF`.
pub fn cauchy_green<const R: usize>(f: &SMatrix<f64, R, 2>) -> [f64; 3] {
    let (f1, f2) = (f.column(0), f.column(1));
    [f1.dot(&f1), f2.dot(&f2), f1.dot(&f2)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rod::fd::{FdOptions, check_gradient, check_hessian};

    fn check<const R: usize>(m: &Material, f: SMatrix<f64, R, 2>) {
        let q: Vec<f64> = f.as_slice().to_vec();
        let as_f = |x: &[f64]| SMatrix::<f64, R, 2>::from_column_slice(x);
        let p = m.first_piola(&f);
        let typ = p.amax().max(1.0);
        check_gradient(
            |x| m.energy(&as_f(x)),
            p.as_slice(),
            &q,
            &FdOptions::for_scale(1.0, typ),
        )
        .unwrap_or_else(|e| panic!("stress: {e} at F = {f}"));
        let t = m.tangent(&f);
        check_hessian(
            |x| m.first_piola(&as_f(x)).as_slice().to_vec(),
            t.as_slice(),
            &q,
            &FdOptions::for_scale(1.0, t.amax().max(1.0)),
        )
        .unwrap_or_else(|e| panic!("tangent: {e} at F = {f}"));
    }

    #[test]
    fn stress_and_tangent_are_derivatives_of_energy() {
        let f2 = SMatrix::<f64, 2, 2>::new(1.3, 0.2, -0.1, 0.8);
        let f3 = SMatrix::<f64, 3, 2>::new(1.1, 0.3, -0.2, 0.9, 0.25, 0.1);
        for m in [
            Material::augmented(InPlaneParams::example()),
            Material::stvk(InPlaneParams::example()),
        ] {
            check(&m, f2);
            check(&m, f3);
        }
    }

    #[test]
    fn rest_state_is_stress_free_and_rotation_invariant() {
        let m = Material::augmented(InPlaneParams::example());
        let (s, c) = 0.3f64.sin_cos();
        let rot = SMatrix::<f64, 2, 2>::new(c, -s, s, c);
        assert!(m.energy(&rot).abs() < 1e-12);
        assert!(m.first_piola(&rot).amax() < 1e-12);
        let f = SMatrix::<f64, 2, 2>::new(1.2, 0.1, 0.05, 0.9);
        assert!((m.energy(&(rot * f)) - m.energy(&f)).abs() < 1e-12 * m.energy(&f));
    }

    #[test]
    fn augmented_energy_is_infinite_for_degenerate_area() {
        let m = Material::augmented(InPlaneParams::example());
        let f = SMatrix::<f64, 2, 2>::new(1.0, 1.0, 1.0, 1.0);
        assert_eq!(m.energy(&f), f64::INFINITY);
        assert!(
            Material::stvk(InPlaneParams::example())
                .energy(&f)
                .is_finite()
        );
    }

    #[test]
    fn energy_is_linear_in_parameters() {
        let p = InPlaneParams::example();
        let f = SMatrix::<f64, 2, 2>::new(1.4, 0.1, 0.2, 0.85);
        let full = Material::augmented(p).energy(&f);
        let sum: f64 = (0..6)
            .map(|k| p.to_array()[k] * Material::augmented(InPlaneParams::unit(k)).energy(&f))
            .sum();
        assert!((full - sum).abs() < 1e-12 * full.abs());
    }
}
