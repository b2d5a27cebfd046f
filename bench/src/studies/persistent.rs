//! Swatch experiments of the persistent-contact simulator (seed 000), shared by the
//! `rib-stretch`, `curl`, `plasticity` and `persistent-time-vs-error` figures.
//!
//! Every swatch uses the Table 1 sweater yarn (R = 0.75 mm) with a loop width of 3 mm, no
//! gravity, Table 1 mass damping α = 10 /s and the simulator's default force terms. A swatch
//! is first **settled**: simulated free (no pins) from the flat layout while the stitch
//! wrapping rest angles ramp in ([`StepSettings::wrapping_ramp_time`], 0.1 s), until
//! `settle_time`. Experiments then clamp edges at their settled positions.

use std::time::Instant;

use anyhow::Context;
use rod::geometry::V3;
use sim_persistent::chart::Chart;
use sim_persistent::forces::{ForceSet, TermKind};
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_column_nodes};

/// Loop width of every swatch (m).
pub const LOOP_WIDTH: f64 = 3e-3;

/// Table 1 mass damping (1/s).
pub const ALPHA: f64 = 10.0;

/// How a swatch is simulated.
#[derive(Clone, Debug)]
pub struct SwatchSettings {
    /// Time step (s).
    pub dt: f64,
    /// Absolute Newton force tolerance (N). Forces are ≈ 1 mN; 1e-7 N is below what the
    /// figures resolve (see `sim-persistent/tests/curl.rs`).
    pub newton_abs_tol: f64,
    /// Simulated time of the free settling (s).
    pub settle_time: f64,
    /// The force terms.
    pub forces: ForceSet,
    /// Re-solves of the friction return mapping per step
    /// ([`StepSettings::friction_return_mapping`]; 0: the paper's explicit anchor update).
    pub friction_return_mapping: usize,
    /// The yarn.
    pub params: YarnParams,
}

impl Default for SwatchSettings {
    fn default() -> Self {
        let mut params = YarnParams::sweater();
        params.gravity *= 0.0;
        Self {
            dt: 1e-3,
            newton_abs_tol: 1e-7,
            settle_time: 0.3,
            friction_return_mapping: StepSettings::default().friction_return_mapping,
            forces: ForceSet {
                gravity: false,
                ..ForceSet::default()
            },
            params,
        }
    }
}

impl SwatchSettings {
    /// The integrator settings.
    pub fn step_settings(&self) -> StepSettings {
        let mut s = StepSettings {
            dt: self.dt,
            rayleigh_alpha: ALPHA,
            friction_return_mapping: self.friction_return_mapping,
            ..StepSettings::default()
        };
        s.newton.gradient_abs_tol = self.newton_abs_tol;
        s
    }

    /// Number of steps covering `time` (s), at least one.
    pub fn steps(&self, time: f64) -> usize {
        ((time / self.dt).round() as usize).max(1)
    }
}

/// A swatch of `chart` in its flat layout.
pub fn swatch(chart: &Chart, settings: &SwatchSettings) -> anyhow::Result<(Simulator, Layout)> {
    let topo = Topology::knit(chart);
    let layout = Layout::new(
        &topo,
        &LayoutParams::new(LOOP_WIDTH, settings.params.radius),
    )?;
    let sim = Simulator::new(
        topo,
        &layout,
        settings.params,
        settings.forces,
        settings.step_settings(),
    )?;
    Ok((sim, layout))
}

/// Steps `sim` `steps` times; returns the Newton iterations taken.
pub fn run_steps(sim: &mut Simulator, steps: usize) -> anyhow::Result<usize> {
    let mut iterations = 0;
    for k in 0..steps {
        let report = sim
            .step()
            .with_context(|| format!("step {k} at t = {:.4} s", sim.time()))?;
        iterations += report.newton_iterations;
    }
    Ok(iterations)
}

/// A settled free swatch of `chart` (module documentation) and its flat layout.
pub fn settled(chart: &Chart, settings: &SwatchSettings) -> anyhow::Result<(Simulator, Layout)> {
    let (mut sim, layout) = swatch(chart, settings)?;
    run_steps(&mut sim, settings.steps(settings.settle_time)).context("settling")?;
    Ok((sim, layout))
}

/// Node positions of `sim`'s current state.
pub fn positions(sim: &Simulator) -> Vec<V3> {
    let q = &sim.state().q;
    (0..sim.topology().nodes.len())
        .map(|n| sim.dofs().position(q, n))
        .collect()
}

/// Centroid of `nodes` at `positions`.
pub fn centroid(positions: &[V3], nodes: &[usize]) -> V3 {
    nodes.iter().map(|&n| positions[n]).sum::<V3>() / nodes.len() as f64
}

/// Elastic energies by term, excluding inertia and damping (J).
pub fn elastic_energies(sim: &Simulator) -> Vec<(TermKind, f64)> {
    sim.energy_by_kind()
        .into_iter()
        .filter(|(k, _)| !matches!(k, TermKind::Inertia | TermKind::Damping))
        .collect()
}

/// A short name of a term kind for tables and legends.
pub fn kind_name(kind: TermKind) -> String {
    let debug = format!("{kind:?}");
    let mut out = String::new();
    for (i, c) in debug.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('_');
        }
        out.extend(c.to_lowercase());
    }
    out
}

/// Clamps over the first and last columns of a knit `w` stitches wide and `h` rows tall,
/// pinned where the nodes are now.
pub struct SideClamps {
    /// Nodes of the left clamp.
    pub left: Vec<usize>,
    /// Nodes of the right clamp.
    pub right: Vec<usize>,
    /// Unit vector from the left clamp's centroid to the right one's.
    pub axis: V3,
    /// Distance between the centroids (m).
    pub distance: f64,
}

impl SideClamps {
    /// Pins both clamps of `sim`.
    pub fn pin(sim: &mut Simulator, w: usize, h: usize) -> anyhow::Result<Self> {
        let left = knit_column_nodes(w, h, 0);
        let right = knit_column_nodes(w, h, w - 1);
        sim.pin_nodes(&left)?;
        sim.pin_nodes(&right)?;
        let p = positions(sim);
        let span = centroid(&p, &right) - centroid(&p, &left);
        Ok(Self {
            left,
            right,
            axis: span.normalize(),
            distance: span.norm(),
        })
    }
}

/// A rib stretch (seed 000 §5.2.3, Fig. 11): a settled `width × height` 2 × 2 rib is clamped
/// over its first and last columns, and the right clamp is driven away from the left one at
/// `speed` along the line between them, up to `extension`.
#[derive(Clone, Debug)]
pub struct RibStretch {
    /// Stitches per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Clamp speed (m/s).
    pub speed: f64,
    /// Total clamp travel (m).
    pub extension: f64,
    /// Samples are taken every `sample_every` of clamp travel (m); a multiple of
    /// `speed · dt` for every dt compared.
    pub sample_every: f64,
    /// Simulation settings.
    pub settings: SwatchSettings,
}

/// One sample of a [`RibStretch`].
#[derive(Clone, Debug)]
pub struct StretchSample {
    /// Clamp travel since the start of the pull (m).
    pub extension: f64,
    /// Side-to-side distance: between the centroids of the two clamps (m).
    pub distance: f64,
    /// Pull of the moving clamp along the stretch direction (N): minus the yarns' force on
    /// its nodes, projected.
    pub force: f64,
    /// Elastic energies by term (J).
    pub energies: Vec<(TermKind, f64)>,
    /// Sliding coordinates that slipped in the steps since the previous sample.
    pub slipped: usize,
}

/// The result of a [`RibStretch`].
#[derive(Clone, Debug)]
pub struct RibStretchRun {
    /// Side-to-side width of the free settled swatch over its laid-out width.
    pub settled_width_ratio: f64,
    /// Samples, the first at zero travel.
    pub samples: Vec<StretchSample>,
    /// Degrees of freedom.
    pub dofs: usize,
    /// Steps of the pull.
    pub steps: usize,
    /// Newton iterations of the settle and the pull.
    pub newton_iterations: usize,
    /// Wall time of settle + pull (s).
    pub seconds: f64,
    /// Steps of the pull whose friction return mapping still changed modes after its last
    /// re-solve (kept with the explicit update; 0 without the return mapping).
    pub friction_unresolved: usize,
}

/// A rib of a [`RibStretch`] settled free (before its clamps close).
#[derive(Clone)]
pub struct SettledRib {
    /// The simulator in the settled state.
    pub sim: Simulator,
    /// Side-to-side width of the settled swatch over its laid-out width.
    pub width_ratio: f64,
    /// Newton iterations of the settle.
    pub newton_iterations: usize,
    /// Wall time of the settle (s).
    pub seconds: f64,
}

impl RibStretch {
    /// Runs the experiment: settles and pulls with [`RibStretch::settings`]. The run's
    /// Newton iterations and wall time cover both.
    pub fn run(&self) -> anyhow::Result<RibStretchRun> {
        let settled = self.settle()?;
        let mut run = self.pull(&settled, &self.settings)?;
        run.newton_iterations += settled.newton_iterations;
        run.seconds += settled.seconds;
        Ok(run)
    }

    /// Settles the rib free with [`RibStretch::settings`].
    pub fn settle(&self) -> anyhow::Result<SettledRib> {
        let start = Instant::now();
        let s = &self.settings;
        let chart = Chart::rib(self.width, self.height, 2, 2)?;
        let (mut sim, layout) = swatch(&chart, s)?;
        let newton_iterations =
            run_steps(&mut sim, s.steps(s.settle_time)).context("settling the rib")?;
        let topo = sim.topology().clone();
        let width_ratio = sim_persistent::measure::course_width(&topo, &positions(&sim))?
            / sim_persistent::measure::course_width(&topo, &layout.positions)?;
        Ok(SettledRib {
            sim,
            width_ratio,
            newton_iterations,
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// Clamps a copy of `settled` and pulls it with the time step, Newton tolerance and
    /// friction update of `settings` (its yarn and force terms must be the settle's). The
    /// run's Newton iterations and wall time cover the pull only.
    pub fn pull(
        &self,
        settled: &SettledRib,
        settings: &SwatchSettings,
    ) -> anyhow::Result<RibStretchRun> {
        let start = Instant::now();
        let s = settings;
        anyhow::ensure!(
            s.forces == self.settings.forces && s.params == self.settings.params,
            "a pull needs the yarn and force terms of the settle"
        );
        let mut sim = settled.sim.clone();
        sim.set_settings(s.step_settings())?;
        let SideClamps {
            left, right, axis, ..
        } = SideClamps::pin(&mut sim, self.width, self.height)?;
        let per_step = self.speed * s.dt;
        let steps = (self.extension / per_step).round() as usize;
        let sample_stride = ((self.sample_every / per_step).round() as usize).max(1);
        let sample = |sim: &Simulator, extension: f64, slipped: usize| {
            let p = positions(sim);
            StretchSample {
                extension,
                distance: (centroid(&p, &right) - centroid(&p, &left)).norm(),
                force: -sim.force_on_nodes(&right).dot(&axis),
                energies: elastic_energies(sim),
                slipped,
            }
        };
        let mut samples = vec![sample(&sim, 0.0, 0)];
        let mut slipped = 0;
        let mut newton_iterations = 0;
        let mut friction_unresolved = 0;
        for k in 1..=steps {
            sim.displace_pinned_nodes(&right, axis * per_step)?;
            let report = sim
                .step()
                .with_context(|| format!("pull step {k} of {steps} (dt = {} s)", s.dt))?;
            newton_iterations += report.newton_iterations;
            friction_unresolved += report.friction_unresolved;
            slipped += report.slipped;
            if k % sample_stride == 0 {
                samples.push(sample(&sim, k as f64 * per_step, slipped));
                slipped = 0;
            }
        }
        Ok(RibStretchRun {
            settled_width_ratio: settled.width_ratio,
            samples,
            dofs: sim.dofs().n_dofs(),
            steps,
            newton_iterations,
            seconds: start.elapsed().as_secs_f64(),
            friction_unresolved,
        })
    }
}

/// A loading–unloading test between side clamps (seed 000 §4.5, Fig. 9): a settled
/// `chart` swatch is clamped over its first and last columns; for each amplitude the right
/// clamp is driven out at `speed` to that clamp travel and then back until the pull drops to
/// zero. The travel where it does is the **residual deformation** left by the cycle (yarns
/// slid through their contacts against friction and stay there); the next cycle starts
/// there.
#[derive(Clone, Debug)]
pub struct Cycles {
    /// The swatch.
    pub chart: Chart,
    /// Clamp speed (m/s).
    pub speed: f64,
    /// Clamp travel of each cycle's turning point, from the settled clamp distance (m),
    /// increasing.
    pub amplitudes: Vec<f64>,
    /// Simulation settings.
    pub settings: SwatchSettings,
}

/// One recorded state of a [`Cycles`] test.
#[derive(Clone, Debug)]
pub struct CycleSample {
    /// Cycle index.
    pub cycle: usize,
    /// Clamp travel from the settled distance (m).
    pub travel: f64,
    /// Pull of the moving clamp along the stretch direction (N).
    pub force: f64,
    /// Largest |u − u₀| over the free sliding coordinates since the clamps closed (m).
    pub max_slide: f64,
}

/// Result of a [`Cycles`] test.
#[derive(Clone, Debug)]
pub struct CyclesRun {
    /// Samples every step, in order.
    pub samples: Vec<CycleSample>,
    /// Per cycle: (amplitude, residual travel at zero pull, largest slide at the turning
    /// point) (m).
    pub residuals: Vec<(f64, f64, f64)>,
    /// Distance between the clamps when they closed (m).
    pub clamp_distance: f64,
    /// Sliding coordinates that slipped over the whole test.
    pub slipped: usize,
}

impl Cycles {
    /// Runs the test. Errors if a step fails or the pull does not return to zero before
    /// the clamp is back at its start.
    pub fn run(&self) -> anyhow::Result<CyclesRun> {
        let s = &self.settings;
        let (mut sim, _) = settled(&self.chart, s)?;
        let SideClamps {
            right,
            axis,
            distance: clamp_distance,
            ..
        } = SideClamps::pin(&mut sim, self.chart.width(), self.chart.height())?;
        let free_u: Vec<usize> = (0..sim.topology().nodes.len())
            .flat_map(|n| {
                let passes = sim.topology().nodes[n].passes.len();
                (0..passes).map(move |k| (n, k))
            })
            .map(|(n, k)| sim.dofs().u(n, k))
            .filter(|&i| !sim.fixed()[i])
            .collect();
        let u0: Vec<f64> = free_u.iter().map(|&i| sim.state().q[i]).collect();
        let max_slide = |sim: &Simulator| {
            free_u
                .iter()
                .zip(&u0)
                .map(|(&i, u)| (sim.state().q[i] - u).abs())
                .fold(0.0, f64::max)
        };
        let step = self.speed * s.dt;
        let mut travel = 0.0;
        let mut samples = Vec::new();
        let mut residuals = Vec::new();
        let mut slipped = 0;
        let mut advance = |sim: &mut Simulator, dx: f64| -> anyhow::Result<f64> {
            sim.displace_pinned_nodes(&right, axis * dx)?;
            let report = sim
                .step()
                .with_context(|| format!("step at t = {:.4} s", sim.time()))?;
            slipped += report.slipped;
            Ok(-sim.force_on_nodes(&right).dot(&axis))
        };
        for (cycle, &amplitude) in self.amplitudes.iter().enumerate() {
            anyhow::ensure!(
                amplitude - travel >= step,
                "cycle {cycle}: amplitude {amplitude} m is less than one clamp step ({step} m) \
                 beyond the current travel {travel} m"
            );
            while travel < amplitude - 0.5 * step {
                let force = advance(&mut sim, step)?;
                travel += step;
                samples.push(CycleSample {
                    cycle,
                    travel,
                    force,
                    max_slide: max_slide(&sim),
                });
            }
            let slide_at_turn = max_slide(&sim);
            let mut previous = samples.last().expect("at least one loading step").clone();
            let residual = loop {
                anyhow::ensure!(
                    travel > 0.5 * step,
                    "cycle {cycle}: the pull stayed positive back to the start"
                );
                let force = advance(&mut sim, -step)?;
                travel -= step;
                let sample = CycleSample {
                    cycle,
                    travel,
                    force,
                    max_slide: max_slide(&sim),
                };
                samples.push(sample.clone());
                if force <= 0.0 {
                    // Linear interpolation of the zero crossing.
                    let t = previous.force / (previous.force - force);
                    break previous.travel + t * (travel - previous.travel);
                }
                previous = sample;
            };
            residuals.push((amplitude, residual, slide_at_turn));
        }
        Ok(CyclesRun {
            samples,
            residuals,
            clamp_distance,
            slipped,
        })
    }
}

/// `sim`'s yarns rendered as tubes of the yarn radius: the smooth rendering curves of
/// `sim_persistent::output` (each yarn offset by ±R from its contact nodes along the node
/// normal, Catmull-Rom between), seen along `direction` with `up` on screen.
pub fn render(
    sim: &Simulator,
    radius: f64,
    size: (u32, u32),
    direction: [f64; 3],
    up: [f64; 3],
) -> anyhow::Result<yarn_output::render::Rendering> {
    use sim_persistent::output::{CurveOptions, RenderCurves};
    use yarn_output::render::{Camera, Framing, RenderOptions};
    let curves = RenderCurves::from_simulator(
        sim,
        &CurveOptions {
            radius,
            samples_per_segment: 4,
        },
    )?;
    let options = RenderOptions {
        camera: Camera { direction, up },
        framing: Framing::Auto { margin: 0.05 },
        supersample: 2,
        ..RenderOptions::new(size.0, size.1, radius)
    };
    Ok(curves.render(&options, std::path::Path::new("figure image"))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_names_are_snake_case() {
        assert_eq!(kind_name(TermKind::StitchLength), "stitch_length");
        assert_eq!(kind_name(TermKind::Bending), "bending");
    }
}
