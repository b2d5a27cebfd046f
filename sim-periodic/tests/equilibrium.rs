//! The periodic tile problem on the real stockinette tile: derivatives of the assembled energy,
//! invariance under re-expressing a vertex by its periodic copy, and the homogenized stress
//! from gathered forces against the derivative of the equilibrium energy density.

use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::periodic::{
    EquilibriumSettings, PeriodicTile, YarnModel, initial_dofs, solve_equilibrium,
};
use sim_periodic::tile::Tile;
use solver::Assembler;

fn stockinette() -> Tile {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    sim_periodic::pyp::read_pyp(path)
        .expect("the real tile loads")
        .tile
}

/// A deterministic, smooth perturbation of the DOFs (fluctuations ~0.05 R, twists ~0.05 rad).
fn perturbed(tile: &Tile) -> Vec<f64> {
    let mut x = initial_dofs(tile).unwrap();
    let n = tile.n_vertices();
    for (i, xi) in x.iter_mut().enumerate() {
        let scale = if i < 3 * n { 0.05 * tile.radius } else { 0.05 };
        *xi += scale * ((i as f64) * 0.7).sin();
    }
    x
}

#[test]
fn assembled_tile_energy_has_consistent_gradient_and_hessian() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let coarse = Coarse::from_strain(&Strain {
        sx: 0.2,
        sa: 0.1,
        sy: -0.05,
    });
    let x = perturbed(&tile);
    let pairs = PeriodicTile::find_pairs(&tile, &model, &coarse, &x, 1.5).unwrap();
    assert!(pairs.len() > 100, "contacts expected in a knit tile");
    let problem = PeriodicTile::new(&tile, model, coarse, pairs).unwrap();
    let mut asm = Assembler::new(&problem).unwrap();
    let energy_at = |y: &[f64], asm: &mut Assembler| asm.energy(&problem, y).unwrap();
    let a = asm.assemble(&problem, &x, false).unwrap();
    assert!(a.energy.is_finite());
    let gradient = a.gradient.to_vec();
    // The assembler stores the lower triangle of the symmetric Hessian.
    let lower = a.hessian.to_dense();
    let hessian = |i: usize, j: usize| if i >= j { lower[(i, j)] } else { lower[(j, i)] };
    // Gradient: all DOFs. Positions are in m (~1e-3), twists in rad: step per kind.
    let n = tile.n_vertices();
    let step = |i: usize| if i < 3 * n { 1e-6 * tile.radius } else { 1e-6 };
    let gmax = gradient.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    let mut y = x.clone();
    for i in 0..x.len() {
        let h = step(i);
        y[i] = x[i] + h;
        let ep = energy_at(&y, &mut asm);
        y[i] = x[i] - h;
        let em = energy_at(&y, &mut asm);
        y[i] = x[i];
        let fd = (ep - em) / (2.0 * h);
        assert!(
            (fd - gradient[i]).abs() <= 1e-5 * gmax,
            "gradient {i}: {} vs fd {fd}",
            gradient[i]
        );
    }
    // Hessian: a spread of columns (positions and twists), against differences of the gradient.
    let hmax = (0..x.len())
        .map(|i| hessian(i, i).abs())
        .fold(0.0, f64::max);
    for j in (0..x.len()).step_by(13) {
        let h = step(j);
        y[j] = x[j] + h;
        let gp = asm.gradient(&problem, &y).unwrap().1.to_vec();
        y[j] = x[j] - h;
        let gm = asm.gradient(&problem, &y).unwrap().1.to_vec();
        y[j] = x[j];
        for i in 0..x.len() {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            let scale = if (i < 3 * n) == (j < 3 * n) {
                hmax
            } else {
                hmax * tile.radius
            };
            assert!(
                (fd - hessian(i, j)).abs() <= 1e-5 * scale,
                "Hessian ({i}, {j}): {} vs fd {fd}",
                hessian(i, j)
            );
        }
    }
}

/// Moving vertex `v`'s rest position by one period and fixing the shifts of its two edges
/// describes the same fabric: energy and equilibrium density must not change.
#[test]
fn re_expressing_a_vertex_by_its_periodic_copy_changes_nothing() {
    let tile = stockinette();
    let mut moved = tile.clone();
    let v = 7;
    moved.positions[v].x += tile.period[0];
    for edge in &mut moved.edges {
        if edge.v0 == v {
            edge.shift[0] += 1;
        }
        if edge.v1 == v {
            edge.shift[0] -= 1;
        }
    }
    moved.validate().unwrap();
    let model = YarnModel::default_for_radius(tile.radius);
    let coarse = Coarse::from_strain(&Strain {
        sx: 0.15,
        sa: 0.0,
        sy: 0.05,
    });
    let settings = EquilibriumSettings::default();
    let a = solve_equilibrium(&tile, &model, coarse, None, &settings).unwrap();
    let b = solve_equilibrium(&moved, &model, coarse, None, &settings).unwrap();
    assert_eq!(a.pairs.len(), b.pairs.len());
    assert!(
        (a.density - b.density).abs() <= 1e-9 * a.density,
        "{} vs {}",
        a.density,
        b.density
    );
    assert!((a.stress - b.stress).norm() <= 1e-6 * a.stress.norm());
}

/// Seed 002 Eq. 10: the stress gathered from the stencil forces equals the derivative of the
/// equilibrium energy density (central differences of re-solved equilibria).
#[test]
fn gathered_stress_matches_the_derivative_of_the_energy_density() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let settings = EquilibriumSettings::default();
    let strain = |sx: f64| {
        Coarse::from_strain(&Strain {
            sx,
            sa: 0.0,
            sy: 0.0,
        })
    };
    let base = solve_equilibrium(&tile, &model, strain(0.1), None, &settings).unwrap();
    let h = 1e-4;
    let plus =
        solve_equilibrium(&tile, &model, strain(0.1 + h), Some(&base.dofs), &settings).unwrap();
    let minus =
        solve_equilibrium(&tile, &model, strain(0.1 - h), Some(&base.dofs), &settings).unwrap();
    let fd = (plus.density - minus.density) / (2.0 * h);
    // dΨ/dsx = P : dF/dsx with F = √I (dF/dsx by central differences of the closed form).
    let df = (strain(0.1 + 1e-6).f - strain(0.1 - 1e-6).f) / 2e-6;
    let gathered = base.stress.component_mul(&df).sum();
    println!("dΨ/dsx: gathered {gathered:.9e}, finite difference {fd:.9e}");
    assert!(
        (gathered - fd).abs() <= 1e-6 * fd.abs(),
        "gathered {gathered} vs fd {fd}"
    );
}
