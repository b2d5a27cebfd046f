//! A free swatch from its layout, measured as `sim_persistent::fidelity` measures knits.
//!
//! `cargo run --release -p sim-persistent --example knit_fidelity -- [chart] [w] [h] [time]
//! [key=value …]` with chart `stockinette|garter|rib1|rib2|seed`, keys `unwrap` (rad, or
//! `paper` for the fixed quarter turn), `contact` (0/1), `width`, `height`, `length` (loop
//! width, row height and yarn per loop in yarn diameters; `length` solves the out-of-plane
//! offset), `kw` (wrapping stiffness, N).

use sim_persistent::chart::Chart;
use sim_persistent::experiment::swatch::positions;
use sim_persistent::fidelity::{contacts, grid_shape};
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::measure::edge_curl;
use sim_persistent::params::{WrappingRest, YarnParams};
use sim_persistent::topology::Topology;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = args.first().map(String::as_str).unwrap_or("stockinette");
    let w: usize = args.get(1).map_or(Ok(16), |s| s.parse())?;
    let h: usize = args.get(2).map_or(Ok(16), |s| s.parse())?;
    let time: f64 = args.get(3).map_or(Ok(0.5), |s| s.parse())?;
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    let d = 2.0 * params.radius;
    let mut forces = ForceSet {
        gravity: false,
        ..ForceSet::default()
    };
    let (mut width, mut height, mut length) = (2.0, 2.0, None);
    for kv in args.iter().skip(4) {
        let (k, v) = kv.split_once('=').expect("key=value");
        match k {
            "unwrap" if v == "paper" => params.wrapping_rest = WrappingRest::paper(),
            "unwrap" => params.wrapping_rest = WrappingRest::Layout { unwrap: v.parse()? },
            "contact" => forces.yarn_contact = v == "1",
            "wrapping" => forces.wrapping = v == "1",
            "width" => width = v.parse()?,
            "height" => height = v.parse()?,
            "length" => length = Some(v.parse::<f64>()?),
            "kw" => params.wrapping_stiffness = v.parse()?,
            _ => anyhow::bail!("unknown key {k}"),
        }
    }
    let chart = match kind {
        "stockinette" => Chart::stockinette(w, h)?,
        "garter" => Chart::garter(w, h)?,
        "rib1" => Chart::rib(w, h, 1, 1)?,
        "rib2" => Chart::rib(w, h, 2, 2)?,
        "seed" => Chart::seed(w, h)?,
        _ => anyhow::bail!("unknown chart {kind}"),
    };
    let topo = Topology::knit(&chart);
    let mut lp = LayoutParams::new(width * d, params.radius);
    lp.row_height = height * d;
    if let Some(l) = length {
        lp = lp.with_loop_length(&topo, l * d)?;
    }
    let layout = Layout::new(&topo, &lp)?;
    println!(
        "layout: width {width} d, height {height} d, offset {:.3} d, yarn per loop {:.2} d",
        lp.out_of_plane / d,
        layout.yarn_per_loop(&topo)? / d
    );
    let mut settings = StepSettings {
        rayleigh_alpha: 10.0,
        ..StepSettings::default()
    };
    settings.newton.gradient_abs_tol = 1e-7;
    let mut sim = Simulator::new(topo.clone(), &layout, params, forces, settings)?;
    let report = |sim: &Simulator, label: &str| -> anyhow::Result<()> {
        let p = positions(sim);
        let g = grid_shape(&topo, &p, d)?;
        let c = contacts(&topo, &p, d)?;
        let curl = edge_curl(&topo, &p)?;
        println!(
            "{label}: course {:.2} [{:.2}, {:.2}] d, row {:.2} [{:.2}, {:.2}] d, turn/loop {:.1}° (p90 {:.1}, max {:.1}), \
             turn/row {:.1}° (p90 {:.1}, max {:.1}), kept {:.2} × {:.2}, roll ≥ {:.2} d",
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
        );
        println!(
            "   closest unstitched {:.2} d, under 0.9 d {:.1} %, degenerate wings {:.1} %, leg joints median {:.0}° ({:.0} % < 80°); \
             curl sides {:+.2}/{:+.2}, ends {:+.2}/{:+.2} rad",
            c.closest_unstitched,
            100.0 * c.under_09,
            100.0 * c.degenerate_wings,
            c.leg_joint.median,
            100.0 * c.leg_joints_below_80,
            curl.left,
            curl.right,
            curl.bottom,
            curl.top
        );
        Ok(())
    };
    report(&sim, "t = 0")?;
    let steps = (time / 1e-3).round() as usize;
    let (mut peak, start) = (0.0f64, std::time::Instant::now());
    for k in 0..steps {
        sim.step().map_err(|e| anyhow::anyhow!("step {k}: {e}"))?;
        peak = peak.max(sim.kinetic_energy());
        if (k + 1) % 100 == 0 {
            println!(
                "  t = {:.2} s: kinetic {:.2e} J (peak {:.2e}), {:.1} s wall",
                sim.time(),
                sim.kinetic_energy(),
                peak,
                start.elapsed().as_secs_f64()
            );
        }
    }
    report(&sim, &format!("t = {time}"))?;
    println!(
        "kinetic end/peak {:.2e}; contact terms {}",
        sim.kinetic_energy() / peak.max(1e-300),
        sim.static_terms()
            .count(sim_persistent::forces::TermKind::YarnContact)
    );
    Ok(())
}
