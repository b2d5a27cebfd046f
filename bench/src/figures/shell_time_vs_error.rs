//! `shell-time-vs-error`: run time of one virtual stretch test and of the in-plane fit against
//! their error relative to the finest mesh / tightest Newton tolerance, as the mesh and the
//! tolerance are swept (Pareto plot).

use std::time::Instant;
use yarn_pattern::direction::Direction;

use shell_fem::fit::{FitConfig, Weighting, fit, initial_guess, targets};
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::swatch::{StretchPoint, StretchTest, SwatchConfig};

use crate::figures::shell_fit::acrylic_measurements;
use crate::plot::{LineChart, Series};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "shell-time-vs-error",
        title: "Thin shell: run time vs error",
        shows: "wall time of one virtual stretch test (bias, s = 0.5) and of the real-data in-plane fit against their relative error w.r.t. the finest mesh, for a mesh sweep and a Newton-tolerance sweep",
        paper: "no paper figure; the paper reports a 2 % change under two uniform subdivisions",
        guarded: false,
        run,
    }
}

fn stretch(cfg: &SwatchConfig) -> anyhow::Result<(StretchPoint, f64)> {
    let t0 = Instant::now();
    let mut t = StretchTest::new(
        cfg,
        Material::augmented(InPlaneParams::example()),
        Direction::Bias.angle(),
    )?;
    let p = t.solve_to(0.5)?;
    Ok((p, t0.elapsed().as_secs_f64()))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let meshes: &[(usize, usize)] = if ctx.quick {
        &[(4, 2), (6, 4), (10, 6), (14, 8), (20, 12)]
    } else {
        &[
            (4, 2),
            (6, 4),
            (10, 6),
            (14, 8),
            (20, 12),
            (28, 16),
            (40, 24),
            (56, 34),
        ]
    };
    let finest = if ctx.quick { (40, 24) } else { (80, 48) };
    let tolerances = [1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-9];
    let fit_meshes: &[(usize, usize)] = if ctx.quick {
        &[(4, 2), (6, 4), (10, 6)]
    } else {
        &[(4, 2), (6, 4), (10, 6), (14, 8), (20, 12)]
    };
    let fit_finest = if ctx.quick { (14, 8) } else { (28, 16) };
    let progress = ctx.progress(
        (meshes.len() + tolerances.len() + fit_meshes.len() + 3) as u64,
        "sweeps",
    );
    let mesh_cfg = |(nx, ny): (usize, usize)| SwatchConfig {
        nx,
        ny,
        ..SwatchConfig::default()
    };
    let (reference, _) = stretch(&mesh_cfg(finest))?;
    progress.inc(1);
    // kind: 0 = stretch-test mesh sweep, 1 = Newton tolerance sweep (base mesh), 2 = fit mesh sweep.
    let mut data = Table::new(&["kind", "nx", "ny", "gradient_tol_n", "seconds", "rel_error"]);
    let mut mesh_pts = Vec::new();
    for &m in meshes {
        let (p, secs) = stretch(&mesh_cfg(m))?;
        let e = rel(p.force, reference.force).max(rel(p.compression, reference.compression));
        data.push_row([0.0, m.0 as f64, m.1 as f64, 1e-9, secs, e]);
        mesh_pts.push((secs, e));
        progress.inc(1);
    }
    let mut tol_pts = Vec::new();
    let base = (20, 12);
    let (tight, _) = stretch(&mesh_cfg(base))?;
    progress.inc(1);
    for &tol in &tolerances {
        let mut cfg = mesh_cfg(base);
        cfg.newton.gradient_abs_tol = tol;
        let (p, secs) = stretch(&cfg)?;
        let e = rel(p.force, tight.force)
            .max(rel(p.compression, tight.compression))
            .max(1e-16);
        data.push_row([1.0, base.0 as f64, base.1 as f64, tol, secs, e]);
        tol_pts.push((secs, e));
        progress.inc(1);
    }
    let measurements = acrylic_measurements(24)?;
    let tg = targets(&measurements, 6);
    let fit_at = |m: (usize, usize)| -> anyhow::Result<(InPlaneParams, f64)> {
        let mut fixed = [false; shell_fem::InPlaneParams::LEN];
        fixed[3] = true;
        let cfg = FitConfig {
            swatch: mesh_cfg(m),
            weighting: Weighting::Relative,
            fixed,
            ..FitConfig::default()
        };
        let r = fit(&tg, initial_guess(&measurements, 0.06), &cfg, None)?;
        Ok((r.params, r.seconds))
    };
    let (fit_ref, _) = fit_at(fit_finest)?;
    progress.inc(1);
    let mut fit_pts = Vec::new();
    for &m in fit_meshes {
        let (p, secs) = fit_at(m)?;
        // Error: largest relative change of the identifiable parameters kxx, kxy, kyy, kn1.
        let e = [0, 1, 2, 4]
            .iter()
            .map(|&k| {
                (p.to_array()[k] - fit_ref.to_array()[k]).abs()
                    / fit_ref.to_array()[k].abs().max(1.0)
            })
            .fold(0.0, f64::max)
            .max(1e-16);
        data.push_row([2.0, m.0 as f64, m.1 as f64, 1e-9, secs, e]);
        fit_pts.push((secs, e));
        progress.inc(1);
    }
    LineChart::new("Thin shell: run time vs error (relative to finest / tightest)")
        .x_label("wall time (s)")
        .y_label("relative error")
        .log_x()
        .log_y()
        .series(Series::line_markers(
            "stretch test, mesh sweep (f_s, c)",
            mesh_pts.clone(),
        ))
        .series(Series::line_markers(
            "stretch test, Newton tolerance sweep",
            tol_pts,
        ))
        .series(Series::line_markers(
            "in-plane fit, mesh sweep (parameters)",
            fit_pts,
        ))
        .save(&ctx.out_dir, ctx.name)?;
    let base_err = data
        .rows
        .iter()
        .find(|r| r[0] == 0.0 && r[1] == 20.0)
        .map_or(f64::NAN, |r| r[5]);
    Ok(FigureOutput {
        summary: vec![
            (
                format!("stretch test 20×12 vs {}×{} error", finest.0, finest.1),
                crate::percent(base_err),
            ),
            (
                "fit reference mesh".into(),
                format!("{}×{}", fit_finest.0, fit_finest.1),
            ),
        ],
        config: serde_json::json!({
            "meshes": meshes, "finest": finest, "tolerances_n": tolerances, "fit_meshes": fit_meshes,
            "stretch": 0.5, "direction": "bias", "params": InPlaneParams::example(),
        }),
        data,
    })
}
