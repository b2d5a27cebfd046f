//! `naive-vs-mechanics-aware` (paper 004 Figs. 9–10): a flat stockinette sheet stretched along
//! x, deformed with the real `sim-periodic` database (mechanics-aware) and without it (naive
//! embedding: the mesh map applied to the rest pattern). Reports the position difference / R,
//! the yarn length ratio (deformed / rest polyline length — naive embedding stretches the yarn
//! with the mesh, a mechanics-aware result straightens loops instead) and the out-of-plane
//! loop displacement, and draws a top view of both at the largest stretch, plus both rendered as
//! shaded yarn tubes of radius R (`yarn_output::render`) at the same scale.

use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, Real, synthetic};
use yarn_output::render::{Camera, Framing, RenderOptions, Rendering, render_tubes};

use super::deform_real_db as real;
use crate::plot::{LineChart, Series, save_images, save_side_by_side};
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

/// `d`'s output rendered as tubes (radius `options.radius`).
fn tubes(d: &Deformer<f64>, options: &RenderOptions) -> anyhow::Result<Rendering> {
    let (e, o) = (d.embedding(), d.output());
    let lines = e.polylines(o);
    Ok(render_tubes(&lines, options)?)
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let n = if ctx.quick { 3 } else { 5 };
    let reference = real::reference(ctx)?;
    let tile = &reference.tile;
    let r = tile.radius;
    let progress = ctx.progress((n * n * n) as u64, "database samples");
    let db = real::database(ctx, n, &|| progress.inc(1))?;
    progress.finish_and_clear();

    let cells = 4.0;
    let mesh = real::sheet(tile, cells, 8);
    let options = SetupOptions {
        uv_scale: 1.0,
        ..SetupOptions::default()
    };
    let mut aware = build::<f64>(tile, &db.generated.database, &mesh, &options)?;
    let mut naive = build::<f64>(tile, &db.generated.database, &mesh, &options)?;
    naive.set_options(DeformOptions {
        displacement: false,
        ..DeformOptions::default()
    })?;
    let rest_length = yarn_length(&aware, true);
    let steps = if ctx.quick { 4 } else { 7 };
    let stretches: Vec<f64> = (0..steps)
        .map(|k| real::SX[1] * k as f64 / (steps - 1) as f64)
        .collect();
    let mut data = Table::new(&[
        "stretch_sx",
        "rms_difference_over_r",
        "max_difference_over_r",
        "yarn_length_ratio_naive",
        "yarn_length_ratio_aware",
        "rms_out_of_plane_over_r_naive",
        "rms_out_of_plane_over_r_aware",
    ]);
    let rms_dz = |d: &Deformer<f64>| {
        let e = d.embedding();
        let z = &d.output().z;
        let n = e.len().max(1) as f64;
        (e.material
            .iter()
            .zip(z)
            .map(|(m, z)| (z - m[2]).powi(2))
            .sum::<f64>()
            / n)
            .sqrt()
            / r
    };
    for &s in &stretches {
        let pos = synthetic::map_uvs(&mesh, |uv| [(1.0 + s) * uv[0], uv[1], 0.0]);
        aware.frame(&pos)?;
        naive.frame(&pos)?;
        let [rms, max] = real::position_error(aware.output(), naive.output(), r);
        data.push_row([
            s,
            rms,
            max,
            yarn_length(&naive, false) / rest_length,
            yarn_length(&aware, false) / rest_length,
            rms_dz(&naive),
            rms_dz(&aware),
        ]);
    }
    let last = *stretches.last().expect("steps ≥ 2");
    save_side_by_side(
        &top_view(&naive, &format!("Naive embedding, sx = {last:.2}")),
        &top_view(
            &aware,
            &format!("Mechanics-aware ({n}³ database), sx = {last:.2}"),
        ),
        &ctx.out_dir,
        &format!("{}-top-view", ctx.name),
    )?;
    // Slightly oblique so loop crossings and out-of-plane shape read as depth; the naive
    // image fixes the framing, the mechanics-aware one reuses it (same scale and centre).
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
    let naive_image = tubes(&naive, &render)?;
    let aware_image = tubes(
        &aware,
        &RenderOptions {
            framing: naive_image.framing,
            ..render.clone()
        },
    )?;
    save_images(
        &[
            (
                &format!("Naive embedding, sx = {last:.2}"),
                &naive_image.image,
            ),
            (
                &format!("Mechanics-aware ({n}³ database), sx = {last:.2}"),
                &aware_image.image,
            ),
        ],
        &ctx.out_dir,
        &format!("{}-tubes", ctx.name),
    )?;

    let col = |name: &str| data.column(name).expect("column exists");
    let x = col("stretch_sx");
    let zip = |y: &[f64]| x.iter().copied().zip(y.iter().copied()).collect::<Vec<_>>();
    let left = LineChart::new("Difference mechanics-aware − naive")
        .x_label("uniaxial stretch sx")
        .y_label("yarn-vertex distance / R")
        .series(Series::line_markers(
            "RMS",
            zip(&col("rms_difference_over_r")),
        ))
        .series(Series::line_markers(
            "max",
            zip(&col("max_difference_over_r")),
        ))
        .series(Series::dashed(
            "RMS out-of-plane, mechanics-aware",
            zip(&col("rms_out_of_plane_over_r_aware")),
        ));
    let right = LineChart::new("Loop shape: yarn length (deformed / rest)")
        .x_label("uniaxial stretch sx")
        .y_label("yarn length ratio")
        .series(Series::line_markers(
            "naive embedding",
            zip(&col("yarn_length_ratio_naive")),
        ))
        .series(Series::line_markers(
            "mechanics-aware",
            zip(&col("yarn_length_ratio_aware")),
        ));
    save_side_by_side(&left, &right, &ctx.out_dir, ctx.name)?;

    let row = data.rows.last().cloned().unwrap_or_default();
    Ok(FigureOutput {
        summary: vec![
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
        ],
        config: serde_json::json!({
            "pattern": real::PATTERN,
            "database": format!("real {n}³ from sim_periodic::database::generate, relaxed tile"),
            "axes": {"sx": real::SX, "sa": real::SA, "sy": real::SY},
            "sheet_cells": cells, "sheet_quads": 8, "yarn_vertices": aware.embedding().len(),
            "stretches": stretches, "precision": "f64",
            "top_view": format!("{}-top-view.png", ctx.name),
            "tubes": {"file": format!("{}-tubes.png", ctx.name), "camera": camera,
                      "framing": naive_image.framing, "radius_m": r,
                      "segments": [naive_image.segments, aware_image.segments]},
        }),
        data,
    })
}
