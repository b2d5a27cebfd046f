//! Implicit (backward) Euler time stepping as one Newton minimization per step (seed 000 §5:
//! "implicit-integration algorithm proposed in" ref. 6, Cirio et al. 2014; time step 1 ms).
//!
//! With step `h`, coordinates `qₙ`, velocities `vₙ`, Rayleigh damping `D = α M + β K` and the
//! potential `V` of [`crate::forces`], backward Euler
//!
//! ```text
//! M (vₙ₊₁ − vₙ)/h = −∇V(qₙ₊₁) − D vₙ₊₁,     qₙ₊₁ = qₙ + h vₙ₊₁
//! ```
//!
//! is the stationarity condition of the incremental potential
//!
//! ```text
//! Φ(q) = 1/(2h²) (q − q̂)ᵀ M (q − q̂) + 1/(2h) (q − qₙ)ᵀ D (q − qₙ) + V(q),   q̂ = qₙ + h vₙ,
//! ```
//!
//! which [`solver::NewtonSolver`] minimizes (backtracking line search, diagonal shift when
//! the Hessian is indefinite, Dirichlet DOFs for pinned positions and pinned sliding
//! coordinates; the sparsity pattern and symbolic factorization are built once and reused
//! every step).
//!
//! **Documented choices.**
//! - *Lagged mass matrix.* The state-dependent segment mass matrix
//!   ([`crate::state::segment_mass_matrix`]) is evaluated at `qₙ` and frozen over the step.
//! - *Velocity-quadratic terms dropped.* Lagrange's equations for `T = ½ q̇ᵀ M(q) q̇` add
//!   `Ṁ q̇ − ½ ∂(q̇ᵀ M q̇)/∂q`; we drop them. Their power is
//!   `q̇ᵀ(Ṁq̇ − ½ ∂(q̇ᵀMq̇)/∂q) = ½ q̇ᵀṀq̇`, exactly what `d/dt (½ q̇ᵀMq̇)` gains from the
//!   changing `M`, so without them `T + V` drifts at a rate cubic in the velocity (small at
//!   cloth speeds), on top of backward Euler's O(h) numerical dissipation. The free-swatch
//!   test measures the total drift and its decrease with `h`.
//! - *Friction.* The anchored springs of Eq. 5 with the slip force `μ λ`, λ *lagged*:
//!   estimated ([`crate::forces::compression`]) at the state at the start of the (sub)step,
//!   so that it does not change during the Newton solve (a static solve uses its
//!   equilibrium instead and always updates the anchors explicitly,
//!   [`Simulator::solve_static`]). By default the anchors move only after the step, as in
//!   the paper ([`crate::forces::friction::AnchoredSpring::update_anchor`]), and friction
//!   grows with the step. With [`StepSettings::friction_return_mapping`] > 0 the stick/slip
//!   decision is implicit, a return mapping: the step is re-solved with each coordinate
//!   either sticking (spring) or slipping (constant Coulomb force) until no coordinate
//!   changes mode ([`crate::forces::friction`]); then the slipped anchors move to their
//!   maximal stick positions.
//! - *Damping.* `D = α M(qₙ) + β K⁺(qₙ)`, with `K⁺` the per-stencil PSD-projected Hessian of
//!   the elastic terms at the start of the step (so damping is dissipative), both frozen over
//!   the step like `M`. Optionally `K⁺` is only recomputed every
//!   [`StepSettings::damping_refresh_steps`] steps (its per-stencil eigen-projections are
//!   the largest part of a step's setup).
//! - *Linear solver and linearization.* The Newton system is solved by sparse Cholesky
//!   (default) or preconditioned conjugate gradients (`StepSettings::newton.linear_solver`);
//!   [`StepSettings::linearized_implicit_euler`] stops after one Newton iteration
//!   (linearized backward Euler, as in seed 000's ref. 6), damped by the line search and a
//!   bound on how far the step may shrink segments ([`StepSettings::max_material_shrink`]),
//!   reporting the residual it leaves.
//! - *Step halving.* A step whose Newton solve fails (far from the minimizer, e.g. the first
//!   undamped step from a layout that is not at rest) is replaced by two half steps,
//!   recursively ([`StepSettings::max_halvings`]); the state only changes on success.
//! - *Wrapping ramp.* The layout starts with unwrapped stitch contacts (ψ ≈ 0; a flat layout
//!   cannot be wrapped uniformly, see [`crate::forces::wrapping`]). Each wrapping term's rest
//!   angle therefore moves from the layout's angle ψ_L to its target ψ₀ as
//!   `ψ_L + s(t/T) (ψ₀ − ψ_L)`, `s(λ) = 3λ² − 2λ³` (smoothstep, no jump in the rest angle's
//!   rate at either end), `T` = [`StepSettings::wrapping_ramp_time`], evaluated at the end
//!   of each (sub)step; the wrapping energy is zero at the layout. Without the ramp (`T = 0`)
//!   every contact would get a quarter-turn torque at once.
//! - *Contact ramp.* A layout can start with segments that are not stitched together closer
//!   than the yarn diameter (the Table 1 layouts: adjacent stitch contacts' axes 0.65 d
//!   apart), where yarn self-contact ([`crate::forces::yarn_contact`]) would start deep in
//!   its barrier and the first step would be an explosion. Over the same settling phase the
//!   contact radii therefore grow from `ρ₀ R` to `R`, `ρ(t) = ρ₀ + s(t/T) (1 − ρ₀)`, with
//!   `ρ₀ = min(1, 0.9 D_min/2R)` and `D_min` the closest such pair of the layout: the
//!   contact energy is zero at the layout, and the fabric is pushed apart as smoothly as
//!   the stitches wrap. A layout with every pair at least `2R/0.9` apart has no ramp.
//!   Pairs the layout puts through each other (closer than
//!   [`YarnContact::crossing_distance`], R: the leaning legs of decreases in the flat
//!   layouts of shaped and lace charts) are excluded from contact for the run
//!   ([`crate::forces::yarn_contact::Segments::exclude_crossed`],
//!   [`Simulator::crossed_contact_pairs`]) and do not set `D_min`.

mod settings;
mod snapshot;
mod step;

pub use settings::{
    CARRIED_SHIFT_PROBE_INTERVAL, LINEARIZED_MAX_SHRINK, SimError, StepReport, StepSettings,
};
pub use snapshot::Snapshot;

use crate::forces::compression::{CompressionEstimator, NodeCompression};
use crate::forces::friction::{AnchoredSpring, ParallelSpring};
use crate::forces::obstacle::Obstacle;
use crate::forces::quadratic::{DampingSource, Quadratic};
use crate::forces::wrapping::StitchWrap;
use crate::forces::yarn_contact::{Segments, YarnContact};
use crate::forces::{ForceSet, Potential, TermKind, build_terms};
use crate::layout::Layout;
use crate::params::YarnParams;
use crate::state::{DofMap, State, kinetic_energy};
use crate::topology::Topology;
use rod::geometry::V3;
use solver::{Concat, NewtonReport, NewtonSettings, NewtonSolver};

/// A fabric under implicit Euler time stepping (see the module documentation).
#[derive(Clone)]
pub struct Simulator {
    topology: Topology,
    dofs: DofMap,
    params: YarnParams,
    settings: StepSettings,
    /// The elastic and gravity terms (obstacle terms at their end).
    elastic: Potential,
    /// The terms of the backward Euler step: one inertia term per segment (`segment_dofs`),
    /// then the Rayleigh-β damping forms of the elastic terms listed in `damped`.
    step: Potential,
    segment_dofs: Vec<[usize; 8]>,
    damped: Vec<DampingSource>,
    /// Wrapping terms under the rest-angle ramp: (term index, layout angle ψ_L, target ψ₀).
    wrap_ramp: Vec<(usize, f64, f64)>,
    /// Whether the wrapping rest angles come from a reference layout
    /// ([`Simulator::set_wrapping_reference`]).
    wrap_reference: bool,
    fixed: Vec<bool>,
    state: State,
    /// The Newton solver of the step (cached sparsity pattern and factorization); a clone
    /// rebuilds it at its first step.
    solver: SolverCache,
    time: f64,
    /// The Rayleigh-β damping matrices: (number of (sub)steps they were used in, the
    /// factor β/h they hold); `None` before the first step.
    damping_built: Option<(usize, f64)>,
    /// Compression estimation for the Coulomb bound of friction (`None` without friction
    /// springs or with a constant slip force).
    compression: Option<CompressionEstimator>,
    /// The force terms the simulator was built with (to rebuild them when contacts break).
    forces: ForceSet,
    /// The rest state the terms were built from (the layout), carried through contact
    /// breaking.
    q_rest: Vec<f64>,
    /// The obstacles added so far.
    obstacles: Vec<Obstacle>,
    /// The Verlet list of yarn self-contact pairs (its terms end `elastic`).
    contact: ContactList,
}

/// The clearance of the contact ramp's start: at the layout the closest pair of segments in
/// contact is at `1/0.9` times the scaled contact distance (module documentation, *contact
/// ramp*).
const CONTACT_RAMP_CLEARANCE: f64 = 0.9;

/// The yarn self-contact terms at the end of [`Simulator::elastic`] and where the nodes were
/// when their pairs were searched ([`crate::forces::yarn_contact`]).
#[derive(Clone, Debug)]
struct ContactList {
    /// The contact parameters (`None` without [`ForceSet::yarn_contact`]); a search again
    /// once a node has moved half their margin.
    contact: Option<YarnContact>,
    /// The segments of the topology.
    segments: Segments,
    /// Index of the first contact term in `elastic` (its length when there are none).
    start: usize,
    /// Node positions at the last search (empty: search at the next refresh).
    searched_at: Vec<V3>,
    /// The scale ρ₀ of the contact radii at `t = 0` (1: no contact ramp; module
    /// documentation, *contact ramp*).
    start_scale: f64,
    /// How many pairs the layout put through each other (excluded from contact,
    /// [`Segments::exclude_crossed`]).
    crossed: usize,
}

/// Everything [`Simulator::assemble`] builds a simulator from.
struct Parts {
    topology: Topology,
    dofs: DofMap,
    state: State,
    q_rest: Vec<f64>,
    fixed: Vec<bool>,
    params: YarnParams,
    forces: ForceSet,
    settings: StepSettings,
    obstacles: Vec<Obstacle>,
    /// Simulated time (s): animated obstacles are rebuilt where they are then.
    time: f64,
}

/// A lazily built Newton solver that clones as "not built yet".
#[derive(Default)]
struct SolverCache(Option<NewtonSolver>);

impl Clone for SolverCache {
    fn clone(&self) -> Self {
        Self(None)
    }
}

impl Simulator {
    /// A simulator at rest in `layout`, with the force terms `forces`. Sliding coordinates the
    /// topology pins (yarn ends, one-yarn nodes) are fixed; node positions are free until
    /// [`pin_nodes`](Self::pin_nodes).
    pub fn new(
        topology: Topology,
        layout: &Layout,
        params: YarnParams,
        forces: ForceSet,
        settings: StepSettings,
    ) -> Result<Self, SimError> {
        validate_input(&topology, layout, &params, &forces, &settings)?;
        let dofs = DofMap::new(&topology);
        let state = State::from_layout(&topology, &dofs, layout);
        let mut fixed = vec![false; dofs.n_dofs()];
        for (n, node) in topology.nodes.iter().enumerate() {
            for (s, p) in node.passes.iter().enumerate() {
                if p.sliding_pinned {
                    fixed[dofs.u(n, s)] = true;
                }
            }
        }
        let q_rest = state.q.clone();
        let parts = Parts {
            topology,
            dofs,
            state,
            q_rest,
            fixed,
            params,
            forces,
            settings,
            obstacles: Vec::new(),
            time: 0.0,
        };
        Self::assemble(parts, true)
    }

    /// Builds the terms, step forms and compression estimator of `parts`. With `ramp` the
    /// wrapping rest angles start at the current angles (the ramp of
    /// [`StepSettings::wrapping_ramp_time`]); without it at their full values.
    fn assemble(parts: Parts, ramp: bool) -> Result<Self, SimError> {
        let Parts {
            topology,
            dofs,
            state,
            q_rest,
            fixed,
            params,
            forces,
            settings,
            obstacles,
            time,
        } = parts;
        let contact = ContactList {
            contact: forces
                .yarn_contact
                .then(|| YarnContact::for_yarn(params.radius, params.bending_stiffness())),
            segments: Segments::new(&topology),
            start: 0,
            searched_at: Vec::new(),
            start_scale: 1.0,
            crossed: 0,
        };
        let mut elastic = build_terms(&topology, &dofs, &params, &forces, &q_rest);
        elastic.check_dofs().map_err(SimError::Invalid)?;
        let mut wrap_ramp = Vec::new();
        for (k, wrap, d) in elastic.iter_mut_of::<StitchWrap, 12>() {
            let x: [f64; 12] = std::array::from_fn(|i| state.q[d[i]]);
            let start = if ramp {
                StitchWrap::angle(&x)
            } else {
                wrap.rest_angle
            };
            wrap_ramp.push((k, start, wrap.rest_angle));
            if ramp && settings.wrapping_ramp_time > 0.0 {
                wrap.rest_angle = start;
            }
        }
        let segment_dofs: Vec<[usize; 8]> = topology
            .segments()
            .map(|(y, i)| {
                let p = &topology.yarns[y].passes;
                dofs.segment_dofs(p[i], p[i + 1])
            })
            .collect();
        let mut step = Potential::new(dofs.n_dofs());
        for d in &segment_dofs {
            step.push(TermKind::Inertia, Quadratic::<8>::zero(), *d);
        }
        step.bound_material_steps(material_step_bound(&settings, &segment_dofs));
        let mut damped = Vec::new();
        if settings.rayleigh_beta > 0.0 {
            for k in 0..elastic.len() {
                // Under the return mapping a slipping coordinate feels only the Coulomb
                // force: a β-damping form of its spring would brake it by β k_f u̇.
                let friction = matches!(
                    elastic.kind(k),
                    TermKind::Friction | TermKind::ParallelFriction
                );
                if friction && settings.friction_return_mapping > 0 {
                    continue;
                }
                damped.extend(DampingSource::push_form(
                    &elastic, k, &state.q, 0.0, &mut step,
                ));
            }
        }
        let has_friction =
            elastic.count(TermKind::Friction) > 0 || elastic.count(TermKind::ParallelFriction) > 0;
        let compression = if has_friction && params.friction_max_force.is_none() {
            Some(
                CompressionEstimator::new(&topology, &dofs)
                    .map_err(|e| SimError::Invalid(e.to_string()))?,
            )
        } else {
            None
        };
        let mut sim = Self {
            topology,
            dofs,
            params,
            forces,
            settings,
            elastic,
            step,
            segment_dofs,
            damped,
            wrap_ramp,
            wrap_reference: false,
            fixed,
            state,
            q_rest,
            obstacles: Vec::new(),
            contact,
            solver: SolverCache::default(),
            time,
            damping_built: None,
            compression,
        };
        sim.contact.start = sim.elastic.len();
        sim.add_obstacles(&obstacles)?;
        if let Some(contact) = sim.contact.contact {
            // At a rebuild (contact breaking) the pairs excluded at the start are the ones
            // still this close, as contact kept every other pair apart.
            let positions = sim.positions();
            sim.contact.crossed = sim.contact.segments.exclude_crossed(
                &positions,
                contact.crossing_distance(),
                contact.min_arc_separation,
            );
            if ramp && sim.settings.wrapping_ramp_time > 0.0 {
                sim.contact.start_scale = sim.contact_start_scale();
            }
        }
        sim.refresh_contact(true);
        sim.apply_contact_ramp(sim.time);
        Ok(sim)
    }

    /// Takes the stitch-wrapping rest angles from `reference` instead of the layout the
    /// simulator was built from ([`crate::params::WrappingRest::rest_angle`] of each pair's
    /// angle in `reference`; rest lengths stay the layout's): a layout that starts wrapped,
    /// such as a rest-shape compensated one ([`crate::rest_shape`]), keeps the rest state of
    /// the flat layout its shapes were relaxed against. The ramp then goes from the current
    /// angles (or, without a ramp or past it, jumps) to these. Errors if `reference` does not
    /// match the topology. Contact breaking afterwards is refused ([`Simulator::break_passes`]
    /// rebuilds the terms from the layout).
    pub fn set_wrapping_reference(&mut self, reference: &Layout) -> Result<(), SimError> {
        let topology = &self.topology;
        if reference.positions.len() != topology.nodes.len()
            || reference.sliding.len() != topology.nodes.len()
            || (topology.nodes.iter().zip(&reference.sliding))
                .any(|(n, s)| n.passes.len() != s.len())
        {
            return Err(SimError::Invalid(
                "the wrapping reference layout does not match the topology".into(),
            ));
        }
        if !(self.forces.wrapping && self.params.wrapping_stiffness > 0.0) {
            return Ok(());
        }
        let q_ref = State::from_layout(topology, &self.dofs, reference).q;
        let stencils = crate::forces::wrapping_stencils(topology, &self.dofs, &self.params, &q_ref);
        let targets: Vec<f64> = stencils.iter().map(|(w, _)| w.rest_angle).collect();
        if targets.len() != self.wrap_ramp.len() {
            return Err(SimError::Invalid(format!(
                "{} wrapping pairs in the reference, {} in the simulator",
                targets.len(),
                self.wrap_ramp.len()
            )));
        }
        for (entry, target) in self.wrap_ramp.iter_mut().zip(targets) {
            entry.2 = target;
        }
        self.wrap_reference = true;
        self.apply_wrapping_ramp(self.time);
        Ok(())
    }

    /// The contact ramp's start scale ρ₀ = min(1, 0.9 D_min / 2R) at the current state, with
    /// `D_min` the closest centreline distance of two segments in contact (module
    /// documentation, *contact ramp*); 1 without yarn contact.
    fn contact_start_scale(&self) -> f64 {
        let Some(contact) = self.contact.contact else {
            return 1.0;
        };
        let positions = self.positions();
        let pairs = crate::forces::yarn_contact::close_pairs(
            &self.contact.segments,
            &positions,
            contact.cutoff(),
            contact.min_arc_separation,
        );
        let closest = pairs
            .iter()
            .map(|p| p.distance)
            .fold(f64::INFINITY, f64::min);
        (CONTACT_RAMP_CLEARANCE * closest / contact.cutoff()).min(1.0)
    }

    /// How many pairs of segments the layout put through each other (closer than
    /// [`YarnContact::crossing_distance`]): they are excluded from yarn self-contact for the
    /// whole run ([`crate::forces::yarn_contact::Segments::exclude_crossed`]); 0 without yarn
    /// contact.
    pub fn crossed_contact_pairs(&self) -> usize {
        self.contact.crossed
    }

    /// Node positions at the current state (m).
    fn positions(&self) -> Vec<V3> {
        (0..self.dofs.n_nodes())
            .map(|n| self.dofs.position(&self.state.q, n))
            .collect()
    }

    /// Scales the radii of every yarn self-contact term to their value on the contact ramp
    /// at time `t` (s): `ρ(t) = ρ₀ + s(t/T) (1 − ρ₀)` with the wrapping ramp's `s` and `T`.
    pub(super) fn apply_contact_ramp(&mut self, t: f64) {
        let Some(contact) = self.contact.contact else {
            return;
        };
        let rho0 = self.contact.start_scale;
        if rho0 >= 1.0 {
            return;
        }
        let rho = rho0 + self.wrapping_ramp_progress(t) * (1.0 - rho0);
        let phases = contact.phases.map(|mut p| {
            p.radius *= rho;
            p
        });
        for (k, term, _) in self.elastic.iter_mut_of::<rod::contact::EdgeContact, 12>() {
            if k >= self.contact.start {
                term.phases = phases;
            }
        }
    }

    /// Searches the yarn self-contact pairs again ([`crate::forces::yarn_contact`]) if
    /// `force` or once a node has moved more than half the search margin since the last
    /// search; replaces the contact terms (and the Newton solver's pattern) when the pairs
    /// change. Nothing without [`ForceSet::yarn_contact`].
    pub(super) fn refresh_contact(&mut self, force: bool) {
        let Some(contact) = self.contact.contact else {
            return;
        };
        let positions = self.positions();
        let moved = self.contact.searched_at.len() != positions.len()
            || positions
                .iter()
                .zip(&self.contact.searched_at)
                .any(|(p, s)| (p - s).norm() > 0.5 * contact.margin);
        if !(force || moved) {
            return;
        }
        let terms = crate::forces::yarn_contact_terms(
            &contact,
            &self.contact.segments,
            &self.dofs,
            &positions,
        );
        let old: Vec<&[usize]> = (self.contact.start..self.elastic.len())
            .map(|k| self.elastic.dofs(k))
            .collect();
        let same = old.len() == terms.len() && (0..terms.len()).all(|k| old[k] == terms.dofs(k));
        self.elastic.truncate(self.contact.start);
        self.elastic.append(terms);
        if !same {
            self.solver.0 = None; // new stencils, new pattern
        }
        self.contact.searched_at = positions;
    }

    /// Contact breaking (seed 000 §5.2.4) without a restart: the yarn passes `(yarn, pass
    /// index)` — each a yarn end — leave their nodes ([`Topology::without_passes`]) one after
    /// another (indices refer to the topology after the earlier removals, so `(y, 0)` twice
    /// removes yarn `y`'s first two passes), and the simulator continues on the new topology. Positions, velocities, sliding coordinates of
    /// the remaining passes, pins, the rest state (stitch lengths, crossing rest angles),
    /// friction anchors, obstacles and the time carry over; terms, step forms, compression
    /// stacks and the Newton solver are rebuilt; friction springs that did not exist before
    /// start unstretched at the current state, and newly pinned coordinates at rest. Errors
    /// (and changes nothing) for a pass that is not a yarn end or whose node has no other
    /// yarn, during the wrapping ramp, and when a node would keep several yarns outside any
    /// stitch contact (no stacking order for its compression): remove a yarn from a stitch
    /// contact with both of its passes (`(y, 0)` twice), as [`crate::experiment::pullout`]
    /// does.
    pub fn break_passes(&mut self, removed: &[(usize, usize)]) -> Result<(), SimError> {
        if removed.is_empty() {
            return Ok(());
        }
        if self.wrap_reference {
            return Err(SimError::Invalid(
                "contacts cannot break in a simulator with a wrapping reference layout (the \
                 rebuild would take the rest angles from the layout)"
                    .into(),
            ));
        }
        if self.time < self.settings.wrapping_ramp_time
            && self.elastic.count(TermKind::Wrapping) > 0
        {
            return Err(SimError::Invalid(format!(
                "contacts can break only after the wrapping ramp ({} s; now {} s)",
                self.settings.wrapping_ramp_time, self.time
            )));
        }
        // One removal after another; compose the slot maps.
        let mut topology = self.topology.clone();
        let mut slots: Vec<Vec<Option<usize>>> = topology
            .nodes
            .iter()
            .map(|n| (0..n.passes.len()).map(Some).collect())
            .collect();
        for r in removed {
            let (next, map) = topology
                .without_passes(std::slice::from_ref(r))
                .map_err(|e| SimError::Invalid(e.to_string()))?;
            for (n, node_slots) in slots.iter_mut().enumerate() {
                for s in node_slots.iter_mut() {
                    *s = s.and_then(|x| map[n][x]);
                }
            }
            topology = next;
        }
        let dofs = DofMap::new(&topology);
        let mut to_new = vec![None; self.dofs.n_dofs()];
        for (n, node_slots) in slots.iter().enumerate() {
            for k in 0..3 {
                to_new[self.dofs.x(n) + k] = Some(dofs.x(n) + k);
            }
            for (s, t) in node_slots.iter().enumerate() {
                to_new[self.dofs.u(n, s)] = t.map(|t| dofs.u(n, t));
            }
        }
        let carry = |v: &[f64]| {
            let mut out = vec![0.0; dofs.n_dofs()];
            for (i, t) in to_new.iter().enumerate() {
                if let Some(t) = *t {
                    out[t] = v[i];
                }
            }
            out
        };
        let state = State {
            q: carry(&self.state.q),
            v: carry(&self.state.v),
        };
        let q_rest = carry(&self.q_rest);
        let mut fixed = vec![false; dofs.n_dofs()];
        for (i, t) in to_new.iter().enumerate() {
            if let Some(t) = *t {
                fixed[t] = self.fixed[i];
            }
        }
        for (n, node) in topology.nodes.iter().enumerate() {
            for (s, p) in node.passes.iter().enumerate() {
                if p.sliding_pinned {
                    fixed[dofs.u(n, s)] = true;
                }
            }
        }
        // Friction anchors by their (new) coordinates.
        let mut anchors = std::collections::HashMap::new();
        for (k, spring) in self.elastic.iter_of::<AnchoredSpring, 1>() {
            let d = self.elastic.dofs(k);
            if let Some(t) = to_new[d[0]] {
                anchors.insert((t, usize::MAX), spring.anchor);
            }
        }
        for (k, pair) in self.elastic.iter_of::<ParallelSpring, 2>() {
            let d = self.elastic.dofs(k);
            if let (Some(a), Some(b)) = (to_new[d[0]], to_new[d[1]]) {
                anchors.insert((a, b), pair.spring.anchor);
            }
        }
        let parts = Parts {
            topology,
            dofs,
            state,
            q_rest,
            fixed,
            params: self.params,
            forces: self.forces,
            settings: self.settings.clone(),
            obstacles: self.obstacles.clone(),
            time: self.time,
        };
        let mut sim = Self::assemble(parts, false)?;
        // Springs that existed keep their anchors; new ones (a head that lost its parallel
        // partner) start unstretched at the current state, not at the layout.
        let q = sim.state.q.clone();
        for (_, spring, d) in sim.elastic.iter_mut_of::<AnchoredSpring, 1>() {
            spring.anchor = anchors.get(&(d[0], usize::MAX)).copied().unwrap_or(q[d[0]]);
        }
        for (_, pair, d) in sim.elastic.iter_mut_of::<ParallelSpring, 2>() {
            pair.spring.anchor = anchors
                .get(&(d[0], d[1]))
                .copied()
                .unwrap_or_else(|| ParallelSpring::delta(q[d[0]], q[d[1]]));
        }
        for (v, &f) in sim.state.v.iter_mut().zip(&sim.fixed) {
            if f {
                *v = 0.0;
            }
        }
        *self = sim;
        Ok(())
    }

    /// Adds sphere, plane and mesh obstacles: one penalty-contact term per node and obstacle,
    /// and per segment and mesh obstacle ([`crate::forces::obstacle`]), counted among the elastic terms (potential energy,
    /// clamp forces, static equilibrium). Without obstacles nothing is added, so a scene
    /// without obstacles makes no obstacle queries. Obstacle terms are not Rayleigh-β
    /// damped. Errors (and adds nothing) if an obstacle is invalid.
    pub fn add_obstacles(
        &mut self,
        obstacles: &[crate::forces::obstacle::Obstacle],
    ) -> Result<(), SimError> {
        if obstacles.is_empty() {
            return Ok(());
        }
        // Animated obstacles start where the simulation is.
        let obstacles: Vec<Obstacle> = obstacles
            .iter()
            .map(|o| Obstacle {
                shape: o.shape.at_time(self.time),
                ..o.clone()
            })
            .collect();
        let obstacles = &obstacles[..];
        let terms =
            crate::forces::obstacle_terms(&self.topology, &self.dofs, &self.params, obstacles)
                .map_err(SimError::Invalid)?;
        self.obstacles.extend_from_slice(obstacles);
        // Appended to the elastic terms before the self-contact terms: the indices of the
        // elastic terms (wrapping ramp, damped terms) stay valid.
        self.elastic.truncate(self.contact.start);
        self.elastic.append(terms);
        self.contact.start = self.elastic.len();
        self.solver.0 = None; // new stencils, new pattern
        self.refresh_contact(true);
        Ok(())
    }

    /// Moves every animated obstacle to time `t` (s) ([`crate::forces::obstacle::mesh`]): its
    /// contact terms get the mesh at `t`. Static obstacles are untouched.
    pub(super) fn move_obstacles(&mut self, t: f64) {
        use crate::forces::obstacle::{MidpointContact, ObstacleContact, Shape};
        for o in self.obstacles.iter_mut().filter(|o| o.shape.is_animated()) {
            let moved = o.shape.at_time(t);
            if moved == o.shape {
                continue;
            }
            let old = std::mem::replace(&mut o.shape, moved.clone());
            let replace = |shape: &mut Shape| {
                if *shape == old {
                    *shape = moved.clone();
                }
            };
            for (_, c, _) in self.elastic.iter_mut_of::<ObstacleContact, 3>() {
                replace(&mut c.shape);
            }
            for (_, c, _) in self.elastic.iter_mut_of::<MidpointContact, 6>() {
                replace(&mut c.0.shape);
            }
        }
    }

    /// The obstacles added so far (animated meshes where the last step left them).
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// Holds the positions of `nodes` fixed (Dirichlet DOFs) from now on.
    pub fn pin_nodes(&mut self, nodes: &[usize]) -> Result<(), SimError> {
        for &n in nodes {
            if n >= self.topology.nodes.len() {
                return Err(SimError::Invalid(format!("no node {n} to pin")));
            }
            let x = self.dofs.x(n);
            for i in x..x + 3 {
                self.fixed[i] = true;
                self.state.v[i] = 0.0;
            }
        }
        self.solver.0 = None; // the pattern depends on the fixed DOFs
        Ok(())
    }

    /// Holds the sliding coordinates of every yarn through `nodes` fixed (Dirichlet DOFs)
    /// from now on: a clamp that grips the yarns, so that no yarn slides through it. With
    /// [`pin_nodes`](Self::pin_nodes) alone the yarns stay free to slide through pinned
    /// nodes, against friction only.
    pub fn pin_sliding(&mut self, nodes: &[usize]) -> Result<(), SimError> {
        for &n in nodes {
            if n >= self.topology.nodes.len() {
                return Err(SimError::Invalid(format!("no node {n} to pin")));
            }
            for s in 0..self.topology.nodes[n].passes.len() {
                let i = self.dofs.u(n, s);
                self.fixed[i] = true;
                self.state.v[i] = 0.0;
            }
        }
        self.solver.0 = None; // the pattern depends on the fixed DOFs
        Ok(())
    }

    /// Static equilibrium under the current pins: minimizes the potential of the elastic
    /// terms and gravity (no inertia, no damping) from the current state with
    /// [`StepSettings::newton`] (iteration limit raised to 200, always iterated to
    /// convergence with a line search), sets the velocities to zero, and then updates the
    /// friction anchors (Eq. 5) as a step would. For quasi-static loading (driven clamps).
    /// Needs pins that remove the rigid motions; time does not advance, and the wrapping rest
    /// angles are those of the ramp at the current time ([`StepSettings::wrapping_ramp_time`]).
    pub fn solve_static(&mut self) -> Result<NewtonReport, SimError> {
        self.refresh_contact(false);
        self.apply_wrapping_ramp(self.time);
        // Always a full Newton solve (with line search, to convergence), even when the
        // steps are linearized; the linear solver is the steps' one.
        let settings = NewtonSettings {
            max_iterations: 200,
            line_search: true,
            accept_iteration_limit: false,
            ..self.settings.newton.clone()
        };
        let mut q = self.state.q.clone();
        let report = solver::minimize(&self.elastic, &mut q, &self.fixed, &settings)?;
        // No time lag in a static solve: the anchors are checked against the compression
        // of the equilibrium they are checked at. No return mapping either: without inertia
        // a coordinate released to slide at the constant Coulomb force has nothing that
        // bounds its travel within the solve.
        let limits = self.slip_limits(&q)?;
        step::finish_friction(&mut self.elastic, &q, &limits);
        self.state.q = q;
        self.state.v.fill(0.0);
        Ok(report)
    }

    /// Moves pinned nodes by `displacement` (m) before the next step: driven clamps. Their
    /// velocity stays zero (the move is a prescribed position, not a dynamic state). Errors
    /// if a node does not exist or is not pinned.
    pub fn displace_pinned_nodes(
        &mut self,
        nodes: &[usize],
        displacement: V3,
    ) -> Result<(), SimError> {
        for &n in nodes {
            if n >= self.topology.nodes.len() || !self.fixed[self.dofs.x(n)] {
                return Err(SimError::Invalid(format!("node {n} is not a pinned node")));
            }
        }
        for &n in nodes {
            let x = self.dofs.x(n);
            for k in 0..3 {
                self.state.q[x + k] += displacement[k];
            }
        }
        Ok(())
    }

    /// The total force (N) that the yarns (elastic terms and gravity) exert on `nodes`:
    /// `−Σ ∂V/∂x` over their positions. At equilibrium, a clamp holding pinned nodes applies
    /// the opposite force.
    pub fn force_on_nodes(&self, nodes: &[usize]) -> V3 {
        let g = self.elastic.gradient(&self.state.q);
        let mut f = V3::zeros();
        for &n in nodes {
            let x = self.dofs.x(n);
            f -= V3::new(g[x], g[x + 1], g[x + 2]);
        }
        f
    }

    /// The compression (Eqs. 3–4, both solvers) at every stacked node at the current state,
    /// with the current force terms. Errors if the topology has no compression rule (see
    /// [`CompressionEstimator::new`]) or the estimate fails.
    pub fn compression(&self) -> Result<Vec<NodeCompression>, SimError> {
        let built;
        let estimator = match &self.compression {
            Some(e) => e,
            None => {
                built = CompressionEstimator::new(&self.topology, &self.dofs)
                    .map_err(|e| SimError::Invalid(e.to_string()))?;
                &built
            }
        };
        estimator
            .estimate(
                self.static_terms(),
                &self.state.q,
                &self.dofs,
                self.params.radius,
                &self.params.compression,
            )
            .map_err(|e| SimError::Invalid(e.to_string()))
    }

    /// Kinetic energy `½ q̇ᵀ M(q) q̇` (J).
    pub fn kinetic_energy(&self) -> f64 {
        kinetic_energy(
            &self.topology,
            &self.dofs,
            self.params.linear_density,
            &self.state,
        )
    }

    /// Potential energy (J): elastic terms and gravity at the current state.
    pub fn potential_energy(&self) -> f64 {
        self.elastic.energy(&self.state.q)
    }

    /// Energy (J) of each kind of elastic and gravity term at the current state (the per-term
    /// energy shares of the rib-stretch figure).
    pub fn energy_by_kind(&self) -> Vec<(TermKind, f64)> {
        self.elastic.energy_by_kind(&self.state.q)
    }

    /// The potential of the backward Euler step: the elastic and gravity terms
    /// ([`Simulator::static_terms`]) followed by the inertia and damping terms of the last
    /// (sub)step ([`Simulator::step_terms`]), as one `solver::Problem` (for inspection and
    /// timing of the assembly, e.g. with [`solver::Assembler`]).
    pub fn step_potential(&self) -> Concat<'_, Potential, Potential> {
        Concat::new(&self.elastic, &self.step)
    }

    /// The elastic and gravity terms (without the per-step inertia and damping).
    pub fn static_terms(&self) -> &Potential {
        &self.elastic
    }

    /// The per-step terms of the last (sub)step: one inertia term per segment, then the
    /// Rayleigh-β damping forms.
    pub fn step_terms(&self) -> &Potential {
        &self.step
    }

    /// The current state.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// Replaces the state (same DOF count required), e.g. to start with a velocity.
    pub fn set_state(&mut self, state: State) -> Result<(), SimError> {
        if state.q.len() != self.dofs.n_dofs() || state.v.len() != self.dofs.n_dofs() {
            return Err(SimError::Invalid(
                "state has the wrong number of DOFs".into(),
            ));
        }
        self.state = state;
        self.refresh_contact(true);
        Ok(())
    }

    /// The topology.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// The DOF layout.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Which DOFs are held fixed.
    pub fn fixed(&self) -> &[bool] {
        &self.fixed
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The step settings.
    pub fn settings(&self) -> &StepSettings {
        &self.settings
    }

    /// Replaces the step settings from the next step on (e.g. a pull at another time step
    /// from a state settled at a reference one). The Rayleigh-β damping forms are rebuilt
    /// at the next step; a changed [`StepSettings::wrapping_ramp_time`] moves the wrapping
    /// rest angles to the new ramp's values at the current time (a jump if the ramp is
    /// still running). Errors (and changes nothing) if the settings are invalid, switch
    /// Rayleigh-β damping on or off, or, with β > 0, switch the friction return mapping on
    /// or off (the friction springs are β-damped only without it).
    pub fn set_settings(&mut self, settings: StepSettings) -> Result<(), SimError> {
        settings.validate()?;
        if settings.rayleigh_beta > 0.0
            && (settings.friction_return_mapping > 0) != (self.settings.friction_return_mapping > 0)
        {
            return Err(SimError::Invalid(
                "with Rayleigh β damping the friction return mapping cannot be switched on or \
                 off after construction (friction springs are β-damped only without it)"
                    .into(),
            ));
        }
        if (settings.rayleigh_beta > 0.0) != (self.settings.rayleigh_beta > 0.0) {
            // The Rayleigh-β damping terms exist only if β > 0 at construction.
            return Err(SimError::Invalid(
                "Rayleigh β damping cannot be switched on or off after construction".into(),
            ));
        }
        self.step
            .bound_material_steps(material_step_bound(&settings, &self.segment_dofs));
        self.settings = settings;
        self.damping_built = None;
        Ok(())
    }
}

/// The material-length step bound of `settings` ([`StepSettings::max_material_shrink`]) on
/// the segments with DOFs `segment_dofs` (`(x₀, u₀, x₁, u₁)`).
fn material_step_bound(
    settings: &StepSettings,
    segment_dofs: &[[usize; 8]],
) -> Option<(Vec<[usize; 2]>, f64)> {
    let shrink = settings.max_material_shrink?;
    Some((segment_dofs.iter().map(|d| [d[3], d[7]]).collect(), shrink))
}

/// Checks the inputs of [`Simulator::new`]: parameters, settings, topology, and that the
/// layout matches the topology.
fn validate_input(
    topology: &Topology,
    layout: &Layout,
    params: &YarnParams,
    forces: &ForceSet,
    settings: &StepSettings,
) -> Result<(), SimError> {
    params.validate().map_err(SimError::Invalid)?;
    settings.validate()?;
    forces
        .crossing_shear_params
        .validate()
        .map_err(SimError::Invalid)?;
    topology
        .validate()
        .map_err(|e| SimError::Invalid(e.to_string()))?;
    let slots_match = layout.sliding.len() == topology.nodes.len()
        && topology
            .nodes
            .iter()
            .zip(&layout.sliding)
            .all(|(n, s)| n.passes.len() == s.len());
    if layout.positions.len() != topology.nodes.len() || !slots_match {
        return Err(SimError::Invalid(
            "layout does not match the topology".into(),
        ));
    }
    Ok(())
}
