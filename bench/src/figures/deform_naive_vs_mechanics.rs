//! `naive-vs-mechanics-aware` (paper 004 Figs. 9–10): a flat stockinette sheet stretched along
//! x, deformed with the real `sim-periodic` database (mechanics-aware) and without it (naive
//! embedding: the mesh map applied to the rest pattern). Reports the position difference / R,
//! the yarn length ratio (deformed / rest polyline length — naive embedding stretches the yarn
//! with the mesh, a mechanics-aware result straightens loops instead) and the out-of-plane
//! loop displacement, and draws a top view of both at the largest stretch, plus both rendered as
//! shaded yarn tubes of radius R (`yarn_output::render`) at the same scale.

use deform_runtime::obj::ObjMesh;
use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, Real, synthetic};
use yarn_output::render::{Camera, Framing, RenderOptions, Rendering};

use crate::plot::{LineChart, Series, column_points, save_images, save_side_by_side};
use crate::studies::deform::{rms_out_of_plane, tubes};
use crate::studies::deform_databases as real;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "naive-vs-mechanics-aware",
        title: "Naive vs mechanics-aware embedding",
        shows: "flat stockinette sheet under uniaxial stretch sx: RMS / max yarn-vertex difference between naive embedding and database displacement (/ R), yarn length ratio (deformed / rest) of both, RMS out-of-plane loop displacement / R; plus a top view of the yarns at the largest stretch (…-top-view.png) and both rendered as shaded tubes of radius R at the same scale (…-tubes.png)",
        paper: "Figs. 9–10: naive embedding stretches the yarns with the mesh, the mechanics-aware result keeps yarn length and changes loop shape; here with a real sim-periodic database (3³ in quick mode, 5³ in full mode, over sx, sy ∈ [−0.1, 0.3], sa ∈ [−0.2, 0.2])",
        guarded: false,
        run,
    }
}

/// Total polyline length of every curve of `d`'s output (m); `rest` uses material positions.
fn yarn_length<T: Real>(d: &Deformer<T>, rest: bool) -> f64 {
    let e = d.embedding();
    let o = d.output();
    let p = |k: usize| -> [f64; 3] {
        if rest {
            e.material[k]
        } else {
            [o.x[k].as_(), o.y[k].as_(), o.z[k].as_()]
        }
    };
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let mut total = 0.0;
    for c in 0..e.n_curves() {
        let (s, t) = (e.curve_offsets[c] as usize, e.curve_offsets[c + 1] as usize);
        for k in s + 1..t {
            total += dist(p(k - 1), p(k));
        }
        if e.closed[c] && t > s + 1 {
            total += dist(p(t - 1), p(s));
        }
    }
    total
}

/// Top-view (x, y) polylines of every curve of `d`'s output, one unnamed series each.
fn top_view<T: Real>(d: &Deformer<T>, title: &str) -> LineChart {
    let e = d.embedding();
    let o = d.output();
    let mut chart = LineChart::new(title).x_label("x (mm)").y_label("y (mm)");
    for c in 0..e.n_curves() {
        let (s, t) = (e.curve_offsets[c] as usize, e.curve_offsets[c + 1] as usize);
        let mut pts: Vec<(f64, f64)> = (s..t)
            .map(|k| (1e3 * o.x[k].as_(), 1e3 * o.y[k].as_()))
            .collect();
        if e.closed[c] && t > s {
            pts.push(pts[0]);
        }
        chart = chart.series(Series::line("", pts));
    }
    chart
}

/// The two deformers of the comparison on one sheet: with the database (mechanics-aware) and
/// without its displacement (naive embedding).
struct Pair {
    aware: Deformer<f64>,
    naive: Deformer<f64>,
}

/// Sheet size in pattern periods and quads per side.
const SHEET_CELLS: f64 = 4.0;
const SHEET_QUADS: usize = 8;

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let n = if ctx.quick { 3 } else { 5 };
    let reference = real::reference(ctx)?;
    let tile = &reference.tile;
    let r = tile.radius;
    let progress = ctx.progress((n * n * n) as u64, "database samples");
    let db = real::database(ctx, n, &|| progress.inc(1))?;
    progress.finish_and_clear();

    let mesh = real::sheet(tile, SHEET_CELLS, SHEET_QUADS);
    let options = SetupOptions {
        uv_scale: 1.0,
        ..SetupOptions::default()
    };
    let mut pair = Pair {
        aware: build::<f64>(tile, &db.generated.database, &mesh, &options)?,
        naive: build::<f64>(tile, &db.generated.database, &mesh, &options)?,
    };
    pair.naive.set_options(DeformOptions {
        displacement: false,
        ..DeformOptions::default()
    })?;
    let steps = if ctx.quick { 4 } else { 7 };
    let stretches: Vec<f64> = (0..steps)
        .map(|k| real::SX[1] * k as f64 / (steps - 1) as f64)
        .collect();
    let data = stretch_sweep(&mut pair, &mesh, &stretches, r)?;
    let last = *stretches.last().expect("steps ≥ 2");
    let naive_title = format!("Naive embedding, sx = {last:.2}");
    let aware_title = format!("Mechanics-aware ({n}³ database), sx = {last:.2}");
    save_side_by_side(
        &top_view(&pair.naive, &naive_title),
        &top_view(&pair.aware, &aware_title),
        &ctx.out_dir,
        &format!("{}-top-view", ctx.name),
    )?;
    let (camera, [naive_image, aware_image]) = render_pair(&pair, r)?;
    save_images(
        &[
            (&naive_title, &naive_image.image),
            (&aware_title, &aware_image.image),
        ],
        &ctx.out_dir,
        &format!("{}-tubes", ctx.name),
    )?;
    save_charts(ctx, &data)?;

    Ok(FigureOutput {
        summary: summary(&data, n),
        config: serde_json::json!({
            "pattern": real::PATTERN,
            "database": format!("real {n}³ from sim_periodic::database::generate, relaxed tile"),
            "axes": {"sx": real::SX, "sa": real::SA, "sy": real::SY},
            "sheet_cells": SHEET_CELLS, "sheet_quads": SHEET_QUADS,
            "yarn_vertices": pair.aware.embedding().len(),
            "stretches": stretches, "precision": "f64",
            "top_view": format!("{}-top-view.png", ctx.name),
            "tubes": {"file": format!("{}-tubes.png", ctx.name), "camera": camera,
                      "framing": naive_image.framing, "radius_m": r,
                      "segments": [naive_image.segments, aware_image.segments]},
        }),
        data,
    })
}

/// The CSV: both deformers on the sheet stretched uniaxially by each of `stretches` along x,
/// their difference, yarn length ratios and out-of-plane displacement (/ `r`).
fn stretch_sweep(
    pair: &mut Pair,
    mesh: &ObjMesh,
    stretches: &[f64],
    r: f64,
) -> anyhow::Result<Table> {
    let rest_length = yarn_length(&pair.aware, true);
    let mut data = Table::new(&[
        "stretch_sx",
        "rms_difference_over_r",
        "max_difference_over_r",
        "yarn_length_ratio_naive",
        "yarn_length_ratio_aware",
        "rms_out_of_plane_over_r_naive",
        "rms_out_of_plane_over_r_aware",
    ]);
    for &s in stretches {
        let pos = synthetic::map_uvs(mesh, |uv| [(1.0 + s) * uv[0], uv[1], 0.0]);
        pair.aware.frame(&pos)?;
        pair.naive.frame(&pos)?;
        let [rms, max] = real::position_error(pair.aware.output(), pair.naive.output(), r);
        data.push_row([
            s,
            rms,
            max,
            yarn_length(&pair.naive, false) / rest_length,
            yarn_length(&pair.aware, false) / rest_length,
            rms_out_of_plane(&pair.naive) / r,
            rms_out_of_plane(&pair.aware) / r,
        ]);
    }
    Ok(data)
}

/// Both deformers' current output rendered as tubes of radius `r`, slightly oblique so loop
/// crossings and out-of-plane shape read as depth; the naive image fixes the framing, the
/// mechanics-aware one reuses it (same scale and centre). Returns the camera and the
/// `[naive, mechanics-aware]` renderings.
fn render_pair(pair: &Pair, r: f64) -> anyhow::Result<(Camera, [Rendering; 2])> {
    let camera = Camera {
        direction: [0.0, 0.35, -1.0],
        up: [0.0, 1.0, 0.0],
    };
    let render = RenderOptions {
        camera,
        framing: Framing::Auto { margin: 0.05 },
        supersample: 3,
        ..RenderOptions::new(800, 380, r)
    };
    let naive_image = tubes(&pair.naive, &render)?;
    let aware_image = tubes(
        &pair.aware,
        &RenderOptions {
            framing: naive_image.framing,
            ..render.clone()
        },
    )?;
    Ok((camera, [naive_image, aware_image]))
}

/// Left: the difference over stretch; right: the yarn length ratios.
fn save_charts(ctx: &FigureContext, data: &Table) -> anyhow::Result<()> {
    let points = |y: &str| column_points(data, "stretch_sx", y);
    let left = LineChart::new("Difference mechanics-aware − naive")
        .x_label("uniaxial stretch sx")
        .y_label("yarn-vertex distance / R")
        .series(Series::line_markers("RMS", points("rms_difference_over_r")))
        .series(Series::line_markers("max", points("max_difference_over_r")))
        .series(Series::dashed(
            "RMS out-of-plane, mechanics-aware",
            points("rms_out_of_plane_over_r_aware"),
        ));
    let right = LineChart::new("Loop shape: yarn length (deformed / rest)")
        .x_label("uniaxial stretch sx")
        .y_label("yarn length ratio")
        .series(Series::line_markers(
            "naive embedding",
            points("yarn_length_ratio_naive"),
        ))
        .series(Series::line_markers(
            "mechanics-aware",
            points("yarn_length_ratio_aware"),
        ));
    save_side_by_side(&left, &right, &ctx.out_dir, ctx.name)
}

/// Key numbers at the largest stretch, and the difference at zero stretch (the `n³` grid's
/// interpolated ΔQ(0)).
fn summary(data: &Table, n: usize) -> Vec<(String, String)> {
    let row = data.rows.last().cloned().unwrap_or_default();
    vec![
        (
            format!("difference at sx = {:.2}", row[0]),
            format!("RMS {:.3} R, max {:.3} R", row[1], row[2]),
        ),
        (
            format!("yarn length ratio at sx = {:.2}", row[0]),
            format!("naive {:.4}, mechanics-aware {:.4}", row[3], row[4]),
        ),
        (
            format!("RMS out-of-plane at sx = {:.2}", row[0]),
            format!("naive {:.3} R, mechanics-aware {:.3} R", row[5], row[6]),
        ),
        (
            "difference at sx = 0".into(),
            format!(
                "RMS {:.3e} R (the interpolated ΔQ(0) of the {n}³ grid)",
                data.rows[0][1]
            ),
        ),
    ]
}
