//! Pipeline behaviour: skip-work, thread independence, curvature, clamping, embedding and
//! output files.

mod common;

use common::*;
use deform_runtime::deform::{clamp_eigenvalues, strains};
use deform_runtime::{DeformOptions, EmbedOptions, RestMesh, embed, synthetic};
use yarn_output::render::{Camera, Image, RenderOptions, render_tubes};

#[test]
fn static_frames_reuse_the_previous_output() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 2.0, 3.0, 4);
    let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    let p = synthetic::map_uvs(&mesh, synthetic::strain_map([0.2, 0.1, 0.0]));
    let first = d.frame(&p).unwrap();
    assert!(!first.static_frame);
    let before = d.output().x.clone();
    let second = d.frame(&p).unwrap();
    assert!(second.static_frame);
    assert_eq!(second.vertices.processed, 0);
    assert_eq!(d.output().x, before);
    let mut q = p.clone();
    q[0][2] += 1e-4;
    assert!(!d.frame(&q).unwrap().static_frame);
}

#[test]
fn skipping_identity_faces_does_not_change_the_result() {
    let tile = stockinette();
    // A database that is *not* zero at zero strain (solver tolerance in real data).
    let base = synthetic::multilinear(tile.radius);
    let db = synthetic::database(&tile, axes(), move |v, s| {
        let q = base(v, s);
        [q[0] + 1e-5, q[1], q[2] - 2e-5, q[3]]
    });
    let mesh = grid(&tile, 4.0, 4.0, 8);
    // Stretch only the right half: the left half stays at identity.
    let width = 4.0 * tile.period[0];
    let p = synthetic::map_uvs(&mesh, |uv| {
        let x = if uv[0] > 0.5 * width {
            0.5 * width + 1.3 * (uv[0] - 0.5 * width)
        } else {
            uv[0]
        };
        [x, uv[1], 0.0]
    });
    let mut on = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    let mut off = deformer::<f32>(
        &tile,
        &db,
        &mesh,
        DeformOptions {
            skip_identity: false,
            ..DeformOptions::default()
        },
    );
    let s_on = on.frame(&p).unwrap();
    let s_off = off.frame(&p).unwrap();
    assert!(
        s_on.vertices.lookups_skipped > s_on.vertices.processed / 4,
        "{s_on:?}"
    );
    assert_eq!(s_off.vertices.lookups_skipped, 0);
    let worst = (0..on.output().x.len())
        .map(|k| {
            (on.output().x[k] - off.output().x[k])
                .abs()
                .max((on.output().z[k] - off.output().z[k]).abs())
        })
        .fold(0.0f32, f32::max);
    assert!(
        worst < 1e-6 * tile.radius as f32 * 10.0,
        "max difference {worst:e} m"
    );
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 14.0, 14.0, 5);
    let p = synthetic::map_uvs(&mesh, |uv| {
        [uv[0], uv[1], 0.3 * (uv[0] * 40.0).sin() * 0.01]
    });
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
            d.frame(&p).unwrap();
            d.output().clone()
        })
    };
    let (a, b) = (run(1), run(3));
    assert!(
        a.x.len() > 2 * deform_runtime::deform::CHUNK,
        "needs several chunks"
    );
    assert_eq!(a.x, b.x);
    assert_eq!(a.z, b.z);
    assert_eq!(a.twist, b.twist);
}

#[test]
fn cylinder_has_second_fundamental_form_minus_one_over_r() {
    // Outward normals: II = −∇φᵀ∇n = −1/r along the circumference, 0 along the axis.
    let r = 0.05;
    let mesh = synthetic::cylinder_mesh(48, 6, r, 0.5, 0.1);
    let rest = RestMesh::new(&mesh, 1.0).unwrap();
    let mut g = deform_runtime::FrameGeometry::<f64>::new(&rest);
    g.update(
        &rest,
        &mesh.positions,
        1e-6,
        1e-3,
        deform_runtime::mesh::PolyOptions {
            phong: true,
            interpolate_forms: true,
        },
    );
    let mut checked = 0;
    for (f, face) in g.faces.iter().enumerate() {
        let interior = rest.neighbours[f].iter().all(|n| n.0 != u32::MAX);
        if !interior {
            continue;
        }
        // Faces whose axis edge lies in the interior of the sweep.
        let ii_uu = face.ii[0];
        assert!(ii_uu < 0.0, "face {f}: II₁₁ = {ii_uu}");
        assert!(
            (ii_uu * r + 1.0).abs() < 0.02,
            "face {f}: II₁₁·r = {}",
            ii_uu * r
        );
        assert!(face.ii[2].abs() < 1e-9, "face {f}: II₂₂ = {}", face.ii[2]);
        checked += 1;
    }
    assert!(checked > 100);
    // Vertex normals point outward.
    for (v, vf) in g.vertices.iter().enumerate() {
        let p = vf.p;
        let radial = [p[0] / r, 0.0, p[2] / r];
        let dot: f64 = (0..3).map(|c| radial[c] * vf.n[c]).sum();
        assert!(dot > 0.99, "vertex {v}: n·radial = {dot}");
    }
}

#[test]
fn linearized_bending_stretches_the_outside_of_a_bend() {
    // Bend a flat strip into a half cylinder of radius r. With Δx = R·0.5·cos(0.37v)·sx... the
    // per-vertex effect is hard to isolate, so use a database where Δz = R·sx (all vertices):
    // vertices above the mid-surface (X₃ > 0) see sx ≈ X₃/r > 0, below sx < 0.
    let tile = stockinette();
    let r_yarn = tile.radius;
    let db = synthetic::database(&tile, axes(), move |_, s| [0.0, 0.0, r_yarn * s[0], 0.0]);
    let r = 0.02;
    let flat = synthetic::grid_mesh(40, 4, std::f64::consts::PI * r, 4.0 * tile.period[1]);
    let bent = synthetic::map_uvs(&flat, |uv| {
        let a = uv[0] / r;
        [r * a.sin(), uv[1], r * a.cos()]
    });
    let rel = |bending: bool| {
        let options = DeformOptions {
            linearized_bending: bending,
            clamp_compression: false,
            skip_identity: false,
            ..DeformOptions::default()
        };
        let mut d = deformer::<f64>(&tile, &db, &flat, options);
        d.frame(&bent).unwrap();
        let (e, o) = (d.embedding(), d.output());
        // Radial distance from the axis minus (r + X₃): the extra normal offset ΔQ_z.
        (0..e.len())
            .map(|k| {
                let dist = (o.x[k] * o.x[k] + o.z[k] * o.z[k]).sqrt();
                // Away from the u boundaries, where boundary edges carry no curvature.
                let u = e.material[k][0];
                let inside =
                    u > 0.1 * std::f64::consts::PI * r && u < 0.9 * std::f64::consts::PI * r;
                (
                    if inside { e.material[k][2] } else { 0.0 },
                    dist - r - e.material[k][2],
                )
            })
            .collect::<Vec<_>>()
    };
    let with = rel(true);
    let without = rel(false);
    let mut checked = 0;
    for (&(h, dz), &(_, dz0)) in with.iter().zip(&without) {
        if h.abs() < 0.5 * r_yarn {
            continue;
        }
        // Expected ΔQ_z ≈ R·sx with sx ≈ √(1 + 2h/r) − 1 ≈ h/r.
        let expected = r_yarn * ((1.0 + 2.0 * h / r).sqrt() - 1.0);
        // Without bending ΔQ_z = 0; the rest of the radial offset is the Phong surface's
        // deviation from the exact cylinder (sagitta of a π/40 chord ≈ 1.5e-5 m).
        assert!(dz0.abs() < 0.02 * r_yarn, "no bending: {dz0}");
        let dq = dz - dz0;
        assert!(
            (dq - expected).abs() < 0.1 * expected.abs() + 1e-7,
            "h {h}: {dq} vs {expected}"
        );
        checked += 1;
    }
    assert!(checked > 100);
}

#[test]
fn compression_clamping_bounds_eigenvalues() {
    let cases = [
        [0.5, 0.1, 0.9],
        [1.2, 0.0, 1.1],
        [0.3, 0.0, 0.3],
        [0.0, 0.0, 0.0],
        [2.0, 1.9, 2.0],
    ];
    for i in cases {
        let (c, changed) = clamp_eigenvalues(i, 0.8f64);
        let m = 0.5 * (c[0] + c[2]);
        let d = (0.25 * (c[0] - c[2]).powi(2) + c[1] * c[1]).sqrt();
        assert!(m - d >= 0.8 - 1e-12, "{i:?} → {c:?}");
        let m0 = 0.5 * (i[0] + i[2]);
        let d0 = (0.25 * (i[0] - i[2]).powi(2) + i[1] * i[1]).sqrt();
        assert_eq!(changed, m0 - d0 < 0.8, "{i:?}");
        // The larger eigenvalue and its eigenvector survive when it is above the bound.
        if m0 + d0 >= 0.8 {
            assert!((m + d - (m0 + d0)).abs() < 1e-12, "{i:?} → {c:?}");
        }
        if !changed {
            assert_eq!(c, i);
        }
    }
    let s = strains([1.69f64, 0.26, 1.0]);
    assert!((s[0] - 0.3).abs() < 1e-12 && (s[1] - 0.2).abs() < 1e-12 && s[2].abs() < 1e-12);
}

#[test]
fn embedding_follows_yarn_edges_and_drops_short_fragments() {
    let tile = stockinette();
    let mesh = synthetic::grid_mesh(3, 3, 2.5 * tile.period[0], 2.5 * tile.period[1]);
    let rest = RestMesh::new(&mesh, 1.0).unwrap();
    let all = embed::<f64>(&rest, &tile, &EmbedOptions::default()).unwrap();
    let s = all.stats;
    assert_eq!(s.candidates, s.cells * tile.positions.len());
    assert_eq!(s.vertices + s.cut_outside + s.dropped_short, s.candidates);
    let w = 2.5 * tile.period[0];
    let h = 2.5 * tile.period[1];
    // Every vertex lies inside the UV rectangle and consecutive vertices are tile edges.
    let mut longest_edge = 0.0f64;
    for e in 0..tile.edges.len() {
        longest_edge = longest_edge.max(tile.edge_vector(e).norm());
    }
    for c in 0..all.n_curves() {
        let range = all.curve_offsets[c] as usize..all.curve_offsets[c + 1] as usize;
        for k in range.clone() {
            let m = all.material[k];
            assert!(m[0] >= -1e-12 && m[0] <= w + 1e-12 && m[1] >= -1e-12 && m[1] <= h + 1e-12);
        }
        for k in range.start..range.end - 1 {
            let (a, b) = (all.material[k], all.material[k + 1]);
            let v = all.tile_vertex[k] as usize;
            let e = tile.topology().unwrap().outgoing(v);
            let ev = tile.edge_vector(e);
            for (cmp, evc) in [0, 1, 2].iter().zip([ev.x, ev.y, ev.z]) {
                assert!((b[*cmp] - a[*cmp] - evc).abs() < 1e-12);
            }
        }
    }
    // Dropping fragments shorter than 5 mm removes some fragments and vertices.
    let options = EmbedOptions {
        min_fragment_length: 0.005,
        ..EmbedOptions::default()
    };
    let long = embed::<f64>(&rest, &tile, &options).unwrap();
    assert!(long.stats.fragments_dropped > all.stats.fragments_dropped);
    assert!(long.len() < all.len());
    for c in 0..long.n_curves() {
        let range = long.curve_offsets[c] as usize..long.curve_offsets[c + 1] as usize;
        let len: f64 = (range.start..range.end - 1)
            .map(|k| {
                let (a, b) = (long.material[k], long.material[k + 1]);
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
            })
            .sum();
        assert!(len >= 0.005, "curve {c} of length {len}");
    }
    assert!(longest_edge < tile.period[0]);
}

#[test]
fn output_files_describe_the_same_curves() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 2.0, 2.0, 3);
    let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    d.frame(&synthetic::map_uvs(
        &mesh,
        synthetic::strain_map([0.1, 0.0, 0.1]),
    ))
    .unwrap();
    let e = d.embedding();
    let o = d.output();
    let lines = e.polylines(o);
    let dir = std::env::temp_dir().join(format!("deform-runtime-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let comment = "deform-runtime test";
    yarn_output::write_with(&dir.join("y.obj"), |w| {
        yarn_output::obj::write(w, &lines, comment)
    })
    .unwrap();
    yarn_output::write_with(&dir.join("y.ply"), |w| {
        yarn_output::ply::write(w, &lines, comment)
    })
    .unwrap();
    let header = yarn_output::bcc::BccHeader {
        curve: yarn_output::bcc::CurveType::Polyline,
        up: yarn_output::UpAxis::Z,
        info: comment,
    };
    let bytes = yarn_output::bcc::to_bytes(&lines, &header).unwrap();
    yarn_output::write_file(&dir.join("y.bcc"), &bytes).unwrap();
    let obj = std::fs::read_to_string(dir.join("y.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), e.len());
    assert_eq!(
        obj.lines().filter(|l| l.starts_with("l ")).count(),
        e.n_curves()
    );
    let ply = std::fs::read_to_string(dir.join("y.ply")).unwrap();
    assert!(ply.contains(&format!("element vertex {}", e.len())));
    let bcc = std::fs::read(dir.join("y.bcc")).unwrap();
    assert_eq!(&bcc[0..3], b"BCC");
    let curves = u64::from_le_bytes(bcc[8..16].try_into().unwrap()) as usize;
    let points = u64::from_le_bytes(bcc[16..24].try_into().unwrap()) as usize;
    assert_eq!((curves, points), (e.n_curves(), e.len()));
    assert_eq!(bcc.len(), 64 + 4 * curves + 12 * points);
    let first_x = f32::from_le_bytes(bcc[68..72].try_into().unwrap());
    assert_eq!(first_x, o.x[0]);
    std::fs::remove_dir_all(&dir).ok();
}

fn is_background(image: &Image, x: u32, y: u32) -> bool {
    image.pixel(x, y) == [255, 255, 255]
}

#[test]
fn deformed_pattern_renders_every_edge() {
    let tile = stockinette();
    let db = database(&tile);
    let mesh = grid(&tile, 3.0, 4.0, 4);
    let mut d = deformer::<f32>(&tile, &db, &mesh, DeformOptions::default());
    d.frame(&synthetic::map_uvs(&mesh, |uv| synthetic::wave(uv, 2.0)))
        .unwrap();
    let (e, o) = (d.embedding(), d.output());
    let lines = e.polylines(o);
    let options = RenderOptions {
        camera: Camera {
            direction: [0.3, 0.5, -1.0],
            up: [0.0, 1.0, 0.0],
        },
        supersample: 2,
        ..RenderOptions::new(320, 240, tile.radius)
    };
    let r = render_tubes(&lines, &options).unwrap();
    let edges: usize = (0..e.n_curves())
        .map(|c| {
            let n = (e.curve_offsets[c + 1] - e.curve_offsets[c]) as usize;
            n.saturating_sub(1) + usize::from(e.closed[c] && n > 2) + usize::from(n == 1)
        })
        .sum();
    assert_eq!(r.segments, edges);
    assert_eq!(r.skipped_vertices, 0);
    if let Ok(dir) = std::env::var("RENDER_TEST_DUMP") {
        r.image
            .write_png(&std::path::Path::new(&dir).join("deformed.png"))
            .unwrap();
    }
    // Auto framing: the silhouette's bounding box fills the image minus the 4 % margins along
    // the limiting direction (a capsule's screen extent is its vertices' extent ± R).
    let (mut lo, mut hi) = ([u32::MAX; 2], [0u32; 2]);
    for y in 0..240 {
        for x in 0..320 {
            if !is_background(&r.image, x, y) {
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            }
        }
    }
    let span = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1];
    let free = [0.92 * 320.0, 0.92 * 240.0];
    eprintln!("{edges} segments; silhouette {span:?} px, free area {free:?} px");
    assert!(
        (0..2).any(|d| (f64::from(span[d]) - free[d]).abs() <= 2.0),
        "{span:?} vs {free:?}"
    );
    assert!((0..2).all(|d| f64::from(span[d]) <= free[d] + 2.0));
    let png = r.image.to_png().unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

/// A tile on a sheared lattice ([`yarn_pattern::tile::Tile::skew`]; the seed stitch's
/// primitive tile is one) is copied onto its own lattice: every embedded vertex is its tile
/// vertex moved by `i a₁ + j a₂` with integer `i`, `j`, consecutive vertices follow tile edges,
/// and away from the mesh border exactly the lattice copies are embedded (counted by brute
/// force over the lattice). The same holds for the rectangular tile.
#[test]
fn a_sheared_tile_is_embedded_on_its_own_lattice() {
    for skew in [0.0, 0.5, -0.5] {
        let mut tile = stockinette();
        tile.skew = skew;
        let [px, py] = tile.period;
        let (w, h) = (6.0 * px, 6.0 * py);
        let mesh = synthetic::grid_mesh(6, 6, w, h);
        let rest = RestMesh::new(&mesh, 1.0).unwrap();
        let all = embed::<f64>(&rest, &tile, &EmbedOptions::default()).unwrap();
        let topology = tile.topology().unwrap();
        for k in 0..all.len() {
            let v = all.tile_vertex[k] as usize;
            let m = all.material[k];
            let j = (m[1] - tile.positions[v].y) / py;
            let i = (m[0] - tile.positions[v].x) / px - skew * j.round();
            assert!(
                (j - j.round()).abs() < 1e-9 && (i - i.round()).abs() < 1e-9,
                "skew {skew}: vertex {k} is copy ({i}, {j}) of tile vertex {v}"
            );
            assert!((m[2] - tile.positions[v].z).abs() < 1e-15);
        }
        for c in 0..all.n_curves() {
            let range = all.curve_offsets[c] as usize..all.curve_offsets[c + 1] as usize;
            for k in range.start..range.end - 1 {
                let (a, b) = (all.material[k], all.material[k + 1]);
                let ev = tile.edge_vector(topology.outgoing(all.tile_vertex[k] as usize));
                for (d, evc) in [ev.x, ev.y, ev.z].into_iter().enumerate() {
                    assert!((b[d] - a[d] - evc).abs() < 1e-12, "skew {skew}, curve {c}");
                }
            }
        }
        // Inside the rectangle at least a period from its border (where a copy whose cell
        // lies outside the mesh is not placed, as for rectangular tiles), exactly the lattice
        // copies' vertices are embedded.
        let interior = |x: f64, y: f64| x > px && x < w - px && y > py && y < h - py;
        let expected = (-6..12)
            .flat_map(|i| (-3..10).map(move |j| [i, j]))
            .flat_map(|shift| {
                let offset = tile.period_offset(shift);
                tile.positions.iter().map(move |x| x + offset)
            })
            .filter(|p| interior(p.x, p.y))
            .count();
        let embedded = all.material.iter().filter(|m| interior(m[0], m[1])).count();
        assert!(expected > 1000, "skew {skew}: {expected}");
        assert_eq!(embedded, expected, "skew {skew}");
        assert!(
            all.material
                .iter()
                .all(|m| (0.0..=w).contains(&m[0]) && (0.0..=h).contains(&m[1]))
        );
    }
}
