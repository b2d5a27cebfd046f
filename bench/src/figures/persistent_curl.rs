//! `curl` (seed 000 §3.1, §4.2, §5.2.2, Figs. 5 and 7): free swatches relaxed from their
//! flat layouts. Stockinette curls at its edges (side edges to the back, cast-on and
//! bind-off edges to the front), rib compresses in width (under the paper's quarter turn),
//! garter should stay flat. Measured
//! with `sim_persistent::measure` (edge curl in rad, positive towards the front; width over
//! laid-out width) and rendered as yarn tubes. The swatches are knitted with one continuous
//! yarn turning at the row ends, with the simulator's default model (the layout wrapping
//! rest state and yarn self-contact); the manifest and reports/README.md give the numbers.

use rayon::prelude::*;
use sim_persistent::chart::Chart;
use sim_persistent::measure::{course_width, edge_curl};
use sim_persistent::topology::Construction;

use crate::plot::save_images;
use crate::studies::persistent::render;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};
use sim_persistent::experiment::{SwatchSettings, positions, settled};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "curl",
        title: "Curl of free knit swatches",
        shows: "edge curl (rad, + towards the knit side) of the four edges and the side-to-side width ratio of settled stockinette, garter and 2×2 rib swatches; the settled swatches rendered as yarn tubes (curl-images.png)",
        paper: "seed 000 Figs. 5, 7: stockinette rows and columns curl in opposite senses, rib compresses, garter stays flat",
        guarded: false,
        run,
    }
}

/// (name, chart) of the swatches: quick mode uses fewer stitches (full: at least 20 × 20).
fn swatches(quick: bool) -> anyhow::Result<Vec<(&'static str, Chart)>> {
    let n = if quick { 6 } else { 20 };
    Ok(vec![
        ("stockinette", Chart::stockinette(n, n)?),
        // An odd row count: the contact boundaries hold as many knit as purl stitches.
        ("garter", Chart::garter(n, n + 1)?),
        ("rib 2×2", Chart::rib(n + 2, n, 2, 2)?),
    ])
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    // Knitted as they are knitted: one continuous yarn turning at the row ends (with one
    // yarn per row and tied ends, garter's side edges roll by ≈ 1.2 rad: tests/curl.rs).
    let settings = SwatchSettings {
        settle_time: if ctx.quick { 0.3 } else { 0.5 },
        construction: Construction::Flat,
        ..SwatchSettings::default()
    };
    let swatches = swatches(ctx.quick)?;
    let progress = ctx.progress(swatches.len() as u64, "swatches");
    let mut data = Table::new(&[
        "pattern",
        "width",
        "height",
        "curl_left_rad",
        "curl_right_rad",
        "curl_bottom_rad",
        "curl_top_rad",
        "width_ratio",
    ]);
    let mut summary = Vec::new();
    let mut images = Vec::new();
    // The swatches are independent: settle them in parallel, then measure and render.
    let settled_swatches = swatches
        .par_iter()
        .map(|(name, chart)| {
            let out = settled(chart, &settings).map_err(|e| anyhow::anyhow!("{name}: {e:#}"));
            progress.inc(1);
            out
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    for (k, ((name, chart), (sim, layout))) in swatches.iter().zip(settled_swatches).enumerate() {
        let p = positions(&sim);
        let topo = sim.topology();
        anyhow::ensure!(
            p.iter().all(|v| v.iter().all(|c| c.is_finite())),
            "{name}: non-finite positions after settling"
        );
        let curl = edge_curl(topo, &p)?;
        let ratio = course_width(topo, &p)? / course_width(topo, &layout.positions)?;
        data.push_row([
            k as f64,
            chart.width() as f64,
            chart.height() as f64,
            curl.left,
            curl.right,
            curl.bottom,
            curl.top,
            ratio,
        ]);
        summary.push((
            format!(
                "{name} {}×{}: curl left/right/bottom/top",
                chart.width(),
                chart.height()
            ),
            format!(
                "{:+.2}/{:+.2}/{:+.2}/{:+.2} rad, width ratio {ratio:.3}",
                curl.left, curl.right, curl.bottom, curl.top
            ),
        ));
        // An oblique view from the front, below and to the left.
        let image = render(
            &sim,
            settings.params.radius,
            (420, 420),
            [0.45, 0.55, -1.0],
            [0.0, 1.0, 0.0],
        )?;
        images.push((format!("{name} (front)"), image.image));
    }
    let panels: Vec<(&str, &yarn_output::render::Image)> =
        images.iter().map(|(t, i)| (t.as_str(), i)).collect();
    save_images(&panels, &ctx.out_dir, &format!("{}-images", ctx.name))?;
    // The data as a chart too: curls per pattern as markers.
    let mut chart = crate::plot::LineChart::new("Edge curl of settled swatches")
        .x_label("pattern (0 stockinette, 1 garter, 2 rib 2×2)")
        .y_label("edge curl (rad, + towards the front)");
    for (col, label) in [
        ("curl_left_rad", "left"),
        ("curl_right_rad", "right"),
        ("curl_bottom_rad", "bottom (cast-on)"),
        ("curl_top_rad", "top (bind-off)"),
    ] {
        let values = data.column(col).expect("column exists");
        chart = chart.series(crate::plot::Series::markers(
            label,
            values.iter().enumerate().map(|(k, &v)| (k as f64, v)),
        ));
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "patterns": swatches.iter().map(|(n, c)| format!("{n} {}x{}", c.width(), c.height())).collect::<Vec<_>>(),
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width 3 mm, no gravity, no pins",
            "construction": "flat, one continuous yarn",
            "damping_alpha": sim_persistent::experiment::ALPHA,
            "dt_s": settings.dt, "settle_time_s": settings.settle_time,
        }),
        data,
    })
}
