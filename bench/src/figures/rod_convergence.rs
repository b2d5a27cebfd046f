//! `rod-convergence`: relative error of discrete rod energies and of the cantilever tip
//! deflection against the segment count, log–log, with measured orders.

use crate::plot::{LineChart, Series};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};
use rod::validation::{BendingModel, Helix, measured_order, relative_bending_error};
use solver::validation::cantilever::{Beam, elastica_tip, sweep};
use std::f64::consts::TAU;

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "rod-convergence",
        title: "Convergence of discrete rod bending",
        shows: "relative error vs segment count (log–log) of the bending energy of a circle and a helix (curvature-binormal and angle models) and of the cantilever tip deflection (α = 1, vs the elastica)",
        paper: "discretization check (no paper figure): all curves converge at second order, as expected of Bergou-style discrete curvature",
        guarded: true,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let ns: Vec<usize> = if ctx.quick {
        vec![8, 16, 32, 64]
    } else {
        vec![8, 16, 32, 64, 128, 256, 512]
    };
    let circle = Helix::REFERENCE_CIRCLE;
    let helix = Helix::REFERENCE_HELIX;
    // Stiff in stretch (axial strain ≈ 6e-8 at α = 1), to compare with the inextensible
    // elastica; loads ramp up in steps of 0.1 (load continuation).
    let beam = Beam {
        axial_stiffness: 4e4,
        ..Beam::default()
    };
    let ramp: Vec<f64> = (1..=10).map(|i| 0.1 * i as f64).collect();
    let (elastica, _) = elastica_tip(1.0)?;
    let progress = ctx.progress(ns.len() as u64, "refining");
    let mut data = Table::new(&[
        "segments",
        "circle_binormal",
        "circle_angle",
        "helix_binormal",
        "helix_angle",
        "cantilever_tip",
    ]);
    for &n in &ns {
        let err =
            |model, h: &Helix, span, closed| relative_bending_error(model, h, span, n, closed);
        let tip = sweep(&beam, n, &ramp)?
            .last()
            .expect("ten loads")
            .deflection;
        data.push_row([
            n as f64,
            err(BendingModel::Binormal, &circle, TAU, true),
            err(BendingModel::Angle, &circle, TAU, true),
            err(BendingModel::Binormal, &helix, 3.0 * TAU, false),
            err(BendingModel::Angle, &helix, 3.0 * TAU, false),
            ((tip - elastica) / elastica).abs(),
        ]);
        progress.inc(1);
    }
    let mut chart = LineChart::new("Discrete rod convergence")
        .x_label("segments")
        .y_label("relative error")
        .log_x()
        .log_y();
    let mut summary = Vec::new();
    let x: Vec<f64> = ns.iter().map(|&n| n as f64).collect();
    for (column, label) in [
        ("circle_binormal", "circle, curvature binormal"),
        ("circle_angle", "circle, angle (seed 000 Eq. 1)"),
        ("helix_binormal", "helix, curvature binormal"),
        ("helix_angle", "helix, angle (seed 000 Eq. 1)"),
        ("cantilever_tip", "cantilever tip, α = 1"),
    ] {
        let e = data.column(column).expect("column exists");
        // Asymptotic order from the last three refinements.
        let k = ns.len() - 3;
        let order = measured_order(&ns[k..], &e[k..]);
        summary.push((format!("order: {label}"), format!("{order:.2}")));
        chart = chart.series(Series::line_markers(
            format!("{label} (order {order:.2})"),
            x.iter().copied().zip(e.iter().copied()),
        ));
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({ "segments": ns, "circle_radius_m": 0.01, "helix_rise_m_per_rad": 0.004, "cantilever_alpha": 1.0 }),
        data,
    })
}
