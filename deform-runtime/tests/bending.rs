//! The explicit bending model (paper 004 Appendix C, Eq. 19): closed form for data linear in
//! κ, agreement with the in-plane database on flat meshes, reproduction of the bent samples
//! on a rolled sheet, and input validation.

mod common;

use common::*;
use deform_runtime::bending::{BendingDatabase, curvature_tensor};
use deform_runtime::{DeformError, DeformOptions, Deformer, synthetic};
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

const KAPPA: f64 = 40.0;

/// Curvature samples (1/m).
fn kappas() -> Vec<f64> {
    vec![-KAPPA, 0.0, KAPPA]
}

/// Per-vertex slope ∂ΔQ/∂κ of the synthetic bending data along `axis` (m², m², m², rad·m).
fn slope(r: f64, axis: usize, v: usize) -> [f64; 4] {
    let p = (v % 11) as f64 / 11.0 - 0.5;
    let q = (v % 5) as f64 / 5.0 - 0.4;
    let a = [1.0, -0.6][axis];
    [
        a * r * p / KAPPA,
        r * q / KAPPA,
        a * r * (p + q) / KAPPA,
        0.1 * q / KAPPA,
    ]
}

/// Databases bent along `axis`: the multilinear in-plane data plus κ times [`slope`].
fn bent(tile: &Tile, axis: usize) -> Vec<Database> {
    let r = tile.radius;
    let base = synthetic::multilinear(r);
    kappas()
        .into_iter()
        .map(|k| {
            synthetic::database(tile, axes(), |v, s| {
                let a = base(v, s);
                let b = slope(r, axis, v);
                [0, 1, 2, 3].map(|c| a[c] + k * b[c])
            })
        })
        .collect()
}

fn bending(tile: &Tile) -> BendingDatabase<f64> {
    BendingDatabase::new(tile, &kappas(), &bent(tile, 0), &bent(tile, 1)).unwrap()
}

#[test]
fn linear_data_give_the_closed_form_for_every_orientation() {
    let tile = stockinette();
    let b = bending(&tile);
    let r = tile.radius;
    let base = synthetic::multilinear(r);
    let s = [0.1, -0.05, 0.12];
    // The databases store f32, so compare relative to each channel's magnitude.
    let mut worst = 0.0f64;
    let mut scale = [0.0f64; 4];
    for step in 0..12 {
        let angle = 0.3 * step as f64;
        let (l1, l2) = (35.0, -20.0 + 3.0 * step as f64);
        let (c, sn) = (angle.cos(), angle.sin());
        let k = [
            l1 * c * c + l2 * sn * sn,
            (l1 - l2) * c * sn,
            l1 * sn * sn + l2 * c * c,
        ];
        for v in [0, 3, 17, tile.positions.len() - 1] {
            let got = b.displacement(v, s, k);
            let a = base(v, s);
            let (b1, b2) = (slope(r, 0, v), slope(r, 1, v));
            for ch in 0..4 {
                let want = a[ch] + k[0] * b1[ch] + k[2] * b2[ch];
                scale[ch] = scale[ch].max(want.abs());
                worst = worst.max((got[ch] - want).abs() / scale[ch].max(f64::MIN_POSITIVE));
            }
        }
    }
    eprintln!("largest relative deviation from ΔQ(s) + K₁₁ b₁ + K₂₂ b₂: {worst:.2e}");
    assert!(worst < 1e-6, "{worst:e}");
    // Outside the sampled curvatures the lookup clamps (no extrapolation).
    let v = 5;
    let clamped = b.lookup(0, v, s, 3.0 * KAPPA);
    let edge = b.lookup(0, v, s, KAPPA);
    assert_eq!(clamped, edge);
}

#[test]
fn flat_sheets_match_the_in_plane_database() {
    let tile = stockinette();
    let db = database(&tile);
    let b = bending(&tile);
    let mesh = grid(&tile, 4.0, 5.0, 6);
    let mut d = deformer::<f64>(&tile, &db, &mesh, DeformOptions::default());
    for map in [
        synthetic::strain_map([0.15, 0.1, -0.05]),
        synthetic::strain_map([-0.15, 0.0, 0.2]),
    ] {
        let pos = synthetic::map_uvs(&mesh, map);
        d.frame(&pos).unwrap();
        let linearized = d.output().clone();
        let stats = d.frame_explicit(&pos, &b).unwrap();
        assert_eq!(stats.vertices.nonfinite_output, 0);
        let worst = linearized
            .x
            .iter()
            .zip(&d.output().x)
            .chain(linearized.y.iter().zip(&d.output().y))
            .chain(linearized.z.iter().zip(&d.output().z))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-12, "flat: explicit − linearized = {worst:e} m");
    }
}

/// A sheet rolled onto a cylinder of curvature 1.5 κmax along `axis` (centre on the +z side)
/// has interior curvature K ≈ 1.5 κmax e e ᵀ, clamped to the κmax sample: away from the
/// boundary the explicit model reproduces the deformation with the κmax sample's database.
#[test]
fn rolled_sheet_reproduces_the_bent_sample() {
    let tile = stockinette();
    let b = bending(&tile);
    let (cu, cv, quads) = (6.0, 8.0, 12);
    let mesh = grid(&tile, cu, cv, quads);
    let size = [cu * tile.period[0], cv * tile.period[1]];
    let kappa = 1.5 * KAPPA;
    for axis in 0..2 {
        let roll = |uv: [f64; 2]| {
            let (a, other) = (uv[axis], uv[1 - axis]);
            let mut p = [0.0, 0.0, (1.0 - (kappa * a).cos()) / kappa];
            p[axis] = (kappa * a).sin() / kappa;
            p[1 - axis] = other;
            p
        };
        let pos = synthetic::map_uvs(&mesh, roll);
        let options = DeformOptions::default();
        let mut explicit = deformer::<f64>(&tile, &database(&tile), &mesh, options);
        explicit.frame_explicit(&pos, &b).unwrap();
        // The κmax sample as a 3-D database, without linearized bending.
        let sample = &bent(&tile, axis)[2];
        let mut reference: Deformer<f64> = deformer(
            &tile,
            sample,
            &mesh,
            DeformOptions {
                linearized_bending: false,
                ..options
            },
        );
        reference.frame(&pos).unwrap();
        // Interior K from the mesh stage: one face in the middle.
        let g = explicit.geometry();
        let f = g.face_poly.len() / 2 + quads;
        let k = curvature_tensor(g.face_poly[f].i0, g.face_poly[f].ii0);
        eprintln!("axis {axis}: interior K = {k:?} (rolled with {kappa} 1/m)");
        assert!((k[2 * axis] - kappa).abs() < 0.05 * kappa, "{k:?}");
        let e = explicit.embedding();
        let margin = [1.5 * size[0] / quads as f64, 1.5 * size[1] / quads as f64];
        let (a, r) = (explicit.output(), reference.output());
        let mut worst = 0.0f64;
        let mut counted = 0;
        for k in 0..e.len() {
            let m = e.material[k];
            if (0..2).all(|d| m[d] > margin[d] && m[d] < size[d] - margin[d]) {
                counted += 1;
                let d = ((a.x[k] - r.x[k]).powi(2)
                    + (a.y[k] - r.y[k]).powi(2)
                    + (a.z[k] - r.z[k]).powi(2))
                .sqrt();
                worst = worst.max(d);
            }
        }
        eprintln!(
            "axis {axis}: {counted} interior vertices, explicit vs κmax sample {:.2e} R",
            worst / tile.radius
        );
        assert!(counted > 1000);
        assert!(worst < 1e-3 * tile.radius, "{:e} R", worst / tile.radius);
        // ... while the linearized model differs (it sees no bending data).
        let mut linearized = deformer::<f64>(&tile, &database(&tile), &mesh, options);
        linearized.frame(&pos).unwrap();
        let l = linearized.output();
        let moved = (0..e.len())
            .map(|k| (l.z[k] - a.z[k]).abs())
            .fold(0.0, f64::max);
        assert!(moved > 0.05 * tile.radius, "{:e}", moved / tile.radius);
    }
}

#[test]
fn invalid_bending_databases_are_rejected() {
    let tile = stockinette();
    let (x, y) = (bent(&tile, 0), bent(&tile, 1));
    let option = |r: deform_runtime::Result<BendingDatabase<f32>>| match r {
        Err(DeformError::Option { name, message }) => {
            assert_eq!(name, "bending database");
            message
        }
        other => panic!("expected an option error, found {other:?}"),
    };
    let m = option(BendingDatabase::new(&tile, &[0.0, -1.0, 1.0], &x, &y));
    assert!(m.contains("increasing"), "{m}");
    let m = option(BendingDatabase::new(&tile, &kappas(), &x[..2], &y));
    assert!(m.contains("one database per curvature"), "{m}");
    let mut other_axes = y.clone();
    other_axes[1] = synthetic::database(
        &tile,
        synthetic::uniform_axes(3),
        synthetic::multilinear(tile.radius),
    );
    let m = option(BendingDatabase::new(&tile, &kappas(), &x, &other_axes));
    assert!(m.contains("strain axes"), "{m}");
    let mut bad = x.clone();
    bad[0].data[7][2] = f32::NAN;
    assert!(matches!(
        BendingDatabase::<f32>::new(&tile, &kappas(), &bad, &y),
        Err(DeformError::NonFiniteData { .. })
    ));
}
