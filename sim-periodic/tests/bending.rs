//! Bent coarse deformations (single curvature, seed 004 Appendix A): derivatives of the
//! assembled energy, the gathered in-plane stress on a bent tile, and the bending stress.

use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::curves::bending_curve;
use sim_periodic::database::relax_reference;
use sim_periodic::periodic::{EquilibriumSettings, YarnModel, solve_equilibrium};
use yarn_pattern::tile::Tile;

mod common;

fn relaxed() -> (Tile, YarnModel) {
    let tile = common::stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let (tile, _) = relax_reference(&tile, &model, &EquilibriumSettings::default()).unwrap();
    (tile, model)
}

#[test]
fn bent_tile_energy_has_consistent_gradient_and_hessian() {
    let (tile, model) = relaxed();
    for axis in [0, 1] {
        let coarse = Coarse::from_strain(&Strain {
            sx: 0.1,
            sa: 0.05,
            sy: 0.0,
        })
        .bent(axis, 80.0);
        common::assert_assembled_derivatives(&tile, model, coarse, 17);
    }
}

#[test]
fn gathered_stress_of_a_bent_tile_is_dpsi_dsx_and_bending_stress_is_consistent() {
    let (tile, model) = relaxed();
    let settings = EquilibriumSettings::default();
    let kappa = 60.0;
    let at = |sx: f64, start: Option<&[f64]>| {
        let coarse = Coarse::from_strain(&Strain {
            sx,
            sa: 0.0,
            sy: 0.0,
        })
        .bent(0, kappa);
        solve_equilibrium(&tile, &model, coarse, start, &settings).unwrap()
    };
    let centre = at(0.1, None);
    let h = 1e-4;
    let plus = at(0.1 + h, Some(&centre.dofs));
    let minus = at(0.1 - h, Some(&centre.dofs));
    // F₂ = diag(1 + sx, 1) at sa = sy = 0, so dΨ/dsx = P₁₁.
    let fd = (plus.density - minus.density) / (2.0 * h);
    let rel = (fd - centre.stress[(0, 0)]).abs() / fd.abs();
    eprintln!(
        "bent tile: P11 = {} vs dΨ/dsx = {fd} ({rel:.1e})",
        centre.stress[(0, 0)]
    );
    assert!(rel < 1e-5, "{rel}");

    // Bending curve: Ψ is smooth in κ, and the differenced moment integrates back to Ψ.
    let kappas = [0.0, 20.0, 40.0];
    let curve = bending_curve(&tile, &model, 0, &kappas, 1.0, &settings).unwrap();
    for p in &curve {
        eprintln!(
            "κ {} 1/m: Ψ {} J/m², σ_κ {} N",
            p.kappa, p.density, p.moment
        );
        assert!(p.density.is_finite() && p.moment.is_finite());
    }
    // Trapezoid rule of σ_κ over [0, 40] against ΔΨ (second-order accurate).
    let integral = 0.5 * 20.0 * (curve[0].moment + 2.0 * curve[1].moment + curve[2].moment);
    let delta = curve[2].density - curve[0].density;
    eprintln!("∫σ_κ dκ = {integral}, ΔΨ = {delta}");
    assert!(
        (integral - delta).abs() < 0.05 * delta.abs().max(1e-12),
        "{integral} vs {delta}"
    );
}
