//! Triangle meshes and the assembled thin shell as a [`solver::Problem`].

use nalgebra::SVector;
use rod::Stencil;
use solver::{LocalEnergy, Problem, Terms};
use std::collections::HashMap;

use crate::ShellError;
use crate::elements::{BendingParams, GravityNode, Hinge, MembraneTriangle};
use crate::material::Material;

/// A triangle mesh with 2-D rest positions (m).
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    /// Rest positions (m).
    pub rest: Vec<[f64; 2]>,
    /// Counter-clockwise node triples.
    pub triangles: Vec<[usize; 3]>,
}

impl TriMesh {
    /// Rectangle `[0, length] × [0, width]` (m) with `nx × ny` cells, each split into two
    /// triangles with diagonals alternating in a checkerboard (no preferred shear direction).
    /// Node `(i, j)` has index `i + (nx + 1) j`.
    pub fn rectangle(length: f64, width: f64, nx: usize, ny: usize) -> Result<Self, ShellError> {
        if nx == 0 || ny == 0 || !(length > 0.0 && width > 0.0) {
            return Err(ShellError::InvalidInput(format!(
                "rectangle needs positive size and at least one cell, got {length} × {width} m, {nx} × {ny} cells"
            )));
        }
        let id = |i: usize, j: usize| i + (nx + 1) * j;
        let mut rest = Vec::with_capacity((nx + 1) * (ny + 1));
        for j in 0..=ny {
            for i in 0..=nx {
                rest.push([length * i as f64 / nx as f64, width * j as f64 / ny as f64]);
            }
        }
        let mut triangles = Vec::with_capacity(2 * nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if (i + j) % 2 == 0 {
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                } else {
                    triangles.push([a, b, d]);
                    triangles.push([b, c, d]);
                }
            }
        }
        Ok(Self { rest, triangles })
    }

    /// One uniform (1 → 4, edge midpoint) subdivision; existing nodes keep their indices.
    pub fn subdivide(&self) -> Self {
        let mut rest = self.rest.clone();
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut midpoint = |a: usize, b: usize, rest: &mut Vec<[f64; 2]>| {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                let (p, q) = (rest[a], rest[b]);
                rest.push([0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])]);
                rest.len() - 1
            })
        };
        let mut triangles = Vec::with_capacity(4 * self.triangles.len());
        for &[a, b, c] in &self.triangles {
            let ab = midpoint(a, b, &mut rest);
            let bc = midpoint(b, c, &mut rest);
            let ca = midpoint(c, a, &mut rest);
            triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        Self { rest, triangles }
    }

    /// Interior edges as hinges `[x₀, x₁, x₂, x₃]` (edge `x₁ x₂`, see [`Hinge`]).
    pub fn hinges(&self) -> Vec<[usize; 4]> {
        let mut first: HashMap<(usize, usize), usize> = HashMap::new();
        let mut out = Vec::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b, opp) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                if let Some(other) = first.remove(&(b, a)) {
                    // The earlier triangle (b, a, other) is CCW: with x₁ = b, x₂ = a it is
                    // (x₁, x₂, x₀), x₀ = other; this one, (a, b, opp), is (x₂, x₁, x₃).
                    out.push([other, b, a, opp]);
                } else {
                    first.insert((a, b), opp);
                }
            }
        }
        out
    }
}

/// Optional gravity on a 3-D shell: areal density `rho` (kg/m²) and `g` (m/s², along −z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gravity {
    /// Areal mass density (kg/m²).
    pub areal_density: f64,
    /// Gravitational acceleration (m/s²), acting along −z.
    pub g: f64,
}

/// Configuration of a [`Shell`] beyond the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellOptions {
    /// Dimension of node positions: 2 (planar membrane) or 3.
    pub dim: usize,
    /// Edge-hinge bending (3-D only).
    pub bending: Option<BendingParams>,
    /// Gravity (3-D only).
    pub gravity: Option<Gravity>,
}

impl ShellOptions {
    /// Planar membrane (2 DOFs per node), no bending, no gravity.
    pub fn planar() -> Self {
        Self {
            dim: 2,
            bending: None,
            gravity: None,
        }
    }
}

/// A hinge and its coefficients for unit `k_θ,weft`, `k_θ,bias`, `k_θ,warp` (the coefficient
/// is linear in the bending parameters). Every evaluation is the hinge's full hyper-dual
/// evaluation (as before the term container; the cheaper energy and gradient paths of
/// `rod::hyperdual` are a possible speed-up that changes rounding).
#[derive(Clone, Copy, Debug, PartialEq)]
struct UnitHinge {
    hinge: Hinge,
    unit: [f64; 3],
}

impl LocalEnergy for UnitHinge {
    fn n_local(&self) -> usize {
        12
    }
    fn local_energy(&self, q: &[f64]) -> f64 {
        self.hinge.eval(&SVector::from_column_slice(q)).energy
    }
    fn local_eval(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let ev = self.hinge.eval(&SVector::<f64, 12>::from_column_slice(q));
        grad.copy_from_slice(ev.gradient.as_slice());
        if let Some(hs) = hess {
            hs.copy_from_slice(ev.hessian.as_slice());
        }
        ev.energy
    }
}

/// A membrane triangle on `q`: its 3 nodes' `dim` coordinates each.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Membrane {
    triangle: MembraneTriangle,
    dim: usize,
}

impl LocalEnergy for Membrane {
    fn n_local(&self) -> usize {
        3 * self.dim
    }
    fn local_energy(&self, q: &[f64]) -> f64 {
        let mut grad = [0.0; 9];
        self.local_eval(q, &mut grad[..q.len()], None)
    }
    fn local_eval(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        self.triangle.eval_into(self.dim, q, grad, hess)
    }
}

/// Gravity on one node: `W = m g z`, DOF `z`.
impl LocalEnergy for GravityNode {
    fn n_local(&self) -> usize {
        1
    }
    fn local_energy(&self, q: &[f64]) -> f64 {
        self.weight * q[0]
    }
    fn local_eval(&self, q: &[f64], grad: &mut [f64], _: Option<&mut [f64]>) -> f64 {
        grad[0] = self.weight;
        self.weight * q[0]
    }
}

/// The discrete shell energy `E(x) = Σ membrane + Σ hinges + Σ gravity` (J) over node positions
/// `x` (m, `dim` DOFs per node, node-major), stored in a [`solver::Terms`] in that order.
/// Implements [`solver::Problem`].
pub struct Shell {
    dim: usize,
    n_nodes: usize,
    terms: Terms,
}

impl Shell {
    /// Builds the shell. The mesh's rest positions are **material coordinates** (weft = x).
    pub fn new(mesh: &TriMesh, material: Material, opts: ShellOptions) -> Result<Self, ShellError> {
        let dim = opts.dim;
        if dim != 2 && dim != 3 {
            return Err(ShellError::InvalidInput(format!(
                "dimension must be 2 or 3, got {dim}"
            )));
        }
        if dim == 2 && (opts.bending.is_some() || opts.gravity.is_some()) {
            return Err(ShellError::InvalidInput(
                "bending and gravity need a 3-D shell (dim = 3)".into(),
            ));
        }
        let n = mesh.rest.len();
        let mut terms = Terms::new(dim * n);
        let node_dofs = |nodes: &[usize]| -> Vec<usize> {
            nodes
                .iter()
                .flat_map(|&v| (0..dim).map(move |j| dim * v + j))
                .collect()
        };
        for (k, t) in mesh.triangles.iter().enumerate() {
            if t.iter().any(|&v| v >= n) {
                return Err(ShellError::InvalidInput(format!(
                    "triangle {k} references a node ≥ {n}"
                )));
            }
            let triangle =
                MembraneTriangle::new(t.map(|v| mesh.rest[v]), material).ok_or_else(|| {
                    ShellError::InvalidInput(format!("triangle {k} is degenerate or clockwise"))
                })?;
            terms.push(Membrane { triangle, dim }, &node_dofs(t));
        }
        if let Some(b) = opts.bending {
            for h in mesh.hinges() {
                let rest = h.map(|v| mesh.rest[v]);
                let hinge = Hinge::new(rest, &b).ok_or_else(|| {
                    ShellError::InvalidInput(format!("degenerate hinge at nodes {h:?}"))
                })?;
                let unit: [f64; 3] = std::array::from_fn(|j| {
                    Hinge::new(rest, &BendingParams::unit(j)).map_or(0.0, |u| u.coefficient)
                });
                terms.push(UnitHinge { hinge, unit }, &node_dofs(&h));
            }
        }
        if let Some(g) = opts.gravity {
            let mut mass = vec![0.0; n];
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|v| mesh.rest[v]);
                let area =
                    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs();
                for &v in t {
                    mass[v] += g.areal_density * area / 3.0;
                }
            }
            for (v, m) in mass.iter().enumerate() {
                terms.push(GravityNode { weight: m * g.g }, &[dim * v + 2]);
            }
        }
        Ok(Self {
            dim,
            n_nodes: n,
            terms,
        })
    }

    /// DOFs per node (2 or 3).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Replaces the material of every membrane triangle (the mesh and Dm⁻¹ are kept).
    pub fn set_material(&mut self, material: Material) {
        for (_, m) in self.terms.iter_mut_of::<Membrane>() {
            m.triangle.material = material;
        }
    }

    /// Replaces the bending stiffnesses of every hinge (the mesh is kept). No effect on a
    /// shell built without bending.
    pub fn set_bending(&mut self, bending: BendingParams) {
        let p = bending.to_array();
        for (_, h) in self.terms.iter_mut_of::<UnitHinge>() {
            h.hinge.coefficient = (0..3).map(|j| h.unit[j] * p[j]).sum();
        }
    }

    /// `∂g/∂k_j` (length `n_dofs`): the gradient of the hinge energy with the unit bending
    /// parameter `j` (0 weft, 1 bias, 2 warp; see [`BendingParams::unit`]). The hinge energy
    /// is linear in the bending parameters, so this is exact.
    pub fn bending_gradient_unit(&self, x: &[f64], j: usize) -> Vec<f64> {
        let mut g = vec![0.0; x.len()];
        for (k, h) in self.terms.iter_of::<UnitHinge>() {
            let dofs = self.terms.dofs(k);
            let q = SVector::<f64, 12>::from_fn(|l, _| x[dofs[l]]);
            let ev = Hinge {
                coefficient: h.unit[j],
            }
            .eval(&q);
            for (l, &d) in dofs.iter().enumerate() {
                g[d] += ev.gradient[l];
            }
        }
        g
    }

    /// `∂(∂E/∂x)/∂p_k` (length `n_dofs`): the derivative of the membrane gradient by in-plane
    /// parameter `k` (order of [`crate::InPlaneParams::to_array`]), for the adjoint fit.
    pub fn membrane_param_gradient(&self, x: &[f64], k: usize) -> Vec<f64> {
        let mut g = vec![0.0; x.len()];
        let mut local = [0.0; 9];
        for (t, m) in self.terms.iter_of::<Membrane>() {
            let q = self.terms.gather(t, x);
            m.triangle
                .param_gradient_into(self.dim, &q, k, &mut local[..q.len()]);
            for (l, &d) in self.terms.dofs(t).iter().enumerate() {
                g[d] += local[l];
            }
        }
        g
    }

    /// Positions `rest` (m, any 2-D frame) embedded as a DOF vector (z = 0 in 3-D).
    pub fn positions_from_rest(&self, rest: &[[f64; 2]]) -> Vec<f64> {
        let mut x = vec![0.0; self.dim * rest.len()];
        for (v, p) in rest.iter().enumerate() {
            x[self.dim * v] = p[0];
            x[self.dim * v + 1] = p[1];
        }
        x
    }
}

impl Problem for Shell {
    fn n_dofs(&self) -> usize {
        self.terms.n_dofs()
    }

    fn n_stencils(&self) -> usize {
        self.terms.n_stencils()
    }

    fn stencil_dofs(&self, k: usize) -> &[usize] {
        self.terms.stencil_dofs(k)
    }

    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        self.terms.eval_stencil(k, x, grad, hess)
    }

    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        self.terms.stencil_energy(k, x)
    }
}

/// The free-DOF numbering of a Dirichlet mask: `index[d]` is the free index of DOF `d`
/// (`usize::MAX` where fixed), `n` the number of free DOFs.
pub(crate) struct FreeDofs {
    pub index: Vec<usize>,
    pub n: usize,
}

impl FreeDofs {
    pub fn new(fixed: &[bool]) -> Self {
        let mut index = vec![usize::MAX; fixed.len()];
        let mut n = 0;
        for (d, &f) in fixed.iter().enumerate() {
            if !f {
                index[d] = n;
                n += 1;
            }
        }
        Self { index, n }
    }
}

/// The exact (unprojected) Hessian of `shell` at `x`, stencil by stencil: the triplets
/// `(free a, free b, h)` of the free–free block in stencil order, and `fixed_row(a, fb, h)`
/// for every entry of a free column `fb` in a fixed row `a` (for adjoint right-hand sides).
pub(crate) fn free_hessian(
    shell: &Shell,
    x: &[f64],
    free: &FreeDofs,
    mut fixed_row: impl FnMut(usize, usize, f64),
) -> Vec<faer::sparse::Triplet<usize, usize, f64>> {
    let mut triplets = Vec::new();
    let mut grad = [0.0; 12];
    let mut hess = [0.0; 144];
    for k in 0..shell.n_stencils() {
        let dofs = shell.stencil_dofs(k);
        let m = dofs.len();
        grad[..m].fill(0.0);
        hess[..m * m].fill(0.0);
        shell.eval_stencil(k, x, &mut grad[..m], Some(&mut hess[..m * m]));
        for (b, &db) in dofs.iter().enumerate() {
            let fb = free.index[db];
            if fb == usize::MAX {
                continue;
            }
            for (a, &da) in dofs.iter().enumerate() {
                let h = hess[a + m * b];
                let fa = free.index[da];
                if fa != usize::MAX {
                    triplets.push(faer::sparse::Triplet::new(fa, fb, h));
                } else {
                    fixed_row(da, fb, h);
                }
            }
        }
    }
    triplets
}
