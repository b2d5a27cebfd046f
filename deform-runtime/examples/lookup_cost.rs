//! Micro-measurement of the database lookup alone: `cargo run --release -p deform-runtime
//! --example lookup_cost`.

use deform_runtime::{RuntimeDatabase, synthetic};
use std::time::Instant;

fn main() {
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
    let rt = RuntimeDatabase::<f32>::new(&db, &tile).expect("database");
    let n = 1 << 22;
    let strains: Vec<[f32; 3]> = (0..n)
        .map(|k| {
            let t = k as f32 * 1e-6;
            [0.1 + 0.05 * t.sin(), 0.05 * t.cos(), 0.08]
        })
        .collect();
    for _ in 0..3 {
        let t = Instant::now();
        let mut acc = [0.0f32; 4];
        for (k, s) in strains.iter().enumerate() {
            let d = rt.lookup(k % 100, *s);
            for c in 0..4 {
                acc[c] += d[c];
            }
        }
        let dt = t.elapsed().as_secs_f64();
        println!(
            "lookup: {:.1} ns each (check {:?})",
            dt / n as f64 * 1e9,
            acc[0]
        );
        let t = Instant::now();
        let mut acc = 0.0f32;
        for s in &strains {
            let w = rt.weights(*s);
            acc += w[0].t + w[1].t + w[2].t + w[0].lo as f32;
        }
        let dt = t.elapsed().as_secs_f64();
        println!(
            "weights only: {:.1} ns each (check {acc})",
            dt / n as f64 * 1e9
        );
    }
}
