//! `shell-nh-vs-stvk` (seed 002, Fig. 5): uniaxial stretch with zero orthogonal stress (Eq. 3)
//! of plain anisotropic StVK and of StVK + the area terms of Eq. 1, each fitted (Eq. 2) to the
//! same real acrylic stockinette measurements, evaluated far beyond the measured range.

use shell_fem::curves::uniaxial_curve;
use shell_fem::fit::{FitConfig, Weighting, fit, initial_guess, targets};
use shell_fem::material::{Material, Model};
use shell_fem::swatch::SwatchConfig;
use yarn_pattern::direction::Direction;

use crate::figures::shell_fit::acrylic_measurements;
use crate::plot::{LineChart, Series, save_side_by_side};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "shell-nh-vs-stvk",
        title: "Anisotropic StVK with and without the area terms",
        shows: "stretch stress σ_s = uᵀPu and orthogonal compression c under uniaxial stretch with zero orthogonal stress (Eq. 3), weft, for both models fitted to the same acrylic data",
        paper: "Fig. 5: same stress–stretch behaviour, StVK reaches 100 % compression (inversion), the augmented model does not",
        guarded: false,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let (nx, ny, iters, n) = if ctx.quick {
        (10, 6, 60, 41)
    } else {
        (20, 12, 200, 161)
    };
    let measurements = acrylic_measurements(24)?;
    let swatch = SwatchConfig {
        nx,
        ny,
        ..SwatchConfig::default()
    };
    let tg = targets(&measurements, 6);
    let progress = ctx.progress(3, "fits and curves");
    let mut fitted = Vec::new();
    for model in [Model::StVK, Model::Augmented] {
        let mut fixed = [false; shell_fem::InPlaneParams::LEN];
        fixed[3] = true; // no bias data
        if model == Model::StVK {
            fixed[4] = true; // kn1, kn2 unused by StVK
            fixed[5] = true;
        }
        let cfg = FitConfig {
            swatch: swatch.clone(),
            model,
            weighting: Weighting::Relative,
            fixed,
            max_iterations: iters,
            ..FitConfig::default()
        };
        let mut init = initial_guess(&measurements, swatch.width);
        if model == Model::StVK {
            init.kn1 = 0.0;
            init.kn2 = 0.0;
        }
        let r = fit(&tg, init, &cfg, None)?;
        fitted.push((model, r));
        progress.inc(1);
    }
    let s_max = 1.6; // the paper's rig limit (160 %) along the weft
    let stretches: Vec<f64> = (0..n).map(|i| s_max * i as f64 / (n - 1) as f64).collect();
    let mut data = Table::new(&[
        "s",
        "sigma_stvk_n_per_m",
        "c_stvk",
        "sigma_aug_n_per_m",
        "c_aug",
    ]);
    let dir = Direction::Weft;
    let curves: Vec<_> = fitted
        .iter()
        .map(|(model, r)| {
            uniaxial_curve(
                &Material {
                    params: r.params,
                    model: *model,
                },
                dir.angle(),
                &stretches,
            )
        })
        .collect::<Result<_, _>>()?;
    for i in 0..n {
        data.push_row([
            stretches[i],
            curves[0][i].sigma,
            curves[0][i].c,
            curves[1][i].sigma,
            curves[1][i].c,
        ]);
    }
    progress.inc(1);
    let col = |k: usize, f: &dyn Fn(&shell_fem::curves::UniaxialPoint) -> f64| {
        curves[k].iter().map(|p| (p.s, f(p))).collect::<Vec<_>>()
    };
    let stress = LineChart::new("Stretch stress (weft, Eq. 3)")
        .x_label("stretch s")
        .y_label("σ_s (N/m)")
        .series(Series::line("anisotropic StVK", col(0, &|p| p.sigma)))
        .series(Series::dashed(
            "StVK + area terms (Eq. 1)",
            col(1, &|p| p.sigma),
        ));
    let comp = LineChart::new("Orthogonal compression (weft)")
        .x_label("stretch s")
        .y_label("compression c")
        .hline("inversion (c = 1)", 1.0)
        .series(Series::line("anisotropic StVK", col(0, &|p| p.c)))
        .series(Series::dashed(
            "StVK + area terms (Eq. 1)",
            col(1, &|p| p.c),
        ));
    save_side_by_side(&stress, &comp, &ctx.out_dir, ctx.name)?;
    let max_c = |k: usize| {
        curves[k]
            .iter()
            .map(|p| p.c)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let inverted_at = curves[0].iter().find(|p| p.c >= 1.0 - 1e-9).map(|p| p.s);
    let sigma_diff = (0..n)
        .filter(|&i| stretches[i] <= measurements[0].s_max())
        .map(|i| {
            (curves[0][i].sigma - curves[1][i].sigma).abs() / curves[1][i].sigma.abs().max(1e-12)
        })
        .fold(0.0, f64::max);
    progress.inc(1);
    Ok(FigureOutput {
        summary: vec![
            ("max compression, StVK".into(), format!("{:.3}", max_c(0))),
            (
                "max compression, StVK + area terms".into(),
                format!("{:.3}", max_c(1)),
            ),
            (
                "StVK inverts at s".into(),
                inverted_at.map_or("no inversion up to 1.6".into(), |s| format!("{s:.3}")),
            ),
            (
                "max σ_s difference within measured range".into(),
                crate::percent(sigma_diff),
            ),
            (
                "fit errors force/compression StVK (paper metric; per point)".into(),
                format!(
                    "{} / {}; {} / {}",
                    crate::percent(fitted[0].1.errors.force_error),
                    crate::percent(fitted[0].1.errors.compression_error),
                    crate::percent(fitted[0].1.errors.force_rel_error),
                    crate::percent(fitted[0].1.errors.compression_rel_error)
                ),
            ),
            (
                "fit errors force/compression augmented (paper metric; per point)".into(),
                format!(
                    "{} / {}; {} / {}",
                    crate::percent(fitted[1].1.errors.force_error),
                    crate::percent(fitted[1].1.errors.compression_error),
                    crate::percent(fitted[1].1.errors.force_rel_error),
                    crate::percent(fitted[1].1.errors.compression_rel_error)
                ),
            ),
        ],
        config: serde_json::json!({
            "swatch": {"nx": nx, "ny": ny}, "weighting": "relative", "direction": "weft",
            "stvk_params": fitted[0].1.params, "augmented_params": fitted[1].1.params,
        }),
        data,
    })
}
