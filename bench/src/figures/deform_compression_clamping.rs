//! `compression-clamping` (paper 004 Fig. 6, §4.3): out-of-plane yarn displacement of a sheet
//! under uniaxial compression, for several lower bounds λmin on the eigenvalues of I.
//!
//! The database is synthetic (the periodic solver's databases are not wired into the figure
//! set yet): a buckling mode whose out-of-plane amplitude grows with compression,
//! `Δz = R · 2(−sx)₊ · sin(2π v / 7)` per pattern vertex v, plus a small in-plane part. The
//! figure therefore shows what clamping does to a database that buckles, not the buckling of
//! real yarns. At the largest compression the sheet without clamping and with λmin = 0.8 is
//! rendered as shaded yarn tubes (`yarn_output::render`, grazing view, same scale).

use deform_runtime::obj::ObjMesh;
use deform_runtime::pipeline::{SetupOptions, build, read_pattern};
use deform_runtime::{DeformOptions, Deformer, synthetic};
use yarn_output::render::{Camera, Framing, RenderOptions, Rendering};
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series, column_points, save_images};
use crate::studies::deform::{rms_out_of_plane, tubes};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "compression-clamping",
        title: "Compression clamping",
        shows: "RMS out-of-plane yarn displacement / R of a compressed flat sheet against compression, without clamping and for λmin = 0.6 … 0.9, plus the large-scale width (unchanged by clamping); the sheet at the largest compression without clamping and with λmin = 0.8 rendered as shaded tubes (…-tubes.png)",
        paper: "Fig. 6: clamping the eigenvalues of I at λmin limits buckling in a user-tunable way while the large-scale deformation is preserved; reproduced qualitatively with a synthetic buckling database",
        guarded: false,
        run,
    }
}

/// The λmin values compared (`None`: no clamping), in the CSV's column order.
const LAMBDAS: [Option<f64>; 5] = [None, Some(0.6), Some(0.7), Some(0.8), Some(0.9)];

/// The compressed sheet: the stockinette tile, the synthetic buckling database and a sheet of
/// `cells` pattern periods on a 6 × 6 grid mesh.
struct Sheet {
    tile: Tile,
    db: Database,
    cells: [f64; 2],
    mesh: ObjMesh,
}

impl Sheet {
    /// The 6 × 10-period stockinette sheet with the buckling database (module docs).
    fn new() -> anyhow::Result<Self> {
        let pattern = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/data/patterns/stockinette.pyp"
        );
        let tile = read_pattern(std::path::Path::new(pattern))?;
        let r = tile.radius;
        let axes = [
            (0..=14).map(|k| -0.4 + 0.1 * k as f64).collect::<Vec<_>>(),
            vec![-0.7, 0.0, 0.7],
            vec![-0.4, 0.0, 1.0],
        ];
        let db = synthetic::database(&tile, axes, move |v, s| {
            let squeeze = (-s[0]).max(0.0);
            let mode = (2.0 * std::f64::consts::PI * v as f64 / 7.0).sin();
            [0.1 * r * s[0], 0.0, 2.0 * r * squeeze * mode, 0.0]
        });
        let (cu, cv) = (6.0, 10.0);
        let width = cu * tile.period[0];
        let mesh = synthetic::grid_mesh(6, 6, width, cv * tile.period[1]);
        Ok(Self {
            tile,
            db,
            cells: [cu, cv],
            mesh,
        })
    }
}

/// The sweep's results: per compression the CSV row, and the tube renderings at the largest
/// compression without clamping and with λmin = 0.8, with their captions.
struct Sweep {
    rows: Vec<Vec<f64>>,
    images: Vec<(String, Rendering)>,
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let sheet = Sheet::new()?;
    let r = sheet.tile.radius;
    let steps = if ctx.quick { 7 } else { 31 };
    let compressions: Vec<f64> = (0..steps)
        .map(|k| 0.3 * k as f64 / (steps - 1) as f64)
        .collect();
    // Grazing view along +y so the out-of-plane buckling shows; the unclamped sheet fixes the
    // framing and the clamped one reuses it.
    let camera = Camera {
        direction: [0.0, 1.0, -0.45],
        up: [0.0, 0.0, 1.0],
    };
    let mut render = RenderOptions {
        camera,
        framing: Framing::Auto { margin: 0.05 },
        supersample: 3,
        ..RenderOptions::new(640, 420, r)
    };
    let sweep = sweep(ctx, &sheet, &compressions, &mut render)?;
    let mut data = Table::new(&[
        "compression",
        "rms_dz_over_r_no_clamp",
        "rms_dz_over_r_lmin_0.6",
        "rms_dz_over_r_lmin_0.7",
        "rms_dz_over_r_lmin_0.8",
        "rms_dz_over_r_lmin_0.9",
        "width_ratio_no_clamp",
        "width_ratio_lmin_0.8",
    ]);
    for row in sweep.rows {
        data.push_row(row);
    }
    save_chart(ctx, &data)?;
    let panels: Vec<(&str, &yarn_output::render::Image)> = sweep
        .images
        .iter()
        .map(|(label, r)| (label.as_str(), &r.image))
        .collect();
    save_images(&panels, &ctx.out_dir, &format!("{}-tubes", ctx.name))?;
    let last = data.rows.last().cloned().unwrap_or_default();
    Ok(FigureOutput {
        summary: vec![
            (
                format!(
                    "RMS Δz/R at {:.0} % compression, no clamping",
                    100.0 * last[0]
                ),
                format!("{:.3}", last[1]),
            ),
            ("same with λmin = 0.8".into(), format!("{:.3}", last[4])),
            (
                "large-scale width ratio with λmin = 0.8".into(),
                format!("{:.4}", last[7]),
            ),
        ],
        config: serde_json::json!({
            "pattern": "tests/data/patterns/stockinette.pyp",
            "database": "synthetic: Δz = R·2(−sx)₊·sin(2πv/7), Δx = 0.1·R·sx",
            "cells": sheet.cells, "compressions": compressions, "lambda_min": [null, 0.6, 0.7, 0.8, 0.9],
            "precision": "f64",
            "tubes": {"file": format!("{}-tubes.png", ctx.name), "camera": camera,
                      "framing": render.framing, "radius_m": r},
        }),
        data,
    })
}

/// Deforms the sheet, for each of [`LAMBDAS`], compressed along x by each of `compressions`:
/// RMS out-of-plane displacement / R per λmin, and the width ratio without clamping and with
/// λmin = 0.8. The renderings at the largest compression use `render`, whose framing the
/// first one fixes.
fn sweep(
    ctx: &FigureContext,
    sheet: &Sheet,
    compressions: &[f64],
    render: &mut RenderOptions,
) -> anyhow::Result<Sweep> {
    let r = sheet.tile.radius;
    let progress = ctx.progress(LAMBDAS.len() as u64, "λmin values");
    let mut images: Vec<(String, Rendering)> = Vec::new();
    let mut rows: Vec<Vec<f64>> = compressions.iter().map(|&c| vec![c; 8]).collect();
    for (j, lmin) in LAMBDAS.iter().enumerate() {
        let deform = DeformOptions {
            clamp_compression: lmin.is_some(),
            lambda_min: lmin.unwrap_or(0.8),
            ..DeformOptions::default()
        };
        let options = SetupOptions {
            uv_scale: 1.0,
            deform,
            ..SetupOptions::default()
        };
        let mut d = build::<f64>(&sheet.tile, &sheet.db, &sheet.mesh, &options)?;
        for (i, &c) in compressions.iter().enumerate() {
            let stretch = 1.0 - c;
            d.frame(&synthetic::map_uvs(&sheet.mesh, |uv| {
                [stretch * uv[0], uv[1], 0.0]
            }))?;
            rows[i][1 + j] = rms_out_of_plane(&d) / r;
            let ratio = width_ratio(&d, stretch);
            if j == 0 {
                rows[i][6] = ratio;
            } else if *lmin == Some(0.8) {
                rows[i][7] = ratio;
            }
            if i + 1 == compressions.len() && (j == 0 || *lmin == Some(0.8)) {
                let image = tubes(&d, render)?;
                render.framing = image.framing;
                let label = match lmin {
                    None => "no clamping".to_string(),
                    Some(l) => format!("λmin = {l}"),
                };
                images.push((format!("{label}, {:.0} % compression", 100.0 * c), image));
            }
        }
        progress.inc(1);
    }
    Ok(Sweep { rows, images })
}

/// The large-scale width of `d`'s output (x extent) over the material width times `stretch`:
/// 1 when the sheet follows the mesh.
fn width_ratio(d: &Deformer<f64>, stretch: f64) -> f64 {
    let (e, o) = (d.embedding(), d.output());
    let (lo, hi) =
        o.x.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
    let material_span = e
        .material
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| {
            (a.min(m[0]), b.max(m[0]))
        });
    (hi - lo) / (stretch * (material_span.1 - material_span.0))
}

/// RMS out-of-plane displacement / R against compression, one line per λmin.
fn save_chart(ctx: &FigureContext, data: &Table) -> anyhow::Result<()> {
    let lines = [
        ("no clamping", "rms_dz_over_r_no_clamp"),
        ("λmin = 0.6", "rms_dz_over_r_lmin_0.6"),
        ("λmin = 0.7", "rms_dz_over_r_lmin_0.7"),
        ("λmin = 0.8 (default)", "rms_dz_over_r_lmin_0.8"),
        ("λmin = 0.9", "rms_dz_over_r_lmin_0.9"),
    ];
    let mut chart = LineChart::new("Compression clamping (synthetic buckling database)")
        .x_label("uniaxial compression 1 − λ along x")
        .y_label("RMS out-of-plane yarn displacement / R");
    for (label, column) in lines {
        chart = chart.series(Series::line_markers(
            label,
            column_points(data, "compression", column),
        ));
    }
    chart.save(&ctx.out_dir, ctx.name)
}
