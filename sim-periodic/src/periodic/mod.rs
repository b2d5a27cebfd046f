//! A periodic yarn tile under a prescribed coarse deformation, as a `solver::Problem`
//! (seed 002 §6–7.1, seed 004 §3.1, after Sperl et al. 2020).
//!
//! **Kinematics.** Vertex positions are `x_v = F X_v + ũ_v` with `F` the coarse map
//! ([`Coarse::f3`]), `X_v` the rest position and `ũ_v` the periodic fluctuation. On a bent
//! coarse surface ([`Coarse::curvature`]) they are `x̄(X_v) + R(X_v) ũ_v` ([`Coarse::map`],
//! [`Coarse::frame`]): the fluctuation lives in the local frame and rolls with the surface. An edge ending
//! at the copy of `v₁` shifted by `(dx, dy)` periods ends at `F (X_{v₁} + dx pₓ e₁ + dy p_y e₂)
//! + ũ_{v₁}`. DOFs: the fluctuations `ũ_v` (3 per vertex, at `3v..3v+3`) followed by the twist
//! angle θ of every edge (at `3n + e`).
//!
//! **Energy** `E = Σ W`: two-phase stretch per edge (seed 002 Eq. 5), material-frame bending with
//! rest curvature per vertex (Eq. 6), DER twist per vertex, and two-phase barrier contact
//! between pairs of edges within the cutoff, including periodic images (Eq. 7). Pairs of edges
//! on the same yarn strand closer than `min_arc_separation` along it are skipped (they always
//! touch). Energy density `Ψ = E / (pₓ p_y)`.
//!
//! **Reference frames** of the bending and twist stencils are the tile's rest frames
//! (`*RefD1`, `*RefT`) transported directly onto the current edges, so the energy is one
//! smooth function of the DOFs for every coarse deformation (degenerate only if an edge turns
//! by nearly π from its rest direction).
//!
//! **Constraints** `C ũ = 0`: zero mean fluctuation (no net translation), and one vertex per
//! yarn loop kept on its tile boundary, `ũ · (F N) = 0` (no yarn sliding, seed 004 Eq. 3).
//!
//! | file | contents |
//! |---|---|
//! | `model.rs` | [`YarnModel`], [`PeriodicError`] |
//! | `mod.rs` | [`PeriodicTile`]: the stencils (a [`solver::Terms`]), coarse offsets, the [`Problem`] |
//! | `bent.rs` | the chain rule through the point frames of a bent coarse surface |
//! | `contacts.rs` | [`ContactPair`], the broad phase ([`PeriodicTile::find_pairs`]), closest approach |
//! | `constraints.rs` | [`PeriodicTile::constraints`] |
//! | `stress.rs` | [`PeriodicTile::stress`] |
//! | `filter.rs` | the collision filter ([`Problem::max_step`]) |
//! | `solve.rs` | [`initial_dofs`], [`EquilibriumSettings`], [`Equilibrium`], [`solve_equilibrium`] |
//! | `compression.rs` | [`CompressedTile`], [`solve_compressed`]: a uniaxial point with its compression as a DOF |

mod bent;
mod compression;
mod constraints;
mod contacts;
mod filter;
mod model;
mod sensitivity;
mod solve;
mod stress;

pub use compression::{CompressedTile, along_tile_axis, solve_compressed};
pub use contacts::ContactPair;
pub use model::{PeriodicError, YarnModel};
pub use sensitivity::{Partial, equilibrium_problem, stress_sensitivities};
pub use solve::{
    Equilibrium, EquilibriumSettings, STALL_ITERATIONS, initial_dofs, solve_equilibrium,
};

use crate::coarse::Coarse;
use nalgebra::{Matrix3, Vector2, Vector3};
use rod::contact::EdgeContact;
use rod::geometry::Frame;
use rod::material_bending::MaterialBending;
use rod::stretch::Segment;
use rod::twist::Twist;
use solver::{Problem, RodTerm, Terms};
use yarn_pattern::tile::{Tile, Topology};

/// One stencil point: vertex and the period shift of the copy used.
type Point = (usize, [i32; 2]);

/// The periodic tile problem for one coarse deformation and one set of contact pairs.
pub struct PeriodicTile<'t> {
    tile: &'t Tile,
    topology: Topology,
    coarse: Coarse,
    /// Stretch per edge, bending (and twist) per vertex, contact per pair, in that order;
    /// offsets `x̄(X_v + shift)` of each point followed by zeros for twist DOFs.
    terms: Terms,
    /// The points of every term.
    points: Vec<Vec<Point>>,
    /// Local frame `R` of each point of every term when the coarse surface is bent
    /// (positions are `x̄ + R ũ`); empty when flat (`R = I`).
    frames: Vec<Vec<Matrix3<f64>>>,
    pairs: Vec<ContactPair>,
}

impl<'t> PeriodicTile<'t> {
    /// Builds the stencils of `tile` under `coarse` with the given contact pairs.
    pub fn new(
        tile: &'t Tile,
        model: YarnModel,
        coarse: Coarse,
        pairs: Vec<ContactPair>,
    ) -> Result<Self, PeriodicError> {
        let topology = tile.topology()?;
        if !coarse.f.iter().all(|v| v.is_finite()) || coarse.f.determinant() <= 0.0 {
            return Err(PeriodicError::Invalid(format!(
                "coarse deformation F = {} is not orientation-preserving",
                coarse.f
            )));
        }
        let n = tile.n_vertices();
        let theta = |e: usize| 3 * n + e;
        let u = |v: usize| [3 * v, 3 * v + 1, 3 * v + 2];
        let rest_frame = |e: usize| {
            Frame::new(&tile.edge_vector(e), &tile.reference_directors[e])
                .or_else(|| Frame::any_for(&tile.edge_vector(e)))
                .ok_or_else(|| PeriodicError::Invalid(format!("edge {e} has zero length")))
        };
        let mut terms = Terms::new(4 * n);
        let mut points = Vec::new();
        for (e, edge) in tile.edges.iter().enumerate() {
            let stretch = Segment {
                rest_length: tile.rest_lengths[e],
                law: model.stretch,
            };
            terms.push(RodTerm::<_, 6>(stretch), &[u(edge.v0), u(edge.v1)].concat());
            points.push(vec![(edge.v0, [0, 0]), (edge.v1, edge.shift)]);
        }
        for v in 0..n {
            let (a, b) = (topology.incoming(v), topology.outgoing(v));
            let (ea, eb) = (tile.edges[a], tile.edges[b]);
            let vertex_points = vec![
                (ea.v0, [-ea.shift[0], -ea.shift[1]]),
                (v, [0, 0]),
                (eb.v1, eb.shift),
            ];
            let dofs = [u(ea.v0).as_slice(), &u(v), &u(eb.v1), &[theta(a), theta(b)]].concat();
            let reference = (rest_frame(a)?, rest_frame(b)?);
            let rest_lengths = (tile.rest_lengths[a], tile.rest_lengths[b]);
            let bend = MaterialBending {
                stiffness: model.bending,
                rest_lengths,
                rest_curvature: Vector2::from(tile.rest_curvatures[v]),
                reference,
            };
            terms.push(RodTerm::<_, 11>(bend), &dofs);
            points.push(vertex_points.clone());
            if model.twist > 0.0 {
                let twist = Twist {
                    stiffness: model.twist,
                    rest_lengths,
                    rest_twist: tile.rest_twists[v],
                    reference,
                    reference_twist: tile.reference_twists[v],
                };
                terms.push(RodTerm::<_, 11>(twist), &dofs);
                points.push(vertex_points);
            }
        }
        for p in &pairs {
            let (ea, eb) = (tile.edges[p.a], tile.edges[p.b]);
            let contact = EdgeContact {
                phases: model.contact,
                rest_lengths: (tile.rest_lengths[p.a], tile.rest_lengths[p.b]),
                quadrature: model.quadrature,
            };
            let end_b = [eb.shift[0] + p.image[0], eb.shift[1] + p.image[1]];
            let dofs = [u(ea.v0), u(ea.v1), u(eb.v0), u(eb.v1)].concat();
            terms.push(RodTerm::<_, 12>(contact), &dofs);
            points.push(vec![
                (ea.v0, [0, 0]),
                (ea.v1, ea.shift),
                (eb.v0, p.image),
                (eb.v1, end_b),
            ]);
        }
        let mut out = Self {
            tile,
            topology,
            coarse,
            frames: vec![Vec::new(); terms.len()],
            terms,
            points,
            pairs,
        };
        out.set_coarse(coarse);
        Ok(out)
    }

    /// Changes the coarse deformation (the stencils and the sparsity pattern are unchanged).
    pub fn set_coarse(&mut self, coarse: Coarse) {
        self.coarse = coarse;
        let bent = coarse.curvature.is_some_and(|c| c.kappa != 0.0);
        for (k, (points, frames)) in self.points.iter().zip(&mut self.frames).enumerate() {
            let offset = self.terms.offset_mut(k);
            offset.fill(0.0);
            frames.clear();
            for (i, &(v, shift)) in points.iter().enumerate() {
                let y = self.tile.positions[v] + self.tile.period_offset(shift);
                offset[3 * i..3 * i + 3].copy_from_slice(coarse.map(&y).as_slice());
                if bent {
                    frames.push(coarse.frame(&y));
                }
            }
        }
    }

    /// The coarse deformation.
    pub fn coarse(&self) -> Coarse {
        self.coarse
    }

    /// The contact pairs this problem was built with.
    pub fn pairs(&self) -> &[ContactPair] {
        &self.pairs
    }

    /// Current vertex positions `F X_v + ũ_v` (m).
    pub fn positions(&self, x: &[f64]) -> Vec<Vector3<f64>> {
        let c = &self.coarse;
        self.tile
            .positions
            .iter()
            .enumerate()
            .map(|(v, p)| {
                c.map(p) + c.frame(p) * Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2])
            })
            .collect()
    }

    /// Rest tile area `pₓ p_y` (m²).
    pub fn area(&self) -> f64 {
        self.tile.period[0] * self.tile.period[1]
    }
}

impl Problem for PeriodicTile<'_> {
    fn n_dofs(&self) -> usize {
        self.terms.n_dofs()
    }
    fn n_stencils(&self) -> usize {
        self.terms.len()
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        self.terms.dofs(k)
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        if self.frames[k].is_empty() {
            self.terms.eval_stencil(k, x, grad, hess)
        } else {
            self.eval_bent(k, x, grad, hess)
        }
    }
    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        if self.frames[k].is_empty() {
            self.terms.stencil_energy(k, x)
        } else {
            self.terms.term(k).local_energy(&self.local_positions(k, x))
        }
    }
    /// See `filter.rs`.
    fn max_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        self.collision_step(x, dx)
    }
}
