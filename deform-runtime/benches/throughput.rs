//! Per-frame throughput of the CPU deformer on ≥ 10 M yarn vertices (stockinette tile on a
//! 64 × 64-quad sheet covering 320 × 320 pattern periods, f32; [`synthetic::throughput_scene`])
//! for the full pipeline, the naive embedding, an all-identity frame (lookups skipped) and a
//! static frame, beside the roofline of the per-vertex stage measured in the same run
//! ([`deform_runtime::roofline`]): the triad bandwidth over the bytes each vertex streams, and
//! the rate of the kernel's arithmetic from registers. The full frame's throughput is printed
//! as a fraction of the lower roof and as a ratio to MADYPG's GPU runtime (42.7 M vertices in
//! 63 ms on a GTX 1080 Ti, paper 004 Table 1).
//!
//! `cargo bench -p deform-runtime --bench throughput`; set `DEFORM_BENCH_CELLS` to change the
//! number of periods per side (default 320 → 10.2 M vertices).

// `criterion_group!` generates an undocumented public function.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use deform_runtime::roofline::{MADYPG_GPU_VERTICES_PER_SECOND, Roofline, VertexCost};
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
    let scene = synthetic::throughput_scene::<f32>(&tile, cells).expect("setup");
    let (mut d, rest, moved) = (scene.deformer, scene.rest, scene.moved);
    let n = d.embedding().len();
    eprintln!(
        "throughput bench: {n} yarn vertices, {} triangles, {} threads",
        d.mesh().n_faces(),
        rayon::current_num_threads()
    );
    let roof = Roofline::measure(VertexCost::f32_kernel());
    eprintln!("roofline: {roof}");
    for s in roof.cost.stages() {
        eprintln!(
            "  stage {:8} {:3} B memory, {:3} B cache, {:3} mul {:3} add {} sqrt {} div per vertex",
            s.name, s.dram_bytes, s.cache_bytes, s.ops.mul, s.ops.add, s.ops.sqrt, s.ops.div
        );
    }
    let mut group = c.benchmark_group("deform_frame");
    group.sample_size(10);
    group.throughput(Throughput::Elements(n as u64));
    let base = DeformOptions {
        skip_static: false,
        ..DeformOptions::default()
    };
    let cases: [(&str, DeformOptions, &Vec<[f64; 3]>); 3] = [
        ("full", base, &moved),
        (
            "naive_embedding",
            DeformOptions {
                displacement: false,
                ..base
            },
            &moved,
        ),
        ("identity_skipped", base, &rest),
    ];
    for (name, opts, positions) in cases {
        d.set_options(opts).expect("options");
        group.bench_function(name, |b| b.iter(|| d.frame(positions).expect("frame")));
    }
    d.set_options(DeformOptions::default()).expect("options");
    d.frame(&moved).expect("frame");
    group.bench_function("static", |b| b.iter(|| d.frame(&moved).expect("frame")));
    group.finish();

    // The full frame against the roof: best of 10 frames, mesh stage included.
    d.set_options(base).expect("options");
    let best = (0..10)
        .map(|_| {
            let s = d.frame(&moved).expect("frame");
            (s.mesh_seconds + s.vertex_seconds, s.vertex_seconds)
        })
        .fold((f64::INFINITY, f64::INFINITY), |a, b| {
            (a.0.min(b.0), a.1.min(b.1))
        });
    let (frame, vertex) = (n as f64 / best.0, n as f64 / best.1);
    eprintln!(
        "full frame, {n} vertices: {:.1} ms = {:.0} M vertices/s = {:.1} % of the roof; vertex stage alone {:.0} M vertices/s = {:.1} %; {:.2}× MADYPG's GPU (0.68 G vertices/s)",
        best.0 * 1e3,
        frame / 1e6,
        100.0 * roof.fraction(frame),
        vertex / 1e6,
        100.0 * roof.fraction(vertex),
        frame / MADYPG_GPU_VERTICES_PER_SECOND
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
