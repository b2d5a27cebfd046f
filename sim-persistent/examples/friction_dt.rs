//! How the friction update shapes a rib pull: the explicit anchor update of the paper
//! against the return mapping ([`StepSettings::friction_return_mapping`]), over the time
//! step (the measurements behind `sim_persistent::forces::friction` and the
//! `persistent-time-vs-error` figure).
//!
//! ```text
//! cargo run --release -p sim-persistent --example friction_dt -- \
//!     [--size 4x4] [--extension 8e-3] [--dts 1e-3,2.5e-4,1e-4,2.5e-5] [--loop-contact] [--no-floor]
//! ```
//!
//! A 2 × 2 rib of `--size` stitches × rows (Table 1 sweater yarn, loop width 3 mm, no
//! gravity, α = 10 /s) settles free for 0.3 s at dt = 0.25 ms with the explicit update
//! (the `rib-stretch` protocol); its first and last columns are then clamped (positions
//! only) and the right clamp is pulled at 0.1 m/s over `--extension` (m), once per time
//! step of `--dts` with the explicit update and once with the return mapping (20
//! re-solves). Printed: the pull at the end, the slips and Newton iterations of the pull,
//! and the wall time. `--loop-contact` adds the contact between adjacent loops;
//! `--no-floor` removes the segment floor (on by default), which the return mapping needs:
//! without it draining segments collapse and the pull fails, as the output then shows.

use rod::geometry::V3;
use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_column_nodes};
use std::time::Instant;

fn centroid(sim: &Simulator, nodes: &[usize]) -> V3 {
    nodes
        .iter()
        .map(|&n| sim.dofs().position(&sim.state().q, n))
        .sum::<V3>()
        / nodes.len() as f64
}

fn main() {
    let mut size = (4usize, 4usize);
    let mut extension = 8e-3;
    let mut dts = vec![1e-3, 2.5e-4, 1e-4, 2.5e-5];
    let mut floor = true;
    let mut loop_contact = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => {
                let v = value();
                let (w, h) = v.split_once('x').expect("--size WxH");
                size = (w.parse().expect("width"), h.parse().expect("height"));
            }
            "--extension" => extension = value().parse().expect("--extension in m"),
            "--dts" => {
                dts = value()
                    .split(',')
                    .map(|d| d.parse().expect("--dts in s"))
                    .collect()
            }
            "--no-floor" => floor = false,
            "--loop-contact" => loop_contact = true,
            _ => panic!("unknown argument {a} (see the module documentation)"),
        }
    }
    let (w, h) = size;
    let chart = Chart::rib(w, h, 2, 2).expect("rib chart");
    let topo = Topology::knit(&chart);
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).expect("layout");
    let forces = ForceSet {
        gravity: false,
        loop_contact,
        segment_floor: floor,
        ..ForceSet::default()
    };
    let mut settings = StepSettings {
        dt: 2.5e-4,
        rayleigh_alpha: 10.0,
        ..StepSettings::default()
    };
    settings.newton.gradient_abs_tol = 1e-7;
    let start = Instant::now();
    let mut settled = Simulator::new(topo, &layout, params, forces, settings.clone()).expect("sim");
    for k in 0..1200 {
        settled
            .step()
            .unwrap_or_else(|e| panic!("settle step {k}: {e}"));
    }
    println!(
        "rib {w}x{h}, {} DoFs, settled in {:.1} s; pull {:.1} mm at 0.1 m/s{}",
        settled.dofs().n_dofs(),
        start.elapsed().as_secs_f64(),
        1e3 * extension,
        match (floor, loop_contact) {
            (true, false) => "",
            (true, true) => " (with loop contact)",
            (false, false) => " (without the segment floor)",
            (false, true) => " (with loop contact, without the segment floor)",
        }
    );
    println!(
        "dt (ms) | update | pull at the end (N) | slips | Newton iterations | unresolved steps | wall (s)"
    );
    for &dt in &dts {
        for return_mapping in [0, StepSettings::RETURN_MAPPING_RESOLVES] {
            let mut sim = settled.clone();
            let s = StepSettings {
                dt,
                friction_return_mapping: return_mapping,
                ..settings.clone()
            };
            sim.set_settings(s).expect("settings");
            let left = knit_column_nodes(w, h, 0);
            let right = knit_column_nodes(w, h, w - 1);
            sim.pin_nodes(&left).expect("pin");
            sim.pin_nodes(&right).expect("pin");
            let axis = (centroid(&sim, &right) - centroid(&sim, &left)).normalize();
            let steps = (extension / (0.1 * dt)).round() as usize;
            let (mut slips, mut iterations, mut unresolved) = (0, 0, 0);
            let start = Instant::now();
            let mut failure = None;
            for k in 0..steps {
                sim.displace_pinned_nodes(&right, axis * 0.1 * dt)
                    .expect("clamp");
                match sim.step() {
                    Ok(r) => {
                        slips += r.slipped;
                        iterations += r.newton_iterations;
                        unresolved += r.friction_unresolved;
                    }
                    Err(e) => {
                        failure = Some(format!(
                            "failed at {:.2} mm: {}",
                            1e3 * k as f64 * 0.1 * dt,
                            e.to_string().chars().take(80).collect::<String>()
                        ));
                        break;
                    }
                }
            }
            let update = if return_mapping > 0 {
                "return mapping"
            } else {
                "explicit"
            };
            let pull = failure
                .unwrap_or_else(|| format!("{:.4e}", -sim.force_on_nodes(&right).dot(&axis)));
            println!(
                "{:.4} | {update} | {pull} | {slips} | {iterations} | {unresolved} | {:.1}",
                1e3 * dt,
                start.elapsed().as_secs_f64()
            );
        }
    }
}
