//! Coarse (homogenized) in-plane deformation of a periodic tile.
//!
//! The coarse map is `x̄(X) = F X` with a 3 × 3 `F = [[F₂, 0], [0, 1]]` acting on the tile
//! plane (material x = weft, y = warp) and leaving the height unchanged. It is built either from
//! the strains of seed 004 Eq. 4 — `sx = √I₁₁ − 1`, `sa = I₁₂/√(I₁₁ I₂₂)`, `sy = √I₂₂ − 1`, with
//! `I = F₂ᵀF₂` the first fundamental form and `F₂ = √I` its principal square root — or from a
//! uniaxial stretch `s` with orthogonal compression `c` along a direction (seed 002 §7.1,
//! physics notes): `F₂ = (1 + s) u uᵀ + (1 − c) v vᵀ`.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

pub use yarn_pattern::strain::{Strain, sqrt_spd2};

/// Single curvature of the coarse surface (seed 004 Appendix A for one non-zero principal
/// curvature): after the in-plane map `y = F₃ X`, the plane is rolled onto a cylinder whose
/// axis is perpendicular to the deformed `axis` direction, with the centre of curvature on the
/// `+z` side. In that deformed frame `I` is unchanged and `II = κ e_a e_aᵀ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature {
    /// 0: curved along (deformed) x, 1: along y.
    pub axis: usize,
    /// Curvature κ (1/m); positive bends the `+z` face inward.
    pub kappa: f64,
}

/// A coarse deformation: in-plane `F₂` and an optional single curvature.
///
/// The coarse map of a material point `Y` (rest position, m) is `x̄(Y) = φ(F₃ Y)` with `φ` the
/// identity (flat) or the roll onto the cylinder of [`Curvature`]: for `axis = 0`, with
/// `(a, b, z) = F₃ Y`,
///
/// ```text
/// φ(a, b, z) = ((1/κ − z) sin κa,  b,  1/κ − (1/κ − z) cos κa),
/// ```
///
/// i.e. the mid-surface point of arc length `a` plus `z` along its normal `n = (−sin κa, 0,
/// cos κa)`. Fluctuations are expressed in the local frame `R(a) = [t, e_b, n]` of the point,
/// so a periodic fluctuation rolls with the surface ([`Coarse::frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coarse {
    /// `F₂` (unitless), acting on material (x, y).
    pub f: Matrix2<f64>,
    /// Optional single curvature (bending).
    pub curvature: Option<Curvature>,
}

impl Coarse {
    /// No deformation.
    pub fn identity() -> Self {
        Self::in_plane(Matrix2::identity())
    }

    /// The flat coarse deformation with in-plane gradient `f`.
    pub fn in_plane(f: Matrix2<f64>) -> Self {
        Self { f, curvature: None }
    }

    /// The same deformation bent with curvature `kappa` (1/m) along `axis` (0 = x, 1 = y).
    pub fn bent(self, axis: usize, kappa: f64) -> Self {
        Self {
            curvature: Some(Curvature { axis, kappa }),
            ..self
        }
    }

    /// `F₂ = √I` from seed 004 strains (symmetric: no rigid rotation).
    pub fn from_strain(s: &Strain) -> Self {
        Self::in_plane(sqrt_spd2(&s.first_fundamental_form()))
    }

    /// The active curvature: `None` when flat or `κ = 0`.
    fn roll(&self) -> Option<(usize, f64)> {
        self.curvature
            .filter(|c| c.kappa != 0.0)
            .map(|c| (c.axis.min(1), c.kappa))
    }

    /// The coarse map `x̄(Y)` of a rest point `Y` (m).
    pub fn map(&self, y: &Vector3<f64>) -> Vector3<f64> {
        let p = self.f3() * y;
        match self.roll() {
            None => p,
            Some((axis, k)) => {
                let (a, b) = (p[axis], p[1 - axis]);
                let (sin, cos) = (k * a).sin_cos();
                let r = 1.0 / k - p.z;
                let mut out = Vector3::new(0.0, 0.0, 1.0 / k - r * cos);
                out[axis] = r * sin;
                out[1 - axis] = b;
                out
            }
        }
    }

    /// The local frame `R` (orthonormal columns: tangent along the curved axis, the straight
    /// axis, the normal) at rest point `Y`; the identity when flat.
    pub fn frame(&self, y: &Vector3<f64>) -> Matrix3<f64> {
        match self.roll() {
            None => Matrix3::identity(),
            Some((axis, k)) => {
                let a = (self.f3() * y)[axis];
                let (sin, cos) = (k * a).sin_cos();
                let mut m = Matrix3::zeros();
                m[(axis, axis)] = cos;
                m[(2, axis)] = sin;
                m[(1 - axis, 1 - axis)] = 1.0;
                m[(axis, 2)] = -sin;
                m[(2, 2)] = cos;
                m
            }
        }
    }

    /// Jacobian `∂/∂p [φ(p) + R(p) u]` at `p = F₃ Y` (used to gather the in-plane stress of a
    /// bent tile); the identity when flat.
    pub fn map_jacobian(&self, y: &Vector3<f64>, u: &Vector3<f64>) -> Matrix3<f64> {
        match self.roll() {
            None => Matrix3::identity(),
            Some((axis, k)) => {
                let p = self.f3() * y;
                let (sin, cos) = (k * p[axis]).sin_cos();
                let mut j = Matrix3::zeros();
                // ∂φ/∂a, ∂φ/∂b, ∂φ/∂z.
                j[(axis, axis)] = cos * (1.0 - k * p.z);
                j[(2, axis)] = sin * (1.0 - k * p.z);
                j[(1 - axis, 1 - axis)] = 1.0;
                j[(axis, 2)] = -sin;
                j[(2, 2)] = cos;
                // ∂(R u)/∂a = R'(a) u.
                let ua = u[axis];
                let uz = u.z;
                j[(axis, axis)] += k * (-sin * ua - cos * uz);
                j[(2, axis)] += k * (cos * ua - sin * uz);
                j
            }
        }
    }

    /// Uniaxial stretch `s` along the unit direction at angle `angle` (rad, from material x)
    /// with orthogonal compression `c`: `F₂ = (1 + s) u uᵀ + (1 − c) v vᵀ`.
    pub fn uniaxial(s: f64, c: f64, angle: f64) -> Self {
        let u = Vector2::new(angle.cos(), angle.sin());
        let v = Vector2::new(-u.y, u.x);
        Self::in_plane((1.0 + s) * u * u.transpose() + (1.0 - c) * v * v.transpose())
    }

    /// The 3 × 3 map `[[F₂, 0], [0, 1]]`.
    pub fn f3(&self) -> Matrix3<f64> {
        let mut m = Matrix3::identity();
        m.fixed_view_mut::<2, 2>(0, 0).copy_from(&self.f);
        m
    }

    /// Seed 004 strains of this deformation.
    pub fn strain(&self) -> Strain {
        Strain::from_first_fundamental_form(&(self.f.transpose() * self.f))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strain_round_trips_through_the_square_root() {
        for s in [
            Strain {
                sx: 0.3,
                sa: 0.2,
                sy: -0.1,
            },
            Strain {
                sx: -0.2,
                sa: -0.7,
                sy: 1.0,
            },
            Strain::ZERO,
        ] {
            let c = Coarse::from_strain(&s);
            assert!((c.f - c.f.transpose()).norm() < 1e-15);
            let back = c.strain();
            assert!((back.sx - s.sx).abs() < 1e-13);
            assert!((back.sa - s.sa).abs() < 1e-13);
            assert!((back.sy - s.sy).abs() < 1e-13);
        }
        assert!(
            Strain {
                sx: 0.0,
                sa: 1.0,
                sy: 0.0
            }
            .validated()
            .is_none()
        );
        assert!(
            Strain {
                sx: -1.0,
                sa: 0.0,
                sy: 0.0
            }
            .validated()
            .is_none()
        );
    }

    #[test]
    fn rolled_map_is_isometric_with_the_stated_frame_and_jacobian() {
        let c = Coarse::from_strain(&Strain {
            sx: 0.1,
            sa: 0.2,
            sy: -0.05,
        })
        .bent(0, 150.0);
        let y = Vector3::new(0.003, -0.002, 0.0007);
        let u = Vector3::new(1e-4, -2e-4, 3e-4);
        // Frame: orthonormal, third column is the normal of the mid-surface (∂φ/∂z).
        let r = c.frame(&y);
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-14);
        // Jacobian against central differences in p = F₃ Y.
        let f3 = c.f3();
        let finv = f3.try_inverse().unwrap();
        let g = |p: &Vector3<f64>| {
            let yy = finv * p;
            c.map(&yy) + c.frame(&yy) * u
        };
        let p = f3 * y;
        let j = c.map_jacobian(&y, &u);
        for k in 0..3 {
            let mut e = Vector3::zeros();
            e[k] = 1e-7;
            let fd = (g(&(p + e)) - g(&(p - e))) / 2e-7;
            assert!(
                (fd - j.column(k)).norm() < 1e-7,
                "column {k}: {fd} vs {}",
                j.column(k)
            );
        }
        // Arc length along the curved axis is preserved on the mid-surface (z = 0).
        let flat = Coarse::identity().bent(0, 200.0);
        let a = flat.map(&Vector3::new(0.0, 0.0, 0.0));
        let b = flat.map(&Vector3::new(0.01, 0.0, 0.0));
        let chord = 2.0 / 200.0 * (0.5 * 200.0 * 0.01f64).sin();
        assert!(((b - a).norm() - chord).abs() < 1e-15);
        // Zero curvature is exactly the flat map.
        let zero = Coarse::identity().bent(1, 0.0);
        assert_eq!(zero.map(&y), y);
    }

    #[test]
    fn uniaxial_stretch_along_the_bias() {
        let c = Coarse::uniaxial(0.5, 0.2, std::f64::consts::FRAC_PI_4);
        let u = Vector2::new(1.0, 1.0).normalize();
        assert!(((c.f * u).norm() - 1.5).abs() < 1e-14);
        let v = Vector2::new(-1.0, 1.0).normalize();
        assert!(((c.f * v).norm() - 0.8).abs() < 1e-14);
    }
}
