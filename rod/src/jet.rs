//! Second-order jets: value, gradient and Hessian in `N` variables, carried through one
//! evaluation (dense second-order forward mode).
//!
//! A [`crate::hyperdual::HyperDual`] pass yields one Hessian entry, so an `N`-DOF stencil
//! needs `N (N + 1) / 2` passes (66 for the 11-DOF material-frame terms), each re-evaluating
//! every square root, sine and division. A jet carries the whole gradient and Hessian through
//! a single pass instead. Its cost per operation grows with `N²`, so the material-frame terms
//! evaluate each piece in the variables it actually depends on — a transported frame in its
//! edge and twist angle (`Jet<4>`), the curvature binormal in the two edges (`Jet<6>`) — and
//! [`Jet::embed`] the pieces into the stencil's reduced variables only where they combine.
//! That structure, not the arithmetic, is what makes them cheap.

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::hyperdual::{Real, atan2_partials};

/// `f(x₀ + δ) ≈ v + g·δ + ½ δᵀ h δ` in `N` variables; `h` is stored in full and kept
/// symmetric.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jet<const N: usize> {
    /// Value.
    pub v: f64,
    /// Gradient.
    pub g: [f64; N],
    /// Hessian (symmetric).
    pub h: [[f64; N]; N],
}

impl<const N: usize> Jet<N> {
    /// The `i`-th variable, at `value`.
    pub fn var(i: usize, value: f64) -> Self {
        let mut j = Self::cst(value);
        j.g[i] = 1.0;
        j
    }

    /// Hessian entry `(i, j)`.
    pub fn hessian(&self, i: usize, j: usize) -> f64 {
        self.h[i][j]
    }

    /// The same function in `M ≥ N` variables: variable `k` of `self` becomes variable
    /// `map[k]` of the result.
    pub fn embed<const M: usize>(&self, map: [usize; N]) -> Jet<M> {
        let mut out = Jet::<M>::cst(self.v);
        for (a, &ma) in map.iter().enumerate() {
            out.g[ma] = self.g[a];
            for (b, &mb) in map.iter().enumerate() {
                out.h[ma][mb] = self.h[a][b];
            }
        }
        out
    }

    /// Applies a scalar function with value `f0`, first and second derivative `f1`, `f2`.
    fn chain(&self, f0: f64, f1: f64, f2: f64) -> Self {
        let mut out = Self::cst(f0);
        for i in 0..N {
            out.g[i] = f1 * self.g[i];
            for j in 0..N {
                out.h[i][j] = f1 * self.h[i][j] + f2 * self.g[i] * self.g[j];
            }
        }
        out
    }

    /// Multiplies by a constant.
    pub fn scale(&self, s: f64) -> Self {
        let mut out = *self;
        out.v *= s;
        out.g.iter_mut().for_each(|x| *x *= s);
        out.h.iter_mut().flatten().for_each(|x| *x *= s);
        out
    }
}

impl<const N: usize> Add for Jet<N> {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        self.v += o.v;
        for i in 0..N {
            self.g[i] += o.g[i];
            for j in 0..N {
                self.h[i][j] += o.h[i][j];
            }
        }
        self
    }
}

impl<const N: usize> Sub for Jet<N> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        self + (-o)
    }
}

impl<const N: usize> Neg for Jet<N> {
    type Output = Self;
    fn neg(self) -> Self {
        self.scale(-1.0)
    }
}

impl<const N: usize> Mul for Jet<N> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let mut out = Self::cst(self.v * o.v);
        for i in 0..N {
            out.g[i] = self.g[i] * o.v + self.v * o.g[i];
            for j in 0..N {
                out.h[i][j] = self.h[i][j] * o.v
                    + self.v * o.h[i][j]
                    + self.g[i] * o.g[j]
                    + o.g[i] * self.g[j];
            }
        }
        out
    }
}

impl<const N: usize> Div for Jet<N> {
    type Output = Self;
    #[allow(clippy::suspicious_arithmetic_impl)]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.v;
        self * o.chain(inv, -inv * inv, 2.0 * inv * inv * inv)
    }
}

impl<const N: usize> Real for Jet<N> {
    fn cst(x: f64) -> Self {
        Self {
            v: x,
            g: [0.0; N],
            h: [[0.0; N]; N],
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
        let (y, xv) = (self.v, x.v);
        let [fy, fx, fyy, fxx, fxy] = atan2_partials(y, xv);
        let mut out = Self::cst(y.atan2(xv));
        for i in 0..N {
            out.g[i] = fy * self.g[i] + fx * x.g[i];
            for j in 0..N {
                out.h[i][j] = fy * self.h[i][j]
                    + fx * x.h[i][j]
                    + fyy * self.g[i] * self.g[j]
                    + fxy * (self.g[i] * x.g[j] + x.g[i] * self.g[j])
                    + fxx * x.g[i] * x.g[j];
            }
        }
        out
    }
    fn value(self) -> f64 {
        self.v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hyperdual::gradient_and_hessian;

    /// A function using every operation, over any [`Real`].
    fn f<T: Real>(x: &[T; 3]) -> T {
        let (s, c) = (x[0] * x[1]).sin_cos();
        let r = (x[0] * x[0] + x[2] * x[2] + T::cst(1.0)).sqrt();
        (s + c * x[2]) / r - x[1].atan2(x[0] - x[2]) + -x[2]
    }

    #[test]
    fn one_jet_pass_equals_the_hyper_dual_hessian() {
        let q = nalgebra::Vector3::new(0.3, -0.7, 1.1);
        let (v, g, h) = gradient_and_hessian(&q, f);
        let jet = f(&std::array::from_fn(|i| Jet::<3>::var(i, q[i])));
        assert!((jet.v - v).abs() < 1e-14);
        for i in 0..3 {
            assert!((jet.g[i] - g[i]).abs() < 1e-13, "g[{i}]");
            for j in 0..3 {
                assert!((jet.h[i][j] - h[(i, j)]).abs() < 1e-12, "h[{i}][{j}]");
                assert_eq!(jet.h[i][j], jet.h[j][i]);
            }
        }
    }

    #[test]
    fn embedding_moves_variables_and_keeps_derivatives() {
        let q = [0.3, -0.7, 1.1];
        let small = f(&std::array::from_fn(|i| Jet::<3>::var(i, q[i])));
        let map = [4, 0, 2];
        let big = f(&std::array::from_fn(|i| Jet::<5>::var(map[i], q[i])));
        assert_eq!(small.embed::<5>(map), big);
    }
}
