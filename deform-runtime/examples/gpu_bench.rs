//! The GPU benchmark as one command, for a machine with a real GPU:
//!
//! ```sh
//! cargo run --release -p deform-runtime --example gpu_bench -- [cells_per_side] [frames]
//! ```
//!
//! Builds the throughput scene ([`deform_runtime::synthetic::throughput_scene`]: the
//! stockinette tile on a 64 × 64-quad sheet, default 320 × 320 periods = 10.2 M yarn
//! vertices, synthetic 9³ database), runs the full frame on the GPU back end and on the CPU
//! ([`deform_runtime::gpu::benchmark`], best of `frames`, default 10) and prints the frame
//! times, vertices per second, the ratio to MADYPG's GPU runtime (42.7 M vertices in 63 ms on
//! a GTX 1080 Ti, paper 004 Table 1) and the CPU/GPU agreement. It also runs on Mesa's
//! lavapipe (CPU Vulkan), where the times say nothing about a GPU. Exits non-zero without an
//! adapter.

use deform_runtime::roofline::MADYPG_GPU_VERTICES_PER_SECOND;
use deform_runtime::{gpu, synthetic};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let cells: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(320.0);
    let frames: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(10);
    let tile = yarn_pattern::pyp::read_pyp(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    ))?
    .tile;
    let mut scene = synthetic::throughput_scene::<f32>(&tile, cells)?;
    let b = gpu::benchmark(&mut scene, frames)?;
    let rate = |s: f64| b.vertices as f64 / s;
    println!("adapter: {}", b.adapter);
    println!(
        "{} yarn vertices per frame, {} dispatch(es)",
        b.vertices, b.chunks
    );
    println!(
        "GPU frame (CPU mesh stage + upload + dispatch + read-back): {:.2} ms = {:.1} M vertices/s = {:.2}x MADYPG's 0.68 G vertices/s",
        b.gpu_frame_seconds * 1e3,
        rate(b.gpu_frame_seconds) / 1e6,
        rate(b.gpu_frame_seconds) / MADYPG_GPU_VERTICES_PER_SECOND
    );
    println!(
        "GPU vertex stage (upload + dispatch + read-back): {:.2} ms = {:.1} M vertices/s",
        b.gpu_vertex_seconds * 1e3,
        rate(b.gpu_vertex_seconds) / 1e6
    );
    println!(
        "CPU frame ({} rayon threads): {:.2} ms = {:.1} M vertices/s",
        rayon::current_num_threads(),
        b.cpu_frame_seconds * 1e3,
        rate(b.cpu_frame_seconds) / 1e6
    );
    println!(
        "GPU vs CPU: max relative coordinate difference {:.2e}, max twist difference {:.2e} rad",
        b.max_relative_difference, b.max_twist_difference
    );
    println!("{}", serde_json::to_string(&b)?);
    Ok(())
}
