//! Crossing shear with shear jamming of woven cloth (`forces::crossing_shear`): asserting
//! finite-difference checks of the stencil below, near and past the jamming angle (seeded
//! proptest) and of an assembled weave; which fabrics get the terms; and a trellis-shear test
//! of a plain-weave swatch between driven clamps that resists shear and stiffens past
//! jamming.

use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::Stencil;
use rod::fd::{FdOptions, assert_stencil_derivatives, check_gradient, check_hessian};
use sim_persistent::chart::Chart;
use sim_persistent::forces::crossing_shear::{CrossingShear, CrossingShearParams, quadrants};
use sim_persistent::forces::{ForceSet, TermKind, build_terms};
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::state::{DofMap, State};
use sim_persistent::topology::Topology;
use sim_persistent::weave::WeavePattern;
use solver::{Assembler, Problem};

/// Fixed seed, no failure files written into the source tree.
fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x000c_5a7e),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Length scale: yarn spacing (m).
const W: f64 = 3e-3;

fn stencil(rest_angle: f64) -> CrossingShear {
    let p = CrossingShearParams::default();
    CrossingShear {
        stiffness: p.stiffness,
        length: W,
        rest_angle,
        jamming: p.jamming,
    }
}

/// `(x_a, x₀, x_b)` with the edges at angle φ in the plane spanned by `e1`, `e2` (rotated
/// out of the xy plane by `tilt`), lengths `la`, `lb`, crossing node at `x0`.
fn quadrant(x0: Vector3<f64>, phi: f64, la: f64, lb: f64, tilt: f64) -> SVector<f64, 9> {
    let e1 = Vector3::new(1.0, 0.0, 0.0);
    let e2 = Vector3::new(0.0, tilt.cos(), tilt.sin());
    let xa = x0 + la * e1;
    let xb = x0 + lb * (phi.cos() * e1 + phi.sin() * e2);
    let mut q = SVector::<f64, 9>::zeros();
    q.fixed_rows_mut::<3>(0).copy_from(&xa);
    q.fixed_rows_mut::<3>(3).copy_from(&x0);
    q.fixed_rows_mut::<3>(6).copy_from(&xb);
    q
}

fn v3(range: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

proptest! {
    #![proptest_config(config(96))]

    /// Random quadrants in 3-D over the whole range of shear, below, inside and past the
    /// jamming transition (γ_j = π/3, width 0.1 rad), off its two exact ends (where ψ'''
    /// jumps) and off the parallel-yarn singularity.
    #[test]
    fn crossing_shear_derivatives(x0 in v3(W), a in v3(1.0), b in v3(1.0), la in 0.3*W..2.0*W,
                                  lb in 0.3*W..2.0*W, rest in 1.2..1.9f64) {
        prop_assume!(a.norm() > 0.1 && b.norm() > 0.1);
        let (xa, xb) = (x0 + a.normalize() * la, x0 + b.normalize() * lb);
        let mut q = SVector::<f64, 9>::zeros();
        q.fixed_rows_mut::<3>(0).copy_from(&xa);
        q.fixed_rows_mut::<3>(3).copy_from(&x0);
        q.fixed_rows_mut::<3>(6).copy_from(&xb);
        let phi = CrossingShear::angle(&q);
        prop_assume!(phi > 0.05 && phi < std::f64::consts::PI - 0.05);
        let s = stencil(rest);
        let g = (phi - rest).abs();
        prop_assume!((g - s.jamming.angle).abs() > 1e-4 && (g - s.jamming.angle - s.jamming.width).abs() > 1e-4);
        assert_stencil_derivatives(&s, &q, W);
    }
}

/// Deterministic sweep of the shear angle through the jamming transition (both senses):
/// below it, inside the 0.1 rad smoothstep, and past it; every point passes the asserting
/// FD check. Reports the worst relative errors.
#[test]
fn crossing_shear_derivatives_through_jamming() {
    let s = stencil(std::f64::consts::FRAC_PI_2);
    let (gj, w) = (s.jamming.angle, s.jamming.width);
    let mut worst = (0.0f64, 0.0f64);
    // (Not at γ = 0 exactly: there the gradient is zero and its FD round-off has no scale.)
    for gamma in [
        1e-3,
        0.2,
        gj - 0.01,
        gj + 0.001,
        gj + 0.03,
        gj + 0.5 * w,
        gj + w - 0.001,
        gj + w + 0.001,
        gj + 0.3,
    ] {
        for sign in [1.0, -1.0] {
            let phi = std::f64::consts::FRAC_PI_2 + sign * gamma;
            let q = quadrant(Vector3::new(1e-4, -2e-4, 3e-4), phi, 0.9 * W, 1.2 * W, 0.4);
            let r = assert_stencil_derivatives(&s, &q, W);
            worst.0 = worst.0.max(r.gradient_rel_error);
            worst.1 = worst.1.max(r.hessian_rel_error);
        }
    }
    eprintln!(
        "crossing shear sweep: worst gradient rel. error {:.2e}, Hessian {:.2e}",
        worst.0, worst.1
    );
}

/// Below jamming the energy is exactly `½ k_x L (φ − φ₀)²`; past the transition its
/// second derivative in γ is `factor` times larger (measured by central differences of the
/// energy along a pure rotation of one edge).
#[test]
fn crossing_shear_energy_and_jamming_stiffness() {
    let s = stencil(std::f64::consts::FRAC_PI_2);
    let energy = |gamma: f64| {
        let q = quadrant(
            Vector3::zeros(),
            std::f64::consts::FRAC_PI_2 + gamma,
            W,
            W,
            0.0,
        );
        s.energy(&q)
    };
    for gamma in [-0.7, -0.1, 0.05, 0.9] {
        let expected = 0.5 * s.stiffness * s.length * gamma * gamma;
        assert!((energy(gamma) - expected).abs() <= 1e-12 * expected);
    }
    let curvature = |gamma: f64| {
        let h = 1e-4;
        (energy(gamma + h) - 2.0 * energy(gamma) + energy(gamma - h)) / (h * h)
    };
    let soft = curvature(0.5);
    let jammed = curvature(-(s.jamming.angle + s.jamming.width + 0.1));
    let kl = s.stiffness * s.length;
    assert!((soft - kl).abs() < 1e-5 * kl, "{soft} vs {kl}");
    let ratio = jammed / soft;
    eprintln!("crossing shear: V''(γ) = {soft:.4e} J/rad² below, ratio {ratio:.2} past jamming");
    assert!((ratio - s.jamming.factor).abs() < 1e-3 * s.jamming.factor);
}

/// Invalid parameters are rejected with a message naming the quantity, also by the
/// simulator.
#[test]
fn crossing_shear_params_are_validated() {
    let bad = [
        CrossingShearParams {
            stiffness: -1.0,
            ..Default::default()
        },
        CrossingShearParams {
            jamming: rod::bending::Jamming {
                angle: 2.0,
                ..CrossingShearParams::default().jamming
            },
            ..Default::default()
        },
        CrossingShearParams {
            jamming: rod::bending::Jamming {
                width: 0.0,
                ..CrossingShearParams::default().jamming
            },
            ..Default::default()
        },
        CrossingShearParams {
            jamming: rod::bending::Jamming {
                factor: 0.5,
                ..CrossingShearParams::default().jamming
            },
            ..Default::default()
        },
    ];
    for (p, word) in bad.iter().zip(["stiffness", "angle", "width", "factor"]) {
        let e = p.validate().unwrap_err();
        assert!(e.contains(word), "{e}");
    }
    assert!(CrossingShearParams::default().validate().is_ok());
    let topo = Topology::weave(WeavePattern::Plain, 3, 3).unwrap();
    let params = YarnParams::sweater();
    let layout = Layout::new(&topo, &LayoutParams::new(W, params.radius)).unwrap();
    let forces = ForceSet {
        crossing_shear_params: bad[0],
        ..ForceSet::default()
    };
    let e = Simulator::new(topo, &layout, params, forces, StepSettings::default())
        .err()
        .expect("invalid shear stiffness is an error");
    assert!(e.to_string().contains("stiffness"), "{e}");
}

/// Which fabrics get crossing-shear terms: a `4 × 3` weave gets one per quadrant, `4 (w − 1)
/// (h − 1) = 24` (interior crossings 4, edges 2, corners 1), all at rest (zero energy and
/// force) in the layout; none when the flag is off, and a knit never gets any.
#[test]
fn crossing_shear_terms_only_for_weaves_with_the_flag() {
    let params = YarnParams::sweater();
    let count = |topo: &Topology, forces: &ForceSet| {
        let layout = Layout::new(topo, &LayoutParams::new(W, params.radius)).unwrap();
        let dofs = DofMap::new(topo);
        let q = State::from_layout(topo, &dofs, &layout).q;
        let terms = build_terms(topo, &dofs, &params, forces, &q);
        let shear: Vec<usize> = (0..terms.len())
            .filter(|&k| terms.kind(k) == TermKind::CrossingShear)
            .collect();
        let g = terms.gradient(&q);
        let energy: f64 = shear.iter().map(|&k| terms.term_energy(k, &q)).sum();
        (
            shear.len(),
            energy,
            g.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        )
    };
    let weave = Topology::weave(WeavePattern::Twill { over: 2, under: 1 }, 4, 3).unwrap();
    let per_node: usize = (0..weave.nodes.len())
        .map(|n| quadrants(&weave, n).len())
        .sum();
    assert_eq!(per_node, 24);
    let no_gravity = ForceSet {
        gravity: false,
        ..ForceSet::default()
    };
    let (n, energy, max_force) = count(&weave, &no_gravity);
    assert_eq!(n, 24);
    assert!(
        energy.abs() < 1e-30 && max_force < 1e-15,
        "{energy} {max_force}"
    );
    let off = ForceSet {
        crossing_shear: false,
        ..no_gravity
    };
    assert_eq!(count(&weave, &off).0, 0);
    let knit = Topology::knit(&Chart::stockinette(3, 3).unwrap());
    assert_eq!(count(&knit, &ForceSet::default()).0, 0);
}

/// The assembled potential of a 3 × 3 plain weave with every term (crossing shear
/// included), at a perturbed layout: gradient vs central differences of the energy on every
/// DOF, Hessian vs central differences of the gradient on every column.
#[test]
fn assembled_weave_potential() {
    let topo = Topology::weave(WeavePattern::Plain, 3, 3).unwrap();
    let params = YarnParams::sweater();
    let layout = Layout::new(&topo, &LayoutParams::new(W, params.radius)).unwrap();
    let dofs = DofMap::new(&topo);
    let rest = State::from_layout(&topo, &dofs, &layout);
    let pot = build_terms(&topo, &dofs, &params, &ForceSet::default(), &rest.q);
    let mut q = rest.q.clone();
    for n in 0..topo.nodes.len() {
        let i = dofs.x(n);
        for k in 0..3 {
            q[i + k] += 3e-4 * ((7 * n + 3 * k) as f64 * 0.37).sin();
        }
        for s in 0..topo.nodes[n].passes.len() {
            q[dofs.u(n, s)] += 5e-5 * ((5 * n + s) as f64 * 0.71).cos();
        }
    }
    let shear: f64 = pot
        .energy_by_kind(&q)
        .iter()
        .filter(|(k, _)| *k == TermKind::CrossingShear)
        .map(|(_, e)| *e)
        .sum();
    assert!(shear > 0.0);
    let mut asm = Assembler::new(&pot).unwrap();
    let assembled = asm.assemble(&pot, &q, false).unwrap();
    let gradient = assembled.gradient.to_vec();
    let n = pot.n_dofs();
    let h = assembled.hessian;
    let mut dense = vec![0.0; n * n];
    for j in 0..n {
        let col = h.col_ptr()[j]..h.col_ptr()[j + 1];
        for (idx, &i) in h.row_idx()[col.clone()].iter().enumerate() {
            let v = h.val()[col.start + idx];
            dense[i + n * j] = v;
            dense[j + n * i] = v;
        }
    }
    let g_typ = gradient.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let opts = FdOptions {
        step: 1e-8,
        rtol: 1e-6,
        atol: 1e-9 * g_typ,
    };
    let ge =
        check_gradient(|x| pot.energy(x), &gradient, &q, &opts).unwrap_or_else(|e| panic!("{e}"));
    let asm2 = std::cell::RefCell::new(Assembler::new(&pot).unwrap());
    let h_typ = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let hopts = FdOptions {
        step: 1e-8,
        rtol: 1e-5,
        atol: 1e-9 * h_typ,
    };
    let he = check_hessian(
        |x| asm2.borrow_mut().gradient(&pot, x).unwrap().1.to_vec(),
        &dense,
        &q,
        &hopts,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "assembled weave: {n} DOFs, shear energy {shear:.3e} J, gradient rel. error {ge:.2e}, \
         Hessian rel. error {he:.2e}"
    );
}

/// Trellis shear of a `5 × 5` plain weave (Table 1 sweater yarn, 3 mm spacing, no
/// gravity): the bottom weft is clamped, the top weft (height H = 12 mm) is driven along the
/// arc `(H sin γ, H cos γ)` that keeps every yarn length (the pin-jointed trellis), and
/// every crossing is solved to static equilibrium at each γ. The work-conjugate clamp
/// moment `M(γ) = dE/dγ = −F_top · dX/dγ`:
///
/// - without crossing shear the trellis is a mechanism: M = 0 to round-off;
/// - with it, M grows linearly with slope ≈ the trellis value `Σ k_x L` over the 64
///   quadrants (free side edges may relax it a little);
/// - past the jamming angle (π/3 + 0.1 rad) the slope is ≥ 300× larger (×1000 in the
///   profile; measured ≈ 576× with the compliance of the yarns and free edges).
///
/// The static solves use per-stencil SPD projection: at the onset of jamming plain Newton
/// (the simulator's default) does not converge in 200 iterations.
#[test]
fn plain_weave_resists_shear_and_jams() {
    let (n, spacing) = (5usize, W);
    let h = (n - 1) as f64 * spacing;
    let mut params = YarnParams::sweater();
    params.gravity = Vector3::zeros();
    let build = |shear: bool| {
        let topo = Topology::weave(WeavePattern::Plain, n, n).unwrap();
        let layout = Layout::new(&topo, &LayoutParams::new(spacing, params.radius)).unwrap();
        let forces = ForceSet {
            crossing_shear: shear,
            ..ForceSet::default()
        };
        let mut settings = StepSettings::default();
        settings.newton.project_spd = true;
        let mut sim = Simulator::new(topo, &layout, params, forces, settings).expect("simulator");
        let bottom: Vec<usize> = (0..n).collect();
        let top: Vec<usize> = (0..n).map(|i| (n - 1) * n + i).collect();
        sim.pin_nodes(&bottom).unwrap();
        sim.pin_nodes(&top).unwrap();
        (sim, top)
    };
    // Moves every node by the trellis increment from γ₀ to γ (the trellis itself is an
    // exact equilibrium without shear; with it, the increment predicts the next static
    // solve from the last equilibrium).
    let set_trellis = |sim: &mut Simulator, from: f64, gamma: f64| {
        let mut state = sim.state().clone();
        for node in 0..n * n {
            let x = sim.dofs().x(node);
            let y = (node / n) as f64 * spacing;
            state.q[x] += y * (gamma.sin() - from.sin());
            state.q[x + 1] += y * (gamma.cos() - from.cos());
        }
        sim.set_state(state).unwrap();
    };
    let moment = |sim: &Simulator, top: &[usize], gamma: f64| {
        let f = sim.force_on_nodes(top);
        -(f.x * h * gamma.cos() - f.y * h * gamma.sin())
    };
    // Without crossing shear.
    let (mut free, top) = build(false);
    set_trellis(&mut free, 0.0, 0.3);
    let m_free = moment(&free, &top, 0.3);
    // With crossing shear: quasi-static sweep.
    let (mut sim, top) = build(true);
    let start = std::time::Instant::now();
    let mut curve = Vec::new();
    for k in 0..=26 {
        let gamma = 0.05 * k as f64;
        set_trellis(
            &mut sim,
            curve.last().map_or(0.0, |c: &(f64, f64)| c.0),
            gamma,
        );
        sim.solve_static()
            .unwrap_or_else(|e| panic!("γ = {gamma}: {e}"));
        curve.push((gamma, moment(&sim, &top, gamma)));
    }
    let elapsed = start.elapsed().as_secs_f64();
    let slope = |a: usize, b: usize| (curve[b].1 - curve[a].1) / (curve[b].0 - curve[a].0);
    let soft = slope(2, 12); // γ 0.1 → 0.6
    let jammed = slope(24, 26); // γ 1.2 → 1.3 (jammed from π/3 + 0.1 ≈ 1.147)
    let s = CrossingShearParams::default();
    let trellis = 64.0 * s.stiffness * spacing;
    eprintln!(
        "trellis shear 5×5: M(0.3) = {:.3e} N·m (no shear: {m_free:.1e}); slope {soft:.4e} \
         below jamming (trellis Σ k_x L = {trellis:.4e}), {jammed:.4e} past it, ratio {:.1}; \
         {} static solves in {elapsed:.2} s",
        curve[6].1,
        jammed / soft,
        curve.len()
    );
    for (g, m) in &curve {
        eprintln!("  γ {g:.2}  M {m:.5e}");
    }
    assert!(curve[6].1 > 0.0);
    assert!(m_free.abs() < 1e-9 * curve[6].1, "mechanism: {m_free:e}");
    assert!(
        soft > 0.8 * trellis && soft < 1.0001 * trellis,
        "{soft} vs {trellis}"
    );
    assert!(jammed > 300.0 * soft, "ratio {}", jammed / soft);
}
