//! `rest-shape` (seed 000 §4.1, Fig. 6): the same free swatch started from the flat layout
//! and from the rest-shape compensated layout ([`sim_persistent::rest_shape`]: a free
//! characteristic rectangle relaxed, its loop shapes applied to the whole chart), side by
//! side. Each is a [`FreeSwatch`] with the default model (layout wrapping rest state, yarn
//! self-contact; Table 1 sweater yarn at its 3 mm loops, no gravity, no pins, α = 10/s,
//! dt = 1 ms).
//!
//! What the paper's Fig. 6 shows, a garment that shrinks and wrinkles without compensation
//! and keeps its size with it, is measured here on the interior of flat swatches: the
//! median course and row spacing of the interior cells (≥ 2 loops from every edge,
//! `sim_persistent::fidelity`) at the start and at the end, and their change, which is the
//! swatch's shrinkage (negative) or growth (positive); and the start's force residual
//! ([`sim_persistent::rest_shape::elastic_residual`], every elastic term and yarn contact at
//! full radius, with the wrapping rest angles the simulation uses). The chart
//! (`rest-shape.png`) plots the spacing changes per run; the images
//! (`rest-shape-images.png`) show each swatch at its start and at the end, from the front,
//! the four panels of a chart at one scale.

use rayon::prelude::*;
use sim_persistent::chart::Chart;
use sim_persistent::experiment::FreeSwatch;
use sim_persistent::params::{WrappingRest, YarnParams};
use sim_persistent::rest_shape::CompensationSettings;

use crate::plot::{LineChart, Series, save_images};
use crate::studies::persistent::render_framed;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};
use sim_persistent::integrator::Simulator;
use yarn_output::render::Framing;

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "rest-shape",
        title: "Rest-shape compensation (Fig. 6)",
        shows: "free stockinette and 2×2 rib swatches started from the flat layout and from the rest-shape compensated layout (a free characteristic rectangle relaxed, its loop shapes applied): start force residual and the change of the interior course and row spacing over the run (shrinkage or growth); the swatches at their start and end (rest-shape-images.png)",
        paper: "seed 000 Fig. 6: without compensation the garment shrinks and wrinkles as its loops relax; with the relaxed loop shapes applied to the layout it keeps its size",
        guarded: false,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let n = if ctx.quick { 8 } else { 16 };
    let time = if ctx.quick { 0.1 } else { 0.3 };
    let radius = YarnParams::sweater().radius;
    let d = 2.0 * radius;
    // The paper's 5 cm rectangle in full mode; one repeat plus the margin in quick mode.
    let compensation = CompensationSettings {
        min_extent: if ctx.quick { 3e-3 } else { 0.05 },
        ..CompensationSettings::default()
    };
    let charts = [
        ("stockinette", Chart::stockinette(n, n)?),
        ("rib 2×2", Chart::rib(n, n, 2, 2)?),
    ];
    let mut runs = Vec::new();
    for (k, (_, chart)) in charts.iter().enumerate() {
        for compensated in [false, true] {
            runs.push((
                k,
                compensated,
                FreeSwatch {
                    chart: chart.clone(),
                    gauge: None,
                    wrapping: WrappingRest::default(),
                    yarn_contact: true,
                    time,
                    compensation: compensated.then(|| compensation.clone()),
                },
            ));
        }
    }
    let progress = ctx.progress(runs.len() as u64, "swatches");
    let simulated = runs
        .par_iter()
        .map(|(k, compensated, spec)| {
            let out = spec.simulate_with_start().map_err(|e| {
                anyhow::anyhow!("{} (compensated: {compensated}): {e:#}", charts[*k].0)
            });
            progress.inc(1);
            out
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut data = Table::new(&[
        "run",
        "chart",
        "compensated",
        "start_residual_n",
        "course_start_d",
        "course_end_d",
        "course_change",
        "row_start_d",
        "row_end_d",
        "row_change",
        "kept_width_end",
        "kept_height_end",
        "closest_unstitched_end_d",
        "kinetic_end_over_peak",
    ]);
    let (mut summary, mut images, mut sims) = (Vec::new(), Vec::new(), Vec::new());
    let (mut course_points, mut row_points) = (Vec::new(), Vec::new());
    for (i, ((k, compensated, _), (result, start, end))) in runs.iter().zip(simulated).enumerate() {
        let name = charts[*k].0;
        let (Some(g0), Some(g1)) = (result.start.grid, result.end.grid) else {
            anyhow::bail!("{name}: no grid measures (the swatch is not a ≥ 6 × 6 K/P chart)");
        };
        let change = |a: f64, b: f64| b / a - 1.0;
        let (course, row) = (
            change(g0.course.median, g1.course.median),
            change(g0.row.median, g1.row.median),
        );
        let kinetic = result.final_kinetic / result.peak_kinetic.max(1e-300);
        data.push_row([
            i as f64,
            *k as f64,
            f64::from(u8::from(*compensated)),
            result.start_residual,
            g0.course.median,
            g1.course.median,
            course,
            g0.row.median,
            g1.row.median,
            row,
            g1.kept_width,
            g1.kept_height,
            result.end.contacts.closest_unstitched,
            kinetic,
        ]);
        course_points.push((i as f64, 100.0 * course));
        row_points.push((i as f64, 100.0 * row));
        let label = if *compensated { "compensated" } else { "flat" };
        summary.push((
            format!("{name} {n}×{n}, {label} layout"),
            format!(
                "start residual {:.3e} N; interior course {:.2} → {:.2} d ({:+.1} %), row \
                 {:.2} → {:.2} d ({:+.1} %); kept {:.2} × {:.2}; closest unstitched {:.2} d; \
                 kinetic end/peak {kinetic:.1e}",
                result.start_residual,
                g0.course.median,
                g1.course.median,
                100.0 * course,
                g0.row.median,
                g1.row.median,
                100.0 * row,
                g1.kept_width,
                g1.kept_height,
                result.end.contacts.closest_unstitched,
            ),
        ));
        sims.push((*k, format!("{name}, {label}"), start, end));
    }
    // One scale for the four panels of a chart (flat and compensated, start and end), so
    // that the images show the sizes the table gives; each panel centred on its swatch.
    let size = (300, 300);
    for (k, _) in charts.iter().enumerate() {
        let ours: Vec<_> = sims.iter().filter(|s| s.0 == k).collect();
        let mut extent: [f64; 2] = [0.0; 2];
        for (_, _, start, end) in &ours {
            for sim in [start, end] {
                let (lo, hi) = bounds(sim);
                extent[0] = extent[0].max(hi[0] - lo[0] + 4.0 * radius);
                extent[1] = extent[1].max(hi[1] - lo[1] + 4.0 * radius);
            }
        }
        let pixels_per_metre =
            0.95 * (f64::from(size.0) / extent[0]).min(f64::from(size.1) / extent[1]);
        for (_, label, start, end) in ours {
            for (when, sim) in [("start", start), ("end", end)] {
                let (lo, hi) = bounds(sim);
                let framing = Framing::Fixed {
                    center: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])],
                    pixels_per_metre,
                };
                let image = render_framed(
                    sim,
                    radius,
                    size,
                    [0.0, 0.0, -1.0],
                    [0.0, 1.0, 0.0],
                    framing,
                )?;
                images.push((format!("{label}, {when}"), image.image));
            }
        }
    }
    let panels: Vec<(&str, &yarn_output::render::Image)> =
        images.iter().map(|(t, i)| (t.as_str(), i)).collect();
    save_images(&panels, &ctx.out_dir, &format!("{}-images", ctx.name))?;
    LineChart::new("Interior spacing change over the run (shrinkage < 0)")
        .x_label(
            "run (0 stockinette flat, 1 stockinette compensated, 2 rib flat, 3 rib compensated)",
        )
        .y_label("change of the median spacing (%)")
        .hline("±5 %", 5.0)
        .hline("-5 %", -5.0)
        .series(Series::markers("course spacing", course_points))
        .series(Series::markers("row spacing", row_points))
        .save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "charts": charts.iter().map(|(c, _)| format!("{c} {n}x{n}")).collect::<Vec<_>>(),
            "model": "defaults: layout wrapping rest state with the default bias, yarn self-contact",
            "yarn": "Table 1 sweater (R = 0.75 mm), 3 mm loops, no gravity, no pins",
            "diameter_m": d,
            "rectangle_min_extent_m": compensation.min_extent,
            "rectangle_margin_loops": compensation.margin,
            "damping_alpha": sim_persistent::experiment::ALPHA,
            "time_s": time,
        }),
        data,
    })
}

/// The lower and upper corners `(x, y)` (m) of `sim`'s nodes: the screen box of the front
/// view (the camera's right and up axes are x and y).
fn bounds(sim: &Simulator) -> ([f64; 2], [f64; 2]) {
    let q = &sim.state().q;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for n in 0..sim.topology().nodes.len() {
        let p = sim.dofs().position(q, n);
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}
