//! `periodic-time-vs-error`: wall time of a uniaxial curve (weft, s = 0, 0.1, 0.2 with zero
//! orthogonal stress) against the error of σ_s(0.2) relative to a fine reference, as the yarn
//! discretization, the contact quadrature and the Newton tolerance are swept.

use std::time::Instant;
use yarn_pattern::direction::Direction;

use rod::contact::Simpson;
use sim_periodic::curves::CurveSettings;
use sim_periodic::patterns::Pattern;
use sim_periodic::periodic::YarnModel;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series};
use crate::studies::periodic::{curve, pattern_tile, real_stockinette, stress_free};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "periodic-time-vs-error",
        title: "Periodic tile: solve time against stress error",
        shows: "wall time of a weft curve (3 points, each one Newton solve with the compression as a DOF, finished by a root-find where its orthogonal stress is above the root-find's tolerance) against the relative error of σ_s at s = 0.2 vs the finest setting of each sweep: vertices per loop (generated stockinette), Simpson intervals and Newton tolerance (real stockinette)",
        paper: "our study (no paper figure): where accuracy is bought and what it costs",
        guarded: false,
        run,
    }
}

/// One run of a sweep: (parameter, seconds, σ_s at the last stretch).
type Run = (f64, f64, f64);

const STRETCHES: [f64; 3] = [0.0, 0.1, 0.2];

/// (seconds, σ_s at the last stretch) of one curve.
fn timed(tile: &Tile, model: &YarnModel, settings: &CurveSettings) -> anyhow::Result<(f64, f64)> {
    let t = Instant::now();
    let points = curve(tile, model, Direction::Weft, &STRETCHES, settings)?;
    let sigma = points.last().expect("three points").sigma_s;
    Ok((t.elapsed().as_secs_f64(), sigma))
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let mut data = Table::new(&[
        "family",
        "parameter",
        "seconds",
        "sigma_s_n_per_m",
        "rel_error",
    ]);
    let mut chart = LineChart::new("Weft curve: time vs error of σ_s(0.2)")
        .x_label("relative error of σ_s(0.2) vs finest setting")
        .y_label("wall time (s)")
        .log_x()
        .log_y();
    let mut summary = Vec::new();
    let base = CurveSettings::default();

    // Family 0: vertices per stitch loop of a generated stockinette (each relaxed to a
    // stress-free period, not timed); the finest is the reference.
    let resolutions: Vec<usize> = if ctx.quick {
        vec![12, 16, 24]
    } else {
        vec![12, 16, 24, 32, 48]
    };
    // Family 1: Simpson intervals per contact edge; family 2: Newton gradient tolerance
    // (absolute in N, relative 1e-3 of it), both on the real tile.
    let intervals: Vec<usize> = if ctx.quick {
        vec![2, 4, 8]
    } else {
        vec![2, 4, 6, 8, 12]
    };
    let tolerances: Vec<f64> = if ctx.quick {
        vec![1e-2, 1e-5, 1e-11]
    } else {
        vec![1e-1, 1e-2, 1e-3, 1e-5, 1e-7, 1e-9, 1e-11]
    };
    let progress = ctx.progress(
        (resolutions.len() + intervals.len() + tolerances.len()) as u64,
        "sweeps",
    );

    let mut families: Vec<(&str, Vec<Run>)> = Vec::new();
    let mut runs = Vec::new();
    for &r in &resolutions {
        let tile = pattern_tile(Pattern::Stockinette, 1e-3, Some(r))?;
        let model = YarnModel::default_for_radius(tile.radius);
        let tile = stress_free(&tile, &model, &base.equilibrium)?;
        let (s, sigma) = timed(&tile, &model, &base)?;
        runs.push((r as f64, s, sigma));
        progress.inc(1);
    }
    families.push(("vertices per loop", runs));

    let real = real_stockinette()?;
    let model = YarnModel::default_for_radius(real.radius);
    let real = stress_free(&real, &model, &base.equilibrium)?;
    let mut runs = Vec::new();
    for &n in &intervals {
        let mut m = model;
        m.quadrature = Simpson::new(n).ok_or_else(|| anyhow::anyhow!("bad Simpson count {n}"))?;
        let (s, sigma) = timed(&real, &m, &base)?;
        runs.push((n as f64, s, sigma));
        progress.inc(1);
    }
    families.push(("Simpson intervals", runs));
    let mut runs = Vec::new();
    for &tol in &tolerances {
        let mut settings = base.clone();
        settings.equilibrium.newton.gradient_abs_tol = tol;
        settings.equilibrium.newton.gradient_rel_tol = 1e-3 * tol;
        settings.stress_abs_tol = tol;
        // A tolerance too loose for the root-find is a result of the sweep, not an error of
        // the figure: it is listed in the summary and left out of the chart.
        match timed(&real, &model, &settings) {
            Ok((s, sigma)) => runs.push((tol, s, sigma)),
            Err(e) => summary.push((
                format!("Newton tolerance {tol:e} N"),
                format!("failed: {e}"),
            )),
        }
        progress.inc(1);
    }
    families.push(("Newton tolerance (N)", runs));

    for (k, (name, runs)) in families.iter().enumerate() {
        // The reference is the finest setting: last for the first two families, the
        // tightest tolerance (last) for the third.
        let reference = runs.last().expect("non-empty sweep").2;
        let mut points = Vec::new();
        for &(p, s, sigma) in runs {
            let err = (sigma - reference).abs() / reference.abs();
            data.push_row([k as f64, p, s, sigma, err]);
            if err > 0.0 {
                points.push((err, s));
            }
        }
        let coarsest = &runs[0];
        summary.push((
            format!("{name}: coarsest ({}) error, time", coarsest.0),
            format!(
                "{}, {:.2} s",
                crate::percent((coarsest.2 - reference).abs() / reference.abs()),
                coarsest.1
            ),
        ));
        if !points.is_empty() {
            chart = chart.series(Series::line_markers(*name, points));
        }
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "stretches": STRETCHES, "direction": "weft", "resolutions": resolutions,
            "simpson_intervals": intervals, "newton_abs_tolerances_n": tolerances,
            "reference": "finest setting of each sweep",
        }),
        data,
    })
}
