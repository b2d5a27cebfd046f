//! Swatches of the experiments (seed 000 §5.2): build, settle, step, measure.
//!
//! Every swatch uses the Table 1 sweater yarn (R = 0.75 mm) with a loop width of 3 mm, no
//! gravity, Table 1 mass damping α = 10 /s and the simulator's default force terms. A swatch
//! is first **settled**: simulated free (no pins) from the flat layout while the stitch
//! wrapping rest angles ramp in ([`StepSettings::wrapping_ramp_time`], 0.1 s), until
//! `settle_time`. Experiments then clamp edges at their settled positions.

use crate::chart::Chart;
use crate::forces::{ForceSet, TermKind};
use crate::integrator::{Simulator, StepSettings};
use crate::layout::{Layout, LayoutParams};
use crate::params::YarnParams;
use crate::topology::{Construction, Topology};
use anyhow::Context;
use rod::geometry::V3;

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
    /// How the chart is knitted (default: one yarn per row).
    pub construction: Construction,
    /// `Some(tol)`: linearized implicit Euler ([`StepSettings::linearized_implicit_euler`])
    /// with IC(0)-preconditioned conjugate gradients at relative tolerance `tol` (the fast
    /// configuration of `examples/scaling.rs`); `None` (default): full Newton, Cholesky.
    pub linearized_cg: Option<f64>,
    /// With `linearized_cg`: start every CG solve from the previous one's solution
    /// ([`StepSettings::warm_started_cg`]). Default false.
    pub cg_warm_start: bool,
    /// With `linearized_cg`: take every linearized step at full length, as seed 000's ref. 6
    /// does ([`StepSettings::at_full_length`]) instead of damped
    /// ([`StepSettings::linearized_implicit_euler`]). Default false.
    pub linearized_full_steps: bool,
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
            construction: Construction::default(),
            linearized_cg: None,
            cg_warm_start: false,
            linearized_full_steps: false,
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
        if let Some(tol) = self.linearized_cg {
            s = s.linearized_ic_cg(tol);
            if self.cg_warm_start {
                s = s.warm_started_cg();
            }
            if self.linearized_full_steps {
                s = s.at_full_length();
            }
        }
        s
    }

    /// Number of steps covering `time` (s), at least one.
    pub fn steps(&self, time: f64) -> usize {
        ((time / self.dt).round() as usize).max(1)
    }
}

/// A swatch of `chart` in its flat layout.
pub fn swatch(chart: &Chart, settings: &SwatchSettings) -> anyhow::Result<(Simulator, Layout)> {
    let topo = Topology::knit_with(chart, settings.construction)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_names_are_snake_case() {
        assert_eq!(kind_name(TermKind::StitchLength), "stitch_length");
        assert_eq!(kind_name(TermKind::Bending), "bending");
    }
}
