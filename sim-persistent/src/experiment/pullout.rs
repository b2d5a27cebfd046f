//! Yarn pull-out (seed 000 §5.2.4, Fig. 13): "We take a garter fabric, fix its boundaries
//! except on one row, and pull on the yarn that makes the row. […] break the required contacts
//! by turning 5-DoF nodes into two 3-DoF nodes (one for each yarn)."
//!
//! **Set-up.** A garter swatch knitted with one yarn per row. The pulled row's yarn gets a
//! *handle*: one more node past its right end, `handle` metres to the right, a material point
//! of the yarn (one-yarn node) that is pinned and driven along +x at `speed`. Its other end
//! (the left) is made free to slide. The nodes of the four edges (cast-on and bind-off rows,
//! first and last stitch columns) are pinned where they lie, except those the pulled yarn
//! passes through. The swatch first settles under the pins while the wrapping rest angles
//! ramp in.
//!
//! **Contact breaking.** The sliding coordinate `u` of a pass is the material coordinate of
//! the yarn at its node. The free end's material starts at `u = 0`, so when the pass at the
//! free end reaches `u < 0` the end has slid through that node: the pass leaves the node
//! ([`Simulator::break_passes`]) and the yarn's next pass becomes its free end. The node
//! keeps its other yarn, whose sliding is then pinned (a one-yarn node is a material point:
//! the paper's 3-DoF node). Stitch contacts the yarn leaves are dropped with their wrapping,
//! stitch-length and friction terms; the simulation goes on without a restart. The pull ends
//! after `distance`, or when the pulled yarn has only its handle and one more pass left.
//!
//! **Differences from the paper.** No collapse of short segments is needed: the free end's
//! segment grows as material flows out of it, and the segment floor
//! ([`crate::forces::segment_floor`]) keeps the others from draining. The yarn beyond the free
//! end's last contact is not simulated (no nodes, no mass).

use anyhow::Context;
use rod::geometry::V3;

use super::swatch::{LOOP_WIDTH, SwatchSettings, positions, run_steps};
use crate::chart::Chart;
use crate::forces::ForceSet;
use crate::integrator::Simulator;
use crate::layout::{Layout, LayoutParams};
use crate::topology::{FabricKind, Topology, TopologyError};

/// A pull-out experiment (module documentation).
#[derive(Clone, Debug)]
pub struct PullOut {
    /// The swatch (knitted one yarn per row).
    pub chart: Chart,
    /// The pulled row (0-based; an interior row, `1..height − 1`).
    pub row: usize,
    /// Yarn, forces, time step, settling.
    pub settings: SwatchSettings,
    /// Pull speed of the handle (m/s).
    pub speed: f64,
    /// Pulled distance (m).
    pub distance: f64,
    /// Distance of the handle past the row's right end (m).
    pub handle: f64,
    /// Pulled distances (m) at which to keep a copy of the simulator (for images).
    pub snapshots: Vec<f64>,
}

/// One sample of the pull.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PullOutSample {
    /// Distance the handle moved (m).
    pub pulled: f64,
    /// Force the handle applies along the pull (N).
    pub force: f64,
    /// Passes of the pulled yarn still on the fabric (besides the handle).
    pub passes: usize,
    /// Stitch contacts of the whole swatch.
    pub contacts: usize,
}

/// The result of [`PullOut::run`].
pub struct PullOutRun {
    /// One sample per step.
    pub samples: Vec<PullOutSample>,
    /// `(pulled distance, simulator)` at the requested snapshots (the first is the settled
    /// swatch before the pull).
    pub snapshots: Vec<(f64, Simulator)>,
    /// Passes that left their node during the pull.
    pub broken: usize,
    /// Passes that left their node while the pinned swatch settled, before the pull: the free
    /// end starts at `u = 0` and slips under the settling tension.
    pub broken_settling: usize,
    /// Pulled distance (m) at which the yarn was out (only the handle and one pass left).
    pub out_at: Option<f64>,
    /// The step that failed, if one did (the samples end before it).
    pub failure: Option<String>,
    /// Newton iterations over the pull.
    pub newton_iterations: usize,
}

impl PullOut {
    /// A `width × height` garter pulled at its middle row, 0.05 m/s over `distance`, handle
    /// one loop width past the edge, the Table 1 sweater yarn without gravity, settled for
    /// 0.1 s (the wrapping ramp). Friction is Coulomb-consistent (the return mapping, at most
    /// 5 re-solves a step, with loop contact): with the paper's explicit anchor update a
    /// yarn pulled at 5 cm/s meets a viscous brake ≈ `k_f dt` ([`crate::forces::friction`])
    /// and stretches (10.6 N at 30 mm on a 5 × 5 garter, measured) instead of sliding out.
    /// dt = 0.5 ms and a Newton tolerance of 1e-6 N (forces of a few mN): at 1 ms a step
    /// of the 5 × 5 pull failed after 7 mm, measured.
    pub fn garter(width: usize, height: usize, distance: f64) -> anyhow::Result<Self> {
        Ok(Self {
            chart: Chart::garter(width, height)?,
            row: height / 2,
            settings: SwatchSettings {
                dt: 5e-4,
                newton_abs_tol: 1e-6,
                settle_time: 0.1,
                friction_return_mapping: 5,
                forces: ForceSet {
                    gravity: false,
                    loop_contact: true,
                    ..ForceSet::default()
                },
                ..SwatchSettings::default()
            },
            speed: 0.05,
            distance,
            handle: LOOP_WIDTH,
            snapshots: Vec::new(),
        })
    }

    /// The swatch with the handle: its simulator (pinned, not settled), the pulled yarn and
    /// the handle node.
    pub fn build(&self) -> anyhow::Result<(Simulator, usize, usize)> {
        let (w, h) = (self.chart.width(), self.chart.height());
        anyhow::ensure!(
            self.chart.is_rectangular() && w >= 2 && h >= 3 && (1..h - 1).contains(&self.row),
            "pull-out needs a rectangular K/P chart of ≥ 2 × 3 stitches and an interior row, \
             got {w} × {h} and row {}",
            self.row
        );
        anyhow::ensure!(
            self.speed > 0.0 && self.distance > 0.0 && self.handle > 0.0,
            "pull-out speed, distance and handle must be > 0"
        );
        let knit = Topology::knit(&self.chart);
        let yarn = self.row;
        let (topo, handle) = with_handle(&knit, yarn)?;
        let params = LayoutParams::new(LOOP_WIDTH, self.settings.params.radius);
        let mut layout = Layout::new(&topo, &params)?;
        // The handle lies past the right end; its sliding coordinate continues the yarn's.
        let passes = &topo.yarns[yarn].passes;
        let last = passes[passes.len() - 2];
        layout.positions[handle] = layout.positions[last.node] + V3::new(self.handle, 0.0, 0.0);
        layout.sliding[handle][0] = layout.sliding[last.node][last.slot] + self.handle;
        let mut sim = Simulator::new(
            topo,
            &layout,
            self.settings.params,
            self.settings.forces,
            self.settings.step_settings(),
        )?;
        let on_yarn: Vec<usize> = sim.topology().yarns[yarn]
            .passes
            .iter()
            .map(|p| p.node)
            .collect();
        let map = knit
            .knit
            .as_ref()
            .context("a knit topology has a knit map")?;
        let mut edges: Vec<usize> = map.boundary_nodes(0);
        edges.extend(map.boundary_nodes(h));
        edges.extend(map.edge_nodes(false));
        edges.extend(map.edge_nodes(true));
        edges.sort_unstable();
        edges.dedup();
        edges.retain(|n| !on_yarn.contains(n));
        edges.push(handle);
        sim.pin_nodes(&edges)?;
        Ok((sim, yarn, handle))
    }

    /// Settles, then pulls (module documentation).
    pub fn run(&self) -> anyhow::Result<PullOutRun> {
        let (mut sim, yarn, handle) = self.build()?;
        let s = &self.settings;
        run_steps(&mut sim, s.steps(s.settle_time)).context("settling the pinned swatch")?;
        let broken_settling = break_free_end(&mut sim, yarn)?;
        let mut broken = 0;
        let mut snapshots = Vec::new();
        let mut wanted: Vec<f64> = self.snapshots.clone();
        wanted.sort_by(f64::total_cmp);
        let mut next = 0;
        let steps = s.steps(self.distance / self.speed);
        let dx = self.distance / steps as f64;
        let mut samples = Vec::with_capacity(steps);
        let (mut failure, mut out_at) = (None, None);
        let mut newton_iterations = 0;
        for k in 0..=steps {
            let pulled = k as f64 * dx;
            if k > 0 {
                sim.displace_pinned_nodes(&[handle], V3::new(dx, 0.0, 0.0))?;
                match sim.step() {
                    Ok(r) => newton_iterations += r.newton_iterations,
                    Err(e) => {
                        failure = Some(format!("step at {pulled:.4} m pulled failed: {e}"));
                        break;
                    }
                }
                broken += break_free_end(&mut sim, yarn)?;
            }
            let force = -sim.force_on_nodes(&[handle]).x;
            let passes = sim.topology().yarns[yarn].passes.len() - 1;
            samples.push(PullOutSample {
                pulled,
                force,
                passes,
                contacts: sim.topology().stitch_contacts.len(),
            });
            while next < wanted.len() && wanted[next] <= pulled + 0.5 * dx {
                snapshots.push((pulled, sim.clone()));
                next += 1;
            }
            if passes <= 1 {
                out_at = Some(pulled);
                break;
            }
        }
        anyhow::ensure!(
            positions(&sim)
                .iter()
                .all(|p| p.iter().all(|c| c.is_finite())),
            "non-finite positions after the pull"
        );
        Ok(PullOutRun {
            samples,
            snapshots,
            broken,
            broken_settling,
            out_at,
            failure,
            newton_iterations,
        })
    }
}

/// `topology` with one more one-yarn node appended to the end of `yarn` (the handle), and the
/// yarn's first pass free to slide where its node holds another yarn. Returns the topology
/// and the handle node.
pub fn with_handle(topology: &Topology, yarn: usize) -> Result<(Topology, usize), TopologyError> {
    if !matches!(topology.kind, FabricKind::Knit(_)) || yarn >= topology.yarns.len() {
        return Err(TopologyError::Invalid(format!(
            "no knit yarn {yarn} to put a handle on"
        )));
    }
    let handle = topology.nodes.len();
    let mut yarn_nodes: Vec<Vec<usize>> = topology
        .yarns
        .iter()
        .map(|y| y.passes.iter().map(|p| p.node).collect())
        .collect();
    yarn_nodes[yarn].push(handle);
    let mut topo = Topology::from_yarn_nodes(handle + 1, &yarn_nodes, topology.kind.clone());
    // Appending at the end keeps every pass index: the stitch contacts carry over.
    topo.stitch_contacts = topology.stitch_contacts.clone();
    topo.crossings = topology.crossings.clone();
    topo.knit = topology.knit.clone();
    let first = topo.yarns[yarn].passes[0];
    if topo.nodes[first.node].passes.len() > 1 {
        topo.nodes[first.node].passes[first.slot].sliding_pinned = false;
    }
    topo.validate()?;
    Ok((topo, handle))
}

/// Breaks the stitch contact at `yarn`'s free start once the end has slid through it
/// (module documentation), repeatedly; returns how many passes left. The passes of a knit
/// yarn come in pairs through the two nodes of one stitch contact; the end leaves a contact
/// with both: `u < 0` at the first pass means the end has slid into the contact, and the
/// node behind it would otherwise keep a half contact without a stacking order.
fn break_free_end(sim: &mut Simulator, yarn: usize) -> anyhow::Result<usize> {
    let mut broken = 0;
    loop {
        let topo = sim.topology();
        let passes = &topo.yarns[yarn].passes;
        if passes.len() <= 3 {
            return Ok(broken);
        }
        let first = passes[0];
        let node = &topo.nodes[first.node];
        if node.passes.len() < 2 || node.passes[first.slot].sliding_pinned {
            return Ok(broken);
        }
        let u = sim.state().q[sim.dofs().u(first.node, first.slot)];
        if u >= 0.0 {
            return Ok(broken);
        }
        let pair = topo
            .stitch_contacts
            .iter()
            .flat_map(|sc| sc.strands())
            .any(|st| st.yarn == yarn && st.indices().contains(&0) && st.indices().contains(&1));
        let removed: &[(usize, usize)] = if pair {
            &[(yarn, 0), (yarn, 0)]
        } else {
            &[(yarn, 0)]
        };
        sim.break_passes(removed)
            .with_context(|| format!("breaking yarn {yarn} at node {}", first.node))?;
        broken += removed.len();
    }
}
