//! The curve writers on one small set of polylines (an open curve, a closed one, a
//! one-vertex curve): OBJ and PLY structure, `.bcc` header and payload, and the `.usda` file
//! read back by an independent USD parser (openusd), so that it is checked against the USD
//! grammar and not only against our own expectations.

use openusd::sdf::{Path, Value};
use yarn_output::bcc::{BccHeader, CurveType};
use yarn_output::usda::UsdOptions;
use yarn_output::{PolylineBuf, UpAxis, bcc, obj, ply, usda};

/// Curve 0 open with 3 points, curve 1 closed with 4, curve 2 a single point.
fn sample() -> PolylineBuf {
    let mut b = PolylineBuf::default();
    let open = [[0.0, 0.0, 0.0], [1e-3, 0.5e-3, 0.0], [2e-3, 0.0, 0.25e-3]];
    let closed = [
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 2.0, 0.0],
        [0.0, 2.0, 0.5],
    ];
    b.push_curve(open, false).unwrap();
    b.push_curve(closed, true).unwrap();
    b.push_curve([[5.0, 5.0, 5.0]], false).unwrap();
    b
}

#[test]
fn obj_lists_vertices_and_one_element_per_drawable_curve() {
    let text = obj::to_string(&sample().view(), "test curves");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("# test curves"));
    assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 8);
    assert!(
        text.contains("v 0.001 0.0005 0\n"),
        "shortest round-trip form:\n{text}"
    );
    let elements: Vec<&str> = text.lines().filter(|l| l.starts_with("l ")).collect();
    assert_eq!(elements, ["l 1 2 3", "l 4 5 6 7 4"]);
}

#[test]
fn ply_counts_match_the_body() {
    let text = ply::to_string(&sample().view(), "test curves");
    assert!(text.contains("element vertex 8\n") && text.contains("element edge 6\n"));
    let body: Vec<&str> = text.split("end_header\n").nth(1).unwrap().lines().collect();
    assert_eq!(body.len(), 8 + 6);
    assert_eq!(
        body[7], "5 5 5 2",
        "the single-point curve keeps its vertex"
    );
    assert_eq!(body[8 + 5], "6 3 1", "the closing edge of the closed curve");
}

#[test]
fn bcc_header_and_payload() {
    let b = sample();
    let header = BccHeader {
        curve: CurveType::CatmullRom,
        up: UpAxis::Z,
        info: "yarn-output test",
    };
    let bytes = bcc::to_bytes(&b.view(), &header).unwrap();
    assert_eq!(&bytes[0..8], b"BCC\x44C0\x03\x02");
    assert_eq!(u64::from_le_bytes(bytes[8..16].try_into().unwrap()), 3);
    assert_eq!(u64::from_le_bytes(bytes[16..24].try_into().unwrap()), 8);
    assert!(bytes[24..64].starts_with(b"yarn-output test\0"));
    assert_eq!(bytes.len(), 64 + 3 * 4 + 8 * 12);
    let n1 = 64 + 4 + 3 * 12;
    assert_eq!(
        i32::from_le_bytes(bytes[n1..n1 + 4].try_into().unwrap()),
        -4
    );
    let long = BccHeader {
        info: "an info text that is longer than forty bytes",
        ..header
    };
    assert!(bcc::to_bytes(&b.view(), &long).is_err());
}

#[test]
fn usda_parses_with_an_independent_usd_parser() {
    let options = UsdOptions {
        radius: 0.5e-3,
        up: UpAxis::Y,
        comment: "yarn-output \"test\" curves",
        meshes: &[],
    };
    let text = usda::to_string(&sample().view(), &options).unwrap();
    let data = openusd::usda::parse(&text).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
    let value = |path: &str, field: &str| -> Value {
        let spec = data.spec(&Path::new(path).unwrap());
        let spec = spec.unwrap_or_else(|| panic!("no spec {path} in\n{text}"));
        let found = spec.fields.iter().find(|(k, _)| k == field);
        found
            .unwrap_or_else(|| panic!("{path} has no {field}"))
            .1
            .clone()
    };
    assert!(matches!(value("/Yarns", "typeName"), Value::Token(t) if t.as_str() == "BasisCurves"));
    assert!(
        matches!(value("/Yarns.curveVertexCounts", "default"), Value::IntVec(v) if v == [3, 5])
    );
    match value("/Yarns.points", "default") {
        Value::Vec3fVec(p) => {
            assert_eq!(p.len(), 8);
            assert_eq!((p[1].x, p[1].y), (1e-3, 0.5e-3));
            assert_eq!(
                (p[7].x, p[7].y),
                (p[3].x, p[3].y),
                "the closed curve repeats its start"
            );
        }
        other => panic!("points: {other:?}"),
    }
    assert!(matches!(value("/Yarns.widths", "default"), Value::FloatVec(w) if w == [1e-3]));

    // The parser is not vacuous: a file with a missing bracket is rejected.
    let broken = text.replacen("points = [", "points = ", 1);
    assert!(openusd::usda::parse(&broken).is_err());
    // A radius that is not positive is refused before anything is written.
    let bad = UsdOptions {
        radius: 0.0,
        ..options
    };
    assert!(usda::to_string(&sample().view(), &bad).is_err());

    // A mesh beside the curves is a Mesh prim the parser reads back.
    let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]];
    let layer = yarn_output::render::MeshLayer {
        positions: &positions,
        triangles: &[[0, 1, 2]],
        colour: [255, 0, 0],
    };
    let meshes = [layer];
    let with_mesh = UsdOptions {
        meshes: &meshes,
        ..options
    };
    let text = usda::to_string(&sample().view(), &with_mesh).unwrap();
    let data = openusd::usda::parse(&text).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
    let spec = data
        .spec(&Path::new("/Mesh0").unwrap())
        .expect("a Mesh0 prim");
    assert!(
        spec.fields
            .iter()
            .any(|(k, v)| k == "typeName" && matches!(v, Value::Token(t) if t.as_str() == "Mesh"))
    );
    let indices = data
        .spec(&Path::new("/Mesh0.faceVertexIndices").unwrap())
        .expect("indices");
    assert!(
        indices
            .fields
            .iter()
            .any(|(k, v)| k == "default" && matches!(v, Value::IntVec(i) if i == &[0, 1, 2]))
    );
    let broken = yarn_output::render::MeshLayer {
        triangles: &[[0, 1, 3]],
        ..layer
    };
    let bad_mesh = UsdOptions {
        meshes: &[broken],
        ..options
    };
    assert!(usda::to_string(&sample().view(), &bad_mesh).is_err());
}

/// The pseudo-root field `name` of a parsed layer.
fn layer_field(data: &openusd::sdf::Data, name: &str) -> Value {
    let spec = data.spec(&Path::abs_root()).expect("a pseudo-root");
    spec.fields
        .iter()
        .find(|(k, _)| k == name)
        .unwrap_or_else(|| panic!("the layer has no {name}"))
        .1
        .clone()
}

/// The time samples of attribute `path` of a parsed layer.
fn samples(data: &openusd::sdf::Data, path: &str) -> Vec<(f64, Value)> {
    let spec = data
        .spec(&Path::new(path).unwrap())
        .unwrap_or_else(|| panic!("no spec {path}"));
    match spec.fields.iter().find(|(k, _)| k == "timeSamples") {
        Some((_, Value::TimeSamples(s))) => s.clone(),
        other => panic!("{path}: no time samples ({other:?})"),
    }
}

/// A three-frame cache of the sample curves (moving along x) and one mesh, read back by the
/// independent parser: frame range and rate in the layer metadata, one points and one extent
/// sample per frame with the frame's points, the extent holding the points grown by R, the
/// mesh's topology once and its points per frame, and no side file left behind.
#[test]
fn usda_sequence_is_one_layer_with_time_samples() {
    let dir = std::env::temp_dir().join(format!("yarn-output-seq-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cache.usda");
    let options = usda::SequenceOptions {
        radius: 0.5e-3,
        up: UpAxis::Z,
        comment: "test cache".into(),
        frames_per_second: 100.0,
    };
    let mut seq = usda::Sequence::create(&path, options.clone()).unwrap();
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]];
    for k in 0..3 {
        let shift = k as f64 * 1e-3;
        let mut b = PolylineBuf::default();
        for (c, closed) in [(0usize, false), (1, true)] {
            let curve: Vec<[f64; 3]> = (0..3 + c)
                .map(|i| [shift + i as f64 * 1e-3, c as f64, 0.0])
                .collect();
            b.push_curve(curve, closed).unwrap();
        }
        let moved: Vec<[f64; 3]> = tri.iter().map(|p| [p[0] + shift, p[1], p[2]]).collect();
        let mesh = yarn_output::render::MeshLayer {
            positions: &moved,
            triangles: &[[0, 1, 2]],
            colour: [0, 128, 255],
        };
        seq.push(&b.view(), &[mesh]).unwrap();
    }
    assert_eq!(seq.frames(), 3);
    assert_eq!(seq.finish().unwrap(), path);
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(leftovers, [std::ffi::OsString::from("cache.usda")]);
    let text = std::fs::read_to_string(&path).unwrap();
    let data = openusd::usda::parse(&text).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
    assert!(matches!(layer_field(&data, "startTimeCode"), Value::Double(t) if t == 0.0));
    assert!(matches!(layer_field(&data, "endTimeCode"), Value::Double(t) if t == 2.0));
    assert!(matches!(layer_field(&data, "timeCodesPerSecond"), Value::Double(t) if t == 100.0));
    let points = samples(&data, "/Yarns.points");
    let extents = samples(&data, "/Yarns.extent");
    assert_eq!(points.len(), 3);
    assert_eq!(extents.len(), 3);
    for (k, ((tp, p), (te, e))) in points.iter().zip(&extents).enumerate() {
        assert_eq!((*tp, *te), (k as f64, k as f64));
        let (Value::Vec3fVec(p), Value::Vec3fVec(e)) = (p, e) else {
            panic!("frame {k}: {p:?} / {e:?}");
        };
        // 3 open points and 4 closed ones plus the repeated start.
        assert_eq!(p.len(), 8);
        let shift = k as f32 * 1e-3;
        assert!((p[0].x - shift).abs() < 1e-9, "{:?}", p[0]);
        assert!((e[0].x - (shift - 0.5e-3)).abs() < 1e-7, "{:?}", e[0]);
        assert!(
            (e[1].x - (shift + 3e-3 + 0.5e-3)).abs() < 1e-7,
            "{:?}",
            e[1]
        );
        assert!(p.iter().all(|q| (e[0].x..=e[1].x).contains(&q.x)
            && (e[0].y..=e[1].y).contains(&q.y)
            && (e[0].z..=e[1].z).contains(&q.z)));
    }
    assert_eq!(samples(&data, "/Mesh0.points").len(), 3);
    assert_eq!(samples(&data, "/Mesh0.extent").len(), 3);
    // Pixar's USD loads it too (where python3 has usd-core; CI requires it).
    match usda::check_with_usd_if_available(&path, 3, 1).unwrap() {
        Some(report) => {
            assert_eq!(report.lines().count(), 3, "{report}");
            // The checker is not vacuous: a frame count the cache does not have is refused.
            assert!(usda::check_with_usd(&path, 4, 1).is_err());
        }
        None => eprintln!("skipping the USD check: no pxr module"),
    }

    // A mesh that changes its triangles, no frames, and a bad frame rate are refused.
    let mut seq = usda::Sequence::create(&dir.join("bad.usda"), options.clone()).unwrap();
    let layer = |t: &'static [[u32; 3]]| yarn_output::render::MeshLayer {
        positions: &tri,
        triangles: t,
        colour: [0, 0, 0],
    };
    seq.push(&sample().view(), &[layer(&[[0, 1, 2]])]).unwrap();
    let err = seq
        .push(&sample().view(), &[layer(&[[0, 2, 1]])])
        .unwrap_err();
    assert!(err.to_string().contains("mesh topology"), "{err}");
    let empty = usda::Sequence::create(&dir.join("empty.usda"), options.clone()).unwrap();
    assert!(
        empty
            .finish()
            .unwrap_err()
            .to_string()
            .contains("at least one frame")
    );
    let bad = usda::SequenceOptions {
        frames_per_second: 0.0,
        ..options
    };
    assert!(usda::Sequence::create(&dir.join("x.usda"), bad).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}
