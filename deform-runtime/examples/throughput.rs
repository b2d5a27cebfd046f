//! Release-binary throughput measurement: `cargo run --release -p deform-runtime --example
//! throughput -- [cells_per_side] [frames]` prints per-configuration frame times.

use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, synthetic};
use std::time::Instant;

/// Process CPU time (user + system) in seconds, from `/proc/self/stat` (Linux; 0 elsewhere).
/// Under contention from other processes CPU time is a steadier measure than wall time.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |k: usize| {
        fields
            .get(k)
            .and_then(|s| s.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // Fields 14 and 15 of stat (utime, stime) are at 11 and 12 after the command name.
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let mut args = std::env::args().skip(1);
    let cells: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(320.0);
    let frames: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(5);
    let tile = yarn_pattern::pyp::read_pyp(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    ))
    .expect("stockinette test data")
    .tile;
    let db = synthetic::database(
        &tile,
        synthetic::uniform_axes(9),
        synthetic::multilinear(tile.radius),
    );
    let mesh = synthetic::grid_mesh(64, 64, cells * tile.period[0], cells * tile.period[1]);
    let t = Instant::now();
    let mut d = build::<f32>(
        &tile,
        &db,
        &mesh,
        &SetupOptions {
            uv_scale: 1.0,
            ..Default::default()
        },
    )
    .expect("setup");
    let n = d.embedding().len();
    println!(
        "setup {:.2} s, {n} yarn vertices, {} threads",
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    let rest = synthetic::map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]);
    let moved = synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 0.05));
    let base = DeformOptions {
        skip_static: false,
        ..DeformOptions::default()
    };
    let cases = [
        ("full", base, &moved),
        (
            "no_clamp_no_bending",
            DeformOptions {
                clamp_compression: false,
                linearized_bending: false,
                ..base
            },
            &moved,
        ),
        (
            "no_phong",
            DeformOptions {
                phong: false,
                interpolate_forms: false,
                ..base
            },
            &moved,
        ),
        (
            "naive",
            DeformOptions {
                displacement: false,
                ..base
            },
            &moved,
        ),
        ("identity_skip", base, &rest),
        (
            "identity_noskip",
            DeformOptions {
                skip_identity: false,
                ..base
            },
            &rest,
        ),
    ];
    // Memory bandwidth reference: a rayon triad a[i] = b[i] + 0.5 c[i] over 3 × 256 MB.
    {
        use rayon::prelude::*;
        let len = 64 << 20;
        let b = vec![1.0f32; len];
        let c = vec![2.0f32; len];
        let mut a = vec![0.0f32; len];
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t = Instant::now();
            a.par_chunks_mut(1 << 16)
                .zip(b.par_chunks(1 << 16).zip(c.par_chunks(1 << 16)))
                .for_each(|(a, (b, c))| {
                    for i in 0..a.len() {
                        a[i] = b[i] + 0.5 * c[i];
                    }
                });
            best = best.min(t.elapsed().as_secs_f64());
        }
        // Bytes moved: read b, c; write a (plus the write-allocate read of a).
        let bytes = 4.0 * len as f64 * 4.0;
        println!(
            "triad bandwidth {:.1} GB/s (check {})",
            bytes / best / 1e9,
            a[len / 2]
        );
        println!(
            "deformer traffic per yarn vertex: 20 B in (triangle, du, dv, height, pattern vertex) + 16 B out (x, y, z, θ) + 16 B write-allocate = 52 B"
        );
    }
    for (name, opts, pos) in cases {
        d.set_options(opts).expect("options");
        d.frame(pos).expect("frame");
        let mut best = f64::INFINITY;
        let mut mesh_s = 0.0;
        let cpu0 = cpu_seconds();
        let wall0 = Instant::now();
        for _ in 0..frames {
            let s = d.frame(pos).expect("frame");
            if s.vertex_seconds < best {
                best = s.vertex_seconds;
                mesh_s = s.mesh_seconds;
            }
        }
        let cpu = (cpu_seconds() - cpu0) / frames as f64;
        let wall = wall0.elapsed().as_secs_f64() / frames as f64;
        println!(
            "{name:20} best wall: vertex {:7.2} ms mesh {:5.2} ms = {:6.1} M/s | mean wall {:7.2} ms | CPU {:7.2} ms/frame = {:6.1} M vertices per CPU-second",
            best * 1e3,
            mesh_s * 1e3,
            n as f64 / (best + mesh_s) / 1e6,
            wall * 1e3,
            cpu * 1e3,
            n as f64 / cpu / 1e6
        );
    }
    // GPU back end (any wgpu adapter, e.g. Mesa lavapipe), default options.
    d.set_options(DeformOptions {
        skip_static: false,
        ..DeformOptions::default()
    })
    .expect("options");
    match deform_runtime::gpu::GpuDeformer::new(&d) {
        Ok(mut gpu) => {
            gpu.frame(&mut d, &moved).expect("gpu frame");
            let mut best = f64::INFINITY;
            for _ in 0..frames {
                let s = gpu.frame(&mut d, &moved).expect("gpu frame");
                best = best.min(s.mesh_seconds + s.vertex_seconds);
            }
            println!(
                "GPU ({}, {} chunk(s)) full frame incl. upload + read-back: {:.2} ms = {:.1} M vertices/s",
                gpu.adapter(),
                gpu.chunk_lengths().len(),
                best * 1e3,
                n as f64 / best / 1e6
            );
            // The same frame on the CPU: largest coordinate difference relative to the
            // largest coordinate magnitude (the tests' measure).
            d.frame(&moved).expect("frame");
            let (a, b) = (d.output(), gpu.output());
            let scale =
                a.x.iter()
                    .chain(&a.y)
                    .chain(&a.z)
                    .fold(0.0f32, |m, v| m.max(v.abs()));
            let worst = [(&a.x, &b.x), (&a.y, &b.y), (&a.z, &b.z)]
                .iter()
                .flat_map(|(p, q)| p.iter().zip(q.iter()).map(|(p, q)| (p - q).abs()))
                .fold(0.0f32, f32::max);
            println!(
                "GPU vs CPU: max relative difference {:.2e} over {n} vertices",
                worst / scale
            );
        }
        Err(e) => println!("GPU: {e}"),
    }
}
