//! Scenes shared by the obstacle tests (`obstacles.rs`, `mesh_obstacles.rs`).

use nalgebra::Vector3;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::Topology;
use sim_persistent::weave::WeavePattern;

/// Yarn spacing (m) of [`weave_sim`].
pub const SPACING: f64 = 3e-3;

/// A `n × n` plain weave of the sweater yarn in the xy plane (z = 0) with gravity along −z
/// and Table 1 damping (α = 10, β = 0.01).
pub fn weave_sim(n: usize) -> Simulator {
    let topo = Topology::weave(WeavePattern::Plain, n, n).unwrap();
    let mut params = YarnParams::sweater();
    params.gravity = Vector3::new(0.0, 0.0, -9.81);
    let layout = Layout::new(&topo, &LayoutParams::new(SPACING, params.radius)).unwrap();
    let settings = StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    };
    Simulator::new(topo, &layout, params, ForceSet::default(), settings).unwrap()
}
