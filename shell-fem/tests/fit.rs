//! The in-plane fit (Eq. 2): identifiability on virtual data from known parameters, and
//! behaviour with missing directions.

use shell_fem::fit::{FitConfig, Simulator, Target, VirtualTest, fit};
use shell_fem::material::{InPlaneParams, Model};
use shell_fem::swatch::{Clamp, SwatchConfig};
use yarn_pattern::direction::Direction;

fn coarse() -> SwatchConfig {
    SwatchConfig {
        nx: 10,
        ny: 6,
        ..SwatchConfig::default()
    }
}

fn virtual_targets(
    truth: &InPlaneParams,
    dirs: &[(Direction, f64)],
    cfg: &SwatchConfig,
) -> Vec<Target> {
    virtual_targets_of(Model::Augmented, truth, dirs, cfg)
}

/// The three test directions and their largest stretch.
const ALL_DIRECTIONS: [(Direction, f64); 3] = [
    (Direction::Weft, 0.5),
    (Direction::Bias, 0.5),
    (Direction::Warp, 0.3),
];

/// Every parameter `model` uses within 1 % of the truth.
fn assert_recovered(model: Model, got: &InPlaneParams, truth: &InPlaneParams) {
    for (k, (got, want)) in got.to_array().iter().zip(truth.to_array()).enumerate() {
        if !model.uses(k) {
            continue;
        }
        let rel = (got - want).abs() / want.abs();
        println!("{}: {got} vs {want} ({:.2e})", InPlaneParams::NAMES[k], rel);
        assert!(
            rel <= 0.01,
            "{} recovered as {got}, truth {want}",
            InPlaneParams::NAMES[k]
        );
    }
}

fn virtual_targets_of(
    model: Model,
    truth: &InPlaneParams,
    dirs: &[(Direction, f64)],
    cfg: &SwatchConfig,
) -> Vec<Target> {
    virtual_targets_with(VirtualTest::Swatch, model, truth, dirs, cfg)
}

/// Six targets per direction up to its largest stretch, force and compression still zero.
fn target_grid(dirs: &[(Direction, f64)]) -> Vec<Target> {
    dirs.iter()
        .flat_map(|&(d, s_max)| {
            (1..=6).map(move |i| Target {
                direction: d,
                s: s_max * i as f64 / 6.0,
                force: 0.0,
                compression: 0.0,
            })
        })
        .collect()
}

fn virtual_targets_with(
    test: VirtualTest,
    model: Model,
    truth: &InPlaneParams,
    dirs: &[(Direction, f64)],
    cfg: &SwatchConfig,
) -> Vec<Target> {
    let mut targets = target_grid(dirs);
    let mut sim = Simulator::new(test, cfg, model, &targets).unwrap();
    let values = sim.simulate(truth, &targets).unwrap();
    for (t, (f, c)) in targets.iter_mut().zip(values) {
        t.force = f;
        t.compression = c;
    }
    targets
}

/// The augmented model's example parameters, the default fit on the coarse swatch, and
/// virtual targets in all three directions.
fn augmented_case() -> (InPlaneParams, FitConfig, Vec<Target>) {
    let truth = InPlaneParams::example();
    let cfg = FitConfig {
        swatch: coarse(),
        ..FitConfig::default()
    };
    let targets = virtual_targets(&truth, &ALL_DIRECTIONS, &cfg.swatch);
    (truth, cfg, targets)
}

#[test]
fn fit_recovers_known_parameters_within_one_percent() {
    let (truth, cfg, targets) = augmented_case();
    let initial = start([0.0; 4]);
    let result = fit(&targets, initial, &cfg, None).unwrap();
    println!("{result:#?}");
    assert_recovered(Model::Augmented, &result.params, &truth);
    assert!(result.errors.force_rel_error < 1e-3 && result.errors.compression_rel_error < 1e-3);
    assert!(result.cost_history.windows(2).all(|w| w[1] < w[0]));
}

#[test]
fn fit_recovers_known_stiffening_parameters() {
    // The stiffening model through the same adjoint fit: the rates' sensitivities are the
    // closed-form parameter derivatives, so LM must walk back to the truth.
    let truth = stiffening_truth();
    let cfg = FitConfig {
        swatch: coarse(),
        ..FitConfig::for_model(Model::Stiffening)
    };
    let targets = virtual_targets_of(Model::Stiffening, &truth, &ALL_DIRECTIONS, &cfg.swatch);
    let initial = start([1.0, 1.0, 0.5, 0.5]);
    let result = fit(&targets, initial, &cfg, None).unwrap();
    assert_recovered(Model::Stiffening, &result.params, &truth);
    assert!(result.errors.force_error < 1e-4 && result.errors.compression_error < 1e-4);
}

#[test]
fn fit_is_the_same_on_one_and_two_threads() {
    // The directions' stretch tests run in parallel (Simulator::evaluate): the fit must not
    // depend on how they are scheduled, bit for bit.
    let (_, cfg, targets) = augmented_case();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| fit(&targets, start([0.0; 4]), &cfg, None).unwrap())
    };
    let (one, two) = (run(1), run(2));
    let bits = |p: &InPlaneParams| p.to_array().map(f64::to_bits);
    assert_eq!(bits(&one.params), bits(&two.params));
    assert_eq!(one.cost_history.len(), two.cost_history.len());
    for (a, b) in one.cost_history.iter().zip(&two.cost_history) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
}

/// The fits' starting point: stiffnesses 22–75 % off the truth ([`InPlaneParams::example`]),
/// stiffening rates `[bx, by, cx, cy]`.
fn start([bx, by, cx, cy]: [f64; 4]) -> InPlaneParams {
    InPlaneParams {
        kxx: 400.0,
        kxy: 30.0,
        kyy: 700.0,
        kss: 220.0,
        kn1: 25.0,
        kn2: 35.0,
        bx,
        by,
        cx,
        cy,
    }
}

fn stiffening_truth() -> InPlaneParams {
    InPlaneParams {
        bx: 3.0,
        by: 6.0,
        cx: 2.0,
        cy: 4.0,
        ..InPlaneParams::example()
    }
}

#[test]
fn uniaxial_test_equals_a_swatch_with_sliding_clamps() {
    // With sliding clamps the swatch deforms homogeneously, so the FEM swatch and the
    // homogeneous uniaxial test must give the same force and compression (weft and warp: no
    // normal–shear coupling there, so the homogeneous state has no shear either).
    let truth = stiffening_truth();
    let swatch = SwatchConfig {
        clamp: Clamp::Sliding,
        ..coarse()
    };
    let dirs = [(Direction::Weft, 0.5), (Direction::Warp, 0.3)];
    for model in Model::ALL {
        let fem = virtual_targets_with(VirtualTest::Swatch, model, &truth, &dirs, &swatch);
        let hom = virtual_targets_with(VirtualTest::Uniaxial, model, &truth, &dirs, &swatch);
        for (a, b) in fem.iter().zip(&hom) {
            let rel_f = (a.force - b.force).abs() / b.force.abs();
            let rel_c = (a.compression - b.compression).abs() / b.compression.abs();
            assert!(
                rel_f < 1e-6 && rel_c < 1e-6,
                "{model:?} {:?} s = {}: swatch ({}, {}) vs uniaxial ({}, {})",
                a.direction,
                a.s,
                a.force,
                a.compression,
                b.force,
                b.compression
            );
        }
    }
}

#[test]
fn uniaxial_fit_recovers_known_stiffening_parameters() {
    let truth = stiffening_truth();
    let cfg = FitConfig {
        test: VirtualTest::Uniaxial,
        ..FitConfig::for_model(Model::Stiffening)
    };
    let targets = virtual_targets_with(
        VirtualTest::Uniaxial,
        Model::Stiffening,
        &truth,
        &ALL_DIRECTIONS,
        &cfg.swatch,
    );
    let initial = start([1.0, 1.0, 0.5, 0.5]);
    let result = fit(&targets, initial, &cfg, None).unwrap();
    assert_recovered(Model::Stiffening, &result.params, &truth);
    assert!(result.errors.force_error < 1e-4 && result.errors.compression_error < 1e-4);
}

fn acrylic() -> Vec<shell_fem::measurements::Measurement> {
    use shell_fem::measurements::{BinOptions, direction_from_name, read_stitch_csv};
    let dir =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/measurements");
    [
        "acrylic-yarn-stockinette-x.csv",
        "acrylic-yarn-stockinette-y.csv",
    ]
    .iter()
    .map(|f| {
        let p = dir.join(f);
        read_stitch_csv(&p, direction_from_name(&p).unwrap(), &BinOptions::default()).unwrap()
    })
    .collect()
}

#[test]
fn real_acrylic_data_is_merged_binned_and_fitted() {
    let m = acrylic();
    assert_eq!(m[0].direction, Direction::Weft);
    assert_eq!(m[1].direction, Direction::Warp);
    for d in &m {
        assert!(d.points.windows(2).all(|w| w[1].s > w[0].s));
        // Loading branch only: force grows with stretch (bin averages of noisy runs).
        assert!(d.points.last().unwrap().force > 10.0 * d.points[1].force);
    }
    // The runs reach about 50 % (x) and 22 % (y) strain.
    assert!((m[0].s_max() - 0.5).abs() < 0.03 && (m[1].s_max() - 0.22).abs() < 0.03);
    let tg = shell_fem::fit::targets(&m, 6);
    assert_eq!(tg.len(), 12);
    let mut fixed = [false; InPlaneParams::LEN];
    fixed[3] = true;
    let cfg = FitConfig {
        swatch: coarse(),
        weighting: shell_fem::fit::Weighting::Relative,
        fixed,
        ..FitConfig::default()
    };
    let r = fit(&tg, shell_fem::fit::initial_guess(&m, 0.06), &cfg, None).unwrap();
    assert_eq!(r.params.kss, r.initial.kss);
    assert!(r.cost_history.last().unwrap() < &(0.5 * r.cost_history[0]));
    assert!(
        r.errors.force_rel_error < 0.2 && r.errors.compression_rel_error < 0.25,
        "{} / {}",
        r.errors.force_rel_error,
        r.errors.compression_rel_error
    );
}

/// Data without contraction (a straight-yarn weave, as the persistent swatch of
/// `cross-method` gives) still fits its forces: the compression normalization is floored at
/// `COMPRESSION_FLOOR`, so a zero mean compression does not weigh the compression residuals
/// by 1/0 (before the floor, `cross-method`'s plain-weave shell missed its forces by 3600 %).
#[test]
fn data_without_contraction_still_fits_the_forces() {
    let truth = InPlaneParams::example();
    let cfg = FitConfig {
        swatch: coarse(),
        ..FitConfig::default()
    };
    let dirs = [(Direction::Weft, 0.3), (Direction::Warp, 0.3)];
    let mut targets = virtual_targets(&truth, &dirs, &cfg.swatch);
    for t in &mut targets {
        t.compression = 0.0;
    }
    let result = fit(&targets, start([0.0; 4]), &cfg, None).unwrap();
    println!("{:?}", result.errors);
    assert!(
        result.errors.force_error < 0.05,
        "force error {}",
        result.errors.force_error
    );
}

/// Strips cut to a different size per direction (`FitConfig::direction_swatches`): virtual
/// data from a 100 × 60 mm weft strip and a 40 × 90 mm warp strip is fitted back within 1 %
/// on those swatches (force error 2e-11); fitted with the weft strip for both, each
/// direction is missed by more than 10 % (18 % measured: the clamps hold a short, wide
/// strip's width over much more of it).
#[test]
fn per_direction_swatches_are_fitted_on_their_own_strips() {
    let truth = InPlaneParams::example();
    let weft = coarse();
    let warp = SwatchConfig {
        length: 0.04,
        width: 0.09,
        nx: 6,
        ny: 10,
        ..SwatchConfig::default()
    };
    let mut targets = target_grid(&[(Direction::Weft, 0.5), (Direction::Warp, 0.3)]);
    let swatches = [(Direction::Warp, warp.clone())].into_iter().collect();
    let mut sim = Simulator::with_swatches(
        VirtualTest::Swatch,
        &weft,
        &swatches,
        Model::Augmented,
        &targets,
    )
    .unwrap();
    let values = sim.simulate(&truth, &targets).unwrap();
    for (t, (f, c)) in targets.iter_mut().zip(values) {
        t.force = f;
        t.compression = c;
    }
    let mut cfg = FitConfig {
        swatch: weft,
        direction_swatches: swatches,
        ..FitConfig::default()
    };
    // No bias test: kss is not identifiable.
    cfg.fixed[3] = true;
    let initial = InPlaneParams {
        kss: truth.kss,
        ..start([0.0; 4])
    };
    let own = fit(&targets, initial, &cfg, None).unwrap();
    assert_recovered(Model::Augmented, &own.params, &truth);
    assert!(own.errors.force_rel_error < 1e-3, "{:?}", own.errors);
    cfg.direction_swatches.clear();
    let one = fit(&targets, initial, &cfg, None).unwrap();
    println!("own strips: {:?}\none strip: {:?}", own.errors, one.errors);
    for d in &one.errors.directions {
        assert!(d.force_rel_error > 0.1, "{d:?}");
    }
}
