//! The virtual swatch test of seed 002 §4.3 on the persistent-contact simulator: a
//! rectangular swatch, settled free, clamped over two opposite edges and stretched
//! quasi-statically between them with the other two edges free, measuring the clamp force and
//! the orthogonal compression at the swatch's middle.
//!
//! - **Weft** pulls between the side clamps (first and last stitch column of a knit, first and
//!   last warp of a weave), **warp** between the row clamps (cast-on and bind-off of a knit,
//!   first and last weft of a weave). **Bias** needs clamps along a diagonal of the stitch
//!   grid, which a rectangular swatch of these topologies does not have: it is refused with
//!   an error rather than approximated.
//! - The swatch is clamped flat in its layout and settles between the clamps (damped
//!   dynamics for [`SwatchSettings::settle_time`], then a static solve: the first sample), or,
//!   with [`UniaxialTest::settle_free`], settles free first and is clamped where it lies.
//! - With [`UniaxialTest::zero_force_start`] the pulled clamp is then moved to where the
//!   swatch exerts no force on it, and the curve starts there.
//! - Every load step moves the pulled clamp by `max_stretch · L₀ / steps` along the line
//!   between the clamps and solves the static equilibrium
//!   ([`Simulator::solve_static`]; friction anchors updated after every solve), so the curve
//!   does not depend on a pulling speed or on damping. A step whose solve fails is retried in
//!   halves (at most [`MAX_HALVINGS`] times).
//! - **Stretch** `s = L/L₀ − 1`, `L` the distance between the clamps' centroids.
//! - **Width.** Two lines of yarn crossings parallel to the pull (row boundaries of a knit
//!   pulled in weft, stitch columns of a knit pulled in warp, wefts or warps of a weave), each
//!   a quarter of the way in from a free edge, measure the width: `w` is the length of the
//!   polyline through the centroids of every line's nodes in the middle third of the span
//!   between the clamps, from the one line to the other: the width along the fabric, so a
//!   curled swatch is measured unrolled. The free edges themselves are not used: they curl
//!   (a stockinette rolls up), and a rolled edge says nothing about the contraction.
//! - **Stress** `σ = F / W₀` (N/m): `F` the pull on the moving clamp along the axis, `W₀` the
//!   swatch's width across the pull at the start: the number of yarn periods across (rows,
//!   stitch columns or yarns) times their spacing measured at the start (`w₀` over the
//!   periods between the two lines). This is the stress of a periodic tile, whose width is a
//!   whole number of periods.
//! - **Compression** `c = 1 − w/w₀` at the middle.
//!
//! A finite swatch is not a homogeneous one: near the clamps the fabric cannot contract, and
//! its free edges are not periodic. Those boundary effects are what a cross-method comparison
//! with the periodic tile measures.

use std::time::Instant;

use anyhow::Context;
use rod::geometry::V3;

use super::clamps::{ClampSet, Grid};
use super::swatch::{LOOP_WIDTH, SwatchSettings, centroid, positions, run_steps};
use crate::integrator::Simulator;
use crate::layout::{Layout, LayoutParams};
use crate::topology::Fabric;
use crate::topology::{Construction, knit_boundary_nodes, knit_column_nodes};

/// Most halvings of a load step whose static solve fails.
pub const MAX_HALVINGS: u32 = 4;

/// The direction of a virtual swatch test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pull {
    /// Along the courses (x): between the side clamps.
    Weft,
    /// Along the wales (y): between the row clamps.
    Warp,
}

impl Pull {
    /// `weft` or `warp`.
    pub fn name(self) -> &'static str {
        match self {
            Pull::Weft => "weft",
            Pull::Warp => "warp",
        }
    }

    /// The direction named `name`; `bias` is refused with the reason (module documentation).
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "weft" => Ok(Pull::Weft),
            "warp" => Ok(Pull::Warp),
            "bias" => Err(
                "a bias test needs clamps along a diagonal of the stitch grid, which \
                 a rectangular swatch does not have; use weft or warp"
                    .into(),
            ),
            other => Err(format!(
                "unknown test direction \"{other}\" (expected weft or warp)"
            )),
        }
    }

    /// `(fixed clamp, pulled clamp)`.
    fn clamp_sets(self) -> [ClampSet; 2] {
        match self {
            Pull::Weft => [ClampSet::Left, ClampSet::Right],
            Pull::Warp => [ClampSet::CastOn, ClampSet::BindOff],
        }
    }
}

/// A virtual uniaxial swatch test (module documentation).
#[derive(Clone, Debug)]
pub struct UniaxialTest {
    /// The swatch.
    pub fabric: Fabric,
    /// Direction of the pull.
    pub pull: Pull,
    /// Largest stretch `s` (unitless, > 0).
    pub max_stretch: f64,
    /// Quasi-static load steps up to `max_stretch` (≥ 1); every step is a sample.
    pub steps: usize,
    /// The flat layout the swatch starts from (loop width and row height of a knit, yarn
    /// spacing of a weave).
    pub layout: LayoutParams,
    /// The yarn and the force terms; with [`UniaxialTest::settle_free`] also the free settle
    /// ([`SwatchSettings::settle_time`], dynamic with mass damping
    /// [`ALPHA`](super::swatch::ALPHA)).
    pub settings: SwatchSettings,
    /// Settle the swatch free before clamping it (`true`), or clamp it flat in its layout and
    /// let it find its equilibrium between the clamps (`false`, the default: a fabric is
    /// mounted flat in a test machine, while a free stockinette of a few stitches rolls up
    /// into a tube whose clamped edges are no longer a clamp line).
    pub settle_free: bool,
    /// Start the curve where the clamps carry no force (`true`): after the settle, the pulled
    /// clamp is moved along the pull until the swatch's force on it changes sign, and then back
    /// to the interpolated zero (`zero_force`), as a test machine removes the slack and
    /// the preload before it measures. `L₀` is then the zero-force length, and the curve
    /// starts stress-free, as a relaxed periodic tile does. `false` (the default): the curve
    /// starts at the layout's clamp distance, with whatever force the settled swatch exerts
    /// there (seed 000's loops are bent at rest, so a clamped swatch pushes or pulls).
    pub zero_force_start: bool,
}

/// Most static solves of the zero-force start's search
/// ([`UniaxialTest::zero_force_start`]).
pub const ZERO_FORCE_MAX_SOLVES: usize = 200;

/// One load step of a [`UniaxialTest`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniaxialSample {
    /// Stretch `s = L/L₀ − 1` between the clamps (unitless).
    pub stretch: f64,
    /// Pull on the moving clamp along the axis (N).
    pub force: f64,
    /// `σ = F/W₀` (N/m).
    pub stress: f64,
    /// Orthogonal compression at the middle, `1 − w/w₀` (unitless).
    pub compression: f64,
    /// Newton iterations of the step's static solve.
    pub newton_iterations: usize,
}

/// The result of a [`UniaxialTest`].
#[derive(Clone, Debug)]
pub struct UniaxialRun {
    /// The direction.
    pub pull: Pull,
    /// Distance between the clamps at the start (m).
    pub length: f64,
    /// Width `W₀` across the pull at the start (m).
    pub width: f64,
    /// Yarn periods across the pull (the count `W₀` is made of).
    pub periods: usize,
    /// Samples, the first at zero stretch.
    pub samples: Vec<UniaxialSample>,
    /// Degrees of freedom.
    pub dofs: usize,
    /// Newton iterations of the settles (dynamic steps).
    pub settle_iterations: usize,
    /// Wall time, settle included (s).
    pub seconds: f64,
    /// Why the curve ends before `max_stretch` ([`UniaxialTest::run_until_failure`]).
    pub failure: Option<String>,
}

impl UniaxialTest {
    /// Settles the swatch, clamps it and stretches it (module documentation). A load step
    /// that fails after its halvings is an error.
    pub fn run(&self) -> anyhow::Result<UniaxialRun> {
        let run = self.run_until_failure()?;
        match &run.failure {
            Some(e) => Err(anyhow::anyhow!("{e}")),
            None => Ok(run),
        }
    }

    /// [`UniaxialTest::run`], but a load step that fails after its halvings ends the curve:
    /// the run keeps the samples before it and says why in [`UniaxialRun::failure`]. The
    /// settle, the first static solve and the zero-force start must succeed.
    pub fn run_until_failure(&self) -> anyhow::Result<UniaxialRun> {
        let start = Instant::now();
        anyhow::ensure!(
            self.max_stretch.is_finite() && self.max_stretch > 0.0 && self.steps >= 1,
            "a uniaxial test needs max_stretch > 0 and at least one step, got {} and {}",
            self.max_stretch,
            self.steps
        );
        if let Fabric::Knit(chart, construction) = &self.fabric {
            anyhow::ensure!(
                chart.is_rectangular() && *construction != Construction::Round,
                "a uniaxial test needs a rectangular K/P chart knitted flat (its clamps and \
                 width lines follow the stitch grid); this chart changes its width or is \
                 knitted in the round"
            );
        }
        let s = &self.settings;
        let topology = self.fabric.topology()?;
        let layout = Layout::new(&topology, &self.layout)?;
        let mut sim = Simulator::new(topology, &layout, s.params, s.forces, s.step_settings())?;
        let settle_iterations = if self.settle_free {
            run_steps(&mut sim, s.steps(s.settle_time)).context("settling the swatch")?
        } else {
            0
        };

        let grid = Grid::from(&self.fabric);
        let [fixed, pulled] = self
            .pull
            .clamp_sets()
            .map(|set| set.nodes(grid).map_err(anyhow::Error::msg));
        let (fixed, pulled) = (fixed?, pulled?);
        sim.pin_nodes(&fixed)?;
        sim.pin_nodes(&pulled)?;
        let p = positions(&sim);
        let span = centroid(&p, &pulled) - centroid(&p, &fixed);
        let length = span.norm();
        anyhow::ensure!(length > 0.0, "the clamps coincide after the settle");
        let axis = span / length;
        // Two interior lines along the pull, a quarter of the way in from either free edge:
        // a free edge curls (stockinette rolls up), so it does not measure the fabric's width.
        let (count, periods, line) = lines(&self.fabric, self.pull);
        anyhow::ensure!(
            count >= 4,
            "the swatch needs at least four yarn lines along the pull to measure its width \
             away from its free edges, found {count}"
        );
        let a = (count / 4).max(1);
        let b = count - 1 - a;
        let lines_between: Vec<Vec<usize>> = (a..=b).map(&line).collect();
        let fixed_nodes = fixed.clone();
        let width_at = |sim: &Simulator| -> anyhow::Result<f64> {
            let p = positions(sim);
            let origin = centroid(&p, &fixed_nodes);
            let l = (centroid(&p, &pulled) - origin).dot(&axis);
            let middle = |nodes: &[usize]| -> anyhow::Result<V3> {
                let inside: Vec<usize> = nodes
                    .iter()
                    .copied()
                    .filter(|&n| {
                        let t = (p[n] - origin).dot(&axis) / l;
                        (1.0 / 3.0..=2.0 / 3.0).contains(&t)
                    })
                    .collect();
                anyhow::ensure!(
                    !inside.is_empty(),
                    "no node of a measuring line lies in the middle third of the swatch"
                );
                Ok(centroid(&p, &inside))
            };
            // Along the fabric's surface: through every line in between, so that a curled
            // swatch is measured unrolled.
            let mids = lines_between
                .iter()
                .map(|l| middle(l))
                .collect::<anyhow::Result<Vec<V3>>>()?;
            Ok(mids.windows(2).map(|w| (w[1] - w[0]).norm()).sum())
        };
        // The reference state: the clamped swatch in equilibrium at zero stretch, reached by a
        // damped dynamic settle between the clamps (a static solve straight from the flat
        // layout of a garter stalls: its rows want to close up far from the layout), then a
        // static solve.
        let mut settle_iterations = settle_iterations;
        if !self.settle_free {
            settle_iterations += run_steps(&mut sim, s.steps(s.settle_time))
                .context("settling the clamped swatch")?;
        }
        let mut first = sim
            .solve_static()
            .context("static solve of the clamped swatch")?;
        let force_at = |sim: &Simulator| -sim.force_on_nodes(&pulled).dot(&axis);
        if self.zero_force_start {
            let probe = 0.5 * self.max_stretch * length / self.steps as f64;
            first.iterations += zero_force(&mut sim, &pulled, axis, (probe, length), force_at)
                .context("moving the clamp to zero force")?;
        }
        // The clamps move only with the zero-force start; L₀ is measured where the curve starts.
        let clamp_distance = |sim: &Simulator| {
            let p = positions(sim);
            (centroid(&p, &pulled) - centroid(&p, &fixed)).norm()
        };
        let length = clamp_distance(&sim);
        let w0 = width_at(&sim)?;
        anyhow::ensure!(w0 > 0.0, "the measuring lines coincide after the settle");
        let width = w0 * periods as f64 / (b - a) as f64;

        let per_step = self.max_stretch * length / self.steps as f64;
        let mut samples = Vec::new();
        let mut sample = |sim: &Simulator, newton_iterations: usize| -> anyhow::Result<()> {
            let force = force_at(sim);
            samples.push(UniaxialSample {
                stretch: clamp_distance(sim) / length - 1.0,
                force,
                stress: force / width,
                compression: 1.0 - width_at(sim)? / w0,
                newton_iterations,
            });
            Ok(())
        };
        sample(&sim, first.iterations)?;
        let mut failure = None;
        for k in 1..=self.steps {
            if failure.is_some() {
                break;
            }
            // A load step whose static solve fails is retried in halves, at most
            // MAX_HALVINGS times (a failed solve leaves the state and the friction anchors as
            // they were; only the clamp is moved back).
            let (mut done, mut part, mut iterations) = (0.0, per_step, 0);
            while done < per_step {
                let d = part.min(per_step - done);
                sim.displace_pinned_nodes(&pulled, axis * d)?;
                match sim.solve_static() {
                    Ok(report) => {
                        iterations += report.iterations;
                        done += d;
                    }
                    Err(e) if part > per_step / f64::from(1 << MAX_HALVINGS) => {
                        sim.displace_pinned_nodes(&pulled, -axis * d)?;
                        part *= 0.5;
                        let _ = e;
                    }
                    Err(e) => {
                        failure = Some(format!(
                            "{} stretch step {k} of {} (s = {:.4}), after {MAX_HALVINGS} \
                             halvings: {e}",
                            self.pull.name(),
                            self.steps,
                            (k - 1) as f64 * per_step / length + done / length
                        ));
                        break;
                    }
                }
            }
            if failure.is_none() {
                sample(&sim, iterations)?;
            }
        }
        Ok(UniaxialRun {
            pull: self.pull,
            length,
            width,
            periods,
            samples,
            dofs: sim.dofs().n_dofs(),
            settle_iterations,
            seconds: start.elapsed().as_secs_f64(),
            failure,
        })
    }
}

/// Moves the `pulled` clamp along `axis` to where `force` (the swatch's pull on it, positive
/// in tension) vanishes ([`UniaxialTest::zero_force_start`]): steps of `step` against the
/// force (out under compression, in under tension), each a static solve and halved up to
/// [`MAX_HALVINGS`] times where the solve fails, until the force changes sign; then one move
/// back to the zero of the straight line through the last two forces, and a last solve (if
/// that solve fails, the clamp returns to the overshoot, whose equilibrium is kept). With
/// friction the force depends on the path (the yarns slip between solves), so the search
/// only ever reverses once, like a test machine backing off its overshoot; the force that
/// remains is the curve's first sample. Returns the Newton iterations. Errors: the force
/// keeps its sign for [`ZERO_FORCE_MAX_SOLVES`] solves (failed ones included), the clamps
/// would come closer than a tenth of their settled distance `length`, a solve still fails
/// after its halvings, or the force is not finite.
fn zero_force(
    sim: &mut Simulator,
    pulled: &[usize],
    axis: V3,
    (step, length): (f64, f64),
    force: impl Fn(&Simulator) -> f64,
) -> anyhow::Result<usize> {
    let f0 = force(sim);
    anyhow::ensure!(f0.is_finite(), "the settled clamp force is {f0}");
    if f0 == 0.0 {
        return Ok(0);
    }
    let direction = -f0.signum();
    let (mut iterations, mut solves) = (0, 0);
    let (mut at, mut f) = (0.0, f0);
    let mut part = step;
    loop {
        anyhow::ensure!(
            solves < ZERO_FORCE_MAX_SOLVES,
            "the clamp force keeps its sign over {ZERO_FORCE_MAX_SOLVES} static solves, failed \
             ones included ({f0:.4e} N at the settled length, {f:.4e} N after moving the clamp \
             {at:.4e} m)"
        );
        let d = direction * part;
        anyhow::ensure!(
            length + at + d > 0.1 * length,
            "the clamps would come within a tenth of their settled distance ({length:.4e} m) \
             without the clamp force changing sign ({f:.4e} N)"
        );
        solves += 1;
        sim.displace_pinned_nodes(pulled, axis * d)?;
        match sim.solve_static() {
            Ok(report) => {
                iterations += report.iterations;
                let next = force(sim);
                anyhow::ensure!(next.is_finite(), "the clamp force became {next}");
                if next.signum() != f.signum() {
                    // Back to the zero of the line through (at, f) and (at + d, next).
                    let back = d * next / (next - f);
                    sim.displace_pinned_nodes(pulled, -axis * back)?;
                    match sim.solve_static() {
                        Ok(report) => iterations += report.iterations,
                        // A failed solve leaves the overshoot's equilibrium: keep it.
                        Err(_) => sim.displace_pinned_nodes(pulled, axis * back)?,
                    }
                    return Ok(iterations);
                }
                (at, f) = (at + d, next);
            }
            Err(e) => {
                sim.displace_pinned_nodes(pulled, -axis * d)?;
                anyhow::ensure!(
                    part > step / f64::from(1 << MAX_HALVINGS),
                    "moving the clamp {at:.4e} m towards zero force, after {MAX_HALVINGS} \
                     halvings: {e}"
                );
                part *= 0.5;
            }
        }
    }
}

/// The lines of yarn crossings parallel to the pull, as `(count, periods across, nodes of
/// line k)`: row boundaries of a knit pulled in weft (`h + 1` lines, `h` rows across), stitch
/// columns of a knit pulled in warp (`w` lines and periods), wefts or warps of a weave.
/// Neighbouring lines are one period apart.
#[allow(clippy::type_complexity)]
fn lines(fabric: &Fabric, pull: Pull) -> (usize, usize, Box<dyn Fn(usize) -> Vec<usize>>) {
    match (fabric, pull) {
        (Fabric::Knit(chart, _), Pull::Weft) => {
            let (w, h) = (chart.width(), chart.height());
            (h + 1, h, Box::new(move |b| knit_boundary_nodes(w, b)))
        }
        (Fabric::Knit(chart, _), Pull::Warp) => {
            let (w, h) = (chart.width(), chart.height());
            (w, w, Box::new(move |c| knit_column_nodes(w, h, c)))
        }
        (&Fabric::Weave { warps, wefts, .. }, Pull::Weft) => (
            wefts,
            wefts,
            Box::new(move |j| (0..warps).map(|i| j * warps + i).collect()),
        ),
        (&Fabric::Weave { warps, wefts, .. }, Pull::Warp) => (
            warps,
            warps,
            Box::new(move |i| (0..wefts).map(|j| j * warps + i).collect()),
        ),
    }
}

/// The default test of `fabric`: 40 % stretch in 20 steps, the swatch settings' defaults
/// (Table 1 sweater yarn, no gravity) in the seed 000 layout (loop width 3 mm).
pub fn default_test(fabric: Fabric, pull: Pull) -> UniaxialTest {
    let settings = SwatchSettings::default();
    UniaxialTest {
        fabric,
        pull,
        max_stretch: 0.4,
        steps: 20,
        layout: LayoutParams::new(LOOP_WIDTH, settings.params.radius),
        settings,
        settle_free: false,
        zero_force_start: false,
    }
}
