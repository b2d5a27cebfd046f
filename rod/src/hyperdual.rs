//! Hyper-dual numbers: exact first and second derivatives by forward-mode differentiation.
//!
//! A hyper-dual number `v + a ε₁ + b ε₂ + ab ε₁ε₂` with `ε₁² = ε₂² = 0` carries, for a
//! function evaluated at `q + ε₁ eᵢ + ε₂ eⱼ`, the value, `∂/∂qᵢ`, `∂/∂qⱼ` and `∂²/∂qᵢ∂qⱼ`
//! exactly (no truncation error; Fike & Alonso 2011). The material-frame terms write their
//! energy once over [`Real`]; hyper-dual passes of that generic energy are the independent
//! reference their closed-form jets ([`crate::jet`]) are tested and benchmarked against.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Arithmetic a generic energy needs; implemented for `f64` and [`HyperDual`].
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Lifts a constant.
    fn cst(x: f64) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// `(sin, cos)`.
    fn sin_cos(self) -> (Self, Self);
    /// Four-quadrant `atan2(self, x)` (rad).
    fn atan2(self, x: Self) -> Self;
    /// The value part (for branch decisions that do not depend on derivatives).
    fn value(self) -> f64;
}

impl Real for f64 {
    fn cst(x: f64) -> Self {
        x
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn sin_cos(self) -> (Self, Self) {
        f64::sin_cos(self)
    }
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    fn value(self) -> f64 {
        self
    }
}

/// `v + a ε₁ + b ε₂ + ab ε₁ε₂`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HyperDual {
    /// Value.
    pub v: f64,
    /// Derivative along the first seed direction.
    pub a: f64,
    /// Derivative along the second seed direction.
    pub b: f64,
    /// Mixed second derivative.
    pub ab: f64,
}

impl HyperDual {
    /// Applies a scalar function with value `f0`, first and second derivative `f1`, `f2`.
    fn chain(self, f0: f64, f1: f64, f2: f64) -> Self {
        Self {
            v: f0,
            a: f1 * self.a,
            b: f1 * self.b,
            ab: f1 * self.ab + f2 * self.a * self.b,
        }
    }
}

impl Add for HyperDual {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            v: self.v + o.v,
            a: self.a + o.a,
            b: self.b + o.b,
            ab: self.ab + o.ab,
        }
    }
}

impl Sub for HyperDual {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self {
            v: self.v - o.v,
            a: self.a - o.a,
            b: self.b - o.b,
            ab: self.ab - o.ab,
        }
    }
}

impl Neg for HyperDual {
    type Output = Self;
    fn neg(self) -> Self {
        Self {
            v: -self.v,
            a: -self.a,
            b: -self.b,
            ab: -self.ab,
        }
    }
}

impl Mul for HyperDual {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self {
            v: self.v * o.v,
            a: self.a * o.v + self.v * o.a,
            b: self.b * o.v + self.v * o.b,
            ab: self.ab * o.v + self.a * o.b + self.b * o.a + self.v * o.ab,
        }
    }
}

impl Div for HyperDual {
    type Output = Self;
    #[allow(clippy::suspicious_arithmetic_impl)]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.v;
        self * o.chain(inv, -inv * inv, 2.0 * inv * inv * inv)
    }
}

impl Real for HyperDual {
    fn cst(x: f64) -> Self {
        Self {
            v: x,
            a: 0.0,
            b: 0.0,
            ab: 0.0,
        }
    }
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, 0.5 / r, -0.25 / (r * self.v))
    }
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        (self.chain(s, c, -s), self.chain(c, -s, -c))
    }
    fn atan2(self, x: Self) -> Self {
        let [fy, fx, fyy, fxx, fxy] = atan2_partials(self.v, x.v);
        Self {
            v: self.v.atan2(x.v),
            a: fy * self.a + fx * x.a,
            b: fy * self.b + fx * x.b,
            ab: fy * self.ab
                + fx * x.ab
                + fyy * self.a * self.b
                + fxy * (self.a * x.b + x.a * self.b)
                + fxx * x.a * x.b,
        }
    }
    fn value(self) -> f64 {
        self.v
    }
}

/// First and second partial derivatives of `f(y, x) = atan2(y, x)`:
/// `[f_y, f_x, f_yy, f_xx, f_xy] = [x/r², −y/r², −2xy/r⁴, 2xy/r⁴, (y² − x²)/r⁴]`, `r² = x² + y²`.
pub(crate) fn atan2_partials(y: f64, x: f64) -> [f64; 5] {
    let r2 = y * y + x * x;
    let r4 = r2 * r2;
    [
        x / r2,
        -y / r2,
        -2.0 * x * y / r4,
        2.0 * x * y / r4,
        (y * y - x * x) / r4,
    ]
}

/// A 3-vector over a [`Real`] scalar (just what generic stencils need).
#[derive(Clone, Copy, Debug)]
pub struct Vec3<T>(pub [T; 3]);

impl<T: Real> Vec3<T> {
    /// Lifts a constant f64 vector.
    pub fn cst(v: &nalgebra::Vector3<f64>) -> Self {
        Self([T::cst(v.x), T::cst(v.y), T::cst(v.z)])
    }
    /// Dot product.
    pub fn dot(&self, o: &Self) -> T {
        self.0[0] * o.0[0] + self.0[1] * o.0[1] + self.0[2] * o.0[2]
    }
    /// Cross product.
    pub fn cross(&self, o: &Self) -> Self {
        let (a, b) = (&self.0, &o.0);
        Self([
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ])
    }
    /// Euclidean norm.
    pub fn norm(&self) -> T {
        self.dot(self).sqrt()
    }
    /// Scaled by `s`.
    pub fn scale(&self, s: T) -> Self {
        Self(self.0.map(|x| x * s))
    }
}

impl<T: Real> Add for Vec3<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}

impl<T: Real> Sub for Vec3<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}

/// An energy written once over any [`Real`] scalar: the blanket [`crate::Stencil`] impl
/// evaluates it with `f64` for the energy and with hyper-duals for exact derivatives.
pub trait GenericEnergy<const N: usize> {
    /// The energy (J) at `q`.
    fn energy_generic<T: Real>(&self, q: &[T; N]) -> T;
}

impl<const N: usize, S: GenericEnergy<N>> crate::Stencil<N> for S {
    fn energy(&self, q: &nalgebra::SVector<f64, N>) -> f64 {
        self.energy_generic(&std::array::from_fn(|k| q[k]))
    }

    fn eval(&self, q: &nalgebra::SVector<f64, N>) -> crate::Evaluation<N> {
        let (energy, gradient, hessian) = gradient_and_hessian(q, |x| self.energy_generic(x));
        crate::Evaluation {
            energy,
            gradient,
            hessian,
        }
    }

    fn energy_and_gradient(
        &self,
        q: &nalgebra::SVector<f64, N>,
    ) -> (f64, nalgebra::SVector<f64, N>) {
        gradient(q, |x| self.energy_generic(x))
    }
}

/// Gradient of `f` at `q` by dual evaluation, one pass per DOF (`N` passes instead of the
/// `N (N + 1) / 2` of [`gradient_and_hessian`]).
pub fn gradient<const N: usize>(
    q: &nalgebra::SVector<f64, N>,
    f: impl Fn(&[HyperDual; N]) -> HyperDual,
) -> (f64, nalgebra::SVector<f64, N>) {
    let mut g = nalgebra::SVector::<f64, N>::zeros();
    let mut value = 0.0;
    for i in 0..N {
        let x: [HyperDual; N] = std::array::from_fn(|k| HyperDual {
            v: q[k],
            a: if k == i { 1.0 } else { 0.0 },
            b: 0.0,
            ab: 0.0,
        });
        let r = f(&x);
        value = r.v;
        g[i] = r.a;
    }
    (value, g)
}

/// Gradient and Hessian of `f` at `q` by hyper-dual evaluation, one pass per pair `i ≤ j`.
pub fn gradient_and_hessian<const N: usize>(
    q: &nalgebra::SVector<f64, N>,
    f: impl Fn(&[HyperDual; N]) -> HyperDual,
) -> (f64, nalgebra::SVector<f64, N>, nalgebra::SMatrix<f64, N, N>) {
    let mut g = nalgebra::SVector::<f64, N>::zeros();
    let mut h = nalgebra::SMatrix::<f64, N, N>::zeros();
    let mut value = 0.0;
    for i in 0..N {
        for j in i..N {
            let x: [HyperDual; N] = std::array::from_fn(|k| HyperDual {
                v: q[k],
                a: if k == i { 1.0 } else { 0.0 },
                b: if k == j { 1.0 } else { 0.0 },
                ab: 0.0,
            });
            let r = f(&x);
            value = r.v;
            if j == i {
                g[i] = r.a;
            }
            h[(i, j)] = r.ab;
            h[(j, i)] = r.ab;
        }
    }
    (value, g, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_known_function_are_exact() {
        // f(x, y) = sin(x) y / sqrt(x² + y²)
        let f = |x: &[HyperDual; 2]| {
            let (s, _) = x[0].sin_cos();
            s * x[1] / (x[0] * x[0] + x[1] * x[1]).sqrt()
        };
        let q = nalgebra::Vector2::new(0.7, -1.3);
        let (v, g, h) = gradient_and_hessian(&q, f);
        let (x, y) = (q[0], q[1]);
        let r = (x * x + y * y).sqrt();
        assert!((v - x.sin() * y / r).abs() < 1e-15);
        let fx = x.cos() * y / r - x.sin() * y * x / r.powi(3);
        let fy = x.sin() / r - x.sin() * y * y / r.powi(3);
        assert!((g[0] - fx).abs() < 1e-14 && (g[1] - fy).abs() < 1e-14);
        // Mixed derivative by hand: ∂/∂y of fx.
        let fxy = x.cos() / r - x.cos() * y * y / r.powi(3) - x.sin() * x / r.powi(3)
            + 3.0 * x.sin() * x * y * y / r.powi(5);
        assert!((h[(0, 1)] - fxy).abs() < 1e-14 && h[(1, 0)] == h[(0, 1)]);
    }

    #[test]
    fn atan2_derivatives_match_finite_differences() {
        let f = |x: &[HyperDual; 2]| x[0].atan2(x[1]) * x[0];
        for q in [
            nalgebra::Vector2::new(0.3, -1.2),
            nalgebra::Vector2::new(-0.7, 0.2),
        ] {
            let (_, g, h) = gradient_and_hessian(&q, f);
            let fv = |y: f64, x: f64| y.atan2(x) * y;
            let e = 1e-5;
            let gy = (fv(q[0] + e, q[1]) - fv(q[0] - e, q[1])) / (2.0 * e);
            let gx = (fv(q[0], q[1] + e) - fv(q[0], q[1] - e)) / (2.0 * e);
            assert!((g[0] - gy).abs() < 1e-8 && (g[1] - gx).abs() < 1e-8);
            let hxy = (fv(q[0] + e, q[1] + e) - fv(q[0] + e, q[1] - e) - fv(q[0] - e, q[1] + e)
                + fv(q[0] - e, q[1] - e))
                / (4.0 * e * e);
            assert!((h[(0, 1)] - hxy).abs() < 1e-5, "{} vs {hxy}", h[(0, 1)]);
        }
    }
}
