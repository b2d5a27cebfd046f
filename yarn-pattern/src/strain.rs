//! In-plane strain kinematics of seed 004 Eq. 4: the strains (sx, sa, sy) that index a
//! displacement database, their first fundamental form `I`, and `F₂ = √I`.

use nalgebra::Matrix2;

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
