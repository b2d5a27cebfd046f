//! Generates, relaxes and writes every pattern of [`sim_periodic::patterns`] as `.pyp`, and
//! prints per pattern: vertex count, guess and relaxed clearance, Newton iterations and time.
//!
//! Usage: `cargo run --release -p sim-periodic --example patterns -- [OUT_DIR [KNIT_RES
//! WEAVE_RES]]` (default `target/patterns` and the patterns' default resolutions: vertices per
//! knit loop, per weave crossing). For comparison it also prints the clearance of the real
//! `tests/data/patterns/stockinette.pyp`.

use sim_periodic::patterns::{Pattern, RelaxSettings, min_clearance, relax};
use sim_periodic::periodic::YarnModel;
use std::path::PathBuf;
use yarn_pattern::pyp::write_pyp;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "target/patterns".into()));
    let knit_res: Option<usize> = args.next().map(|s| s.parse()).transpose()?;
    let weave_res: Option<usize> = args.next().map(|s| s.parse()).transpose()?;
    std::fs::create_dir_all(&out)?;
    let radius = 1e-3;
    let model = YarnModel::default_for_radius(radius);
    println!(
        "pattern      n  guess/2R  relaxed/2R  iterations        time_s  L/L0    stress_N/m (xx, yy)  max_disp/R"
    );
    for pattern in Pattern::ALL {
        let mut params = pattern.default_params(radius);
        let res = if pattern.is_knit() {
            knit_res
        } else {
            weave_res
        };
        if let Some(r) = res {
            params.resolution = r;
        }
        let guess = pattern.generate(&params)?;
        let c0 = min_clearance(&guess, &model)?.map_or(f64::NAN, |c| c.distance / (2.0 * radius));
        let (tile, report) = relax(&guess, &model, &RelaxSettings::default())?;
        let c1 = min_clearance(&tile, &model)?.map_or(f64::NAN, |c| c.distance / (2.0 * radius));
        let length = |t: &yarn_pattern::tile::Tile| t.rest_lengths.iter().sum::<f64>();
        println!(
            "{:<10} {:>4}  {:>8.3}  {:>10.3}  {:<16} {:>7.3}  {:.3}  ({:>8.4}, {:>8.4})  {:?}",
            pattern.name(),
            tile.n_vertices(),
            c0,
            c1,
            format!("{:?}", report.iterations),
            report.seconds,
            length(&tile) / length(&guess),
            report.stress[(0, 0)],
            report.stress[(1, 1)],
            report
                .max_displacement
                .iter()
                .map(|d| (d / radius * 1000.0).round() / 1000.0)
                .collect::<Vec<_>>()
        );
        write_pyp(&tile, out.join(format!("{}.pyp", pattern.name())))?;
    }
    let real = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    if let Ok(read) = yarn_pattern::pyp::read_pyp(real) {
        let tile = read.tile;
        let model = YarnModel::default_for_radius(tile.radius);
        let c =
            min_clearance(&tile, &model)?.map_or(f64::NAN, |c| c.distance / (2.0 * tile.radius));
        println!(
            "real stockinette.pyp ({} vertices): clearance {c:.3} × 2R",
            tile.n_vertices()
        );
    }
    Ok(())
}
