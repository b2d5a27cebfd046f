//! Exactness of the pipeline on flat meshes: a uniform strain equal to a database sample
//! reproduces that sample's deformed tile; zero strain leaves the pattern unchanged; strains
//! between samples interpolate the (multilinear) synthetic data exactly.

mod common;

use common::*;
use deform_runtime::{DeformOptions, Deformer, Real, synthetic};
use yarn_pattern::tile::Tile;

/// Largest distance (m) between the output and `F₂ (X + ΔQ(s))` over all yarn vertices, and
/// largest twist error (rad).
fn max_error<T: Real>(d: &Deformer<T>, tile: &Tile, s: [f64; 3]) -> (f64, f64) {
    let f = synthetic::sqrt_i(s);
    let dq = synthetic::multilinear(tile.radius);
    let e = d.embedding();
    let out = d.output();
    let (mut worst, mut worst_twist) = (0.0f64, 0.0f64);
    for k in 0..e.len() {
        let v = e.tile_vertex[k] as usize;
        let q = dq(v, s);
        let x = [
            e.material[k][0] + q[0],
            e.material[k][1] + q[1],
            e.material[k][2] + q[2],
        ];
        let expected = [f[0] * x[0] + f[1] * x[1], f[2] * x[0] + f[3] * x[1], x[2]];
        let got = [out.x[k].as_(), out.y[k].as_(), out.z[k].as_()];
        let err = (0..3)
            .map(|c| (got[c] - expected[c]).powi(2))
            .sum::<f64>()
            .sqrt();
        worst = worst.max(err);
        let twist = tile.twists[v] + q[3];
        worst_twist = worst_twist.max((out.twist[k].as_() - twist).abs());
    }
    (worst, worst_twist)
}

fn run<T: Real>(s: [f64; 3], options: DeformOptions) -> (f64, f64, usize) {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 3.0, 4.0, 5);
    let mut d = deformer::<T>(&tile, &db, &mesh, options);
    let positions = synthetic::map_uvs(&mesh, synthetic::strain_map(s));
    let stats = d.frame(&positions).unwrap();
    assert_eq!(stats.vertices.nonfinite_output, 0);
    let (err, twist) = max_error(&d, &tile, s);
    (err / tile.radius, twist, d.embedding().len())
}

#[test]
fn uniform_strain_at_a_sample_reproduces_the_sample_tile_f64() {
    // Sample (sx, sa, sy) = (0.3, 0.2, 0.15); eigenvalues of I are above λmin = 0.8, so the
    // default pipeline (clamping, bending, Phong) must reproduce it exactly.
    for s in [[0.3, 0.2, 0.15], [1.0, -0.2, 0.0], [-0.05, 0.0, 0.15]] {
        let (err, twist, n) = run::<f64>(s, DeformOptions::default());
        assert!(n > 500, "embedding has {n} vertices");
        assert!(err < 1e-6, "strain {s:?}: max error {err:e} R");
        assert!(twist < 1e-6, "strain {s:?}: twist error {twist:e} rad");
    }
}

#[test]
fn uniform_strain_at_a_sample_reproduces_the_sample_tile_f32() {
    // f32 world coordinates on a mesh of ~5 cm carry an ulp of ~4e-9 m = 4e-6 R; the bound
    // is a few ulps of the coordinates, not of R.
    let (err, _, _) = run::<f32>([0.3, 0.2, 0.15], DeformOptions::default());
    assert!(err < 5e-5, "max error {err:e} R");
}

#[test]
fn uniform_strain_between_samples_interpolates_multilinear_data_exactly() {
    let (err, twist, _) = run::<f64>([0.1, 0.05, 0.5], DeformOptions::default());
    assert!(err < 1e-6, "max error {err:e} R");
    assert!(twist < 1e-6, "twist error {twist:e}");
}

#[test]
fn zero_strain_leaves_the_pattern_unchanged() {
    for skip in [true, false] {
        let options = DeformOptions {
            skip_identity: skip,
            ..DeformOptions::default()
        };
        let (err, twist, _) = run::<f64>([0.0; 3], options);
        assert!(err < 1e-9, "skip {skip}: max error {err:e} R");
        assert!(twist < 1e-12, "skip {skip}: twist error {twist:e}");
        let (err, _, _) = run::<f32>([0.0; 3], options);
        assert!(err < 5e-5, "f32, skip {skip}: max error {err:e} R");
    }
}

#[test]
fn strains_outside_the_range_clamp_to_the_nearest_sample() {
    // sx = 1.5 is beyond the last sample 1.0: the lookup must use ΔQ(1.0, sa, sy), while the
    // mesh embedding still stretches by 1 + 1.5.
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 2.0, 3.0, 4);
    let mut d = deformer::<f64>(&tile, &db, &mesh, DeformOptions::default());
    let s = [1.5, 0.0, 0.15];
    d.frame(&synthetic::map_uvs(&mesh, synthetic::strain_map(s)))
        .unwrap();
    let f = synthetic::sqrt_i(s);
    let dq = synthetic::multilinear(tile.radius);
    let e = d.embedding();
    for k in 0..e.len() {
        let q = dq(e.tile_vertex[k] as usize, [1.0, 0.0, 0.15]);
        let x = [e.material[k][0] + q[0], e.material[k][1] + q[1]];
        let expected = f[0] * x[0] + f[1] * x[1];
        let err = (d.output().x[k] - expected).abs() / tile.radius;
        assert!(err < 1e-6, "vertex {k}: {err:e} R");
    }
}
