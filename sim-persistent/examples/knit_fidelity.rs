//! A free swatch from its layout, measured as `sim_persistent::fidelity` measures knits
//! ([`sim_persistent::experiment::FreeSwatch`]).
//!
//! `cargo run --release -p sim-persistent --example knit_fidelity -- [chart] [w] [h] [time]
//! [key=value …]` with chart `stockinette|garter|rib1|rib2|seed`; keys `wrap` (the wrapping
//! bias in rad, or `paper` for the fixed quarter turn), `contact` (0/1), `gauge` (`real`
//! for the relaxed stockinette tile's, `table1` for 3 mm loops).

use sim_persistent::chart::Chart;
use sim_persistent::experiment::{FreeSwatch, Measures};
use sim_persistent::layout::Gauge;
use sim_persistent::params::WrappingRest;

fn print(label: &str, m: &Measures) {
    if let Some(g) = m.grid {
        println!(
            "{label}: course {:.2} [{:.2}, {:.2}] d, row {:.2} [{:.2}, {:.2}] d, turn/loop {:.1}° \
             (p90 {:.1}, max {:.1}), turn/row {:.1}° (p90 {:.1}, max {:.1}), kept {:.2} × {:.2}, \
             roll ≥ {:.2} d",
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
    }
    let c = m.contacts;
    println!(
        "   closest unstitched {:.2} d, under 0.9 d {:.1} %, degenerate wings {:.1} %, leg joints \
         median {:.0}° ({:.0} % < 80°)",
        c.closest_unstitched,
        100.0 * c.under_09,
        100.0 * c.degenerate_wings,
        c.leg_joint.median,
        100.0 * c.leg_joints_below_80
    );
    if let Some(k) = m.curl {
        println!(
            "   curl sides {:+.2}/{:+.2}, ends {:+.2}/{:+.2} rad",
            k.left, k.right, k.bottom, k.top
        );
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = args.first().map(String::as_str).unwrap_or("stockinette");
    let w: usize = args.get(1).map_or(Ok(16), |s| s.parse())?;
    let h: usize = args.get(2).map_or(Ok(16), |s| s.parse())?;
    let time: f64 = args.get(3).map_or(Ok(0.5), |s| s.parse())?;
    let chart = match kind {
        "stockinette" => Chart::stockinette(w, h)?,
        "garter" => Chart::garter(w, h)?,
        "rib1" => Chart::rib(w, h, 1, 1)?,
        "rib2" => Chart::rib(w, h, 2, 2)?,
        "seed" => Chart::seed(w, h)?,
        _ => anyhow::bail!("unknown chart {kind}"),
    };
    let mut spec = FreeSwatch {
        chart,
        gauge: Some(Gauge::RELAXED_STOCKINETTE),
        wrapping: WrappingRest::default(),
        yarn_contact: true,
        time,
    };
    for kv in args.iter().skip(4) {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| anyhow::anyhow!("expected key=value, found {kv}"))?;
        match (k, v) {
            ("wrap", "paper") => spec.wrapping = WrappingRest::paper(),
            ("wrap", v) => spec.wrapping = WrappingRest::Layout { wrap: v.parse()? },
            ("contact", v) => spec.yarn_contact = v == "1",
            ("gauge", "real") => spec.gauge = Some(Gauge::RELAXED_STOCKINETTE),
            ("gauge", "table1") => spec.gauge = None,
            _ => anyhow::bail!("unknown key or value {kv}"),
        }
    }
    let start = std::time::Instant::now();
    let run = spec.run()?;
    println!("yarn per loop {:.2} d", run.yarn_per_loop);
    print("layout", &run.start);
    print(&format!("t = {time} s"), &run.end);
    println!(
        "kinetic energy end/peak {:.2e} (peak {:.2e} J); {} contact terms; {:.1} s wall",
        run.final_kinetic / run.peak_kinetic.max(1e-300),
        run.peak_kinetic,
        run.contact_terms,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
