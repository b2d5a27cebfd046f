//! `periodic-databases`: the displacement-database benchmark of issue 13 — for the real
//! stockinette tile and every procedural pattern, generate the 9³ database over the full
//! published strain range (sx, sy ∈ [−0.2, 1.0], sa ∈ [−0.7, 0.7]) with default settings and
//! report wall time, unsolved samples, Newton iterations per sample (median, max) and time per
//! iteration, against the paper's 120 s (stockinette) and 762 s (rib) on a desktop.

use sim_periodic::database::{DatabaseSettings, generate, relax_period, uniform_axis};
use sim_periodic::patterns::Pattern;
use sim_periodic::periodic::{EquilibriumSettings, YarnModel};
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series};
use crate::studies::periodic::{pattern_tile, real_stockinette};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "periodic-databases",
        title: "Displacement databases per pattern: time and Newton iterations",
        shows: "9³ displacement databases over sx, sy ∈ [−0.2, 1.0], sa ∈ [−0.7, 0.7] (default settings, stress-free period) for the real stockinette tile and the eight procedural patterns: wall time, unsolved samples, Newton iterations per sample (median, max) and ms per iteration, against the tile's DOF count",
        paper: "seed 004 §5: a 9³ stockinette database in 120–130 s and a 9³ rib in 762 s on a desktop; quick mode runs 3³ over the same range",
        guarded: false,
        run,
    }
}

/// The paper's 9³ generation times (s): stockinette and rib (seed 004 §5).
const PAPER_STOCKINETTE_S: f64 = 120.0;
const PAPER_RIB_S: f64 = 762.0;

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let n = if ctx.quick { 3 } else { 9 };
    let axes = [
        uniform_axis(-0.2, 1.0, n),
        uniform_axis(-0.7, 0.7, n),
        uniform_axis(-0.2, 1.0, n),
    ];
    let mut tiles: Vec<(String, Tile)> = vec![("stockinette (real)".into(), real_stockinette()?)];
    for p in Pattern::ALL {
        tiles.push((p.name().to_string(), pattern_tile(p, 1e-3, None)?));
    }
    let mut data = Table::new(&[
        "pattern",
        "vertices",
        "dofs",
        "samples",
        "unsolved",
        "seconds",
        "sample_seconds",
        "iterations_median",
        "iterations_max",
        "ms_per_iteration",
    ]);
    let mut time = Vec::new();
    let mut per_iteration = Vec::new();
    let mut summary = Vec::new();
    let settings = DatabaseSettings {
        fill_unsolved: true,
        ..DatabaseSettings::default()
    };
    let progress = ctx.progress(tiles.len() as u64, "patterns");
    for (k, (name, tile)) in tiles.iter().enumerate() {
        let model = YarnModel::default_for_radius(tile.radius);
        // As `sim-periodic database` with `relax_period = true`: relaxed at zero strain with a
        // stress-free period (not timed).
        let (tile, _) = relax_period(tile, &model, &EquilibriumSettings::default(), 1e-6)?;
        let generated = generate(&tile, &model, axes.clone(), &settings, None, &|_| {})?;
        let samples = &generated.samples;
        let mut iterations: Vec<usize> = samples.iter().map(|s| s.iterations).collect();
        iterations.sort_unstable();
        let median = iterations[iterations.len() / 2];
        let max = *iterations.last().expect("samples");
        let total: usize = iterations.iter().sum();
        let sample_seconds: f64 = samples.iter().map(|s| s.seconds).sum();
        let unsolved = samples.iter().filter(|s| !s.solved).count();
        let ms = 1e3 * sample_seconds / total.max(1) as f64;
        let dofs = 4 * tile.n_vertices();
        data.push_row([
            k as f64,
            tile.n_vertices() as f64,
            dofs as f64,
            samples.len() as f64,
            unsolved as f64,
            generated.seconds,
            sample_seconds,
            median as f64,
            max as f64,
            ms,
        ]);
        time.push((dofs as f64, generated.seconds));
        per_iteration.push((dofs as f64, ms));
        let paper = match name.as_str() {
            "stockinette (real)" => Some(PAPER_STOCKINETTE_S),
            "rib2x2" => Some(PAPER_RIB_S),
            _ => None,
        };
        let ratio = match (paper, ctx.quick) {
            (Some(p), false) => format!(", {:.2}× the paper's {p:.0} s", generated.seconds / p),
            _ => String::new(),
        };
        summary.push((
            format!("{name} ({} vertices), {n}³", tile.n_vertices()),
            format!(
                "{:.1} s, {unsolved} unsolved, iterations median {median} / max {max}, {ms:.2} ms/iteration{ratio}",
                generated.seconds
            ),
        ));
        progress.inc(1);
    }
    LineChart::new(format!("{n}³ databases over the full strain range"))
        .x_label("tile DOFs (4 per vertex)")
        .y_label("wall time (s) / ms per Newton iteration")
        .log_x()
        .log_y()
        .series(Series::markers("database wall time (s)", time))
        .series(Series::markers("ms per Newton iteration", per_iteration))
        .save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "axes": axes,
            "patterns": tiles.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(),
            "settings": "DatabaseSettings::default() with fill_unsolved (reported per pattern)",
            "period": "relax_period to 1e-6 N/m, as `sim-periodic database` with relax_period = true",
            "threads": rayon::current_num_threads(),
        }),
        data,
    })
}
