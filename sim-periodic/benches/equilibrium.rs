//! Equilibrium solves per pattern and a small database, in wall time.
//!
//! `cargo bench -p sim-periodic`. Each tile is first relaxed (not timed); one iteration solves
//! it at a 20 % weft stretch from its relaxed state. The broad-phase bench finds the contact
//! pairs of the relaxed procedural seed at that stretch (16 and 24 vertices per loop). The
//! database bench generates a 3³ grid around zero strain for the real stockinette tile. The
//! curve bench computes the real stockinette's weft curve at s = 0, 0.1, …, 0.4 with secant
//! steps and with Newton steps on the exact slope (`CurveSettings::exact_slope`), and prints
//! the solves each took.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{Criterion, criterion_group, criterion_main};
use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::curves::{CurveSettings, uniaxial_curve};
use sim_periodic::database::{DatabaseSettings, generate, relax_reference, uniform_axis};
use sim_periodic::patterns::{Pattern, RelaxSettings, relax};
use sim_periodic::periodic::{EquilibriumSettings, PeriodicTile, YarnModel, solve_equilibrium};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

fn stockinette() -> Tile {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    yarn_pattern::pyp::read_pyp(path)
        .expect("the real tile loads")
        .tile
}

fn bench(c: &mut Criterion) {
    let settings = EquilibriumSettings::default();
    let mut tiles = vec![("stockinette-real".to_string(), stockinette())];
    for p in Pattern::ALL {
        let guess = p
            .generate(&p.default_params(1e-3))
            .expect("pattern generates");
        let model = YarnModel::default_for_radius(1e-3);
        let (tile, _) = relax(&guess, &model, &RelaxSettings::default()).expect("pattern relaxes");
        tiles.push((p.name().to_string(), tile));
    }
    let mut group = c.benchmark_group("equilibrium, sx = 0.2");
    group.sample_size(10);
    for (name, tile) in &tiles {
        let model = YarnModel::default_for_radius(tile.radius);
        let (tile, _) = relax_reference(tile, &model, &settings).expect("relaxes");
        let coarse = Coarse::from_strain(&Strain {
            sx: 0.2,
            sa: 0.0,
            sy: 0.0,
        });
        let id = format!("{name} ({} vertices)", tile.n_vertices());
        group.bench_function(id, |b| {
            b.iter(|| solve_equilibrium(&tile, &model, coarse, None, &settings).expect("converges"))
        });
    }
    group.finish();

    // The contact broad phase at a solved state (every equilibrium solve runs it at least
    // twice per pair round): the relaxed procedural seed at the yarn fit's 16 vertices per
    // loop and at the default 24.
    let mut group = c.benchmark_group("broad phase, sx = 0.2");
    for resolution in [16, 24] {
        let mut params = Pattern::Seed.default_params(1e-3);
        params.resolution = resolution;
        let model = YarnModel::default_for_radius(1e-3);
        let guess = Pattern::Seed.generate(&params).expect("pattern generates");
        let (tile, _) = relax(&guess, &model, &RelaxSettings::default()).expect("relaxes");
        let coarse = Coarse::from_strain(&Strain {
            sx: 0.2,
            sa: 0.0,
            sy: 0.0,
        });
        let eq = solve_equilibrium(&tile, &model, coarse, None, &settings).expect("converges");
        let id = format!("seed ({} vertices)", tile.n_vertices());
        group.bench_function(id, |b| {
            b.iter(|| {
                PeriodicTile::find_pairs(&tile, &model, &coarse, &eq.dofs, 1.5).expect("pairs")
            })
        });
    }
    group.finish();

    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let (tile, _) = relax_reference(&tile, &model, &settings).expect("relaxes");
    let axes = [
        uniform_axis(-0.1, 0.1, 3),
        uniform_axis(-0.1, 0.1, 3),
        uniform_axis(-0.1, 0.1, 3),
    ];
    let mut group = c.benchmark_group("database");
    group.sample_size(10);
    group.bench_function("stockinette-real 3x3x3 in [-0.1, 0.1]", |b| {
        b.iter(|| {
            generate(
                &tile,
                &model,
                axes.clone(),
                &DatabaseSettings::default(),
                None,
                &|_| {},
            )
            .expect("generates")
        })
    });
    group.finish();

    // Uniaxial weft curve of the same relaxed tile: secant against exact-slope Newton steps.
    let stretches = uniform_axis(0.0, 0.4, 5);
    let mut group = c.benchmark_group("weft curve, s = 0 … 0.4 (5 points)");
    group.sample_size(10);
    for exact_slope in [false, true] {
        let curve = CurveSettings {
            exact_slope,
            ..CurveSettings::default()
        };
        let run =
            || uniaxial_curve(&tile, &model, Direction::Weft, &stretches, &curve).expect("curve");
        let solves: usize = run().iter().map(|p| p.solves).sum();
        let name = if exact_slope { "exact slope" } else { "secant" };
        println!("weft curve, {name}: {solves} solves");
        group.bench_function(format!("stockinette-real, {name}"), |b| b.iter(run));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
