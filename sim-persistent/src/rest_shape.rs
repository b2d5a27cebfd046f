//! Rest-shape bending compensation (seed 000 §4.1, Fig. 6): a knit layout whose loops start
//! in the shape they relax to, so that a garment does not shrink and wrinkle when simulated.
//!
//! The paper: "we first relax a small characteristic rectangle of cloth, by simulating it
//! without gravity until it reaches static equilibrium. For complex knits, we choose the
//! smallest rectangle that contains the full knitting pattern. For simpler regular knits, we
//! choose a 5 cm × 5 cm rectangle […] After relaxation, we apply the resulting loop shapes in
//! the initialization of the yarn layout for the entire garment." Here, in four steps:
//!
//! 1. **Repeat** ([`detect_repeat`]): the smallest `pr` rows × `pc` columns such that every
//!    stitch equals the one `pr` rows above and the one `pc` columns to the right, wherever
//!    both are in the chart (stockinette 1 × 1, garter 2 × 1, `k × p` rib 1 × (k + p), seed
//!    2 × 2; a chart that does not repeat is its own repeat, `H × W`).
//! 2. **Characteristic rectangle** ([`Rectangle`]): the repeat continued cyclically over
//!    `max(p, n_min) + 2 m` loops each way, with `n_min = ⌈extent / loop size⌉`
//!    ([`CompensationSettings::min_extent`]; default 5 cm as in the paper, 17 loops of
//!    3 mm, so 21 × 21 loops for stockinette; tests use one repeat) and `m` margin loops
//!    ([`CompensationSettings::margin`], default 2) so that the shape taken from its centre
//!    is not an edge shape. The *source tile* `(r₀, c₀)` is the copy of the repeat (phase
//!    `(0, 0)`) nearest the rectangle's centre.
//! 3. **Relaxation** ([`relax_rectangle`]): the flat layout of the rectangle is simulated
//!    free and without gravity, as the paper does (with
//!    [`CompensationSettings::pin_border`] its border cells are pinned where the flat layout
//!    has them instead, standing for the surrounding garment). Mass damping
//!    ([`CompensationSettings::step`], default α = 10/s as Table 1, Newton stopped at
//!    1e-7 N, the settling ramps of wrapping and contact over 0.1 s) for
//!    [`CompensationSettings::settle_time`] and then until the kinetic energy is below
//!    [`CompensationSettings::kinetic_ratio`] of its peak, then a static solve
//!    ([`CompensationSettings::static_solve`]; a free rectangle has the source tile's first
//!    cell pinned for it, which removes the rigid motions). If the kinetic criterion is not
//!    met by [`CompensationSettings::max_settle_time`] it is an error
//!    ([`RestShapeError::NotSettled`]), never a silent result; the final force residual is
//!    reported ([`RelaxReport`]).
//! 4. **Transfer** ([`transfer`]): every contact cell of the full chart (the four nodes of
//!    column `c` on row boundary `b`: a left and a right stitch contact) takes the relaxed
//!    shape of the rectangle's cell with the same phase (`r₀ + b mod pr`, `c₀ + c mod pc`):
//!    the same stitches above and below, the same neighbours. Shapes are expressed in the
//!    *tile frame*: origin at the centroid of cell `(r₀, c₀)`, course axis `e₁` along the
//!    translation `T_c` to cell `(r₀, c₀ + pc)`, normal `e₃ ∥ T_c × T_w` (the front, as in
//!    [`crate::measure`]) with `T_w` the translation to cell `(r₀ + pr, c₀)`, `e₂ = e₃ × e₁`.
//!    Cell `(b, c)` is placed at `⌊b/pr⌋ T_w + ⌊c/pc⌋ T_c` (in frame coordinates, a plane
//!    lattice) plus its source cell's local shape; within a tile the relaxed geometry is
//!    copied exactly, across tiles it is exact when the relaxed rectangle is periodic. Each
//!    node has exactly one source (no averaging). Edge cells of the chart take interior
//!    shapes too. The layout is then translated so that its centroid is the flat layout's.
//!    **Sliding coordinates** are cumulative along each yarn, with every segment's material
//!    length `Δu = |Δx| · Δu_s / |Δx_s|` keeping the stretch ratio of its source segment `s`
//!    (so yarn tensions carry over); the stitch-contact rest lengths (Eq. 6 and the wrapping
//!    `L` of Eq. 2, both taken from the initial state by [`crate::forces::build_terms`]) are
//!    the transferred ones.
//!
//! **Wrapping rest state.** The relaxed loops are wrapped: their stitch contacts have
//! turned from the flat layout's angles towards the rest angles of
//! [`crate::params::WrappingRest`] taken from the flat layout. A simulator started from the
//! compensated layout keeps those rest angles ([`Simulator::set_wrapping_reference`] with the
//! flat layout, [`compensated_simulator`]) and steps without the settling ramps
//! ([`compensated_step_settings`]): the layout's own angles as rest angles would drop the
//! wrapping moment that balances the loops' bending, and a ramp would first unwrap them. The
//! residual [`elastic_residual_with_reference`] measures the same state. The `rest-shape`
//! figure (Fig. 6) and `tests/rest_shape.rs` compare the compensated and the flat start.
//!
//! **Differences from the paper.** The paper places the relaxed loop shapes on the garment's
//! mesh; here the target is the flat chart on a plane lattice (the relaxed tile's lattice
//! vectors). A non-repeating chart is continued cyclically into its margin. The default
//! rectangle is at least 5 cm × 5 cm for every chart, also for complex ones whose repeat is
//! smaller than that.

use crate::chart::Chart;
use crate::forces::wrapping::StitchWrap;
use crate::forces::yarn_contact::{Segments, YarnContact};
use crate::forces::{ForceSet, build_terms, wrapping_stencils, yarn_contact_terms};
use crate::integrator::{SimError, Simulator, StepSettings};
use crate::layout::{Layout, LayoutError, LayoutParams};
use crate::params::YarnParams;
use crate::state::{DofMap, State};
use crate::topology::{Side, Topology, knit_node};
use rod::geometry::V3;

/// The rectangular repeat of a chart (loops).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Repeat {
    /// Rows after which the chart repeats (`pr`).
    pub rows: usize,
    /// Columns after which the chart repeats (`pc`).
    pub columns: usize,
}

/// The smallest rectangular repeat of `chart` (module documentation, step 1).
pub fn detect_repeat(chart: &Chart) -> Repeat {
    let (w, h) = (chart.width(), chart.height());
    // `get`: rows of a shaped chart may be shorter than the cast-on (such charts are refused
    // by [`Rectangle::new`]; this function only must not panic on them).
    let at = |r: usize, c: usize| chart.row(r).get(c);
    let columns = (1..=w)
        .find(|&p| (0..h).all(|r| (0..w - p).all(|c| at(r, c) == at(r, c + p))))
        .unwrap_or(w);
    let rows = (1..=h)
        .find(|&p| (0..h - p).all(|r| chart.row(r) == chart.row(r + p)))
        .unwrap_or(h);
    Repeat { rows, columns }
}

/// Settings of the compensation (SI units; module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct CompensationSettings {
    /// Least side of the characteristic rectangle without its margin (m), turned into a loop
    /// count with the layout's loop width and row height. Default 0.05 (5 cm, seed 000
    /// §4.1). Smaller values (a few loops) relax much faster; a repeat larger than this is
    /// always used whole.
    pub min_extent: f64,
    /// Border loops around the repeat-sized core on every side (≥ 1, so that the tile frame
    /// can be measured). Default 2.
    pub margin: usize,
    /// Time steps of the relaxation: the rectangle starts flat, so the wrapping ramp is
    /// wanted here. Default: [`StepSettings::default`] with α = 10/s (Table 1), a Newton
    /// force tolerance of 1e-7 N (as `tests/curl.rs`) and steps that reach the Newton
    /// iteration limit accepted.
    pub step: StepSettings,
    /// Forces of the relaxation. Gravity is always switched off. Default: every default term
    /// (friction included: without it the sliding coordinates of this model are not held
    /// and a step's Newton solve can diverge).
    pub forces: ForceSet,
    /// Simulated time before the settling criterion is checked (s). Default 0.15 (past the
    /// default wrapping ramp of 0.1 s).
    pub settle_time: f64,
    /// Longest simulated time (s); not settled by then is an error. Default 1.0.
    pub max_settle_time: f64,
    /// Settled when the kinetic energy is at most this fraction of its peak. Default 1e-2
    /// (the static solve finishes the job).
    pub kinetic_ratio: f64,
    /// After the dynamic settle, solve for static equilibrium. Default true. (With a free
    /// rectangle the source tile's first cell is pinned for this solve, which removes the
    /// rigid motions; with [`CompensationSettings::pin_border`] the border does.)
    pub static_solve: bool,
    /// Pin the rectangle's border cells during the relaxation (`true`: they stand for the
    /// surrounding garment and keep the rectangle from rolling up) or relax it free
    /// (`false`, the default, as the paper: the default model keeps a free rectangle flat,
    /// and its loops take their own pitch).
    pub pin_border: bool,
}

impl Default for CompensationSettings {
    fn default() -> Self {
        let mut step = StepSettings {
            rayleigh_alpha: 10.0,
            ..StepSettings::default()
        };
        step.newton.gradient_abs_tol = 1e-7;
        // A damped step only has to bring the rectangle towards rest: one that ends at the
        // iteration limit is taken (measured: a 9 × 9 stockinette rectangle otherwise fails
        // a step); the static solve afterwards always iterates to convergence.
        step.newton.accept_iteration_limit = true;
        Self {
            min_extent: 0.05,
            margin: 2,
            step,
            forces: ForceSet {
                gravity: false,
                ..ForceSet::default()
            },
            settle_time: 0.15,
            max_settle_time: 1.0,
            kinetic_ratio: 1e-2,
            static_solve: true,
            pin_border: false,
        }
    }
}

impl CompensationSettings {
    /// Checks the ranges: `min_extent ≥ 0`, `margin ≥ 1`, `0 < settle_time ≤ max_settle_time`,
    /// `0 < kinetic_ratio < 1`, valid step settings.
    pub fn validate(&self) -> Result<(), RestShapeError> {
        let bad = |m: String| Err(RestShapeError::Invalid(m));
        if !(self.min_extent.is_finite() && self.min_extent >= 0.0) {
            return bad(format!("min_extent must be ≥ 0 m, got {}", self.min_extent));
        }
        if self.margin == 0 {
            return bad("margin must be ≥ 1 loop (the tile frame needs a neighbour)".into());
        }
        if !(self.settle_time.is_finite()
            && self.settle_time > 0.0
            && self.max_settle_time.is_finite()
            && self.max_settle_time >= self.settle_time)
        {
            return bad(format!(
                "need 0 < settle_time ≤ max_settle_time, got {} and {} s",
                self.settle_time, self.max_settle_time
            ));
        }
        if !(self.kinetic_ratio > 0.0 && self.kinetic_ratio < 1.0) {
            return bad(format!(
                "kinetic_ratio must be in (0, 1), got {}",
                self.kinetic_ratio
            ));
        }
        self.step.validate().map_err(RestShapeError::Sim)
    }
}

/// Why a compensated layout could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RestShapeError {
    /// Invalid settings or input (sizes, lengths).
    #[error("rest-shape compensation: invalid input: {0}")]
    Invalid(String),
    /// The layout parameters are invalid.
    #[error("rest-shape compensation: {0}")]
    Layout(#[from] LayoutError),
    /// The relaxation of the rectangle failed (a step or the static solve).
    #[error("rest-shape compensation: relaxation failed: {0}")]
    Sim(#[from] SimError),
    /// The rectangle did not come to rest within the allowed time.
    #[error(
        "rest-shape compensation: the rectangle did not settle in {time} s: kinetic energy \
         {kinetic:e} J > {ratio} × peak {peak:e} J"
    )]
    NotSettled {
        /// Simulated time (s).
        time: f64,
        /// Final kinetic energy (J).
        kinetic: f64,
        /// Peak kinetic energy (J).
        peak: f64,
        /// The required ratio.
        ratio: f64,
    },
    /// A relaxed or transferred position is not finite.
    #[error("rest-shape compensation: non-finite result: {0}")]
    NonFinite(String),
}

/// The characteristic rectangle of a chart (module documentation, step 2).
#[derive(Clone, Debug, PartialEq)]
pub struct Rectangle {
    /// The rectangle's own chart: the repeat continued cyclically, loop `(r, c)` having the
    /// stitch of phase `((r − margin) mod pr, (c − margin) mod pc)`.
    pub chart: Chart,
    /// The repeat of the full chart.
    pub repeat: Repeat,
    /// First row and first column of the source tile (its phase is `(0, 0)`).
    pub tile: (usize, usize),
}

impl Rectangle {
    /// The rectangle for `chart`: at least `min_loops = (columns, rows)` loops (and a whole
    /// repeat) plus `margin` loops on every side. Errors if `margin` is 0.
    pub fn new(
        chart: &Chart,
        min_loops: (usize, usize),
        margin: usize,
    ) -> Result<Self, RestShapeError> {
        if margin == 0 {
            return Err(RestShapeError::Invalid(
                "margin must be ≥ 1 loop (the tile frame needs a neighbour)".into(),
            ));
        }
        if !chart.is_rectangular() {
            return Err(RestShapeError::Invalid(
                "rest-shape compensation needs a rectangular K/P chart (its characteristic \
                 rectangle repeats the stitch grid); this chart changes its width or uses \
                 other stitches"
                    .into(),
            ));
        }
        let repeat = detect_repeat(chart);
        let (pr, pc) = (repeat.rows, repeat.columns);
        let w = pc.max(min_loops.0) + 2 * margin;
        let h = pr.max(min_loops.1) + 2 * margin;
        let rect_chart = Chart::from_fn(w, h, |r, c| {
            chart.stitch((r + pr - margin % pr) % pr, (c + pc - margin % pc) % pc)
        })
        .map_err(|e| RestShapeError::Invalid(e.to_string()))?;
        // The tile start with phase 0 nearest the centre, inside the core.
        let start = |n: usize, p: usize| {
            let centre = (n - p) / 2; // ideal start of a centred tile
            let k = (centre.max(margin) - margin) / p;
            (margin + k * p).min(n - margin - p)
        };
        Ok(Self {
            chart: rect_chart,
            repeat,
            tile: (start(h, pr), start(w, pc)),
        })
    }

    /// Columns and rows of the rectangle (loops).
    pub fn size(&self) -> (usize, usize) {
        (self.chart.width(), self.chart.height())
    }
}

/// What the relaxation of the rectangle did.
#[derive(Clone, Debug, PartialEq)]
pub struct RelaxReport {
    /// Time steps taken.
    pub steps: usize,
    /// Simulated time (s).
    pub time: f64,
    /// Peak and final kinetic energy (J).
    pub peak_kinetic: f64,
    /// Kinetic energy at the end (J).
    pub final_kinetic: f64,
    /// Norm of the force (N) of the relaxation's elastic terms (full wrapping rest angle ψ₀)
    /// on the free node positions (pinned nodes left out; sliding coordinates left out
    /// too, as friction holds them), at the flat start and at the end.
    pub start_residual: f64,
    /// See `start_residual`.
    pub final_residual: f64,
    /// Newton iterations of the static solve, if one was made.
    pub static_iterations: Option<usize>,
}

/// Norm (N) of the gradient of the elastic terms of `forces` (gravity and friction switched
/// off; yarn self-contact at its full radius) over the free coordinates (the sliding
/// coordinates the topology pins are left out) of `layout`, with the full wrapping rest
/// angle ψ₀: how far the layout is from rest.
pub fn elastic_residual(
    topology: &Topology,
    layout: &Layout,
    params: &YarnParams,
    forces: &ForceSet,
) -> Result<f64, RestShapeError> {
    elastic_residual_with_reference(topology, layout, layout, params, forces)
}

/// [`elastic_residual`] with the wrapping rest angles taken from `wrap_reference` (as a
/// compensated simulator takes them from the flat layout, [`compensated_simulator`]).
pub fn elastic_residual_with_reference(
    topology: &Topology,
    layout: &Layout,
    wrap_reference: &Layout,
    params: &YarnParams,
    forces: &ForceSet,
) -> Result<f64, RestShapeError> {
    let matches = |l: &Layout| {
        l.positions.len() == topology.nodes.len()
            && l.sliding.len() == topology.nodes.len()
            && (topology.nodes.iter().zip(&l.sliding)).all(|(n, s)| n.passes.len() == s.len())
    };
    if !(matches(layout) && matches(wrap_reference)) {
        return Err(RestShapeError::Invalid(
            "layout does not match the topology".into(),
        ));
    }
    let forces = ForceSet {
        gravity: false,
        friction: false,
        ..*forces
    };
    let dofs = DofMap::new(topology);
    let state = State::from_layout(topology, &dofs, layout);
    let mut terms = build_terms(topology, &dofs, params, &forces, &state.q);
    let q_ref = State::from_layout(topology, &dofs, wrap_reference).q;
    let rest = wrapping_stencils(topology, &dofs, params, &q_ref);
    for ((_, wrap, _), (reference, _)) in terms.iter_mut_of::<StitchWrap, 12>().zip(rest) {
        wrap.rest_angle = reference.rest_angle;
    }
    if forces.yarn_contact {
        // Yarn self-contact at its full radius, without the pairs the layout crosses (as the
        // simulator leaves them out).
        let contact = YarnContact::for_yarn(params.radius, params.bending_stiffness());
        let mut segments = Segments::new(topology);
        segments.exclude_crossed(
            &layout.positions,
            contact.crossing_distance(),
            contact.min_arc_separation,
        );
        terms.append(yarn_contact_terms(
            &contact,
            &segments,
            &dofs,
            &layout.positions,
        ));
    }
    let g = terms.gradient(&state.q);
    let mut free = vec![true; dofs.n_dofs()];
    for (n, node) in topology.nodes.iter().enumerate() {
        for (s, p) in node.passes.iter().enumerate() {
            if p.sliding_pinned {
                free[dofs.u(n, s)] = false;
            }
        }
    }
    let norm = g
        .iter()
        .zip(&free)
        .filter(|(_, f)| **f)
        .map(|(v, _)| v * v)
        .sum::<f64>()
        .sqrt();
    if !norm.is_finite() {
        return Err(RestShapeError::NonFinite("elastic residual".into()));
    }
    Ok(norm)
}

/// Relaxes the flat layout of `rect` without gravity, free or with its border cells pinned
/// (module documentation, step 3), and returns the relaxed layout (positions and sliding
/// coordinates, indexed like `Topology::knit(&rect.chart)`).
pub fn relax_rectangle(
    rect: &Rectangle,
    params: &YarnParams,
    layout_params: &LayoutParams,
    settings: &CompensationSettings,
) -> Result<(Layout, RelaxReport), RestShapeError> {
    settings.validate()?;
    let topo = Topology::knit(&rect.chart);
    let layout = Layout::new(&topo, layout_params)?;
    let forces = ForceSet {
        gravity: false,
        ..settings.forces
    };
    let mut sim = Simulator::new(
        topo.clone(),
        &layout,
        *params,
        forces,
        settings.step.clone(),
    )?;
    if settings.pin_border {
        sim.pin_nodes(&border_nodes(rect))?;
    }
    // Residuals over the free node positions: friction (Eq. 5) acts on the sliding
    // coordinates only, and the static solve moves its anchors afterwards.
    let mut skip = sim.fixed().to_vec();
    for (n, node) in topo.nodes.iter().enumerate() {
        for slot in 0..node.passes.len() {
            skip[sim.dofs().u(n, slot)] = true;
        }
    }
    let start_residual = {
        // The full rest angle ψ₀ (the simulator's own terms start with the ramp's).
        let q = &sim.state().q;
        let terms = build_terms(&topo, sim.dofs(), params, &forces, q);
        free_norm(&terms.gradient(q), &skip)
    };
    let (mut steps, mut peak) = (0, 0.0_f64);
    loop {
        sim.step()?;
        steps += 1;
        let kinetic = sim.kinetic_energy();
        if !kinetic.is_finite() {
            return Err(RestShapeError::NonFinite(format!(
                "kinetic energy after {steps} steps"
            )));
        }
        peak = peak.max(kinetic);
        let t = sim.time();
        let ramped = t >= settings.step.wrapping_ramp_time;
        if ramped && t >= settings.settle_time && kinetic <= settings.kinetic_ratio * peak {
            break;
        }
        if t >= settings.max_settle_time {
            return Err(RestShapeError::NotSettled {
                time: t,
                kinetic,
                peak,
                ratio: settings.kinetic_ratio,
            });
        }
    }
    let final_kinetic = sim.kinetic_energy();
    let static_iterations = if settings.static_solve {
        if !settings.pin_border {
            let (w, _) = rect.size();
            let (r0, c0) = rect.tile;
            let cell: Vec<usize> = [Side::Left, Side::Right]
                .into_iter()
                .flat_map(|side| [false, true].map(|hi| knit_node(w, r0, c0, side, hi)))
                .collect();
            sim.pin_nodes(&cell)?;
            for &n in &cell {
                let d = sim.dofs().x(n);
                for k in d..d + 3 {
                    skip[k] = true;
                }
            }
        }
        Some(sim.solve_static()?.iterations)
    } else {
        None
    };
    let s = sim.state();
    let relaxed = Layout {
        positions: (0..topo.nodes.len())
            .map(|n| sim.dofs().position(&s.q, n))
            .collect(),
        sliding: (0..topo.nodes.len())
            .map(|n| {
                (0..topo.nodes[n].passes.len())
                    .map(|k| s.q[sim.dofs().u(n, k)])
                    .collect()
            })
            .collect(),
    };
    if let Some(n) = relaxed
        .positions
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(RestShapeError::NonFinite(format!(
            "relaxed position of node {n}"
        )));
    }
    // Equilibrium residual of the relaxation's own static terms over the free positions.
    let final_residual = free_norm(&sim.static_terms().gradient(&s.q), &skip);
    Ok((
        relaxed,
        RelaxReport {
            steps,
            time: sim.time(),
            peak_kinetic: peak,
            final_kinetic,
            start_residual,
            final_residual,
            static_iterations,
        },
    ))
}

/// Norm of `g` over the coordinates that are not `fixed`.
fn free_norm(g: &[f64], fixed: &[bool]) -> f64 {
    g.iter()
        .zip(fixed)
        .filter(|(_, f)| !**f)
        .map(|(v, _)| v * v)
        .sum::<f64>()
        .sqrt()
}

/// The nodes of the rectangle's border cells (cast-on and bind-off boundaries, first and
/// last column), pinned during the relaxation with [`CompensationSettings::pin_border`]:
/// they stand for the surrounding fabric.
pub fn border_nodes(rect: &Rectangle) -> Vec<usize> {
    let (w, h) = rect.size();
    let mut nodes = Vec::new();
    for b in 0..=h {
        for c in 0..w {
            if b == 0 || b == h || c == 0 || c + 1 == w {
                for side in [Side::Left, Side::Right] {
                    for hi in [false, true] {
                        nodes.push(knit_node(w, b, c, side, hi));
                    }
                }
            }
        }
    }
    nodes
}

/// The tile frame and lattice measured on a relaxed rectangle (module documentation,
/// step 4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileFrame {
    /// Origin: centroid of the source tile's first contact cell `(r₀, c₀)` (m).
    pub origin: V3,
    /// Orthonormal axes `[e₁, e₂, e₃]`: course, wale, front normal.
    pub axes: [V3; 3],
    /// Translation from one tile to the next along the course, in frame coordinates (m):
    /// `(|T_c|, 0, 0)`.
    pub course_vector: V3,
    /// Translation from one tile to the next along the wale, in frame coordinates (m):
    /// `(T_w · e₁, T_w · e₂, 0)`.
    pub wale_vector: V3,
    /// Relaxed course pitch `|T_c| / pc` (m per column).
    pub course_pitch: f64,
    /// Relaxed wale pitch `T_w · e₂ / pr` (m per row).
    pub wale_pitch: f64,
}

/// Measures the tile frame of `rect` at `relaxed` positions (module documentation, step 4).
pub fn tile_frame(rect: &Rectangle, relaxed: &[V3]) -> Result<TileFrame, RestShapeError> {
    let (w, h) = rect.size();
    if relaxed.len() != 4 * w * (h + 1) {
        return Err(RestShapeError::Invalid(format!(
            "{} relaxed positions for a {w} × {h} rectangle ({} nodes)",
            relaxed.len(),
            4 * w * (h + 1)
        )));
    }
    if let Some(n) = relaxed
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(RestShapeError::NonFinite(format!(
            "relaxed position of node {n}"
        )));
    }
    let (pr, pc) = (rect.repeat.rows, rect.repeat.columns);
    let (r0, c0) = rect.tile;
    if r0 == 0 || c0 == 0 || r0 + pr >= h || c0 + pc >= w {
        return Err(RestShapeError::Invalid(format!(
            "source tile at {:?} has no neighbour loops in a {w} × {h} rectangle",
            rect.tile
        )));
    }
    let cell = |b: usize, c: usize| {
        let mut sum = V3::zeros();
        for side in [Side::Left, Side::Right] {
            for hi in [false, true] {
                sum += relaxed[knit_node(w, b, c, side, hi)];
            }
        }
        sum / 4.0
    };
    let origin = cell(r0, c0);
    let course = cell(r0, c0 + pc) - origin;
    let wale = cell(r0 + pr, c0) - origin;
    let normal = course.cross(&wale);
    if !(normal.norm() > 0.0 && course.norm() > 0.0) {
        return Err(RestShapeError::NonFinite(
            "degenerate tile frame (course and wale translations parallel or zero)".into(),
        ));
    }
    let e1 = course.normalize();
    let e3 = normal.normalize();
    let e2 = e3.cross(&e1);
    let course_vector = V3::new(course.norm(), 0.0, 0.0);
    let wale_vector = V3::new(wale.dot(&e1), wale.dot(&e2), 0.0);
    Ok(TileFrame {
        origin,
        axes: [e1, e2, e3],
        course_vector,
        wale_vector,
        course_pitch: course_vector.x / pc as f64,
        wale_pitch: wale_vector.y / pr as f64,
    })
}

/// Applies the relaxed loop shapes of `rect` (its relaxed layout `relaxed_layout`) to the
/// whole of `chart` (module documentation, step 4). The result is centred on `centre` (m).
/// `chart` must have the repeat the rectangle was made from.
pub fn transfer(
    chart: &Chart,
    rect: &Rectangle,
    relaxed_layout: &Layout,
    centre: V3,
) -> Result<Layout, RestShapeError> {
    let relaxed = &relaxed_layout.positions[..];
    if !chart.is_rectangular() {
        return Err(RestShapeError::Invalid(
            "rest-shape transfer needs a rectangular K/P chart".into(),
        ));
    }
    let repeat = detect_repeat(chart);
    if repeat != rect.repeat {
        return Err(RestShapeError::Invalid(format!(
            "chart repeat {repeat:?} differs from the rectangle's {:?}",
            rect.repeat
        )));
    }
    let frame = tile_frame(rect, relaxed)?;
    let (rw, _) = rect.size();
    let (pr, pc) = (repeat.rows, repeat.columns);
    let (r0, c0) = rect.tile;
    let [e1, e2, e3] = frame.axes;
    let local = |p: V3| {
        let d = p - frame.origin;
        V3::new(d.dot(&e1), d.dot(&e2), d.dot(&e3))
    };
    let (w, h) = (chart.width(), chart.height());
    let topo = Topology::knit(chart);
    let mut positions = vec![V3::zeros(); topo.nodes.len()];
    for b in 0..=h {
        for c in 0..w {
            let offset =
                (b / pr) as f64 * frame.wale_vector + (c / pc) as f64 * frame.course_vector;
            for side in [Side::Left, Side::Right] {
                for hi in [false, true] {
                    let src = relaxed[knit_node(rw, r0 + b % pr, c0 + c % pc, side, hi)];
                    positions[knit_node(w, b, c, side, hi)] = offset + local(src);
                }
            }
        }
    }
    let mean = positions.iter().sum::<V3>() / positions.len() as f64;
    for p in &mut positions {
        *p += centre - mean;
    }
    if let Some(n) = positions
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(RestShapeError::NonFinite(format!(
            "transferred position of node {n}"
        )));
    }
    // Material length of every segment from the source segment of the rectangle.
    let rect_topo = Topology::knit(&rect.chart);
    let slots_match = relaxed_layout.sliding.len() == rect_topo.nodes.len()
        && rect_topo
            .nodes
            .iter()
            .zip(&relaxed_layout.sliding)
            .all(|(n, s)| n.passes.len() == s.len());
    if !slots_match {
        return Err(RestShapeError::Invalid(
            "relaxed sliding coordinates do not match the rectangle".into(),
        ));
    }
    let rect_pass = |y: usize, i: usize| {
        let p = rect_topo.yarns[y].passes[i];
        (relaxed[p.node], relaxed_layout.sliding[p.node][p.slot])
    };
    let mut sliding: Vec<Vec<f64>> = topo
        .nodes
        .iter()
        .map(|n| vec![0.0; n.passes.len()])
        .collect();
    for (r, yarn) in topo.yarns.iter().enumerate() {
        let source_yarn = r0 + r % pr;
        let mut s = 0.0;
        for (i, p) in yarn.passes.iter().enumerate() {
            if i > 0 {
                // Segment i − 1 → i: pass k = (i − 1) mod 8 of loop (i − 1) / 8 (k = 7: the
                // sinker to the next loop). It keeps the stretch ratio of its source segment.
                let (c, k) = ((i - 1) / 8, (i - 1) % 8);
                let j = 8 * (c0 + c % pc) + k;
                let ((x0, u0), (x1, u1)) =
                    (rect_pass(source_yarn, j), rect_pass(source_yarn, j + 1));
                let ratio = (u1 - u0) / (x1 - x0).norm();
                let chord = (positions[p.node] - positions[yarn.passes[i - 1].node]).norm();
                let du = ratio * chord;
                if !(du.is_finite() && du > 0.0) {
                    return Err(RestShapeError::NonFinite(format!(
                        "material length {du} m of yarn {r}, segment {} (relaxed: {} m over \
                         {} m)",
                        i - 1,
                        u1 - u0,
                        (x1 - x0).norm()
                    )));
                }
                s += du;
            }
            sliding[p.node][p.slot] = s;
        }
    }
    Ok(Layout { positions, sliding })
}

/// What [`compensated_layout`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct CompensationReport {
    /// The characteristic rectangle.
    pub rectangle: Rectangle,
    /// Its relaxation.
    pub relax: RelaxReport,
    /// The tile frame and the relaxed pitches.
    pub frame: TileFrame,
}

/// The compensated layout of `chart` (module documentation): relaxes the characteristic
/// rectangle and applies its loop shapes to the whole chart, centred on the flat layout.
/// Simulate it with [`compensated_step_settings`].
pub fn compensated_layout(
    chart: &Chart,
    params: &YarnParams,
    layout_params: &LayoutParams,
    settings: &CompensationSettings,
) -> Result<(Layout, CompensationReport), RestShapeError> {
    settings.validate()?;
    layout_params.validate()?;
    params.validate().map_err(RestShapeError::Invalid)?;
    let loops = |extent: f64, size: f64| (extent / size).ceil() as usize;
    let min_loops = (
        loops(settings.min_extent, layout_params.loop_width),
        loops(settings.min_extent, layout_params.row_height),
    );
    // A 5 cm rectangle of 3 mm loops is 17 loops; a limit far above any sensible size keeps
    // a tiny loop width from asking for millions of loops.
    if min_loops.0.max(min_loops.1) > 200 {
        return Err(RestShapeError::Invalid(format!(
            "min_extent {} m needs {min_loops:?} loops (at most 200 each way)",
            settings.min_extent
        )));
    }
    let rect = Rectangle::new(chart, min_loops, settings.margin)?;
    let (relaxed, relax) = relax_rectangle(&rect, params, layout_params, settings)?;
    let flat = Layout::new(&Topology::knit(chart), layout_params)?;
    let centre = flat.positions.iter().sum::<V3>() / flat.positions.len() as f64;
    let layout = transfer(chart, &rect, &relaxed, centre)?;
    let frame = tile_frame(&rect, &relaxed.positions)?;
    Ok((
        layout,
        CompensationReport {
            rectangle: rect,
            relax,
            frame,
        },
    ))
}

/// A simulator of `chart` started from its compensated layout ([`compensated_layout`]):
/// steps `step` without the settling ramps ([`compensated_step_settings`]), the wrapping rest
/// angles those of the flat layout the rectangle relaxed against
/// ([`Simulator::set_wrapping_reference`]). Also returns the compensated and the flat
/// layout and the report.
pub fn compensated_simulator(
    chart: &Chart,
    params: &YarnParams,
    layout_params: &LayoutParams,
    forces: ForceSet,
    step: &StepSettings,
    settings: &CompensationSettings,
) -> Result<(Simulator, Layout, Layout, CompensationReport), RestShapeError> {
    let (layout, report) = compensated_layout(chart, params, layout_params, settings)?;
    let topology = Topology::knit(chart);
    let flat = Layout::new(&topology, layout_params)?;
    let mut sim = Simulator::new(
        topology,
        &layout,
        *params,
        forces,
        compensated_step_settings(step),
    )?;
    sim.set_wrapping_reference(&flat)?;
    Ok((sim, layout, flat, report))
}

/// `settings` with the wrapping ramp switched off (ramp time 0), for simulating a
/// compensated layout: its contacts are already wrapped (module documentation).
pub fn compensated_step_settings(settings: &StepSettings) -> StepSettings {
    StepSettings {
        wrapping_ramp_time: 0.0,
        ..settings.clone()
    }
}
