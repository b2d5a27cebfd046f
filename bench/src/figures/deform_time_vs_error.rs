//! `deform-time-vs-error`: per-frame time of the CPU deformer against the yarn-vertex position
//! error / R on a *curved* sheet, over database density, run-time precision (f32 / f64) and the
//! bending model (linearized `I(h) = I − 2h·II` with the 3-D in-plane database, or the
//! explicit model of paper 004 Appendix C, Eq. 19, with real bending-direction databases),
//! relative to the densest database with the explicit (full) bending model in f64; the naive
//! embedding (no displacement) is the zero-cost end.
//!
//! The sheet carries the in-plane strain field of [`real::test_field`] and is bent, without
//! further stretching, along a direction 30° from the x axis with curvature
//! `κ = ½κmax (1 + sin(2π a / λ))` ([`waved`]), so every curvature in the sampled range `[0, κmax]`
//! occurs, at a principal direction between the two bending-database axes. (Curvatures of one
//! sign halve the bent-tile solves, which keeps quick mode short.) The bending
//! databases are built once at the densest in-plane grid ([`bending`]) and restricted to the
//! coarser, nested grids ([`crate::studies::deform_databases::RealBending::restrict`]).

use std::sync::Arc;

use deform_runtime::bending::BendingDatabase;
use deform_runtime::obj::ObjMesh;
use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, FrameStats, Real, synthetic};
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series};
use crate::studies::deform_databases as real;
use crate::studies::deform_databases::{KAPPA_MAX, RealBending, bending, waved};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "deform-time-vs-error",
        title: "Deformer time vs error",
        shows: "per-frame time (mesh + per-vertex stage, best of 10 in interleaved rounds, CPU rayon) against RMS yarn-vertex position error / R on a curved sheet (in-plane test strain plus a curvature 0 … 60 1/m), relative to the densest real database with the explicit bending model (Eq. 19) in f64, for each database density × bending model (linearized I − 2h·II: circles; explicit: triangles) × f32 / f64, and the naive embedding",
        paper: "issue 5's time-vs-error study over database density, f32/f64 and the bending model (no direct paper counterpart; Fig. 15 reports error vs density only, Fig. 16 linearized vs explicit); real sim-periodic in-plane databases over sx, sy ∈ [−0.1, 0.3], sa ∈ [−0.2, 0.2] and bending databases from bent-tile solves at κ ∈ {0, 60} 1/m (quick: 2³, 3³ vs the 3³ explicit reference; full: 3³, 5³, 9³ vs 9³ explicit); the error of the densest linearized f64 point is the linearized model's own error",
        guarded: false,
        run,
    }
}

/// Direction of the wave (radians from the x axis): between the two bending-database axes,
/// so Eq. 19 mixes both.
const WAVE_ANGLE: f64 = std::f64::consts::FRAC_PI_6;
/// Wavelength of the curvature wave, in pattern periods along x.
const WAVE_PERIODS: f64 = 12.0;

/// The bending model of a variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Model {
    /// No displacement: the naive embedding.
    Naive,
    /// `I(h) = I − 2h·II` with the in-plane database ([`Deformer::frame`]).
    Linearized,
    /// Eq. 19 with the bending databases ([`Deformer::frame_explicit`]).
    Explicit,
}

impl Model {
    /// Code in the CSV's `bending_model` column.
    fn code(self) -> f64 {
        match self {
            Model::Naive => 0.0,
            Model::Linearized => 1.0,
            Model::Explicit => 2.0,
        }
    }
}

/// The test positions: [`real::test_field`] on the flat sheet of UV size `size`, then bent
/// into the curvature wave of [`waved`] (its out-of-plane bump along the wave's normal).
fn curved_positions(mesh: &ObjMesh, size: [f64; 2], tile: &Tile) -> Vec<[f64; 3]> {
    let dir = [WAVE_ANGLE.cos(), WAVE_ANGLE.sin()];
    let wavelength = WAVE_PERIODS * tile.period[0];
    synthetic::map_uvs(mesh, |uv| {
        let p = real::test_field(uv, size);
        let (q, n) = waved([p[0], p[1]], dir, [0.5 * KAPPA_MAX; 2], wavelength);
        [0, 1, 2].map(|k| q[k] + p[2] * n[k])
    })
}

/// One variant: a deformer in precision `T` with its bending model.
struct Variant<'a, T> {
    deformer: Deformer<T>,
    /// The explicit model's databases (`None`: [`Deformer::frame`]).
    bending: Option<BendingDatabase<T>>,
    positions: &'a [[f64; 3]],
}

/// What the timing loop needs of a [`Variant`], whatever its precision.
trait Timed {
    /// One recomputed frame.
    fn frame(&mut self) -> anyhow::Result<FrameStats>;
    /// RMS and maximum yarn-vertex distance / `r` to `exact`.
    fn error(&self, exact: &Deformer<f64>, r: f64) -> [f64; 2];
}

impl<T: Real> Timed for Variant<'_, T> {
    fn frame(&mut self) -> anyhow::Result<FrameStats> {
        Ok(match &self.bending {
            Some(b) => self.deformer.frame_explicit(self.positions, b)?,
            None => self.deformer.frame(self.positions)?,
        })
    }

    fn error(&self, exact: &Deformer<f64>, r: f64) -> [f64; 2] {
        real::position_error(self.deformer.output(), exact.output(), r)
    }
}

/// A [`Variant`] on `db` (with `bending`, or the linearized model; `displacement` off: the
/// naive embedding), static-frame skipping off so that every frame recomputes.
fn variant<'a, T: Real>(
    tile: &Tile,
    db: &Database,
    bending: Option<BendingDatabase<T>>,
    mesh: &ObjMesh,
    positions: &'a [[f64; 3]],
    displacement: bool,
) -> anyhow::Result<Box<dyn Timed + 'a>> {
    let options = SetupOptions {
        uv_scale: 1.0,
        deform: DeformOptions {
            displacement,
            skip_static: false,
            ..DeformOptions::default()
        },
        ..SetupOptions::default()
    };
    Ok(Box::new(Variant {
        deformer: build::<T>(tile, db, mesh, &options)?,
        bending,
        positions,
    }))
}

/// A [`Variant`] with its CSV labels.
struct Labelled<'a> {
    /// Samples per axis of the in-plane database (0: the naive embedding).
    n: usize,
    model: Model,
    /// Precision (32 or 64 bits).
    bits: f64,
    variant: Box<dyn Timed + 'a>,
}

/// Timed rounds (one frame per variant each) after the warm-up round.
const FRAMES: usize = 10;

/// The curved test sheet: its size in pattern periods, its quads per side, the mesh and the
/// bent positions.
struct CurvedSheet {
    cells: f64,
    quads: usize,
    mesh: ObjMesh,
    positions: Vec<[f64; 3]>,
}

impl CurvedSheet {
    /// The sheet of 24 (quick) or 48 periods with 48 or 96 quads per side, in-plane strained
    /// and bent by [`curved_positions`].
    fn new(tile: &Tile, quick: bool) -> Self {
        let cells = if quick { 24.0 } else { 48.0 };
        let quads = if quick { 48 } else { 96 };
        let mesh = real::sheet(tile, cells, quads);
        let size = [cells * tile.period[0], cells * tile.period[1]];
        let positions = curved_positions(&mesh, size, tile);
        Self {
            cells,
            quads,
            mesh,
            positions,
        }
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let densities: &[usize] = if ctx.quick { &[2, 3] } else { &[3, 5, 9] };
    let kappas = [0.0, KAPPA_MAX];
    let reference = real::reference(ctx)?;
    let tile = &reference.tile;
    let densest_n = *densities.last().expect("at least one density");
    let real_bending = bending(ctx, densest_n, &kappas)?;
    let dbs = real::databases(ctx, densities)?;
    let sheet = CurvedSheet::new(tile, ctx.quick);
    let densest = dbs.last().expect("at least one density");
    let exact = explicit_reference(tile, &densest.generated.database, &sheet, &real_bending)?;
    let n_yarn = exact.embedding().len();

    let mut variants = variants(tile, &dbs, &real_bending, &kappas, &sheet)?;
    let best = interleaved_best_times(ctx, &mut variants)?;
    let data = timing_table(&variants, &best, &exact, tile.radius);
    drop(variants);
    save_chart(ctx, &data, n_yarn, densest_n)?;
    Ok(FigureOutput {
        summary: summary(&data, densest_n, &kappas, &real_bending),
        config: config(densities, &kappas, densest_n, &sheet, n_yarn),
        data,
    })
}

/// The reference output: the densest database with the explicit bending model in f64, on
/// the curved sheet.
fn explicit_reference(
    tile: &Tile,
    densest: &Database,
    sheet: &CurvedSheet,
    real_bending: &RealBending,
) -> anyhow::Result<Deformer<f64>> {
    let options = SetupOptions {
        uv_scale: 1.0,
        ..SetupOptions::default()
    };
    let mut exact = build::<f64>(tile, densest, &sheet.mesh, &options)?;
    exact.frame_explicit(&sheet.positions, &real_bending.model::<f64>(tile)?)?;
    Ok(exact)
}

/// The variants in CSV row order: the naive embedding in f32 and f64, then per density the
/// linearized and the explicit model in f32 and f64 (the explicit ones with the dense
/// bending databases restricted to the density's grid).
fn variants<'a>(
    tile: &Tile,
    dbs: &[Arc<real::RealDatabase>],
    real_bending: &RealBending,
    kappas: &[f64],
    sheet: &'a CurvedSheet,
) -> anyhow::Result<Vec<Labelled<'a>>> {
    let (mesh, moved) = (&sheet.mesh, &sheet.positions[..]);
    let labelled = |n, model, bits, variant| Labelled {
        n,
        model,
        bits,
        variant,
    };
    let first = &dbs[0].generated.database;
    let mut variants = vec![
        labelled(
            0,
            Model::Naive,
            32.0,
            variant::<f32>(tile, first, None, mesh, moved, false)?,
        ),
        labelled(
            0,
            Model::Naive,
            64.0,
            variant::<f64>(tile, first, None, mesh, moved, false)?,
        ),
    ];
    for db in dbs {
        let database = &db.generated.database;
        let [x, y] = real_bending.restrict(database)?;
        let b32 = BendingDatabase::<f32>::new(tile, kappas, &x, &y)?;
        let b64 = BendingDatabase::<f64>::new(tile, kappas, &x, &y)?;
        let lin32 = variant::<f32>(tile, database, None, mesh, moved, true)?;
        let lin64 = variant::<f64>(tile, database, None, mesh, moved, true)?;
        let exp32 = variant(tile, database, Some(b32), mesh, moved, true)?;
        let exp64 = variant(tile, database, Some(b64), mesh, moved, true)?;
        variants.push(labelled(db.n, Model::Linearized, 32.0, lin32));
        variants.push(labelled(db.n, Model::Linearized, 64.0, lin64));
        variants.push(labelled(db.n, Model::Explicit, 32.0, exp32));
        variants.push(labelled(db.n, Model::Explicit, 64.0, exp64));
    }
    Ok(variants)
}

/// Best (frame, per-vertex stage) seconds of each variant over [`FRAMES`] interleaved rounds
/// of one frame per variant, after a warm-up round: load from other processes on the shared
/// machine then affects all variants alike instead of whichever ran during a burst.
fn interleaved_best_times(
    ctx: &FigureContext,
    variants: &mut [Labelled<'_>],
) -> anyhow::Result<Vec<(f64, f64)>> {
    let mut best = vec![(f64::INFINITY, f64::INFINITY); variants.len()];
    let bar = ctx.progress(FRAMES as u64 + 1, "timing rounds");
    for round in 0..=FRAMES {
        for (slot, v) in best.iter_mut().zip(variants.iter_mut()) {
            let s = v.variant.frame()?;
            let (total, vertex) = (s.mesh_seconds + s.vertex_seconds, s.vertex_seconds);
            if round > 0 && total < slot.0 {
                *slot = (total, vertex);
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(best)
}

/// The CSV: per variant its labels, best times (ms) and RMS / max error / R against `exact`.
fn timing_table(
    variants: &[Labelled<'_>],
    best: &[(f64, f64)],
    exact: &Deformer<f64>,
    r: f64,
) -> Table {
    // samples_per_axis 0 marks the naive embedding; bending_model: Model::code.
    let mut data = Table::new(&[
        "samples_per_axis",
        "bending_model",
        "precision_bits",
        "frame_ms",
        "vertex_stage_ms",
        "rms_error_over_r",
        "max_error_over_r",
    ]);
    for (v, (total, vertex)) in variants.iter().zip(best) {
        let [rms, max] = v.variant.error(exact, r);
        data.push_row([
            v.n as f64,
            v.model.code(),
            v.bits,
            1e3 * total,
            1e3 * vertex,
            rms,
            max,
        ]);
    }
    data
}

/// The legend label of a CSV row.
fn variant_label(r: &[f64], densest_n: usize) -> String {
    match r[1] as u8 {
        0 => format!("naive embedding, f{}", r[2]),
        1 => format!("{}³ linearized, f{}", r[0], r[2]),
        _ if r[0] as usize == densest_n && r[2] == 64.0 => {
            format!("{}³ explicit, f64 (reference, error 0)", r[0])
        }
        _ => format!("{}³ explicit, f{}", r[0], r[2]),
    }
}

/// The time-vs-error chart: one marker series per variant (frame times on the shared machine
/// vary by more than the density changes them, so joining the points would suggest a trend
/// that is not there).
fn save_chart(
    ctx: &FigureContext,
    data: &Table,
    n_yarn: usize,
    densest_n: usize,
) -> anyhow::Result<()> {
    let mut chart = LineChart::new(format!(
        "Time vs error, curved sheet ({n_yarn} yarn vertices, reference {densest_n}³ explicit f64)"
    ))
    .x_label("time per frame (ms)")
    .y_label("RMS yarn-vertex position error / R")
    .log_y();
    for r in &data.rows {
        let point = [(r[3], r[5])];
        let label = variant_label(r, densest_n);
        chart = chart.series(if r[1] == Model::Explicit.code() {
            Series::triangles(label, point)
        } else {
            Series::markers(label, point)
        });
    }
    chart.save(&ctx.out_dir, ctx.name)
}

/// Key numbers: time and error per variant, the explicit / linearized time ratios and the
/// bending databases' cost.
fn summary(
    data: &Table,
    densest_n: usize,
    kappas: &[f64],
    real_bending: &RealBending,
) -> Vec<(String, String)> {
    let mut summary: Vec<(String, String)> = data
        .rows
        .iter()
        .map(|r| {
            (
                variant_label(r, densest_n),
                format!(
                    "{:.2} ms/frame (per-vertex stage {:.2} ms), error RMS {:.3e} R, max {:.3e} R",
                    r[3], r[4], r[5], r[6]
                ),
            )
        })
        .collect();
    // Explicit / linearized time ratio per density and precision (rows come in the order
    // linearized f32, f64, explicit f32, f64).
    for chunk in data.rows[2..].chunks(4) {
        let (lin, exp) = (&chunk[..2], &chunk[2..]);
        summary.push((
            format!("{}³ explicit / linearized time (f32, f64)", chunk[0][0]),
            format!(
                "per frame {:.2}×, {:.2}×; per-vertex stage {:.2}×, {:.2}×",
                exp[0][3] / lin[0][3],
                exp[1][3] / lin[1][3],
                exp[0][4] / lin[0][4],
                exp[1][4] / lin[1][4]
            ),
        ));
    }
    summary.push((
        "bending databases".into(),
        format!(
            "2 × {} curvatures × {densest_n}³ ({} equilibrium solves in {:.1} s; coarser grids restricted)",
            kappas.len(),
            real_bending.solves,
            real_bending.seconds
        ),
    ));
    summary
}

/// The manifest's record of the study's parameters.
fn config(
    densities: &[usize],
    kappas: &[f64],
    densest_n: usize,
    sheet: &CurvedSheet,
    n_yarn: usize,
) -> serde_json::Value {
    serde_json::json!({
        "pattern": real::PATTERN,
        "database": "real: sim_periodic::database::generate on the relaxed tile (memoized per process)",
        "bending_databases": format!(
            "real: deform_databases::bending at {densest_n}³ (sim-periodic bent-tile solves along x and y), restricted to the coarser nested grids; κ = 0 is each grid's in-plane database"
        ),
        "bending_kappas_per_m": kappas,
        "axes": {"sx": real::SX, "sa": real::SA, "sy": real::SY},
        "samples_per_axis": densities,
        "bending_models": ["linearized I(h) = I − 2h·II (Deformer::frame)", "explicit Eq. 19 (Deformer::frame_explicit)"],
        "reference": format!("{densest_n}³ with the explicit bending model in f64"),
        "sheet_cells": sheet.cells, "sheet_quads": sheet.quads, "yarn_vertices": n_yarn,
        "deformation": format!(
            "deform_databases::test_field, bent isometrically with curvature κ = ½·{KAPPA_MAX}·(1 + sin(2π a / λ)) 1/m along {:.0}° from x, λ = {WAVE_PERIODS} periods along x (deform_databases::waved)",
            WAVE_ANGLE.to_degrees()
        ),
        "csv_bending_model": "0 naive embedding, 1 linearized, 2 explicit (samples_per_axis 0: naive)",
        "frames": FRAMES,
        "timing": "one warm-up frame, then best of `frames` per variant over interleaved rounds (one frame per variant per round), static-frame skipping off",
        "threads": rayon::current_num_threads(),
        "not_included": "GPU back end (CPU rayon only here; the explicit model runs on the CPU only)",
    })
}
