//! `periodic-bending`: energy density and bending stress dΨ/dκ of the real stockinette tile
//! rolled onto a cylinder along the weft and along the warp (single curvature, seed 004
//! Appendix A), in both senses.

use sim_periodic::curves::bending_curve;
use sim_periodic::periodic::YarnModel;

use crate::plot::{LineChart, Series, save_side_by_side};
use crate::studies::periodic::{real_stockinette, stress_free};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "periodic-bending",
        title: "Bending of a periodic stockinette tile",
        shows: "energy density Ψ and bending stress σ_κ = dΨ/dκ (central differences of re-solved equilibria) against curvature κ for weft and warp bending of the real stockinette tile (stress-free period)",
        paper: "seed 002 §7.1 bending targets / seed 004 Appendix A; a non-zero σ_κ at κ = 0 is the knit's tendency to curl",
        guarded: false,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let kappas: Vec<f64> = if ctx.quick {
        vec![-60.0, -30.0, 0.0, 30.0, 60.0]
    } else {
        (-8..=8).map(|i| 15.0 * i as f64).collect()
    };
    let progress = ctx.progress(3, "relax, weft and warp bending");
    let tile = real_stockinette()?;
    let model = YarnModel::default_for_radius(tile.radius);
    let settings = sim_periodic::periodic::EquilibriumSettings::default();
    let tile = stress_free(&tile, &model, &settings)?;
    progress.inc(1);
    let mut data = Table::new(&["axis", "kappa_per_m", "psi_j_per_m2", "sigma_kappa_n"]);
    let mut energy = LineChart::new("Energy density")
        .x_label("curvature κ (1/m)")
        .y_label("Ψ (J/m²)");
    let mut stress = LineChart::new("Bending stress")
        .x_label("curvature κ (1/m)")
        .y_label("σ_κ = dΨ/dκ (N)");
    let mut summary = Vec::new();
    for (axis, name) in [(0, "weft"), (1, "warp")] {
        // Solve outward from zero in both senses for warm starts.
        let mut up: Vec<f64> = kappas.iter().copied().filter(|k| *k >= 0.0).collect();
        up.sort_by(f64::total_cmp);
        let mut down: Vec<f64> = kappas.iter().copied().filter(|k| *k < 0.0).collect();
        down.sort_by(|a, b| b.total_cmp(a));
        let mut points = bending_curve(&tile, &model, axis, &up, 1.0, &settings)?;
        points.extend(bending_curve(&tile, &model, axis, &down, 1.0, &settings)?);
        points.sort_by(|a, b| a.kappa.total_cmp(&b.kappa));
        for p in &points {
            data.push_row([axis as f64, p.kappa, p.density, p.moment]);
        }
        energy = energy.series(Series::line_markers(
            format!("{name} bending"),
            points.iter().map(|p| (p.kappa, p.density)),
        ));
        stress = stress.series(Series::line_markers(
            format!("{name} bending"),
            points.iter().map(|p| (p.kappa, p.moment)),
        ));
        let zero = points
            .iter()
            .find(|p| p.kappa == 0.0)
            .map_or(f64::NAN, |p| p.moment);
        summary.push((format!("{name}: σ_κ at κ = 0"), format!("{zero:.4} N")));
        progress.inc(1);
    }
    save_side_by_side(&energy, &stress, &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({"kappas_per_m": kappas, "difference_step_per_m": 1.0,
            "tile": "tests/data/patterns/stockinette.pyp (period relaxed)"}),
        data,
    })
}
