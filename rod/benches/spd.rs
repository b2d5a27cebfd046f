//! Throughput of the per-stencil PSD projection (`rod::spd`): nalgebra's symmetric QR
//! (`project_spd_qr`, the garment simulator's damping forms) against the cyclic Jacobi method
//! (`project_spd`, the Newton solvers'), measured in the same run, on the stencil sizes of the
//! garment simulator's damping forms (8: sliding stretch, 9: crossing shear, 12: bending and
//! wrapping). Inputs are indefinite like the Hessians they stand for: a random rotation of a
//! spectrum with one or two negative eigenvalues of 10–10⁴, two zero ones (a free rigid
//! motion) and positive ones spread over six decades (`cargo bench -p rod --bench spd`).
#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{DMatrix, SMatrix};
use rod::spd::{project_spd, project_spd_qr};
use std::hint::black_box;

/// `count` indefinite symmetric `N × N` matrices (see the file's documentation).
fn indefinite<const N: usize>(count: usize) -> Vec<SMatrix<f64, N, N>> {
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut uniform = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count)
        .map(|c| {
            let q = DMatrix::<f64>::from_fn(N, N, |_, _| uniform() - 0.5)
                .qr()
                .q();
            let negative = 1 + c % 2;
            let spectrum = SMatrix::<f64, N, 1>::from_fn(|i, _| match i {
                i if i < negative => -(10f64.powf(1.0 + 3.0 * uniform())),
                i if i >= N - 2 => 0.0,
                _ => 10f64.powf(6.0 * uniform()),
            });
            SMatrix::<f64, N, N>::from_fn(|i, j| {
                (0..N).map(|k| q[(i, k)] * spectrum[k] * q[(j, k)]).sum()
            })
        })
        .collect()
}

fn projection<const N: usize>(c: &mut Criterion) {
    let inputs = indefinite::<N>(256);
    let mut group = c.benchmark_group("spd-projection");
    group.throughput(Throughput::Elements(inputs.len() as u64));
    for (name, project) in [
        ("symmetric-qr", project_spd_qr as fn(&mut [f64], usize)),
        ("cyclic-jacobi", project_spd),
    ] {
        group.bench_function(BenchmarkId::new(name, N), |b| {
            b.iter_batched_ref(
                || inputs.clone(),
                |matrices| {
                    for m in matrices.iter_mut() {
                        project(black_box(m.as_mut_slice()), N);
                    }
                },
                criterion::BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

fn sizes(c: &mut Criterion) {
    projection::<8>(c);
    projection::<9>(c);
    projection::<12>(c);
}

criterion_group!(benches, sizes);
criterion_main!(benches);
