//! The GPU back end (WGSL compute shader through wgpu) agrees with the CPU back end within
//! 1e-5 relative. Runs on any adapter, including Mesa's lavapipe CPU driver. Without an
//! adapter the test prints a loud message and passes, unless
//! `WORKBENCH_REQUIRE_GPU_ADAPTER=1` (set in CI, where lavapipe is installed), in which case
//! a missing adapter fails it.

mod common;

use common::*;
use deform_runtime::gpu::{Chunking, GpuDeformer, GpuError};
use deform_runtime::{DeformOptions, Deformer, synthetic};

fn gpu_or_skip(cpu: &Deformer<f32>) -> Option<GpuDeformer> {
    gpu_chunked_or_skip(cpu, Chunking::default())
}

fn gpu_chunked_or_skip(cpu: &Deformer<f32>, chunking: Chunking) -> Option<GpuDeformer> {
    match GpuDeformer::with_chunking(cpu, chunking) {
        Ok(gpu) => {
            eprintln!("GPU test on {}", gpu.adapter());
            Some(gpu)
        }
        Err(e @ GpuError::NoAdapter(_)) => {
            if std::env::var("WORKBENCH_REQUIRE_GPU_ADAPTER").as_deref() == Ok("1") {
                panic!("WORKBENCH_REQUIRE_GPU_ADAPTER=1 but {e}");
            }
            eprintln!("\n!!!!!!!!!! SKIPPING the CPU/GPU comparison: {e} !!!!!!!!!!\n");
            None
        }
        Err(e) => panic!("GPU back end failed: {e}"),
    }
}

/// Largest coordinate difference relative to the largest coordinate magnitude, and largest
/// twist difference.
fn compare(cpu: &Deformer<f32>, gpu: &GpuDeformer) -> (f64, f64) {
    deform_runtime::gpu::agreement(cpu.output(), gpu.output())
}

#[test]
fn cpu_and_gpu_agree() {
    let tile = stockinette();
    // Non-uniform axes (search path) and uniform axes (direct path).
    let databases = [
        database(&tile),
        synthetic::database(
            &tile,
            synthetic::uniform_axes(5),
            synthetic::multilinear(tile.radius),
        ),
    ];
    let mesh = grid(&tile, 6.0, 8.0, 6);
    let moved = synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 2.0));
    let squeezed = synthetic::map_uvs(&mesh, |uv| [0.7 * uv[0], 1.05 * uv[1] + 0.2 * uv[0], 0.0]);
    let rest = synthetic::map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]);
    for db in &databases {
        for options in [
            DeformOptions::default(),
            DeformOptions {
                clamp_compression: false,
                phong: false,
                interpolate_forms: false,
                ..DeformOptions::default()
            },
            DeformOptions {
                linearized_bending: false,
                skip_identity: false,
                ..DeformOptions::default()
            },
        ] {
            let mut cpu = deformer::<f32>(&tile, db, &mesh, options);
            let Some(mut gpu) = gpu_or_skip(&cpu) else {
                return;
            };
            for positions in [&moved, &squeezed, &rest] {
                cpu.frame(positions).unwrap();
                let mut for_gpu = cpu.clone();
                let stats = gpu.frame(&mut for_gpu, positions).unwrap();
                assert_eq!(stats.vertices.nonfinite_output, 0);
                let (rel, twist) = compare(&cpu, &gpu);
                eprintln!("CPU vs GPU: max relative difference {rel:.2e}, twist {twist:.2e} rad");
                assert!(rel < 1e-5, "{options:?}: relative difference {rel:e}");
                assert!(twist < 1e-5, "{options:?}: twist difference {twist:e}");
            }
        }
    }
}

/// Splitting the per-vertex buffers into chunks (one dispatch each) changes nothing: tiny
/// chunks, including ones that are not a multiple of the workgroup size and ones dispatched
/// as 2-D grids, give bit-identical output to one chunk, and agree with the CPU.
#[test]
fn chunked_dispatch_equals_unchunked_and_cpu() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 6.0, 8.0, 6);
    let moved = synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 2.0));
    let mut cpu = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    cpu.frame(&moved).unwrap();
    let n = cpu.embedding().len();
    let Some(mut whole) = gpu_or_skip(&cpu) else {
        return;
    };
    assert_eq!(whole.chunk_lengths(), [n], "the test mesh fits one chunk");
    let mut for_gpu = cpu.clone();
    whole.frame(&mut for_gpu, &moved).unwrap();
    let (rel, _) = compare(&cpu, &whole);
    assert!(rel < 1e-5, "unchunked: {rel:e}");
    for chunking in [
        // 37 vertices: partial workgroups in every chunk.
        Chunking {
            max_vertices: 37,
            ..Chunking::default()
        },
        // 1000 vertices in rows of 2 workgroups: 8 rows of 128 invocations per chunk.
        Chunking {
            max_vertices: 1000,
            row_groups: 2,
        },
        // A third of the vertices, one workgroup per row.
        Chunking {
            max_vertices: n.div_ceil(3),
            row_groups: 1,
        },
    ] {
        let mut gpu = gpu_chunked_or_skip(&cpu, chunking).expect("adapter found above");
        let lengths = gpu.chunk_lengths();
        assert_eq!(lengths.len(), n.div_ceil(chunking.max_vertices));
        assert_eq!(lengths.iter().sum::<usize>(), n);
        assert!(lengths.iter().all(|&l| l <= chunking.max_vertices));
        let mut for_gpu = cpu.clone();
        let stats = gpu.frame(&mut for_gpu, &moved).unwrap();
        assert_eq!(stats.vertices.processed, n);
        assert_eq!(stats.vertices.nonfinite_output, 0);
        let (a, b) = (whole.output(), gpu.output());
        let same = |p: &[f32], q: &[f32]| p.iter().zip(q).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(
            same(&a.x, &b.x) && same(&a.y, &b.y) && same(&a.z, &b.z) && same(&a.twist, &b.twist),
            "{chunking:?}: chunked output differs from the single dispatch"
        );
        let (rel, twist) = compare(&cpu, &gpu);
        eprintln!(
            "{} chunks of ≤ {} vertices ({n} in all): CPU vs GPU {rel:.2e}, twist {twist:.2e} rad",
            lengths.len(),
            chunking.max_vertices
        );
        assert!(
            rel < 1e-5 && twist < 1e-5,
            "{chunking:?}: {rel:e}, {twist:e}"
        );
    }
    // Invalid chunking is an error, not a panic.
    let zero = Chunking {
        max_vertices: 0,
        ..Chunking::default()
    };
    assert!(matches!(
        GpuDeformer::with_chunking(&cpu, zero),
        Err(GpuError::Chunking(_))
    ));
}

#[test]
fn the_gpu_benchmark_runs_and_agrees_with_the_cpu() {
    // What `examples/gpu_bench.rs` runs on a real GPU, on a small scene.
    let tile = stockinette();
    let mut scene = synthetic::throughput_scene::<f32>(&tile, 16.0).expect("scene");
    if gpu_or_skip(&scene.deformer).is_none() {
        return;
    }
    let b = deform_runtime::gpu::benchmark(&mut scene, 2).expect("benchmark");
    assert_eq!(b.vertices, scene.deformer.embedding().len());
    assert!(b.vertices > 20_000, "{b:?}");
    assert!(
        b.gpu_frame_seconds > 0.0 && b.cpu_frame_seconds > 0.0,
        "{b:?}"
    );
    assert!(b.max_relative_difference < 1e-5, "{b:?}");
    assert!(b.max_twist_difference < 1e-5, "{b:?}");
}
