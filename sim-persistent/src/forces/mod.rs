//! Force terms (seed 000 §4), one file each, and the [`Potential`] that sums them.
//!
//! Every term is a `rod::Stencil` (energy, gradient and exact Hessian on a fixed-size DOF
//! vector) placed on the global coordinates by its DOF indices ([`crate::state::DofMap`]):
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
//! | stitch wrapping (knits only) | [`wrapping`] | `(x₀, x₁, x₄, x₃)` per pair of opposite segments | seed 000 Eq. 2, Eqs. 7–13 |
//! | crossing shear with jamming (weaves only) | [`crossing_shear`] | `(x_a, x₀, x_b)` per crossing quadrant | ref. 6 (Cirio 2014) shear, seed 000 §4.1 jamming |
//! | sphere / plane obstacle contact (only with obstacles) | [`obstacle`] | `x` per node and obstacle | seed 000 §5.2.1 (penalty, C²) |
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

use crate::params::YarnParams;
use crate::state::{DofMap, gather};
use crate::topology::{FabricKind, Topology};
use crossing_shear::{CrossingShear, CrossingShearParams};
use friction::AnchoredSpring;
use gravity::Gravity;
use loop_contact::LoopContact;
use obstacle::ObstacleContact;
use quadratic::Quadratic;
use rod::Stencil;
use rod::bending::AngleBending;
use rod::stretch::SlidingSegment;
use segment_floor::SegmentFloor;
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
        }
    }
}

/// The kind of a [`Term`] (for per-term energy shares).
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
    /// Inertia (+ mass damping) of an implicit step.
    Inertia,
    /// Stiffness (Rayleigh β) damping of an implicit step.
    Damping,
}

/// One stencil with its global DOF indices.
#[derive(Clone, Debug, PartialEq)]
pub enum Term {
    /// Gravity on a segment.
    Gravity(Gravity, [usize; 8]),
    /// Stretch of a segment.
    Stretch(SlidingSegment, [usize; 8]),
    /// Bending at an interior pass.
    Bending(AngleBending, [usize; 12]),
    /// Stitch-contact length of one yarn.
    StitchLength(StitchLength, [usize; 2]),
    /// Friction spring of one sliding coordinate.
    Friction(AnchoredSpring, [usize; 1]),
    /// Stitch wrapping of one pair of opposite segments (positions of `q₀, q₁, q₄, q₃`).
    Wrapping(StitchWrap, [usize; 12]),
    /// Shear of one crossing quadrant (positions of the weft neighbour, the crossing node
    /// and the warp neighbour).
    CrossingShear(CrossingShear, [usize; 9]),
    /// Penalty contact of one node with one obstacle (its position).
    Obstacle(ObstacleContact, [usize; 3]),
    /// Contact penalty of one pair of nodes on adjacent loops (their positions).
    LoopContact(LoopContact, [usize; 6]),
    /// Material-length floor of one segment (its two sliding coordinates).
    SegmentFloor(SegmentFloor, [usize; 2]),
    /// Inertia of a segment (boxed: the per-step matrices dwarf the other variants).
    Inertia(Box<Quadratic<8>>, [usize; 8]),
    /// Stiffness damping of a 1-DOF term.
    Damping1(Box<Quadratic<1>>, [usize; 1]),
    /// Stiffness damping of a 2-DOF term.
    Damping2(Box<Quadratic<2>>, [usize; 2]),
    /// Stiffness damping of an 8-DOF term.
    Damping8(Box<Quadratic<8>>, [usize; 8]),
    /// Stiffness damping of a 12-DOF term.
    Damping12(Box<Quadratic<12>>, [usize; 12]),
    /// Stiffness damping of a 9-DOF term (crossing shear).
    Damping9(Box<Quadratic<9>>, [usize; 9]),
}

/// Runs `$body` with `$s` bound to the stencil and `$d` to its DOF array, for any variant.
macro_rules! with_stencil {
    ($term:expr, $s:ident, $d:ident => $body:expr) => {
        match $term {
            Term::Gravity($s, $d) => $body,
            Term::Stretch($s, $d) => $body,
            Term::Bending($s, $d) => $body,
            Term::StitchLength($s, $d) => $body,
            Term::Friction($s, $d) => $body,
            Term::Wrapping($s, $d) => $body,
            Term::CrossingShear($s, $d) => $body,
            Term::Obstacle($s, $d) => $body,
            Term::LoopContact($s, $d) => $body,
            Term::SegmentFloor($s, $d) => $body,
            Term::Inertia($s, $d) => $body,
            Term::Damping1($s, $d) => $body,
            Term::Damping2($s, $d) => $body,
            Term::Damping8($s, $d) => $body,
            Term::Damping12($s, $d) => $body,
            Term::Damping9($s, $d) => $body,
        }
    };
}

impl Term {
    /// The term's global DOF indices.
    pub fn dofs(&self) -> &[usize] {
        with_stencil!(self, _s, d => d.as_slice())
    }

    /// The term's kind.
    pub fn kind(&self) -> TermKind {
        match self {
            Term::Gravity(..) => TermKind::Gravity,
            Term::Stretch(..) => TermKind::Stretch,
            Term::Bending(..) => TermKind::Bending,
            Term::StitchLength(..) => TermKind::StitchLength,
            Term::Friction(..) => TermKind::Friction,
            Term::Wrapping(..) => TermKind::Wrapping,
            Term::CrossingShear(..) => TermKind::CrossingShear,
            Term::Obstacle(..) => TermKind::Obstacle,
            Term::LoopContact(..) => TermKind::LoopContact,
            Term::SegmentFloor(..) => TermKind::SegmentFloor,
            Term::Inertia(..) => TermKind::Inertia,
            Term::Damping1(..)
            | Term::Damping2(..)
            | Term::Damping8(..)
            | Term::Damping9(..)
            | Term::Damping12(..) => TermKind::Damping,
        }
    }

    /// Energy (J) at the global coordinates `q`.
    pub fn energy(&self, q: &[f64]) -> f64 {
        with_stencil!(self, s, d => s.energy(&gather(q, d)))
    }

    /// Overwrites `target`, the damping term made by [`Term::damping_form`] for this term,
    /// with the form at `q` (no allocation). Returns `false` (and leaves `target` alone) if
    /// `target` is not this term's damping form.
    pub fn update_damping_form(&self, q: &[f64], factor: f64, target: &mut Term) -> bool {
        /// `project`: whether the Hessian can be indefinite (the Eq. 5 and Eq. 6 springs
        /// have constant PSD Hessians, so their costly eigen-projection is skipped).
        fn fill<const N: usize>(
            s: &impl Stencil<N>,
            d: &[usize; N],
            q: &[f64],
            factor: f64,
            project: bool,
            out: &mut Quadratic<N>,
        ) {
            let local = gather(q, d);
            let mut h = s.eval(&local).hessian;
            if project {
                rod::spd::project_spd_matrix(&mut h);
            }
            out.matrix = factor * h;
            out.center = local;
        }
        match (self, target) {
            (Term::Stretch(s, d), Term::Damping8(f, e)) if d == e => fill(s, d, q, factor, true, f),
            (Term::Bending(s, d), Term::Damping12(f, e)) if d == e => {
                fill(s, d, q, factor, true, f)
            }
            (Term::Wrapping(s, d), Term::Damping12(f, e)) if d == e => {
                fill(s, d, q, factor, true, f)
            }
            (Term::CrossingShear(s, d), Term::Damping9(f, e)) if d == e => {
                fill(s, d, q, factor, true, f)
            }
            (Term::StitchLength(s, d), Term::Damping2(f, e)) if d == e => {
                fill(s, d, q, factor, false, f)
            }
            (Term::Friction(s, d), Term::Damping1(f, e)) if d == e => {
                fill(s, d, q, factor, false, f)
            }
            _ => return false,
        }
        true
    }

    /// The stiffness-damping form of this term at `q` (`(β/h) K⁺(q)` centred at `q`), or
    /// `None` for terms that are not elastic (gravity, inertia, damping).
    pub fn damping_form(&self, q: &[f64], factor: f64) -> Option<Term> {
        let mut target = match self {
            Term::Stretch(_, d) => Term::Damping8(Box::new(Quadratic::zero()), *d),
            Term::Bending(_, d) | Term::Wrapping(_, d) => {
                Term::Damping12(Box::new(Quadratic::zero()), *d)
            }
            Term::StitchLength(_, d) => Term::Damping2(Box::new(Quadratic::zero()), *d),
            Term::CrossingShear(_, d) => Term::Damping9(Box::new(Quadratic::zero()), *d),
            Term::Friction(_, d) => Term::Damping1(Box::new(Quadratic::zero()), *d),
            _ => return None,
        };
        self.update_damping_form(q, factor, &mut target);
        Some(target)
    }
}

/// Energy (J) of each kind among `terms` at `q`, in [`TermKind`] order (kinds without terms
/// are left out).
pub fn energy_by_kind(terms: &[Term], q: &[f64]) -> Vec<(TermKind, f64)> {
    let mut out: Vec<(TermKind, f64)> = Vec::new();
    for t in terms {
        let e = t.energy(q);
        match out.iter_mut().find(|(k, _)| *k == t.kind()) {
            Some((_, sum)) => *sum += e,
            None => out.push((t.kind(), e)),
        }
    }
    out.sort_by_key(|(k, _)| *k);
    out
}

/// Gradient `∂V/∂q` (N for positions and sliding coordinates) of the sum of `terms` at `q`,
/// over all `n_dofs` coordinates, summed serially in term order.
pub fn gradient(terms: &[Term], q: &[f64], n_dofs: usize) -> Vec<f64> {
    let mut g = vec![0.0; n_dofs];
    for t in terms {
        with_stencil!(t, s, d => {
            let (_, local) = s.energy_and_gradient(&gather(q, d));
            for (&i, v) in d.iter().zip(local.iter()) {
                g[i] += v;
            }
        })
    }
    g
}

/// The sum of a list of terms: a `solver::Problem` over all generalized coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Potential {
    /// The terms, in assembly order.
    pub terms: Vec<Term>,
    n_dofs: usize,
}

impl Potential {
    /// A potential over `n_dofs` coordinates. Errors if a term references a DOF ≥ `n_dofs`.
    pub fn new(n_dofs: usize, terms: Vec<Term>) -> Result<Self, String> {
        if let Some(t) = terms.iter().find(|t| t.dofs().iter().any(|&d| d >= n_dofs)) {
            return Err(format!("term {t:?} references a DOF ≥ {n_dofs}"));
        }
        Ok(Self { terms, n_dofs })
    }

    /// Total energy (J) at `q`, summed in term order.
    pub fn energy(&self, q: &[f64]) -> f64 {
        self.terms.iter().map(|t| t.energy(q)).sum()
    }

    /// Energy (J) of each kind of term at `q` (kinds without terms are left out).
    pub fn energy_by_kind(&self, q: &[f64]) -> Vec<(TermKind, f64)> {
        energy_by_kind(&self.terms, q)
    }
}

impl solver::Problem for Potential {
    fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    fn n_stencils(&self) -> usize {
        self.terms.len()
    }

    fn stencil_dofs(&self, k: usize) -> &[usize] {
        self.terms[k].dofs()
    }

    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        with_stencil!(&self.terms[k], s, d => solver::eval_rod_stencil(s, d, x, grad, hess))
    }

    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        self.terms[k].energy(x)
    }
}

/// The obstacle-contact terms of `obstacles` for the yarns of `params` (one per node and
/// obstacle, [`obstacle`]); empty without obstacles. Errors if an obstacle is invalid.
pub fn obstacle_terms(
    topology: &Topology,
    dofs: &DofMap,
    params: &YarnParams,
    obstacles: &[obstacle::Obstacle],
) -> Result<Vec<Term>, String> {
    Ok(obstacle::stencils(topology, dofs, params, obstacles)?
        .into_iter()
        .map(|(s, d)| Term::Obstacle(s, d))
        .collect())
}

/// The elastic and gravity terms of a fabric (everything but the per-step inertia and
/// damping), selected by `forces`. Rest lengths of stitch contacts (Eqs. 2 and 6) and the
/// initial friction anchors (Eq. 5; one per free sliding coordinate of a node with ≥ 2 yarns) are
/// taken from the coordinates `q_rest` (normally the initial layout). Wrapping terms (knits
/// only) get their full rest angle `± ψ₀` ([`wrapping::rest_angle_sign`]); the simulator
/// ramps it in ([`crate::integrator::StepSettings::wrapping_ramp_time`]). Crossing-shear
/// terms (weaves only) take their rest angles and lengths from `q_rest`. Obstacle terms are
/// not built here ([`obstacle_terms`]).
pub fn build_terms(
    topology: &Topology,
    dofs: &DofMap,
    params: &YarnParams,
    forces: &ForceSet,
    q_rest: &[f64],
) -> Vec<Term> {
    let mut terms = Vec::new();
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
            terms.push(Term::Gravity(gravity, d));
        }
        if forces.stretch {
            terms.push(Term::Stretch(stretch, d));
        }
        if forces.segment_floor {
            terms.push(Term::SegmentFloor(
                SegmentFloor::for_yarn(params),
                [d[3], d[7]],
            ));
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
            terms.push(Term::Bending(bend, d));
        }
    }
    if forces.stitch_length && params.stitch_length_stiffness > 0.0 {
        for sc in &topology.stitch_contacts {
            for &y in &sc.yarns {
                let slot = |n: usize| {
                    topology.nodes[n]
                        .passes
                        .iter()
                        .position(|p| p.yarn == y)
                        .expect("a stitch contact's yarn passes through its nodes")
                };
                let d = [
                    dofs.u(sc.nodes[0], slot(sc.nodes[0])),
                    dofs.u(sc.nodes[1], slot(sc.nodes[1])),
                ];
                let rest_length = q_rest[d[1]] - q_rest[d[0]];
                terms.push(Term::StitchLength(
                    StitchLength {
                        stiffness: params.stitch_length_stiffness,
                        rest_length,
                    },
                    d,
                ));
            }
        }
    }
    let knit = matches!(topology.kind, FabricKind::Knit(_));
    if forces.wrapping && knit && params.wrapping_stiffness > 0.0 {
        let position = |n: usize| dofs.position(q_rest, n);
        for sc in &topology.stitch_contacts {
            let rest_angle = wrapping::rest_angle_sign(sc) * params.wrapping_rest_angle;
            let rest_length = (position(sc.nodes[1]) - position(sc.nodes[0])).norm();
            for nodes in wrapping::wrap_pairs(topology, sc).into_iter().flatten() {
                let d: [usize; 12] = std::array::from_fn(|k| dofs.x(nodes[k / 3]) + k % 3);
                terms.push(Term::Wrapping(
                    StitchWrap {
                        stiffness: params.wrapping_stiffness,
                        rest_length,
                        rest_angle,
                    },
                    d,
                ));
            }
        }
    }
    let weave = matches!(topology.kind, FabricKind::Weave { .. });
    if forces.crossing_shear && weave && forces.crossing_shear_params.stiffness > 0.0 {
        let shear = crossing_shear::stencils(topology, dofs, &forces.crossing_shear_params, q_rest);
        terms.extend(shear.into_iter().map(|(s, d)| Term::CrossingShear(s, d)));
    }
    if forces.loop_contact && params.loop_contact_stiffness > 0.0 {
        let contact = LoopContact {
            stiffness: params.loop_contact_stiffness,
            distance: 2.0 * params.radius,
        };
        for [a, b] in loop_contact::candidate_pairs(topology) {
            let d: [usize; 6] = std::array::from_fn(|k| dofs.x([a, b][k / 3]) + k % 3);
            terms.push(Term::LoopContact(contact, d));
        }
    }
    if forces.friction && params.friction_stiffness > 0.0 {
        for (n, node) in topology.nodes.iter().enumerate() {
            if node.passes.len() < 2 {
                continue;
            }
            for (slot, p) in node.passes.iter().enumerate() {
                if !p.sliding_pinned {
                    let d = [dofs.u(n, slot)];
                    let spring = AnchoredSpring::new(params.friction_stiffness, q_rest[d[0]]);
                    terms.push(Term::Friction(spring, d));
                }
            }
        }
    }
    terms
}
