//! The convention of MADYPG's published displacement tables (`tests/data/madypg`, MIT), read
//! through our reader and written back through our writer: what ΔQ is relative to, in which
//! frame, and that two tables of one tile agree where their samples coincide.

use std::path::PathBuf;

use yarn_pattern::madypg::{DATA_FILE, Database};
use yarn_pattern::pyp::read_pyp;

/// The tile of both tables: MADYPG ships it as `pyp` beside each, byte-identical to this file.
const TILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/data/patterns/stockinette.pyp"
);

fn published(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/madypg")).join(name)
}

fn position(axis: &[f64], value: f64) -> usize {
    axis.iter()
        .position(|&a| (a - value).abs() < 1e-9)
        .unwrap_or_else(|| panic!("{value} is not a sample of {axis:?}"))
}

#[test]
fn published_tables_are_relative_to_their_tile_at_zero_strain() {
    for name in ["model_stock_5", "model_stock_9"] {
        let db = Database::read(published(name)).unwrap();
        let tile = read_pyp(TILE).unwrap().tile;
        assert_eq!(db.n_vertices, tile.n_vertices(), "{name}");
        let zero = [0, 1, 2].map(|k| position(&db.axes[k], 0.0));
        let mut twist = 0.0f64;
        for v in 0..db.n_vertices {
            let row = db.get(v, zero[0], zero[1], zero[2]).unwrap();
            // The tile's own positions are the zero-strain state: no displacement at all...
            assert_eq!(&row[..3], &[0.0; 3], "{name}, vertex {v}");
            twist = twist.max(f64::from(row[3]).abs());
        }
        // ...while the twist angles move a little (solver-level, well under a degree).
        assert!(twist > 0.0 && twist < 0.02, "{name}: largest Δθ {twist}");
        // Elsewhere the displacements are a sizeable fraction of the yarn radius.
        let corner = db.get(0, 0, 0, 0).unwrap();
        let size = corner[..3]
            .iter()
            .map(|c| f64::from(*c).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            size > 0.1 * tile.radius,
            "{name}: corner displacement {size}"
        );
    }
}

#[test]
fn the_five_and_nine_sample_tables_agree_where_their_samples_coincide() {
    let five = Database::read(published("model_stock_5")).unwrap();
    let nine = Database::read(published("model_stock_9")).unwrap();
    let mut compared = 0;
    for sx in [-0.2, 0.0, 1.0] {
        for sy in [-0.2, 0.0, 1.0] {
            let a = [
                position(&five.axes[0], sx),
                position(&five.axes[1], 0.0),
                position(&five.axes[2], sy),
            ];
            let b = [
                position(&nine.axes[0], sx),
                position(&nine.axes[1], 0.0),
                position(&nine.axes[2], sy),
            ];
            for v in 0..five.n_vertices {
                let p = five.get(v, a[0], a[1], a[2]).unwrap();
                let q = nine.get(v, b[0], b[1], b[2]).unwrap();
                for c in 0..4 {
                    assert!(
                        (p[c] - q[c]).abs() <= 1e-6 * (1.0 + p[c].abs()),
                        "({sx}, 0, {sy}) vertex {v} component {c}: {} vs {}",
                        p[c],
                        q[c]
                    );
                }
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 9 * five.n_vertices);
}

#[test]
fn a_published_table_round_trips_through_our_writer() {
    let dir = std::env::temp_dir().join(format!("published-round-trip-{}", std::process::id()));
    for name in ["model_stock_5", "model_stock_9"] {
        let db = Database::read(published(name)).unwrap();
        let out = dir.join(name);
        db.write(&out).unwrap();
        assert_eq!(Database::read(&out).unwrap(), db, "{name}");
        // Same header size (numpy pads to 64 bytes; npyz writes the shape as `(R, 4, )`,
        // numpy as `(R, 4)`) and the same data bytes.
        let ours = std::fs::read(out.join(DATA_FILE)).unwrap();
        let theirs = std::fs::read(published(name).join(DATA_FILE)).unwrap();
        assert_eq!(ours.len(), theirs.len(), "{name}");
        let header = 10 + usize::from(u16::from_le_bytes([theirs[8], theirs[9]]));
        assert_eq!(header % 64, 0, "{name}");
        assert!(
            ours[header..] == theirs[header..],
            "{name}: data bytes differ"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
