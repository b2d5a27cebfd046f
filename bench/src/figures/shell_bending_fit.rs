//! `shell-bending-fit` (seed 002, Fig. 8): the bending fit of `{k_θ,weft, k_θ,bias, k_θ,warp}`
//! to pear-loop aspect ratios, as a parameter-recovery case: virtual targets (7 per direction,
//! clamp distance 3.4 cm → 0.3 cm) from known stiffnesses, fitted from a uniform initial guess
//! by bounded Levenberg–Marquardt with implicit-differentiation sensitivities.
//!
//! Guarded: deterministic and cheap in quick mode (coarse strip, 24 × 1 cells, about 10 s);
//! the reference curve pins the pear-loop model and the fit's recovery.

use shell_fem::bending_fit::{
    BendingFitConfig, BendingSimulator, BendingTarget, fit_bending, target_distances,
    virtual_targets,
};
use shell_fem::elements::BendingParams;
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::pear_loop::PearLoopConfig;
use yarn_pattern::direction::Direction;

use crate::plot::{LineChart, Series};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// The stiffnesses the virtual data are generated from (N·m).
const TRUTH: BendingParams = BendingParams {
    weft: 3e-6,
    bias: 1.5e-6,
    warp: 6e-6,
};

/// The fit's initial guess (N·m).
const INITIAL: BendingParams = BendingParams {
    weft: 1e-6,
    bias: 1e-6,
    warp: 1e-6,
};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "shell-bending-fit",
        title: "Bending fit to pear-loop targets (parameter recovery)",
        shows: "pear-loop aspect ratio r = h/p vs inter-clamp distance d per strip direction: virtual targets from known k_θ (markers) and the curve of the fitted k_θ (lines)",
        paper: "Fig. 8: fitted thin-shell bending model vs pear-loop data (real L1 fabric there, virtual data here; paper avg. error 5.61 %)",
        guarded: true,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let (nx, ny, n_curve) = if ctx.quick { (24, 1, 11) } else { (40, 4, 32) };
    let pear = PearLoopConfig {
        nx,
        ny,
        max_step: 0.006,
        ..PearLoopConfig::default()
    };
    let material = Material::augmented(InPlaneParams::example());
    let progress = ctx.progress(3, "targets, fit, curves");
    let targets = virtual_targets(
        &pear,
        material,
        &TRUTH,
        &Direction::ALL,
        &target_distances(7),
    )?;
    progress.inc(1);
    let cfg = BendingFitConfig {
        pear: pear.clone(),
        material,
        ..BendingFitConfig::default()
    };
    let fit = fit_bending(&targets, INITIAL, &cfg, None)?;
    progress.inc(1);
    let ds = target_distances(n_curve);
    let dense: Vec<BendingTarget> = Direction::ALL
        .iter()
        .flat_map(|&direction| {
            ds.iter().map(move |&d| BendingTarget {
                direction,
                d,
                ratio: 1.0,
            })
        })
        .collect();
    let curve = BendingSimulator::new(&pear, material, &dense).simulate(&fit.params, &dense)?;
    progress.inc(1);

    let mut data = Table::new(&["direction_deg", "kind_0target_1fit", "d_m", "ratio"]);
    for t in &targets {
        data.push_row([t.direction.angle().to_degrees(), 0.0, t.d, t.ratio]);
    }
    for (t, r) in dense.iter().zip(&curve) {
        data.push_row([t.direction.angle().to_degrees(), 1.0, t.d, *r]);
    }
    let mut chart = LineChart::new("Pear loop: aspect ratio vs clamp distance")
        .x_label("inter-clamp distance d (cm)")
        .y_label("aspect ratio r = h/p");
    for dir in Direction::ALL {
        chart = chart
            .series(Series::markers(
                format!("{} targets (true k_θ)", dir.name()),
                targets
                    .iter()
                    .filter(|t| t.direction == dir)
                    .map(|t| (100.0 * t.d, t.ratio)),
            ))
            .series(Series::line(
                format!("{} fitted", dir.name()),
                dense
                    .iter()
                    .zip(&curve)
                    .filter(|(t, _)| t.direction == dir)
                    .map(|(t, r)| (100.0 * t.d, *r)),
            ));
    }
    chart.save(&ctx.out_dir, ctx.name)?;

    let truth = TRUTH.to_array();
    let got = fit.params.to_array();
    let param_err = (0..3)
        .map(|j| (got[j] - truth[j]).abs() / truth[j])
        .fold(0.0, f64::max);
    Ok(FigureOutput {
        summary: vec![
            (
                "fitted k_θ weft / bias / warp (N·m)".into(),
                format!("{:.4e} / {:.4e} / {:.4e}", got[0], got[1], got[2]),
            ),
            (
                "true k_θ weft / bias / warp (N·m)".into(),
                format!("{:.4e} / {:.4e} / {:.4e}", truth[0], truth[1], truth[2]),
            ),
            (
                "max relative parameter error".into(),
                crate::percent(param_err),
            ),
            (
                "mean relative ratio error at targets".into(),
                crate::percent(fit.ratio_rel_error),
            ),
            (
                "LM iterations / fit time".into(),
                format!("{} / {:.2} s", fit.iterations, fit.seconds),
            ),
        ],
        config: serde_json::json!({
            "pear_loop": {"nx": nx, "ny": ny, "length_m": pear.length, "width_m": pear.width,
                          "areal_density_kg_m2": pear.areal_density, "max_step_m": pear.max_step},
            "truth": TRUTH, "initial": INITIAL, "fitted": fit.params,
            "termination": fit.termination, "cost_history": fit.cost_history,
        }),
        data,
    })
}
