//! Per-frame throughput of the CPU deformer on ≥ 10 M yarn vertices (stockinette tile on a
//! 64 × 64-quad sheet covering 320 × 320 pattern periods, f32), for the full pipeline, the
//! naive embedding, an all-identity frame (lookups skipped) and a static frame.
//!
//! `cargo bench -p deform-runtime --bench throughput`; set `DEFORM_BENCH_CELLS` to change the
//! number of periods per side (default 320 → 10.2 M vertices).

// `criterion_group!` generates an undocumented public function.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, synthetic};

fn bench(c: &mut Criterion) {
    let tile = yarn_pattern::pyp::read_pyp(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    ))
    .expect("stockinette test data")
    .tile;
    let cells: f64 = std::env::var("DEFORM_BENCH_CELLS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(320.0);
    let db = synthetic::database(
        &tile,
        synthetic::uniform_axes(9),
        synthetic::multilinear(tile.radius),
    );
    let mesh = synthetic::grid_mesh(64, 64, cells * tile.period[0], cells * tile.period[1]);
    let options = SetupOptions {
        uv_scale: 1.0,
        ..SetupOptions::default()
    };
    let mut d = build::<f32>(&tile, &db, &mesh, &options).expect("setup");
    let n = d.embedding().len();
    eprintln!(
        "throughput bench: {n} yarn vertices, {} triangles",
        d.mesh().n_faces()
    );
    let rest: Vec<[f64; 3]> = synthetic::map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]);
    let moved: Vec<[f64; 3]> = synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 0.05));
    let mut group = c.benchmark_group("deform_frame");
    group.sample_size(10);
    group.throughput(Throughput::Elements(n as u64));
    let cases: [(&str, DeformOptions, &Vec<[f64; 3]>); 3] = [
        (
            "full",
            DeformOptions {
                skip_static: false,
                ..DeformOptions::default()
            },
            &moved,
        ),
        (
            "naive_embedding",
            DeformOptions {
                displacement: false,
                skip_static: false,
                ..DeformOptions::default()
            },
            &moved,
        ),
        (
            "identity_skipped",
            DeformOptions {
                skip_static: false,
                ..DeformOptions::default()
            },
            &rest,
        ),
    ];
    for (name, opts, positions) in cases {
        d.set_options(opts).expect("options");
        group.bench_function(name, |b| b.iter(|| d.frame(positions).expect("frame")));
    }
    d.set_options(DeformOptions::default()).expect("options");
    d.frame(&moved).expect("frame");
    group.bench_function("static", |b| b.iter(|| d.frame(&moved).expect("frame")));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
