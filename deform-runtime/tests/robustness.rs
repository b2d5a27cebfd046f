//! Bad inputs never produce NaN yarn vertices or a crash, and malformed or mismatched
//! databases fail with clear errors.

mod common;

use common::*;
use deform_runtime::{DeformError, DeformOptions, RuntimeDatabase, synthetic};

fn all_finite(d: &deform_runtime::Deformer<f32>) -> bool {
    let o = d.output();
    o.x.iter()
        .chain(&o.y)
        .chain(&o.z)
        .chain(&o.twist)
        .all(|v| v.is_finite())
}

#[test]
fn degenerate_inverted_stretched_and_nan_faces_stay_finite() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 3.0, 4.0, 6);
    for clamp in [true, false] {
        let options = DeformOptions {
            clamp_compression: clamp,
            ..DeformOptions::default()
        };
        let mut d = deformer::<f32>(&tile, &db, &mesh, options);
        let rest = synthetic::map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]);
        // Frame 1: a NaN vertex, an infinite vertex, a collapsed triangle (vertex 8 moved onto
        // vertex 7), an inverted corner (vertex 20 pushed across its neighbours) and a huge
        // stretch of one vertex.
        let mut p = rest.clone();
        p[3] = [f64::NAN, 0.0, 0.0];
        p[10][2] = f64::INFINITY;
        p[8] = p[7];
        p[20][0] -= 3.0 * tile.period[0];
        p[30] = [1e6, -1e6, 1e6];
        let stats = d.frame(&p).unwrap();
        assert!(all_finite(&d), "clamp {clamp}: NaN in output");
        assert_eq!(stats.mesh.positions_replaced, 2);
        assert!(stats.mesh.faces_degenerate >= 1, "{stats:?}");
        // Frame 2: every position NaN: outputs keep their last values.
        let nan = vec![[f64::NAN; 3]; rest.len()];
        let stats = d.frame(&nan).unwrap();
        assert!(all_finite(&d));
        assert_eq!(stats.mesh.positions_replaced, rest.len());
        // Frame 3: everything collapsed to one point: degenerate everywhere.
        let stats = d.frame(&vec![[0.5, 0.5, 0.5]; rest.len()]).unwrap();
        assert!(all_finite(&d));
        assert_eq!(stats.mesh.faces_degenerate, d.mesh().n_faces());
        // I = 0 everywhere: every looked-up vertex has its eigenvalues raised.
        assert_eq!(
            stats.vertices.clamped, stats.vertices.processed,
            "{stats:?}"
        );
    }
}

#[test]
fn nan_on_the_first_frame_falls_back_to_the_rest_position() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 2.0, 2.0, 3);
    let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    let mut p = synthetic::map_uvs(&mesh, |uv| [uv[0], uv[1], 0.0]);
    p[0] = [f64::NAN; 3];
    let stats = d.frame(&p).unwrap();
    assert_eq!(stats.mesh.positions_replaced, 1);
    assert!(all_finite(&d));
    assert_eq!(d.geometry().positions[0], [0.0, 0.0, 0.0]);
}

#[test]
fn database_with_another_vertex_count_is_rejected() {
    let tile = stockinette();
    let mut other = tile.clone();
    other.positions.pop();
    let db = synthetic::database(&other, axes(), synthetic::multilinear(1e-3));
    let err = RuntimeDatabase::<f32>::new(&db, &tile).unwrap_err();
    assert!(
        matches!(
            err,
            DeformError::VertexCountMismatch {
                database: 99,
                pattern: 100
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("99"), "{err}");
}

#[test]
fn non_finite_database_values_are_rejected_with_row_and_vertex() {
    let tile = stockinette();
    let mut db = database(&tile);
    let per_vertex = db.samples_per_vertex();
    db.data[3 * per_vertex + 7][1] = f32::NAN;
    let err = RuntimeDatabase::<f32>::new(&db, &tile).unwrap_err();
    match err {
        DeformError::NonFiniteData { row, vertex, .. } => {
            assert_eq!((row, vertex), (3 * per_vertex + 7, 3));
        }
        other => panic!("unexpected error {other}"),
    }
}

#[test]
fn malformed_database_files_name_the_file() {
    let tile = stockinette();
    let dir = std::env::temp_dir().join(format!("deform-runtime-baddb-{}", std::process::id()));
    database(&tile).write(&dir).unwrap();
    // Round trip works.
    let db = yarn_pattern::madypg::Database::read(&dir).unwrap();
    RuntimeDatabase::<f32>::new(&db, &tile).unwrap();
    // Decreasing axis.
    std::fs::write(dir.join("axes.txt"), "0 1\n0.5 0.2\n0\n").unwrap();
    let err = deform_runtime::pipeline::load_pattern_and_database(
        std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/data/patterns/stockinette.pyp"
        )),
        &dir,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("axes.txt:2"), "{err}");
    // Truncated data.
    database(&tile).write(&dir).unwrap();
    let bytes = std::fs::read(dir.join("data.npy")).unwrap();
    std::fs::write(dir.join("data.npy"), &bytes[..bytes.len() - 16]).unwrap();
    let err = yarn_pattern::madypg::Database::read(&dir)
        .unwrap_err()
        .to_string();
    assert!(err.contains("data.npy"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn invalid_options_are_rejected() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 2.0, 2.0, 2);
    let options = deform_runtime::pipeline::SetupOptions {
        uv_scale: 1.0,
        deform: DeformOptions {
            lambda_min: f64::NAN,
            ..DeformOptions::default()
        },
        ..Default::default()
    };
    let err = deform_runtime::pipeline::build::<f32>(&tile, &db, &mesh, &options).unwrap_err();
    assert!(err.to_string().contains("lambda_min"), "{err}");
    let options = deform_runtime::pipeline::SetupOptions {
        uv_scale: 1e-9,
        ..options
    };
    let err = deform_runtime::pipeline::build::<f32>(&tile, &db, &mesh, &options).unwrap_err();
    assert!(matches!(err, DeformError::EmptyEmbedding { .. }), "{err}");
}

#[test]
fn a_wrong_uv_scale_fails_fast_on_rectangular_and_sheared_tiles() {
    for skew in [0.0, 0.5] {
        let mut tile = stockinette();
        tile.skew = skew;
        let db = database(&tile);
        let mesh = grid(&tile, 2.0, 2.0, 2);
        // UVs a million times too large: about 10¹² cells per triangle.
        let options = deform_runtime::pipeline::SetupOptions {
            uv_scale: 1e6,
            ..Default::default()
        };
        let err = deform_runtime::pipeline::build::<f32>(&tile, &db, &mesh, &options).unwrap_err();
        assert!(
            matches!(
                err,
                DeformError::Option {
                    name: "uv_scale",
                    ..
                }
            ),
            "skew {skew}: {err}"
        );
        assert!(
            err.to_string().contains("pattern cells"),
            "skew {skew}: {err}"
        );
    }
}
