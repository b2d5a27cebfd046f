//! Coarse (homogenized) in-plane deformation of a periodic tile.
//!
//! The coarse map is `x̄(X) = F X` with a 3 × 3 `F = [[F₂, 0], [0, 1]]` acting on the tile
//! plane (material x = weft, y = warp) and leaving the height unchanged. It is built either from
//! the strains of seed 004 Eq. 4 — `sx = √I₁₁ − 1`, `sa = I₁₂/√(I₁₁ I₂₂)`, `sy = √I₂₂ − 1`, with
//! `I = F₂ᵀF₂` the first fundamental form and `F₂ = √I` its principal square root — or from a
//! uniaxial stretch `s` with orthogonal compression `c` along a direction (seed 002 §7.1,
//! physics notes): `F₂ = (1 + s) u uᵀ + (1 − c) v vᵀ`.

use nalgebra::{Matrix2, Matrix3, Vector2};

/// In-plane strains of seed 004 Eq. 4 (unitless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strain {
    /// Stretch along x: `√I₁₁ − 1` (> −1).
    pub sx: f64,
    /// Shear: `I₁₂ / √(I₁₁ I₂₂)` (in (−1, 1), the cosine of the deformed angle between axes).
    pub sa: f64,
    /// Stretch along y: `√I₂₂ − 1` (> −1).
    pub sy: f64,
}

impl Strain {
    /// The undeformed state.
    pub const ZERO: Strain = Strain {
        sx: 0.0,
        sa: 0.0,
        sy: 0.0,
    };

    /// First fundamental form `I` (unitless, SPD when the strain is admissible).
    pub fn first_fundamental_form(&self) -> Matrix2<f64> {
        let (a, b) = (1.0 + self.sx, 1.0 + self.sy);
        Matrix2::new(a * a, self.sa * a * b, self.sa * a * b, b * b)
    }

    /// `None` unless `sx, sy > −1` and `|sa| < 1` (finite), i.e. `I` is SPD.
    pub fn validated(self) -> Option<Self> {
        let ok = self.sx.is_finite()
            && self.sy.is_finite()
            && self.sa.is_finite()
            && self.sx > -1.0
            && self.sy > -1.0
            && self.sa.abs() < 1.0;
        ok.then_some(self)
    }

    /// Strain of a first fundamental form (inverse of [`Self::first_fundamental_form`]).
    pub fn from_first_fundamental_form(i: &Matrix2<f64>) -> Self {
        let (a, b) = (i[(0, 0)].sqrt(), i[(1, 1)].sqrt());
        Self {
            sx: a - 1.0,
            sa: i[(0, 1)] / (a * b),
            sy: b - 1.0,
        }
    }
}

/// Principal square root of a 2 × 2 SPD matrix: `√A = (A + √det A · Id) / √(tr A + 2√det A)`.
pub fn sqrt_spd2(a: &Matrix2<f64>) -> Matrix2<f64> {
    let s = a.determinant().sqrt();
    let t = (a.trace() + 2.0 * s).sqrt();
    (a + Matrix2::identity() * s) / t
}

/// The in-plane deformation gradient `F₂` of a coarse deformation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coarse {
    /// `F₂` (unitless), acting on material (x, y).
    pub f: Matrix2<f64>,
}

impl Coarse {
    /// No deformation.
    pub fn identity() -> Self {
        Self {
            f: Matrix2::identity(),
        }
    }

    /// `F₂ = √I` from seed 004 strains (symmetric: no rigid rotation).
    pub fn from_strain(s: &Strain) -> Self {
        Self {
            f: sqrt_spd2(&s.first_fundamental_form()),
        }
    }

    /// Uniaxial stretch `s` along the unit direction at angle `angle` (rad, from material x)
    /// with orthogonal compression `c`: `F₂ = (1 + s) u uᵀ + (1 − c) v vᵀ`.
    pub fn uniaxial(s: f64, c: f64, angle: f64) -> Self {
        let u = Vector2::new(angle.cos(), angle.sin());
        let v = Vector2::new(-u.y, u.x);
        Self {
            f: (1.0 + s) * u * u.transpose() + (1.0 - c) * v * v.transpose(),
        }
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
    fn uniaxial_stretch_along_the_bias() {
        let c = Coarse::uniaxial(0.5, 0.2, std::f64::consts::FRAC_PI_4);
        let u = Vector2::new(1.0, 1.0).normalize();
        assert!(((c.f * u).norm() - 1.5).abs() < 1e-14);
        let v = Vector2::new(-1.0, 1.0).normalize();
        assert!(((c.f * v).norm() - 0.8).abs() < 1e-14);
    }
}
