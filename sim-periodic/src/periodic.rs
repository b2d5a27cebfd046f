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

use crate::coarse::Coarse;
use crate::tile::{Tile, TileError, Topology};
use nalgebra::{Matrix2, Matrix3, SVector, Vector2, Vector3};
use rod::Stencil;
use rod::contact::{BarrierPhase, EdgeContact, Simpson, closest_points};
use rod::geometry::Frame;
use rod::material_bending::MaterialBending;
use rod::stretch::{Segment, StretchLaw};
use rod::twist::Twist;
use solver::{
    LinearConstraints, NewtonSettings, Problem, SolveError, eval_rod_stencil_energy_offset,
    eval_rod_stencil_offset, minimize_constrained,
};

/// Yarn material parameters (SI). The defaults are illustrative values for a ~1 mm yarn, not
/// fitted ones; paper 002 §7 fits them to fabric tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YarnModel {
    /// Stretch law (seed 002 Eq. 5), stiffnesses in N.
    pub stretch: StretchLaw,
    /// Bending stiffness k_b (N·m²).
    pub bending: f64,
    /// Twist stiffness k_t (N·m²).
    pub twist: f64,
    /// Contact phases `[soft large-radius, stiff small-radius]` (seed 002 Eq. 7).
    pub contact: [BarrierPhase; 2],
    /// Simpson quadrature of the contact integral along each edge.
    pub quadrature: Simpson,
    /// Pairs of edges on one yarn strand closer than this along the yarn (m) are not in
    /// contact (they are neighbours).
    pub min_arc_separation: f64,
}

impl YarnModel {
    /// Illustrative defaults for yarn radius `r` (m): two-phase stretch `k₁ = 20 N`,
    /// `k₂ = 200 N` past 3 % strain; `k_b = 5e-6 N·m²`; `k_t = 4e-6 N·m²`; contact phases
    /// `(1e3 J/m², R₁ = r)` and `(1e6 J/m², R₂ = r/4)` (R₂ = 0.25 R as in seed 002 §6.3);
    /// Simpson with 4 intervals; neighbours within `4 r` along the yarn skipped.
    ///
    /// Why 4 intervals, not the paper's 3-point rule (2 intervals): the barrier is only felt at
    /// the quadrature points, and on the real stockinette tile (edges ≈ 1.2 R) under biaxial
    /// stretch (sx, sy) = (0.7, 0.25…0.7) two yarns squeeze between the 3 × 3 points of the
    /// 2-interval rule: with the collision filter ([`solver::Problem::max_step`]) Newton then
    /// stalls, without it the tile unravels (Ψ falls from 327 to 5 J/m²). With 4 intervals the
    /// closest approach stays at the stiff core (0.44 R at (0.7, 0, 0.7)) and every solve
    /// converges; Ψ at (−0.05, 0, −0.05) changes by 1.3 %.
    pub fn default_for_radius(r: f64) -> Self {
        Self {
            stretch: StretchLaw::TwoPhase {
                k1: 20.0,
                k2: 200.0,
                onset: 0.03,
            },
            bending: 5e-6,
            twist: 4e-6,
            contact: [
                BarrierPhase {
                    stiffness: 1e3,
                    radius: r,
                },
                BarrierPhase {
                    stiffness: 1e6,
                    radius: 0.25 * r,
                },
            ],
            quadrature: Simpson { intervals: 4 },
            min_arc_separation: 4.0 * r,
        }
    }

    /// Centreline distance (m) below which two edges interact.
    pub fn contact_cutoff(&self) -> f64 {
        2.0 * self.contact[0].radius.max(self.contact[1].radius)
    }
}

/// Errors of periodic-tile problems.
#[derive(Debug, thiserror::Error)]
pub enum PeriodicError {
    /// The tile is inconsistent.
    #[error("invalid tile: {0}")]
    Tile(#[from] TileError),
    /// The solver failed (carries its report).
    #[error("equilibrium solve failed: {0}")]
    Solve(#[from] SolveError),
    /// The coarse deformation or the model is not admissible.
    #[error("invalid input: {0}")]
    Invalid(String),
}

/// One stencil point: vertex and the period shift of the copy used.
type Point = (usize, [i32; 2]);

enum Term {
    Stretch(Segment),
    Bend(MaterialBending),
    Twist(Twist),
    Contact(EdgeContact),
}

struct Entry {
    term: Term,
    dofs: Vec<usize>,
    points: Vec<Point>,
    /// `x̄(X_v + shift)` of each point followed by zeros for twist DOFs (the coarse part).
    offset: Vec<f64>,
    /// Local frame `R` of each point when the coarse surface is bent (positions are
    /// `x̄ + R ũ`); empty when flat (`R = I`).
    frames: Vec<Matrix3<f64>>,
}

/// An unordered pair of edges in contact: edge `b` taken in the image shifted by `image`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ContactPair {
    /// First edge.
    pub a: usize,
    /// Second edge.
    pub b: usize,
    /// Period shift of edge `b`'s copy.
    pub image: [i32; 2],
}

/// The periodic tile problem for one coarse deformation and one set of contact pairs.
pub struct PeriodicTile<'t> {
    tile: &'t Tile,
    topology: Topology,
    coarse: Coarse,
    entries: Vec<Entry>,
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
        let mut entries = Vec::new();
        for (e, edge) in tile.edges.iter().enumerate() {
            let stretch = Segment {
                rest_length: tile.rest_lengths[e],
                law: model.stretch,
            };
            let dofs = [u(edge.v0), u(edge.v1)].concat();
            entries.push(Entry {
                term: Term::Stretch(stretch),
                dofs,
                points: vec![(edge.v0, [0, 0]), (edge.v1, edge.shift)],
                offset: vec![],
                frames: vec![],
            });
        }
        for v in 0..n {
            let (a, b) = (topology.incoming(v), topology.outgoing(v));
            let (ea, eb) = (tile.edges[a], tile.edges[b]);
            let points = vec![
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
            entries.push(Entry {
                term: Term::Bend(bend),
                dofs: dofs.clone(),
                points: points.clone(),
                offset: vec![],
                frames: vec![],
            });
            if model.twist > 0.0 {
                let twist = Twist {
                    stiffness: model.twist,
                    rest_lengths,
                    rest_twist: tile.rest_twists[v],
                    reference,
                    reference_twist: tile.reference_twists[v],
                };
                entries.push(Entry {
                    term: Term::Twist(twist),
                    dofs,
                    points,
                    offset: vec![],
                    frames: vec![],
                });
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
            let points = vec![
                (ea.v0, [0, 0]),
                (ea.v1, ea.shift),
                (eb.v0, p.image),
                (eb.v1, end_b),
            ];
            let dofs = [u(ea.v0), u(ea.v1), u(eb.v0), u(eb.v1)].concat();
            entries.push(Entry {
                term: Term::Contact(contact),
                dofs,
                points,
                offset: vec![],
                frames: vec![],
            });
        }
        let mut out = Self {
            tile,
            topology,
            coarse,
            entries,
            pairs,
        };
        out.set_coarse(coarse);
        Ok(out)
    }

    /// Changes the coarse deformation (the stencils and the sparsity pattern are unchanged).
    pub fn set_coarse(&mut self, coarse: Coarse) {
        self.coarse = coarse;
        let bent = coarse.curvature.is_some_and(|c| c.kappa != 0.0);
        for entry in &mut self.entries {
            entry.offset.clear();
            entry.frames.clear();
            for &(v, shift) in &entry.points {
                let y = self.tile.positions[v] + self.tile.period_offset(shift);
                entry.offset.extend(coarse.map(&y).iter());
                if bent {
                    entry.frames.push(coarse.frame(&y));
                }
            }
            entry.offset.resize(entry.dofs.len(), 0.0);
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

    /// The smallest centre-line distance (m) between the two edges of any contact pair of this
    /// problem at the DOFs `x` (`+∞` without pairs).
    pub fn closest_approach(&self, x: &[f64]) -> f64 {
        self.pair_segments(x)
            .map(|(_, [a0, a1, b0, b1])| closest_points(&a0, &a1, &b0, &b1).2)
            .fold(f64::INFINITY, f64::min)
    }

    /// Every contact pair with the deformed end points `[a0, a1, b0, b1]` of its two edges.
    fn pair_segments<'a>(
        &'a self,
        x: &'a [f64],
    ) -> impl Iterator<Item = (&'a ContactPair, [Vector3<f64>; 4])> + 'a {
        let (tile, c) = (self.tile, self.coarse);
        let pos = move |v: usize, shift: [i32; 2]| {
            let y = tile.positions[v] + tile.period_offset(shift);
            c.map(&y) + c.frame(&y) * Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2])
        };
        self.pairs.iter().map(move |p| {
            let (ea, eb) = (tile.edges[p.a], tile.edges[p.b]);
            let [i, j] = p.image;
            let ends = [
                pos(ea.v0, [0, 0]),
                pos(ea.v1, ea.shift),
                pos(eb.v0, p.image),
                pos(eb.v1, [eb.shift[0] + i, eb.shift[1] + j]),
            ];
            (p, ends)
        })
    }

    /// Rest tile area `pₓ p_y` (m²).
    pub fn area(&self) -> f64 {
        self.tile.period[0] * self.tile.period[1]
    }

    /// The linear constraints `C ũ = 0` (zero mean fluctuation; no sliding, seed 004 Eq. 3).
    pub fn constraints(&self) -> Result<LinearConstraints, PeriodicError> {
        let n = self.tile.n_vertices();
        let mut triplets = Vec::new();
        for v in 0..n {
            for c in 0..3 {
                triplets.push((c, 3 * v + c, 1.0 / n as f64));
            }
        }
        let mut rows = 3;
        let f3 = self.coarse.f3();
        for lp in self.topology.loops() {
            // The start vertex of the first edge that crosses the tile boundary stays on it.
            let Some(&e) = lp.iter().find(|&&e| self.tile.edges[e].shift != [0, 0]) else {
                return Err(PeriodicError::Invalid(format!(
                    "yarn loop starting at edge {} never crosses the tile boundary",
                    lp[0]
                )));
            };
            let edge = self.tile.edges[e];
            let normal = if edge.shift[0] != 0 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let fnormal = f3 * normal;
            for c in 0..3 {
                if fnormal[c] != 0.0 {
                    triplets.push((rows, 3 * edge.v1, fnormal[c]));
                }
            }
            rows += 1;
        }
        let mut rhs = vec![0.0; rows];
        // No twist drift: the mean twist angle of every loop stays at the tile's.
        let mut twist_of_edge = vec![0.0; n];
        for v in 0..n {
            twist_of_edge[self.topology.outgoing(v)] = self.tile.twists[v];
        }
        for lp in self.topology.loops() {
            let w = 1.0 / lp.len() as f64;
            for &e in &lp {
                triplets.push((rows, 3 * n + e, w));
            }
            rhs.push(w * lp.iter().map(|&e| twist_of_edge[e]).sum::<f64>());
            rows += 1;
        }
        Ok(LinearConstraints::new(4 * n, &triplets, &rhs)?)
    }

    /// `∂Ψ/∂F₂` (Pa·m = N/m) gathered from the stencil forces (seed 002 Eq. 10): with positions
    /// `x̄(Y_k) + R ũ` and `p = F Y_k`, `∂E/∂F = Σ_k (J_kᵀ g_k) Y_kᵀ` by the chain rule, `J_k` the
    /// Jacobian of `p ↦ φ(p) + R(p) ũ` ([`Coarse::map_jacobian`], the identity when flat); at
    /// equilibrium (∂E/∂ũ = 0) it is the derivative of the equilibrium energy density with
    /// respect to `F` at fixed curvature.
    pub fn stress(&self, x: &[f64]) -> Matrix2<f64> {
        let mut p = Matrix2::zeros();
        for k in 0..self.entries.len() {
            let entry = &self.entries[k];
            // The stencil's gradient with respect to its point positions.
            let q = self.local_positions(entry, x);
            let g = self.position_gradient(k, &q);
            for (i, &(v, shift)) in entry.points.iter().enumerate() {
                let y = self.tile.positions[v] + self.tile.period_offset(shift);
                let u = Vector3::new(
                    x[entry.dofs[3 * i]],
                    x[entry.dofs[3 * i + 1]],
                    x[entry.dofs[3 * i + 2]],
                );
                // ∂x/∂F_rc = J e_r Y_c with J the Jacobian of p ↦ φ(p) + R(p) ũ (I when flat).
                let gj = self.coarse.map_jacobian(&y, &u).transpose()
                    * Vector3::new(g[3 * i], g[3 * i + 1], g[3 * i + 2]);
                for r in 0..2 {
                    for c in 0..2 {
                        p[(r, c)] += gj[r] * y[c];
                    }
                }
            }
        }
        p / self.area()
    }

    /// Contact pairs within `cutoff · margin` at DOFs `x` (broad phase over the 3 × 3 images).
    pub fn find_pairs(
        tile: &Tile,
        model: &YarnModel,
        coarse: &Coarse,
        x: &[f64],
        margin: f64,
    ) -> Result<Vec<ContactPair>, PeriodicError> {
        let topology = tile.topology()?;
        let n = tile.n_vertices();
        let pos = |v: usize, shift: [i32; 2]| {
            let y = tile.positions[v] + tile.period_offset(shift);
            coarse.map(&y) + coarse.frame(&y) * Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2])
        };
        // Arc position of every edge's start along its loop, loop lengths and total shifts.
        let loops = topology.loops();
        let mut loop_of = vec![0; n];
        let mut arc = vec![0.0; n];
        let mut loop_len = vec![0.0; loops.len()];
        let mut loop_shift = vec![[0i32; 2]; loops.len()];
        // Cumulative period shift of the edges before each edge along its loop: edge e (image
        // 0) continues the strand of the loop's first edge taken in image −cum[e].
        let mut cum = vec![[0i32; 2]; n];
        for (l, lp) in loops.iter().enumerate() {
            let mut s = 0.0;
            for &e in lp {
                loop_of[e] = l;
                arc[e] = s;
                cum[e] = loop_shift[l];
                s += tile.rest_lengths[e];
                loop_shift[l][0] += tile.edges[e].shift[0];
                loop_shift[l][1] += tile.edges[e].shift[1];
            }
            loop_len[l] = s;
        }
        // Distance along the yarn between edge a and edge b taken in image `t`, if both lie on
        // one yarn strand: a loop with total shift S continues into its image S, so, with d =
        // t − cum[b] + cum[a], the copies are on one strand iff d = k S (k integer), and b is k
        // loop lengths further along. A loop closed inside the tile (S = 0) is one strand only
        // for d = 0, measured around the loop.
        let arc_gap = |a: usize, b: usize, t: [i32; 2]| -> Option<f64> {
            let l = loop_of[a];
            if loop_of[b] != l {
                return None;
            }
            let s = loop_shift[l];
            let t = [t[0] - cum[b][0] + cum[a][0], t[1] - cum[b][1] + cum[a][1]];
            let k = if t == [0, 0] {
                0
            } else if s[0] != 0 && t[0] % s[0] == 0 {
                t[0] / s[0]
            } else if s[0] == 0 && s[1] != 0 && t[1] % s[1] == 0 {
                t[1] / s[1]
            } else {
                return None;
            };
            if [k * s[0], k * s[1]] != t {
                return None;
            }
            let (la, lb) = (tile.rest_lengths[a], tile.rest_lengths[b]);
            let interval_gap = |sa: f64, sb: f64| (sb - (sa + la)).max(sa - (sb + lb)).max(0.0);
            let sb = arc[b] + k as f64 * loop_len[l];
            let gap = if s == [0, 0] {
                [-1.0, 0.0, 1.0]
                    .iter()
                    .map(|w| interval_gap(arc[a], sb + w * loop_len[l]))
                    .fold(f64::INFINITY, f64::min)
            } else {
                interval_gap(arc[a], sb)
            };
            Some(gap)
        };
        let cutoff = model.contact_cutoff() * margin;
        let mut pairs = Vec::new();
        for a in 0..n {
            let ea = tile.edges[a];
            let (a0, a1) = (pos(ea.v0, [0, 0]), pos(ea.v1, ea.shift));
            for b in a..n {
                let eb = tile.edges[b];
                for i in -1..=1 {
                    for j in -1..=1 {
                        let t = [i, j];
                        if a == b && (t <= [0, 0]) {
                            continue; // an edge with itself only in half of the images
                        }
                        if let Some(gap) = arc_gap(a, b, t)
                            && gap < model.min_arc_separation
                        {
                            continue;
                        }
                        let b0 = pos(eb.v0, t);
                        let b1 = pos(eb.v1, [eb.shift[0] + i, eb.shift[1] + j]);
                        if closest_points(&a0, &a1, &b0, &b1).2 < cutoff {
                            pairs.push(ContactPair { a, b, image: t });
                        }
                    }
                }
            }
        }
        Ok(pairs)
    }
}

impl PeriodicTile<'_> {
    /// The stencil's local vector `q`: point positions `x̄ + R ũ` followed by its twist DOFs.
    fn local_positions(&self, e: &Entry, x: &[f64]) -> Vec<f64> {
        let mut q: Vec<f64> = e
            .dofs
            .iter()
            .zip(&e.offset)
            .map(|(&d, o)| x[d] + o)
            .collect();
        for (i, r) in e.frames.iter().enumerate() {
            let u = Vector3::new(x[e.dofs[3 * i]], x[e.dofs[3 * i + 1]], x[e.dofs[3 * i + 2]]);
            let p = r * u;
            for c in 0..3 {
                q[3 * i + c] = e.offset[3 * i + c] + p[c];
            }
        }
        q
    }

    fn term_energy(&self, k: usize, q: &[f64]) -> f64 {
        match &self.entries[k].term {
            Term::Stretch(s) => s.energy(&SVector::from_column_slice(q)),
            Term::Bend(s) => s.energy(&SVector::from_column_slice(q)),
            Term::Twist(s) => s.energy(&SVector::from_column_slice(q)),
            Term::Contact(s) => s.energy(&SVector::from_column_slice(q)),
        }
    }

    /// Energy, gradient and (optionally) Hessian of term `k` at local vector `q`.
    fn term_eval(&self, k: usize, q: &[f64], hessian: bool) -> (f64, Vec<f64>, Vec<f64>) {
        fn run<const N: usize>(
            s: &impl Stencil<N>,
            q: &[f64],
            hessian: bool,
        ) -> (f64, Vec<f64>, Vec<f64>) {
            let q = SVector::<f64, N>::from_column_slice(q);
            if hessian {
                let e = s.eval(&q);
                (
                    e.energy,
                    e.gradient.as_slice().to_vec(),
                    e.hessian.as_slice().to_vec(),
                )
            } else {
                let (energy, g) = s.energy_and_gradient(&q);
                (energy, g.as_slice().to_vec(), vec![])
            }
        }
        match &self.entries[k].term {
            Term::Stretch(s) => run(s, q, hessian),
            Term::Bend(s) => run(s, q, hessian),
            Term::Twist(s) => run(s, q, hessian),
            Term::Contact(s) => run(s, q, hessian),
        }
    }

    /// Gradient of term `k` with respect to its local vector `q` (positions, then twists).
    fn position_gradient(&self, k: usize, q: &[f64]) -> Vec<f64> {
        self.term_eval(k, q, false).1
    }

    /// [`Problem::eval_stencil`] on a bent coarse surface: chain rule through the point frames,
    /// `∂/∂ũ_i = R_iᵀ ∂/∂x_i` and Hessian blocks `R_iᵀ H_ij R_j` (twist DOFs unrotated).
    fn eval_bent(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let e = &self.entries[k];
        let q = self.local_positions(e, x);
        let (energy, g, h) = self.term_eval(k, &q, hess.is_some());
        let n = e.dofs.len();
        let np = e.frames.len();
        // Block-diagonal T with R_i for the points and 1 for twist DOFs: grad = Tᵀ g.
        let t = |row: usize, col: usize| -> f64 {
            if row / 3 < np && col / 3 < np {
                if row / 3 == col / 3 {
                    e.frames[row / 3][(row % 3, col % 3)]
                } else {
                    0.0
                }
            } else if row == col {
                1.0
            } else {
                0.0
            }
        };
        for j in 0..n {
            grad[j] = (0..n).map(|i| t(i, j) * g[i]).sum();
        }
        if let Some(hout) = hess {
            // H' = Tᵀ H T (column-major n × n).
            let mut ht = vec![0.0; n * n];
            for c in 0..n {
                for r in 0..n {
                    let lo = if c / 3 < np { 3 * (c / 3) } else { c };
                    let hi = if c / 3 < np { lo + 3 } else { c + 1 };
                    ht[r + n * c] = (lo..hi).map(|m| h[r + n * m] * t(m, c)).sum();
                }
            }
            for c in 0..n {
                for r in 0..n {
                    let lo = if r / 3 < np { 3 * (r / 3) } else { r };
                    let hi = if r / 3 < np { lo + 3 } else { r + 1 };
                    hout[r + n * c] = (lo..hi).map(|m| t(m, r) * ht[m + n * c]).sum();
                }
            }
        }
        energy
    }
}

impl Problem for PeriodicTile<'_> {
    fn n_dofs(&self) -> usize {
        4 * self.tile.n_vertices()
    }
    fn n_stencils(&self) -> usize {
        self.entries.len()
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        &self.entries[k].dofs
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let e = &self.entries[k];
        if !e.frames.is_empty() {
            return self.eval_bent(k, x, grad, hess);
        }
        match &e.term {
            Term::Stretch(s) => eval_rod_stencil_offset(s, &e.dofs, &e.offset, x, grad, hess),
            Term::Bend(s) => eval_rod_stencil_offset(s, &e.dofs, &e.offset, x, grad, hess),
            Term::Twist(s) => eval_rod_stencil_offset(s, &e.dofs, &e.offset, x, grad, hess),
            Term::Contact(s) => eval_rod_stencil_offset(s, &e.dofs, &e.offset, x, grad, hess),
        }
    }
    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        let e = &self.entries[k];
        if !e.frames.is_empty() {
            let q = self.local_positions(e, x);
            return self.term_energy(k, &q);
        }
        match &e.term {
            Term::Stretch(s) => eval_rod_stencil_energy_offset(s, &e.dofs, &e.offset, x),
            Term::Bend(s) => eval_rod_stencil_energy_offset(s, &e.dofs, &e.offset, x),
            Term::Twist(s) => eval_rod_stencil_energy_offset(s, &e.dofs, &e.offset, x),
            Term::Contact(s) => eval_rod_stencil_energy_offset(s, &e.dofs, &e.offset, x),
        }
    }
    /// Conservative continuous collision filter: a point of an edge moves by at most the larger
    /// move of its two end vertices (`|R Δũ| = |Δũ|`, frames are orthonormal), so a pair at
    /// distance `d` whose ends move by at most `m_a` and `m_b` stays at least `(1 − η) d`
    /// apart for `α ≤ η d / (m_a + m_b)`, `η = 0.9`. Without this, a long Newton step or an
    /// extrapolated warm start can carry a yarn through another (the barrier is only sampled
    /// at quadrature points), after which Newton converges to a topologically wrong state.
    fn max_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        const ETA: f64 = 0.9;
        let moves: Vec<f64> = (0..self.tile.n_vertices())
            .map(|v| Vector3::new(dx[3 * v], dx[3 * v + 1], dx[3 * v + 2]).norm())
            .collect();
        let edge_move = |e: usize| {
            let edge = self.tile.edges[e];
            moves[edge.v0].max(moves[edge.v1])
        };
        self.pair_segments(x)
            .map(|(p, [a0, a1, b0, b1])| {
                let m = edge_move(p.a) + edge_move(p.b);
                let d = closest_points(&a0, &a1, &b0, &b1).2;
                if m > 0.0 { ETA * d / m } else { f64::INFINITY }
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// Initial DOFs of a tile: zero fluctuation, the tile's twist angles (`*Q`'s `t` column
/// belongs to the edge starting at each vertex).
pub fn initial_dofs(tile: &Tile) -> Result<Vec<f64>, PeriodicError> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let mut x = vec![0.0; 4 * n];
    for v in 0..n {
        x[3 * n + topology.outgoing(v)] = tile.twists[v];
    }
    Ok(x)
}

/// Settings of an equilibrium solve.
#[derive(Clone, Debug)]
pub struct EquilibriumSettings {
    /// Newton settings (tolerances on the Lagrangian gradient, J/m and J/rad).
    pub newton: NewtonSettings,
    /// The broad phase keeps pairs within `margin × cutoff`, so that pairs approaching during
    /// the solve are already in the pattern. Default 1.5.
    pub pair_margin: f64,
    /// How often the contact pairs may be rebuilt when the solution brings new pairs within
    /// the cutoff. Default 5.
    pub max_pair_updates: usize,
}

impl Default for EquilibriumSettings {
    fn default() -> Self {
        Self {
            // Exact Hessians (no per-stencil SPD projection; the solver regularizes when the
            // assembled Hessian is indefinite). On the stockinette tile, relaxing at rest takes
            // 11 Newton iterations this way and 76 with projection (sx = 0.3: 10 vs 98), to the
            // same Ψ; one release run took 0.23 s vs 1.9 s (not a benchmark).
            newton: NewtonSettings {
                gradient_abs_tol: 1e-9,
                gradient_rel_tol: 1e-9,
                max_iterations: 200,
                project_spd: false,
                ..NewtonSettings::default()
            },
            pair_margin: 1.5,
            max_pair_updates: 5,
        }
    }
}

/// An equilibrium of a tile under a coarse deformation.
#[derive(Clone, Debug)]
pub struct Equilibrium {
    /// The coarse deformation.
    pub coarse: Coarse,
    /// DOFs: fluctuations (m) then edge twist angles (rad).
    pub dofs: Vec<f64>,
    /// Total energy E (J).
    pub energy: f64,
    /// Energy density Ψ = E/A (J/m²).
    pub density: f64,
    /// `∂Ψ/∂F₂` from the gathered stencil forces (N/m).
    pub stress: Matrix2<f64>,
    /// Contact pairs of the final problem.
    pub pairs: Vec<ContactPair>,
    /// Smallest centre-line distance of a contact pair (m), see
    /// [`PeriodicTile::closest_approach`].
    pub closest_approach: f64,
    /// Newton iterations summed over pair updates.
    pub iterations: usize,
}

/// Solves for the equilibrium of `tile` under `coarse`, starting from `start` (or the tile's
/// rest state), rebuilding the contact pairs until no pair outside the problem comes within
/// the cutoff. Errors if Newton fails or the pairs do not settle.
pub fn solve_equilibrium(
    tile: &Tile,
    model: &YarnModel,
    coarse: Coarse,
    start: Option<&[f64]>,
    settings: &EquilibriumSettings,
) -> Result<Equilibrium, PeriodicError> {
    let mut x = match start {
        Some(s) => s.to_vec(),
        None => initial_dofs(tile)?,
    };
    if x.len() != 4 * tile.n_vertices() {
        return Err(PeriodicError::Invalid(format!(
            "start has {} DOFs, expected {}",
            x.len(),
            4 * tile.n_vertices()
        )));
    }
    let mut iterations = 0;
    for _ in 0..=settings.max_pair_updates {
        let pairs = PeriodicTile::find_pairs(tile, model, &coarse, &x, settings.pair_margin)?;
        let problem = PeriodicTile::new(tile, *model, coarse, pairs)?;
        let constraints = problem.constraints()?;
        let report = minimize_constrained(&problem, &mut x, &constraints, &settings.newton)?;
        iterations += report.iterations;
        let needed = PeriodicTile::find_pairs(tile, model, &coarse, &x, 1.0)?;
        if needed
            .iter()
            .all(|p| problem.pairs().binary_search(p).is_ok())
        {
            let energy = *report.energy_history.last().unwrap_or(&f64::NAN);
            let approach = problem.closest_approach(&x);
            return Ok(Equilibrium {
                coarse,
                energy,
                density: energy / problem.area(),
                stress: problem.stress(&x),
                pairs: problem.pairs().to_vec(),
                closest_approach: approach,
                dofs: x,
                iterations,
            });
        }
    }
    Err(PeriodicError::Invalid(format!(
        "contact pairs did not settle after {} rebuilds",
        settings.max_pair_updates
    )))
}
