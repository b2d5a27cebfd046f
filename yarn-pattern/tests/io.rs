//! File I/O of the periodic tile (`.pyp`) and of the displacement database (`axes.txt` +
//! `data.npy`): the real stockinette tile, round trips, and located errors on malformed input.

use std::path::PathBuf;

use yarn_pattern::madypg::{Database, DatabaseError, NpyProblem};
use yarn_pattern::pyp::{Block, PypError, parse_pyp, read_pyp, to_pyp_string, write_pyp};
use yarn_pattern::tile::TileError;

const STOCKINETTE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/data/patterns/stockinette.pyp"
);

// Layout of stockinette.pyp (1-based lines): *pattern 1 (data 2), *Q 4 (vertex v on line
// 5 + v), *E 106 (edge e on 107 + e), *RL 208 (209 + e), *RK 310, *RT 412, *RefD1 514,
// *RefT 616 (617 + v), 717 lines in all.
const Q_LINE: usize = 5;
const E_LINE: usize = 107;
const RL_LINE: usize = 209;

fn stockinette_text() -> String {
    std::fs::read_to_string(STOCKINETTE).expect("stockinette.pyp is readable")
}

/// The real file's lines (index = line number − 1), edited by `edit`, joined with `\n`.
fn edited(edit: impl FnOnce(&mut Vec<String>)) -> String {
    let mut lines: Vec<String> = stockinette_text().lines().map(str::to_string).collect();
    edit(&mut lines);
    lines.join("\n")
}

/// Parses `text` and returns the error message, which must name the file and `line`.
fn parse_error(text: &str, line: usize) -> String {
    let err = parse_pyp(text, "stockinette.pyp").expect_err("malformed input must be rejected");
    let msg = err.to_string();
    assert!(
        msg.starts_with(&format!("stockinette.pyp:{line}: ")),
        "expected an error at line {line}, got: {msg}"
    );
    msg
}

fn tmp_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("sim-periodic-io")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn stockinette_loads_and_is_consistent() {
    let read = read_pyp(STOCKINETTE).unwrap();
    assert!(read.defaulted.is_empty(), "all blocks are in the file");
    let tile = read.tile;
    assert_eq!(tile.n_vertices(), 100);
    assert_eq!(tile.edges.len(), 100);
    assert_eq!(tile.period, [0.0150513, 0.00793099]);
    assert_eq!(tile.radius, 0.001);
    tile.validate().unwrap();

    // Edge 0 is "49 0 1 0": it does not start at vertex 0.
    assert_eq!(tile.edges[0].v0, 49);
    assert_eq!(tile.edges[0].v1, 0);
    assert_eq!(tile.edges[0].shift, [1, 0]);
    // Spot values from the file.
    assert_eq!(tile.positions[0].x, -0.00775656);
    assert_eq!(tile.twists[0], 0.158865);
    // Per-edge blocks are listed by start vertex: *RL line 0 (0.0010969) is the edge leaving
    // vertex 0, which is edge 1 ("0 1 0 0"); edge 0 leaves vertex 49 (*RL line 49).
    assert_eq!(tile.rest_lengths[1], 0.0010969);
    assert_eq!(tile.rest_lengths[0], 0.00111363);
    assert_eq!(tile.reference_directors[1].x, -0.252932);
    assert_eq!(tile.rest_curvatures[0], [0.565936, -0.245898]);
    assert_eq!(tile.reference_twists[99], -0.0102376);

    let topology = tile.topology().unwrap();
    for v in 0..100 {
        assert_eq!(tile.edges[topology.outgoing(v)].v0, v);
        assert_eq!(tile.edges[topology.incoming(v)].v1, v);
    }
    let loops = topology.loops();
    assert_eq!(loops.len(), 2, "two yarn loops");
    for lp in &loops {
        assert_eq!(lp.len(), 50);
        for k in 0..lp.len() {
            let (e, next) = (lp[k], lp[(k + 1) % lp.len()]);
            assert_eq!(
                tile.edges[e].v1, tile.edges[next].v0,
                "loops follow the yarn"
            );
        }
        // Each loop closes after a net shift of one period along x (a course of loops).
        let net = lp.iter().fold([0, 0], |acc, &e| {
            let s = tile.edges[e].shift;
            [acc[0] + s[0], acc[1] + s[1]]
        });
        assert_eq!(net, [1, 0]);
    }
    assert_eq!(loops[0], (0..50).collect::<Vec<_>>());

    // The stored rest lengths agree with the rest geometry: all are 0.22-0.29 % shorter than
    // the edges (the stored state is slightly stretched).
    let mut max_rel = 0.0_f64;
    for e in 0..100 {
        let length = tile.edge_vector(e).norm();
        let rel = (tile.rest_lengths[e] - length) / length;
        assert!(
            (-0.004..0.0).contains(&rel),
            "edge {e}: relative difference {rel}"
        );
        max_rel = max_rel.max(rel.abs());
    }
    println!("max relative difference between *RL and |edge|: {max_rel:.3e}");
    // Read by *E line instead (line i for edge i), *RL would be off by up to 31 %.
    let by_line = (0..100)
        .map(|i| {
            let length = tile.edge_vector(i).norm();
            (tile.rest_lengths[topology.outgoing(i)] - length).abs() / length
        })
        .fold(0.0, f64::max);
    assert!(by_line > 0.3, "{by_line}");

    // Reference directors: unit vectors orthogonal to their edges (to the file's precision).
    for e in 0..100 {
        let d = tile.reference_directors[e];
        let t = tile.edge_vector(e).normalize();
        assert!(
            (d.norm() - 1.0).abs() < 1e-5,
            "edge {e}: |d1| = {}",
            d.norm()
        );
        assert!(d.dot(&t).abs() < 1e-4, "edge {e}: d1 · t = {}", d.dot(&t));
    }
}

#[test]
fn write_read_round_trips_bit_exactly() {
    let tile = read_pyp(STOCKINETTE).unwrap().tile;
    let path = tmp_dir("roundtrip").join("stockinette.pyp");
    write_pyp(&tile, &path).unwrap();
    let back = read_pyp(&path).unwrap();
    assert!(back.defaulted.is_empty());
    assert_eq!(back.tile, tile);
    // The written file holds the original numbers, line for line, in the original layout.
    let numbers = |text: &str| -> Vec<Vec<String>> {
        text.lines()
            .map(|l| l.split('#').next().unwrap().split_whitespace())
            .map(|tokens| tokens.map(str::to_string).collect::<Vec<_>>())
            .map(|t| match t.first() {
                Some(h) if h.starts_with('*') => t,
                _ => t
                    .iter()
                    .map(|x| x.parse::<f64>().unwrap().to_string())
                    .collect(),
            })
            .collect()
    };
    let written = std::fs::read_to_string(&path).unwrap();
    assert_eq!(numbers(&written), numbers(&stockinette_text()));

    // Values that need every digit, and extreme magnitudes, survive too.
    let mut odd = tile.clone();
    odd.positions[3].x = 0.1 + 0.2;
    odd.positions[4].y = -1.234_567_890_123_456_7e-300;
    odd.twists[5] = 1e300;
    odd.rest_twists[6] = -0.0;
    odd.reference_twists[7] = f64::MIN_POSITIVE / 3.0; // subnormal
    odd.radius = std::f64::consts::PI * 1e-4;
    let text = to_pyp_string(&odd).unwrap();
    let back = parse_pyp(&text, "odd.pyp").unwrap().tile;
    assert_eq!(back, odd);
    assert_eq!(back.rest_twists[6].to_bits(), (-0.0_f64).to_bits());
    // The writer is stable: writing the re-read tile gives the same text.
    assert_eq!(to_pyp_string(&back).unwrap(), text);
}

#[test]
fn writer_rejects_invalid_tiles() {
    let mut tile = read_pyp(STOCKINETTE).unwrap().tile;
    tile.rest_lengths.pop();
    let err = to_pyp_string(&tile).unwrap_err();
    assert!(matches!(
        err,
        TileError::LengthMismatch {
            field: "rest_lengths",
            ..
        }
    ));
    let err = write_pyp(&tile, tmp_dir("invalid").join("x.pyp")).unwrap_err();
    assert!(matches!(err, PypError::InvalidTile(_)), "{err}");
}

#[test]
fn missing_optional_blocks_are_defaulted_and_reported() {
    // Keep *pattern, *Q, *E only (lines 1..=206).
    let text = edited(|l| l.truncate(206));
    let read = parse_pyp(&text, "stockinette.pyp").unwrap();
    assert_eq!(
        read.defaulted,
        [Block::RL, Block::RK, Block::RT, Block::RefD1, Block::RefT]
    );
    let tile = &read.tile;
    for e in 0..100 {
        assert_eq!(tile.rest_lengths[e], tile.edge_vector(e).norm());
        let d = tile.reference_directors[e];
        assert!((d.norm() - 1.0).abs() < 1e-12);
        assert!(d.dot(&tile.edge_vector(e)).abs() < 1e-12 * tile.rest_lengths[e]);
    }
    assert!(tile.rest_curvatures.iter().all(|k| *k == [0.0, 0.0]));
    assert!(tile.rest_twists.iter().all(|&t| t == 0.0));
    assert!(tile.reference_twists.iter().all(|&t| t == 0.0));
}

#[test]
fn blocks_may_come_in_any_order_after_pattern() {
    // Move *E (lines 106..=207) to the end, *RefT before *Q.
    let text = edited(|l| {
        let e: Vec<String> = l.drain(105..207).collect();
        let reft: Vec<String> = l.drain(l.len() - 102..).collect();
        l.extend(e);
        l.splice(3..3, reft);
    });
    let reordered = parse_pyp(&text, "reordered.pyp").unwrap();
    assert_eq!(reordered.tile, read_pyp(STOCKINETTE).unwrap().tile);
}

#[test]
fn malformed_pyp_inputs_give_located_errors() {
    // A dropped value on a *Q line (vertex 12, line 17).
    let text = edited(|l| l[16] = "-0.0043541 0.00314232 -0.00131091".into());
    let msg = parse_error(&text, 17);
    assert!(
        msg.contains(r#"expected 4 numbers "x y z t" in block *Q, found 3"#),
        "{msg}"
    );

    // A bad token on an *E line (edge 13, line 120).
    let text = edited(|l| l[119] = "12 1x3 0 0".into());
    let msg = parse_error(&text, 120);
    assert!(
        msg.contains("vertex index") && msg.contains("\"1x3\""),
        "{msg}"
    );

    // A bad token in *RK (line 320).
    let text = edited(|l| l[319] = "0.1 abc".into());
    let msg = parse_error(&text, 320);
    assert!(
        msg.contains("expected a number") && msg.contains("\"abc\""),
        "{msg}"
    );

    // A missing required block (*E removed): reported at the end of the file.
    let text = edited(|l| {
        l.drain(105..207);
    });
    let last = text.lines().count();
    let msg = parse_error(&text, last);
    assert!(msg.contains("expected block *E (required)"), "{msg}");

    // An extra line at the end of *Q (line 105).
    let text = edited(|l| l.insert(104, "0 0 0 0".into()));
    let msg = parse_error(&text, 105);
    assert!(
        msg.contains("expected 100 data lines in block *Q") && msg.contains("extra"),
        "{msg}"
    );

    // A missing line in *RK: reported at the block header (line 310).
    let text = edited(|l| {
        l.remove(399);
    });
    let msg = parse_error(&text, 310);
    assert!(
        msg.contains("expected 100 data lines in block *RK") && msg.contains("found 99"),
        "{msg}"
    );

    // An out-of-range vertex (edge 43, line 150).
    let text = edited(|l| l[149] = "42 100 0 0".into());
    let msg = parse_error(&text, 150);
    assert!(
        msg.contains("expected a vertex index < n = 100") && msg.contains("100"),
        "{msg}"
    );

    // A duplicate block (a second *RT after *RefT, at line 718).
    let text = edited(|l| {
        let rt: Vec<String> = l[411..512].to_vec();
        l.extend(rt);
    });
    let msg = parse_error(&text, 718);
    assert!(
        msg.contains("duplicate block *RT (first on line 412)"),
        "{msg}"
    );

    // A vertex with two outgoing edges: edge 43 (line 150) made to start at vertex 41, which
    // already starts edge 42 (line 149).
    let text = edited(|l| l[E_LINE + 43 - 1] = "41 43 0 0".into());
    let msg = parse_error(&text, E_LINE + 43);
    assert!(
        msg.contains("vertex 41 starts two edges (42 and 43)"),
        "{msg}"
    );
    assert!(msg.contains("expected exactly one outgoing edge"), "{msg}");

    // Two incoming edges: edge 44 (line 151) made to end at vertex 43, like edge 42.
    let text = edited(|l| l[E_LINE + 43] = "43 43 0 0".into());
    let msg = parse_error(&text, E_LINE + 44);
    assert!(msg.contains("expected exactly one incoming edge"), "{msg}");

    // NaN in *RL (edge 41, line 250).
    let text = edited(|l| l[RL_LINE + 41 - 1] = "NaN".into());
    let msg = parse_error(&text, 250);
    assert!(
        msg.contains("expected a finite number in block *RL") && msg.contains("NaN"),
        "{msg}"
    );

    // Infinity in *Q.
    let text = edited(|l| l[Q_LINE - 1] = "inf 0 0 0".into());
    let msg = parse_error(&text, Q_LINE);
    assert!(msg.contains("expected a finite number"), "{msg}");

    // n = 0.
    let text = edited(|l| l[1] = "0.0150513 0.00793099 0.001 0".into());
    let msg = parse_error(&text, 2);
    assert!(msg.contains("expected a vertex count n ≥ 1"), "{msg}");

    // n not an integer.
    let text = edited(|l| l[1] = "0.0150513 0.00793099 0.001 100.5".into());
    let msg = parse_error(&text, 2);
    assert!(
        msg.contains("expected a vertex count n") && msg.contains("\"100.5\""),
        "{msg}"
    );

    // A non-positive rest length (line 209: the edge leaving vertex 0, edge 1).
    let text = edited(|l| l[RL_LINE - 1] = "0".into());
    let msg = parse_error(&text, RL_LINE);
    assert!(
        msg.contains("rest length of edge 1 must be positive"),
        "{msg}"
    );
    let text = edited(|l| l[RL_LINE + 48] = "-1e-3".into());
    let msg = parse_error(&text, RL_LINE + 49);
    assert!(
        msg.contains("rest length of edge 0 must be positive"),
        "{msg}"
    );

    // A negative radius (line 2).
    let text = edited(|l| l[1] = "0.0150513 0.00793099 -0.001 100".into());
    let msg = parse_error(&text, 2);
    assert!(msg.contains("radius must be positive"), "{msg}");

    // An unknown block name (line 208).
    let text = edited(|l| l[207] = "*RestLengths".into());
    let msg = parse_error(&text, 208);
    assert!(
        msg.contains("unknown block *RestLengths; expected one of"),
        "{msg}"
    );

    // *pattern not first.
    let text = edited(|l| {
        l.drain(0..3);
    });
    let msg = parse_error(&text, 1);
    assert!(
        msg.contains("expected block *pattern first, found *Q"),
        "{msg}"
    );

    // Data before any block.
    let msg = parse_error("# a comment\n1 2 3\n", 2);
    assert!(msg.contains("expected a block header"), "{msg}");

    // Empty input.
    let msg = parse_error("", 1);
    assert!(msg.contains("expected block *pattern (required)"), "{msg}");
}

#[test]
fn damaged_files_never_panic() {
    let lines: Vec<String> = stockinette_text().lines().map(str::to_string).collect();
    for k in 0..lines.len() {
        let _ = parse_pyp(&lines[..k].join("\n"), "cut.pyp");
    }
    let garbage = [
        "",
        "*",
        "#",
        "1",
        "x",
        "1 2 3 4 5",
        "-1 -1 -1 -1",
        "0 0 0 0",
        "1e999",
    ];
    for i in 0..lines.len() {
        for g in garbage {
            let mut edited = lines.clone();
            edited[i] = g.to_string();
            if let Err(err) = parse_pyp(&edited.join("\n"), "damaged.pyp") {
                assert!(err.to_string().starts_with("damaged.pyp:"), "{err}");
            }
        }
    }
}

#[test]
fn io_errors_name_the_path() {
    let path = tmp_dir("missing").join("does-not-exist.pyp");
    let err = read_pyp(&path).unwrap_err();
    assert!(matches!(err, PypError::Io { .. }));
    assert!(err.to_string().contains("does-not-exist.pyp"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Displacement database

fn small_database() -> Database {
    let axes = [
        vec![0.8, 1.0, 1.3],
        vec![-0.2, 0.0],
        vec![0.9, 1.0, 1.05, 1.2],
    ];
    let n_vertices = 5;
    let mut db = Database {
        axes,
        n_vertices,
        data: Vec::new(),
    };
    // Each row encodes its own (vertex, isx, isa, isy), stored in the documented order.
    db.data = vec![[0.0; 4]; n_vertices * 3 * 2 * 4];
    for v in 0..n_vertices {
        for isy in 0..4 {
            for isa in 0..2 {
                for isx in 0..3 {
                    let row = isx + 3 * (isa + 2 * (isy + 4 * v));
                    db.data[row] = [v as f32, isx as f32, isa as f32, isy as f32];
                }
            }
        }
    }
    db
}

#[test]
fn database_round_trips_and_keeps_the_row_layout() {
    let db = small_database();
    db.validate().unwrap();
    let dir = tmp_dir("db-roundtrip");
    db.write(&dir).unwrap();
    let back = Database::read(&dir).unwrap();
    assert_eq!(back, db);
    assert_eq!(back.n_vertices, 5);
    for v in 0..5 {
        for isy in 0..4 {
            for isa in 0..2 {
                for isx in 0..3 {
                    let expected = [v as f32, isx as f32, isa as f32, isy as f32];
                    assert_eq!(back.get(v, isx, isa, isy), Some(expected));
                    assert_eq!(back.data[back.index(v, isx, isa, isy)], expected);
                }
            }
        }
    }
    assert_eq!(back.get(5, 0, 0, 0), None);
    assert_eq!(back.get(0, 3, 0, 0), None);
    assert_eq!(back.get(0, 0, 2, 0), None);
    assert_eq!(back.get(0, 0, 0, 4), None);

    // Non-trivial floats survive bit for bit (including -0 and subnormals).
    let mut odd = db.clone();
    odd.data[0] = [0.1, -0.0, f32::MIN_POSITIVE / 7.0, f32::MAX];
    odd.axes[0] = vec![0.1 + 0.2, 1.0 / 3.0, 1e300];
    let dir = tmp_dir("db-odd");
    odd.write(&dir).unwrap();
    let back = Database::read(&dir).unwrap();
    assert_eq!(back.axes, odd.axes);
    for (a, b) in back.data.iter().zip(&odd.data) {
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
    }
}

#[test]
fn npy_header_is_well_formed() {
    for n_vertices in [1, 7, 100] {
        let db = Database {
            axes: [vec![1.0], vec![0.0, 0.1], vec![1.0]],
            n_vertices,
            data: (0..2 * n_vertices).map(|i| [i as f32; 4]).collect(),
        };
        let dir = tmp_dir(&format!("db-header-{n_vertices}"));
        db.write(&dir).unwrap();
        let bytes = std::fs::read(dir.join("data.npy")).unwrap();

        assert_eq!(&bytes[..6], b"\x93NUMPY");
        assert_eq!(&bytes[6..8], &[1, 0], "version 1.0");
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        let data_start = 10 + header_len;
        assert_eq!(
            data_start % 64,
            0,
            "header padded to a multiple of 64 bytes"
        );
        let header = std::str::from_utf8(&bytes[10..data_start]).unwrap();
        assert!(header.ends_with('\n'));
        assert_eq!(
            header.trim_end(),
            format!(
                "{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, 4, ), }}",
                2 * n_vertices
            )
        );
        assert!(
            header[..header.len() - 1]
                .trim_end_matches(' ')
                .ends_with('}')
        );
        assert_eq!(bytes.len() - data_start, 2 * n_vertices * 16);
        // First value of the second row, little-endian f32.
        let second = &bytes[data_start + 16..data_start + 20];
        assert_eq!(f32::from_le_bytes(second.try_into().unwrap()), 1.0);

        let axes = std::fs::read_to_string(dir.join("axes.txt")).unwrap();
        assert_eq!(axes, "1\n0 0.1\n1\n");
    }
}

#[test]
fn npy_version_2_headers_are_accepted() {
    let db = small_database();
    let dir = tmp_dir("db-v2");
    db.write(&dir).unwrap();
    let path = dir.join("data.npy");
    let v1 = std::fs::read(&path).unwrap();
    let header_len = u16::from_le_bytes([v1[8], v1[9]]) as u32;
    let mut v2 = b"\x93NUMPY\x02\x00".to_vec();
    v2.extend_from_slice(&header_len.to_le_bytes());
    v2.extend_from_slice(&v1[10..]);
    std::fs::write(&path, v2).unwrap();
    assert_eq!(Database::read(&dir).unwrap(), db);
}

/// Writes the small database to a fresh directory, lets `edit` change a file, reads it back
/// and returns the error message.
fn database_error(name: &str, edit: impl FnOnce(&std::path::Path)) -> (DatabaseError, String) {
    let dir = tmp_dir(name);
    small_database().write(&dir).unwrap();
    edit(&dir);
    let err = Database::read(&dir).expect_err("malformed database must be rejected");
    let msg = err.to_string();
    (err, msg)
}

/// Replaces the header dictionary of `dir/data.npy`, keeping its padded length.
fn replace_header(dir: &std::path::Path, from: &str, to: &str) {
    let path = dir.join("data.npy");
    let bytes = std::fs::read(&path).unwrap();
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
    assert!(header.contains(from));
    let mut new = header.replacen(from, to, 1);
    new.truncate(new.trim_end().len());
    let padded = format!("{new:<width$}\n", width = header_len - 1);
    assert_eq!(padded.len(), header_len);
    let mut out = bytes[..10].to_vec();
    out.extend_from_slice(padded.as_bytes());
    out.extend_from_slice(&bytes[10 + header_len..]);
    std::fs::write(&path, out).unwrap();
}

#[test]
fn malformed_databases_give_clear_errors() {
    // Truncated data.
    let (err, msg) = database_error("bad-truncated", |dir| {
        let path = dir.join("data.npy");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
    });
    assert!(matches!(
        err,
        DatabaseError::Npy {
            problem: NpyProblem::DataLength { .. },
            ..
        }
    ));
    assert!(
        msg.contains("data.npy") && msg.contains("expected 1920 bytes of data"),
        "{msg}"
    );

    // Truncated header.
    let (_, msg) = database_error("bad-truncated-header", |dir| {
        let path = dir.join("data.npy");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..40]).unwrap();
    });
    assert!(
        msg.contains("data.npy") && msg.contains("expected a valid .npy file"),
        "{msg}"
    );

    // Not an .npy file.
    let (_, msg) = database_error("bad-magic", |dir| {
        std::fs::write(dir.join("data.npy"), b"PK\x03\x04 a zip file").unwrap();
    });
    assert!(
        msg.contains("data.npy") && msg.contains("expected a valid .npy file"),
        "{msg}"
    );

    // Wrong dtype (float64).
    let (err, msg) = database_error("bad-dtype", |dir| replace_header(dir, "'<f4'", "'<f8'"));
    assert!(matches!(
        err,
        DatabaseError::Npy { problem: NpyProblem::WrongDtype { ref found }, .. } if found == "<f8"
    ));
    assert!(
        msg.contains("expected dtype '<f4'") && msg.contains("\"<f8\""),
        "{msg}"
    );

    // Big-endian float32.
    let (_, msg) = database_error("bad-endian", |dir| replace_header(dir, "'<f4'", "'>f4'"));
    assert!(msg.contains("found \">f4\""), "{msg}");

    // Fortran order.
    let (_, msg) = database_error("bad-fortran", |dir| replace_header(dir, "False", "True"));
    assert!(msg.contains("expected 'fortran_order': False"), "{msg}");

    // Wrong shape: (120,) and (60, 8) and rows not divisible by |SX||SA||SY| = 24.
    let (_, msg) = database_error("bad-shape-1d", |dir| {
        replace_header(dir, "(120, 4, )", "(480,)")
    });
    assert!(
        msg.contains("expected shape (R, 4)") && msg.contains("[480]"),
        "{msg}"
    );
    let (_, msg) = database_error("bad-shape-8", |dir| {
        replace_header(dir, "(120, 4, )", "(60, 8)")
    });
    assert!(
        msg.contains("expected shape (R, 4)") && msg.contains("[60, 8]"),
        "{msg}"
    );
    let (_, msg) = database_error("bad-rows", |dir| {
        replace_header(dir, "(120, 4, )", "(100, 4)");
        let path = dir.join("data.npy");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 20 * 16]).unwrap();
    });
    assert!(
        msg.contains("divisible by |SX|·|SA|·|SY| = 24") && msg.contains("100"),
        "{msg}"
    );

    // Garbled header.
    let (_, msg) = database_error("bad-header", |dir| {
        replace_header(dir, "'shape'", "'shapes'")
    });
    assert!(
        msg.contains("expected a valid .npy file") && msg.contains("header dictionary"),
        "{msg}"
    );

    // Non-increasing axis (line 2).
    let (err, msg) = database_error("bad-increasing", |dir| {
        std::fs::write(
            dir.join("axes.txt"),
            "0.8 1.0 1.3\n0.0 0.0\n0.9 1.0 1.05 1.2\n",
        )
        .unwrap();
    });
    assert!(matches!(err, DatabaseError::Axis { line: 2, .. }));
    assert!(
        msg.contains("axes.txt:2: expected strictly increasing sample values of sa"),
        "{msg}"
    );

    // Empty axis line (line 3).
    let (_, msg) = database_error("bad-empty", |dir| {
        std::fs::write(dir.join("axes.txt"), "0.8 1.0 1.3\n-0.2 0.0\n\n").unwrap();
    });
    assert!(
        msg.contains("axes.txt:3: expected 1 to 32 sample values of sy, found none"),
        "{msg}"
    );

    // Too many samples (33, line 1).
    let (_, msg) = database_error("bad-too-many", |dir| {
        let sx: Vec<String> = (0..33).map(|i| i.to_string()).collect();
        let text = format!("{}\n-0.2 0.0\n0.9 1.0 1.05 1.2\n", sx.join(" "));
        std::fs::write(dir.join("axes.txt"), text).unwrap();
    });
    assert!(
        msg.contains("axes.txt:1: expected at most 32 sample values of sx, found 33"),
        "{msg}"
    );

    // A non-numeric sample and a NaN.
    let (_, msg) = database_error("bad-token", |dir| {
        std::fs::write(
            dir.join("axes.txt"),
            "0.8 1,0 1.3\n-0.2 0.0\n0.9 1.0 1.05 1.2\n",
        )
        .unwrap();
    });
    assert!(
        msg.contains("axes.txt:1: expected a number") && msg.contains("\"1,0\""),
        "{msg}"
    );
    let (_, msg) = database_error("bad-nan", |dir| {
        std::fs::write(
            dir.join("axes.txt"),
            "0.8 1.0 1.3\n-0.2 NaN\n0.9 1.0 1.05 1.2\n",
        )
        .unwrap();
    });
    assert!(
        msg.contains("axes.txt:2: expected finite sample values of sa"),
        "{msg}"
    );

    // Two or four lines.
    let (_, msg) = database_error("bad-two-lines", |dir| {
        std::fs::write(dir.join("axes.txt"), "0.8 1.0 1.3\n-0.2 0.0\n").unwrap();
    });
    assert!(
        msg.contains("axes.txt:2: expected 3 lines") && msg.contains("found 2"),
        "{msg}"
    );
    let (_, msg) = database_error("bad-four-lines", |dir| {
        std::fs::write(
            dir.join("axes.txt"),
            "0.8 1.0 1.3\n-0.2 0.0\n0.9 1.0 1.05 1.2\n7\n\n",
        )
        .unwrap();
    });
    assert!(msg.contains("axes.txt:4: expected 3 lines"), "{msg}");

    // A missing file names its path.
    let (err, msg) = database_error("bad-missing", |dir| {
        std::fs::remove_file(dir.join("data.npy")).unwrap();
    });
    assert!(matches!(err, DatabaseError::Io { .. }));
    assert!(msg.contains("data.npy"), "{msg}");
}

#[test]
fn damaged_npy_files_never_panic() {
    let dir = tmp_dir("db-damaged");
    small_database().write(&dir).unwrap();
    let path = dir.join("data.npy");
    let good = std::fs::read(&path).unwrap();
    // Every truncation inside the header and the first rows, and every single-byte change of
    // the header.
    for k in (0..200).chain([good.len() - 1]) {
        std::fs::write(&path, &good[..k]).unwrap();
        let err = Database::read(&dir).unwrap_err();
        assert!(err.to_string().contains("data.npy"), "{err}");
    }
    for i in 0..128 {
        for b in [b' ', b'(', b')', b',', b'\'', b'0', b'9', 0xff] {
            let mut bytes = good.clone();
            bytes[i] = b;
            std::fs::write(&path, &bytes).unwrap();
            let _ = Database::read(&dir);
        }
    }
}

#[test]
fn invalid_databases_are_not_written() {
    let mut db = small_database();
    db.data.pop();
    let err = db.write(tmp_dir("invalid-db")).unwrap_err();
    assert!(
        matches!(
            err,
            DatabaseError::DataLength {
                expected: 120,
                found: 119
            }
        ),
        "{err}"
    );

    let mut db = small_database();
    db.axes[1] = vec![0.0, -0.1];
    let err = db.validate().unwrap_err();
    assert!(
        err.to_string()
            .contains("expected strictly increasing sample values of sa"),
        "{err}"
    );
}

/// The optional fifth number of `*pattern` is the lattice skew: written only when non-zero
/// (rectangular files keep the original layout), read back bit for bit, and checked.
#[test]
fn lattice_skew_round_trips_and_is_checked() {
    let mut tile = read_pyp(STOCKINETTE).unwrap().tile;
    assert_eq!(tile.skew, 0.0);
    let pattern_line = |text: &str| text.lines().nth(1).unwrap().to_string();
    assert_eq!(
        pattern_line(&to_pyp_string(&tile).unwrap())
            .split_whitespace()
            .count(),
        4
    );
    tile.skew = 0.5;
    // The sheared lattice moves the second period: a₂ = (px / 2, py).
    let a2 = tile.period_offset([0, 1]);
    assert_eq!([a2.x, a2.y], [0.5 * tile.period[0], tile.period[1]]);
    let text = to_pyp_string(&tile).unwrap();
    assert!(pattern_line(&text).ends_with(" 0.5"), "{text}");
    assert_eq!(parse_pyp(&text, "skewed.pyp").unwrap().tile, tile);

    // A skew outside [-1/2, 1/2] or not a number is a located error on the *pattern line.
    let text = edited(|l| l[1] = format!("{} 0.75", l[1]));
    let msg = parse_error(&text, 2);
    assert!(msg.contains("skew") && msg.contains("0.75"), "{msg}");
    let text = edited(|l| l[1] = format!("{} half", l[1]));
    let msg = parse_error(&text, 2);
    assert!(msg.contains("\"half\""), "{msg}");
    let text = edited(|l| l[1] = format!("{} 0 0", l[1]));
    let msg = parse_error(&text, 2);
    assert!(msg.contains("px py r n [skew]"), "{msg}");
    tile.skew = f64::NAN;
    assert!(matches!(
        to_pyp_string(&tile).unwrap_err(),
        TileError::Skew { .. }
    ));
}

/// Regression (fuzzing, target `madypg`): a `.npy` header of nested `[` made npyz's
/// Python-literal parser backtrack for more than 10 s. Such headers are refused before they
/// are parsed, quickly and with the file named.
#[test]
fn fuzz_timeout_npy_header_with_nested_brackets_is_refused() {
    let mut header = String::from("{'descr': '<f4', 'fortran_order': False, 'shape': ");
    header.push_str(&"[".repeat(200));
    header.push_str("(1, 4), }");
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    bytes.extend_from_slice(&[0u8; 16]);
    let dir = std::path::Path::new("db");
    let start = std::time::Instant::now();
    let e = Database::parse("0\n0\n0\n", &bytes, dir).unwrap_err();
    let message = e.to_string();
    assert!(
        matches!(
            e,
            DatabaseError::Npy {
                problem: NpyProblem::BadHeader(_),
                ..
            }
        ),
        "{message}"
    );
    assert!(
        message.contains("data.npy") && message.contains("'['"),
        "{message}"
    );
    eprintln!("refused in {:?}: {message}", start.elapsed());
    // A plain header still reads.
    let plain = "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 4), }";
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(plain.len() as u16).to_le_bytes());
    bytes.extend_from_slice(plain.as_bytes());
    bytes.extend_from_slice(&[0u8; 16]);
    let db = Database::parse("0\n0\n0\n", &bytes, dir).unwrap();
    assert_eq!(db.n_vertices, 1);
}
