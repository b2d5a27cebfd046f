//! Rendering curves (seed 000 §3.2) and their writers: fitted node normals and ±R offsets,
//! the Catmull-Rom spline, and OBJ / PLY / `.bcc` / PNG files read back.

use nalgebra::{Matrix3, Rotation3, Vector3};
use sim_persistent::chart::Chart;
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::output::{
    BCC_INFO, BccCurve, CurveOptions, NormalSource, RenderCurves, catmull_rom, node_normals,
};
use sim_persistent::topology::Topology;
use sim_persistent::weave::WeavePattern;
use std::path::Path;

type V3 = Vector3<f64>;

const R: f64 = 0.75e-3;
const W: f64 = 3e-3;

fn options(samples: usize) -> CurveOptions {
    CurveOptions {
        radius: R,
        samples_per_segment: samples,
    }
}

fn layout(topo: &Topology) -> Vec<V3> {
    Layout::new(topo, &LayoutParams::new(W, R))
        .unwrap()
        .positions
}

/// Points of node `n` and its neighbours along all yarns (each once), as the fit sees them.
fn neighbourhood(topo: &Topology, pos: &[V3], n: usize) -> Vec<V3> {
    let mut ids = vec![n];
    for yarn in &topo.yarns {
        for (i, p) in yarn.passes.iter().enumerate() {
            if p.node == n {
                if i > 0 {
                    ids.push(yarn.passes[i - 1].node);
                }
                if i + 1 < yarn.passes.len() {
                    ids.push(yarn.passes[i + 1].node);
                }
            }
        }
    }
    ids[1..].sort_unstable();
    ids.dedup();
    ids.iter().map(|&m| pos[m]).collect()
}

/// Asserts that `n` is a unit eigenvector of the smallest eigenvalue of the covariance of
/// `pts`: `C n = λ n` and no other unit direction has a smaller Rayleigh quotient.
fn assert_smallest_eigenvector(pts: &[V3], n: V3) {
    let c = pts.iter().sum::<V3>() / pts.len() as f64;
    let cov: Matrix3<f64> = pts.iter().map(|p| (p - c) * (p - c).transpose()).sum();
    let scale = cov.norm();
    assert!((n.norm() - 1.0).abs() < 1e-12);
    let lambda = n.dot(&(cov * n));
    assert!(
        (cov * n - lambda * n).norm() < 1e-9 * scale,
        "not an eigenvector"
    );
    for k in 0..200 {
        let t = k as f64 * 0.7;
        let d = V3::new(t.sin() * (3.0 * t).cos(), t.cos(), (5.0 * t).sin()).normalize();
        assert!(d.dot(&(cov * d)) >= lambda - 1e-12 * scale);
    }
}

/// Weave crossings: on a tilted plane the fitted normal of every interior crossing is the
/// plane's normal (oriented to the fabric front), the warp is offset by +R where it is on
/// top and the weft by −R, so the two yarns are exactly 2R apart along the normal.
#[test]
fn weave_crossing_offsets_are_plus_minus_r_along_the_fitted_normal() {
    let (warps, wefts) = (4, 3);
    let topo = Topology::weave(WeavePattern::Plain, warps, wefts).unwrap();
    let rot = Rotation3::from_euler_angles(0.3, -0.2, 0.5);
    let pos: Vec<V3> = layout(&topo).iter().map(|p| rot * p).collect();
    let plane_normal = rot * V3::z();
    let curves = RenderCurves::new(&topo, &pos, &options(4)).unwrap();
    let g = curves.normals.fabric;
    assert!((g.dot(&plane_normal).abs() - 1.0).abs() < 1e-12);
    for c in &topo.crossings {
        let n = curves.normals.normals[c.node];
        assert_eq!(curves.normals.sources[c.node], NormalSource::Fitted);
        assert!((n - g).norm() < 1e-9, "node {}: {n:?} vs {g:?}", c.node);
        assert_smallest_eigenvector(&neighbourhood(&topo, &pos, c.node), n);
        let weft = curves.control_points[c.weft][c.warp];
        let warp = curves.control_points[wefts + c.warp][c.weft];
        let top = if c.warp_over { 1.0 } else { -1.0 };
        assert!((warp - (pos[c.node] + top * R * n)).norm() < 1e-15);
        assert!((weft - (pos[c.node] - top * R * n)).norm() < 1e-15);
        assert!(((warp - weft).norm() - 2.0 * R).abs() < 1e-15);
    }
}

/// Knit stitch contacts: at both nodes of every contact the upper loop's leg lies `+σR` and
/// the lower loop's head `−σR` along the node normal (σ = +1 knit, −1 purl), 2R apart, and
/// the normal is the smallest-eigenvalue eigenvector of the node's neighbourhood; one-yarn
/// nodes (cast-on, bind-off) are not offset.
#[test]
fn knit_contact_offsets_follow_knit_and_purl_sides() {
    let chart = Chart::rib(4, 3, 1, 1).unwrap();
    let topo = Topology::knit(&chart);
    let pos = layout(&topo);
    let curves = RenderCurves::new(&topo, &pos, &options(4)).unwrap();
    assert_eq!(topo.stitch_contacts.len(), 2 * 4 * 2);
    for sc in &topo.stitch_contacts {
        let sigma = sc.sign;
        for &node in &sc.nodes {
            let n = curves.normals.normals[node];
            assert!(n.z > 0.5, "normal {n:?} should face the front (+z)");
            assert_smallest_eigenvector(&neighbourhood(&topo, &pos, node), n);
            let at = |yarn: usize| {
                let i = topo.pass_index(node, yarn).unwrap();
                curves.control_points[yarn][i]
            };
            let (upper, lower) = (at(sc.upper.yarn), at(sc.lower[0].yarn));
            assert!((upper - (pos[node] + sigma * R * n)).norm() < 1e-15);
            assert!((lower - (pos[node] - sigma * R * n)).norm() < 1e-15);
            assert!(((upper - lower).norm() - 2.0 * R).abs() < 1e-15);
        }
    }
    for (y, yarn) in topo.yarns.iter().enumerate() {
        for (i, p) in yarn.passes.iter().enumerate() {
            if topo.nodes[p.node].passes.len() == 1 {
                assert_eq!(curves.control_points[y][i], pos[p.node]);
            }
        }
    }
}

/// On a weave rolled 300° around a cylinder the normals follow the surface: every normal is
/// radial (the fabric is locally a plane through the axis direction) with one sign for all
/// nodes, so neighbouring normals never flip (a single global reference would flip them).
#[test]
fn normals_are_oriented_consistently_around_a_roll() {
    let (warps, wefts) = (6, 12);
    let topo = Topology::weave(WeavePattern::Twill { over: 2, under: 1 }, warps, wefts).unwrap();
    let rho = 4e-3;
    let span = 300f64.to_radians();
    let pos: Vec<V3> = (0..warps * wefts)
        .map(|n| {
            let (i, j) = (n % warps, n / warps);
            let a = span * j as f64 / (wefts - 1) as f64;
            V3::new(i as f64 * W, rho * a.sin(), rho * (1.0 - a.cos()))
        })
        .collect();
    let curves = RenderCurves::new(&topo, &pos, &options(2)).unwrap();
    let normals = &curves.normals.normals;
    let axis = V3::new(0.0, 0.0, rho);
    let mut signs = Vec::new();
    for (n, p) in pos.iter().enumerate() {
        let radial = V3::new(0.0, p.y - axis.y, p.z - axis.z).normalize();
        let d = normals[n].dot(&radial);
        // Interior rows see both neighbours (symmetric: radial); the first and last row
        // tilt by half the 27° arc step towards their only neighbour row.
        let edge_row = n / warps == 0 || n / warps == wefts - 1;
        let min = if edge_row { 0.95 } else { 0.99 };
        assert!(d.abs() > min, "node {n}: normal {:?}", normals[n]);
        signs.push(d.signum());
    }
    assert!(signs.iter().all(|s| *s == signs[0]), "{signs:?}");
    for yarn in &topo.yarns {
        for w in yarn.passes.windows(2) {
            assert!(normals[w[0].node].dot(&normals[w[1].node]) > 0.0);
        }
    }
}

/// Degenerate and broken input never panics: collinear nodes fall back to a documented unit
/// normal, a NaN node spoils only the samples around it, and bad options are errors.
#[test]
fn degenerate_and_non_finite_nodes_fall_back() {
    let topo = Topology::weave(WeavePattern::Plain, 3, 3).unwrap();
    // All nodes on one line along x: every neighbourhood and the fabric are collinear.
    let line: Vec<V3> = (0..9).map(|n| V3::new(n as f64 * 1e-3, 0.0, 0.0)).collect();
    let curves = RenderCurves::new(&topo, &line, &options(3)).unwrap();
    assert!((curves.normals.fabric - V3::z()).norm() < 1e-12);
    for (n, s) in curves.normals.sources.iter().enumerate() {
        assert_ne!(*s, NormalSource::Fitted, "node {n}");
        assert!((curves.normals.normals[n].norm() - 1.0).abs() < 1e-12);
    }
    assert!(
        curves
            .samples
            .iter()
            .flatten()
            .all(|p| p.iter().all(|c| c.is_finite()))
    );
    // All nodes at one point.
    let point = vec![V3::new(1.0, 2.0, 3.0); 9];
    let curves = RenderCurves::new(&topo, &point, &options(3)).unwrap();
    assert!(
        curves
            .samples
            .iter()
            .flatten()
            .all(|p| p.iter().all(|c| c.is_finite()))
    );
    // One NaN node (the corner crossing of weft 0 and warp 0) on a 6 × 6 plain weave.
    let topo = Topology::weave(WeavePattern::Plain, 6, 6).unwrap();
    let mut pos = layout(&topo);
    pos[0].x = f64::NAN;
    let curves = RenderCurves::new(&topo, &pos, &options(4)).unwrap();
    assert_eq!(curves.non_finite_nodes, 1);
    assert!(
        curves
            .normals
            .normals
            .iter()
            .all(|n| n.iter().all(|c| c.is_finite()))
    );
    let finite = |s: &[V3]| s.iter().all(|p| p.iter().all(|c| c.is_finite()));
    // Weft 0 and warp 0 (yarn 6) pass node 0; the yarns that do not are untouched.
    assert!(!finite(&curves.samples[0]) && !finite(&curves.samples[6]));
    for y in (1..6).chain(7..12) {
        assert!(finite(&curves.samples[y]), "yarn {y}");
    }
    // Only the samples of the two segments next to the NaN point of weft 0 are NaN.
    let bad = curves.samples[0]
        .iter()
        .filter(|p| !p.x.is_finite())
        .count();
    assert!(bad <= 2 * 4 + 1, "{bad} NaN samples");
    // Invalid requests are errors.
    assert!(RenderCurves::new(&topo, &pos[1..], &options(4)).is_err());
    assert!(node_normals(&topo, &pos[1..]).is_err());
    assert!(RenderCurves::new(&topo, &pos, &options(0)).is_err());
    let bad_r = CurveOptions {
        radius: -1.0,
        samples_per_segment: 4,
    };
    assert!(RenderCurves::new(&topo, &pos, &bad_r).is_err());
}

/// The centripetal Catmull-Rom spline passes through its points (sample `i m` is `pᵢ`), has
/// `(N − 1) m + 1` samples, reproduces a straight line, is tangent-continuous at the knots,
/// and survives coincident points.
#[test]
fn spline_interpolates_the_offset_points() {
    let pts = vec![
        V3::new(0.0, 0.0, 0.0),
        V3::new(1e-3, 0.5e-3, 0.2e-3),
        V3::new(1.3e-3, 2e-3, -0.1e-3),
        V3::new(3e-3, 2.1e-3, 0.0),
        V3::new(3.2e-3, 0.4e-3, 0.3e-3),
    ];
    let m = 10;
    let s = catmull_rom(&pts, m);
    assert_eq!(s.len(), (pts.len() - 1) * m + 1);
    for (i, p) in pts.iter().enumerate() {
        assert!((s[i * m] - p).norm() < 1e-15, "knot {i}");
    }
    // Tangent continuity: one-sided difference quotients at each interior knot agree in
    // direction far better than the turn between the chords.
    let fine = catmull_rom(&pts, 2000);
    for i in 1..pts.len() - 1 {
        let k = i * 2000;
        let before = (fine[k] - fine[k - 1]).normalize();
        let after = (fine[k + 1] - fine[k]).normalize();
        let chords = (pts[i] - pts[i - 1])
            .normalize()
            .dot(&(pts[i + 1] - pts[i]).normalize());
        assert!(before.dot(&after) > 1.0 - 1e-5, "knot {i}");
        assert!(chords < 0.99);
    }
    // Equally spaced collinear points: the samples stay on the line, equally spaced.
    let line: Vec<V3> = (0..4)
        .map(|i| V3::new(i as f64, 2.0 * i as f64, 0.0))
        .collect();
    let s = catmull_rom(&line, 4);
    for (k, p) in s.iter().enumerate() {
        let t = k as f64 / 4.0;
        assert!((p - V3::new(t, 2.0 * t, 0.0)).norm() < 1e-12);
    }
    // Coincident points: finite samples, still through the points.
    let dup = vec![pts[0], pts[1], pts[1], pts[2]];
    let s = catmull_rom(&dup, 5);
    assert!(s.iter().all(|p| p.iter().all(|c| c.is_finite())));
    assert!((s[10] - pts[1]).norm() < 1e-15 && (s[15] - pts[2]).norm() < 1e-15);
    assert_eq!(catmull_rom(&pts[..1], 5), vec![pts[0]]);
}

fn stockinette_curves(samples: usize) -> (Topology, RenderCurves) {
    let topo = Topology::knit(&Chart::stockinette(3, 2).unwrap());
    let pos = layout(&topo);
    let curves = RenderCurves::new(&topo, &pos, &options(samples)).unwrap();
    (topo, curves)
}

/// The OBJ text has one `v` per sample and one `l` per yarn through its samples in order.
#[test]
fn obj_has_one_polyline_per_yarn() {
    let (topo, curves) = stockinette_curves(5);
    let text = curves.obj_text().unwrap();
    let v: Vec<V3> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            V3::new(c[0], c[1], c[2])
        })
        .collect();
    assert_eq!(v.len(), curves.sample_count());
    let l: Vec<Vec<usize>> = text
        .lines()
        .filter_map(|l| l.strip_prefix("l "))
        .map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect())
        .collect();
    assert_eq!(l.len(), topo.yarns.len());
    for (line, samples) in l.iter().zip(&curves.samples) {
        assert_eq!(line.len(), samples.len());
        for (&k, p) in line.iter().zip(samples) {
            assert!((v[k - 1] - p).norm() < 1e-12);
        }
    }
}

/// The PLY text reads back: header counts, one vertex line `x y z yarn` per sample with the
/// right yarn, one edge line per spline segment joining consecutive samples of one yarn.
#[test]
fn ply_reads_back_with_yarn_indices() {
    let (topo, curves) = stockinette_curves(6);
    let text = curves.ply_text().unwrap();
    let (header, body) = text.split_once("end_header\n").unwrap();
    let hl: Vec<&str> = header.lines().collect();
    assert_eq!(&hl[..2], &["ply", "format ascii 1.0"]);
    let count = |name: &str| -> usize {
        hl.iter()
            .find_map(|l| l.strip_prefix(&format!("element {name} ")))
            .unwrap()
            .parse()
            .unwrap()
    };
    let (nv, ne) = (count("vertex"), count("edge"));
    assert_eq!(nv, curves.sample_count());
    let segments: usize = topo.yarns.iter().map(|y| (y.passes.len() - 1) * 6).sum();
    assert_eq!(ne, segments);
    let props: Vec<&str> = hl
        .iter()
        .filter(|l| l.starts_with("property"))
        .copied()
        .collect();
    assert_eq!(
        props,
        [
            "property float x",
            "property float y",
            "property float z",
            "property int yarn",
            "property int vertex1",
            "property int vertex2",
            "property int yarn"
        ]
    );
    let rows: Vec<Vec<&str>> = body.lines().map(|l| l.split(' ').collect()).collect();
    assert_eq!(rows.len(), nv + ne);
    let mut vertex_yarn = Vec::new();
    for (row, (y, p)) in rows[..nv].iter().zip(
        curves
            .samples
            .iter()
            .enumerate()
            .flat_map(|(y, s)| s.iter().map(move |p| (y, p))),
    ) {
        assert_eq!(row.len(), 4);
        let x: Vec<f32> = row[..3].iter().map(|t| t.parse().unwrap()).collect();
        assert_eq!(x, [p.x as f32, p.y as f32, p.z as f32]);
        let yarn: usize = row[3].parse().unwrap();
        assert_eq!(yarn, y);
        vertex_yarn.push(yarn);
    }
    for row in &rows[nv..] {
        let e: Vec<usize> = row.iter().map(|t| t.parse().unwrap()).collect();
        assert_eq!(e.len(), 3);
        assert_eq!(e[1], e[0] + 1);
        assert!(vertex_yarn[e[0]] == e[2] && vertex_yarn[e[1]] == e[2]);
    }
}

/// A `.bcc` file as read by a BCC loader: (curve type, up axis, info, curves).
fn read_bcc(bytes: &[u8]) -> ([u8; 2], u8, String, Vec<Vec<[f32; 3]>>) {
    assert!(bytes.len() >= 64);
    assert_eq!(&bytes[0..3], b"BCC");
    assert_eq!(bytes[3], 0x44);
    assert_eq!(bytes[6], 3);
    let u64_at = |k: usize| u64::from_le_bytes(bytes[k..k + 8].try_into().unwrap()) as usize;
    let (n_curves, n_points) = (u64_at(8), u64_at(16));
    let info = String::from_utf8(
        bytes[24..64]
            .iter()
            .copied()
            .take_while(|&b| b != 0)
            .collect(),
    )
    .unwrap();
    let mut k = 64;
    let mut curves = Vec::new();
    for _ in 0..n_curves {
        let n = i32::from_le_bytes(bytes[k..k + 4].try_into().unwrap());
        assert!(n > 0, "open curves have a positive count");
        k += 4;
        let mut c = Vec::new();
        for _ in 0..n {
            let f = |j: usize| f32::from_le_bytes(bytes[j..j + 4].try_into().unwrap());
            c.push([f(k), f(k + 4), f(k + 8)]);
            k += 12;
        }
        curves.push(c);
    }
    assert_eq!(k, bytes.len(), "no trailing bytes");
    assert_eq!(curves.iter().map(Vec::len).sum::<usize>(), n_points);
    ([bytes[4], bytes[5]], bytes[7], info, curves)
}

/// `.bcc` reads back: `C0` holds the offset control points (one per pass), `PL` the spline
/// samples, both one curve per yarn with up axis Y and our info text.
#[test]
fn bcc_reads_back_for_both_curve_types() {
    let (topo, curves) = stockinette_curves(4);
    for (kind, expected, tag) in [
        (BccCurve::C0, &curves.control_points, *b"C0"),
        (BccCurve::Pl, &curves.samples, *b"PL"),
    ] {
        let (t, up, info, read) = read_bcc(&curves.bcc_bytes(kind).unwrap());
        assert_eq!(t, tag);
        assert_eq!(up, 1);
        assert_eq!(info, BCC_INFO);
        assert_eq!(read.len(), topo.yarns.len());
        for (r, e) in read.iter().zip(expected) {
            assert_eq!(r.len(), e.len());
            for (a, b) in r.iter().zip(e) {
                assert_eq!(*a, [b.x as f32, b.y as f32, b.z as f32]);
            }
        }
    }
    assert_eq!(
        read_bcc(&curves.bcc_bytes(BccCurve::C0).unwrap())
            .3
            .iter()
            .map(Vec::len)
            .sum::<usize>(),
        topo.n_passes()
    );
}

/// The PNG rendering through `yarn_output::render` draws the yarns: a valid PNG signature
/// and IHDR size, a good share of non-background pixels, and several yarn colours.
#[test]
fn png_rendering_shows_the_yarns() {
    let (_, curves) = stockinette_curves(6);
    let mut opts = yarn_output::render::RenderOptions::new(160, 120, R);
    opts.supersample = 1;
    let r = curves.render(&opts, Path::new("test.png")).unwrap();
    assert_eq!(r.skipped_vertices, 0);
    assert_eq!(r.segments, curves.edge_count());
    let png = r.image.to_png().unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 160);
    assert_eq!(u32::from_be_bytes(png[20..24].try_into().unwrap()), 120);
    let mut drawn = 0;
    let mut colours = std::collections::BTreeSet::new();
    for y in 0..120 {
        for x in 0..160 {
            let p = r.image.pixel(x, y);
            if p != [255, 255, 255] {
                drawn += 1;
                colours.insert(p);
            }
        }
    }
    assert!(drawn > 160 * 120 / 5, "{drawn} drawn pixels");
    assert!(colours.len() > 10);
}
