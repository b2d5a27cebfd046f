//! `knit-fidelity` (issue 56; seed 000 §4.1–§4.2, Figs. 5–7): do free swatches of the
//! persistent-contact simulator keep the shape of knitting? Each swatch is a
//! [`FreeSwatch`] (sweater yarn, no gravity, no pins, α = 10/s, dt = 1 ms) measured with
//! `sim_persistent::fidelity` at its layout and after the simulated time, under two force
//! models:
//!
//! - **paper**: the fixed quarter-turn wrapping rest angle of Eq. 2 and no yarn self-contact
//!   ([`WrappingRest::paper`]);
//! - **contact + layout wrap**: the wrapping rest angle taken from the layout plus the small
//!   wrapping bias ([`WrappingRest::Layout`] with [`DEFAULT_WRAP_BIAS`]) and yarn
//!   self-contact (the simulator's defaults).
//!
//! Every chart is laid out at Table 1's 3 mm loops; the stockinette is also laid out at the
//! relaxed periodic tile's gauge ([`Gauge::RELAXED_STOCKINETTE`]) under the second model.
//!
//! The chart (`knit-fidelity.png`) plots each measure as its *acceptance ratio*: the value
//! over the limit for limits of the form "at most" (closest approach: limit over
//! value), so that a run passes a criterion where its marker is at or below 1. Ratios are
//! clipped to [0.01, 100] so that a collapsed swatch stays on the chart. The images
//! (`knit-fidelity-images.png`, `…-paper-images.png`) show the settled swatches from the
//! front.

use rayon::prelude::*;
use sim_persistent::chart::Chart;
use sim_persistent::experiment::{FreeSwatch, FreeSwatchRun, Measures};
use sim_persistent::layout::Gauge;
use sim_persistent::params::{DEFAULT_WRAP_BIAS, WrappingRest, YarnParams};

use crate::plot::{LineChart, Series, save_images};
use crate::studies::persistent::render;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "knit-fidelity",
        title: "Knit fidelity of free swatches",
        shows: "gauge, turn per loop and row, kept width and height, closest approach of unstitched yarns, wrapping-pair states, leg joints, edge curl and kinetic energy of free stockinette, garter, rib, seed and lace swatches under the paper's force model and with yarn self-contact and the layout wrapping rest state, as ratios to the issue's acceptance limits (≤ 1 passes); the settled swatches rendered (knit-fidelity-images.png, knit-fidelity-paper-images.png)",
        paper: "seed 000 Figs. 5–7: loops stay open and stitches stay where they were knitted; stockinette sides curl to the back, its ends to the front; garter stays flat",
        guarded: false,
        run,
    }
}

/// (name, chart) of the swatches: 16 × 16 loops in full mode (the acceptance size),
/// 8 × 8 in quick mode.
fn swatches(quick: bool) -> anyhow::Result<Vec<(&'static str, Chart)>> {
    let n = if quick { 8 } else { 16 };
    Ok(vec![
        ("stockinette", Chart::stockinette(n, n)?),
        // An odd row count: the contact boundaries hold as many knit as purl stitches.
        ("garter", Chart::garter(n, n + 1)?),
        ("rib 1×1", Chart::rib(n, n, 1, 1)?),
        ("rib 2×2", Chart::rib(n, n, 2, 2)?),
        ("seed", Chart::seed(n, n)?),
        (
            "lace",
            Chart::lace(if quick { 1 } else { 2 }, if quick { 1 } else { 2 })?,
        ),
    ])
}

/// One acceptance criterion: its name and the ratio of a run's measure to its limit
/// (`None` where the measure does not apply to the chart).
type Criterion = (&'static str, fn(&Row) -> Option<f64>);

/// What one run contributes to the criteria.
struct Row {
    chart: &'static str,
    tile_gauge: bool,
    end: Measures,
    kinetic_ratio: f64,
}

/// The acceptance criteria as ratios (≤ 1 passes).
const CRITERIA: [Criterion; 11] = [
    ("closest unstitched ≥ 0.8 d", |r| {
        Some(0.8 / r.end.contacts.closest_unstitched.max(1e-12))
    }),
    ("segments under 0.9 d ≤ 1 %", |r| {
        Some(r.end.contacts.under_09 / 0.01)
    }),
    ("max turn per loop ≤ 10°", |r| {
        r.end.grid.map(|g| g.turn_per_loop.max / 10.0)
    }),
    ("max turn per row ≤ 10°", |r| {
        r.end.grid.map(|g| g.turn_per_row.max / 10.0)
    }),
    ("kept width, height ≥ 0.85", |r| {
        r.end
            .grid
            .map(|g| 0.85 / g.kept_width.min(g.kept_height).max(1e-12))
    }),
    ("degenerate wings ≤ 5 %", |r| {
        Some(r.end.contacts.degenerate_wings / 0.05)
    }),
    ("leg joints < 80° ≥ 90 %", |r| {
        Some(0.9 / r.end.contacts.leg_joints_below_80.max(1e-12))
    }),
    ("kinetic end/peak ≤ 1e-3", |r| {
        Some(r.kinetic_ratio / 1e-3)
    }),
    ("stockinette roll radius ≥ 2 d", |r| {
        (r.chart == "stockinette")
            .then_some(r.end.grid.map(|g| 2.0 / g.min_roll_radius.max(1e-12)))
            .flatten()
    }),
    ("garter |curl| < 0.3 rad", |r| {
        (r.chart == "garter")
            .then_some(r.end.curl.map(|k| {
                [k.left, k.right, k.bottom, k.top]
                    .iter()
                    .fold(0.0f64, |m, v| m.max(v.abs()))
                    / 0.3
            }))
            .flatten()
    }),
    ("tile gauge: course, row within 15 %", |r| {
        r.tile_gauge
            .then_some(r.end.grid.map(|g| {
                let tile = Gauge::RELAXED_STOCKINETTE;
                let dev = (g.course.median / tile.loop_width - 1.0)
                    .abs()
                    .max((g.row.median / tile.row_height - 1.0).abs());
                dev / 0.15
            }))
            .flatten()
    }),
];

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let time = if ctx.quick { 0.1 } else { 0.5 };
    let radius = YarnParams::sweater().radius;
    let swatches = swatches(ctx.quick)?;
    let layout_wrap = WrappingRest::Layout {
        wrap: DEFAULT_WRAP_BIAS,
    };
    // (model, chart index, swatch) of every run, the paper model first.
    let mut runs: Vec<(&'static str, usize, FreeSwatch)> = Vec::new();
    for (model, wrapping, contact) in [
        ("paper", WrappingRest::paper(), false),
        ("contact + layout wrap", layout_wrap, true),
    ] {
        for (k, (_, chart)) in swatches.iter().enumerate() {
            runs.push((
                model,
                k,
                FreeSwatch {
                    chart: chart.clone(),
                    gauge: None,
                    wrapping,
                    yarn_contact: contact,
                    time,
                    compensation: None,
                },
            ));
        }
    }
    runs.push((
        "contact + layout wrap",
        0,
        FreeSwatch {
            chart: swatches[0].1.clone(),
            gauge: Some(Gauge::RELAXED_STOCKINETTE),
            wrapping: layout_wrap,
            yarn_contact: true,
            time,
            compensation: None,
        },
    ));
    let progress = ctx.progress(runs.len() as u64, "swatches");
    let mut data = Table::new(&[
        "run",
        "chart",
        "self_contact",
        "tile_gauge",
        "yarn_per_loop_d",
        "course_d",
        "course_p10_d",
        "course_p90_d",
        "row_d",
        "row_p10_d",
        "row_p90_d",
        "turn_per_loop_max_deg",
        "turn_per_row_max_deg",
        "kept_width",
        "kept_height",
        "min_roll_radius_d",
        "closest_unstitched_d",
        "under_09_fraction",
        "degenerate_wings_fraction",
        "leg_joints_below_80_fraction",
        "curl_left_rad",
        "curl_right_rad",
        "curl_bottom_rad",
        "curl_top_rad",
        "kinetic_end_over_peak",
        "contact_terms",
    ]);
    let mut summary = Vec::new();
    let mut rows = Vec::new();
    let (mut paper_images, mut images) = (Vec::new(), Vec::new());
    // The runs are independent: simulate them in parallel, then measure and render in order.
    // A run that fails (a step whose Newton solve fails after its halvings) is reported as
    // failed, with its error, and the figure goes on: the paper model is expected to fail
    // on some charts.
    let simulated: Vec<anyhow::Result<_>> = runs
        .par_iter()
        .map(|(_, _, spec)| {
            let out = spec.simulate();
            progress.inc(1);
            out
        })
        .collect();
    for (i, ((model, k, spec), outcome)) in runs.iter().zip(simulated).enumerate() {
        let name = swatches[*k].0;
        let tile_gauge = spec.gauge.is_some();
        let (result, sim) = match outcome {
            Ok(out) => out,
            Err(e) => {
                let mut row = vec![f64::NAN; data.columns.len()];
                row[0] = i as f64;
                row[1] = *k as f64;
                row[2] = f64::from(u8::from(spec.yarn_contact));
                row[3] = f64::from(u8::from(tile_gauge));
                data.push_row(row);
                summary.push((
                    format!(
                        "{name} {}×{}, {model}",
                        spec.chart.width(),
                        spec.chart.height()
                    ),
                    format!("FAILED: {e:#}"),
                ));
                continue;
            }
        };
        let FreeSwatchRun {
            end,
            yarn_per_loop,
            peak_kinetic,
            final_kinetic,
            contact_terms,
            ..
        } = result;
        let kinetic_ratio = final_kinetic / peak_kinetic.max(1e-300);
        let nan = f64::NAN;
        let g = end.grid;
        let grid = |f: fn(&sim_persistent::fidelity::GridShape) -> f64| g.as_ref().map_or(nan, f);
        let curl =
            |f: fn(&sim_persistent::measure::EdgeCurl) -> f64| end.curl.as_ref().map_or(nan, f);
        data.push_row([
            i as f64,
            *k as f64,
            f64::from(u8::from(spec.yarn_contact)),
            f64::from(u8::from(tile_gauge)),
            yarn_per_loop,
            grid(|g| g.course.median),
            grid(|g| g.course.p10),
            grid(|g| g.course.p90),
            grid(|g| g.row.median),
            grid(|g| g.row.p10),
            grid(|g| g.row.p90),
            grid(|g| g.turn_per_loop.max),
            grid(|g| g.turn_per_row.max),
            grid(|g| g.kept_width),
            grid(|g| g.kept_height),
            grid(|g| g.min_roll_radius),
            end.contacts.closest_unstitched,
            end.contacts.under_09,
            end.contacts.degenerate_wings,
            end.contacts.leg_joints_below_80,
            curl(|c| c.left),
            curl(|c| c.right),
            curl(|c| c.bottom),
            curl(|c| c.top),
            kinetic_ratio,
            contact_terms as f64,
        ]);
        let layout = if tile_gauge {
            "tile gauge"
        } else {
            "3 mm loops"
        };
        summary.push((
            format!(
                "{name} {}×{}, {model}, {layout}",
                spec.chart.width(),
                spec.chart.height()
            ),
            format!(
                "{yarn_per_loop:.1} d of yarn per loop; {}; kinetic end/peak {kinetic_ratio:.1e}",
                end.to_string().replace('\n', "; ")
            ),
        ));
        let image = render(&sim, radius, (300, 300), [0.0, 0.0, -1.0], [0.0, 1.0, 0.0])?;
        let caption = if tile_gauge {
            format!("{name} (tile gauge)")
        } else {
            name.to_string()
        };
        if *model == "paper" {
            paper_images.push((caption, image.image));
        } else {
            images.push((caption, image.image));
        }
        rows.push((
            i,
            Row {
                chart: name,
                tile_gauge,
                end,
                kinetic_ratio,
            },
        ));
    }
    for (set, stem) in [(&images, "images"), (&paper_images, "paper-images")] {
        let panels: Vec<(&str, &yarn_output::render::Image)> =
            set.iter().map(|(t, i)| (t.as_str(), i)).collect();
        save_images(&panels, &ctx.out_dir, &format!("{}-{stem}", ctx.name))?;
    }
    let mut chart = LineChart::new("Knit fidelity: measure over acceptance limit (≤ 1 passes)")
        .x_label(format!(
            "run (0–{} paper model, {}–{} contact + layout wrap, {} stockinette at the tile gauge)",
            swatches.len() - 1,
            swatches.len(),
            2 * swatches.len() - 1,
            2 * swatches.len()
        ))
        .y_label("ratio to the limit")
        .log_y()
        .hline("limit", 1.0);
    for (name, ratio) in CRITERIA {
        let points: Vec<(f64, f64)> = (rows.iter())
            .filter_map(|(i, r)| Some((*i as f64, ratio(r)?.clamp(1e-2, 100.0))))
            .collect();
        if !points.is_empty() {
            chart = chart.series(Series::markers(name, points));
        }
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "charts": swatches.iter().map(|(n, c)| format!("{n} {}x{}", c.width(), c.height())).collect::<Vec<_>>(),
            "models": ["paper: fixed quarter-turn wrapping rest angle, no self-contact", "contact + layout wrap: layout wrapping rest angle plus the default bias, yarn self-contact"],
            "yarn": "Table 1 sweater (R = 0.75 mm), no gravity, no pins",
            "layouts": "3 mm loops (Table 1) for every chart; the stockinette also at the relaxed tile's gauge (3.76 d × 1.98 d, 13.2 d per loop)",
            "damping_alpha": sim_persistent::experiment::ALPHA,
            "dt_s": sim_persistent::integrator::StepSettings::default().dt,
            "time_s": time,
        }),
        data,
    })
}
