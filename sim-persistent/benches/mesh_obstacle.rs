//! Signed-distance queries of a mesh obstacle (`forces::obstacle::mesh`) against the mesh
//! size, with the throughput in queries per second (criterion `Throughput::Elements`), and
//! the same queries by a linear scan over every triangle as the baseline the tree replaces.
//!
//! `cargo bench -p sim-persistent --bench mesh_obstacle` (add `-- --quick` for a short run).
//! Setup (not timed): the mannequin of `experiment::garment` (0.75 m) revolved with 32, 96
//! and 288 vertices per ring, and 4096 query points scattered within 4 mm of its surface
//! (yarn points of a dressed garment, where every query finds the surface within the reach).

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rod::geometry::V3;
use sim_persistent::experiment::garment::{mannequin, revolved};
use sim_persistent::forces::obstacle::mesh::{DEFAULT_REACH, TriangleMesh, closest_on_triangle};
use std::hint::black_box;

/// `n` points within 4 mm of the surface of `mesh` (deterministic).
fn near_surface(mesh: &TriangleMesh, n: usize) -> Vec<V3> {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let t = mesh.triangles()
                [(uniform() * mesh.triangles().len() as f64) as usize % mesh.triangles().len()];
            let [a, b, c] = t.map(|i| mesh.vertices()[i as usize]);
            let (u, v) = (uniform(), uniform());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let p = a + u * (b - a) + v * (c - a);
            let n = (b - a)
                .cross(&(c - a))
                .try_normalize(0.0)
                .unwrap_or(V3::z());
            p + (uniform() - 0.5) * 8e-3 * n
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh_obstacle");
    for segments in [32, 96, 288] {
        let mesh = revolved(&mannequin(0.75), segments, DEFAULT_REACH).expect("mannequin");
        let points = near_surface(&mesh, 4096);
        let triangles = mesh.triangles().len();
        group.throughput(Throughput::Elements(points.len() as u64));
        group.bench_with_input(BenchmarkId::new("tree", triangles), &points, |b, points| {
            b.iter(|| {
                points
                    .iter()
                    .filter_map(|p| mesh.signed_distance(black_box(p)))
                    .map(|(d, _, _)| d)
                    .sum::<f64>()
            })
        });
        if segments == 32 {
            group.bench_with_input(
                BenchmarkId::new("linear-scan", triangles),
                &points,
                |b, points| {
                    b.iter(|| {
                        points
                            .iter()
                            .map(|p| {
                                mesh.triangles()
                                    .iter()
                                    .map(|t| {
                                        let [a, b, c] = t.map(|i| mesh.vertices()[i as usize]);
                                        (p - closest_on_triangle(black_box(p), &a, &b, &c).0)
                                            .norm_squared()
                                    })
                                    .fold(f64::INFINITY, f64::min)
                            })
                            .sum::<f64>()
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
