//! Asserting finite-difference checks (through `rod::fd`) of every force term of the
//! persistent-contact model, on seeded random configurations (proptest, fixed seed), and of
//! the assembled potential of a real swatch (which also checks the DOF bookkeeping).

use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::fd::{FdOptions, assert_stencil_derivatives, check_gradient, check_hessian};
use sim_persistent::chart::Chart;
use sim_persistent::forces::friction::{AnchoredSpring, ParallelSpring, Slip};
use sim_persistent::forces::gravity::Gravity;
use sim_persistent::forces::quadratic::Quadratic;
use sim_persistent::forces::segment_floor::SegmentFloor;
use sim_persistent::forces::stitch_length::StitchLength;
use sim_persistent::forces::wrapping::{StitchWrap, rest_angle_sign, wrap_pairs};
use sim_persistent::forces::{ForceSet, Potential, TermKind, build_terms};
use sim_persistent::forces::{bending::bending_stencil, stretch::stretch_stencil};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::state::{DofMap, State};
use sim_persistent::topology::{Side, Topology};
use solver::{Assembler, Problem};

/// Fixed seed, no failure files written into the source tree.
fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x000c_1210),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Length scale: yarn-sized (mm).
const L: f64 = 1e-3;

fn v3(range: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn pack<const N: usize>(parts: &[&[f64]]) -> SVector<f64, N> {
    let flat: Vec<f64> = parts.iter().flat_map(|p| p.iter().copied()).collect();
    SVector::from_column_slice(&flat)
}

proptest! {
    #![proptest_config(config(128))]

    #[test]
    fn gravity_on_a_sliding_segment(x0 in v3(L), x1 in v3(L), u0 in -L..L, du in 0.2*L..3.0*L, g in v3(10.0)) {
        let s = Gravity { density: 1.7e-3, g };
        let q = pack::<8>(&[x0.as_slice(), &[u0], x1.as_slice(), &[u0 + du]]);
        assert_stencil_derivatives(&s, &q, L);
    }

    #[test]
    fn stretch_with_table1_yarn(x0 in v3(L), dir in v3(1.0), len in 0.3*L..2.0*L, strain in -0.3..0.3f64, u0 in -L..L) {
        prop_assume!(dir.norm() > 0.1);
        let x1 = x0 + dir.normalize() * len;
        let q = pack::<8>(&[x0.as_slice(), &[u0], x1.as_slice(), &[u0 + len / (1.0 + strain)]]);
        assert_stencil_derivatives(&stretch_stencil(&YarnParams::sweater()), &q, L);
    }

    #[test]
    fn bending_with_jamming_past_half_pi(x1 in v3(L), a in v3(1.0), b in v3(1.0), la in 0.3*L..2.0*L,
                                         lb in 0.3*L..2.0*L, u0 in -L..L, du in 0.8..1.5f64) {
        prop_assume!(a.norm() > 0.1 && b.norm() > 0.1);
        let (x0, x2) = (x1 - a.normalize() * la, x1 + b.normalize() * lb);
        let theta = rod::geometry::turning_angle(&(x1 - x0), &(x2 - x1));
        prop_assume!(theta < 3.0);
        // Stay off the exact ends of the smooth jamming transition, where φ''' jumps.
        let j = YarnParams::sweater().jamming;
        prop_assume!((theta - j.angle).abs() > 1e-4 && (theta - j.angle - j.width).abs() > 1e-4);
        let q = pack::<12>(&[x0.as_slice(), &[u0], x1.as_slice(), &[u0 + la], x2.as_slice(), &[u0 + du * (la + lb)]]);
        assert_stencil_derivatives(&bending_stencil(&YarnParams::sweater()), &q, L);
    }

    #[test]
    fn stitch_contact_length_eq6(u0 in -L..L, l in 0.2*L..3.0*L, rest in 0.2*L..3.0*L, k in 0.1..50.0f64) {
        let s = StitchLength { stiffness: k, rest_length: rest };
        assert_stencil_derivatives(&s, &pack::<2>(&[&[u0, u0 + l]]), L);
    }

    #[test]
    fn friction_anchored_spring_eq5(u in -L..L, anchor in -L..L, k in 1.0..1e5f64) {
        let s = AnchoredSpring::new(k, anchor);
        assert_stencil_derivatives(&s, &pack::<1>(&[&[u]]), L);
    }

    /// The material-length floor, on both sides of its onset (active below `L_min`).
    #[test]
    fn segment_material_floor(u0 in -L..L, l in -0.2*L..2.0*L, floor in 0.1*L..L, k in 1.0..1e7f64) {
        let s = SegmentFloor { stiffness: k, floor };
        prop_assume!((l - floor).abs() > 1e-3 * L);
        assert_stencil_derivatives(&s, &pack::<2>(&[&[u0, u0 + l]]), L);
    }

    /// The slipping mode of the return mapping: the constant Coulomb force.
    #[test]
    fn friction_slipping_coordinate(u in -L..L, anchor in -L..L, k in 1.0..1e5f64,
                                    force in 0.0..1e-2f64, positive in proptest::bool::ANY) {
        let mut s = AnchoredSpring::new(k, anchor);
        let direction = if positive { 1.0 } else { -1.0 };
        s.slip = Some(Slip { direction, force });
        assert_stencil_derivatives(&s, &pack::<1>(&[&[u]]), L);
    }

    /// Eq. 5 for parallel stacked yarns: the spring on `Δu = u_a − u_b`, sticking or slipping.
    #[test]
    fn friction_parallel_pair_eq5(ua in -L..L, ub in -L..L, anchor in -L..L, k in 1.0..1e5f64,
                                  force in 0.0..1e-2f64, mode in 0..3usize) {
        let mut s = ParallelSpring::new(k, anchor);
        s.spring.slip = match mode {
            0 => None,
            1 => Some(Slip { direction: 1.0, force }),
            _ => Some(Slip { direction: -1.0, force }),
        };
        assert_stencil_derivatives(&s, &pack::<2>(&[&[ua, ub]]), L);
        // The energy depends on the difference only (a common slide is free).
        let shifted = rod::Stencil::energy(&s, &pack::<2>(&[&[ua + 0.3 * L, ub + 0.3 * L]]));
        let e = rod::Stencil::energy(&s, &pack::<2>(&[&[ua, ub]]));
        prop_assert!((e - shifted).abs() <= 1e-9 * (1.0 + e.abs()));
    }

    #[test]
    fn stitch_wrapping_eq2(x0 in v3(L), axis in v3(1.0), len in 0.3*L..1.5*L, d4 in v3(1.5 * L), d3 in v3(1.5 * L),
                           rest in -2.0..2.0f64) {
        prop_assume!(axis.norm() > 0.1);
        let x1 = x0 + axis.normalize() * len;
        let (x4, x3) = (x0 + d4, x1 + d3);
        let t = axis.normalize();
        // Wings well away from the hinge line, and off the branch cut ψ = ±π.
        prop_assume!((d4 - t * t.dot(&d4)).norm() > 0.3 * L && (d3 - t * t.dot(&d3)).norm() > 0.3 * L);
        let q = pack::<12>(&[x0.as_slice(), x1.as_slice(), x4.as_slice(), x3.as_slice()]);
        let arr: [f64; 12] = std::array::from_fn(|k| q[k]);
        prop_assume!(StitchWrap::angle(&arr).abs() < 3.0);
        let s = StitchWrap { stiffness: 1e-2, rest_length: len, rest_angle: rest };
        assert_stencil_derivatives(&s, &q, L);
    }

    #[test]
    fn inertia_quadratic_form(x0 in v3(L), x1 in v3(L), u0 in -L..L, du in 0.2*L..3.0*L, shift in v3(L)) {
        let q = pack::<8>(&[x0.as_slice(), &[u0], x1.as_slice(), &[u0 + du]]);
        let m = sim_persistent::state::segment_mass_matrix(1.7e-3, &q) * 1e6;
        let center = q + pack::<8>(&[shift.as_slice(), &[0.3 * L], (-shift).as_slice(), &[-0.1 * L]]);
        let form = Quadratic { matrix: m, center };
        let moved = q + pack::<8>(&[&[0.2 * L; 8]]);
        assert_stencil_derivatives(&form, &moved, L);
    }
}

/// The signed wrapping angle has the magnitude of Eq. 13, `arccos(n_a · n_b)`, and the
/// expected values for a hinge along +z with `q₄` beside `q₀` along +x.
#[test]
fn wrapping_angle_matches_eq13() {
    let angle = |d3: [f64; 3]| {
        let q = [
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            1.0,
            1.0,
            0.0,
            0.0,
            d3[0],
            d3[1],
            1.0 + d3[2],
        ];
        StitchWrap::angle(&q)
    };
    // Opposite sides of the hinge: flat, unwrapped.
    assert!(angle([-1.0, 0.0, 0.0]).abs() < 1e-15);
    // A quarter turn either way: ∓π/2.
    assert!((angle([0.0, 1.0, 0.3]) + std::f64::consts::FRAC_PI_2).abs() < 1e-14);
    assert!((angle([0.0, -1.0, -0.2]) - std::f64::consts::FRAC_PI_2).abs() < 1e-14);
    // Magnitude = Eq. 13 on a general configuration.
    let x: [f64; 12] = [
        0.1, -0.2, 0.05, 0.3, 0.4, 0.9, -0.5, 0.2, 0.1, 0.7, -0.1, 1.2,
    ];
    let v = |k: usize| Vector3::new(x[3 * k], x[3 * k + 1], x[3 * k + 2]);
    let (x0, x1, x4, x3) = (v(0), v(1), v(2), v(3));
    let na = (x4 - x1).cross(&(x0 - x1)).normalize();
    let nb = (x0 - x1).cross(&(x3 - x1)).normalize();
    assert!((StitchWrap::angle(&x).abs() - na.dot(&nb).acos()).abs() < 1e-14);
}

/// The wrapping pairs of the stitch contacts of a knit: the contact's nodes and a neighbour
/// of each on the right yarn; at the two side edges, where the upper yarn (one per row)
/// starts or ends, only the pair that does not need the missing neighbour.
#[test]
fn wrapping_pairs_of_a_knit() {
    let topo = Topology::knit(&Chart::rib(4, 3, 1, 1).unwrap());
    let mut n_pairs = 0;
    for sc in &topo.stitch_contacts {
        let yarn_start = sc.column == 0 && sc.side == Side::Left;
        let yarn_end = sc.column == 3 && sc.side == Side::Right;
        let [first, second]: [Option<[usize; 4]>; 2] = wrap_pairs(&topo, sc).try_into().unwrap();
        assert_eq!(first.is_none(), yarn_start, "{sc:?}");
        assert_eq!(second.is_none(), yarn_end, "{sc:?}");
        let [q0, q1] = sc.nodes;
        let next = |y: usize, n: usize, o: isize| {
            let i = topo.pass_index(n, y).unwrap();
            topo.yarns[y].passes[i.checked_add_signed(o).unwrap()].node
        };
        if let Some(p) = first {
            assert_eq!(
                p,
                [
                    q0,
                    q1,
                    next(sc.upper.yarn, q0, -1),
                    next(sc.lower[0].yarn, q1, 1)
                ]
            );
        }
        if let Some(p) = second {
            assert_eq!(
                p,
                [
                    q1,
                    q0,
                    next(sc.upper.yarn, q1, 1),
                    next(sc.lower[0].yarn, q0, -1)
                ]
            );
        }
        // Four distinct nodes per pair.
        for p in [first, second].into_iter().flatten() {
            n_pairs += 1;
            let mut s = p.to_vec();
            s.sort_unstable();
            s.dedup();
            assert_eq!(s.len(), 4);
        }
    }
    assert_eq!(n_pairs, 2 * topo.stitch_contacts.len() - 2 * 2);
}

#[test]
fn friction_slip_moves_the_anchor_to_the_maximal_stick_position() {
    let mut s = AnchoredSpring::new(1e3, 0.0);
    // Stick: force 0.5 mN ≤ 1 mN.
    assert!(!s.update_anchor(0.5e-6, 1e-3));
    assert_eq!(s.anchor, 0.0);
    // Slip: force 3 mN > 1 mN; afterwards the spring force is exactly the bound.
    assert!(s.update_anchor(3e-6, 1e-3));
    assert!((s.stiffness * (3e-6 - s.anchor) - 1e-3).abs() < 1e-15);
    assert!(s.update_anchor(-5e-6, 1e-3));
    assert!((s.stiffness * (-5e-6 - s.anchor) + 1e-3).abs() < 1e-15);
}

/// The return-mapping modes: a sticking coordinate past the stick limit starts slipping in
/// the direction of its stretch, stays slipping while it stays past the limit on that side,
/// sticks again when it falls back inside, and `finish_step` puts a slipped anchor at the
/// maximal stick position. The energy is continuous (Huber) where the modes meet.
#[test]
fn friction_return_mapping_modes() {
    let (k, f) = (1e3, 1e-3); // stick limit F/k = 1 µm
    let mut s = AnchoredSpring::new(k, 0.0);
    assert!(!s.classify(0.5e-6, f));
    assert_eq!(s.slip, None);
    assert!(s.classify(-3e-6, f));
    assert_eq!(
        s.slip,
        Some(Slip {
            direction: -1.0,
            force: f
        })
    );
    // Still beyond the limit on the same side: unchanged (no mode change counted).
    assert!(!s.classify(-2e-6, f));
    // Back inside the limit: sticks again.
    assert!(s.classify(-0.5e-6, f));
    assert_eq!(s.slip, None);
    // Jumping to the other side starts slipping there.
    assert!(s.classify(4e-6, f));
    assert_eq!(s.slip.map(|p| p.direction), Some(1.0));
    assert_eq!(s.anchor, 0.0, "classify never moves the anchor");
    assert!(s.finish_step(4e-6, f));
    assert_eq!(s.slip, None);
    assert!((k * (4e-6 - s.anchor) - f).abs() < 1e-15);
    // A sticking coordinate at the end of a step gets the explicit update (here: none).
    let anchor = s.anchor;
    assert!(!s.finish_step(anchor + 0.5e-6, f));
    assert_eq!(s.anchor, anchor);
    // Continuity of the energy at the stick limit.
    let at_limit = SVector::<f64, 1>::new(anchor + f / k);
    let stick = rod::Stencil::energy(&s, &at_limit);
    s.slip = Some(Slip {
        direction: 1.0,
        force: f,
    });
    assert!((rod::Stencil::energy(&s, &at_limit) - stick).abs() <= 1e-12 * stick.abs().max(1e-30));
}

/// The assembled gradient and Hessian of `pot` at `q` against central differences of the
/// energy (every DOF) and of the assembled gradient (every column); also checks the assembled
/// energy. Returns the worst relative errors (gradient, Hessian).
fn check_assembled(pot: &Potential, q: &[f64]) -> (f64, f64) {
    let mut asm = Assembler::new(pot).unwrap();
    let assembled = asm.assemble(pot, q, false).unwrap();
    let energy = assembled.energy;
    let gradient = assembled.gradient.to_vec();
    let n = pot.n_dofs();
    // Dense full Hessian from the stored lower triangle.
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
    assert!((energy - pot.energy(q)).abs() <= 1e-12 * energy.abs());
    let g_typ = gradient.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let opts = FdOptions {
        step: 1e-8,
        rtol: 1e-6,
        atol: 1e-9 * g_typ,
    };
    let ge = check_gradient(|x: &[f64]| pot.energy(x), &gradient, q, &opts)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut asm2 = Assembler::new(pot).unwrap();
    let grad_cell = std::cell::RefCell::new(|x: &[f64]| asm2.gradient(pot, x).unwrap().1.to_vec());
    let h_typ = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let hopts = FdOptions {
        step: 1e-8,
        rtol: 1e-5,
        atol: 1e-9 * h_typ,
    };
    let he = check_hessian(|x| (grad_cell.borrow_mut())(x), &dense, q, &hopts)
        .unwrap_or_else(|e| panic!("{e}"));
    (ge, he)
}

/// The assembled potential of a 3 × 3 seed-stitch swatch (every static term kind), at a
/// perturbed layout: gradient vs central differences of the energy on every DOF, Hessian vs
/// central differences of the gradient on every column.
#[test]
fn assembled_potential_of_a_swatch() {
    let chart = Chart::seed(3, 3).unwrap();
    let topo = Topology::knit(&chart);
    let params = YarnParams::sweater();
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).unwrap();
    let dofs = DofMap::new(&topo);
    let rest = State::from_layout(&topo, &dofs, &layout);
    let forces = ForceSet {
        loop_contact: true,
        segment_floor: true,
        ..ForceSet::default()
    };
    let pot = build_terms(&topo, &dofs, &params, &forces, &rest.q);
    let kinds: Vec<_> = pot
        .energy_by_kind(&rest.q)
        .iter()
        .map(|(k, _)| *k)
        .collect();
    assert_eq!(
        kinds.len(),
        8,
        "gravity, stretch, bending, stitch length, friction, wrapping, loop contact, \
         segment floor: {kinds:?}"
    );
    // Deterministic perturbation: 0.1 mm in x, 0.05 mm in u.
    let mut q = rest.q.clone();
    for n in 0..topo.nodes.len() {
        let i = dofs.x(n);
        for k in 0..3 {
            q[i + k] += 1e-4 * ((7 * n + 3 * k) as f64 * 0.37).sin();
        }
        for s in 0..topo.nodes[n].passes.len() {
            q[dofs.u(n, s)] += 5e-5 * ((5 * n + s) as f64 * 0.71).cos();
        }
    }
    // Every segment has its floor, on its two sliding coordinates; drain one segment below
    // the floor so that its term is active in the check.
    let segment_u: Vec<[usize; 2]> = topo
        .segments()
        .map(|(y, i)| {
            let p = &topo.yarns[y].passes;
            [
                dofs.u(p[i].node, p[i].slot),
                dofs.u(p[i + 1].node, p[i + 1].slot),
            ]
        })
        .collect();
    let floors: Vec<&[usize]> = (0..pot.len())
        .filter(|&k| pot.kind(k) == TermKind::SegmentFloor)
        .map(|k| pot.dofs(k))
        .collect();
    assert_eq!(floors.len(), segment_u.len());
    for (f, u) in floors.iter().zip(&segment_u) {
        assert_eq!(*f, u.as_slice());
    }
    let [u0, u1] = segment_u[1];
    q[u1] = q[u0] + 0.2e-3; // below L_min = R/2 = 0.375 mm
    let floor_energy = pot
        .energy_by_kind(&q)
        .into_iter()
        .find(|(k, _)| *k == TermKind::SegmentFloor)
        .map(|(_, e)| e);
    assert!(floor_energy.is_some_and(|e| e > 0.0), "{floor_energy:?}");
    let (ge, he) = check_assembled(&pot, &q);
    let n = pot.n_dofs();
    eprintln!(
        "assembled swatch: {n} DOFs, gradient rel. error {ge:.2e}, Hessian rel. error {he:.2e}"
    );
}

/// The assembled potential of charts with stacked stitches — every stitch kind, knitted flat
/// with one continuous yarn and in the round (stacked (3 + n)-DoF nodes, the parallel-pair
/// friction springs, reversed rows, the round's closing loop contact) — at a perturbed layout:
/// gradient vs central differences of the energy on every DOF, Hessian vs central differences
/// of the gradient on every column.
#[test]
fn assembled_potential_of_stacked_stitches() {
    use sim_persistent::topology::Construction;
    let chart =
        Chart::parse("K7\nK K2TOG YO SSK M1L K KFB\nP K3TOG S2KP SL\nK YO K2 YO K\n").unwrap();
    for construction in [Construction::Flat, Construction::Round] {
        let topo = Topology::knit_with(&chart, construction).unwrap();
        assert!(topo.nodes.iter().any(|n| n.passes.len() == 4));
        let params = YarnParams::sweater();
        let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).unwrap();
        let dofs = DofMap::new(&topo);
        let rest = State::from_layout(&topo, &dofs, &layout);
        let forces = ForceSet {
            loop_contact: true,
            ..ForceSet::default()
        };
        let pot = build_terms(&topo, &dofs, &params, &forces, &rest.q);
        assert!(pot.count(TermKind::ParallelFriction) > 0);
        let mut q = rest.q.clone();
        for n in 0..topo.nodes.len() {
            let i = dofs.x(n);
            for k in 0..3 {
                q[i + k] += 1e-4 * ((7 * n + 3 * k) as f64 * 0.37).sin();
            }
            for s in 0..topo.nodes[n].passes.len() {
                q[dofs.u(n, s)] += 5e-5 * ((5 * n + s) as f64 * 0.71).cos();
            }
        }
        let (ge, he) = check_assembled(&pot, &q);
        let n = pot.n_dofs();
        eprintln!(
            "{construction:?} stacked chart: {n} DOFs, gradient rel. error {ge:.2e}, Hessian rel. error {he:.2e}"
        );
    }
}

/// The sign convention of ψ₀ (`forces::wrapping`, "Sign of ψ₀ per contact"): on the layout
/// of a 1 × 1 rib (knit and purl columns), fold each pair's segments as in a real knit —
/// horizontal segments (sinker, head) to the back and vertical ones (legs) to the front by
/// half a loop width, mirrored for purls — and the signed wrapping angle of every pair of
/// every interior contact has the sign of [`rest_angle_sign`]; on the flat layout it is
/// small (below 0.5 rad: 0.33 rad where a sinker joins a knit and a purl column).
#[test]
fn folded_stitches_wrap_with_the_rest_angle_sign() {
    let chart = Chart::rib(4, 4, 1, 1).unwrap();
    let topo = Topology::knit(&chart);
    let w = 3e-3;
    let layout = Layout::new(&topo, &LayoutParams::new(w, 0.75e-3)).unwrap();
    let mut checked = 0;
    for sc in &topo.stitch_contacts {
        let sigma = sc.sign;
        for nodes in wrap_pairs(&topo, sc).into_iter().flatten() {
            let mut x: Vec<Vector3<f64>> = nodes.iter().map(|&n| layout.positions[n]).collect();
            let flat: [f64; 12] = std::array::from_fn(|k| x[k / 3][k % 3]);
            let flat_psi = StitchWrap::angle(&flat);
            assert!(flat_psi.abs() < 0.5, "{sc:?}: flat ψ = {flat_psi}");
            // Wings: x[2] hangs off x[0], x[3] off x[1].
            for (wing, base) in [(2, 0), (3, 1)] {
                let d = x[wing] - x[base];
                let horizontal = d.x.abs() > d.y.abs();
                let dz = if horizontal { -sigma } else { sigma } * 0.5 * w;
                x[wing].z += dz;
            }
            let folded: [f64; 12] = std::array::from_fn(|k| x[k / 3][k % 3]);
            let psi = StitchWrap::angle(&folded);
            assert!(psi.abs() > 0.3, "{sc:?}: ψ = {psi}");
            assert_eq!(psi.signum(), rest_angle_sign(sc), "{sc:?}: ψ = {psi}");
            checked += 1;
        }
    }
    assert_eq!(checked, 2 * topo.stitch_contacts.len() - 2 * 3);
}

/// The energy is Eq. 2 blended by the degenerate-wing weight with the energy of an
/// unwrapped pair, `½ k_w L (w (ψ − ψ₀)² + (1 − w) ψ₀²)`, with ψ from the cross-product
/// form of Eqs. 9–13 (the stencil itself evaluates it through dot and triple products); the
/// weight is ≈ 1 for well-opened wings and vanishes as a wing collapses onto the axis, where
/// the energy tends to `½ k_w L ψ₀²` (collapsing a wing sheds no wrapping energy).
#[test]
fn wrapping_energy_is_weighted_eq2() {
    let s = StitchWrap {
        stiffness: 1e-2,
        rest_length: 0.7e-3,
        rest_angle: 1.2,
    };
    let x: [f64; 12] = [
        0.1, -0.2, 0.05, 0.3, 0.4, 0.9, -0.5, 0.2, 0.1, 0.7, -0.1, 1.2,
    ];
    let q = SVector::<f64, 12>::from_column_slice(&x);
    let psi = StitchWrap::angle(&x);
    let w = StitchWrap::weight(&x);
    let expected = 0.5 * 1e-2 * 0.7e-3 * (w * (psi - 1.2).powi(2) + (1.0 - w) * 1.2 * 1.2);
    assert!((rod::Stencil::energy(&s, &q) - expected).abs() <= 1e-14 * expected);
    // Perpendicular wings: weight 1; a wing along the axis: weight 0.
    let open: [f64; 12] = [0., 0., 0., 0., 0., 1., 1., 0., 0., 0., 1., 1.];
    assert!((StitchWrap::weight(&open) - 1.0).abs() < 1e-14);
    let collapsed: [f64; 12] = [0., 0., 0., 0., 0., 1., 0., 0., -1., 0., 1., 1.];
    assert!(StitchWrap::weight(&collapsed).abs() < 1e-14);
    let unwrapped = 0.5 * 1e-2 * 0.7e-3 * 1.2 * 1.2;
    let at_collapse = rod::Stencil::energy(&s, &SVector::<f64, 12>::from_column_slice(&collapsed));
    assert!(
        (at_collapse - unwrapped).abs() <= 1e-12 * unwrapped,
        "{at_collapse}"
    );
}

/// Yarn self-contact ([`sim_persistent::forces::yarn_contact`]) on a 4 × 4 stockinette laid
/// out with its rows squeezed to 1.2 d, so that the legs of neighbouring rows come within
/// the contact distance: the pair search finds active pairs (positive energy), none of them
/// between segments that share a node, and the assembled contact potential's gradient and
/// Hessian match central differences on every DOF.
#[test]
fn assembled_yarn_contact_of_a_squeezed_swatch() {
    use sim_persistent::forces::yarn_contact::{Segments, YarnContact};
    let chart = Chart::stockinette(4, 4).unwrap();
    let topo = Topology::knit(&chart);
    let params = YarnParams::sweater();
    let d = 2.0 * params.radius;
    let mut lp = LayoutParams::new(2.0 * d, params.radius);
    lp.row_height = 1.2 * d;
    lp.out_of_plane = 0.5 * d;
    let layout = Layout::new(&topo, &lp).unwrap();
    let dofs = DofMap::new(&topo);
    let rest = State::from_layout(&topo, &dofs, &layout);
    let contact = YarnContact::for_yarn(params.radius, params.bending_stiffness());
    let segments = Segments::new(&topo);
    let positions: Vec<_> = (0..topo.nodes.len())
        .map(|n| dofs.position(&rest.q, n))
        .collect();
    let pot = sim_persistent::forces::yarn_contact_terms(&contact, &segments, &dofs, &positions);
    assert!(!pot.is_empty(), "no contact pairs found");
    for k in 0..pot.len() {
        let nodes: Vec<usize> = pot.dofs(k).chunks(3).map(|c| c[0]).collect();
        assert!(
            !nodes[..2].iter().any(|n| nodes[2..].contains(n)),
            "pair {k} shares a node"
        );
    }
    let energy = pot.energy(&rest.q);
    assert!(energy > 0.0, "no active pair: {energy}");
    let (ge, he) = check_assembled(&pot, &rest.q);
    eprintln!(
        "yarn contact: {} pairs, energy {energy:.3e} J, gradient rel. error {ge:.2e}, Hessian \
         rel. error {he:.2e}",
        pot.len()
    );
}
