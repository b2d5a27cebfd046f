//! Force terms (seed 000 §4), one file each, and the [`Potential`] that sums them.
//!
//! Every term is a `rod::Stencil` (energy, gradient and exact Hessian on a fixed-size DOF
//! vector) placed on the global coordinates by its DOF indices ([`crate::state::DofMap`]) in
//! a [`solver::Terms`] container ([`Potential`] adds each term's [`TermKind`]); adding a
//! term is one new file, one [`TermKind`] and one `push` in [`build_terms`]:
//!
//! | term | file | stencil DOFs | source |
//! |---|---|---|---|
//! | gravity | [`gravity`] | `(x₀, u₀, x₁, u₁)` per segment | seed 000 §4 |
//! | yarn stretch | [`stretch`] | `(x₀, u₀, x₁, u₁)` per segment | seed 000 §4, physics notes |
//! | bending with jamming | [`bending`] | `(x₀, u₀, x₁, u₁, x₂, u₂)` per interior pass | seed 000 Eq. 1, §4.1 |
//! | stitch-contact length | [`stitch_length`] | `(u₀, u₁)` per yarn and stitch contact | seed 000 Eq. 6 |
//! | sliding friction (anchored springs) | [`friction`] | `u` per free sliding coordinate | seed 000 Eq. 5 |
//! | compression estimation at stacked nodes (gives friction its bound μλ; not a potential) | [`compression`] | — | seed 000 Eqs. 3–4, §4.3 |
//! | contact between adjacent loops (knits, off by default) | [`loop_contact`] | `(x_a, x_b)` per candidate node pair | seed 000 §4, ref. 6 |
//! | floor on a segment's material length (ours) | [`segment_floor`] | `(u₀, u₁)` per segment | — |
//! | yarn self-contact (ours; seed 002's barrier) | [`yarn_contact`] | `(x_a0, x_a1, x_b0, x_b1)` per close pair of segments not stitched together | seed 002 Eq. 7 |
//! | stitch wrapping (knits only) | [`wrapping`] | `(x₀, x₁, x₄, x₃)` per pair of opposite segments | seed 000 Eq. 2, Eqs. 7–13 |
//! | crossing shear with jamming (weaves only) | [`crossing_shear`] | `(x_a, x₀, x_b)` per crossing quadrant | ref. 6 (Cirio 2014) shear, seed 000 §4.1 jamming |
//! | sphere / plane / mesh obstacle contact (only with obstacles) | [`obstacle`] | `x` per node and obstacle; `x_a, x_b` per segment and mesh obstacle | seed 000 §5.2.1 (penalty, C²) |
//! | inertia, Rayleigh damping | [`quadratic`] | as the term they belong to | §4, [`crate::integrator`] |
//!
//! Not yet implemented: friction of parallel stacked yarns (no topology has them yet, see
//! [`friction`]).

pub mod bending;
pub mod compression;
pub mod crossing_shear;
pub mod friction;
pub mod gravity;
pub mod loop_contact;
pub mod obstacle;
pub mod quadratic;
pub mod segment_floor;
pub mod stitch_length;
pub mod stretch;
pub mod wrapping;
pub mod yarn_contact;

use crate::params::YarnParams;
use crate::state::DofMap;
use crate::topology::{FabricKind, Topology};
use crossing_shear::CrossingShearParams;
use friction::{AnchoredSpring, ParallelSpring};
use gravity::Gravity;
use loop_contact::LoopContact;
use rod::Stencil;
use segment_floor::SegmentFloor;
use solver::{RodTerm, Terms};
use stitch_length::StitchLength;
use wrapping::StitchWrap;

/// Which force terms a model assembles (only what the scene needs is built).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceSet {
    /// Gravity (seed 000 §4).
    pub gravity: bool,
    /// Yarn stretch.
    pub stretch: bool,
    /// Bending with jamming (Eq. 1).
    pub bending: bool,
    /// Stitch-contact length (Eq. 6).
    pub stitch_length: bool,
    /// Sliding friction with anchored springs (Eq. 5).
    pub friction: bool,
    /// Stitch wrapping (Eq. 2). Only knits have stitch contacts, so a weave never gets
    /// wrapping terms whatever this says.
    pub wrapping: bool,
    /// Crossing shear with shear jamming ([`crossing_shear`]). Only weaves have crossings,
    /// so a knit never gets crossing-shear terms whatever this says.
    pub crossing_shear: bool,
    /// Stiffness and jamming of the crossing shear (not in [`YarnParams`]: ref. 6's shear
    /// parameters, defaults documented on [`CrossingShearParams`]).
    pub crossing_shear_params: CrossingShearParams,
    /// Contact between adjacent loops ([`loop_contact`], knits only). Default off: it is
    /// inactive in the default layouts, and on settled free swatches it weakens the
    /// stockinette curl as much as the garter curl it was hoped to remove (measurements in
    /// [`loop_contact`]).
    pub loop_contact: bool,
    /// Floor on the material length of every segment ([`segment_floor`]; ours). Default
    /// on: without it a segment can drain until its nodes meet, which is what ended the
    /// stretched runs of the stability study at 5 ms steps and quasi-static stretches at
    /// 30 % (measured there), and Coulomb-consistent friction
    /// ([`crate::integrator::StepSettings::friction_return_mapping`]) drains segments
    /// within milliseconds without it.
    pub segment_floor: bool,
    /// Yarn self-contact between segments that are not stitched together
    /// ([`yarn_contact`], ours; parameters [`yarn_contact::YarnContact::for_yarn`]): without
    /// it nothing keeps a curling or folding fabric from passing through itself. Default on.
    pub yarn_contact: bool,
}

impl Default for ForceSet {
    /// Every implemented term.
    fn default() -> Self {
        Self {
            gravity: true,
            stretch: true,
            bending: true,
            stitch_length: true,
            friction: true,
            wrapping: true,
            crossing_shear: true,
            crossing_shear_params: CrossingShearParams::default(),
            loop_contact: false,
            segment_floor: true,
            yarn_contact: true,
        }
    }
}

/// The kind of a term of a [`Potential`] (for per-term energy shares).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TermKind {
    /// Gravity.
    Gravity,
    /// Yarn stretch.
    Stretch,
    /// Bending with jamming.
    Bending,
    /// Stitch-contact length.
    StitchLength,
    /// Sliding friction (anchored springs).
    Friction,
    /// Sliding friction between parallel stacked yarns (anchored springs on `Δu`, Eq. 5).
    ParallelFriction,
    /// Stitch wrapping.
    Wrapping,
    /// Crossing shear with jamming (weaves).
    CrossingShear,
    /// Obstacle contact (penalty).
    Obstacle,
    /// Contact between adjacent loops (penalty).
    LoopContact,
    /// Floor on a segment's material length (penalty).
    SegmentFloor,
    /// Yarn self-contact between segments not stitched together (barrier).
    YarnContact,
    /// Inertia (+ mass damping) of an implicit step.
    Inertia,
    /// Stiffness (Rayleigh β) damping of an implicit step.
    Damping,
}

/// A sum of force terms: a [`solver::Terms`] container (every term a `rod::Stencil` wrapped
/// in [`RodTerm`], on its global DOFs) with the [`TermKind`] of each term beside it. It is a
/// `solver::Problem` over all generalized coordinates; terms are summed in push order.
///
/// The stencil type of each kind: gravity [`Gravity`] (8 DOFs), stretch
/// [`rod::stretch::SlidingSegment`] (8), bending [`rod::bending::AngleBending`] (12), stitch
/// length [`StitchLength`] (2), friction [`AnchoredSpring`] (1), parallel friction
/// [`friction::ParallelSpring`] (2), wrapping [`StitchWrap`] (12;
/// positions of `q₀, q₁, q₄, q₃`), crossing shear [`crossing_shear::CrossingShear`] (9),
/// obstacle [`obstacle::ObstacleContact`] (3) or [`obstacle::MidpointContact`] (6), loop contact [`LoopContact`] (6), segment
/// floor [`SegmentFloor`] (2), inertia and damping [`quadratic::Quadratic<N>`] (as the term
/// they belong to).
#[derive(Clone, Debug)]
pub struct Potential {
    terms: Terms,
    kinds: Vec<TermKind>,
    /// The bound on material-length steps ([`Potential::bound_material_steps`]), if any.
    material_steps: Option<MaterialStepBound>,
}

/// A bound on how far one Newton step may shrink the material length `L = u₁ − u₀` of
/// segments ([`Potential::bound_material_steps`]).
#[derive(Clone, Debug)]
struct MaterialStepBound {
    /// The `(u₀, u₁)` DOFs of each bounded segment.
    segments: Vec<[usize; 2]>,
    /// The largest fraction of its length a segment may lose in one step, in `(0, 1)`.
    max_shrink: f64,
}

impl Potential {
    /// An empty potential over `n_dofs` coordinates.
    pub fn new(n_dofs: usize) -> Self {
        Self {
            terms: Terms::new(n_dofs),
            kinds: Vec::new(),
            material_steps: None,
        }
    }

    /// Bounds every Newton step on this potential ([`solver::Problem::max_step`]) so that no
    /// segment among `segments` (the DOFs `(u₀, u₁)` of its sliding coordinates) loses more
    /// than the fraction `max_shrink ∈ (0, 1)` of its material length `L = u₁ − u₀` in one
    /// step: the step fraction is `α_max = min over shrinking segments of
    /// max_shrink · L / (−ΔL)` (a fraction-to-the-boundary rule as in interior-point
    /// methods, Wächter & Biegler 2006, Eq. 15, on the constraint `L > 0`). `None` removes
    /// the bound. A segment that starts with `L ≤ 0` does not bound the step.
    pub fn bound_material_steps(&mut self, bound: Option<(Vec<[usize; 2]>, f64)>) {
        self.material_steps = bound.map(|(segments, max_shrink)| MaterialStepBound {
            segments,
            max_shrink,
        });
    }

    /// Appends the stencil `stencil` of kind `kind` on the global DOFs `dofs`; returns its
    /// index.
    pub fn push<S, const N: usize>(&mut self, kind: TermKind, stencil: S, dofs: [usize; N]) -> usize
    where
        S: Stencil<N> + Clone + Send + Sync + 'static,
    {
        self.kinds.push(kind);
        self.terms.push_stencil(stencil, dofs)
    }

    /// Removes every term from index `len` on.
    pub fn truncate(&mut self, len: usize) {
        self.terms.truncate(len);
        self.kinds.truncate(len);
    }

    /// Moves every term of `other` (same number of coordinates) to the end, in order (its
    /// material-step bound, if any, is not carried over).
    pub fn append(&mut self, other: Potential) {
        self.terms.append(other.terms);
        self.kinds.extend(other.kinds);
    }

    /// Errors if a term references a DOF ≥ the number of coordinates.
    pub fn check_dofs(&self) -> Result<(), String> {
        let n = self.terms.n_dofs();
        match (0..self.len()).find(|&k| self.dofs(k).iter().any(|&d| d >= n)) {
            Some(k) => Err(format!(
                "term {k} ({:?}) references a DOF ≥ {n}",
                self.kinds[k]
            )),
            None => Ok(()),
        }
    }

    /// The terms.
    pub fn terms(&self) -> &Terms {
        &self.terms
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// Whether there are no terms.
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// The kind of term `k`.
    pub fn kind(&self, k: usize) -> TermKind {
        self.kinds[k]
    }

    /// The kind of every term, in order.
    pub fn kinds(&self) -> &[TermKind] {
        &self.kinds
    }

    /// Number of terms of kind `kind`.
    pub fn count(&self, kind: TermKind) -> usize {
        self.kinds.iter().filter(|&&k| k == kind).count()
    }

    /// The global DOFs of term `k`.
    pub fn dofs(&self, k: usize) -> &[usize] {
        self.terms.dofs(k)
    }

    /// Term `k` as an `S` stencil on `N` DOFs, if it is one.
    pub fn get<S: Stencil<N> + Clone + Send + Sync + 'static, const N: usize>(
        &self,
        k: usize,
    ) -> Option<&S> {
        self.terms.get::<RodTerm<S, N>>(k).map(|t| &t.0)
    }

    /// Term `k` as a mutable `S` stencil on `N` DOFs, if it is one.
    pub fn get_mut<S: Stencil<N> + Clone + Send + Sync + 'static, const N: usize>(
        &mut self,
        k: usize,
    ) -> Option<&mut S> {
        self.terms.get_mut::<RodTerm<S, N>>(k).map(|t| &mut t.0)
    }

    /// Every `S` stencil on `N` DOFs with its index, in order.
    pub fn iter_of<S: Stencil<N> + Clone + Send + Sync + 'static, const N: usize>(
        &self,
    ) -> impl Iterator<Item = (usize, &S)> {
        self.terms
            .iter_of::<RodTerm<S, N>>()
            .map(|(k, t)| (k, &t.0))
    }

    /// Every `S` stencil on `N` DOFs, mutably, with its index and DOFs, in order.
    pub fn iter_mut_of<S: Stencil<N> + Clone + Send + Sync + 'static, const N: usize>(
        &mut self,
    ) -> impl Iterator<Item = (usize, &mut S, &[usize])> {
        self.terms
            .iter_mut_with_dofs_of::<RodTerm<S, N>>()
            .map(|(k, t, d)| (k, &mut t.0, d))
    }

    /// Term `k`, mutably (as a `solver` term: downcast to `RodTerm<S, N>` to change it).
    pub fn term_mut(&mut self, k: usize) -> &mut dyn solver::LocalEnergy {
        self.terms.term_mut(k)
    }

    /// Every term, mutably, in order, as a parallel iterator (per-step updates).
    pub fn par_iter_mut(
        &mut self,
    ) -> impl rayon::iter::IndexedParallelIterator<Item = &mut (dyn solver::LocalEnergy + 'static)>
    {
        self.terms.par_iter_mut()
    }

    /// Energy (J) of term `k` at the global coordinates `q`.
    pub fn term_energy(&self, k: usize, q: &[f64]) -> f64 {
        solver::Problem::stencil_energy(&self.terms, k, q)
    }

    /// Total energy (J) at `q`, summed in term order.
    pub fn energy(&self, q: &[f64]) -> f64 {
        (0..self.len()).map(|k| self.term_energy(k, q)).sum()
    }

    /// Energy (J) of each kind of term at `q`, in [`TermKind`] order (kinds without terms
    /// are left out).
    pub fn energy_by_kind(&self, q: &[f64]) -> Vec<(TermKind, f64)> {
        let mut out: Vec<(TermKind, f64)> = Vec::new();
        for (k, &kind) in self.kinds.iter().enumerate() {
            let e = self.term_energy(k, q);
            match out.iter_mut().find(|(k, _)| *k == kind) {
                Some((_, sum)) => *sum += e,
                None => out.push((kind, e)),
            }
        }
        out.sort_by_key(|(k, _)| *k);
        out
    }

    /// Gradient `∂V/∂q` (N for positions and sliding coordinates) at `q` over all
    /// coordinates, summed serially in term order.
    pub fn gradient(&self, q: &[f64]) -> Vec<f64> {
        let mut g = vec![0.0; self.terms.n_dofs()];
        let mut local = [0.0; solver::MAX_TERM_DOFS];
        for k in 0..self.len() {
            let d = self.dofs(k);
            let local = &mut local[..d.len()];
            self.terms.term(k).eval_at(q, d, None, local, None);
            for (&i, v) in d.iter().zip(local.iter()) {
                g[i] += v;
            }
        }
        g
    }
}

impl solver::Problem for Potential {
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
        self.terms.eval_stencil(k, x, grad, hess)
    }

    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        self.terms.stencil_energy(k, x)
    }

    fn max_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        let Some(bound) = &self.material_steps else {
            return f64::INFINITY;
        };
        bound
            .segments
            .iter()
            .filter_map(|&[a, b]| {
                let (length, change) = (x[b] - x[a], dx[b] - dx[a]);
                (length > 0.0 && change < 0.0).then(|| bound.max_shrink * length / -change)
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The obstacle-contact terms of `obstacles` for the yarns of `params` (one per node and
/// obstacle, and one per segment and mesh obstacle, [`obstacle`]); empty without obstacles.
/// Errors if an obstacle is invalid.
pub fn obstacle_terms(
    topology: &Topology,
    dofs: &DofMap,
    params: &YarnParams,
    obstacles: &[obstacle::Obstacle],
) -> Result<Potential, String> {
    let mut terms = Potential::new(dofs.n_dofs());
    let (nodes, midpoints) = obstacle::stencils(topology, dofs, params, obstacles)?;
    for (s, d) in nodes {
        terms.push(TermKind::Obstacle, s, d);
    }
    for (s, d) in midpoints {
        terms.push(TermKind::Obstacle, s, d);
    }
    Ok(terms)
}

/// The yarn self-contact terms ([`yarn_contact`]) of `contact` between the pairs of
/// `segments` within its search distance at the node `positions`. The simulator refreshes
/// them as the yarns move ([`crate::integrator::Simulator::step`]).
pub fn yarn_contact_terms(
    contact: &yarn_contact::YarnContact,
    segments: &yarn_contact::Segments,
    dofs: &DofMap,
    positions: &[rod::geometry::V3],
) -> Potential {
    let mut terms = Potential::new(dofs.n_dofs());
    for (s, d) in contact.stencils(segments, dofs, positions) {
        terms.push(TermKind::YarnContact, s, d);
    }
    terms
}

/// The stitch-wrapping terms of a knit (Eq. 2) with their position DOFs, in the order
/// [`build_terms`] adds them: per stitch contact, its pairs of [`wrapping::wrap_pairs`].
/// The rest length `L` of each is its contact's length at `q_rest`, its rest angle
/// [`crate::params::WrappingRest::rest_angle`] of the pair's sense and its angle at `q_rest`.
pub fn wrapping_stencils(
    topology: &Topology,
    dofs: &DofMap,
    params: &YarnParams,
    q_rest: &[f64],
) -> Vec<(StitchWrap, [usize; 12])> {
    let position = |n: usize| dofs.position(q_rest, n);
    let mut stencils = Vec::new();
    for sc in &topology.stitch_contacts {
        let sign = wrapping::rest_angle_sign(sc);
        let rest_length = (position(sc.nodes[1]) - position(sc.nodes[0])).norm();
        for nodes in wrapping::wrap_pairs(topology, sc).into_iter().flatten() {
            let d: [usize; 12] = std::array::from_fn(|k| dofs.x(nodes[k / 3]) + k % 3);
            let x: [f64; 12] = std::array::from_fn(|k| q_rest[d[k]]);
            let rest_angle = params.wrapping_rest.rest_angle(sign, StitchWrap::angle(&x));
            let wrap = StitchWrap {
                stiffness: params.wrapping_stiffness,
                rest_length,
                rest_angle,
            };
            stencils.push((wrap, d));
        }
    }
    stencils
}

/// The elastic and gravity terms of a fabric (everything but the per-step inertia and
/// damping), selected by `forces`. Rest lengths of stitch contacts (Eqs. 2 and 6) and the
/// initial friction anchors (Eq. 5; one per free sliding coordinate of a node with ≥ 2 yarns
/// that has a non-parallel contact, one per parallel pair of stacked heads) are
/// taken from the coordinates `q_rest` (normally the initial layout). Wrapping terms (knits
/// only) get their full rest angle ([`crate::params::WrappingRest`], from their angle at
/// `q_rest` and their sense [`wrapping::rest_angle_sign`]); the simulator ramps it in
/// ([`crate::integrator::StepSettings::wrapping_ramp_time`]). Yarn self-contact depends on
/// the state and is not built here ([`yarn_contact_terms`]). Crossing-shear
/// terms (weaves only) take their rest angles and lengths from `q_rest`. Obstacle terms are
/// not built here ([`obstacle_terms`]).
pub fn build_terms(
    topology: &Topology,
    dofs: &DofMap,
    params: &YarnParams,
    forces: &ForceSet,
    q_rest: &[f64],
) -> Potential {
    let mut terms = Potential::new(dofs.n_dofs());
    let gravity = Gravity {
        density: params.linear_density,
        g: params.gravity,
    };
    let stretch = stretch::stretch_stencil(params);
    let bend = bending::bending_stencil(params);
    for (y, i) in topology.segments() {
        let p = &topology.yarns[y].passes;
        let d = dofs.segment_dofs(p[i], p[i + 1]);
        if forces.gravity && gravity.g.norm() > 0.0 {
            terms.push(TermKind::Gravity, gravity, d);
        }
        if forces.stretch {
            terms.push(TermKind::Stretch, stretch, d);
        }
        if forces.segment_floor {
            let floor = SegmentFloor::for_yarn(params);
            terms.push(TermKind::SegmentFloor, floor, [d[3], d[7]]);
        }
    }
    if forces.bending && bend.stiffness > 0.0 {
        for (y, i) in topology.bends() {
            let p = &topology.yarns[y].passes;
            let (a, b, c) = (
                dofs.pass_dofs(p[i - 1]),
                dofs.pass_dofs(p[i]),
                dofs.pass_dofs(p[i + 1]),
            );
            let d = [
                a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], c[0], c[1], c[2], c[3],
            ];
            terms.push(TermKind::Bending, bend, d);
        }
    }
    if forces.stitch_length && params.stitch_length_stiffness > 0.0 {
        for sc in &topology.stitch_contacts {
            for strand in sc.strands() {
                // The sliding coordinates at q₀ and q₁ in yarn order (arc length increasing).
                let [a, b] = topology.strand_slots(strand).map(|(n, s)| dofs.u(n, s));
                let d = if strand.forward { [a, b] } else { [b, a] };
                let rest_length = q_rest[d[1]] - q_rest[d[0]];
                let stiffness = params.stitch_length_stiffness;
                let length = StitchLength {
                    stiffness,
                    rest_length,
                };
                terms.push(TermKind::StitchLength, length, d);
            }
        }
    }
    let knit = matches!(topology.kind, FabricKind::Knit(_));
    if forces.wrapping && knit && params.wrapping_stiffness > 0.0 {
        for (wrap, d) in wrapping_stencils(topology, dofs, params, q_rest) {
            terms.push(TermKind::Wrapping, wrap, d);
        }
    }
    let weave = matches!(topology.kind, FabricKind::Weave { .. });
    if forces.crossing_shear && weave && forces.crossing_shear_params.stiffness > 0.0 {
        let shear = crossing_shear::stencils(topology, dofs, &forces.crossing_shear_params, q_rest);
        for (s, d) in shear {
            terms.push(TermKind::CrossingShear, s, d);
        }
    }
    if forces.loop_contact && params.loop_contact_stiffness > 0.0 {
        let contact = LoopContact {
            stiffness: params.loop_contact_stiffness,
            distance: 2.0 * params.radius,
        };
        for [a, b] in loop_contact::candidate_pairs(topology) {
            let d: [usize; 6] = std::array::from_fn(|k| dofs.x([a, b][k / 3]) + k % 3);
            terms.push(TermKind::LoopContact, contact, d);
        }
    }
    if forces.friction && params.friction_stiffness > 0.0 {
        let stacks = topology.knit_stacks();
        for (n, node) in topology.nodes.iter().enumerate() {
            if node.passes.len() < 2 {
                continue;
            }
            // Slots with a non-parallel contact get their own spring (all slots of a weave
            // crossing or a two-yarn stitch); parallel pairs get one spring on Δu.
            let (own, pairs) = match &stacks[n] {
                Some((layers, parallel)) => friction_springs(layers, parallel),
                None => ((0..node.passes.len()).collect(), Vec::new()),
            };
            for slot in own {
                if !node.passes[slot].sliding_pinned {
                    let d = [dofs.u(n, slot)];
                    let spring = AnchoredSpring::new(params.friction_stiffness, q_rest[d[0]]);
                    terms.push(TermKind::Friction, spring, d);
                }
            }
            for [a, b] in pairs {
                if !(node.passes[a].sliding_pinned && node.passes[b].sliding_pinned) {
                    let d = [dofs.u(n, a), dofs.u(n, b)];
                    let anchor = ParallelSpring::delta(q_rest[d[0]], q_rest[d[1]]);
                    let spring = ParallelSpring::new(params.friction_stiffness, anchor);
                    terms.push(TermKind::ParallelFriction, spring, d);
                }
            }
        }
    }
    terms
}

/// The friction springs of a stack (layers front to back as slots, `parallel[i]` for the
/// contact between layers `i` and `i + 1`): the slots with a non-parallel contact, and the
/// parallel pairs `[near, far]` ordered from the stack's non-parallel end (the upper leg) —
/// so every far slot is the far end of exactly one pair ([`compression::slip_forces`]). The
/// parallel pairs of a stack form one chain from the upper leg's end
/// ([`Topology::knit_stacks`]: a stack with heads running opposite ways has none).
pub fn friction_springs(layers: &[usize], parallel: &[bool]) -> (Vec<usize>, Vec<[usize; 2]>) {
    let own = layers
        .iter()
        .enumerate()
        .filter(|&(i, _)| (i > 0 && !parallel[i - 1]) || (i < parallel.len() && !parallel[i]))
        .map(|(_, &s)| s)
        .collect();
    // The upper leg is at one end of the stack: front for knits, back for purls.
    let upper_first = parallel.first() == Some(&false);
    let pairs = parallel
        .iter()
        .enumerate()
        .filter(|&(_, &p)| p)
        .map(|(i, _)| {
            if upper_first {
                [layers[i], layers[i + 1]]
            } else {
                [layers[i + 1], layers[i]]
            }
        })
        .collect();
    (own, pairs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use solver::Problem;

    /// The material-length bound: the step fraction at which the first shrinking segment
    /// has lost `max_shrink` of its length; growing segments, segments that start inverted
    /// and an unbounded potential impose nothing.
    #[test]
    fn material_steps_stop_where_a_segment_has_lost_its_share() {
        let mut p = Potential::new(6);
        // Segments (0, 1): L = 1, shrinking at 4 per unit step; (2, 3): L = 2, shrinking at
        // 2; (4, 5): L = −1 (inverted), shrinking.
        let x = [0.0, 1.0, 0.0, 2.0, 1.0, 0.0];
        let dx = [1.0, -3.0, 0.0, -2.0, 0.0, -5.0];
        assert_eq!(p.max_step(&x, &dx), f64::INFINITY);
        p.bound_material_steps(Some((vec![[0, 1], [2, 3], [4, 5]], 0.5)));
        let alpha = p.max_step(&x, &dx);
        assert!((alpha - 0.125).abs() < 1e-15, "{alpha}");
        let length = |a: f64| (x[1] + a * dx[1]) - (x[0] + a * dx[0]);
        assert!((length(alpha) - 0.5).abs() < 1e-15);
        // Reversed, every segment grows.
        let back: Vec<f64> = dx.iter().map(|d| -d).collect();
        p.bound_material_steps(Some((vec![[0, 1], [2, 3]], 0.5)));
        assert_eq!(p.max_step(&x, &back), f64::INFINITY);
        p.bound_material_steps(None);
        assert_eq!(p.max_step(&x, &dx), f64::INFINITY);
    }
}
