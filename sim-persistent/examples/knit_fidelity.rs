//! A free swatch from its layout, measured as `sim_persistent::fidelity` measures knits
//! ([`sim_persistent::experiment::FreeSwatch`]).
//!
//! `cargo run --release -p sim-persistent --example knit_fidelity -- [chart] [w] [h] [time]
//! [key=value …]` with chart `stockinette|garter|rib1|rib2|seed`; keys `wrap` (the wrapping
//! bias in rad, or `paper` for the fixed quarter turn), `contact` (0/1), `gauge` (`real`
//! for the relaxed stockinette tile's, `table1` for 3 mm loops).

use sim_persistent::chart::Chart;
use sim_persistent::experiment::FreeSwatch;
use sim_persistent::layout::Gauge;
use sim_persistent::params::WrappingRest;

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
        compensation: None,
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
    println!("layout:\n{}", run.start);
    println!("t = {time} s:\n{}", run.end);
    println!(
        "kinetic energy end/peak {:.2e} (peak {:.2e} J); {} contact terms; {:.1} s wall",
        run.final_kinetic / run.peak_kinetic.max(1e-300),
        run.peak_kinetic,
        run.contact_terms,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
