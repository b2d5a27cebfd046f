//! Implicit Euler dynamics of small swatches: a swatch hanging from its bind-off edge under
//! gravity settles, and a free undamped swatch conserves energy up to backward Euler's
//! first-order numerical dissipation (measured, and shown to shrink with the step).

use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{SimError, Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_boundary_nodes};

/// Loop width of the Table 1 sweater (m).
const LOOP_WIDTH: f64 = 3e-3;

fn simulator(
    chart: &Chart,
    params: YarnParams,
    forces: ForceSet,
    settings: StepSettings,
) -> Simulator {
    let topo = Topology::knit(chart);
    let layout = Layout::new(&topo, &LayoutParams::new(LOOP_WIDTH, params.radius)).unwrap();
    Simulator::new(topo, &layout, params, forces, settings).unwrap()
}

/// The nodes of the bind-off edge (top row boundary).
fn bind_off_nodes(chart: &Chart) -> Vec<usize> {
    let (w, h) = (chart.width(), chart.height());
    knit_boundary_nodes(w, h)
}

fn mean_y(sim: &Simulator) -> f64 {
    let n = sim.topology().nodes.len();
    (0..n)
        .map(|i| sim.state().q[sim.dofs().x(i) + 1])
        .sum::<f64>()
        / n as f64
}

/// A 4 × 4 garter swatch with the Table 1 sweater yarn and damping (α = 10/s, β = 0.01 s),
/// hanging from its pinned bind-off edge, dt = 1 ms: every step converges, the state stays
/// finite, the pins hold exactly, the kinetic energy decays by three orders of magnitude
/// from its peak within 0.6 s and the swatch sags compared with the same run without gravity.
#[test]
fn hanging_swatch_settles() {
    let chart = Chart::garter(4, 4).unwrap();
    let settings = StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    };
    assert_eq!(settings.dt, 1e-3);
    let mut sim = simulator(
        &chart,
        YarnParams::sweater(),
        ForceSet::default(),
        settings.clone(),
    );
    let mut weightless = YarnParams::sweater();
    weightless.gravity *= 0.0;
    let mut reference = simulator(&chart, weightless, ForceSet::default(), settings);
    let pins = bind_off_nodes(&chart);
    sim.pin_nodes(&pins).unwrap();
    reference.pin_nodes(&pins).unwrap();
    let pinned_before: Vec<f64> = pins
        .iter()
        .flat_map(|&n| {
            let i = sim.dofs().x(n);
            sim.state().q[i..i + 3].to_vec()
        })
        .collect();

    let steps = 600;
    let mut peak: f64 = 0.0;
    let mut max_iterations = 0;
    let mut sag = f64::NAN;
    for k in 0..steps {
        let report = sim.step().unwrap_or_else(|e| panic!("step {k}: {e}"));
        assert_eq!(report.substeps, 1, "step {k} needed halving");
        max_iterations = max_iterations.max(report.newton_iterations);
        peak = peak.max(sim.kinetic_energy());
        if k < 300 {
            reference.step().unwrap();
            if k == 299 {
                sag = mean_y(&reference) - mean_y(&sim);
            }
        }
    }
    let state = sim.state();
    assert!(state.q.iter().chain(&state.v).all(|v| v.is_finite()));
    let pinned_after: Vec<f64> = pins
        .iter()
        .flat_map(|&n| {
            let i = sim.dofs().x(n);
            state.q[i..i + 3].to_vec()
        })
        .collect();
    assert_eq!(pinned_before, pinned_after);
    let last = sim.kinetic_energy();
    let shares = sim.energy_by_kind();
    let total: f64 = shares.iter().map(|(_, e)| e).sum();
    assert!((total - sim.potential_energy()).abs() <= 1e-12 * total.abs().max(1e-300));
    eprintln!("energy by term: {shares:?}");
    eprintln!(
        "hanging garter 4×4: peak kinetic energy {peak:.3e} J, after {steps} steps {last:.3e} J \
         (ratio {:.2e}), sag vs weightless {sag:.3e} m, max Newton iterations {max_iterations}",
        last / peak
    );
    assert!(peak > 0.0);
    assert!(
        last < 1e-3 * peak,
        "kinetic energy {last:e} J vs peak {peak:e} J"
    );
    assert!(
        sag > 0.0,
        "gravity must pull the swatch down: sag {sag:e} m"
    );
}

/// Runs a free (no pins), undamped, weightless, frictionless 3 × 3 stockinette swatch for
/// 1 ms from its layout (bent loops, at rest) and returns the largest relative change of
/// `T + V`, the largest kinetic energy over the initial energy, and the largest distance a
/// sliding coordinate moved (m).
fn free_swatch_drift(dt: f64) -> (f64, f64, f64) {
    let chart = Chart::stockinette(3, 3).unwrap();
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    let mut settings = StepSettings {
        dt,
        ..StepSettings::default()
    };
    settings.newton.gradient_rel_tol = 1e-12;
    settings.newton.gradient_abs_tol = 1e-14;
    // Without wrapping: its ramped rest angle makes the potential time dependent, and with
    // the full rest angle from t = 0 (no ramp) the quarter-turn torque drives sliding at
    // ≈ 0.5 m/s, where the drift measured 39 % (100 µs) and 20 % (10 µs): not first order,
    // an open question (dropped velocity-quadratic terms? the degenerate-wing weight?).
    let forces = ForceSet {
        friction: false,
        wrapping: false,
        ..ForceSet::default()
    };
    let mut sim = simulator(&chart, params, forces, settings);
    let h0 = sim.kinetic_energy() + sim.potential_energy();
    let q0 = sim.state().q.clone();
    let (mut drift, mut t_max, mut slide): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let steps = (1e-3 / dt).round() as usize;
    for _ in 0..steps {
        sim.step().unwrap();
        let t = sim.kinetic_energy();
        drift = drift.max((t + sim.potential_energy() - h0).abs() / h0);
        t_max = t_max.max(t / h0);
    }
    for (n, node) in sim.topology().nodes.iter().enumerate() {
        for s in 0..node.passes.len() {
            let i = sim.dofs().u(n, s);
            slide = slide.max((sim.state().q[i] - q0[i]).abs());
        }
    }
    (drift, t_max, slide)
}

/// Without damping and with a tiny step a free swatch approximately conserves `T + V`
/// (kinetic energy with the sliding mass matrix, elastic energy). Measured maximum relative
/// drift over 1 ms: 12 % at dt = 100 µs, 2.2 % at dt = 10 µs (and, over 2 ms, 17 %, 3.6 %,
/// 0.45 % at 100, 10, 1 µs): it shrinks with the step towards first order, as backward
/// Euler's numerical dissipation does, so the dropped velocity-quadratic terms add no visible
/// floor at these speeds. Asserted: < 3 % at 10 µs, and at most a quarter of the 100 µs drift.
#[test]
fn free_swatch_conserves_energy_to_first_order() {
    let (coarse, _, _) = free_swatch_drift(1e-4);
    let (fine, t_max, slide) = free_swatch_drift(1e-5);
    eprintln!(
        "free stockinette 3×3, 1 ms: drift {coarse:.3e} (dt 100 µs), {fine:.3e} (dt 10 µs); \
         max T/E₀ {t_max:.3}; max sliding {slide:.3e} m"
    );
    assert!(
        t_max > 0.05,
        "the swatch must actually move (T/E₀ = {t_max})"
    );
    assert!(
        slide > 1e-7,
        "sliding coordinates must take part ({slide:e} m)"
    );
    assert!(fine < 0.03, "relative energy drift {fine:e} at dt = 10 µs");
    assert!(
        fine < 0.25 * coarse,
        "drift must shrink with the step: {coarse:e} → {fine:e}"
    );
}

/// Bad input is an error, not a panic.
#[test]
fn invalid_input_is_rejected() {
    let chart = Chart::garter(2, 2).unwrap();
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &LayoutParams::new(LOOP_WIDTH, 0.75e-3)).unwrap();
    let mut bad = YarnParams::sweater();
    bad.linear_density = -1.0;
    let r = Simulator::new(
        topo.clone(),
        &layout,
        bad,
        ForceSet::default(),
        StepSettings::default(),
    );
    assert!(matches!(r, Err(SimError::Invalid(_))));
    let settings = StepSettings {
        dt: 0.0,
        ..StepSettings::default()
    };
    let r = Simulator::new(
        topo.clone(),
        &layout,
        YarnParams::sweater(),
        ForceSet::default(),
        settings,
    );
    assert!(matches!(r, Err(SimError::Invalid(_))));
    for shrink in [0.0, 1.0, f64::NAN] {
        let settings = StepSettings {
            max_material_shrink: Some(shrink),
            ..StepSettings::default()
        };
        assert!(matches!(settings.validate(), Err(SimError::Invalid(_))));
    }
    // A layout with a sliding coordinate missing at one node.
    let mut short = layout.clone();
    short.sliding[0].clear();
    let r = Simulator::new(
        topo.clone(),
        &short,
        YarnParams::sweater(),
        ForceSet::default(),
        StepSettings::default(),
    );
    assert!(matches!(r, Err(SimError::Invalid(_))));
    let mut sim = simulator(
        &chart,
        YarnParams::sweater(),
        ForceSet::default(),
        StepSettings::default(),
    );
    assert!(matches!(
        sim.pin_nodes(&[topo.nodes.len()]),
        Err(SimError::Invalid(_))
    ));
}

/// A 5 × 5 plain weave (one crossing node per warp × weft, 5 DoFs each) hanging from its
/// pinned top weft under gravity, with the sweater yarn and damping: every step converges,
/// stays finite, and the free crossings move down — by the elastic stretch of the taut warps
/// only (weight ≈ 2e-3 N on 5 warps of k_s = 17.7 N: strain ≈ 2e-5 over 12 mm, so well
/// under a micrometre), not in free fall.
#[test]
fn hanging_plain_weave_steps() {
    use sim_persistent::topology::Topology;
    use sim_persistent::weave::WeavePattern;
    let (warps, wefts) = (5, 5);
    let topo = Topology::weave(WeavePattern::Plain, warps, wefts).unwrap();
    let params = YarnParams::sweater();
    let layout = Layout::new(&topo, &LayoutParams::new(LOOP_WIDTH, params.radius)).unwrap();
    let settings = StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    };
    let mut sim = Simulator::new(topo, &layout, params, ForceSet::default(), settings).unwrap();
    let top: Vec<usize> = (0..warps).map(|i| (wefts - 1) * warps + i).collect();
    sim.pin_nodes(&top).unwrap();
    let y0 = mean_y(&sim);
    for k in 0..100 {
        sim.step().unwrap_or_else(|e| panic!("step {k}: {e}"));
    }
    let s = sim.state();
    assert!(s.q.iter().chain(&s.v).all(|v| v.is_finite()));
    let drop = y0 - mean_y(&sim);
    eprintln!("plain weave 5×5: mean drop after 0.1 s {drop:.3e} m");
    assert!(drop > 0.0 && drop < 1e-6, "mean drop {drop:e} m");
}

/// A step whose Newton solve fails is split into halves: with only 5 Newton iterations
/// allowed, the first undamped 1 ms step of a 4 × 4 stockinette (far from its minimizer: the
/// layout is not at rest) cannot converge, the halved substeps can, and the clock advances by
/// exactly one step. With no halving allowed the same step is an error carrying the report.
#[test]
fn failed_steps_are_halved() {
    let chart = Chart::stockinette(4, 4).unwrap();
    let mut settings = StepSettings::default();
    settings.newton.max_iterations = 5;
    let mut sim = simulator(
        &chart,
        YarnParams::sweater(),
        ForceSet::default(),
        settings.clone(),
    );
    let report = sim.step().unwrap();
    eprintln!(
        "halving: {} substeps, {} Newton iterations",
        report.substeps, report.newton_iterations
    );
    assert!(report.substeps > 1);
    assert!((sim.time() - 1e-3).abs() < 1e-15);
    settings.max_halvings = 0;
    let mut strict = simulator(&chart, YarnParams::sweater(), ForceSet::default(), settings);
    let q_before = strict.state().q.clone();
    match strict.step() {
        Err(SimError::Solve(e)) => assert!(e.report().is_some()),
        other => panic!("expected a Newton failure, got {other:?}"),
    }
    assert_eq!(
        strict.state().q,
        q_before,
        "a failed step leaves the state alone"
    );
    assert_eq!(strict.time(), 0.0);
}

/// Architecture invariant: results do not depend on the rayon thread count (stencils are
/// evaluated in parallel into private buffers and summed in stencil order).
#[test]
fn steps_are_bit_identical_for_one_and_two_threads() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let chart = Chart::seed(3, 3).unwrap();
            let settings = StepSettings {
                rayleigh_alpha: 5.0,
                rayleigh_beta: 0.01,
                ..StepSettings::default()
            };
            let mut sim = simulator(&chart, YarnParams::sweater(), ForceSet::default(), settings);
            sim.pin_nodes(&bind_off_nodes(&chart)).unwrap();
            for _ in 0..20 {
                sim.step().unwrap();
            }
            sim.state().clone()
        })
    };
    let (one, two) = (run(1), run(2));
    assert!(
        one.q
            .iter()
            .zip(&two.q)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert!(
        one.v
            .iter()
            .zip(&two.v)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
}

/// A clone continues exactly like the original (the copy rebuilds only the Newton solver's
/// caches; its lagged damping forms keep their refresh cycle), and `set_settings` changes the step from then on but refuses to switch
/// Rayleigh-β damping on or off (its terms exist only if β > 0 at construction).
#[test]
fn clones_continue_identically_and_settings_can_change() {
    let chart = Chart::garter(3, 3).unwrap();
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    // Lagged β-damping forms (refreshed every 3 steps): the copy is taken mid-cycle.
    let settings = StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        damping_refresh_steps: 3,
        ..StepSettings::default()
    };
    let mut sim = simulator(&chart, params, ForceSet::default(), settings.clone());
    for _ in 0..5 {
        sim.step().unwrap();
    }
    let mut copy = sim.clone();
    for _ in 0..5 {
        sim.step().unwrap();
        copy.step().unwrap();
    }
    assert_eq!(sim.state(), copy.state());
    assert_eq!(sim.time(), copy.time());
    let half = StepSettings {
        dt: 0.5e-3,
        ..settings.clone()
    };
    copy.set_settings(half).unwrap();
    let t = copy.time();
    copy.step().unwrap();
    assert!((copy.time() - t - 0.5e-3).abs() < 1e-15);
    let undamped = StepSettings {
        rayleigh_beta: 0.0,
        ..settings
    };
    assert!(matches!(
        copy.set_settings(undamped),
        Err(SimError::Invalid(_))
    ));
    assert_eq!(
        copy.settings().dt,
        0.5e-3,
        "a refused change leaves the settings"
    );
}

/// `pin_sliding` fixes every sliding coordinate through the given nodes (a gripping clamp)
/// and nothing else; an unknown node is an error.
#[test]
fn pin_sliding_fixes_the_sliding_coordinates_of_its_nodes() {
    let chart = Chart::garter(3, 3).unwrap();
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    let mut sim = simulator(&chart, params, ForceSet::default(), StepSettings::default());
    let before = sim.fixed().to_vec();
    let nodes = bind_off_nodes(&chart);
    sim.pin_sliding(&nodes).unwrap();
    let dofs = sim.dofs().clone();
    for (n, node) in sim.topology().nodes.iter().enumerate() {
        for s in 0..node.passes.len() {
            let i = dofs.u(n, s);
            assert_eq!(
                sim.fixed()[i],
                before[i] || nodes.contains(&n),
                "node {n} slot {s}"
            );
        }
        for k in 0..3 {
            assert_eq!(sim.fixed()[dofs.x(n) + k], before[dofs.x(n) + k]);
        }
    }
    assert!(matches!(
        sim.pin_sliding(&[usize::MAX]),
        Err(SimError::Invalid(_))
    ));
}

/// With Rayleigh β > 0 the friction springs are β-damped under the paper's update but not
/// under the return mapping (the form would brake slipping coordinates), and the return
/// mapping cannot be switched on or off later.
#[test]
fn return_mapping_leaves_friction_springs_undamped() {
    use sim_persistent::forces::TermKind;
    let chart = Chart::garter(3, 3).unwrap();
    let damped = |return_mapping: usize| {
        let settings = StepSettings {
            rayleigh_beta: 0.01,
            friction_return_mapping: return_mapping,
            ..StepSettings::default()
        };
        let sim = simulator(&chart, YarnParams::sweater(), ForceSet::default(), settings);
        let count = |kind| sim.static_terms().count(kind) + sim.step_terms().count(kind);
        (count(TermKind::Damping), count(TermKind::Friction), sim)
    };
    let (explicit, friction, mut sim) = damped(0);
    let (implicit, _, _) = damped(20);
    assert!(friction > 0);
    assert_eq!(explicit - implicit, friction);
    let settings = StepSettings {
        friction_return_mapping: 20,
        ..sim.settings().clone()
    };
    assert!(matches!(
        sim.set_settings(settings),
        Err(SimError::Invalid(_))
    ));
}
