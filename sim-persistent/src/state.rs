//! Generalized coordinates and the state-dependent segment mass matrix (seed 000 §3.2,
//! after Sueda et al. 2011; physics notes "Sliding (Eulerian) coordinates").
//!
//! The coordinate vector `q` stores, node after node, the node position `x` (3, m) followed
//! by its `n` sliding coordinates `u₁ … uₙ` (m), one per yarn pass in slot order
//! ([`crate::topology::Node::passes`]). A node shared by `n` yarns has `3 + n` DoFs.
//!
//! **Kinematics of a segment.** A segment of one yarn joins passes `0` and `1` with positions
//! `x₀, x₁` and arc-length coordinates `u₀ < u₁`. The material point of arc length `s` sits at
//! `t = (s − u₀)/Δu`, `x(s) = (1 − t) x₀ + t x₁`, and moves with
//! `ẋ(s) = (1 − t)(ẋ₀ − w u̇₀) + t (ẋ₁ − w u̇₁)`, `w = (x₁ − x₀)/Δu`. With linear density ρ the
//! kinetic energy is `T = ρΔu/6 (|a|² + a·b + |b|²)`, `a = ẋ₀ − w u̇₀`, `b = ẋ₁ − w u̇₁`, i.e.
//! `T = ½ q̇ᵀ M q̇` with, in the order `(x₀, u₀, x₁, u₁)`,
//!
//! ```text
//! M = ρΔu/6 · [ 2J  J ; J  2J ],     J = [ I  −w ; −wᵀ  wᵀw ].
//! ```

use crate::layout::Layout;
use crate::topology::{Pass, Topology};
use nalgebra::{SMatrix, SVector};
use rod::geometry::V3;

/// Where each node's coordinates live in `q`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DofMap {
    offsets: Vec<usize>,
    n_dofs: usize,
}

impl DofMap {
    /// The node-major layout of the module documentation.
    pub fn new(topology: &Topology) -> Self {
        let mut offsets = Vec::with_capacity(topology.nodes.len());
        let mut n = 0;
        for node in &topology.nodes {
            offsets.push(n);
            n += 3 + node.passes.len();
        }
        Self { offsets, n_dofs: n }
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.offsets.len()
    }

    /// Total number of DoFs.
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    /// Index of the x component of node `node`'s position (y and z follow).
    pub fn x(&self, node: usize) -> usize {
        self.offsets[node]
    }

    /// Index of the sliding coordinate of `slot` at `node`.
    pub fn u(&self, node: usize, slot: usize) -> usize {
        self.offsets[node] + 3 + slot
    }

    /// The 4 DoFs `(x, u)` of a yarn pass.
    pub fn pass_dofs(&self, pass: Pass) -> [usize; 4] {
        let x = self.x(pass.node);
        [x, x + 1, x + 2, self.u(pass.node, pass.slot)]
    }

    /// The 8 DoFs `(x₀, u₀, x₁, u₁)` of the segment between two passes.
    pub fn segment_dofs(&self, a: Pass, b: Pass) -> [usize; 8] {
        let (p, q) = (self.pass_dofs(a), self.pass_dofs(b));
        [p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3]]
    }

    /// Position of `node` in `q`.
    pub fn position(&self, q: &[f64], node: usize) -> V3 {
        let i = self.x(node);
        V3::new(q[i], q[i + 1], q[i + 2])
    }
}

/// Positions, sliding coordinates and their velocities.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Generalized coordinates (m).
    pub q: Vec<f64>,
    /// Generalized velocities (m/s).
    pub v: Vec<f64>,
}

impl State {
    /// The state of a layout, at rest.
    pub fn from_layout(topology: &Topology, dofs: &DofMap, layout: &Layout) -> Self {
        let mut q = vec![0.0; dofs.n_dofs()];
        for (n, node) in topology.nodes.iter().enumerate() {
            let i = dofs.x(n);
            q[i..i + 3].copy_from_slice(layout.positions[n].as_slice());
            for s in 0..node.passes.len() {
                q[dofs.u(n, s)] = layout.sliding[n][s];
            }
        }
        Self {
            v: vec![0.0; q.len()],
            q,
        }
    }
}

/// Gathers `x[dofs]` into a fixed-size vector.
pub fn gather<const N: usize>(x: &[f64], dofs: &[usize; N]) -> SVector<f64, N> {
    SVector::<f64, N>::from_fn(|i, _| x[dofs[i]])
}

/// The segment mass matrix `M(q)` of the module documentation (kg, kg·m/m …: `q̇ᵀMq̇` is
/// twice a kinetic energy in J), for `q = (x₀, u₀, x₁, u₁)` and linear density `rho` (kg/m).
/// Symmetric positive semi-definite for `Δu > 0`; its null space holds the motions
/// `(x, u) = (w δ, δ)` of each end, which move a node along a straight segment without moving
/// material.
pub fn segment_mass_matrix(rho: f64, q: &SVector<f64, 8>) -> SMatrix<f64, 8, 8> {
    let x0 = q.fixed_rows::<3>(0);
    let x1 = q.fixed_rows::<3>(4);
    let du = q[7] - q[3];
    let w: V3 = (x1 - x0) / du;
    let mut j = SMatrix::<f64, 4, 4>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
    j.fixed_view_mut::<3, 1>(0, 3).copy_from(&-w);
    j.fixed_view_mut::<1, 3>(3, 0).copy_from(&-w.transpose());
    j[(3, 3)] = w.norm_squared();
    let s = rho * du / 6.0;
    let mut m = SMatrix::<f64, 8, 8>::zeros();
    m.fixed_view_mut::<4, 4>(0, 0).copy_from(&(2.0 * s * j));
    m.fixed_view_mut::<4, 4>(4, 4).copy_from(&(2.0 * s * j));
    m.fixed_view_mut::<4, 4>(0, 4).copy_from(&(s * j));
    m.fixed_view_mut::<4, 4>(4, 0).copy_from(&(s * j));
    m
}

/// Kinetic energy `Σ_segments ½ q̇ᵀ M(q) q̇` (J) of a state.
pub fn kinetic_energy(topology: &Topology, dofs: &DofMap, rho: f64, state: &State) -> f64 {
    topology
        .segments()
        .map(|(y, i)| {
            let p = &topology.yarns[y].passes;
            let d = dofs.segment_dofs(p[i], p[i + 1]);
            let (q, v) = (gather(&state.q, &d), gather(&state.v, &d));
            0.5 * (v.transpose() * segment_mass_matrix(rho, &q) * v)[(0, 0)]
        })
        .sum()
}
