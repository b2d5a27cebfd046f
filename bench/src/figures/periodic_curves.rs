//! `periodic-curves`: homogenized uniaxial stress and orthogonal compression against stretch
//! for stockinette (the real tile), garter, 1×1 rib and satin, along weft, bias and warp
//! (seed 002 §7.1; the yarn-level counterpart of the shell's target curves).

use rayon::prelude::*;
use sim_periodic::curves::CurveSettings;
use sim_periodic::patterns::Pattern;
use sim_periodic::periodic::YarnModel;
use yarn_pattern::direction::Direction;

use crate::plot::{LineChart, Series, save_side_by_side};
use crate::studies::periodic::{curve, pattern_tile, real_stockinette, stress_free};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "periodic-curves",
        title: "Homogenized uniaxial curves of periodic yarn tiles",
        shows: "stretch stress σ_s = uᵀPu (N/m) and orthogonal compression c at zero orthogonal stress against stretch s, weft / bias / warp, for stockinette (real tile), garter, 1×1 rib and satin",
        paper: "seed 002 Fig. 10-style yarn-level curves; illustrative (unfitted) yarn parameters, so magnitudes are not the paper's fabrics",
        guarded: true,
        run,
    }
}

/// One pattern's curve along one direction: (pattern index, direction, points).
type PatternCurve = (usize, Direction, Vec<sim_periodic::curves::CurvePoint>);

const PATTERNS: [&str; 4] = ["stockinette", "garter", "rib1x1", "satin"];

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let stretches: Vec<f64> = if ctx.quick {
        vec![0.0, 0.1, 0.2]
    } else {
        (0..=10).map(|i| 0.05 * i as f64).collect()
    };
    // Generated patterns: coarser loops in quick mode.
    let (knit_res, weave_res) = if ctx.quick { (16, 3) } else { (24, 4) };
    let progress = ctx.progress(PATTERNS.len() as u64, "tiles and curves");
    let settings = CurveSettings::default();
    let results: Vec<anyhow::Result<Vec<PatternCurve>>> = PATTERNS
        .par_iter()
        .enumerate()
        .map(|(k, &name)| -> anyhow::Result<_> {
            use anyhow::Context;
            let run = || -> anyhow::Result<_> {
                let tile = match name {
                    "stockinette" => real_stockinette()?,
                    other => {
                        let p = Pattern::from_name(other)
                            .ok_or_else(|| anyhow::anyhow!("unknown pattern {other}"))?;
                        let res = if p.is_knit() { knit_res } else { weave_res };
                        pattern_tile(p, 1e-3, Some(res))?
                    }
                };
                let model = YarnModel::default_for_radius(tile.radius);
                let tile = stress_free(&tile, &model, &settings.equilibrium)?;
                let mut out = Vec::new();
                for d in Direction::ALL {
                    out.push((k, d, curve(&tile, &model, d, &stretches, &settings)?));
                }
                Ok(out)
            };
            let out = run().with_context(|| format!("pattern {name}"))?;
            progress.inc(1);
            Ok(out)
        })
        .collect();
    let mut data = Table::new(&[
        "pattern",
        "direction",
        "s",
        "c",
        "sigma_s_n_per_m",
        "solves",
    ]);
    let mut stress = LineChart::new("Stretch stress")
        .x_label("stretch s")
        .y_label("σ_s (N/m)");
    let mut compression = LineChart::new("Orthogonal compression")
        .x_label("stretch s")
        .y_label("compression c");
    let mut summary = Vec::new();
    for result in results {
        for (k, d, points) in result? {
            let label = format!("{} {}", PATTERNS[k], d.name());
            for p in &points {
                data.push_row([
                    k as f64,
                    d as usize as f64,
                    p.s,
                    p.c,
                    p.sigma_s,
                    p.solves as f64,
                ]);
            }
            let series = |f: fn(&sim_periodic::curves::CurvePoint) -> f64| {
                points.iter().map(|p| (p.s, f(p))).collect::<Vec<_>>()
            };
            stress = stress.series(Series::line_markers(label.clone(), series(|p| p.sigma_s)));
            compression = compression.series(Series::line_markers(label.clone(), series(|p| p.c)));
            let last = points.last().expect("at least one stretch");
            summary.push((
                format!("{label}: σ_s, c at s = {}", last.s),
                format!("{:.1} N/m, {:.3}", last.sigma_s, last.c),
            ));
        }
    }
    save_side_by_side(&stress, &compression, &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "patterns": PATTERNS, "directions": ["weft", "bias", "warp"],
            "stretches": stretches, "knit_resolution": knit_res, "weave_resolution": weave_res,
            "yarn_model": "YarnModel::default_for_radius(R)",
            "period": "relaxed to zero normal stress (relax_period, 1e-6 N/m)",
        }),
        data,
    })
}
