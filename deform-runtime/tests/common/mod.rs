//! Shared helpers of the integration tests (included with `mod common;`).
#![allow(dead_code)]

use deform_runtime::obj::ObjMesh;
use deform_runtime::pipeline::{SetupOptions, build};
use deform_runtime::{DeformOptions, Deformer, Real, synthetic};
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

/// The stockinette tile from the project's test data.
pub fn stockinette() -> Tile {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    yarn_pattern::pyp::read_pyp(path)
        .expect("stockinette test data")
        .tile
}

/// Non-uniform axes containing the samples used by the tests.
pub fn axes() -> [Vec<f64>; 3] {
    [
        vec![-0.2, -0.05, 0.0, 0.3, 1.0],
        vec![-0.7, -0.2, 0.0, 0.2, 0.7],
        vec![-0.2, 0.0, 0.15, 1.0],
    ]
}

/// Multilinear synthetic database of `tile`.
pub fn database(tile: &Tile) -> Database {
    synthetic::database(tile, axes(), synthetic::multilinear(tile.radius))
}

/// A flat grid covering about `cells_u × cells_v` pattern periods, with `quads` quads per side.
pub fn grid(tile: &Tile, cells_u: f64, cells_v: f64, quads: usize) -> ObjMesh {
    synthetic::grid_mesh(
        quads,
        quads,
        cells_u * tile.period[0],
        cells_v * tile.period[1],
    )
}

/// A deformer with the given options.
pub fn deformer<T: Real>(
    tile: &Tile,
    db: &Database,
    mesh: &ObjMesh,
    deform: DeformOptions,
) -> Deformer<T> {
    let options = SetupOptions {
        uv_scale: 1.0,
        deform,
        ..SetupOptions::default()
    };
    build::<T>(tile, db, mesh, &options).expect("setup")
}
