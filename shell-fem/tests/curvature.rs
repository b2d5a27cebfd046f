//! The hinge curvature normalization of Eq. 4 against a closed form: a flat rectangle mesh
//! wrapped isometrically (node-wise) on a cylinder of radius `R` whose axis runs along one
//! grid direction.
//!
//! Closed form. Every triangle of the checkerboard rectangle mesh has exactly one edge along the
//! cylinder axis, and the two triangles of such an edge reach one grid spacing `Δ` around the
//! cylinder, so their chords subtend `Δ/R` each and the dihedral angle is exactly `θ = Δ/R`
//! with mean altitude `H = Δ`. Edges across the axis and diagonals stay flat (each cell's four
//! nodes lie on two generators, a plane). So the printed metric gives `κ = 3θ/H = 3/R`
//! exactly, and the total hinge energy is `k_θ (3/R)² A'` with `A'` the area of the triangles
//! whose axial edge is interior (all but one triangle per row at each end): nine times the
//! continuum `k_θ A'/R²`, i.e. a bending rigidity (moment per width per curvature) of
//! `18 k_θ`, not `2 k_θ`.

use nalgebra::SVector;
use rod::Stencil;
use shell_fem::elements::{BendingParams, Hinge};
use shell_fem::shell::TriMesh;

/// Total hinge energy (J) of the `nx × ny` mesh on `[0, l] × [0, w]` wrapped on a cylinder of
/// radius `r` with its axis along material `y` (`axis_y`) or `x`.
fn wrapped_energy(
    l: f64,
    w: f64,
    nx: usize,
    ny: usize,
    r: f64,
    k: BendingParams,
    axis_y: bool,
) -> f64 {
    let mesh = TriMesh::rectangle(l, w, nx, ny).unwrap();
    let pos: Vec<[f64; 3]> = mesh
        .rest
        .iter()
        .map(|p| {
            let (s, a) = if axis_y { (p[0], p[1]) } else { (p[1], p[0]) };
            let (u, z) = (r * (s / r).sin(), r * (1.0 - (s / r).cos()));
            if axis_y { [u, a, z] } else { [a, u, z] }
        })
        .collect();
    mesh.hinges()
        .iter()
        .map(|h| {
            let hinge = Hinge::new(h.map(|v| mesh.rest[v]), &k).unwrap();
            let q = SVector::<f64, 12>::from_fn(|i, _| pos[h[i / 3]][i % 3]);
            hinge.energy(&q)
        })
        .sum()
}

#[test]
fn printed_hinge_metric_gives_three_over_r_on_a_cylinder() {
    let (l, w, nx, ny) = (0.10, 0.06, 20, 6);
    let k = BendingParams {
        weft: 2e-6,
        bias: 1e-6,
        warp: 5e-6,
    };
    for r in [0.02, 0.05] {
        for axis_y in [true, false] {
            let (along, across, d_across) = if axis_y {
                (w, l, l / nx as f64)
            } else {
                (l, w, w / ny as f64)
            };
            // Bending hinges are the edges along the axis: k of the axis direction.
            let k_axis = if axis_y { k.warp } else { k.weft };
            let area = along * (across - d_across);
            let e = wrapped_energy(l, w, nx, ny, r, k, axis_y);
            let kappa_eff = (e / (k_axis * area)).sqrt();
            println!(
                "R = {r}, axis along {}: κ_eff R = {:.12}",
                if axis_y { "y" } else { "x" },
                kappa_eff * r
            );
            assert!(
                (kappa_eff * r - 3.0).abs() < 1e-9,
                "κ_eff R = {}",
                kappa_eff * r
            );
        }
    }
}
