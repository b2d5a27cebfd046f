//! The in-plane material law of the thin shell: a pointwise energy density of the 2-D
//! deformation, knowing nothing about elements (seed 002, §5.1, Eq. 1, and one model beyond it).
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
//! **Beyond the paper: [`Model::Stiffening`].** Knitted fabrics stiffen by an order of
//! magnitude over their tested stretch range, which no quadratic in `E` follows; and their
//! lateral contraction under a uniaxial pull saturates as the loops jam. The stiffening model
//! replaces the two normal terms `½ kxx E₁₁²`, `½ kyy E₂₂²` of Ψ_StVK by a Fung-type
//! exponential per material direction with one rate in tension and one in compression, keeping
//! everything else of Eq. 1:
//!
//! ```text
//! Ψ_stiff = kxx φ(E₁₁; bx, cx) + kyy φ(E₂₂; by, cy) + kxy E₁₁E₂₂ + ½ kss (2E₁₂)² + kn1 (J − 1)² + kn2 log² J
//! φ(E; b, c) = (e^{βE} − 1 − βE) / β²,   β = b for E ≥ 0, β = −c for E < 0
//! φ' = (e^{βE} − 1)/β,   φ'' = e^{βE} = e^{b E} (tension) or e^{c |E|} (compression)     (φ → ½E² as β → 0)
//! ```
//!
//! The rates `b, c ≥ 0` (per unit Green strain) make the normal tangent stiffness
//! `kxx e^{bx E₁₁}` in tension and `kxx e^{cx |E₁₁|}` in compression, so `kxx` keeps its meaning
//! as the small-strain stiffness and zero rates recover Eq. 1 exactly. φ is convex and `C²` at
//! `E = 0` (both branches have `φ = φ' = 0`, `φ'' = 1` there). **Stable in compression:** the
//! compressive branch only stiffens, and the `log² J` barrier (which the fit keeps at
//! `kn2 > 0` for this model) still rules `J → 0` out, so no element inverts.
//!
//! The law is written as a function of the three independent components `c = (C₁₁, C₂₂, C₁₂)`:
//! `∂Ψ/∂c` and `∂²Ψ/∂c²` are closed forms ([`Material::eval_c`]); the first Piola–Kirchhoff
//! stress `P = ∂Ψ/∂F` (N/m) and the tangent `∂P/∂F` follow by the chain rule through
//! `C₁₁ = f₁·f₁`, `C₂₂ = f₂·f₂`, `C₁₂ = f₁·f₂` (`f_a` the columns of `F`).
//!
//! **Parameter derivatives.** The adjoint fit needs `∂(∂Ψ/∂c)/∂p_k` for every parameter
//! ([`Material::eval_c_dparam`]). Ψ is linear in the six stiffnesses (for the stiffening
//! model: at fixed rates), so for those it is `∂Ψ/∂c` of the unit parameter; for the rates it is
//! the closed form `∂φ'/∂β = E² h₂(βE)`, `h₂(x) = (x eˣ − eˣ + 1)/x²` (with `∂β/∂c = −1`).

use nalgebra::{DMatrix, SMatrix};
use serde::{Deserialize, Serialize};

/// The in-plane parameters: the six `k_inplane = {kxx, kxy, kyy, kss, kn1, kn2}` of Eq. 1
/// (N/m, energy per rest area) and the four stiffening rates `{bx, by, cx, cy}` of
/// [`Model::Stiffening`] (per unit Green strain; ignored by the paper's models, absent in files
/// means 0).
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
    /// Weft stiffening rate `bx` of [`Model::Stiffening`] (per unit Green strain).
    #[serde(default)]
    pub bx: f64,
    /// Warp stiffening rate `by` of [`Model::Stiffening`] (per unit Green strain).
    #[serde(default)]
    pub by: f64,
    /// Weft compression stiffening rate `cx` of [`Model::Stiffening`] (per unit Green strain).
    #[serde(default)]
    pub cx: f64,
    /// Warp compression stiffening rate `cy` of [`Model::Stiffening`] (per unit Green strain).
    #[serde(default)]
    pub cy: f64,
}

impl InPlaneParams {
    /// Number of parameters.
    pub const LEN: usize = 10;
    /// Parameter names in [`to_array`](Self::to_array) order.
    pub const NAMES: [&'static str; 10] = [
        "kxx", "kxy", "kyy", "kss", "kn1", "kn2", "bx", "by", "cx", "cy",
    ];
    /// Indices of the stiffening rates (not used by the paper's models).
    pub const RATES: [usize; 4] = [6, 7, 8, 9];

    /// `[kxx, kxy, kyy, kss, kn1, kn2, bx, by, cx, cy]`.
    pub fn to_array(&self) -> [f64; 10] {
        [
            self.kxx, self.kxy, self.kyy, self.kss, self.kn1, self.kn2, self.bx, self.by, self.cx,
            self.cy,
        ]
    }

    /// Inverse of [`to_array`](Self::to_array).
    pub fn from_array(p: [f64; 10]) -> Self {
        Self {
            kxx: p[0],
            kxy: p[1],
            kyy: p[2],
            kss: p[3],
            kn1: p[4],
            kn2: p[5],
            bx: p[6],
            by: p[7],
            cx: p[8],
            cy: p[9],
        }
    }

    /// A knit-like example (N/m): soft and anisotropic, warp stiffer than weft; no stiffening.
    pub fn example() -> Self {
        Self {
            kxx: 300.0,
            kxy: 60.0,
            kyy: 900.0,
            kss: 150.0,
            kn1: 40.0,
            kn2: 20.0,
            bx: 0.0,
            by: 0.0,
            cx: 0.0,
            cy: 0.0,
        }
    }

    /// The signed rate `β` of direction `a` (0 weft, 1 warp) at normal Green strain `e`.
    fn rate(&self, a: usize, e: f64) -> f64 {
        match (a, e >= 0.0) {
            (0, true) => self.bx,
            (0, false) => -self.cx,
            (_, true) => self.by,
            (_, false) => -self.cy,
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
    /// Beyond the paper: Eq. 1 with exponential stiffening of the weft and warp normal terms
    /// in tension (rates `bx`, `by`) and compression (`cx`, `cy`); see the module docs.
    Stiffening,
}

impl Model {
    /// All models, the paper's first.
    pub const ALL: [Model; 3] = [Model::StVK, Model::Augmented, Model::Stiffening];

    /// Lower-case name (`stvk`, `augmented`, `stiffening`).
    pub fn name(self) -> &'static str {
        match self {
            Model::StVK => "stvk",
            Model::Augmented => "augmented",
            Model::Stiffening => "stiffening",
        }
    }

    /// Whether parameter `k` (order of [`InPlaneParams::to_array`]) enters the energy.
    pub fn uses(self, k: usize) -> bool {
        match self {
            Model::StVK => k < 4,
            Model::Augmented => k < 6,
            Model::Stiffening => k < InPlaneParams::LEN,
        }
    }
}

/// `g(x) = (eˣ − 1 − x)/x²`, `h₁(x) = (eˣ − 1)/x`, `h₂(x) = (x eˣ − eˣ + 1)/x²` (all finite at
/// `x = 0`, by series near it): `φ = E² g(bE)`, `φ' = E h₁(bE)`, `∂φ'/∂b = E² h₂(bE)`.
fn exp_kernels(x: f64) -> (f64, f64, f64) {
    if x.abs() < 1e-3 {
        let x2 = x * x;
        (
            0.5 + x / 6.0 + x2 / 24.0 + x2 * x / 120.0,
            1.0 + 0.5 * x + x2 / 6.0 + x2 * x / 24.0,
            0.5 + x / 3.0 + x2 / 8.0 + x2 * x / 30.0,
        )
    } else {
        let em1 = x.exp_m1();
        let x2 = x * x;
        ((em1 - x) / x2, em1 / x, (x * (em1 + 1.0) - em1) / x2)
    }
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
        if self.model == Model::Stiffening {
            // kxx φ(E₁₁; bx) + kyy φ(E₂₂; by) + kxy E₁₁E₂₂ + ½ kss ε₃², with ∂E_aa/∂c_a = ½.
            let normal = |k: f64, b: f64, e: f64| {
                let (g, h1, _) = exp_kernels(b * e);
                (k * e * e * g, k * e * h1, k * (b * e).exp())
            };
            let (px, dx, hx) = normal(p.kxx, p.rate(0, eps[0]), eps[0]);
            let (py, dy, hy) = normal(p.kyy, p.rate(1, eps[1]), eps[1]);
            psi = px + py + p.kxy * eps[0] * eps[1] + 0.5 * p.kss * eps[2] * eps[2];
            grad = [
                0.5 * (dx + p.kxy * eps[1]),
                0.5 * (dy + p.kxy * eps[0]),
                p.kss * eps[2],
            ];
            hess = [
                [0.25 * hx, 0.25 * p.kxy, 0.0],
                [0.25 * p.kxy, 0.25 * hy, 0.0],
                [0.0, 0.0, p.kss],
            ];
        } else {
            for a in 0..3 {
                let ke: f64 = (0..3).map(|b| k[a][b] * eps[b]).sum();
                psi += 0.5 * eps[a] * ke;
                grad[a] = t[a] * ke;
                for b in 0..3 {
                    hess[a][b] = t[a] * k[a][b] * t[b];
                }
            }
        }
        if self.model != Model::StVK {
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

    /// `∂(∂Ψ/∂c)/∂p_k`: how the stress in `c` changes with parameter `k` (order of
    /// [`InPlaneParams::to_array`]); zero for parameters the model does not use. The six
    /// stiffnesses enter linearly (at fixed rates): their derivative is `∂Ψ/∂c` of the unit
    /// stiffness. NaN where the energy is infinite.
    pub fn eval_c_dparam(&self, c: [f64; 3], k: usize) -> [f64; 3] {
        if !self.model.uses(k) {
            return [0.0; 3];
        }
        let p = &self.params;
        match k {
            6..=9 => {
                // Direction a; the rate acts on its tension (k = 6, 7) or compression branch.
                let a = (k - 6) % 2;
                let tension = k < 8;
                let stiffness = if a == 0 { p.kxx } else { p.kyy };
                let e = 0.5 * (c[a] - 1.0);
                let mut out = [0.0; 3];
                if (e >= 0.0) == tension {
                    let (_, _, h2) = exp_kernels(p.rate(a, e) * e);
                    // ∂β/∂b = 1, ∂β/∂c = −1; ∂E/∂c_a = ½.
                    let sign = if tension { 1.0 } else { -1.0 };
                    out[a] = 0.5 * sign * stiffness * e * e * h2;
                }
                out
            }
            _ => {
                let mut unit = p.to_array();
                unit[..6].fill(0.0);
                unit[k] = 1.0;
                Material {
                    params: InPlaneParams::from_array(unit),
                    model: self.model,
                }
                .eval_c(c)
                .grad
            }
        }
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

    fn stiffening() -> Material {
        Material {
            params: InPlaneParams {
                bx: 4.0,
                by: 9.0,
                cx: 6.0,
                cy: 2.5,
                ..InPlaneParams::example()
            },
            model: Model::Stiffening,
        }
    }

    #[test]
    fn stiffening_stress_and_tangent_are_derivatives_of_energy() {
        let m = stiffening();
        check(&m, SMatrix::<f64, 2, 2>::new(1.3, 0.2, -0.1, 0.8));
        check(&m, SMatrix::<f64, 2, 2>::new(0.7, 0.05, 0.1, 1.4));
        check(
            &m,
            SMatrix::<f64, 3, 2>::new(1.1, 0.3, -0.2, 0.9, 0.25, 0.1),
        );
        // Near E = 0 the kernels switch to their series and the rates switch branch: both
        // sides must agree.
        check(
            &m,
            SMatrix::<f64, 2, 2>::new(1.0 + 2e-5, 1e-6, -2e-6, 1.0 - 3e-5),
        );
        check(&m, SMatrix::<f64, 2, 2>::new(0.6, 0.1, 0.0, 0.75));
    }

    #[test]
    fn stiffening_without_rates_is_the_augmented_model() {
        let p = InPlaneParams::example();
        let (a, s) = (
            Material::augmented(p),
            Material {
                params: p,
                model: Model::Stiffening,
            },
        );
        for f in [
            SMatrix::<f64, 2, 2>::new(1.3, 0.2, -0.1, 0.8),
            SMatrix::<f64, 2, 2>::new(0.6, 0.0, 0.0, 1.7),
        ] {
            let (ea, es) = (a.energy(&f), s.energy(&f));
            assert!((ea - es).abs() <= 1e-12 * ea.abs(), "{ea} vs {es}");
            let d = (a.first_piola(&f) - s.first_piola(&f)).amax();
            assert!(d <= 1e-10 * a.first_piola(&f).amax(), "{d}");
        }
    }

    #[test]
    fn stiffening_tangent_grows_exponentially_in_tension_and_in_compression() {
        // Pure weft stretch with kxy = kn1 = kn2 = 0: ∂²Ψ/∂E₁₁² = kxx e^{bx E₁₁}.
        let m = Material {
            params: InPlaneParams {
                kxy: 0.0,
                kn1: 0.0,
                kn2: 0.0,
                ..stiffening().params
            },
            model: Model::Stiffening,
        };
        for e11 in [-0.3, -1e-5, 0.0, 1e-5, 0.2, 0.5] {
            let c = [1.0 + 2.0 * e11, 1.0, 0.0];
            // ∂²Ψ/∂c₁₁² = ¼ ∂²Ψ/∂E₁₁².
            let got = 4.0 * m.eval_c(c).hess[0][0];
            let rate = if e11 >= 0.0 {
                m.params.bx
            } else {
                -m.params.cx
            };
            let want = m.params.kxx * (rate * e11).exp();
            assert!((got - want).abs() <= 1e-12 * want, "{e11}: {got} vs {want}");
        }
    }

    #[test]
    fn parameter_derivatives_match_finite_differences() {
        let c = [1.44, 0.81, 0.12];
        for m in [
            Material::augmented(InPlaneParams::example()),
            Material::stvk(InPlaneParams::example()),
            stiffening(),
        ] {
            for k in 0..InPlaneParams::LEN {
                let got = m.eval_c_dparam(c, k);
                let h = 1e-6 * m.params.to_array()[k].abs().max(1.0);
                let at = |dp: f64| {
                    let mut p = m.params.to_array();
                    p[k] += dp;
                    Material {
                        params: InPlaneParams::from_array(p),
                        model: m.model,
                    }
                    .eval_c(c)
                    .grad
                };
                let (gp, gm) = (at(h), at(-h));
                for a in 0..3 {
                    let fd = (gp[a] - gm[a]) / (2.0 * h);
                    let tol = 1e-6 * (fd.abs() + got[a].abs()).max(1e-3);
                    assert!(
                        (fd - got[a]).abs() <= tol,
                        "{:?} {} [{a}]: {} vs FD {fd}",
                        m.model,
                        InPlaneParams::NAMES[k],
                        got[a]
                    );
                }
            }
        }
    }
}
