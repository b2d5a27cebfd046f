//! Release-binary throughput measurement: `cargo run --release -p deform-runtime --example
//! throughput -- [cells_per_side] [frames]` prints per-configuration frame times (wall and
//! process CPU time) of the throughput scene beside the roofline measured in the same run.

use deform_runtime::roofline::{Roofline, VertexCost};
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
    let t = Instant::now();
    let scene = synthetic::throughput_scene::<f32>(&tile, cells).expect("setup");
    let (mut d, rest, moved) = (scene.deformer, scene.rest, scene.moved);
    let n = d.embedding().len();
    println!(
        "setup {:.2} s, {n} yarn vertices, {} threads",
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
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
    let roof = Roofline::measure(VertexCost::f32_kernel());
    println!("roofline: {roof}");
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
    println!("GPU back end: `cargo run --release -p deform-runtime --example gpu_bench`");
}
