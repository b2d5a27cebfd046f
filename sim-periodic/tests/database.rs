//! Displacement database generation and uniaxial curves on the real stockinette tile.

use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::curves::{CurveSettings, directional_stress, uniaxial_curve};
use sim_periodic::database::{
    DatabaseSettings, GenerationError, generate, relax_period, relax_reference,
};
use sim_periodic::periodic::{EquilibriumSettings, YarnModel, solve_equilibrium};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

mod common;
use common::stockinette;

fn relaxed() -> (Tile, YarnModel) {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let (relaxed, _) = relax_reference(&tile, &model, &EquilibriumSettings::default()).unwrap();
    (relaxed, model)
}

fn scratch_dir(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn database_is_zero_at_rest_matches_direct_solves_and_resumes() {
    let (tile, model) = relaxed();
    let settings = DatabaseSettings::default();
    let axes = [vec![0.0, 0.1], vec![-0.1, 0.0], vec![0.0]];
    let dir = scratch_dir("database-resume");
    let first = generate(&tile, &model, axes.clone(), &settings, Some(&dir), &|_| {}).unwrap();
    let db = &first.database;
    assert_eq!(db.n_vertices, tile.n_vertices());
    assert_eq!(first.samples.len(), 4);

    // At zero strain the relaxed reference does not move (issue: below 1e-6 m).
    let max_at_rest = (0..db.n_vertices)
        .map(|v| {
            let r = db.get(v, 0, 1, 0).unwrap();
            (r[0].abs()).max(r[1].abs()).max(r[2].abs())
        })
        .fold(0.0f32, f32::max);
    eprintln!("max |ΔQ| at zero strain: {max_at_rest:e} m");
    assert!(max_at_rest < 1e-6, "{max_at_rest}");

    // A sample reproduces an independent solve from rest: F (X + ΔQ) = F X + ũ.
    let strain = Strain {
        sx: 0.1,
        sa: -0.1,
        sy: 0.0,
    };
    let coarse = Coarse::from_strain(&strain);
    let eq =
        solve_equilibrium(&tile, &model, coarse, None, &EquilibriumSettings::default()).unwrap();
    let f3 = coarse.f3();
    let mut worst = 0.0f64;
    for v in 0..tile.n_vertices() {
        let r = db.get(v, 1, 0, 0).unwrap();
        let dq = nalgebra::Vector3::new(r[0] as f64, r[1] as f64, r[2] as f64);
        let from_db = f3 * (tile.positions[v] + dq);
        let direct = f3 * tile.positions[v]
            + nalgebra::Vector3::new(eq.dofs[3 * v], eq.dofs[3 * v + 1], eq.dofs[3 * v + 2]);
        worst = worst.max((from_db - direct).norm());
    }
    eprintln!("database vs direct solve: {:.3e} R", worst / tile.radius);
    assert!(worst < 1e-5 * tile.radius, "{worst}");

    // Resume: remove one sample's checkpoint; the rerun solves only that one, same result.
    let removed = dir.join("sample-01-00-00.bin");
    std::fs::remove_file(&removed).unwrap();
    let second = generate(&tile, &model, axes.clone(), &settings, Some(&dir), &|_| {}).unwrap();
    let resumed = second.samples.iter().filter(|s| s.resumed).count();
    assert_eq!(resumed, 3);
    assert_eq!(second.database, first.database);

    // A checkpoint made for other inputs is refused.
    let other = [vec![0.0, 0.2], vec![-0.1, 0.0], vec![0.0]];
    let err = generate(&tile, &model, other, &settings, Some(&dir), &|_| {}).unwrap_err();
    assert!(matches!(err, GenerationError::Checkpoint { .. }));
    assert!(err.to_string().contains("different inputs"), "{err}");
}

/// A sample that cannot be solved stops the generation with a clear error, or, with
/// `fill_unsolved`, is filled from its continuation parent, flagged, and not checkpointed.
/// (Unsolvable here by a 1-iteration Newton budget without halving.)
#[test]
fn unsolved_samples_fail_or_are_filled_from_their_parent_and_flagged() {
    let (tile, model) = relaxed();
    let mut settings = DatabaseSettings {
        max_bisections: 0,
        ..DatabaseSettings::default()
    };
    settings.equilibrium.newton.max_iterations = 1;
    let axes = [vec![0.0, 0.3], vec![0.0], vec![0.0]];
    let err = generate(&tile, &model, axes.clone(), &settings, None, &|_| {}).unwrap_err();
    assert!(matches!(err, GenerationError::Solve { .. }), "{err}");
    assert!(
        err.to_string().contains("sx, sa, sy) = (0.3, 0, 0)"),
        "{err}"
    );

    settings.fill_unsolved = true;
    let dir = scratch_dir("database-unsolved");
    let filled = generate(&tile, &model, axes, &settings, Some(&dir), &|_| {}).unwrap();
    let flags: Vec<bool> = filled.samples.iter().map(|s| s.solved).collect();
    assert_eq!(flags, [true, false]);
    // The filled row is the parent's (zero) fluctuation under the sample's strain: ΔQ = 0,
    // and its Ψ is the affinely stretched tile's, above the parent's.
    let db = &filled.database;
    let moved = (0..db.n_vertices)
        .map(|v| {
            db.get(v, 1, 0, 0).unwrap()[..3]
                .iter()
                .fold(0f32, |m, x| m.max(x.abs()))
        })
        .fold(0f32, f32::max);
    assert!(moved < 1e-6, "{moved}");
    let s = &filled.samples;
    assert!(s[1].density.is_finite() && s[1].density > s[0].density);
    assert!(s[1].stress.iter().all(|v| v.is_finite()));
    // Only the solved sample was checkpointed.
    assert!(dir.join("sample-00-00-00.bin").exists());
    assert!(!dir.join("sample-01-00-00.bin").exists());
}

#[test]
fn inadmissible_or_malformed_axes_are_rejected() {
    let (tile, model) = relaxed();
    let settings = DatabaseSettings::default();
    let err = generate(
        &tile,
        &model,
        [vec![0.0], vec![0.0, 1.0], vec![0.0]],
        &settings,
        None,
        &|_| {},
    )
    .unwrap_err();
    assert!(err.to_string().contains("not admissible"), "{err}");
    let err = generate(
        &tile,
        &model,
        [vec![0.1, 0.0], vec![0.0], vec![0.0]],
        &settings,
        None,
        &|_| {},
    )
    .unwrap_err();
    assert!(err.to_string().contains("increasing"), "{err}");
}

#[test]
fn uniaxial_curve_has_zero_orthogonal_stress_and_stress_is_dpsi_ds() {
    let tile = stockinette();
    let model = YarnModel::default_for_radius(tile.radius);
    let (tile, period) =
        relax_period(&tile, &model, &EquilibriumSettings::default(), 1e-6).unwrap();
    eprintln!(
        "period stretch {:?}, remaining stress {}",
        period.stretch, period.stress
    );
    assert!(period.stress[(0, 0)].abs() <= 1e-6 && period.stress[(1, 1)].abs() <= 1e-6);
    // The root-find (the compression as a DOF is compared with it in `compression_dof.rs`).
    let settings = CurveSettings {
        compression_dof: false,
        ..CurveSettings::default()
    };
    let h = 0.005;
    let s = [0.0, 0.05, 0.1 - h, 0.1, 0.1 + h];
    let curve = uniaxial_curve(&tile, &model, Direction::Weft, &s, &settings).unwrap();
    for p in &curve {
        assert!(p.sigma_c.abs() <= settings.stress_tolerance(p.sigma_s));
        eprintln!(
            "s {:.3} c {:.5} σ_s {:.5} N/m, {} solves",
            p.s, p.c, p.sigma_s, p.solves
        );
    }
    // Newton steps with the exact slope dσ_c/dc instead of secant steps: the same roots (to
    // far below the measured compressions' 1e-3), in fewer solves.
    let newton = CurveSettings {
        exact_slope: true,
        ..settings.clone()
    };
    let exact = uniaxial_curve(&tile, &model, Direction::Weft, &s, &newton).unwrap();
    let solves = |c: &[sim_periodic::curves::CurvePoint]| c.iter().map(|p| p.solves).sum::<usize>();
    eprintln!(
        "solves: {} with the exact slope, {} with secant steps",
        solves(&exact),
        solves(&curve)
    );
    for (a, b) in exact.iter().zip(&curve) {
        assert!(
            (a.c - b.c).abs() < 1e-6,
            "c {} vs {} at s = {}",
            a.c,
            b.c,
            a.s
        );
    }
    assert!(solves(&exact) < solves(&curve));
    // From a stress-free start; knits narrow when stretched, and stiffen.
    assert!(curve[0].sigma_s.abs() < 1e-4 && curve[0].c.abs() < 1e-4);
    assert!(curve[3].c > 0.0);
    assert!(curve[3].sigma_s > curve[1].sigma_s && curve[1].sigma_s > curve[0].sigma_s);
    // With ∂Ψ/∂c = 0 along the curve, dΨ/ds = ∂Ψ/∂s = σ_s.
    let fd = (curve[4].density - curve[2].density) / (2.0 * h);
    let rel = (fd - curve[3].sigma_s).abs() / curve[3].sigma_s.abs();
    eprintln!("dΨ/ds by differences vs σ_s: {rel:.2e} relative");
    assert!(rel < 1e-3, "{fd} vs {}", curve[3].sigma_s);
    // The returned point is an equilibrium whose orthogonal stress is the one reported.
    let eq = solve_equilibrium(
        &tile,
        &model,
        Coarse::uniaxial(curve[3].s, curve[3].c, 0.0),
        None,
        &EquilibriumSettings::default(),
    )
    .unwrap();
    let (ss, _) = directional_stress(&eq, 0.0);
    assert!((ss - curve[3].sigma_s).abs() < 1e-6 * ss.abs());
}

/// The continuation tree fixes each sample's warm start (its neighbour towards the root), and
/// every solve is deterministic, so the database does not depend on the number of threads.
#[test]
fn database_does_not_depend_on_the_thread_count() {
    let (tile, model) = relaxed();
    let settings = DatabaseSettings::default();
    let axes = [vec![0.0, 0.15], vec![-0.2, 0.0, 0.2], vec![0.0, 0.1]];
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| generate(&tile, &model, axes.clone(), &settings, None, &|_| {}).unwrap())
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.database, two.database);
    let rows = |r: &sim_periodic::database::Generated| -> Vec<(u64, usize)> {
        r.samples
            .iter()
            .map(|s| (s.density.to_bits(), s.iterations))
            .collect()
    };
    assert_eq!(rows(&one), rows(&two));
}
