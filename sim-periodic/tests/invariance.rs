//! Invariances of the pulled-back displacements ΔQ (seed 004 Eq. 18): they do not depend on
//! which `F` with `FᵀF = I` realizes a strain, and a mirror-symmetric tile gives mirrored ΔQ,
//! the same Ψ and opposite shear stress under `sa → −sa`. (That a k × k copy of a tile is in
//! equilibrium in the tile's state, with the tile's Ψ, is tested in `equilibrium.rs`; solved
//! as a supercell, a 2 × 2 copy of the real stockinette relaxes further, see issue 13's notes.)

use nalgebra::{Matrix2, Rotation2, Vector3};
use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::database::{material_displacements, relax_reference};
use sim_periodic::patterns::{Pattern, RelaxSettings, relax};
use sim_periodic::periodic::{Equilibrium, EquilibriumSettings, YarnModel, solve_equilibrium};
use yarn_pattern::tile::Tile;

mod common;
use common::stockinette;

fn relaxed(tile: &Tile) -> (Tile, YarnModel) {
    let model = YarnModel::default_for_radius(tile.radius);
    let (relaxed, _) = relax_reference(tile, &model, &EquilibriumSettings::default()).unwrap();
    (relaxed, model)
}

fn solve(tile: &Tile, model: &YarnModel, coarse: Coarse) -> Equilibrium {
    solve_equilibrium(tile, model, coarse, None, &EquilibriumSettings::default()).unwrap()
}

/// Largest position (m) and twist (rad) difference between two ΔQ row sets.
fn max_difference(a: &[[f64; 4]], b: &[[f64; 4]]) -> (f64, f64) {
    let (mut dx, mut dtheta) = (0.0f64, 0.0f64);
    for (p, q) in a.iter().zip(b) {
        dx = dx.max((0..3).map(|i| (p[i] - q[i]).abs()).fold(0.0, f64::max));
        dtheta = dtheta.max((p[3] - q[3]).abs());
    }
    (dx, dtheta)
}

const STRAIN: Strain = Strain {
    sx: 0.1,
    sa: 0.2,
    sy: -0.05,
};

#[test]
fn displacements_do_not_depend_on_the_rotation_in_f() {
    let (tile, model) = relaxed(&stockinette());
    let symmetric = Coarse::from_strain(&STRAIN);
    let eq = solve(&tile, &model, symmetric);
    let reference = material_displacements(&tile, &symmetric, &eq.dofs).unwrap();
    for angle in [0.3, -1.1] {
        let rotated: Matrix2<f64> = Rotation2::new(angle).matrix() * symmetric.f;
        let coarse = Coarse::in_plane(rotated);
        let other = solve(&tile, &model, coarse);
        let (dx, dtheta) = max_difference(
            &reference,
            &material_displacements(&tile, &coarse, &other.dofs).unwrap(),
        );
        eprintln!(
            "rotation {angle} rad: Ψ {:.12e} vs {:.12e} J/m², max |ΔX − ΔX'| = {:.3e} R, \
             max |Δθ − Δθ'| = {dtheta:.3e} rad",
            eq.density,
            other.density,
            dx / tile.radius
        );
        assert!((eq.density - other.density).abs() <= 1e-9 * eq.density.abs());
        assert!(dx < 1e-6 * tile.radius, "positions differ by {dx:e} m");
        assert!(dtheta < 1e-6, "twists differ by {dtheta:e} rad");
    }
}

/// The material positions `X + ΔQ_xyz` of every vertex, wrapped into the period.
fn material_positions(tile: &Tile, rows: &[[f64; 4]]) -> Vec<Vector3<f64>> {
    (0..tile.n_vertices())
        .map(|v| tile.positions[v] + Vector3::new(rows[v][0], rows[v][1], rows[v][2]))
        .collect()
}

/// The mirror `x → c − x` (and `z → −z` when `flip_z`) of `p`.
fn mirror(p: &Vector3<f64>, c: f64, flip_z: bool) -> Vector3<f64> {
    Vector3::new(c - p.x, p.y, if flip_z { -p.z } else { p.z })
}

/// Largest distance from a mirrored point of `a` to the nearest point of `b` (over the
/// periodic images of `period`).
fn mirror_mismatch(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
    (c, flip_z): (f64, bool),
    period: [f64; 2],
) -> f64 {
    let wrap = |d: f64, p: f64| d - p * (d / p).round();
    a.iter()
        .map(|p| {
            let m = mirror(p, c, flip_z);
            b.iter()
                .map(|q| {
                    Vector3::new(
                        wrap(m.x - q.x, period[0]),
                        wrap(m.y - q.y, period[1]),
                        m.z - q.z,
                    )
                    .norm()
                })
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_mirror_symmetric_tile_gives_mirrored_displacements_under_opposite_shear() {
    // The procedural plain weave is mirror symmetric across a plane x = const.
    let radius = 1e-3;
    let model = YarnModel::default_for_radius(radius);
    let pattern = Pattern::PlainWeave;
    let guess = pattern.generate(&pattern.default_params(radius)).unwrap();
    let (tile, _) = relax(&guess, &model, &RelaxSettings::default()).unwrap();
    let (tile, _) = relax_reference(&tile, &model, &EquilibriumSettings::default()).unwrap();
    let n = tile.n_vertices();
    let rest = material_positions(&tile, &vec![[0.0; 4]; n]);
    // The mirror plane: through the origin or half a period away, with or without z → −z.
    let candidates = [0.0, 0.5 * tile.period[0]]
        .into_iter()
        .flat_map(|c| [(c, false), (c, true)]);
    let (plane, at_rest) = candidates
        .map(|m| (m, mirror_mismatch(&rest, &rest, m, tile.period)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    assert!(
        at_rest < 1e-9 * radius,
        "no mirror plane found: {at_rest:e} m"
    );

    for sa in [0.2, 0.45] {
        let plus = Coarse::from_strain(&Strain { sa, ..STRAIN });
        let minus = Coarse::from_strain(&Strain { sa: -sa, ..STRAIN });
        let (ep, em) = (solve(&tile, &model, plus), solve(&tile, &model, minus));
        let xp = material_positions(
            &tile,
            &material_displacements(&tile, &plus, &ep.dofs).unwrap(),
        );
        let xm = material_positions(
            &tile,
            &material_displacements(&tile, &minus, &em.dofs).unwrap(),
        );
        let mismatch = mirror_mismatch(&xp, &xm, plane, tile.period);
        eprintln!(
            "sa = ±{sa}: Ψ {:.12e} vs {:.12e} J/m², P₁₂ {:.6e} vs {:.6e} N/m, mirrored ΔQ \
             mismatch {:.3e} R",
            ep.density,
            em.density,
            ep.stress[(0, 1)],
            em.stress[(0, 1)],
            mismatch / radius
        );
        assert!((ep.density - em.density).abs() <= 1e-8 * ep.density.abs());
        assert!(
            mismatch < 1e-6 * radius,
            "mirrored ΔQ differ by {mismatch:e} m"
        );
    }
}
