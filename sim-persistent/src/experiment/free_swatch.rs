//! A free swatch from its layout, measured as knits are measured ([`crate::fidelity`]): the
//! experiment behind the `knit-fidelity` figure and tests and the `knit_fidelity` example.
//!
//! The swatch: the Table 1 sweater yarn (R = 0.75 mm), no gravity, no pins, Table 1 mass
//! damping α = 10 /s, dt = 1 ms, Newton to 1e-7 N, the simulator's default force terms with
//! the wrapping rest state and yarn self-contact chosen by the experiment, laid out either
//! at a [`Gauge`] or at Table 1's 3 mm loops. It is measured at its layout and after
//! `time` seconds.

use crate::chart::Chart;
use crate::experiment::swatch::{ALPHA, LOOP_WIDTH, positions};
use crate::fidelity::{Contacts, GridShape, contacts, grid_shape};
use crate::forces::ForceSet;
use crate::integrator::{Simulator, StepSettings};
use crate::layout::{Gauge, Layout, LayoutParams};
use crate::measure::{EdgeCurl, edge_curl};
use crate::params::{WrappingRest, YarnParams};
use crate::rest_shape::{
    CompensationSettings, compensated_simulator, elastic_residual_with_reference,
};
use crate::topology::Topology;
use anyhow::Context;

/// What is simulated.
#[derive(Clone, Debug)]
pub struct FreeSwatch {
    /// The chart (knitted flat, one yarn per row).
    pub chart: Chart,
    /// `Some`: laid out at this gauge ([`LayoutParams::at_gauge`]); `None`: Table 1's 3 mm
    /// loops with the default layout ([`LayoutParams::new`]).
    pub gauge: Option<Gauge>,
    /// The wrapping rest state.
    pub wrapping: WrappingRest,
    /// Yarn self-contact ([`crate::forces::yarn_contact`]).
    pub yarn_contact: bool,
    /// Simulated time (s).
    pub time: f64,
    /// `Some`: start from the rest-shape compensated layout ([`crate::rest_shape`], these
    /// settings; without the settling ramps, wrapping rest angles from the flat layout);
    /// `None`: from the flat layout.
    pub compensation: Option<CompensationSettings>,
}

/// The measures of one state of a free swatch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measures {
    /// Grid measures (rectangular K/P charts ≥ 6 × 6 only).
    pub grid: Option<GridShape>,
    /// Interpenetration and stitch measures.
    pub contacts: Contacts,
    /// Edge curl (rectangular K/P charts only, rad).
    pub curl: Option<EdgeCurl>,
}

/// One line per group of measures: gauge and shape, contacts and wrapping, edge curl
/// (lengths in yarn diameters, turns in degrees, curls in rad).
impl std::fmt::Display for Measures {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(g) = self.grid {
            writeln!(
                f,
                "course {:.2} d [p10 {:.2}, p90 {:.2}], row {:.2} d [{:.2}, {:.2}]; turn per \
                 loop {:.1}° (p90 {:.1}, max {:.1}), per row {:.1}° (p90 {:.1}, max {:.1}); \
                 kept {:.2} × {:.2}; roll radius ≥ {:.1} d",
                g.course.median,
                g.course.p10,
                g.course.p90,
                g.row.median,
                g.row.p10,
                g.row.p90,
                g.turn_per_loop.median,
                g.turn_per_loop.p90,
                g.turn_per_loop.max,
                g.turn_per_row.median,
                g.turn_per_row.p90,
                g.turn_per_row.max,
                g.kept_width,
                g.kept_height,
                g.min_roll_radius
            )?;
        }
        let c = self.contacts;
        write!(
            f,
            "closest unstitched {:.2} d, {:.1} % of segments under 0.9 d; degenerate wings \
             {:.1} %",
            c.closest_unstitched,
            100.0 * c.under_09,
            100.0 * c.degenerate_wings
        )?;
        if let Some(j) = c.leg_joint {
            write!(
                f,
                "; leg joints median {:.0}°, {:.0} % below 80°",
                j.median,
                100.0 * c.leg_joints_below_80
            )?;
        }
        if let Some(k) = self.curl {
            write!(
                f,
                "\ncurl sides {:+.2}/{:+.2}, ends {:+.2}/{:+.2} rad",
                k.left, k.right, k.bottom, k.top
            )?;
        }
        Ok(())
    }
}

/// A simulated free swatch.
#[derive(Clone, Debug)]
pub struct FreeSwatchRun {
    /// At the layout.
    pub start: Measures,
    /// After the simulated time.
    pub end: Measures,
    /// Yarn per loop of the layout (d).
    pub yarn_per_loop: f64,
    /// Peak kinetic energy (J).
    pub peak_kinetic: f64,
    /// Kinetic energy at the end (J).
    pub final_kinetic: f64,
    /// Yarn self-contact terms at the end.
    pub contact_terms: usize,
    /// Norm of the elastic force on the free coordinates at the start (N,
    /// [`crate::rest_shape::elastic_residual`]): how far the start is from rest.
    pub start_residual: f64,
}

impl FreeSwatch {
    /// Simulates the swatch (module documentation). Errors name the failing step.
    pub fn run(&self) -> anyhow::Result<FreeSwatchRun> {
        Ok(self.simulate()?.0)
    }

    /// [`FreeSwatch::run`], also returning the simulator at the end (to render or write it).
    pub fn simulate(&self) -> anyhow::Result<(FreeSwatchRun, Simulator)> {
        let (run, _, end) = self.simulate_with_start()?;
        Ok((run, end))
    }

    /// [`FreeSwatch::simulate`], also returning the simulator at the start.
    pub fn simulate_with_start(&self) -> anyhow::Result<(FreeSwatchRun, Simulator, Simulator)> {
        let topo = Topology::knit(&self.chart);
        let mut params = YarnParams::sweater();
        params.gravity *= 0.0;
        params.wrapping_rest = self.wrapping;
        let d = 2.0 * params.radius;
        let layout_params = match self.gauge {
            Some(g) => LayoutParams::at_gauge(&topo, params.radius, g)?,
            None => LayoutParams::new(LOOP_WIDTH, params.radius),
        };
        let flat = Layout::new(&topo, &layout_params)?;
        let forces = ForceSet {
            gravity: false,
            yarn_contact: self.yarn_contact,
            ..ForceSet::default()
        };
        let mut settings = StepSettings {
            rayleigh_alpha: ALPHA,
            ..StepSettings::default()
        };
        settings.newton.gradient_abs_tol = 1e-7;
        let dt = settings.dt;
        let (mut sim, layout) = match &self.compensation {
            None => (
                Simulator::new(topo.clone(), &flat, params, forces, settings)?,
                flat.clone(),
            ),
            Some(c) => {
                let comp = CompensationSettings {
                    forces: ForceSet {
                        gravity: false,
                        ..forces
                    },
                    ..c.clone()
                };
                let (sim, layout, _, _) = compensated_simulator(
                    &self.chart,
                    &params,
                    &layout_params,
                    forces,
                    &settings,
                    &comp,
                )?;
                (sim, layout)
            }
        };
        let start_residual =
            elastic_residual_with_reference(&topo, &layout, &flat, &params, &forces)?;
        let measure = |sim: &Simulator| -> anyhow::Result<Measures> {
            let p = positions(sim);
            Ok(Measures {
                grid: grid_shape(&topo, &p, d).ok(),
                contacts: contacts(&topo, &p, d)?,
                curl: edge_curl(&topo, &p).ok(),
            })
        };
        let start = measure(&sim)?;
        let at_start = sim.clone();
        let steps = ((self.time / dt).round() as usize).max(1);
        let mut peak_kinetic: f64 = 0.0;
        for k in 0..steps {
            sim.step()
                .with_context(|| format!("step {k} at t = {:.4} s", sim.time()))?;
            peak_kinetic = peak_kinetic.max(sim.kinetic_energy());
        }
        let run = FreeSwatchRun {
            start,
            end: measure(&sim)?,
            yarn_per_loop: layout.yarn_per_loop(&topo)? / d,
            peak_kinetic,
            final_kinetic: sim.kinetic_energy(),
            contact_terms: sim
                .static_terms()
                .count(crate::forces::TermKind::YarnContact),
            start_residual,
        };
        Ok((run, at_start, sim))
    }
}
