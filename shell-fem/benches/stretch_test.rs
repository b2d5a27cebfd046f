//! Criterion benchmark: one virtual stretch test (bias, s = 0.3, from rest, fixed clamps) against
//! mesh size.

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::swatch::{StretchTest, SwatchConfig};
use yarn_pattern::direction::Direction;

fn stretch_test(c: &mut Criterion) {
    let mut group = c.benchmark_group("stretch_test_bias_s0.3");
    group.sample_size(10);
    for (nx, ny) in [(10, 6), (20, 12), (40, 24), (80, 48)] {
        let cfg = SwatchConfig {
            nx,
            ny,
            ..SwatchConfig::default()
        };
        let nodes = (nx + 1) * (ny + 1);
        group.bench_with_input(
            BenchmarkId::from_parameter(format!("{nx}x{ny} ({nodes} nodes)")),
            &cfg,
            |b, cfg| {
                b.iter(|| {
                    let mut t = StretchTest::new(
                        cfg,
                        Material::augmented(InPlaneParams::example()),
                        Direction::Bias.angle(),
                    )
                    .expect("valid swatch");
                    t.solve_to(0.3).expect("converges")
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, stretch_test);
criterion_main!(benches);
