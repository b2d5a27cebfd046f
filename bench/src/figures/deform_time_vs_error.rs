//! `deform-time-vs-error`: per-frame time of the CPU deformer against the yarn-vertex position
//! error / R, relative to the densest real database evaluated in f64, over database density
//! and run-time precision (f32 / f64); the naive embedding (no displacement) is the
//! zero-cost end.

use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, Real};
use sim_periodic::madypg::Database;
use sim_periodic::tile::Tile;

use super::deform_real_db as real;
use crate::plot::{LineChart, Series};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "deform-time-vs-error",
        title: "Deformer time vs error",
        shows: "per-frame time (mesh + per-vertex stage, best of 10, CPU rayon) against RMS yarn-vertex position error / R vs the densest real database in f64, for each database density in f32 and f64, and the naive embedding",
        paper: "issue 5's time-vs-error study (no direct paper counterpart; Fig. 15 reports error vs density only); real sim-periodic databases over sx, sy ∈ [−0.1, 0.3], sa ∈ [−0.2, 0.2] (quick: 2³ vs a 3³ reference, full: 3³, 5³ vs 9³); the explicit bending model is not implemented, so it is not a variant here",
        guarded: false,
        run,
    }
}

/// One variant: (per-frame seconds, RMS error / R, max error / R, yarn vertices).
fn measure<T: Real>(
    tile: &Tile,
    db: &Database,
    mesh: &deform_runtime::obj::ObjMesh,
    moved: &[[f64; 3]],
    displacement: bool,
    exact: &Deformer<f64>,
    frames: usize,
) -> anyhow::Result<[f64; 3]> {
    let options = SetupOptions {
        uv_scale: 1.0,
        deform: DeformOptions {
            displacement,
            ..DeformOptions::default()
        },
        ..SetupOptions::default()
    };
    let mut d = build::<T>(tile, db, mesh, &options)?;
    let (mesh_s, vertex_s) = real::frame_seconds(&mut d, moved, frames)?;
    let [rms, max] = real::position_error(d.output(), exact.output(), tile.radius);
    Ok([mesh_s + vertex_s, rms, max])
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let densities: &[usize] = if ctx.quick { &[2, 3] } else { &[3, 5, 9] };
    let reference = real::reference()?;
    let tile = &reference.tile;
    let dbs = real::databases(ctx, densities)?;

    let cells = if ctx.quick { 24.0 } else { 48.0 };
    let quads = if ctx.quick { 48 } else { 96 };
    let frames = 10;
    let mesh = real::sheet(tile, cells, quads);
    let size = [cells * tile.period[0], cells * tile.period[1]];
    let moved = real::test_positions(&mesh, size);
    let densest = dbs.last().expect("at least one density");
    let options = SetupOptions {
        uv_scale: 1.0,
        ..SetupOptions::default()
    };
    let mut exact = build::<f64>(tile, &densest.generated.database, &mesh, &options)?;
    exact.frame(&moved)?;
    let n_yarn = exact.embedding().len();

    // precision: 32 or 64; samples_per_axis 0 marks the naive embedding.
    let mut data = Table::new(&[
        "samples_per_axis",
        "precision_bits",
        "frame_ms",
        "rms_error_over_r",
        "max_error_over_r",
    ]);
    let bar = ctx.progress(2 * (dbs.len() as u64 + 1), "variants");
    let first = &dbs[0].generated.database;
    for (bits, naive) in [
        (
            32.0,
            measure::<f32>(tile, first, &mesh, &moved, false, &exact, frames)?,
        ),
        (
            64.0,
            measure::<f64>(tile, first, &mesh, &moved, false, &exact, frames)?,
        ),
    ] {
        data.push_row([0.0, bits, 1e3 * naive[0], naive[1], naive[2]]);
        bar.inc(1);
    }
    for db in &dbs {
        let database = &db.generated.database;
        let f32_row = measure::<f32>(tile, database, &mesh, &moved, true, &exact, frames)?;
        data.push_row([db.n as f64, 32.0, 1e3 * f32_row[0], f32_row[1], f32_row[2]]);
        bar.inc(1);
        let f64_row = measure::<f64>(tile, database, &mesh, &moved, true, &exact, frames)?;
        data.push_row([db.n as f64, 64.0, 1e3 * f64_row[0], f64_row[1], f64_row[2]]);
        bar.inc(1);
    }

    // One marker series per variant: frame times on the shared machine vary by more than the
    // density changes them, so joining the points would suggest a trend that is not there.
    let label = |r: &[f64]| {
        if r[0] == 0.0 {
            format!("naive embedding, f{}", r[1])
        } else {
            format!("{}³ database, f{}", r[0], r[1])
        }
    };
    let mut chart = LineChart::new(format!(
        "Per-frame time vs error ({n_yarn} yarn vertices, reference {0}³ f64)",
        densest.n
    ))
    .x_label("time per frame (ms)")
    .y_label("RMS yarn-vertex position error / R")
    .log_y();
    for r in &data.rows {
        chart = chart.series(Series::markers(label(r), [(r[2], r[3])]));
    }
    chart.save(&ctx.out_dir, ctx.name)?;

    let summary = data
        .rows
        .iter()
        .map(|r| {
            (
                label(r),
                format!(
                    "{:.2} ms/frame, error RMS {:.3e} R, max {:.3e} R",
                    r[2], r[3], r[4]
                ),
            )
        })
        .collect();
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "pattern": real::PATTERN,
            "database": "real: sim_periodic::database::generate on the relaxed tile (memoized per process)",
            "axes": {"sx": real::SX, "sa": real::SA, "sy": real::SY},
            "samples_per_axis": densities,
            "reference": format!("{}³ in f64", densest.n),
            "sheet_cells": cells, "sheet_quads": quads, "yarn_vertices": n_yarn,
            "deformation": "deform_real_db::test_field",
            "frames": frames, "threads": rayon::current_num_threads(),
            "not_included": "explicit bending model (Appendix C, Eq. 19): needs bending-direction databases, not generated by sim-periodic yet",
        }),
        data,
    })
}
