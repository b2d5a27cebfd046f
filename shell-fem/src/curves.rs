//! Uniform target curves for the yarn-level fit (seed 002, §5.1 Eq. 3 and §5.2).
//!
//! **Stretch.** For stretch `s` along the material direction `u = (cos φ, sin φ)` and
//! compression `c` along `v ⊥ u`, `F = (1+s) u uᵀ + (1−c) v vᵀ`; the compression minimizes
//! Ψ (Eq. 3), i.e. zero orthogonal stress `vᵀPv = 0`, and the stretch stress is
//! `σ_s = uᵀPu` (N/m, first Piola–Kirchhoff: force per unit *rest* width). Uniaxial force on a
//! swatch of rest width `w̄` under frictionless clamps is `σ_s w̄`.
//!
//! The 1-D minimization is done in `w = 1 − c ≥ 0` by a safeguarded Newton iteration on
//! `dΨ/dw = vᵀPv` inside a sign-change bracket ([`solver::find_root`]). For plain StVK the minimum can sit at `w = 0`
//! (`c = 1`, the inversion of Fig. 5): that value is returned, not an error.
//!
//! **Bending.** `σ_κ = ∂Ψ_b/∂κ = 2 k_θ κ` (N, per unit length: moment per width).

use crate::csv_io::CsvTable;
use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};
use solver::{Bracket, RootError, RootEval, RootSettings, find_root};
use std::convert::Infallible;
use yarn_pattern::direction::Direction;

use crate::ShellError;
use crate::elements::BendingParams;
use crate::material::{InPlaneParams, Material};

/// One point of a uniform uniaxial curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct UniaxialPoint {
    /// Stretch `s`.
    pub s: f64,
    /// Orthogonal compression `c` (Eq. 3).
    pub c: f64,
    /// Stretch stress `σ_s = uᵀPu` (N/m).
    pub sigma: f64,
}

/// One point of a bending curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BendingPoint {
    /// Curvature κ (1/m).
    pub kappa: f64,
    /// Bending stress `σ_κ = 2 k_θ κ` (N).
    pub sigma: f64,
}

/// `(Ψ', Ψ'')` by `w = 1 − c` at `(s, w)`.
fn dpsi_dw(m: &Material, s: f64, w: f64, angle: f64) -> (f64, f64) {
    let f = Material::uniaxial_f(s, 1.0 - w, angle);
    let (sn, cs) = angle.sin_cos();
    let v = Vector2::new(-sn, cs);
    let p = m.first_piola(&f);
    let vv: Matrix2<f64> = v * v.transpose();
    let d1 = (p.component_mul(&vv)).sum();
    let t = m.tangent(&f);
    let vec_vv = nalgebra::DVector::from_column_slice(vv.as_slice());
    let d2 = (vec_vv.transpose() * &t * &vec_vv)[(0, 0)];
    (d1, d2)
}

/// Orthogonal compression `c(s)` of Eq. 3 for pulling along `angle` (rad from the weft).
pub fn uniaxial_compression(m: &Material, s: f64, angle: f64) -> Result<f64, ShellError> {
    if !(s > -1.0 && s.is_finite()) {
        return Err(ShellError::InvalidInput(format!(
            "stretch must be > −1, got {s}"
        )));
    }
    let h = |w: f64| dpsi_dw(m, s, w, angle);
    // Bracket: h(lo) < 0 < h(hi).
    let mut hi = 1.0;
    let mut grow = 0;
    while h(hi).0.is_nan() || h(hi).0 <= 0.0 {
        hi *= 2.0;
        grow += 1;
        if grow > 60 {
            return Err(ShellError::Numerical(format!(
                "Eq. 3: no upper bracket for the compression at s = {s}"
            )));
        }
    }
    let mut lo = hi;
    let mut shrink = 0;
    let f_lo = loop {
        lo *= 0.5;
        shrink += 1;
        let v = h(lo).0;
        if v.is_nan() || v < 0.0 {
            // NaN cannot happen for w > 0 (J > 0); the root finder rejects it loudly.
            break v;
        }
        if shrink > 200 {
            // Ψ'(w) ≥ 0 all the way down to w → 0: the minimum is at w = 0 (c = 1, inversion).
            return Ok(1.0);
        }
    };
    let bracket = Bracket {
        lo,
        hi,
        f_lo,
        f_hi: h(hi).0,
    };
    let settings = RootSettings {
        x_atol: 0.0,
        x_rtol: 1e-15,
        f_atol: 0.0,
        newton_rtol: 1e-15,
        max_iterations: 200,
    };
    let newton = |w: f64| {
        let (d1, d2) = h(w);
        Ok::<_, Infallible>(RootEval::with_derivative(d1, d2))
    };
    match find_root(bracket, None, &settings, newton) {
        Ok(root) => Ok(1.0 - root.x),
        Err(RootError::NotConverged(r)) => Err(ShellError::Numerical(format!(
            "Eq. 3: compression root not converged at s = {s} (bracket [{}, {}] in 1 − c)",
            r.bracket[0], r.bracket[1]
        ))),
        Err(e) => Err(ShellError::Numerical(format!(
            "Eq. 3: compression at s = {s}: {e}"
        ))),
    }
}

/// `{s, c, σ_s}` at each stretch in `stretches` for pulling along `angle` (rad).
pub fn uniaxial_curve(
    m: &Material,
    angle: f64,
    stretches: &[f64],
) -> Result<Vec<UniaxialPoint>, ShellError> {
    stretches
        .iter()
        .map(|&s| {
            let c = uniaxial_compression(m, s, angle)?;
            let f = Material::uniaxial_f(s, c, angle);
            let (sn, cs) = angle.sin_cos();
            let u = Vector2::new(cs, sn);
            let sigma = (u.transpose() * m.first_piola(&f) * u)[(0, 0)];
            if !sigma.is_finite() {
                return Err(ShellError::Numerical(format!(
                    "non-finite stretch stress at s = {s} (c = {c})"
                )));
            }
            Ok(UniaxialPoint { s, c, sigma })
        })
        .collect()
}

/// A point of the homogeneous uniaxial test and its parameter sensitivities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniaxialSensitivity {
    /// The point (Eq. 3: zero orthogonal stress).
    pub point: UniaxialPoint,
    /// `dc/dp_k` (order of [`InPlaneParams::to_array`]).
    pub compression: [f64; InPlaneParams::LEN],
    /// `dσ_s/dp_k` (N/m per unit parameter).
    pub sigma: [f64; InPlaneParams::LEN],
}

/// [`uniaxial_curve`] at one stretch, with the total derivatives of `c` and `σ_s` in the
/// material parameters by implicit differentiation of the zero-orthogonal-stress condition.
///
/// With `F = (1+s) u uᵀ + w v vᵀ`, `w = 1 − c`, `C = FᵀF = (1+s)² u uᵀ + w² v vᵀ`, so in
/// `c = (C₁₁, C₂₂, C₁₂)` the derivatives `C_s = 2(1+s)(u₁², u₂², u₁u₂)` and
/// `C_w = 2w(v₁², v₂², v₁v₂)` are constant directions. The condition `g = ∂Ψ/∂w = ∇Ψ·C_w = 0`
/// gives `dw/dp = −g_p / g_w` with `g_w = C_wᵀ ∇²Ψ C_w + ∇Ψ·C_w/w` and `g_p = ∂(∇Ψ)/∂p · C_w`;
/// `σ_s = ∂Ψ/∂s = ∇Ψ·C_s` then changes by `∂(∇Ψ)/∂p · C_s + (C_sᵀ ∇²Ψ C_w) dw/dp`.
pub fn uniaxial_sensitivity(
    m: &Material,
    s: f64,
    angle: f64,
) -> Result<UniaxialSensitivity, ShellError> {
    let c = uniaxial_compression(m, s, angle)?;
    let w = 1.0 - c;
    let (sn, cs) = angle.sin_cos();
    let (u, v) = ([cs, sn], [-sn, cs]);
    let dir = |a: [f64; 2], scale: f64| {
        [
            scale * a[0] * a[0],
            scale * a[1] * a[1],
            scale * a[0] * a[1],
        ]
    };
    let c_s = dir(u, 2.0 * (1.0 + s));
    let c_w = dir(v, 2.0 * w);
    let cg = [
        (1.0 + s).powi(2) * u[0] * u[0] + w * w * v[0] * v[0],
        (1.0 + s).powi(2) * u[1] * u[1] + w * w * v[1] * v[1],
        (1.0 + s).powi(2) * u[0] * u[1] + w * w * v[0] * v[1],
    ];
    let e = m.eval_c(cg);
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let quad = |a: &[f64; 3], b: &[f64; 3]| {
        (0..3)
            .map(|i| (0..3).map(|j| a[i] * e.hess[i][j] * b[j]).sum::<f64>())
            .sum::<f64>()
    };
    let sigma = dot(&e.grad, &c_s);
    let g_w = quad(&c_w, &c_w) + dot(&e.grad, &c_w) / w;
    let sigma_w = quad(&c_s, &c_w);
    if !(sigma.is_finite() && g_w.is_finite() && g_w > 0.0) {
        return Err(ShellError::Numerical(format!(
            "uniaxial test at s = {s}: compression c = {c} is not a stable minimum \
             (σ_s = {sigma}, ∂²Ψ/∂w² = {g_w})"
        )));
    }
    let mut out = UniaxialSensitivity {
        point: UniaxialPoint { s, c, sigma },
        compression: [0.0; InPlaneParams::LEN],
        sigma: [0.0; InPlaneParams::LEN],
    };
    for k in 0..InPlaneParams::LEN {
        let d = m.eval_c_dparam(cg, k);
        let dw = -dot(&d, &c_w) / g_w;
        out.compression[k] = -dw;
        out.sigma[k] = dot(&d, &c_s) + sigma_w * dw;
    }
    Ok(out)
}

/// `{κ, σ_κ = 2 k_θ κ}` for the bending stiffness of rest edges along `dir` (Eq. 4 read as a
/// continuum law; `κ` in the hinge metric `3θ/H`, which is 3× the true curvature of an aligned
/// cylinder: see the crate docs, "Hinge curvature normalization").
pub fn bending_curve(b: &BendingParams, dir: Direction, kappas: &[f64]) -> Vec<BendingPoint> {
    let phi = dir.angle();
    let k = b.stiffness(phi.cos(), phi.sin());
    kappas
        .iter()
        .map(|&kappa| BendingPoint {
            kappa,
            sigma: 2.0 * k * kappa,
        })
        .collect()
}

/// Target curves per direction (the output consumed by `sim-periodic`'s yarn fit).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TargetCurves {
    /// Uniaxial `{s, c, σ_s}` per direction name (`weft`, `bias`, `warp`).
    pub stretch: std::collections::BTreeMap<String, Vec<UniaxialPoint>>,
    /// Bending `{κ, σ_κ}` per direction name (empty when no bending parameters are known).
    pub bending: std::collections::BTreeMap<String, Vec<BendingPoint>>,
}

impl TargetCurves {
    /// Uniaxial curves on `n` evenly spaced stretches in `[0, s_max]` per direction, and
    /// bending curves on `n` curvatures in `[0, kappa_max]` (1/m) if `bending` is given.
    pub fn generate(
        m: &Material,
        ranges: &[(Direction, f64)],
        n: usize,
        bending: Option<(&BendingParams, f64)>,
    ) -> Result<Self, ShellError> {
        if n < 2 {
            return Err(ShellError::InvalidInput(
                "need at least 2 samples per curve".into(),
            ));
        }
        let mut out = Self::default();
        for &(dir, s_max) in ranges {
            let s: Vec<f64> = (0..n).map(|i| s_max * i as f64 / (n - 1) as f64).collect();
            out.stretch
                .insert(dir.name().into(), uniaxial_curve(m, dir.angle(), &s)?);
            if let Some((b, kmax)) = bending {
                let k: Vec<f64> = (0..n).map(|i| kmax * i as f64 / (n - 1) as f64).collect();
                out.bending
                    .insert(dir.name().into(), bending_curve(b, dir, &k));
            }
        }
        Ok(out)
    }

    /// CSV with columns `kind,direction,x,c,sigma` (`kind` = `stretch` with `x = s`, or
    /// `bending` with `x = κ` and empty `c`).
    pub fn to_csv(&self) -> String {
        let mut t = CsvTable::new(&["kind", "direction", "x", "c", "sigma"]);
        for (d, pts) in &self.stretch {
            for p in pts {
                t.row([
                    "stretch".into(),
                    d.to_string(),
                    p.s.to_string(),
                    p.c.to_string(),
                    p.sigma.to_string(),
                ]);
            }
        }
        for (d, pts) in &self.bending {
            for p in pts {
                t.row([
                    "bending".into(),
                    d.to_string(),
                    p.kappa.to_string(),
                    String::new(),
                    p.sigma.to_string(),
                ]);
            }
        }
        t.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Model;

    fn coupled() -> InPlaneParams {
        InPlaneParams {
            kxx: 300.0,
            kxy: 250.0,
            kyy: 300.0,
            kss: 100.0,
            kn1: 50.0,
            kn2: 50.0,
            bx: 0.0,
            by: 0.0,
            cx: 0.0,
            cy: 0.0,
        }
    }

    #[test]
    fn stiffening_model_never_inverts_under_uniaxial_stretch() {
        // Soft transverse direction, strong coupling, the smallest barrier the fit allows:
        // StVK inverts (c = 1) here, the stiffening model must keep J > 0 at every stretch.
        let params = InPlaneParams {
            kxx: 150.0,
            kxy: 40.0,
            kyy: 20.0,
            kss: 30.0,
            kn1: 0.0,
            kn2: crate::fit::STIFFENING_MIN_KN2,
            bx: 3.0,
            by: 2.0,
            cx: 0.0,
            cy: 0.0,
        };
        let stvk = Material::stvk(params);
        let stiff = Material {
            params,
            model: crate::material::Model::Stiffening,
        };
        assert_eq!(uniaxial_compression(&stvk, 2.0, 0.0).unwrap(), 1.0);
        for s in [0.1, 0.5, 1.0, 2.0, 3.0] {
            for angle in [
                0.0,
                std::f64::consts::FRAC_PI_4,
                std::f64::consts::FRAC_PI_2,
            ] {
                let c = uniaxial_compression(&stiff, s, angle).unwrap();
                assert!(c > 0.0 && c < 1.0, "s = {s}, angle {angle}: c = {c}");
            }
        }
    }

    #[test]
    fn zero_orthogonal_stress_at_the_returned_compression() {
        let m = Material::augmented(InPlaneParams::example());
        for dir in Direction::ALL {
            for s in [0.05, 0.3, 1.0] {
                let c = uniaxial_compression(&m, s, dir.angle()).unwrap();
                let (d1, _) = dpsi_dw(&m, s, 1.0 - c, dir.angle());
                let p = m.first_piola(&Material::uniaxial_f(s, c, dir.angle()));
                assert!(d1.abs() <= 1e-9 * p.amax(), "{dir:?} s = {s}: vᵀPv = {d1}");
                assert!(c > 0.0 && c < 1.0);
            }
        }
    }

    #[test]
    fn stvk_inverts_and_the_area_terms_prevent_it() {
        let stvk = Material::stvk(coupled());
        let aug = Material::augmented(coupled());
        let c_stvk = uniaxial_compression(&stvk, 1.0, 0.0).unwrap();
        let c_aug = uniaxial_compression(&aug, 1.0, 0.0).unwrap();
        assert_eq!(c_stvk, 1.0);
        assert!(c_aug < 0.9, "{c_aug}");
    }

    #[test]
    fn stretch_stress_is_the_derivative_of_the_uniaxial_energy() {
        // With c(s) at its minimum, dΨ(s, c(s))/ds = ∂Ψ/∂s = σ_s (envelope theorem).
        let m = Material::augmented(InPlaneParams::example());
        let angle = Direction::Bias.angle();
        let psi = |s: f64| {
            let c = uniaxial_compression(&m, s, angle).unwrap();
            m.energy(&Material::uniaxial_f(s, c, angle))
        };
        let h = 1e-6;
        let fd = (psi(0.4 + h) - psi(0.4 - h)) / (2.0 * h);
        let sigma = uniaxial_curve(&m, angle, &[0.4]).unwrap()[0].sigma;
        assert!((fd - sigma).abs() <= 1e-6 * sigma.abs(), "{fd} vs {sigma}");
    }

    #[test]
    fn uniaxial_sensitivities_match_finite_differences() {
        let params = InPlaneParams {
            bx: 3.0,
            by: 6.0,
            cx: 2.0,
            cy: 4.0,
            ..coupled()
        };
        for model in Model::ALL {
            for d in Direction::ALL {
                for s in [0.05, 0.3] {
                    let m = Material { params, model };
                    let u = uniaxial_sensitivity(&m, s, d.angle()).unwrap();
                    for k in (0..InPlaneParams::LEN).filter(|&k| model.uses(k)) {
                        let at = |delta: f64| {
                            let mut q = params.to_array();
                            q[k] += delta;
                            let m = Material {
                                params: InPlaneParams::from_array(q),
                                model,
                            };
                            let p = uniaxial_curve(&m, d.angle(), &[s]).unwrap()[0];
                            (p.c, p.sigma)
                        };
                        let h = 1e-6 * params.to_array()[k].abs().max(1.0);
                        let ((c1, s1), (c0, s0)) = (at(h), at(-h));
                        let (dc, ds) = ((c1 - c0) / (2.0 * h), (s1 - s0) / (2.0 * h));
                        // Relative to the derivative, or to the value's change under a
                        // relative parameter change (for derivatives near zero).
                        let pk = params.to_array()[k].abs().max(1.0);
                        let tol = |fd: f64, value: f64| 1e-5 * fd.abs() + 1e-7 * value / pk;
                        assert!(
                            (u.compression[k] - dc).abs() <= tol(dc, 1.0),
                            "{model:?} {d:?} s={s} dc/d{}: {} vs FD {dc}",
                            InPlaneParams::NAMES[k],
                            u.compression[k]
                        );
                        assert!(
                            (u.sigma[k] - ds).abs() <= tol(ds, u.point.sigma.abs()),
                            "{model:?} {d:?} s={s} dσ/d{}: {} vs FD {ds}",
                            InPlaneParams::NAMES[k],
                            u.sigma[k]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn curves_and_csv_cover_requested_directions_only() {
        let m = Material::augmented(InPlaneParams::example());
        let b = BendingParams {
            weft: 1e-5,
            bias: 2e-5,
            warp: 3e-5,
        };
        let t = TargetCurves::generate(
            &m,
            &[(Direction::Weft, 0.5), (Direction::Warp, 0.2)],
            5,
            Some((&b, 50.0)),
        )
        .unwrap();
        assert_eq!(t.stretch.len(), 2);
        assert!(!t.stretch.contains_key("bias"));
        assert_eq!(t.stretch["warp"].last().unwrap().s, 0.2);
        let last = t.bending["warp"].last().unwrap();
        assert!((last.sigma - 2.0 * 3e-5 * 50.0).abs() < 1e-15);
        let csv = t.to_csv();
        assert_eq!(csv.lines().count(), 1 + 4 * 5);
        assert!(!csv.contains("NaN"));
    }
}
