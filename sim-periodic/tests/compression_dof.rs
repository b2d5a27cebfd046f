//! A uniaxial curve point solved with the compression as a DOF
//! (`sim_periodic::periodic::solve_compressed`): exact derivatives, its gradient is the
//! orthogonal stress, and it reaches the root-find's compressions in fewer Newton iterations.

use sim_periodic::coarse::Coarse;
use sim_periodic::curves::{CurveSettings, directional_stress, uniaxial_curve};
use sim_periodic::database::relax_period;
use sim_periodic::periodic::{
    CompressedTile, EquilibriumSettings, PeriodicTile, YarnModel, solve_compressed,
};
use solver::Assembler;
use yarn_pattern::direction::Direction;

mod common;
use common::{assert_problem_derivatives, perturbed, stockinette};

/// Exact gradient and Hessian of the energy in the fluctuations, the twists and `ℓ c`, along
/// weft, bias and warp, against central differences; and `∂E/∂(ℓc) = −ℓ σ_c`, the gathered
/// orthogonal stress (seed 002 Eq. 10) of the tile under the map at that compression.
#[test]
fn compressed_tile_derivatives_are_exact_and_its_gradient_is_the_orthogonal_stress() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let n = tile.n_vertices();
    for direction in [Direction::Weft, Direction::Bias, Direction::Warp] {
        let (s, c0, c) = (0.12, 0.03, 0.05);
        let angle = direction.angle();
        let u = perturbed(&tile);
        let coarse = Coarse::uniaxial(s, c, angle);
        let pairs = PeriodicTile::find_pairs(&tile, &model, &coarse, &u, 1.5).unwrap();
        assert!(pairs.len() > 100, "contacts expected in a knit tile");
        // Built at c0, evaluated at c: the affine offset in c is exercised.
        let problem = CompressedTile::new(&tile, model, s, angle, c0, pairs.clone()).unwrap();
        let mut x = u.clone();
        x.push(problem.scale() * c);
        assert_eq!(problem.compression(&x), c);
        assert_problem_derivatives(&problem, &x, tile.radius, |i| i < 3 * n || i == 4 * n, 11);

        let mut asm = Assembler::new(&problem).unwrap();
        let (energy, gradient) = asm.gradient(&problem, &x).unwrap();
        let gc = gradient[4 * n];
        let at = PeriodicTile::new(&tile, model, coarse, pairs).unwrap();
        let mut plain = Assembler::new(&at).unwrap();
        let plain_energy = plain.energy(&at, &u).unwrap();
        let stress = at.stress(&u);
        let v = nalgebra::Vector2::new(-angle.sin(), angle.cos());
        let sigma_c = v.dot(&(stress * v));
        println!(
            "{}: E {energy:.9e} vs {plain_energy:.9e}, ∂E/∂(ℓc) {gc:.9e}, −ℓσ_c {:.9e}",
            direction.name(),
            -problem.scale() * sigma_c
        );
        assert!((energy - plain_energy).abs() <= 1e-12 * plain_energy.abs());
        assert!(
            (gc + problem.scale() * sigma_c).abs() <= 1e-9 * gc.abs().max(1e-9),
            "{gc} vs {}",
            -problem.scale() * sigma_c
        );
    }
    let err = CompressedTile::new(
        &tile,
        model,
        0.1,
        Direction::Bias.angle(),
        f64::NAN,
        Vec::new(),
    )
    .err()
    .expect("a non-finite compression is refused");
    assert!(err.to_string().contains("must be finite"), "{err}");
}

/// Along weft, bias and warp, the curve with the compression as a DOF (along the bias under
/// frozen no-sliding rows, then one solve at the compression found) has the root-find's compressions and stresses (one
/// continuation from the rest state, the same stretches), zero orthogonal stress to the
/// root-find's tolerance, and takes fewer Newton iterations.
#[test]
fn compression_dof_curve_matches_the_root_find_in_fewer_iterations() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let (tile, _) = relax_period(&tile, &model, &EquilibriumSettings::default(), 1e-6).unwrap();
    let s = [0.0, 0.05, 0.1, 0.2, 0.3];
    let dof = CurveSettings::default();
    assert!(dof.compression_dof, "the default");
    let root = CurveSettings {
        compression_dof: false,
        ..CurveSettings::default()
    };
    for direction in [Direction::Weft, Direction::Bias, Direction::Warp] {
        let a = uniaxial_curve(&tile, &model, direction, &s, &dof).unwrap();
        let b = uniaxial_curve(&tile, &model, direction, &s, &root).unwrap();
        let its =
            |c: &[sim_periodic::curves::CurvePoint]| c.iter().map(|p| p.iterations).sum::<usize>();
        println!(
            "{}: Newton iterations {} (compression DOF) vs {} (root-find)",
            direction.name(),
            its(&a),
            its(&b)
        );
        for (p, q) in a.iter().zip(&b) {
            println!(
                "  s {:.2}: c {:.9} vs {:.9}, σ_s {:.6} vs {:.6} N/m, {} vs {} solves",
                p.s, p.c, q.c, p.sigma_s, q.sigma_s, p.solves, q.solves
            );
            assert!(
                p.sigma_c.abs() <= dof.stress_tolerance(p.sigma_s),
                "σ_c {} at s {}",
                p.sigma_c,
                p.s
            );
            assert!(
                (p.c - q.c).abs() < 1e-6,
                "c {} vs {} at s {}",
                p.c,
                q.c,
                p.s
            );
            assert!(
                (p.sigma_s - q.sigma_s).abs() <= 1e-5 * q.sigma_s.abs().max(1.0),
                "σ_s {} vs {} at s {}",
                p.sigma_s,
                q.sigma_s,
                p.s
            );
        }
        assert!(its(&a) < its(&b));
        // The point is the equilibrium under its own map.
        let last = a.last().unwrap();
        let (_, sigma_c) = directional_stress(
            &sim_periodic::periodic::solve_equilibrium(
                &tile,
                &model,
                Coarse::uniaxial(last.s, last.c, direction.angle()),
                None,
                &EquilibriumSettings::default(),
            )
            .unwrap(),
            direction.angle(),
        );
        println!("  re-solved from rest at the last point's map: σ_c {sigma_c:.3e} N/m");
        assert!(
            sigma_c.abs() <= dof.stress_tolerance(last.sigma_s),
            "σ_c {sigma_c} re-solved at the last point's map"
        );
    }
    // A solve straight to a stretch from the rest state, without continuation.
    let (c, eq) = solve_compressed(
        &tile,
        &model,
        0.1,
        0.0,
        0.0,
        None,
        &EquilibriumSettings::default(),
    )
    .unwrap();
    let (sigma_s, sigma_c) = directional_stress(&eq, 0.0);
    println!(
        "weft s 0.1 from rest: c {c:.6}, σ_s {sigma_s:.6}, σ_c {sigma_c:.3e} N/m, {} iterations",
        eq.iterations
    );
    assert!(c > 0.0, "knits narrow when stretched");
    assert!(sigma_c.abs() <= 1e-6 * sigma_s.abs().max(1.0));
}

/// The collision filter bounds every point's move by its fluctuation's plus the compression's
/// share: along any step no farther than the filter allows, the closest contact pair stays at
/// least `1 − η = 0.1` of its starting distance apart, and a step that also moves `c` is cut
/// shorter than the same step at fixed `c`.
#[test]
fn the_collision_filter_accounts_for_the_compression_dof() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let n = tile.n_vertices();
    let (s, angle, c0) = (0.1, Direction::Weft.angle(), 0.02);
    let u = perturbed(&tile);
    let coarse = Coarse::uniaxial(s, c0, angle);
    let pairs = PeriodicTile::find_pairs(&tile, &model, &coarse, &u, 1.5).unwrap();
    let problem = CompressedTile::new(&tile, model, s, angle, c0, pairs.clone()).unwrap();
    let mut x = u.clone();
    x.push(problem.scale() * c0);
    // A smooth step of the fluctuations, with and without a compression step of 0.3.
    let mut dx: Vec<f64> = (0..x.len())
        .map(|i| {
            if i < 3 * n {
                tile.radius * ((i as f64) * 1.3).cos()
            } else {
                0.0
            }
        })
        .collect();
    let fixed_c = solver::Problem::max_step(&problem, &x, &dx);
    dx[4 * n] = problem.scale() * 0.3;
    let alpha = solver::Problem::max_step(&problem, &x, &dx);
    println!("max step: {fixed_c:.4e} at fixed c, {alpha:.4e} with Δc = 0.3 α");
    assert!(alpha.is_finite() && alpha > 0.0 && alpha < fixed_c);
    let approach = |t: f64| {
        let y: Vec<f64> = x.iter().zip(&dx).map(|(a, b)| a + t * b).collect();
        let c = problem.compression(&y);
        let at =
            PeriodicTile::new(&tile, model, Coarse::uniaxial(s, c, angle), pairs.clone()).unwrap();
        at.closest_approach(&y[..4 * n])
    };
    let start = approach(0.0);
    for k in 1..=20 {
        let d = approach(alpha * k as f64 / 20.0);
        assert!(
            d >= 0.1 * start,
            "closest approach {d} < 0.1 × {start} at {k}/20"
        );
    }
}
