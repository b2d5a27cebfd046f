//! `bending-models` (paper 004 Fig. 16, Appendix C): the linearized bending model
//! `I(h) = I − 2h·II` with the in-plane database against the explicit model of Eq. 19 built
//! from bending-direction databases ([`deform_runtime::bending`]).
//!
//! **Bending databases.** Real bending-direction databases from `sim-periodic` bent-tile
//! solves, built by [`crate::studies::deform_databases`] (memoized per process, shared with
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

use deform_runtime::bending::BendingDatabase;
use deform_runtime::obj::ObjMesh;
use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, synthetic};
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series, column_points, save_side_by_side};
use crate::studies::deform_databases as real;
use crate::studies::deform_databases::{KAPPA_MAX, RealBending, bending, rolled};
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

/// The bending directions of the accuracy comparison: along x, along y and the diagonal.
const DIRECTIONS: [(&str, [f64; 2]); 3] = [
    ("x", [1.0, 0.0]),
    ("y", [0.0, 1.0]),
    (
        "diagonal",
        [
            std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
        ],
    ),
];

/// The accuracy comparison: a sheet of 6 × 6 periods, 12 × 12 quads, deformed by both models
/// in f64.
struct AccuracySheet {
    cells: f64,
    quads: usize,
    mesh: ObjMesh,
    /// UV size of the sheet (m).
    size: [f64; 2],
    /// Vertices closer than this to the boundary are left out (1.5 quads, m).
    margin: [f64; 2],
    linearized: Deformer<f64>,
    explicit: Deformer<f64>,
}

impl AccuracySheet {
    /// The sheet with both models on the in-plane database `db`.
    fn new(tile: &Tile, db: &Database, options: &SetupOptions) -> anyhow::Result<Self> {
        let (cells, quads) = (6.0, 12);
        let mesh = real::sheet(tile, cells, quads);
        let size = [cells * tile.period[0], cells * tile.period[1]];
        let margin = size.map(|s| 1.5 * s / quads as f64);
        let linearized = build::<f64>(tile, db, &mesh, options)?;
        let explicit = build::<f64>(tile, db, &mesh, options)?;
        Ok(Self {
            cells,
            quads,
            mesh,
            size,
            margin,
            linearized,
            explicit,
        })
    }

    /// The sheet rolled with curvature `kappa` along each of [`DIRECTIONS`]: RMS and max
    /// interior distance / `r` between the linearized and the explicit model, per direction.
    fn differences(
        &mut self,
        kappa: f64,
        bending: &BendingDatabase<f64>,
        r: f64,
    ) -> anyhow::Result<Vec<f64>> {
        let mut row = Vec::new();
        for (_, dir) in DIRECTIONS {
            let pos = synthetic::map_uvs(&self.mesh, |uv| rolled(uv, dir, kappa));
            self.linearized.frame(&pos)?;
            self.explicit.frame_explicit(&pos, bending)?;
            row.extend(interior_difference(
                &self.linearized,
                &self.explicit,
                self.size,
                self.margin,
                r,
            ));
        }
        Ok(row)
    }
}

/// The speed comparison: a larger sheet (f32, 32 quads per side) rolled along x, with
/// identity-face skipping off so that the flat frame costs a full lookup per vertex too.
struct SpeedSheet {
    cells: f64,
    /// Frames per model and curvature (the best counts).
    frames: usize,
    mesh: ObjMesh,
    deformer: Deformer<f32>,
    /// Yarn vertices.
    vertices: f64,
}

impl SpeedSheet {
    /// The quick (16 periods, best of 9) or full (40 periods, best of 15) sheet on `db`.
    fn new(
        tile: &Tile,
        db: &Database,
        options: &SetupOptions,
        quick: bool,
    ) -> anyhow::Result<Self> {
        let (cells, frames) = if quick { (16.0, 9) } else { (40.0, 15) };
        let mesh = real::sheet(tile, cells, 32);
        let timing = SetupOptions {
            deform: DeformOptions {
                skip_identity: false,
                ..options.deform
            },
            ..*options
        };
        let deformer = build::<f32>(tile, db, &mesh, &timing)?;
        let vertices = deformer.embedding().len() as f64;
        Ok(Self {
            cells,
            frames,
            mesh,
            deformer,
            vertices,
        })
    }

    /// Best per-vertex stage time (ns per yarn vertex) of the linearized and the explicit
    /// model on the sheet rolled along x with curvature `kappa`.
    fn ns_per_vertex(
        &mut self,
        kappa: f64,
        bending: &BendingDatabase<f32>,
    ) -> anyhow::Result<[f64; 2]> {
        let pos = synthetic::map_uvs(&self.mesh, |uv| rolled(uv, [1.0, 0.0], kappa));
        let (mut lin, mut exp) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..self.frames {
            lin = lin.min(self.deformer.frame(&pos)?.vertex_seconds);
            exp = exp.min(self.deformer.frame_explicit(&pos, bending)?.vertex_seconds);
        }
        Ok([1e9 * lin / self.vertices, 1e9 * exp / self.vertices])
    }
}

/// Curvature samples κ (1/m) of the bending databases: 3 (quick) or 5 in `[−κmax, κmax]`.
fn database_kappas(quick: bool) -> Vec<f64> {
    if quick {
        vec![-KAPPA_MAX, 0.0, KAPPA_MAX]
    } else {
        vec![
            -KAPPA_MAX,
            -0.5 * KAPPA_MAX,
            0.0,
            0.5 * KAPPA_MAX,
            KAPPA_MAX,
        ]
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let n = if ctx.quick { 3 } else { 5 };
    let kappas = database_kappas(ctx.quick);
    let reference = real::reference(ctx)?;
    let tile = &reference.tile;
    let r = tile.radius;
    let real_bending = bending(ctx, n, &kappas)?;
    let inplane_db = &real_bending.inplane.generated.database;
    let bending64 = real_bending.model::<f64>(tile)?;
    let bending32 = real_bending.model::<f32>(tile)?;

    let options = SetupOptions {
        uv_scale: 1.0,
        deform: DeformOptions {
            skip_static: false,
            ..DeformOptions::default()
        },
        ..SetupOptions::default()
    };
    let mut accuracy = AccuracySheet::new(tile, inplane_db, &options)?;
    let steps = if ctx.quick { 5 } else { 13 };
    let sweep: Vec<f64> = (0..steps)
        .map(|k| KAPPA_MAX * (2.0 * k as f64 / (steps - 1) as f64 - 1.0))
        .collect();
    let mut speed = SpeedSheet::new(tile, inplane_db, &options, ctx.quick)?;

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
        row.extend(accuracy.differences(kappa, &bending64, r)?);
        row.extend(speed.ns_per_vertex(kappa, &bending32)?);
        data.push_row(row);
        progress.inc(1);
    }
    progress.finish_and_clear();
    save_charts(ctx, &data, &speed)?;

    let summary = summary(
        &data,
        steps / 2,
        n,
        &kappas,
        &real_bending,
        &bending32,
        &speed,
    );
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "pattern": real::PATTERN,
            "in_plane_database": format!("real {n}³ from sim_periodic::database::generate, relaxed tile"),
            "axes": {"sx": real::SX, "sa": real::SA, "sy": real::SY},
            "bending_kappas_per_m": kappas,
            "sheet_cells": accuracy.cells, "sheet_quads": accuracy.quads,
            "interior_margin_m": accuracy.margin,
            "sweep_kappas_per_m": sweep,
            "speed": {"sheet_cells": speed.cells, "quads": 32, "yarn_vertices": speed.vertices,
                      "frames": speed.frames, "skip_identity": false,
                      "precision": "f32", "threads": rayon::current_num_threads()},
            "accuracy_precision": "f64",
        }),
        data,
    })
}

/// Per-curvature time ratio explicit / linearized (per-vertex stage) of each CSV row.
fn time_ratios(data: &Table) -> Vec<f64> {
    let col = |name: &str| data.column(name).expect("column exists");
    col("ns_per_vertex_explicit")
        .iter()
        .zip(&col("ns_per_vertex_linearized"))
        .map(|(e, l)| e / l)
        .collect()
}

/// Left: the interior differences over curvature per direction; right: the time ratio.
fn save_charts(ctx: &FigureContext, data: &Table, speed: &SpeedSheet) -> anyhow::Result<()> {
    let mut left = LineChart::new("Linearized − explicit bending model (interior vertices)")
        .x_label("curvature κ (1/m)")
        .y_label("yarn-vertex distance / R");
    for (name, _) in DIRECTIONS {
        left = left
            .series(Series::line_markers(
                format!("RMS, bent along {name}"),
                column_points(data, "kappa_per_m", &format!("rms_over_r_{name}")),
            ))
            .series(Series::dashed(
                format!("max, bent along {name}"),
                column_points(data, "kappa_per_m", &format!("max_over_r_{name}")),
            ));
    }
    let kappas = data.column("kappa_per_m").expect("column exists");
    let ratio_points: Vec<(f64, f64)> = kappas.into_iter().zip(time_ratios(data)).collect();
    let right = LineChart::new(format!(
        "Explicit / linearized per-vertex time (f32, best of {})",
        speed.frames
    ))
    .x_label("curvature κ (1/m)")
    .y_label("time ratio")
    .series(Series::line_markers(
        format!(
            "{:.0} k yarn vertices, {} threads",
            speed.vertices / 1e3,
            rayon::current_num_threads()
        ),
        ratio_points,
    ))
    .hline("paper (CPU): ≈ 8×", 8.0);
    save_side_by_side(&left, &right, &ctx.out_dir, ctx.name)
}

/// Key numbers: the differences at the largest curvature and on the flat sheet (row
/// `flat_row`), the median time ratio and the cost and size of the bending databases of the
/// `n³` in-plane database.
fn summary(
    data: &Table,
    flat_row: usize,
    n: usize,
    kappas: &[f64],
    real_bending: &RealBending,
    bending32: &BendingDatabase<f32>,
    speed: &SpeedSheet,
) -> Vec<(String, String)> {
    // Median over the curvatures of the per-curvature time ratio (robust to a noisy frame).
    let mut ratios = time_ratios(data);
    ratios.sort_by(f64::total_cmp);
    let ratio = ratios[ratios.len() / 2];
    let at_max = data.rows.last().cloned().unwrap_or_default();
    let at_zero = data.rows[flat_row].clone();
    vec![
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
                "2 × {} curvatures × {n}³, {} equilibrium solves in {:.1} s, {:.2} MB (in-plane: {:.2} MB)",
                kappas.len(),
                real_bending.solves,
                real_bending.seconds,
                bending32.memory_bytes() as f64 / 1e6,
                speed.deformer.database().memory_bytes() as f64 / 1e6
            ),
        ),
    ]
}
