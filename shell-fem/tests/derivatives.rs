//! Asserting finite-difference checks of every shell energy term (membrane in 2-D and 3-D for
//! all three material models, edge hinge) on seeded random configurations, and of the assembled
//! shell through the `solver::Problem` interface.

use nalgebra::SVector;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::fd::{FdOptions, assert_stencil_derivatives, check_gradient};
use shell_fem::elements::{BendingParams, Hinge, MembraneTriangle};
use shell_fem::material::{InPlaneParams, Material, Model};
use shell_fem::shell::{Gravity, Shell, ShellOptions, TriMesh};
use solver::Problem;

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x5eed_0002),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Element size (m): a 5 mm triangle.
const L: f64 = 5e-3;

fn materials() -> impl Strategy<Value = Material> {
    (
        (50.0..800.0f64, -0.4..0.4f64, 50.0..800.0f64, 10.0..300.0f64),
        (0.0..100.0f64, 0.0..100.0f64),
        (0.0..12.0f64, 0.0..12.0f64, 0.0..12.0f64, 0.0..12.0f64),
        0..3usize,
    )
        .prop_map(
            |((kxx, r, kyy, kss), (kn1, kn2), (bx, by, cx, cy), model)| Material {
                params: InPlaneParams {
                    kxx,
                    kxy: r * (kxx * kyy).sqrt(),
                    kyy,
                    kss,
                    kn1,
                    kn2,
                    bx,
                    by,
                    cx,
                    cy,
                },
                model: Model::ALL[model],
            },
        )
}

fn rest_triangle() -> impl Strategy<Value = [[f64; 2]; 3]> {
    (0.5..1.5f64, -0.4..0.4f64, 0.5..1.5f64, -0.5..0.5f64)
        .prop_map(|(a, b, c, d)| [[0.0, 0.0], [a * L, b * L], [d * L, c * L]])
}

proptest! {
    #![proptest_config(config(128))]

    #[test]
    fn membrane_planar(rest in rest_triangle(), m in materials(),
                       f in (0.6..1.8f64, -0.3..0.3f64, -0.3..0.3f64, 0.6..1.8f64),
                       t in (-L..L, -L..L)) {
        let tri = MembraneTriangle::new(rest, m).unwrap();
        let q = SVector::<f64, 6>::from_fn(|k, _| {
            let p = rest[k / 2];
            if k % 2 == 0 { f.0 * p[0] + f.1 * p[1] + t.0 } else { f.2 * p[0] + f.3 * p[1] + t.1 }
        });
        assert_stencil_derivatives::<6, _>(&tri, &q, L);
    }

    #[test]
    fn membrane_3d(rest in rest_triangle(), m in materials(),
                   noise in proptest::collection::vec(-0.3 * L..0.3 * L, 9)) {
        let tri = MembraneTriangle::new(rest, m).unwrap();
        let q = SVector::<f64, 9>::from_fn(|k, _| {
            let p = rest[k / 3];
            let base = match k % 3 { 0 => 1.2 * p[0], 1 => 0.9 * p[1], _ => 0.3 * p[0] };
            base + noise[k]
        });
        assert_stencil_derivatives::<9, _>(&tri, &q, L);
    }

    #[test]
    fn hinge(kw in 1e-6..1e-4f64, kb in 1e-6..1e-4f64, kp in 1e-6..1e-4f64,
             noise in proptest::collection::vec(-0.4 * L..0.4 * L, 12)) {
        let rest = [[0.5 * L, L], [0.0, 0.0], [L, 0.1 * L], [0.4 * L, -0.9 * L]];
        let h = Hinge::new(rest, &BendingParams { weft: kw, bias: kb, warp: kp }).unwrap();
        let q = SVector::<f64, 12>::from_fn(|k, _| {
            let p = rest[k / 3];
            let base = if k % 3 == 2 { 0.0 } else { p[k % 3] };
            base + noise[k]
        });
        assert_stencil_derivatives::<12, _>(&h, &q, L);
    }
}

#[test]
fn hinge_angle_and_energy_on_a_cylinder() {
    // Two triangles of altitude h across a weft edge, wrapped on a cylinder of radius R whose
    // axis is along the edge: θ = h/R up to O(h³), and W = 9 k (A₁ + A₂) θ² / H² with H = h
    // (Eq. 4 as printed: κ = 3θ/H). Note κ = 3θ/H = 3/R on this stencil, not 1/R: see the
    // crate docs on the curvature normalization.
    let (h, w, r, k) = (1e-3, 1e-2, 0.02, 2.0e-5);
    let rest = [[0.0, -h], [0.0, 0.0], [w, 0.0], [w, h]];
    let hinge = Hinge::new(
        rest,
        &BendingParams {
            weft: k,
            bias: 3.0 * k,
            warp: 5.0 * k,
        },
    )
    .unwrap();
    let on_cyl = |x: f64, s: f64| [x, r * (s / r).sin(), r * (1.0 - (s / r).cos())];
    let pts = [
        on_cyl(0.0, -h),
        on_cyl(0.0, 0.0),
        on_cyl(w, 0.0),
        on_cyl(w, h),
    ];
    let q: [f64; 12] = std::array::from_fn(|i| pts[i / 3][i % 3]);
    let theta = Hinge::angle(&q);
    assert!((theta.abs() - h / r).abs() < 1e-3 * h / r, "θ = {theta}");
    let area = w * h; // A₁ + A₂
    let expected = k * (3.0 * theta / h).powi(2) * area;
    let e = rod::Stencil::<12>::energy(&hinge, &SVector::from_column_slice(&q));
    assert!((e - expected).abs() < 1e-12 * expected, "{e} vs {expected}");
}

#[test]
fn bending_stiffness_interpolates_by_edge_direction() {
    let b = BendingParams {
        weft: 1.0,
        bias: 3.0,
        warp: 7.0,
    };
    assert_eq!(b.stiffness(1.0, 0.0), 1.0);
    assert!((b.stiffness(1.0, 1.0) - 3.0).abs() < 1e-12);
    assert!((b.stiffness(-1.0, 1.0) - 3.0).abs() < 1e-12);
    assert!((b.stiffness(0.0, 1.0) - 7.0).abs() < 1e-12);
    let phi = 22.5f64.to_radians();
    assert!((b.stiffness(phi.cos(), phi.sin()) - 2.0).abs() < 1e-12);
}

#[test]
fn assembled_shell_gradient_matches_finite_differences() {
    let mesh = TriMesh::rectangle(0.02, 0.01, 4, 2).unwrap();
    let opts = ShellOptions {
        dim: 3,
        bending: Some(BendingParams {
            weft: 1e-5,
            bias: 2e-5,
            warp: 3e-5,
        }),
        gravity: Some(Gravity {
            areal_density: 0.2,
            g: 9.81,
        }),
    };
    let shell = Shell::new(&mesh, Material::augmented(InPlaneParams::example()), opts).unwrap();
    assert!(shell.n_stencils() > mesh.triangles.len() + mesh.rest.len());
    let mut x = shell.positions_from_rest(&mesh.rest);
    for (i, v) in x.iter_mut().enumerate() {
        *v += 1e-4 * ((i as f64 * 0.77).sin());
    }
    let energy = |x: &[f64]| {
        let mut g = [0.0; 12];
        (0..shell.n_stencils())
            .map(|k| {
                let m = shell.stencil_dofs(k).len();
                shell.eval_stencil(k, x, &mut g[..m], None)
            })
            .sum::<f64>()
    };
    let g = shell_fem::swatch::full_gradient(&shell, &x);
    check_gradient(energy, &g, &x, &FdOptions::for_scale(1e-2, 1e-3)).unwrap();
}

#[test]
fn hinges_of_a_rectangle_are_its_interior_edges() {
    let mesh = TriMesh::rectangle(1.0, 1.0, 3, 2).unwrap();
    // Interior edges: 3·2 diagonals + 2·2 vertical + 3·1 horizontal.
    assert_eq!(mesh.hinges().len(), 6 + 4 + 3);
    let fine = mesh.subdivide();
    assert_eq!(fine.triangles.len(), 4 * mesh.triangles.len());
    // Euler: V − E + F = 1 for a disc.
    let e_int = fine.hinges().len();
    let boundary = 2 * (6 + 4);
    assert_eq!(fine.rest.len() + fine.triangles.len(), e_int + boundary + 1);
}
