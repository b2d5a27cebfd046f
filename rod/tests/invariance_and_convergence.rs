//! Physical sanity of the rod terms: rigid motions leave every energy unchanged, and discrete
//! bending of circles and helices converges to the smooth rod's energy at second order.

use nalgebra::{Rotation3, SVector, Vector3};
use rod::bending::{AngleBending, BinormalBending, Jamming};
use rod::contact::{BarrierPhase, EdgeContact, Simpson};
use rod::stencil::Stencil;
use rod::stretch::{Segment, SlidingSegment, StretchLaw};
use rod::validation::{BendingModel, Helix, measured_order, relative_bending_error};

/// Applies `x ↦ R x + t` to the 3-vectors starting at the given offsets of `q`.
fn rigid<const N: usize>(
    q: &SVector<f64, N>,
    offsets: &[usize],
    r: &Rotation3<f64>,
    t: &Vector3<f64>,
) -> SVector<f64, N> {
    let mut out = *q;
    for &o in offsets {
        let x: Vector3<f64> = q.fixed_rows::<3>(o).into();
        out.fixed_rows_mut::<3>(o).copy_from(&(r * x + t));
    }
    out
}

fn assert_rigid_invariant<const N: usize>(
    name: &str,
    s: &impl Stencil<N>,
    q: &SVector<f64, N>,
    offsets: &[usize],
) {
    let e0 = s.energy(q);
    assert!(
        e0.abs() > 0.0,
        "{name}: pick a configuration with non-zero energy"
    );
    for (axis, angle, shift) in [
        (
            Vector3::new(1.0, 2.0, 3.0),
            0.7,
            Vector3::new(0.3, -0.2, 0.1),
        ),
        (
            Vector3::new(-0.5, 0.1, 1.0),
            2.9,
            Vector3::new(-1.0, 4.0, 2.0),
        ),
    ] {
        let r = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
        let e1 = s.energy(&rigid(q, offsets, &r, &(shift * 1e-3)));
        assert!(
            (e1 - e0).abs() <= 1e-12 * e0.abs(),
            "{name}: {e0} → {e1} under a rigid motion"
        );
    }
}

#[test]
fn every_term_is_invariant_under_rigid_motions() {
    let p = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x * 1e-3).collect() };
    let law = StretchLaw::TwoPhase {
        k1: 1.0,
        k2: 20.0,
        onset: 0.1,
    };
    let seg = SVector::<f64, 6>::from_column_slice(&p(&[0.1, 0.2, 0.0, 1.3, 0.4, -0.2]));
    assert_rigid_invariant(
        "segment",
        &Segment {
            rest_length: 1e-3,
            law,
        },
        &seg,
        &[0, 3],
    );
    let sl = SVector::<f64, 8>::from_column_slice(&p(&[0.1, 0.2, 0.0, 0.0, 1.3, 0.4, -0.2, 1.0]));
    assert_rigid_invariant("sliding segment", &SlidingSegment { law }, &sl, &[0, 4]);
    let ab = SVector::<f64, 12>::from_column_slice(&p(&[
        0.0, 0.0, 0.0, 0.0, 1.0, 0.1, 0.0, 1.0, 1.5, 0.9, 0.3, 2.1,
    ]));
    let angle = AngleBending {
        stiffness: 1e-6,
        jamming: Jamming::default(),
    };
    assert_rigid_invariant("angle bending", &angle, &ab, &[0, 4, 8]);
    let bb =
        SVector::<f64, 9>::from_column_slice(&p(&[0.0, 0.0, 0.0, 1.0, 0.1, 0.0, 1.5, 0.9, 0.3]));
    assert_rigid_invariant(
        "binormal bending",
        &BinormalBending {
            stiffness: 1e-6,
            rest_lengths: (1e-3, 1e-3),
        },
        &bb,
        &[0, 3, 6],
    );
    let contact = EdgeContact {
        phases: [
            BarrierPhase {
                stiffness: 1.0,
                radius: 5e-4,
            },
            BarrierPhase {
                stiffness: 1e3,
                radius: 1.25e-4,
            },
        ],
        rest_lengths: (1e-3, 1e-3),
        quadrature: Simpson::default(),
    };
    let cq = SVector::<f64, 12>::from_column_slice(&p(&[
        -0.5, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, -0.5, 0.6, 0.1, 0.5, 0.6,
    ]));
    assert_rigid_invariant("edge contact", &contact, &cq, &[0, 3, 6, 9]);
}

/// Measures relative error of discrete vs continuous bending energy for increasing n.
fn errors(model: BendingModel, helix: &Helix, span: f64, closed: bool, ns: &[usize]) -> Vec<f64> {
    ns.iter()
        .map(|&n| relative_bending_error(model, helix, span, n, closed))
        .collect()
}

#[test]
fn bending_of_a_circle_and_a_helix_converges_at_second_order() {
    let ns = [16, 32, 64, 128, 256];
    let circle = Helix::REFERENCE_CIRCLE;
    let helix = Helix::REFERENCE_HELIX;
    for model in [BendingModel::Binormal, BendingModel::Angle] {
        for (name, h, span, closed) in [
            ("circle", &circle, std::f64::consts::TAU, true),
            ("helix", &helix, 3.0 * std::f64::consts::TAU, false),
        ] {
            let e = errors(model, h, span, closed, &ns);
            assert!(
                e.windows(2).all(|w| w[1] < w[0]),
                "{model:?} {name}: errors not decreasing: {e:?}"
            );
            // Fit the asymptotic range (n ≥ 64); n = 16 is pre-asymptotic on the helix.
            let order = measured_order(&ns[2..], &e[2..]);
            println!("{model:?} {name}: errors {e:?}, measured order {order:.3}");
            assert!(
                (1.9..=2.1).contains(&order),
                "{model:?} {name}: order {order}"
            );
            assert!(
                e[ns.len() - 1] < 1e-3,
                "{model:?} {name}: error at n = 256 is {}",
                e[ns.len() - 1]
            );
        }
    }
}

#[test]
fn material_bending_is_invariant_when_positions_and_frames_move_rigidly() {
    use rod::geometry::Frame;
    use rod::material_bending::MaterialBending;
    let x = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(1e-3, 1e-4, 0.0),
        Vector3::new(1.5e-3, 0.9e-3, 0.3e-3),
    ];
    let frame = |a: &Vector3<f64>, b: &Vector3<f64>, hint: &Vector3<f64>| {
        Frame::new(&(b - a), hint).unwrap()
    };
    let make = |x: &[Vector3<f64>; 3], r: &Rotation3<f64>| MaterialBending {
        stiffness: 1e-6,
        rest_lengths: (1e-3, 1e-3),
        rest_curvature: nalgebra::Vector2::new(0.2, -0.1),
        reference: (
            frame(&x[0], &x[1], &(r * Vector3::z())),
            frame(&x[1], &x[2], &(r * Vector3::new(0.3, 0.0, 1.0))),
        ),
    };
    let pack = |x: &[Vector3<f64>; 3]| {
        let mut q = SVector::<f64, 11>::zeros();
        for (k, xk) in x.iter().enumerate() {
            q.fixed_rows_mut::<3>(3 * k).copy_from(xk);
        }
        q[9] = 0.3;
        q[10] = -0.2;
        q
    };
    let id = Rotation3::identity();
    let e0 = make(&x, &id).energy(&pack(&x));
    assert!(e0 > 0.0);
    let r = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(1.0, -2.0, 0.5)),
        1.1,
    );
    let t = Vector3::new(2e-3, -1e-3, 4e-3);
    let y = x.map(|p| r * p + t);
    let e1 = make(&y, &r).energy(&pack(&y));
    assert!((e1 - e0).abs() <= 1e-12 * e0, "{e0} → {e1}");
    // Rotating the material frames about the edges (twist) does change the energy.
    let mut q = pack(&x);
    q[9] += 0.5;
    assert!((make(&x, &id).energy(&q) - e0).abs() > 1e-6 * e0);
}
