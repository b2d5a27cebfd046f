//! The periodic tile problem on the real stockinette tile: derivatives of the assembled energy,
//! invariance under re-expressing a vertex by its periodic copy, and the homogenized stress
//! from gathered forces against the derivative of the equilibrium energy density.

use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::periodic::{EquilibriumSettings, PeriodicTile, YarnModel, solve_equilibrium};
use sim_periodic::tile::Tile;
use solver::Assembler;

mod common;
use common::stockinette;

#[test]
fn assembled_tile_energy_has_consistent_gradient_and_hessian() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let coarse = Coarse::from_strain(&Strain {
        sx: 0.2,
        sa: 0.1,
        sy: -0.05,
    });
    common::assert_assembled_derivatives(&tile, model, coarse, 13);
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

/// The tile repeated `k × k` times as one larger periodic tile (copy `(i, j)` of vertex `v` is
/// vertex `v + n (i + k j)`); edge data travel with their copies.
fn repeated(tile: &Tile, k: i32) -> Tile {
    let n = tile.n_vertices();
    let copy = |v: usize, i: i32, j: i32| v + n * (i + k * j) as usize;
    let mut big = tile.clone();
    big.period = [k as f64 * tile.period[0], k as f64 * tile.period[1]];
    let (mut positions, mut edges) = (vec![], vec![]);
    for j in 0..k {
        for i in 0..k {
            for v in 0..n {
                positions.push(tile.positions[v] + tile.period_offset([i, j]));
            }
            for e in &tile.edges {
                let (ti, tj) = (i + e.shift[0], j + e.shift[1]);
                edges.push(sim_periodic::tile::Edge {
                    v0: copy(e.v0, i, j),
                    v1: copy(e.v1, ti.rem_euclid(k), tj.rem_euclid(k)),
                    shift: [ti.div_euclid(k), tj.div_euclid(k)],
                });
            }
        }
    }
    let times = |v: &Vec<f64>| v.repeat((k * k) as usize);
    big.positions = positions;
    big.edges = edges;
    big.twists = times(&tile.twists);
    big.rest_lengths = times(&tile.rest_lengths);
    big.rest_twists = times(&tile.rest_twists);
    big.reference_twists = times(&tile.reference_twists);
    big.rest_curvatures = tile.rest_curvatures.repeat((k * k) as usize);
    big.reference_directors = tile.reference_directors.repeat((k * k) as usize);
    big.validate().unwrap();
    big
}

#[test]
fn a_3x3_copy_has_the_same_energy_density_and_is_in_equilibrium() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let coarse = Coarse::from_strain(&Strain {
        sx: 0.1,
        sa: 0.05,
        sy: 0.0,
    });
    let eq =
        solve_equilibrium(&tile, &model, coarse, None, &EquilibriumSettings::default()).unwrap();
    let big = repeated(&tile, 3);
    let n = tile.n_vertices();
    // Replicate the fluctuations and twists; positions F X + ũ are then the periodic copies.
    let mut x = vec![0.0; 4 * 9 * n];
    for c in 0..9 {
        x[3 * n * c..3 * n * (c + 1)].copy_from_slice(&eq.dofs[..3 * n]);
        x[27 * n + n * c..27 * n + n * (c + 1)].copy_from_slice(&eq.dofs[3 * n..]);
    }
    let pairs = PeriodicTile::find_pairs(&big, &model, &coarse, &x, 1.5).unwrap();
    let problem = PeriodicTile::new(&big, model, coarse, pairs).unwrap();
    let mut asm = Assembler::new(&problem).unwrap();
    let (energy, gradient) = asm.gradient(&problem, &x).unwrap();
    let density = energy / problem.area();
    println!("Ψ tile {:.12e}, Ψ 3×3 {:.12e}", eq.density, density);
    assert!((density - eq.density).abs() <= 1e-10 * eq.density);
    // The small tile's equilibrium is one of the big tile: the unconstrained residual of the
    // 3×3 copy is the small tile's, i.e. only the replicated no-sliding constraint forces
    // (non-zero: for a discrete yarn with non-uniform rest lengths sliding is not an exact
    // symmetry; about 0.1 N here).
    let small = PeriodicTile::new(&tile, model, coarse, eq.pairs.clone()).unwrap();
    let g_small = Assembler::new(&small)
        .unwrap()
        .gradient(&small, &eq.dofs)
        .unwrap()
        .1
        .to_vec();
    let (rs, rb) = (
        g_small.iter().fold(0.0f64, |m, g| m.max(g.abs())),
        gradient.iter().fold(0.0f64, |m, g| m.max(g.abs())),
    );
    println!("max |∂E/∂q|: tile {rs:.3e}, 3×3 {rb:.3e}");
    assert!(rb <= 1.0001 * rs + 1e-12);
}
