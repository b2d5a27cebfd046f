//! Asserting finite-difference checks of every rod energy term on seeded random
//! configurations (proptest with a fixed seed), through the one harness in `rod::fd`.

use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::bending::{AngleBending, BinormalBending, Jamming};
use rod::contact::{BarrierPhase, EdgeContact, Simpson};
use rod::fd::assert_stencil_derivatives;
use rod::geometry::Frame;
use rod::stretch::{Segment, SlidingSegment, StretchLaw};

/// Fixed seed, no failure files written into the source tree.
fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x5eed_2026),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Length scale of test configurations: yarn-sized (mm).
const L: f64 = 1e-3;

fn v3(range: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn pack<const N: usize>(parts: &[&[f64]]) -> SVector<f64, N> {
    let flat: Vec<f64> = parts.iter().flat_map(|p| p.iter().copied()).collect();
    SVector::from_column_slice(&flat)
}

fn laws() -> impl Strategy<Value = StretchLaw> {
    prop_oneof![
        (0.1..10.0f64).prop_map(|k| StretchLaw::Linear { k }),
        (0.1..2.0f64, 5.0..50.0f64, 0.02..0.3f64)
            .prop_map(|(k1, k2, onset)| StretchLaw::TwoPhase { k1, k2, onset }),
    ]
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn segment_stretch(x0 in v3(L), dir in v3(1.0), len in 0.3*L..2.0*L, strain in -0.4..0.6f64, law in laws()) {
        prop_assume!(dir.norm() > 0.1);
        let x1 = x0 + dir.normalize() * len;
        let s = Segment { rest_length: len / (1.0 + strain), law };
        assert_stencil_derivatives(&s, &pack::<6>(&[x0.as_slice(), x1.as_slice()]), L);
    }

    #[test]
    fn sliding_segment_stretch(x0 in v3(L), dir in v3(1.0), len in 0.3*L..2.0*L,
                               strain in -0.4..0.6f64, u0 in -L..L, law in laws()) {
        prop_assume!(dir.norm() > 0.1);
        let x1 = x0 + dir.normalize() * len;
        let u1 = u0 + len / (1.0 + strain);
        let q = pack::<8>(&[x0.as_slice(), &[u0], x1.as_slice(), &[u1]]);
        assert_stencil_derivatives(&SlidingSegment { law }, &q, L);
    }

    #[test]
    fn angle_bending_with_jamming(x1 in v3(L), a in v3(1.0), b in v3(1.0), la in 0.3*L..2.0*L,
                                  lb in 0.3*L..2.0*L, du in 1.0..3.0f64, u0 in -L..L) {
        prop_assume!(a.norm() > 0.1 && b.norm() > 0.1);
        let (x0, x2) = (x1 - a.normalize() * la, x1 + b.normalize() * lb);
        let theta = rod::geometry::turning_angle(&(x1 - x0), &(x2 - x1));
        prop_assume!(theta < 3.0); // undefined at a full fold (θ = π)
        let q = pack::<12>(&[x0.as_slice(), &[u0], x1.as_slice(), &[u0 + la], x2.as_slice(), &[u0 + du * (la + lb)]]);
        let bend = AngleBending { stiffness: 1e-6, jamming: Jamming::default() };
        assert_stencil_derivatives(&bend, &q, L);
    }

    #[test]
    fn angle_bending_nearly_straight(x1 in v3(L), a in v3(1.0), tilt in v3(1e-4), la in 0.3*L..2.0*L) {
        // Exercises the series branch (θ < 1e-3) that avoids 0/0 at a straight rod.
        prop_assume!(a.norm() > 0.1);
        let t = a.normalize();
        let (x0, x2) = (x1 - t * la, x1 + (t + tilt) * la);
        let q = pack::<12>(&[x0.as_slice(), &[0.0], x1.as_slice(), &[la], x2.as_slice(), &[2.0 * la]]);
        let bend = AngleBending { stiffness: 1e-6, jamming: Jamming::default() };
        assert_stencil_derivatives(&bend, &q, L);
    }

    #[test]
    fn binormal_bending(x1 in v3(L), a in v3(1.0), b in v3(1.0), la in 0.3*L..2.0*L, lb in 0.3*L..2.0*L) {
        prop_assume!(a.norm() > 0.1 && b.norm() > 0.1);
        let (x0, x2) = (x1 - a.normalize() * la, x1 + b.normalize() * lb);
        prop_assume!(rod::geometry::turning_angle(&(x1 - x0), &(x2 - x1)) < 2.8);
        let bend = BinormalBending { stiffness: 1e-6, rest_lengths: (la, lb) };
        assert_stencil_derivatives(&bend, &pack::<9>(&[x0.as_slice(), x1.as_slice(), x2.as_slice()]), L);
    }

    #[test]
    fn two_phase_edge_contact(c in v3(L), a in v3(1.0), b in v3(1.0), gap in 0.3..1.8f64,
                              la in 0.5*L..2.0*L, lb in 0.5*L..2.0*L, sa in -0.3..0.3f64, sb in -0.3..0.3f64,
                              intervals in prop_oneof![Just(2usize), Just(4)]) {
        prop_assume!(a.norm() > 0.1 && b.norm() > 0.1);
        let (ta, tb) = (a.normalize(), b.normalize());
        let n = ta.cross(&tb);
        prop_assume!(n.norm() > 0.2); // crossing (non-parallel) edges: distance > 0 everywhere
        let r = 0.5 * L;
        // Edge b is offset from edge a along their common normal by `gap·R`.
        let cb = c + n.normalize() * gap * r;
        let (xa0, xa1) = (c - ta * la * (0.5 + sa), c + ta * la * (0.5 - sa));
        let (xb0, xb1) = (cb - tb * lb * (0.5 + sb), cb + tb * lb * (0.5 - sb));
        let contact = EdgeContact {
            phases: [
                BarrierPhase { stiffness: 1.0, radius: r },
                BarrierPhase { stiffness: 1e3, radius: 0.25 * r },
            ],
            rest_lengths: (la, lb),
            quadrature: Simpson::new(intervals).unwrap(),
        };
        let q = pack::<12>(&[xa0.as_slice(), xa1.as_slice(), xb0.as_slice(), xb1.as_slice()]);
        assert_stencil_derivatives(&contact, &q, L);
    }
}

/// A vertex stencil configuration `(x₀, x₁, x₂, θᵉ, θᶠ)` with reference frames adapted to its
/// edges (the DER protocol: the harness transports them with the perturbed edges). `None` for
/// degenerate draws (short direction vectors, near-folds, directors parallel to an edge).
#[allow(clippy::too_many_arguments)]
fn adapted_vertex(
    x1: Vector3<f64>,
    a: Vector3<f64>,
    b: Vector3<f64>,
    hint_e: Vector3<f64>,
    hint_f: Vector3<f64>,
    la: f64,
    lb: f64,
    th_e: f64,
    th_f: f64,
) -> Option<(SVector<f64, 11>, (Frame, Frame))> {
    if a.norm() <= 0.1 || b.norm() <= 0.1 {
        return None;
    }
    let (x0, x2) = (x1 - a.normalize() * la, x1 + b.normalize() * lb);
    if rod::geometry::turning_angle(&(x1 - x0), &(x2 - x1)) >= 2.5 {
        return None;
    }
    let frames = (
        Frame::new(&(x1 - x0), &hint_e)?,
        Frame::new(&(x2 - x1), &hint_f)?,
    );
    let q = pack::<11>(&[x0.as_slice(), x1.as_slice(), x2.as_slice(), &[th_e, th_f]]);
    Some((q, frames))
}

proptest! {
    #![proptest_config(config(256))]

    /// DER protocol: frames adapted at the base configuration; the harness transports them
    /// with the perturbed edges (see `rod::material_bending`).
    #[test]
    fn material_bending_with_rest_curvature_and_twist(
        x1 in v3(L), a in v3(1.0), b in v3(1.0), hint_e in v3(1.0), hint_f in v3(1.0),
        la in 0.3*L..2.0*L, lb in 0.3*L..2.0*L, th_e in -3.0..3.0f64, th_f in -3.0..3.0f64,
        k1 in -1.0..1.0f64, k2 in -1.0..1.0f64,
    ) {
        let vertex = adapted_vertex(x1, a, b, hint_e, hint_f, la, lb, th_e, th_f);
        prop_assume!(vertex.is_some());
        let (q, reference) = vertex.unwrap();
        let bend = rod::material_bending::MaterialBending {
            stiffness: 1e-6,
            rest_lengths: (la, lb),
            rest_curvature: nalgebra::Vector2::new(k1, k2),
            reference,
        };
        assert_stencil_derivatives(&bend, &q, L);
    }
}

proptest! {
    #![proptest_config(config(256))]

    /// Twist with transported reference frames and a base reference twist.
    #[test]
    fn twist_with_reference_twist(
        x1 in v3(L), a in v3(1.0), b in v3(1.0), hint_e in v3(1.0), hint_f in v3(1.0),
        la in 0.3*L..2.0*L, lb in 0.3*L..2.0*L, th_e in -3.0..3.0f64, th_f in -3.0..3.0f64,
        rest in -1.0..1.0f64, reference_twist in -7.0..7.0f64,
    ) {
        let vertex = adapted_vertex(x1, a, b, hint_e, hint_f, la, lb, th_e, th_f);
        prop_assume!(vertex.is_some());
        let (q, reference) = vertex.unwrap();
        let twist = rod::twist::Twist {
            stiffness: 1e-6,
            rest_lengths: (la, lb),
            rest_twist: rest,
            reference,
            reference_twist,
        };
        // At the base configuration the reference twist is the stored one.
        prop_assert!((twist.twist(&q) - (th_f - th_e + reference_twist)).abs() < 1e-12);
        assert_stencil_derivatives(&twist, &q, L);
    }
}

/// The adapted vertex moved away from its reference frames: each position displaced by up to
/// `0.6 L` (edges turn by up to about a radian against the stored frames, as in a deformed
/// periodic tile, whose frames stay at rest).
fn deformed(q: &SVector<f64, 11>, d: [Vector3<f64>; 3]) -> SVector<f64, 11> {
    let mut q = *q;
    for (k, dk) in d.iter().enumerate() {
        for i in 0..3 {
            q[3 * k + i] += dk[i];
        }
    }
    q
}

/// The jet evaluation against the hyper-dual one of the same energy: both exact, so they
/// agree to round-off.
fn assert_matches_hyper_dual(
    eval: rod::Evaluation<11>,
    reference: (f64, SVector<f64, 11>, nalgebra::SMatrix<f64, 11, 11>),
) {
    let (e, g, h) = reference;
    let tol = |x: f64, scale: f64| 1e-9 * x.abs().max(scale);
    assert!(
        (eval.energy - e).abs() <= tol(e, 1e-30),
        "energy {} vs {e}",
        eval.energy
    );
    let (gs, hs) = (g.amax(), h.amax());
    for k in 0..11 {
        assert!((eval.gradient[k] - g[k]).abs() <= tol(g[k], gs), "g[{k}]");
        for l in 0..11 {
            assert!(
                (eval.hessian[(k, l)] - h[(k, l)]).abs() <= tol(h[(k, l)], hs),
                "h[{k}][{l}]: {} vs {}",
                eval.hessian[(k, l)],
                h[(k, l)]
            );
        }
    }
}

proptest! {
    #![proptest_config(config(128))]

    /// Material bending and twist away from their reference frames: jets equal the
    /// hyper-dual derivatives, and both pass the finite-difference check.
    #[test]
    fn material_frame_terms_far_from_their_reference_frames(
        x1 in v3(L), a in v3(1.0), b in v3(1.0), hint_e in v3(1.0), hint_f in v3(1.0),
        la in 0.3*L..2.0*L, lb in 0.3*L..2.0*L, th_e in -3.0..3.0f64, th_f in -3.0..3.0f64,
        d0 in v3(0.6 * L), d1 in v3(0.6 * L), d2 in v3(0.6 * L),
        k1 in -1.0..1.0f64, k2 in -1.0..1.0f64, reference_twist in -7.0..7.0f64,
    ) {
        use rod::Stencil;
        use rod::hyperdual::gradient_and_hessian;
        let vertex = adapted_vertex(x1, a, b, hint_e, hint_f, la, lb, th_e, th_f);
        prop_assume!(vertex.is_some());
        let (q, reference) = vertex.unwrap();
        let q = deformed(&q, [d0, d1, d2]);
        let (e, f) = (q.fixed_rows::<3>(3) - q.fixed_rows::<3>(0), q.fixed_rows::<3>(6) - q.fixed_rows::<3>(3));
        // Stay away from folds and from edges turned against their frames (transport is
        // singular for antiparallel tangents).
        prop_assume!(e.norm() > 0.2 * L && f.norm() > 0.2 * L);
        prop_assume!(rod::geometry::turning_angle(&e, &f) < 2.5);
        prop_assume!(e.normalize().dot(&reference.0.t) > -0.5 && f.normalize().dot(&reference.1.t) > -0.5);
        let bend = rod::material_bending::MaterialBending {
            stiffness: 1e-6,
            rest_lengths: (la, lb),
            rest_curvature: nalgebra::Vector2::new(k1, k2),
            reference,
        };
        assert_matches_hyper_dual(bend.eval(&q), gradient_and_hessian(&q, |x| bend.energy_generic(x)));
        assert_stencil_derivatives(&bend, &q, L);
        let twist = rod::twist::Twist {
            stiffness: 1e-6,
            rest_lengths: (la, lb),
            rest_twist: 0.3,
            reference,
            reference_twist,
        };
        assert_matches_hyper_dual(twist.eval(&q), gradient_and_hessian(&q, |x| twist.energy_generic(x)));
        assert_stencil_derivatives(&twist, &q, L);
    }
}
