//! Loading–unloading cycles between side clamps (seed 000 §4.5, Fig. 9): the residual
//! deformation left by friction.

use anyhow::Context;

use super::clamps::SideClamps;
use super::swatch::{SwatchSettings, settled};
use crate::chart::Chart;
use crate::integrator::Simulator;

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
