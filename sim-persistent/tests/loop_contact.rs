//! Contact between adjacent loops ([`sim_persistent::forces::loop_contact`]): asserting
//! finite-difference checks of the penalty, its one-sidedness and C² onset, the persistent
//! candidate pairs, and the assembled swatch with the term switched on.

use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::Stencil;
use rod::fd::{FdOptions, assert_stencil_derivatives};
use sim_persistent::chart::Chart;
use sim_persistent::forces::loop_contact::{LoopContact, candidate_pairs};
use sim_persistent::forces::{ForceSet, Potential, TermKind, build_terms};
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::state::{DofMap, State};
use sim_persistent::topology::Topology;
use sim_persistent::weave::WeavePattern;

/// Contact distance 2R of the Table 1 sweater yarn (m).
const D: f64 = 1.5e-3;

fn stencil() -> LoopContact {
    LoopContact {
        stiffness: YarnParams::sweater().loop_contact_stiffness,
        distance: D,
    }
}

fn pack(a: Vector3<f64>, b: Vector3<f64>) -> SVector<f64, 6> {
    SVector::from_column_slice(&[a.x, a.y, a.z, b.x, b.y, b.z])
}

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x000c_1217),
        failure_persistence: None,
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config(256))]

    /// Gradient and Hessian against central differences, for distances from 0.2 D to
    /// 0.999 D (in contact) in any direction.
    #[test]
    fn penalty_derivatives(xa in (-D..D, -D..D, -D..D), dir in (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
                           frac in 0.2..0.999f64) {
        let dir = Vector3::new(dir.0, dir.1, dir.2);
        prop_assume!(dir.norm() > 0.1);
        let xa = Vector3::new(xa.0, xa.1, xa.2);
        let xb = xa + dir.normalize() * frac * D;
        let r = assert_stencil_derivatives(&stencil(), &pack(xa, xb), D);
        prop_assert!(r.gradient_rel_error < 1e-5 && r.hessian_rel_error < 1e-5);
    }
}

/// Out of contact (d ≥ D) the term is exactly zero, energy, gradient and Hessian; at the
/// onset the energy, the force and the stiffness all vanish (C²), and the force grows as
/// k_c p²: at 10 % penetration it pushes the nodes apart with k_c (0.1 D)².
#[test]
fn one_sided_and_c2_at_the_onset() {
    let s = stencil();
    let a = Vector3::new(0.1e-3, -0.2e-3, 0.05e-3);
    let n = Vector3::new(1.0, 2.0, -0.5).normalize();
    for d in [D, 1.001 * D, 3.0 * D] {
        let e = s.eval(&pack(a, a + n * d));
        assert_eq!(e.energy, 0.0);
        assert_eq!(e.gradient.amax(), 0.0);
        assert_eq!(e.hessian.amax(), 0.0);
    }
    // Just inside: everything ~ p, p², p³ → 0 continuously.
    let p = 1e-9 * D;
    let e = s.eval(&pack(a, a + n * (D - p)));
    assert!(e.energy <= s.stiffness * p.powi(3));
    assert!(e.gradient.amax() <= 2.0 * s.stiffness * p * p);
    assert!(e.hessian.amax() <= 4.0 * s.stiffness * p);
    // 10 % penetration: force on b along +n (apart) of k_c (0.1 D)².
    let e = s.eval(&pack(a, a + n * 0.9 * D));
    let force_b = -Vector3::new(e.gradient[3], e.gradient[4], e.gradient[5]);
    let expected = s.stiffness * (0.1 * D).powi(2);
    assert!(
        (force_b - n * expected).norm() < 1e-12 * expected,
        "{force_b:?}"
    );
    eprintln!("loop contact: force at 10 % penetration {expected:.3e} N");
    // Coincident nodes: finite energy, no direction, zero derivatives (documented).
    let e = s.eval(&pack(a, a));
    assert!((e.energy - s.stiffness * D.powi(3) / 3.0).abs() < 1e-12 * e.energy);
    assert_eq!(e.gradient.amax(), 0.0);
}

/// The candidate pairs of a knit: along each interior row boundary, the node pairs
/// between consecutive contacts not joined by a segment — three per gap (the head joins
/// `hi`–`hi` within a column, the sinker `lo`–`lo` between columns), `2w − 1` gaps per
/// boundary. None for a weave. Every pair is two distinct stacked nodes, no pair repeats,
/// no pair is a segment, and in the default layout every pair is out of contact.
#[test]
fn candidate_pairs_of_a_knit() {
    let chart = Chart::stockinette(4, 3).unwrap();
    let topo = Topology::knit(&chart);
    let pairs = candidate_pairs(&topo);
    let (w, h) = (4, 3);
    assert_eq!(pairs.len(), (h - 1) * (2 * w - 1) * 3);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, 0.75e-3)).unwrap();
    let closest = pairs
        .iter()
        .map(|&[a, b]| (layout.positions[a] - layout.positions[b]).norm())
        .fold(f64::INFINITY, f64::min);
    eprintln!("closest candidate pair in the layout: {closest:.3e} m (2R = {D:.1e} m)");
    assert!(closest > D);
    let segments: std::collections::HashSet<(usize, usize)> = topo
        .segments()
        .map(|(y, i)| {
            let p = &topo.yarns[y].passes;
            (p[i].node.min(p[i + 1].node), p[i].node.max(p[i + 1].node))
        })
        .collect();
    let mut seen = std::collections::HashSet::new();
    for &[a, b] in &pairs {
        assert!(a < b);
        assert!(topo.nodes[a].passes.len() == 2 && topo.nodes[b].passes.len() == 2);
        assert!(!segments.contains(&(a, b)));
        assert!(seen.insert((a, b)), "pair {a}, {b} repeats");
    }
    let weave = Topology::weave(WeavePattern::Plain, 3, 3).unwrap();
    assert!(candidate_pairs(&weave).is_empty());
}

/// The term in a real swatch: built only when switched on (one per candidate pair), zero
/// in the default layout (the candidates sit 1.6–2.0 mm apart, 2R = 1.5 mm), and active in
/// a layout squeezed to 85 % of its width, where the assembled gradient of the
/// loop-contact terms matches central differences of their summed energy on every DOF
/// (DOF bookkeeping) and pushes the first and last column apart (negative x-force on the left, positive on the
/// right: the penalty resists the squeeze). A short simulation of a squeezed free rib
/// with the term on runs and widens the swatch compared with the same run without it.
#[test]
fn swatch_with_loop_contact() {
    let chart = Chart::rib(6, 4, 2, 2).unwrap();
    let topo = Topology::knit(&chart);
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    let dofs = DofMap::new(&topo);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).unwrap();
    let q = State::from_layout(&topo, &dofs, &layout).q;
    let on = ForceSet {
        gravity: false,
        loop_contact: true,
        ..ForceSet::default()
    };
    assert!(!ForceSet::default().loop_contact, "off by default");
    let terms = build_terms(&topo, &dofs, &params, &on, &q);
    let contact: Vec<usize> = (0..terms.len())
        .filter(|&k| terms.kind(k) == TermKind::LoopContact)
        .collect();
    assert_eq!(contact.len(), candidate_pairs(&topo).len());
    let energy: f64 = contact.iter().map(|&k| terms.term_energy(k, &q)).sum();
    assert_eq!(energy, 0.0, "inactive in the default layout");
    let mut squeezed = layout.clone();
    for p in &mut squeezed.positions {
        p.x *= 0.85;
    }
    let qs = State::from_layout(&topo, &dofs, &squeezed).q;
    let active = contact
        .iter()
        .filter(|&&k| terms.term_energy(k, &qs) > 0.0)
        .count();
    assert!(active > 0);
    let mut only = Potential::new(dofs.n_dofs());
    for (k, c) in terms.iter_of::<LoopContact, 6>() {
        let d: [usize; 6] = terms.dofs(k).try_into().unwrap();
        only.push(TermKind::LoopContact, *c, d);
    }
    let g = only.gradient(&qs);
    let fx = |cols: std::ops::Range<usize>| -> f64 {
        (0..topo.nodes.len())
            .filter(|n| cols.contains(&((n / 4) % 6)))
            .map(|n| -g[dofs.x(n)])
            .sum()
    };
    // The assembled gradient (DOF bookkeeping) against central differences of the summed
    // energy, on every DOF.
    let energy = |x: &[f64]| only.energy(x);
    let gmax = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = rod::fd::check_gradient(energy, &g, &qs, &FdOptions::for_scale(D, gmax))
        .unwrap_or_else(|e| panic!("{e}"));
    eprintln!("squeezed rib: assembled loop-contact gradient rel. FD error {err:.1e}");
    let (left, right) = (fx(0..1), fx(5..6));
    eprintln!(
        "squeezed rib: {active} active pairs, x-force left column {left:.3e} N, right {right:.3e} N"
    );
    assert!(left < 0.0 && right > 0.0);
    // Dynamics: 40 steps of the squeezed swatch, with and without the contact.
    let width = |forces: ForceSet| -> f64 {
        let mut settings = StepSettings {
            rayleigh_alpha: 10.0,
            wrapping_ramp_time: 0.0,
            ..StepSettings::default()
        };
        settings.newton.gradient_abs_tol = 1e-7;
        let mut sim = Simulator::new(topo.clone(), &squeezed, params, forces, settings).unwrap();
        for _ in 0..40 {
            sim.step().unwrap();
        }
        let s = sim.state();
        let pos: Vec<_> = (0..topo.nodes.len())
            .map(|n| sim.dofs().position(&s.q, n))
            .collect();
        sim_persistent::measure::course_width(&topo, &pos).unwrap()
    };
    let off = ForceSet {
        gravity: false,
        wrapping: false,
        ..ForceSet::default()
    };
    let with = ForceSet {
        loop_contact: true,
        ..off
    };
    let (w_off, w_on) = (width(off), width(with));
    eprintln!(
        "squeezed rib after 40 steps: width {w_off:.4e} m without, {w_on:.4e} m with loop contact"
    );
    assert!(w_on > w_off);
}
