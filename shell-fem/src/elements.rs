//! Per-stencil energies of the shell: constant-strain membrane triangles, edge-hinge bending
//! (seed 002, §5.2, Eq. 4) and gravity. Each knows nothing about the global system; the
//! [`crate::shell::Shell`] scatters them through the `solver` crate.

use nalgebra::SVector;
use rod::hyperdual::{GenericEnergy, Real, Vec3};
use rod::{Evaluation, Stencil};
use serde::{Deserialize, Serialize};

use crate::material::Material;

/// A constant-strain triangle with a 2-D rest shape in material coordinates (m) and deformed
/// node positions in `R` dimensions (`R = 2`: planar membrane, DOFs `(x₀, y₀, x₁, …)`; `R = 3`:
/// membrane of a 3-D shell). Energy `W = A Ψ(F)` (J) with `F = Σ_i x_i ⊗ ∇N_i`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MembraneTriangle {
    /// Gradients `∇N_i` (1/m) of the three linear shape functions in material coordinates.
    pub shape_gradients: [[f64; 2]; 3],
    /// Rest area `A` (m²).
    pub area: f64,
    /// The material law.
    pub material: Material,
}

impl MembraneTriangle {
    /// From rest positions in material coordinates (m); `None` for a degenerate triangle or
    /// one with clockwise orientation.
    pub fn new(rest: [[f64; 2]; 3], material: Material) -> Option<Self> {
        let e1 = [rest[1][0] - rest[0][0], rest[1][1] - rest[0][1]];
        let e2 = [rest[2][0] - rest[0][0], rest[2][1] - rest[0][1]];
        let det = e1[0] * e2[1] - e1[1] * e2[0];
        let scale = (e1[0].hypot(e1[1]) * e2[0].hypot(e2[1])).max(f64::MIN_POSITIVE);
        // Reject slivers whose area is at rounding level relative to their edge lengths.
        if det.is_nan() || det <= 1e-12 * scale {
            return None;
        }
        // Dm⁻¹ for Dm = [e1 e2] (columns); ∇N₁, ∇N₂ are its rows, ∇N₀ = −∇N₁ − ∇N₂.
        let inv = [[e2[1] / det, -e2[0] / det], [-e1[1] / det, e1[0] / det]];
        let g1 = inv[0];
        let g2 = inv[1];
        Some(Self {
            shape_gradients: [[-g1[0] - g2[0], -g1[1] - g2[1]], g1, g2],
            area: 0.5 * det,
            material,
        })
    }

    /// `c = (C₁₁, C₂₂, C₁₂)` of the triangle's `F = Σ_i x_i ⊗ ∇N_i` and its Jacobian by the
    /// local DOFs (`3 dim` columns used): `∂c₁₁ = 2∇N_i[0] f₀`, `∂c₂₂ = 2∇N_i[1] f₁`,
    /// `∂c₁₂ = ∇N_i[0] f₁ + ∇N_i[1] f₀`.
    fn kinematics(&self, dim: usize, x: &[f64]) -> ([f64; 3], [[f64; 9]; 3]) {
        let d = &self.shape_gradients;
        // Columns f_a = Σ_i ∇N_i[a] x_i.
        let mut f = [[0.0; 3]; 2];
        for a in 0..2 {
            for i in 0..3 {
                for j in 0..dim {
                    f[a][j] += d[i][a] * x[dim * i + j];
                }
            }
        }
        let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        let c = [dot(&f[0], &f[0]), dot(&f[1], &f[1]), dot(&f[0], &f[1])];
        let mut jc = [[0.0; 9]; 3];
        for i in 0..3 {
            for j in 0..dim {
                let k = dim * i + j;
                jc[0][k] = 2.0 * d[i][0] * f[0][j];
                jc[1][k] = 2.0 * d[i][1] * f[1][j];
                jc[2][k] = d[i][0] * f[1][j] + d[i][1] * f[0][j];
            }
        }
        (c, jc)
    }

    /// `∂(∂W/∂x)/∂p_k` (J/m per unit parameter) at node positions `x` of dimension `dim`: the
    /// parameter derivative of the element gradient ([`Material::eval_c_dparam`]), written
    /// into `grad` (`3 dim` entries).
    pub fn param_gradient_into(&self, dim: usize, x: &[f64], k: usize, grad: &mut [f64]) {
        let (c, jc) = self.kinematics(dim, x);
        let dg = self.material.eval_c_dparam(c, k);
        for (l, g) in grad.iter_mut().enumerate().take(3 * dim) {
            *g = self.area * (0..3).map(|m| dg[m] * jc[m][l]).sum::<f64>();
        }
    }

    /// Energy (J), gradient and (optionally) column-major Hessian for node positions `x` of
    /// dimension `dim` (`x.len() == 3 dim`); `grad`/`hess` are overwritten.
    pub fn eval_into(
        &self,
        dim: usize,
        x: &[f64],
        grad: &mut [f64],
        hess: Option<&mut [f64]>,
    ) -> f64 {
        let n = 3 * dim;
        debug_assert!(x.len() == n && grad.len() == n);
        let d = &self.shape_gradients;
        let (c, jc) = self.kinematics(dim, x);
        let e = self.material.eval_c(c);
        let a = self.area;
        for k in 0..n {
            grad[k] = a * (0..3).map(|m| e.grad[m] * jc[m][k]).sum::<f64>();
        }
        if let Some(h) = hess {
            // H = A [Jcᵀ Ψ_cc Jc + Σ_m Ψ_c[m] ∂²c_m].
            let mut hj = [[0.0; 9]; 3];
            for m in 0..3 {
                for k in 0..n {
                    hj[m][k] = (0..3).map(|l| e.hess[m][l] * jc[l][k]).sum();
                }
            }
            for col in 0..n {
                for row in 0..n {
                    h[row + n * col] = a * (0..3).map(|m| jc[m][row] * hj[m][col]).sum::<f64>();
                }
            }
            for i in 0..3 {
                for k in 0..3 {
                    let w = 2.0 * e.grad[0] * d[i][0] * d[k][0]
                        + 2.0 * e.grad[1] * d[i][1] * d[k][1]
                        + e.grad[2] * (d[i][0] * d[k][1] + d[i][1] * d[k][0]);
                    for j in 0..dim {
                        h[(dim * i + j) + n * (dim * k + j)] += a * w;
                    }
                }
            }
        }
        a * e.psi
    }
}

fn eval_fixed<const N: usize>(t: &MembraneTriangle, q: &SVector<f64, N>) -> Evaluation<N> {
    let mut ev = Evaluation::<N>::zero();
    let mut h = vec![0.0; N * N];
    ev.energy = t.eval_into(
        N / 3,
        q.as_slice(),
        ev.gradient.as_mut_slice(),
        Some(&mut h),
    );
    ev.hessian.as_mut_slice().copy_from_slice(&h);
    ev
}

/// Planar membrane: `q = (x₀, y₀, x₁, y₁, x₂, y₂)` (m).
impl Stencil<6> for MembraneTriangle {
    fn energy(&self, q: &SVector<f64, 6>) -> f64 {
        self.eval_into(2, q.as_slice(), &mut [0.0; 6], None)
    }
    fn eval(&self, q: &SVector<f64, 6>) -> Evaluation<6> {
        eval_fixed(self, q)
    }
}

/// 3-D membrane: `q = (x₀, x₁, x₂)` with `x_i ∈ ℝ³` (m).
impl Stencil<9> for MembraneTriangle {
    fn energy(&self, q: &SVector<f64, 9>) -> f64 {
        self.eval_into(3, q.as_slice(), &mut [0.0; 9], None)
    }
    fn eval(&self, q: &SVector<f64, 9>) -> Evaluation<9> {
        eval_fixed(self, q)
    }
}

/// Bending stiffnesses `k_bending = {k_θ,weft, k_θ,bias, k_θ,warp}` (J = N·m: `Ψ_b = k_θ κ²` is
/// an energy per area with `κ` in 1/m), seed 002 §5.2.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BendingParams {
    /// `k_θ` for rest edges along the weft (material x) (N·m).
    pub weft: f64,
    /// `k_θ` for rest edges at 45° (N·m).
    pub bias: f64,
    /// `k_θ` for rest edges along the warp (material y) (N·m).
    pub warp: f64,
}

impl BendingParams {
    /// `[weft, bias, warp]` (N·m).
    pub fn to_array(&self) -> [f64; 3] {
        [self.weft, self.bias, self.warp]
    }

    /// From `[weft, bias, warp]` (N·m).
    pub fn from_array(p: [f64; 3]) -> Self {
        Self {
            weft: p[0],
            bias: p[1],
            warp: p[2],
        }
    }

    /// The unit parameter vector `e_j` (`j` = 0 weft, 1 bias, 2 warp). Panics for `j > 2`.
    pub fn unit(j: usize) -> Self {
        assert!(j < 3, "bending parameter index {j} out of range");
        let mut p = [0.0; 3];
        p[j] = 1.0;
        Self::from_array(p)
    }

    /// `k_θ` of a rest edge with material-space direction `(ex, ey)`: linear interpolation in
    /// the edge angle `φ = atan2(|ey|, |ex|) ∈ [0, π/2]` between weft (0), bias (π/4) and warp
    /// (π/2). Edge directions are unsigned and mirror-symmetric about the material axes.
    pub fn stiffness(&self, ex: f64, ey: f64) -> f64 {
        let phi = ey.abs().atan2(ex.abs());
        let t = phi / std::f64::consts::FRAC_PI_4;
        if t <= 1.0 {
            self.weft + (self.bias - self.weft) * t
        } else {
            self.bias + (self.warp - self.bias) * (t - 1.0)
        }
    }
}

/// Edge-hinge bending (Eq. 4): `κ = 3θ/H`, `W = k_θ κ² (A₁ + A₂)` with rest areas `A₁, A₂`
/// and rest mean altitude `H = (h₁ + h₂)/2`, `h_i = 2A_i/|ē|`. Flat rest shape (θ̄ = 0).
///
/// DOFs `q = (x₀, x₁, x₂, x₃)` ∈ ℝ¹²: the hinge edge is `x₁ x₂`; triangle `(x₁, x₂, x₀)` and
/// triangle `(x₂, x₁, x₃)` are counter-clockwise. The signed angle is
/// `θ = atan2((n₁ × n₂)·ê, n₁·n₂)`. Derivatives come from hyper-dual numbers
/// (`rod::hyperdual`), since the closed-form Hessian of the dihedral angle is long and
/// error-prone; the energy is `coefficient · θ²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hinge {
    /// `9 k_θ (A₁ + A₂) / H²` (J/rad²).
    pub coefficient: f64,
}

impl Hinge {
    /// From rest positions of the four nodes in material coordinates (m).
    pub fn new(rest: [[f64; 2]; 4], bending: &BendingParams) -> Option<Self> {
        let area = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
        };
        let a1 = area(rest[1], rest[2], rest[0]);
        let a2 = area(rest[2], rest[1], rest[3]);
        let (ex, ey) = (rest[2][0] - rest[1][0], rest[2][1] - rest[1][1]);
        let len = ex.hypot(ey);
        if !(a1 > 0.0 && a2 > 0.0 && len > 0.0) {
            return None;
        }
        let h = (a1 + a2) / len; // (2A₁/|e| + 2A₂/|e|)/2
        let k = bending.stiffness(ex, ey);
        Some(Self {
            coefficient: 9.0 * k * (a1 + a2) / (h * h),
        })
    }

    /// Signed dihedral angle θ (rad) of the configuration `q`.
    pub fn angle(q: &[f64; 12]) -> f64 {
        dihedral(q)
    }
}

fn dihedral<T: Real>(q: &[T; 12]) -> T {
    let p = |i: usize| Vec3([q[3 * i], q[3 * i + 1], q[3 * i + 2]]);
    let (x0, x1, x2, x3) = (p(0), p(1), p(2), p(3));
    let e = x2 - x1;
    let n1 = e.cross(&(x0 - x1));
    let n2 = (x1 - x2).cross(&(x3 - x2));
    let sin = n1.cross(&n2).dot(&e) / e.norm();
    sin.atan2(n1.dot(&n2))
}

impl GenericEnergy<12> for Hinge {
    fn energy_generic<T: Real>(&self, q: &[T; 12]) -> T {
        let theta = dihedral(q);
        T::cst(self.coefficient) * theta * theta
    }
}

/// Gravity on one node: `W = m g z` (J) with lumped mass `m` (kg) and `g` (m/s²); DOF `z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GravityNode {
    /// `m g` (N).
    pub weight: f64,
}
