//! The tile under a uniaxial map, with the compression `c` as one more DOF.
//!
//! Under `F₂ = (1 + s) u uᵀ + (1 − c) v vᵀ` the stress orthogonal to the stretch is
//! `σ_c = vᵀPv = −(1/A) ∂E/∂c` at fixed fluctuations (`∂F₂/∂c = −v vᵀ`, [`PeriodicTile::stress`]).
//! So the zero-orthogonal-stress compression of a uniaxial curve point
//! ([`crate::curves`]) is the stationarity in `c` of the energy, and one Newton solve of
//! `E(ũ, θ, c)` over the fluctuations, the twists and `c` reaches it, instead of a root-find
//! over several solves at fixed `c`. The positions `x = F(c) Y + ũ` are affine in `c`, so every
//! stencil's local vector is `q(c) = q(c₀) + (c − c₀) d` with `d_i = −v (v·Y_i)` for its point
//! positions and 0 for its twists, and the chain rule is exact:
//!
//! ```text
//! ∂E_k/∂c = g·d,    ∂²E_k/∂c ∂q = H d,    ∂²E_k/∂c² = dᵀ H d.
//! ```
//!
//! **Along a tile axis, and along the bias as a predictor.** The no-sliding rows
//! `ũ · (F N) = 0` (seed 004 Eq. 3) are linear in `ũ` with coefficients `F N`. Along weft and
//! warp `F` is diagonal, so `F N` is parallel to `N` whatever `c` is, and the rows
//! (homogeneous, each scaled by its largest entry in the solver) do not depend on `c`: the
//! problem keeps the linear constraints the constrained Newton solver takes, and its
//! stationarity is exactly `σ_c = 0`. Along the bias `F N` turns with `c`, so the rows would
//! be bilinear in `c` and `ũ`. There the problem keeps the rows of the compression it was
//! built at, `F(c₀) N` ([`solve_compressed`] rebuilds it at the current `c` with every pair
//! update), and its stationarity is `σ_c = 0` under rows a little off: a prediction of the
//! root, solved once more at the compression found under its own rows. Where the orthogonal
//! stress left is above the root-find's tolerance, [`crate::curves`] finishes with a root-find
//! at fixed compressions; on the stockinette's bias curve and at `yarn_objective`'s fixed
//! points of the eight shared fabrics no point needed it. The energy, its derivatives and
//! `∂E/∂c = −A σ_c` at fixed fluctuations hold in every direction; only the constraints are
//! frozen.
//!
//! The DOF is `q_c = ℓ c` with `ℓ = √(pₓ p_y)`, a length of the tile's size, so that its
//! gradient `−ℓ σ_c` is a force like the other DOFs' and its Hessian entry `ℓ² ∂²Ψ/∂c²`
//! a stiffness of their order (the solver's regularizing shifts and tolerances are shared).

use super::filter::COLLISION_ETA;
use super::solve::{equilibrium_of, settle_pairs, start_dofs};
use super::{
    ContactPair, Equilibrium, EquilibriumSettings, PeriodicError, PeriodicTile, YarnModel,
};
use crate::coarse::Coarse;
use nalgebra::Vector3;
use rod::contact::closest_points;
use solver::{LinearConstraints, Problem};
use yarn_pattern::tile::Tile;

/// Largest local vector of a tile stencil (a contact pair: 4 points).
const MAX_LOCAL: usize = 12;

/// `ℓ = √(pₓ p_y)` (m): the compression DOF is `ℓ c` (module documentation).
fn dof_scale(tile: &Tile) -> f64 {
    (tile.period[0] * tile.period[1]).sqrt()
}

/// Whether the uniaxial map at `angle` stretches along a tile axis (weft or warp), where the
/// no-sliding rows do not depend on the compression and the joint solve is exact (module
/// documentation).
pub fn along_tile_axis(angle: f64) -> bool {
    angle.sin().abs() < 1e-12 || angle.cos().abs() < 1e-12
}

/// [`PeriodicTile`] under `Coarse::uniaxial(s, c, angle)` with `ℓ c` as its last DOF and the
/// no-sliding rows of `c₀` (module documentation; they do not depend on `c` along a tile axis).
/// Flat only.
pub struct CompressedTile<'t> {
    base: PeriodicTile<'t>,
    /// The compression the base problem was built at.
    c0: f64,
    /// `ℓ` (m).
    scale: f64,
    /// Index of the compression DOF.
    c_dof: usize,
    /// Every stencil's DOFs with the compression DOF appended.
    dofs: Vec<Vec<usize>>,
    /// Every stencil's `∂q/∂c` (positions `−v (v·Y_i)`, twists 0).
    d: Vec<Vec<f64>>,
    /// Index of the first contact stencil.
    first_contact: usize,
}

impl<'t> CompressedTile<'t> {
    /// The problem at stretch `s` along `angle`, built at compression `c0` (its no-sliding rows'
    /// compression) with the given pairs.
    pub fn new(
        tile: &'t Tile,
        model: YarnModel,
        s: f64,
        angle: f64,
        c0: f64,
        pairs: Vec<ContactPair>,
    ) -> Result<Self, PeriodicError> {
        if !(s.is_finite() && c0.is_finite() && angle.is_finite()) {
            return Err(PeriodicError::Invalid(format!(
                "stretch {s}, compression {c0} and angle {angle} must be finite"
            )));
        }
        let base = PeriodicTile::new(tile, model, Coarse::uniaxial(s, c0, angle), pairs)?;
        let v = Vector3::new(-angle.sin(), angle.cos(), 0.0);
        let c_dof = base.n_dofs();
        let mut dofs = Vec::with_capacity(base.n_stencils());
        let mut d = Vec::with_capacity(base.n_stencils());
        for k in 0..base.n_stencils() {
            let mut stencil = base.stencil_dofs(k).to_vec();
            let mut dk = vec![0.0; stencil.len()];
            for (i, &(vertex, shift)) in base.points[k].iter().enumerate() {
                let y = tile.positions[vertex] + tile.period_offset(shift);
                let di = -v * v.dot(&y);
                dk[3 * i..3 * i + 3].copy_from_slice(di.as_slice());
            }
            stencil.push(c_dof);
            dofs.push(stencil);
            d.push(dk);
        }
        let first_contact = base.n_stencils() - base.pairs().len();
        Ok(Self {
            scale: dof_scale(tile),
            base,
            c0,
            c_dof,
            dofs,
            d,
            first_contact,
        })
    }

    /// `ℓ` (m): the compression DOF is `ℓ c`.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The compression at `x`.
    pub fn compression(&self, x: &[f64]) -> f64 {
        x[self.c_dof] / self.scale
    }

    /// The linear constraints of the base problem ([`PeriodicTile::constraints`], the rows of
    /// `c₀`), with the compression DOF free.
    pub fn constraints(&self) -> Result<LinearConstraints, PeriodicError> {
        let c = self.base.constraints()?;
        Ok(LinearConstraints::new(
            self.c_dof + 1,
            c.triplets(),
            c.rhs(),
        )?)
    }

    /// Stencil `k`'s local vector at `x` (at the compression `x` holds).
    fn local(&self, k: usize, x: &[f64]) -> solver::LocalVector {
        let mut q = self.base.local_positions(k, x);
        let dc = self.compression(x) - self.c0;
        for (qi, di) in q.iter_mut().zip(&self.d[k]) {
            *qi += dc * di;
        }
        q
    }
}

impl Problem for CompressedTile<'_> {
    fn n_dofs(&self) -> usize {
        self.c_dof + 1
    }
    fn n_stencils(&self) -> usize {
        self.dofs.len()
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        &self.dofs[k]
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let q = self.local(k, x);
        let m = q.len();
        assert!(
            m <= MAX_LOCAL,
            "a tile stencil has at most {MAX_LOCAL} local DOFs"
        );
        let d = &self.d[k];
        let term = self.base.terms.term(k);
        let (g, gc) = grad.split_at_mut(m);
        let Some(hess) = hess else {
            let e = term.local_eval(&q, g, None);
            gc[0] = g.iter().zip(d).map(|(a, b)| a * b).sum::<f64>() / self.scale;
            return e;
        };
        let mut h = [0.0; MAX_LOCAL * MAX_LOCAL];
        let h = &mut h[..m * m];
        let e = term.local_eval(&q, g, Some(h));
        gc[0] = g.iter().zip(d).map(|(a, b)| a * b).sum::<f64>() / self.scale;
        let n = m + 1;
        let mut dhd = 0.0;
        for j in 0..m {
            let column = &h[m * j..m * (j + 1)];
            hess[n * j..n * j + m].copy_from_slice(column);
            // (H d)_j, H symmetric.
            let hd: f64 = column.iter().zip(d).map(|(a, b)| a * b).sum();
            hess[n * j + m] = hd / self.scale;
            hess[n * m + j] = hd / self.scale;
            dhd += hd * d[j];
        }
        hess[n * m + m] = dhd / (self.scale * self.scale);
        e
    }
    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        self.base.terms.term(k).local_energy(&self.local(k, x))
    }
    /// The collision filter of [`PeriodicTile`] (`filter.rs`) with every point's move bounded
    /// by `|Δũ| + |Δc| |d_i|`: a pair stays at least `(1 − η)` of its distance apart.
    fn max_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        let dc = (dx[self.c_dof] / self.scale).abs();
        let vertex_move = |dofs: &[usize], i: usize| {
            Vector3::new(dx[dofs[3 * i]], dx[dofs[3 * i + 1]], dx[dofs[3 * i + 2]]).norm()
        };
        (self.first_contact..self.n_stencils())
            .map(|k| {
                let q = self.local(k, x);
                let (dofs, d) = (&self.dofs[k], &self.d[k]);
                let point = |i: usize| Vector3::new(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
                let moves: [f64; 4] = std::array::from_fn(|i| {
                    vertex_move(dofs, i)
                        + dc * Vector3::new(d[3 * i], d[3 * i + 1], d[3 * i + 2]).norm()
                });
                let m = moves[0].max(moves[1]) + moves[2].max(moves[3]);
                let distance = closest_points(&point(0), &point(1), &point(2), &point(3)).2;
                if m > 0.0 {
                    COLLISION_ETA * distance / m
                } else {
                    f64::INFINITY
                }
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The equilibrium at stretch `s` along `angle` with zero orthogonal stress, in one Newton
/// solve over the fluctuations, the twists and the compression (module documentation),
/// starting from `start` (the tile's rest state if `None`) at compression `guess`. Pair
/// updates and the restart with the wider pair set are those of [`super::solve_equilibrium`].
/// Returns the compression and the equilibrium under its map.
///
/// Along a tile axis ([`along_tile_axis`]) the orthogonal stress of that equilibrium is zero to
/// the solver's gradient tolerance. Along any other direction the joint solve's rows are
/// frozen at the compression of its last pair round; the tile is then solved once more at the
/// compression found, with [`super::solve_equilibrium`] from the joint solve's state (its
/// Newton iterations counted), so the equilibrium returned is exact under its own map; its
/// orthogonal stress is small, not zero by construction (module documentation).
pub fn solve_compressed(
    tile: &Tile,
    model: &YarnModel,
    s: f64,
    angle: f64,
    guess: f64,
    start: Option<&[f64]>,
    settings: &EquilibriumSettings,
) -> Result<(f64, Equilibrium), PeriodicError> {
    let mut first = start_dofs(tile, start)?;
    let scale = dof_scale(tile);
    first.push(scale * guess);
    let compression = |x: &[f64]| x[x.len() - 1] / scale;
    let settled = settle_pairs(
        tile,
        model,
        &first,
        settings,
        |x| Coarse::uniaxial(s, compression(x), angle),
        |x, pairs| {
            let problem = CompressedTile::new(tile, *model, s, angle, compression(x), pairs)?;
            let constraints = problem.constraints()?;
            Ok((problem, constraints))
        },
    )?;
    let (problem, mut dofs) = (settled.problem, settled.x);
    let c = problem.compression(&dofs);
    dofs.pop();
    let coarse = Coarse::uniaxial(s, c, angle);
    if !along_tile_axis(angle) {
        // The rows of the last round's compression: re-solved under the rows of `c`.
        let mut eq = super::solve_equilibrium(tile, model, coarse, Some(&dofs), settings)?;
        eq.iterations += settled.iterations;
        return Ok((c, eq));
    }
    let at = PeriodicTile::new(tile, *model, coarse, problem.base.pairs().to_vec())?;
    Ok((
        c,
        equilibrium_of(&at, dofs, settled.energy, settled.iterations),
    ))
}
