//! The rib stretch of seed 000 §5.2.3 (Fig. 11): a settled 2 × 2 rib pulled between side
//! clamps.

use std::time::Instant;

use anyhow::Context;

use super::clamps::SideClamps;
use super::swatch::{SwatchSettings, centroid, elastic_energies, positions, run_steps, swatch};
use crate::chart::Chart;
use crate::forces::TermKind;
use crate::integrator::Simulator;

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
        let width_ratio = crate::measure::course_width(&topo, &positions(&sim))?
            / crate::measure::course_width(&topo, &layout.positions)?;
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
