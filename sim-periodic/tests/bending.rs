//! Bent coarse deformations (single curvature, seed 004 Appendix A): derivatives of the
//! assembled energy, the gathered in-plane stress on a bent tile, and the bending stress.

use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::curves::bending_curve;
use sim_periodic::database::relax_reference;
use sim_periodic::periodic::{
    EquilibriumSettings, PeriodicTile, YarnModel, initial_dofs, solve_equilibrium,
};
use sim_periodic::tile::Tile;
use solver::Assembler;

fn relaxed() -> (Tile, YarnModel) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    let tile = sim_periodic::pyp::read_pyp(path)
        .expect("the real tile loads")
        .tile;
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
        let mut x = initial_dofs(&tile).unwrap();
        let n = tile.n_vertices();
        for (i, xi) in x.iter_mut().enumerate() {
            let scale = if i < 3 * n { 0.05 * tile.radius } else { 0.05 };
            *xi += scale * ((i as f64) * 0.7).sin();
        }
        let pairs = PeriodicTile::find_pairs(&tile, &model, &coarse, &x, 1.5).unwrap();
        let problem = PeriodicTile::new(&tile, model, coarse, pairs).unwrap();
        let mut asm = Assembler::new(&problem).unwrap();
        let a = asm.assemble(&problem, &x, false).unwrap();
        let gradient = a.gradient.to_vec();
        let lower = a.hessian.to_dense();
        let hessian = |i: usize, j: usize| if i >= j { lower[(i, j)] } else { lower[(j, i)] };
        let step = |i: usize| if i < 3 * n { 1e-6 * tile.radius } else { 1e-6 };
        let gmax = gradient.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        let mut y = x.clone();
        for i in 0..x.len() {
            let h = step(i);
            y[i] = x[i] + h;
            let ep = asm.energy(&problem, &y).unwrap();
            y[i] = x[i] - h;
            let em = asm.energy(&problem, &y).unwrap();
            y[i] = x[i];
            let fd = (ep - em) / (2.0 * h);
            assert!(
                (fd - gradient[i]).abs() <= 1e-5 * gmax,
                "axis {axis} gradient {i}: {} vs {fd}",
                gradient[i]
            );
        }
        let hmax = (0..x.len())
            .map(|i| hessian(i, i).abs())
            .fold(0.0, f64::max);
        for j in (0..x.len()).step_by(17) {
            let h = step(j);
            y[j] = x[j] + h;
            let gp = asm.gradient(&problem, &y).unwrap().1.to_vec();
            y[j] = x[j] - h;
            let gm = asm.gradient(&problem, &y).unwrap().1.to_vec();
            y[j] = x[j];
            for i in 0..x.len() {
                let fd = (gp[i] - gm[i]) / (2.0 * h);
                assert!(
                    (fd - hessian(i, j)).abs() <= 1e-5 * hmax,
                    "axis {axis} H[{i},{j}]: {} vs {fd}",
                    hessian(i, j)
                );
            }
        }
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
