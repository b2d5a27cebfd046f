//! Throughput of the rod stencils: full evaluations (energy + gradient + Hessian) per second.
//! Template for the benchmarks of later crates: fixed inputs, `black_box`, and throughput
//! reported per element (`cargo bench -p rod`).
#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{SVector, Vector2, Vector3};
use rod::Stencil;
use rod::bending::{AngleBending, BinormalBending, Jamming};
use rod::contact::{BarrierPhase, EdgeContact, Simpson};
use rod::geometry::Frame;
use rod::hyperdual::{HyperDual, gradient_and_hessian};
use rod::material_bending::MaterialBending;
use rod::stretch::{Segment, SlidingSegment, StretchLaw};
use std::hint::black_box;

/// `count` slightly different copies of a configuration, so branch predictors see variety.
fn jittered<const N: usize>(base: &[f64], count: usize) -> Vec<SVector<f64, N>> {
    (0..count)
        .map(|i| {
            SVector::<f64, N>::from_fn(|k, _| {
                base[k] * (1.0 + 1e-3 * ((i * 7 + k * 3) % 11) as f64)
            })
        })
        .collect()
}

/// An 11-DOF energy with hyper-dual derivatives (66 passes per Hessian).
struct ViaHyperDual<F>(F);

impl<F: Fn(&[HyperDual; 11]) -> HyperDual> Stencil<11> for ViaHyperDual<F> {
    fn energy(&self, q: &SVector<f64, 11>) -> f64 {
        (self.0)(&std::array::from_fn(|k| HyperDual {
            v: q[k],
            a: 0.0,
            b: 0.0,
            ab: 0.0,
        }))
        .v
    }

    fn eval(&self, q: &SVector<f64, 11>) -> rod::Evaluation<11> {
        let (energy, gradient, hessian) = gradient_and_hessian(q, &self.0);
        rod::Evaluation {
            energy,
            gradient,
            hessian,
        }
    }
}

fn bench_stencil<const N: usize>(c: &mut Criterion, name: &str, s: &impl Stencil<N>, base: &[f64]) {
    let qs = jittered::<N>(base, 1024);
    let mut group = c.benchmark_group("rod-stencils");
    group.throughput(Throughput::Elements(qs.len() as u64));
    group.bench_function(BenchmarkId::new("eval", name), |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in &qs {
                let e = s.eval(black_box(q));
                acc += e.energy + e.hessian[(0, 0)];
            }
            acc
        })
    });
    group.bench_function(BenchmarkId::new("energy", name), |b| {
        b.iter(|| qs.iter().map(|q| s.energy(black_box(q))).sum::<f64>())
    });
    group.finish();
}

fn stencils(c: &mut Criterion) {
    let mm = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x * 1e-3).collect() };
    let law = StretchLaw::TwoPhase {
        k1: 1.0,
        k2: 20.0,
        onset: 0.1,
    };
    bench_stencil(
        c,
        "segment-two-phase",
        &Segment {
            rest_length: 1e-3,
            law,
        },
        &mm(&[0.1, 0.2, 0.3, 1.2, 0.4, 0.1]),
    );
    bench_stencil(
        c,
        "sliding-segment",
        &SlidingSegment { law },
        &mm(&[0.1, 0.2, 0.3, 0.5, 1.2, 0.4, 0.1, 1.5]),
    );
    let angle = AngleBending {
        stiffness: 1e-6,
        jamming: Jamming::default(),
    };
    bench_stencil(
        c,
        "angle-bending",
        &angle,
        &mm(&[0.1, 0.2, 0.3, 0.5, 1.2, 0.4, 0.1, 1.5, 2.0, 1.1, 0.3, 2.5]),
    );
    let binormal = BinormalBending {
        stiffness: 1e-6,
        rest_lengths: (1e-3, 1e-3),
    };
    bench_stencil(
        c,
        "binormal-bending",
        &binormal,
        &mm(&[0.1, 0.2, 0.3, 1.2, 0.4, 0.1, 2.0, 1.1, 0.3]),
    );
    let (e, f) = (Vector3::new(1.1, 0.2, -0.2), Vector3::new(0.8, 0.7, 0.2));
    let material = MaterialBending {
        stiffness: 1e-6,
        rest_lengths: (1e-3, 1e-3),
        rest_curvature: Vector2::new(0.1, -0.2),
        reference: (
            Frame::new(&e, &Vector3::z()).unwrap(),
            Frame::new(&f, &Vector3::z()).unwrap(),
        ),
    };
    let mut q = mm(&[0.1, 0.2, 0.3, 1.2, 0.4, 0.1, 2.0, 1.1, 0.3]);
    q.extend([0.1, 0.2]);
    bench_stencil(c, "material-bending", &material, &q);
    // The same energy differentiated by hyper-dual passes (the former implementation), for
    // the speed-up of the jets in the same run.
    bench_stencil(
        c,
        "material-bending-hyperdual",
        &ViaHyperDual(|x: &[HyperDual; 11]| material.energy_generic(x)),
        &q,
    );
    let twist = rod::twist::Twist {
        stiffness: 4e-6,
        rest_lengths: (1e-3, 1e-3),
        rest_twist: 0.1,
        reference: material.reference,
        reference_twist: 0.05,
    };
    bench_stencil(c, "twist", &twist, &q);
    bench_stencil(
        c,
        "twist-hyperdual",
        &ViaHyperDual(|x: &[HyperDual; 11]| twist.energy_generic(x)),
        &q,
    );
    for intervals in [2, 4] {
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
            quadrature: Simpson::new(intervals).unwrap(),
        };
        let q = mm(&[-0.5, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, -0.5, 0.4, 0.1, 0.5, 0.4]);
        bench_stencil(c, &format!("edge-contact-simpson{intervals}"), &contact, &q);
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(2)).warm_up_time(std::time::Duration::from_millis(500));
    targets = stencils
}
criterion_main!(benches);
