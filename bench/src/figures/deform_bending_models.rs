//! `bending-models` (paper 004 Fig. 16, Appendix C): the linearized bending model
//! `I(h) = I − 2h·II` with the in-plane database against the explicit model of Eq. 19 built
//! from bending-direction databases ([`deform_runtime::bending`]).
//!
//! **Bending databases.** For every sample `s` of the real in-plane `n³` database
//! ([`super::deform_real_db`]) and every curvature κ of a small axis, the relaxed stockinette
//! tile is solved under `Coarse::from_strain(s).bent(axis, κ)` (rolled onto a cylinder along
//! the deformed x or y axis) with `sim_periodic::periodic::solve_equilibrium`, warm-started
//! from the in-plane sample's equilibrium (rebuilt from its database row and polished) and
//! continued outward in κ, halving failed steps. The displacement is pulled back through the
//! exact inverse of the roll, `X̂ = F₃⁻¹ φ⁻¹(x)`, `ΔQ = X̂ − X` (the bent counterpart of seed 004
//! Eq. 18); κ = 0 uses the in-plane database itself, so both models agree on flat sheets.
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

use std::time::Instant;

use anyhow::Context;
use deform_runtime::bending::BendingDatabase;
use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, synthetic};
use nalgebra::Vector3;
use rayon::prelude::*;
use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::madypg::Database;
use sim_periodic::periodic::{EquilibriumSettings, YarnModel, solve_equilibrium};
use sim_periodic::tile::Tile;

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

/// Largest sampled curvature magnitude (1/m): a radius of ≈ 17 mm, ≈ 4 tile periods.
const KAPPA_MAX: f64 = 60.0;

/// Inverse of the roll of [`Coarse::map`] for `curvature` (`axis`, κ ≠ 0): the point
/// `(a, b, z)` with `φ(a, b, z) = x` (valid for `|z| < 1/|κ|`).
fn unroll(axis: usize, kappa: f64, x: &Vector3<f64>) -> Vector3<f64> {
    let c = 1.0 / kappa - x.z;
    let r = kappa.signum() * (x[axis] * x[axis] + c * c).sqrt();
    let angle = (x[axis] / r).atan2(c / r);
    let mut q = Vector3::new(0.0, 0.0, 1.0 / kappa - r);
    q[axis] = angle / kappa;
    q[1 - axis] = x[1 - axis];
    q
}

/// Material displacement rows `(Δx, Δy, Δz, Δθ)` of the equilibrium `dofs` of `tile` under
/// the bent `coarse` map: `ΔQ = F₃⁻¹ φ⁻¹(x) − X` per vertex, `Δθ` of its outgoing edge.
fn bent_displacements(tile: &Tile, coarse: &Coarse, dofs: &[f64]) -> anyhow::Result<Vec<[f32; 4]>> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let inverse = coarse.f3().try_inverse().context("singular coarse map")?;
    let roll = coarse.curvature.filter(|c| c.kappa != 0.0);
    Ok((0..n)
        .map(|v| {
            let y = &tile.positions[v];
            let u = Vector3::new(dofs[3 * v], dofs[3 * v + 1], dofs[3 * v + 2]);
            let x = coarse.map(y) + coarse.frame(y) * u;
            let q = match roll {
                Some(c) => unroll(c.axis, c.kappa, &x),
                None => x,
            };
            let d = inverse * q - y;
            let theta = dofs[3 * n + topology.outgoing(v)] - tile.twists[v];
            [d.x as f32, d.y as f32, d.z as f32, theta as f32]
        })
        .collect())
}

/// The equilibrium DOFs of the in-plane sample at row block `sample` of `db` (fluctuations
/// `F₃ ΔQ`, twists `Θ + Δθ`), before polishing.
fn inplane_dofs(
    tile: &Tile,
    db: &Database,
    index: [usize; 3],
    coarse: &Coarse,
) -> anyhow::Result<Vec<f64>> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let f3 = coarse.f3();
    let mut x = vec![0.0; 4 * n];
    for v in 0..n {
        let row = db.data[db.index(v, index[0], index[1], index[2])];
        let u = f3 * Vector3::new(f64::from(row[0]), f64::from(row[1]), f64::from(row[2]));
        x[3 * v..3 * v + 3].copy_from_slice(u.as_slice());
        x[3 * n + topology.outgoing(v)] = tile.twists[v] + f64::from(row[3]);
    }
    Ok(x)
}

/// One in-plane sample bent along one axis: what [`Bend::to`] solves.
struct Bend<'a> {
    tile: &'a Tile,
    model: &'a YarnModel,
    settings: &'a EquilibriumSettings,
    strain: Strain,
    axis: usize,
}

impl Bend<'_> {
    /// Solves the tile bent by `to` (1/m), continuing from curvature `from` with equilibrium
    /// `dofs`; halves the step up to `depth` times. Returns the DOFs and the number of solves.
    fn to(
        &self,
        (from, dofs): (f64, &[f64]),
        to: f64,
        depth: usize,
    ) -> anyhow::Result<(Vec<f64>, usize)> {
        let coarse = Coarse::from_strain(&self.strain).bent(self.axis, to);
        match solve_equilibrium(self.tile, self.model, coarse, Some(dofs), self.settings) {
            Ok(eq) => Ok((eq.dofs, 1)),
            Err(e) if depth == 0 => Err(e).with_context(|| {
                let s = &self.strain;
                format!(
                    "bending the tile along axis {} to κ = {to} 1/m at (sx, sa, sy) = ({}, {}, {})",
                    self.axis, s.sx, s.sa, s.sy
                )
            }),
            Err(_) => {
                let mid = 0.5 * (from + to);
                let (half, a) = self.to((from, dofs), mid, depth - 1)?;
                let (full, b) = self.to((mid, &half), to, depth - 1)?;
                Ok((full, a + b + 1))
            }
        }
    }
}

/// The bending-direction databases `[along x, along y]`, one per curvature of `kappas` (which
/// contains 0, where the in-plane database is used), and the number of equilibrium solves.
fn bending_databases(
    reference: &real::Reference,
    inplane: &Database,
    kappas: &[f64],
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<([Vec<Database>; 2], usize)> {
    let (tile, model) = (&reference.tile, &reference.model);
    let settings = EquilibriumSettings::default();
    let dims = [0, 1, 2].map(|k| inplane.axes[k].len());
    let n_samples = dims.iter().product::<usize>();
    // Per sample: rows[axis][kappa] (the in-plane rows for κ = 0), solves.
    type Rows = Vec<Vec<[f32; 4]>>;
    let per_sample = (0..n_samples)
        .into_par_iter()
        .map(|flat| -> anyhow::Result<([Rows; 2], usize)> {
            let index = [
                flat % dims[0],
                (flat / dims[0]) % dims[1],
                flat / (dims[0] * dims[1]),
            ];
            let s = Strain {
                sx: inplane.axes[0][index[0]],
                sa: inplane.axes[1][index[1]],
                sy: inplane.axes[2][index[2]],
            };
            let flat_coarse = Coarse::from_strain(&s);
            let start = inplane_dofs(tile, inplane, index, &flat_coarse)?;
            let eq0 = solve_equilibrium(tile, model, flat_coarse, Some(&start), &settings)
                .with_context(|| format!("polishing the in-plane sample {s:?}"))?;
            let zero_rows: Vec<[f32; 4]> = (0..tile.n_vertices())
                .map(|v| inplane.data[inplane.index(v, index[0], index[1], index[2])])
                .collect();
            let mut solves = 1;
            let mut out: [Rows; 2] = [vec![vec![]; kappas.len()], vec![vec![]; kappas.len()]];
            for (axis, rows) in out.iter_mut().enumerate() {
                // Outward from κ = 0 on both sides, each step warm-started from the last.
                let zero = kappas
                    .iter()
                    .position(|&k| k == 0.0)
                    .expect("κ = 0 sampled");
                rows[zero] = zero_rows.clone();
                let bend = Bend {
                    tile,
                    model,
                    settings: &settings,
                    strain: s,
                    axis,
                };
                for side in [
                    (zero + 1..kappas.len()).collect::<Vec<_>>(),
                    (0..zero).rev().collect(),
                ] {
                    let (mut from, mut dofs) = (0.0, eq0.dofs.clone());
                    for k in side {
                        let to = kappas[k];
                        let (next, used) = bend.to((from, &dofs), to, 4)?;
                        solves += used;
                        let coarse = flat_coarse.bent(axis, to);
                        rows[k] = bent_displacements(tile, &coarse, &next)?;
                        (from, dofs) = (to, next);
                    }
                }
            }
            progress();
            Ok((out, solves))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let n = tile.n_vertices();
    let mut solves = 0;
    let mut dbs: [Vec<Database>; 2] = [0, 1].map(|_| {
        kappas
            .iter()
            .map(|_| Database {
                axes: inplane.axes.clone(),
                n_vertices: n,
                data: vec![[0.0; 4]; inplane.data.len()],
            })
            .collect()
    });
    for (flat, (rows, used)) in per_sample.into_iter().enumerate() {
        solves += used;
        let index = [
            flat % dims[0],
            (flat / dims[0]) % dims[1],
            flat / (dims[0] * dims[1]),
        ];
        for axis in 0..2 {
            for (k, db) in dbs[axis].iter_mut().enumerate() {
                for v in 0..n {
                    let row = db.index(v, index[0], index[1], index[2]);
                    db.data[row] = rows[axis][k][v];
                }
            }
        }
    }
    Ok((dbs, solves))
}

/// World position of UV point `uv` of a sheet rolled with curvature `kappa` (1/m) along the
/// unit in-plane direction `dir` (centre of curvature on the +z side); flat for κ = 0.
fn rolled(uv: [f64; 2], dir: [f64; 2], kappa: f64) -> [f64; 3] {
    let a = uv[0] * dir[0] + uv[1] * dir[1];
    let b = -uv[0] * dir[1] + uv[1] * dir[0];
    let (along, z) = if kappa == 0.0 {
        (a, 0.0)
    } else {
        ((kappa * a).sin() / kappa, (1.0 - (kappa * a).cos()) / kappa)
    };
    [along * dir[0] - b * dir[1], along * dir[1] + b * dir[0], z]
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
    let reference = real::reference()?;
    let tile = &reference.tile;
    let r = tile.radius;
    let progress = ctx.progress((n * n * n) as u64, "in-plane samples");
    let inplane = real::database(n, &|| progress.inc(1))?;
    progress.finish_and_clear();
    let progress = ctx.progress((n * n * n) as u64, "bent samples");
    let t = Instant::now();
    let inplane_db = &inplane.generated.database;
    let ([along_x, along_y], solves) =
        bending_databases(&reference, inplane_db, &kappas, &|| progress.inc(1))?;
    let bending_seconds = t.elapsed().as_secs_f64();
    progress.finish_and_clear();
    let bending64 = BendingDatabase::<f64>::new(tile, &kappas, &along_x, &along_y)?;
    let bending32 = BendingDatabase::<f32>::new(tile, &kappas, &along_x, &along_y)?;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unroll_inverts_the_roll() {
        let f = nalgebra::Matrix2::new(1.1, 0.05, 0.05, 0.95);
        for axis in 0..2 {
            for kappa in [-80.0, 25.0] {
                let coarse = Coarse::in_plane(f).bent(axis, kappa);
                let y = Vector3::new(0.003, -0.002, 0.0007);
                let q = unroll(axis, kappa, &coarse.map(&y));
                let back = coarse.f3().try_inverse().unwrap() * q;
                assert!((back - y).norm() < 1e-15, "{back} vs {y}");
            }
        }
    }

    #[test]
    fn rolled_sheet_has_the_requested_curvature() {
        // Unit speed along the roll direction and distance 1/κ from the axis.
        let (kappa, dir) = (40.0, [0.6, 0.8]);
        let p = |t: f64| rolled([t * dir[0], t * dir[1]], dir, kappa);
        let (a, b) = (p(0.01), p(0.01 + 1e-6));
        let speed = ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt() / 1e-6;
        assert!((speed - 1.0).abs() < 1e-6);
        let centre = [0.0, 0.0, 1.0 / kappa];
        let dist = ((0..3).map(|k| (a[k] - centre[k]).powi(2)).sum::<f64>()).sqrt();
        assert!((dist - 1.0 / kappa).abs() < 1e-12);
    }
}
