//! `bending-models` (paper 004 Fig. 16, Appendix C): the linearized bending model
//! `I(h) = I − 2h·II` with the in-plane database against the explicit model of Eq. 19 built
//! from bending-direction databases ([`deform_runtime::bending`]).
//!
//! **Bending databases.** Real bending-direction databases from `sim-periodic` bent-tile
//! solves, built by [`super::deform_bending_db`] (memoized per process, shared with
//! `deform-time-vs-error`).
//!
//! **Comparison.** A sheet (zero in-plane strain) rolled onto cylinders of curvature κ along
//! x, along y and along the diagonal is deformed by both models (f64); the figure plots the
//! RMS and maximum yarn-vertex distance between them over interior vertices (1.5 quads away
//! from the boundary, where the discrete II is exact up to discretization), relative to the
//! yarn radius R. Along x and y at the sampled curvatures the explicit model reproduces the
//! bent-tile equilibria, so there the difference is the linearized model's error. The speed
//! ratio is the per-vertex stage time (f32, best of several frames, identity-face skipping
//! off) of both models on a larger rolled sheet, as the median over the curvatures of the
//! per-curvature ratio.

use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, synthetic};

use super::deform_bending_db::{KAPPA_MAX, bending, rolled};
use super::deform_real_db as real;
use crate::plot::{LineChart, Series, save_side_by_side};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "bending-models",
        title: "Linearized vs explicit bending model",
        shows: "a stockinette sheet rolled onto cylinders of curvature κ along x, y and the diagonal: RMS / max yarn-vertex distance between the linearized model I(h) = I − 2h·II (3-D in-plane database) and the explicit model of Eq. 19 (5 lookups in 4-D bending databases from sim-periodic bent-tile solves), relative to R; explicit / linearized per-vertex time ratio (f32; times in the CSV)",
        paper: "Fig. 16 / Appendix C: differences are small for the nearly planar stockinette and grow with curvature; the linearized model is ≈ 8× faster on the CPU (5 4-D vs 1 3-D lookup; the paper's 4-D data were 9⁴ samples); here with real 3³ (quick) / 5³ in-plane databases and 3 (quick) / 5 curvature samples per bending direction, and both timings include the shared world mapping, so the ratio is below the lookup-count ratio",
        guarded: false,
        run,
    }
}

/// RMS and maximum distance / `r` between the outputs of `a` and `b` over yarn vertices whose
/// material position lies at least `margin` (m) inside the sheet `[0, size]`.
fn interior_difference(
    a: &Deformer<f64>,
    b: &Deformer<f64>,
    size: [f64; 2],
    margin: [f64; 2],
    r: f64,
) -> [f64; 2] {
    let e = a.embedding();
    let (p, q) = (a.output(), b.output());
    let (mut sum, mut max, mut count) = (0.0f64, 0.0f64, 0usize);
    for k in 0..e.len() {
        let m = e.material[k];
        if (0..2).all(|d| m[d] > margin[d] && m[d] < size[d] - margin[d]) {
            let d2 =
                (p.x[k] - q.x[k]).powi(2) + (p.y[k] - q.y[k]).powi(2) + (p.z[k] - q.z[k]).powi(2);
            sum += d2;
            max = max.max(d2);
            count += 1;
        }
    }
    [(sum / count.max(1) as f64).sqrt() / r, max.sqrt() / r]
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let n = if ctx.quick { 3 } else { 5 };
    let kappas: Vec<f64> = if ctx.quick {
        vec![-KAPPA_MAX, 0.0, KAPPA_MAX]
    } else {
        vec![
            -KAPPA_MAX,
            -0.5 * KAPPA_MAX,
            0.0,
            0.5 * KAPPA_MAX,
            KAPPA_MAX,
        ]
    };
    let reference = real::reference(ctx)?;
    let tile = &reference.tile;
    let r = tile.radius;
    let real_bending = bending(ctx, n, &kappas)?;
    let (solves, bending_seconds) = (real_bending.solves, real_bending.seconds);
    let inplane_db = &real_bending.inplane.generated.database;
    let bending64 = real_bending.model::<f64>(tile)?;
    let bending32 = real_bending.model::<f32>(tile)?;

    // Accuracy: a sheet of 6 × 6 periods, 12 × 12 quads.
    let (cells, quads) = (6.0, 12);
    let mesh = real::sheet(tile, cells, quads);
    let size = [cells * tile.period[0], cells * tile.period[1]];
    let margin = size.map(|s| 1.5 * s / quads as f64);
    let options = SetupOptions {
        uv_scale: 1.0,
        deform: DeformOptions {
            skip_static: false,
            ..DeformOptions::default()
        },
        ..SetupOptions::default()
    };
    let mut linearized = build::<f64>(tile, inplane_db, &mesh, &options)?;
    let mut explicit = build::<f64>(tile, inplane_db, &mesh, &options)?;
    let steps = if ctx.quick { 5 } else { 13 };
    let sweep: Vec<f64> = (0..steps)
        .map(|k| KAPPA_MAX * (2.0 * k as f64 / (steps - 1) as f64 - 1.0))
        .collect();
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let directions = [("x", [1.0, 0.0]), ("y", [0.0, 1.0]), ("diagonal", [h, h])];

    // Speed: a larger sheet (f32), rolled along x.
    // Identity-face skipping off, so that the flat frame costs a full lookup per vertex too.
    let (big_cells, frames) = if ctx.quick { (16.0, 9) } else { (40.0, 15) };
    let big = real::sheet(tile, big_cells, 32);
    let timing = SetupOptions {
        deform: DeformOptions {
            skip_identity: false,
            ..options.deform
        },
        ..options
    };
    let mut fast = build::<f32>(tile, inplane_db, &big, &timing)?;
    let big_n = fast.embedding().len() as f64;

    let mut data = Table::new(&[
        "kappa_per_m",
        "rms_over_r_x",
        "max_over_r_x",
        "rms_over_r_y",
        "max_over_r_y",
        "rms_over_r_diagonal",
        "max_over_r_diagonal",
        "ns_per_vertex_linearized",
        "ns_per_vertex_explicit",
    ]);
    let progress = ctx.progress(sweep.len() as u64, "curvatures");
    for &kappa in &sweep {
        let mut row = vec![kappa];
        for (_, dir) in directions {
            let pos = synthetic::map_uvs(&mesh, |uv| rolled(uv, dir, kappa));
            linearized.frame(&pos)?;
            explicit.frame_explicit(&pos, &bending64)?;
            row.extend(interior_difference(&linearized, &explicit, size, margin, r));
        }
        let pos = synthetic::map_uvs(&big, |uv| rolled(uv, [1.0, 0.0], kappa));
        let (mut lin, mut exp) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..frames {
            lin = lin.min(fast.frame(&pos)?.vertex_seconds);
            exp = exp.min(fast.frame_explicit(&pos, &bending32)?.vertex_seconds);
        }
        row.extend([1e9 * lin / big_n, 1e9 * exp / big_n]);
        data.push_row(row);
        progress.inc(1);
    }
    progress.finish_and_clear();

    let col = |name: &str| data.column(name).expect("column exists");
    let x = col("kappa_per_m");
    let zip = |y: &[f64]| x.iter().copied().zip(y.iter().copied()).collect::<Vec<_>>();
    let mut left = LineChart::new("Linearized − explicit bending model (interior vertices)")
        .x_label("curvature κ (1/m)")
        .y_label("yarn-vertex distance / R");
    for (name, _) in directions {
        left = left
            .series(Series::line_markers(
                format!("RMS, bent along {name}"),
                zip(&col(&format!("rms_over_r_{name}"))),
            ))
            .series(Series::dashed(
                format!("max, bent along {name}"),
                zip(&col(&format!("max_over_r_{name}"))),
            ));
    }
    let ratio_points: Vec<(f64, f64)> = x
        .iter()
        .zip(
            col("ns_per_vertex_explicit")
                .iter()
                .zip(&col("ns_per_vertex_linearized")),
        )
        .map(|(&k, (e, l))| (k, e / l))
        .collect();
    let right = LineChart::new(format!(
        "Explicit / linearized per-vertex time (f32, best of {frames})"
    ))
    .x_label("curvature κ (1/m)")
    .y_label("time ratio")
    .series(Series::line_markers(
        format!(
            "{:.0} k yarn vertices, {} threads",
            big_n / 1e3,
            rayon::current_num_threads()
        ),
        ratio_points,
    ))
    .hline("paper (CPU): ≈ 8×", 8.0);
    save_side_by_side(&left, &right, &ctx.out_dir, ctx.name)?;

    // Median over the curvatures of the per-curvature time ratio (robust to a noisy frame).
    let mut ratios: Vec<f64> = col("ns_per_vertex_explicit")
        .iter()
        .zip(&col("ns_per_vertex_linearized"))
        .map(|(e, l)| e / l)
        .collect();
    ratios.sort_by(f64::total_cmp);
    let ratio = ratios[ratios.len() / 2];
    let at_max = data.rows.last().cloned().unwrap_or_default();
    let at_zero = data.rows[steps / 2].clone();
    Ok(FigureOutput {
        summary: vec![
            (
                format!("difference at κ = {KAPPA_MAX} 1/m (bent along x / y / diagonal)"),
                format!(
                    "RMS {:.3} / {:.3} / {:.3} R, max {:.3} / {:.3} / {:.3} R",
                    at_max[1], at_max[3], at_max[5], at_max[2], at_max[4], at_max[6]
                ),
            ),
            (
                "difference on the flat sheet (κ = 0)".into(),
                format!("max {:.2e} R", at_zero[2].max(at_zero[4]).max(at_zero[6])),
            ),
            (
                "explicit / linearized per-vertex time (median over κ)".into(),
                format!("{ratio:.2}× (paper: ≈ 8×)"),
            ),
            (
                "bending databases".into(),
                format!(
                    "2 × {} curvatures × {n}³, {solves} equilibrium solves in {bending_seconds:.1} s, {:.2} MB (in-plane: {:.2} MB)",
                    kappas.len(),
                    bending32.memory_bytes() as f64 / 1e6,
                    fast.database().memory_bytes() as f64 / 1e6
                ),
            ),
        ],
        config: serde_json::json!({
            "pattern": real::PATTERN,
            "in_plane_database": format!("real {n}³ from sim_periodic::database::generate, relaxed tile"),
            "axes": {"sx": real::SX, "sa": real::SA, "sy": real::SY},
            "bending_kappas_per_m": kappas,
            "sheet_cells": cells, "sheet_quads": quads, "interior_margin_m": margin,
            "sweep_kappas_per_m": sweep,
            "speed": {"sheet_cells": big_cells, "quads": 32, "yarn_vertices": big_n, "frames": frames,
                      "skip_identity": false,
                      "precision": "f32", "threads": rayon::current_num_threads()},
            "accuracy_precision": "f64",
        }),
        data,
    })
}
