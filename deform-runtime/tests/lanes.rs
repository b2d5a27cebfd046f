//! The batched SIMD kernel (`deform_runtime::lanes`, what `Deformer::frame` runs) against the
//! one-vertex reference `kernel::deform_vertex`: the same output bit for bit and the same
//! counters, for every option switch, uniform and non-uniform database axes, faces that are
//! skipped, clamped and curved, and meshes whose triangles are smaller than a batch's run of
//! vertices (so that batches cross face boundaries).

mod common;

use common::*;
use deform_runtime::kernel::{KernelInputs, VertexCounters, deform_vertex};
use deform_runtime::{DeformOptions, Deformer, Real, synthetic};
use yarn_pattern::madypg::Database;

/// The reference output and counters of the last frame of `d`, vertex by vertex.
fn reference<T: Real>(d: &Deformer<T>) -> ([Vec<T>; 4], VertexCounters) {
    let g = d.geometry();
    let input = KernelInputs {
        faces: &g.face_poly,
        skip: &g.face_skip,
        db: d.database(),
        rest_dq: d.rest_displacements(),
        twists: d.twists(),
        options: d.options(),
        eigen_floor: d.eigen_floor(),
    };
    let e = d.embedding();
    let mut counters = VertexCounters::default();
    let mut out: [Vec<T>; 4] = std::array::from_fn(|_| Vec::with_capacity(e.len()));
    for k in 0..e.len() {
        let (x, t) = deform_vertex(
            &input,
            e.triangle[k],
            e.du[k],
            e.dv[k],
            e.height[k],
            e.tile_vertex[k],
            &mut counters,
        );
        for c in 0..3 {
            out[c].push(x[c]);
        }
        out[3].push(t);
    }
    counters.processed = e.len();
    (out, counters)
}

/// Runs one frame of `positions` and compares it with the reference; returns the counters.
fn check<T: Real>(d: &mut Deformer<T>, positions: &[[f64; 3]], what: &str) -> VertexCounters {
    let stats = d.frame(positions).expect("frame");
    let (expected, counters) = reference(d);
    let out = d.output();
    let got = [&out.x, &out.y, &out.z, &out.twist];
    for c in 0..4 {
        for (k, (a, b)) in got[c].iter().zip(&expected[c]).enumerate() {
            assert!(
                a.as_().to_bits() == b.as_().to_bits(),
                "{what}: vertex {k} component {c}: lanes {a:?}, reference {b:?}"
            );
        }
    }
    // Non-finite outputs keep the previous value in both, so only counters are compared there.
    assert_eq!(stats.vertices, counters, "{what}: counters");
    counters
}

fn options() -> Vec<(&'static str, DeformOptions)> {
    let base = DeformOptions {
        skip_static: false,
        ..DeformOptions::default()
    };
    vec![
        ("default", base),
        (
            "no clamping",
            DeformOptions {
                clamp_compression: false,
                ..base
            },
        ),
        (
            "no bending",
            DeformOptions {
                linearized_bending: false,
                ..base
            },
        ),
        (
            "face forms, affine map",
            DeformOptions {
                interpolate_forms: false,
                phong: false,
                ..base
            },
        ),
        (
            "no displacement",
            DeformOptions {
                displacement: false,
                ..base
            },
        ),
        (
            "no identity skipping",
            DeformOptions {
                skip_identity: false,
                ..base
            },
        ),
        (
            "strong clamping",
            DeformOptions {
                lambda_min: 0.99,
                ..base
            },
        ),
    ]
}

/// A deformation that is the identity on the left half of the sheet (skipped faces), a strong
/// compressive wave next (clamped) and a stretch on the right quarter.
fn mixed(uv: [f64; 2], width: f64) -> [f64; 3] {
    let [u, v] = uv;
    let s = u / width;
    if s < 0.5 {
        [u, v, 0.0]
    } else if s < 0.75 {
        let w = synthetic::wave(uv, 0.2 * width);
        [
            u + 0.3 * (u - width / 2.0) * -(8.0 * v / width).cos(),
            w[1],
            w[2],
        ]
    } else {
        [
            1.4 * u,
            0.9 * v + 0.2 * u,
            0.05 * width * (5.0 * v / width).sin(),
        ]
    }
}

fn run_all<T: Real>(db: &Database, quads: usize) -> VertexCounters {
    let tile = stockinette();
    let mesh = grid(&tile, 6.0, 5.0, quads);
    let width = 6.0 * tile.period[0];
    let mut total = VertexCounters::default();
    for (name, opts) in options() {
        let mut d = deformer::<T>(&tile, db, &mesh, opts);
        for (frame, positions) in [
            synthetic::map_uvs(&mesh, |uv| mixed(uv, width)),
            synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 0.3 * width)),
        ]
        .iter()
        .enumerate()
        {
            total = total + check(&mut d, positions, &format!("{name}, frame {frame}"));
        }
    }
    total
}

#[test]
fn lanes_equal_the_reference_bit_for_bit_f32_uniform_axes() {
    let tile = stockinette();
    let db = synthetic::database(
        &tile,
        synthetic::uniform_axes(5),
        synthetic::multilinear(tile.radius),
    );
    // Large triangles (long runs in one face) and small ones (many batches across faces).
    for quads in [8, 40] {
        let c = run_all::<f32>(&db, quads);
        // Each path was exercised.
        assert!(c.lookups_skipped > 0, "{quads} quads: {c:?}");
        assert!(c.clamped > 0, "{quads} quads: {c:?}");
    }
}

#[test]
fn lanes_equal_the_reference_bit_for_bit_f64_non_uniform_axes() {
    let tile = stockinette();
    let db = database(&tile);
    for quads in [8, 40] {
        let c = run_all::<f64>(&db, quads);
        assert!(
            c.lookups_skipped > 0 && c.clamped > 0,
            "{quads} quads: {c:?}"
        );
    }
}

#[test]
fn lanes_equal_the_reference_on_a_curved_rest_mesh() {
    let tile = stockinette();
    let db = synthetic::database(
        &tile,
        synthetic::uniform_axes(9),
        synthetic::multilinear(tile.radius),
    );
    let r = 3.0 * tile.period[0];
    let mesh = synthetic::cylinder_mesh(12, 7, r, 0.5, 4.0 * tile.period[1]);
    let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    let squeezed: Vec<[f64; 3]> = mesh
        .positions
        .iter()
        .map(|p| [0.8 * p[0], 1.1 * p[1], 0.9 * p[2]])
        .collect();
    let c = check(&mut d, &squeezed, "squeezed cylinder");
    assert!(c.processed > 1000, "{c:?}");
}
