//! The yarn-parameter fit (seed 002 §7) recovers known parameters from targets that
//! `sim-periodic` generated with them.

use sim_periodic::curves::{CurveSettings, uniaxial_curve};
use sim_periodic::fit::{
    Bound, Evaluation, FitError, FitResult, FitSettings, Journal, LocalMethod, Objective,
    ObjectiveSettings, Parameter, ParameterSpace, Sample, SampleLayout, TargetPoint, Targets,
    comfort_end, estimated_radius, fit, stretched_geometry,
};
use sim_periodic::periodic::{EquilibriumSettings, YarnModel};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

mod common;
use common::{stockinette_geometry as geometry, targets_of};

/// [`fit`] with an in-memory journal and no progress output.
fn fit_in_memory(
    geometry: &Tile,
    targets: &Targets,
    space: &ParameterSpace,
    settings: &FitSettings,
) -> Result<FitResult, FitError> {
    fit(
        geometry,
        targets,
        space,
        settings,
        &Journal::in_memory(),
        &|_| {},
    )
}

/// A small, cheap case for the swarm tests: the paper's space, targets of a known model in
/// weft up to 30 % stretch, and objective settings with 3 samples and 2 compression nodes.
fn small_weft_case(geometry: &Tile) -> (ParameterSpace, Targets, ObjectiveSettings) {
    let space = paper_space(geometry);
    let truth = space.model(&[0.6, 0.4, 0.5, 0.5, 0.5]);
    let targets = targets_of(geometry, &truth, &[(Direction::Weft, 0.3)], 3);
    let objective = ObjectiveSettings {
        samples: 3,
        compression_nodes: 2,
        ..ObjectiveSettings::default()
    };
    (space, targets, objective)
}

/// The paper's five parameters around the default 1 mm model, for `geometry`.
fn paper_space(geometry: &Tile) -> ParameterSpace {
    let base = YarnModel::default_for_radius(1e-3);
    let r_est = estimated_radius(geometry, &base).unwrap();
    ParameterSpace::paper(&base, r_est).unwrap()
}

#[test]
fn the_fit_recovers_known_parameters_from_their_own_curves() {
    let geometry = geometry();
    // All five of the paper's parameters free.
    let space = paper_space(&geometry);
    let truth_x = [0.62, 0.4, 0.55, 0.45, 0.58];
    let truth = space.model(&truth_x);
    let nodes = 5;
    let targets = targets_of(
        &geometry,
        &truth,
        &[(Direction::Weft, 0.4), (Direction::Warp, 0.2)],
        nodes,
    );
    let objective = ObjectiveSettings {
        samples: nodes,
        compression_nodes: nodes,
        ..ObjectiveSettings::default()
    };
    let settings = FitSettings {
        swarm: None,
        start: Some(vec![0.5, 0.5, 0.45, 0.5, 0.5]),
        swarm_objective: objective.clone(),
        local_objective: objective,
        local: LocalMethod::LevenbergMarquardt,
        local_evaluations: 30,
        local_step: 0.1,
        local_starts: 1,
        local_x_tol: 1e-6,
        local_geometry: true,
    };
    let t = std::time::Instant::now();
    let result = fit_in_memory(&geometry, &targets, &space, &settings).unwrap();
    let truth_values = space.values(&truth_x);
    eprintln!(
        "{} evaluations in {:.1} s ({}), g = {:e}",
        result.evaluations[1],
        t.elapsed().as_secs_f64(),
        result.local_status,
        result.evaluation.value
    );
    for ((b, fitted), known) in space.free.iter().zip(&result.values).zip(&truth_values) {
        let rel = (fitted - known).abs() / known.abs();
        eprintln!(
            "{}: fitted {fitted:.6e}, known {known:.6e} ({:.3} %)",
            b.parameter.name(),
            100.0 * rel
        );
        assert!(
            rel < 0.02,
            "{} off by {:.2} %",
            b.parameter.name(),
            100.0 * rel
        );
    }
    let worst = result
        .evaluation
        .samples
        .iter()
        .filter(|p| p.target.sigma.abs() > 0.0)
        .map(|p| (p.sigma - p.target.sigma).abs() / p.target.sigma.abs())
        .fold(0.0, f64::max);
    eprintln!("largest relative stress error: {:.4} %", 100.0 * worst);
    assert!(worst < 0.005);
}

#[test]
fn the_residual_jacobian_matches_central_differences_on_a_frozen_rest_tile() {
    // With the rest tile frozen the objective is smooth in the parameters and the Jacobian
    // (implicit differentiation of every equilibrium, compressions through their
    // zero-orthogonal-stress condition) is its exact derivative.
    let geometry = geometry();
    let space = paper_space(&geometry);
    let x = [0.55, 0.35, 0.6, 0.5, 0.5];
    let mut tight = EquilibriumSettings::default();
    tight.newton.gradient_abs_tol = 1e-13;
    tight.newton.gradient_rel_tol = 1e-13;
    let targets = targets_of(
        &geometry,
        &space.model(&[0.6, 0.4, 0.55, 0.45, 0.58]),
        &[(Direction::Weft, 0.3), (Direction::Bias, 0.2)],
        4,
    );
    let objective = Objective {
        geometry: &geometry,
        targets: &targets,
        settings: ObjectiveSettings {
            samples: 4,
            compression_nodes: 3,
            // Roots and equilibria far tighter than the central differences' step, so
            // that the differences measure the derivative, not the solver tolerances.
            curve: CurveSettings {
                stress_abs_tol: 1e-12,
                stress_rel_tol: 1e-12,
                compression_tol: 0.0,
                equilibrium: tight,
                ..CurveSettings::default()
            },
            ..ObjectiveSettings::default()
        },
    };
    let (rest, _, _) = objective.rest_tile(&space.model(&x)).unwrap();
    let (evaluation, jacobian) = objective
        .evaluate_with_jacobian(&space, &x, Some(&rest))
        .unwrap();
    let r0 = Objective::residuals(&evaluation);
    let h = 1e-5;
    for k in 0..space.dim() {
        let at = |delta: f64| {
            let mut y = x;
            y[k] += delta;
            Objective::residuals(
                &objective
                    .evaluate_with_jacobian(&space, &y, Some(&rest))
                    .unwrap()
                    .0,
            )
        };
        let fd = (at(h) - at(-h)) / (2.0 * h);
        let column = jacobian.column(k);
        let err = (&fd - column).amax() / column.amax().max(r0.amax());
        eprintln!(
            "{}: |J| = {:.3e}, |J − FD| / max = {err:.2e}",
            space.free[k].parameter.name(),
            column.amax()
        );
        assert!(err < 1e-6, "column {k} off by {err:e}");
    }
}

/// A stress sample at the stretch of a compression node has the node's coarse map, so it is
/// the node's equilibrium, bit for bit (not a second solve that lands elsewhere within the
/// Newton tolerance); the samples between nodes take the interpolated compression.
#[test]
fn samples_at_compression_nodes_are_the_nodes_equilibria() {
    let geometry = geometry();
    let space = paper_space(&geometry);
    let model = space.model(&[0.55, 0.35, 0.6, 0.5, 0.5]);
    let targets = targets_of(&geometry, &model, &[(Direction::Weft, 0.3)], 4);
    // Samples at 0, ¼, ½, ¾ and 1 of the curve; nodes at 0, ½ and 1.
    let objective = Objective {
        geometry: &geometry,
        targets: &targets,
        settings: ObjectiveSettings {
            samples: 5,
            compression_nodes: 3,
            ..ObjectiveSettings::default()
        },
    };
    let evaluation = objective.evaluate(&model).unwrap();
    let (rest, _, _) = objective.rest_tile(&model).unwrap();
    let s_max = targets.curves[&Direction::Weft].last().unwrap().s;
    let nodes = uniaxial_curve(
        &rest,
        &model,
        Direction::Weft,
        &[0.0, s_max * 0.5, s_max],
        &CurveSettings::default(),
    )
    .unwrap();
    let samples = &evaluation.samples;
    assert_eq!(samples.len(), 5);
    for (sample, node) in [(0, 0), (2, 1), (4, 2)] {
        let (sample, node) = (&samples[sample], &nodes[node]);
        assert_eq!(sample.target.s, node.s);
        assert_eq!(sample.c, node.c, "at s = {}", node.s);
        assert_eq!(sample.sigma, node.sigma_s, "at s = {}", node.s);
    }
    for (sample, (a, b)) in [(1, (0, 1)), (3, (1, 2))] {
        let c = 0.5 * (nodes[a].c + nodes[b].c);
        assert!((samples[sample].c - c).abs() <= 1e-15, "sample {sample}");
        // Between the nodes: a solve of its own, whose stress lies between theirs.
        let sigma = samples[sample].sigma;
        assert!(
            nodes[a].sigma_s < sigma && sigma < nodes[b].sigma_s,
            "sample {sample}"
        );
    }
}

/// The comfort-half layout puts half of the samples (rounded up) in the comfort range, its
/// end among them, and ends at the curve's last stretch bit for bit (where the last
/// compression node lies, so that sample is the node's equilibrium); a curve that never
/// leaves the comfort range is sampled evenly.
#[test]
fn the_comfort_half_layout_samples_the_comfort_range_with_half_the_samples() {
    let geometry = geometry();
    // σ̂ = 100 s² N/m up to s = 0.9: the comfort stress 2 N / 6 cm = 33.3 N/m is reached
    // between the points at 0.54 and 0.63, where the linear interpolation puts it.
    let curve = |top: f64| -> Vec<TargetPoint> {
        (0..=10)
            .map(|i| {
                let s = 0.09 * i as f64;
                TargetPoint {
                    s,
                    c: 0.2 * s,
                    sigma: top * s * s,
                }
            })
            .collect()
    };
    let s_max = 0.09 * 10.0; // the curve's last stretch (0.8999999999999999)
    let (s54, s63) = (0.09 * 6.0, 0.09 * 7.0);
    let comfort = 2.0 / 0.06;
    let (f54, f63) = (100.0 * s54 * s54, 100.0 * s63 * s63);
    let s_c = s54 + (comfort - f54) / (f63 - f54) * (s63 - s54);
    let stiff = Targets {
        curves: [(Direction::Weft, curve(100.0))].into(),
    };
    // A curve that stays below the comfort stress: the whole range is comfort.
    let soft = Targets {
        curves: [(Direction::Weft, curve(30.0))].into(),
    };
    // The comfort range's end: the interpolated crossing, the last stretch when the curve
    // never reaches the comfort stress, the first when it starts above it, none without points.
    assert!((comfort_end(&curve(100.0), comfort).unwrap() - s_c).abs() < 1e-15);
    assert_eq!(comfort_end(&curve(30.0), comfort), Some(s_max));
    let above: Vec<TargetPoint> = curve(100.0)[7..].to_vec();
    assert_eq!(comfort_end(&above, comfort), Some(above[0].s));
    assert_eq!(comfort_end(&[], comfort), None);
    for (n, inside) in [(7, 4), (20, 10), (2, 1), (3, 2)] {
        let stretches = |targets: &Targets, layout| {
            Objective {
                geometry: &geometry,
                targets,
                settings: ObjectiveSettings {
                    samples: n,
                    layout,
                    ..ObjectiveSettings::default()
                },
            }
            .stretches(Direction::Weft)
            .unwrap()
        };
        let s = stretches(&stiff, SampleLayout::ComfortHalf);
        assert_eq!(s.len(), n);
        assert_eq!(s[0], 0.0);
        assert_eq!(*s.last().unwrap(), s_max, "n = {n}: {s:?}");
        assert!(s.windows(2).all(|w| w[0] < w[1]), "n = {n}: {s:?}");
        let within = s.iter().filter(|&&x| x <= s_c + 1e-12).count();
        assert_eq!(within, inside, "n = {n}: {s:?}, comfort to {s_c}");
        if inside > 1 {
            assert!((s[inside - 1] - s_c).abs() < 1e-12, "n = {n}: {s:?}");
        }
        // The paper's even layout.
        let even = stretches(&stiff, SampleLayout::Even);
        assert!(
            even.iter()
                .enumerate()
                .all(|(i, &x)| (x - s_max * i as f64 / (n - 1) as f64).abs() < 1e-15),
            "{even:?}"
        );
        let s = stretches(&soft, SampleLayout::ComfortHalf);
        assert_eq!(s, even, "n = {n}");
    }
}

/// An evaluation's comfort-range samples are counted per direction, in sample order, without
/// the unstretched sample and with a direction that has none.
#[test]
fn comfort_samples_are_counted_per_direction() {
    let sample = |direction, s: f64, comfort| Sample {
        direction,
        target: TargetPoint {
            s,
            c: 0.0,
            sigma: 10.0 * s,
        },
        c: 0.0,
        sigma: 10.0 * s,
        comfort,
        stretch_term: 0.0,
        compression_term: 0.0,
    };
    let evaluation = Evaluation {
        value: 0.0,
        samples: vec![
            sample(Direction::Weft, 0.0, true),
            sample(Direction::Weft, 0.1, true),
            sample(Direction::Weft, 0.2, true),
            sample(Direction::Weft, 0.3, false),
            sample(Direction::Warp, 0.0, true),
            sample(Direction::Warp, 0.5, false),
        ],
        comfort_error: 0.0,
        power_error: 0.0,
        compression_error: 0.0,
        rest_stress: nalgebra::Matrix2::zeros(),
        iterations: 0,
    };
    assert_eq!(
        evaluation.comfort_samples(),
        vec![(Direction::Weft, 2), (Direction::Warp, 0)]
    );
}

/// Levenberg–Marquardt from several distinct swarm points keeps the lowest objective, and
/// says which start won; no start at all is an error.
#[test]
fn several_local_starts_keep_the_best_and_zero_is_an_error() {
    let geometry = geometry();
    let (space, targets, objective) = small_weft_case(&geometry);
    let settings = |starts: usize| FitSettings {
        swarm: Some(sim_periodic::fit::SwarmSettings {
            particles: 6,
            iterations: 1,
            seed: 7,
            ..sim_periodic::fit::SwarmSettings::default()
        }),
        swarm_objective: objective.clone(),
        local_objective: objective.clone(),
        local_evaluations: 3,
        local_starts: starts,
        ..FitSettings::default()
    };
    let run = |starts: usize| fit_in_memory(&geometry, &targets, &space, &settings(starts));
    let one = run(1).unwrap();
    let two = run(2).unwrap();
    assert!(two.local_status.contains("of 2"), "{}", two.local_status);
    assert!(two.evaluations[1] > one.evaluations[1]);
    // The first start is the single-start run, so two starts never end higher.
    assert!(
        two.evaluation.value <= one.evaluation.value,
        "{} {}",
        two.evaluation.value,
        one.evaluation.value
    );
    // The result's evaluation (kept from the search, not recomputed) is its point's.
    let local = Objective {
        geometry: &geometry,
        targets: &targets,
        settings: objective.clone(),
    };
    for result in [&one, &two] {
        let again = local.evaluate_at(&space, &result.x).unwrap();
        assert_eq!(format!("{:?}", result.evaluation), format!("{again:?}"));
    }
    let e = run(0).unwrap_err().to_string();
    assert!(e.contains("local_starts"), "{e}");
}

/// Independent restarts: two restarts end exactly where the better of the two single fits
/// with seeds `s` and `s + 1` ends, with the evaluations of both, and say which restart won;
/// zero restarts are an error.
#[test]
fn restarts_keep_the_better_of_independent_seeds_and_zero_is_an_error() {
    use sim_periodic::fit::SwarmSettings;
    let geometry = geometry();
    let (space, targets, objective) = small_weft_case(&geometry);
    let settings = |seed: u64, restarts: usize| FitSettings {
        swarm: Some(SwarmSettings {
            particles: 4,
            iterations: 1,
            seed,
            restarts,
            ..SwarmSettings::default()
        }),
        swarm_objective: objective.clone(),
        local_objective: objective.clone(),
        local_evaluations: 3,
        ..FitSettings::default()
    };
    let run = |seed: u64, restarts: usize| {
        fit_in_memory(&geometry, &targets, &space, &settings(seed, restarts))
    };
    let (a, b) = (run(5, 1).unwrap(), run(6, 1).unwrap());
    let both = run(5, 2).unwrap();
    let (winner, index) = if b.evaluation.value < a.evaluation.value {
        (&b, 2)
    } else {
        (&a, 1)
    };
    assert_eq!(both.x, winner.x);
    assert_eq!(
        both.evaluation.value.to_bits(),
        winner.evaluation.value.to_bits()
    );
    assert!(
        both.local_status
            .starts_with(&format!("restart {index} of 2 (seed {})", 4 + index)),
        "{}",
        both.local_status
    );
    assert_eq!(
        both.evaluations,
        [
            a.evaluations[0] + b.evaluations[0],
            a.evaluations[1] + b.evaluations[1]
        ]
    );
    // Both phases are timed, with and without restarts.
    for r in [&a, &b, &both] {
        assert!(
            r.seconds.iter().all(|s| s.is_finite() && *s > 0.0),
            "{:?}",
            r.seconds
        );
    }
    let e = run(5, 0).unwrap_err().to_string();
    assert!(e.contains("restarts"), "{e}");
}

/// The swarm's inertia: argmin's constant weight given explicitly reproduces the default fit
/// bit for bit (the per-iteration weight setting changes nothing else), the paper's decaying
/// schedule moves the swarm, and a negative weight is an error.
#[test]
fn the_swarm_inertia_schedule_is_argmins_swarm_with_the_weight_set_per_iteration() {
    use sim_periodic::fit::{SwarmSettings, constant_inertia};
    let geometry = geometry();
    let (space, targets, objective) = small_weft_case(&geometry);
    let run = |inertia: Option<(f64, f64)>| {
        let mut swarm = SwarmSettings {
            particles: 4,
            iterations: 2,
            seed: 11,
            ..SwarmSettings::default()
        };
        if let Some(w) = inertia {
            swarm.inertia = w;
        }
        let settings = FitSettings {
            swarm: Some(swarm),
            swarm_objective: objective.clone(),
            local_objective: objective.clone(),
            local_evaluations: 1,
            ..FitSettings::default()
        };
        fit_in_memory(&geometry, &targets, &space, &settings)
    };
    let default = run(None).unwrap();
    let w = constant_inertia();
    let explicit = run(Some((w, w))).unwrap();
    assert_eq!(default.swarm_best, explicit.swarm_best);
    assert_eq!(default.x, explicit.x);
    let paper = run(Some((0.9, 0.1))).unwrap();
    assert_ne!(
        paper.swarm_best.as_ref().map(|b| &b.0),
        default.swarm_best.as_ref().map(|b| &b.0)
    );
    let e = run(Some((-0.1, 0.1))).unwrap_err().to_string();
    assert!(e.contains("inertia"), "{e}");
}

/// `k2` (beyond the paper) is free only when listed, only with the two-phase law, and moves
/// the model's stiff stiffness.
#[test]
fn the_stiff_stretch_stiffness_can_be_freed() {
    use rod::stretch::StretchLaw;
    use sim_periodic::fit::{Bound, Parameter};
    let base = YarnModel::default_for_radius(1e-3);
    let paper = ParameterSpace::paper(&base, 1e-3).unwrap();
    assert!(
        paper
            .free
            .iter()
            .all(|b| b.parameter != Parameter::StretchStiff)
    );
    let k2 = Bound {
        parameter: Parameter::StretchStiff,
        min: 10.0,
        max: 1000.0,
    };
    let space = ParameterSpace::new(base, vec![k2]).unwrap();
    let model = space.model(&[0.5]);
    // Log scale: the middle of [10, 1000] is 100.
    assert!(matches!(model.stretch, StretchLaw::TwoPhase { k2, .. } if (k2 - 100.0).abs() < 1e-9));
    let linear = YarnModel {
        stretch: StretchLaw::Linear { k: 20.0 },
        ..base
    };
    let e = ParameterSpace::new(linear, vec![k2])
        .unwrap_err()
        .to_string();
    assert!(e.contains("k2") && e.contains("two-phase"), "{e}");
}

#[test]
fn a_known_geometry_stretch_is_recovered_by_cobyla_and_by_levenberg_marquardt() {
    // Targets of a known yarn model on the input geometry stretched by 1.1 along y
    // (beyond the paper: the geometry's proportions as fit parameters).
    let geometry = geometry();
    let truth = paper_space(&geometry).model(&[0.62, 0.4, 0.55, 0.45, 0.58]);
    let (a_min, a_max, a_true) = (0.8, 1.3, 1.1);
    let nodes = 4;
    let targets = targets_of(
        &stretched_geometry(&geometry, [1.0, a_true]).unwrap(),
        &truth,
        &[(Direction::Weft, 0.3), (Direction::Warp, 0.2)],
        nodes,
    );
    let bound = |parameter, min, max| Bound {
        parameter,
        min,
        max,
    };
    let space =
        ParameterSpace::new(truth, vec![bound(Parameter::GeometryY, a_min, a_max)]).unwrap();
    let objective_settings = ObjectiveSettings {
        samples: nodes,
        compression_nodes: nodes,
        ..ObjectiveSettings::default()
    };
    let objective = Objective {
        geometry: &geometry,
        targets: &targets,
        settings: objective_settings.clone(),
    };
    let x_true = (a_true - a_min) / (a_max - a_min);
    let at_truth = objective.evaluate_at(&space, &[x_true]).unwrap().value;
    let unstretched = objective.evaluate(&truth).unwrap().value;
    eprintln!("g at the known stretch {at_truth:e}, unstretched {unstretched:e}");
    assert!(at_truth < 1e-8, "{at_truth:e}");
    assert!(unstretched > 1e3 * at_truth.max(1e-9), "{unstretched:e}");

    let run = |space: &ParameterSpace, settings: &FitSettings| {
        fit_in_memory(&geometry, &targets, space, settings).unwrap()
    };

    // COBYLA searches it (the swarm would too): from 0.95 back to 1.1.
    let start = (0.95 - a_min) / (a_max - a_min);
    let mut settings = FitSettings {
        swarm: None,
        start: Some(vec![start]),
        swarm_objective: objective_settings.clone(),
        local_objective: objective_settings,
        local: LocalMethod::Cobyla,
        local_evaluations: 16,
        local_step: 0.2,
        local_starts: 1,
        local_x_tol: 1e-4,
        local_geometry: true,
    };
    let result = run(&space, &settings);
    let a = result.geometry_stretch[1];
    eprintln!(
        "COBYLA: a_y = {a} ({}), g = {:e}",
        result.local_status, result.evaluation.value
    );
    assert_eq!(result.geometry_stretch[0], 1.0);
    assert!((a - a_true).abs() < 0.01 * a_true, "a_y = {a}");

    // Levenberg–Marquardt recovers it with k1 (its column by forward differences), from
    // the same start, and keeps it at the start without `local_geometry`.
    let paper = paper_space(&geometry);
    let k1 = paper.free[0];
    let k1_true = 0.62;
    let space =
        ParameterSpace::new(truth, vec![k1, bound(Parameter::GeometryY, a_min, a_max)]).unwrap();
    settings.local = LocalMethod::LevenbergMarquardt;
    settings.local_evaluations = 30;
    settings.start = Some(vec![0.5, start]);
    let result = run(&space, &settings);
    let a = result.geometry_stretch[1];
    eprintln!(
        "LM: x = {:?}, a_y = {a} ({}), g = {:e}",
        result.x, result.local_status, result.evaluation.value
    );
    assert!((a - a_true).abs() < 0.01 * a_true, "a_y = {a}");
    assert!(
        (result.x[0] - k1_true).abs() < 0.02,
        "k1 at {}",
        result.x[0]
    );
    assert!(
        result.evaluation.value < 1e-6,
        "{:e}",
        result.evaluation.value
    );

    settings.local_geometry = false;
    settings.local_evaluations = 3;
    let result = run(&space, &settings);
    eprintln!(
        "LM, geometry kept: x = {:?} ({})",
        result.x, result.local_status
    );
    assert_eq!(result.x[1], start);
    assert!((result.geometry_stretch[1] - 0.95).abs() < 1e-12);
    assert_ne!(result.x[0], 0.5, "LM moved no parameter");
}
