//! The pullback of an equilibrium into material space (seed 004 Eq. 18), for flat and bent
//! tiles: the displacement database stores, per vertex, the material-space displacement
//! `ΔQ = (X̂ − X, θ_{out(v)} − Θ_{out(v)})` of a tile solved under a coarse map.
//!
//! The solved position of vertex `v` with rest position `X` (m) and fluctuation `ũ` (m) is
//! `x = φ(F₃ X) + R(X) ũ` ([`Coarse::map`], [`Coarse::frame`]). Its material position is
//! `X̂ = F₃⁻¹ φ⁻¹(x)`:
//!
//! - **flat** (no curvature, or κ = 0): φ and R are the identity and
//!   `X̂ − X = F₃⁻¹ ũ = (F₂⁻¹ ũ_xy, ũ_z)` (seed 004 Eq. 18, in-plane), evaluated in that form;
//! - **bent** (κ ≠ 0 along x or y, [`crate::coarse::Curvature`]): φ⁻¹ is the exact inverse
//!   of the roll onto the cylinder of radius 1/|κ| (valid for `|z| < 1/|κ|`), the bent
//!   counterpart of Eq. 18 used by the bending databases of seed 004 Appendix C
//!   ([`crate::bending_database`]).
//!
//! Both forms agree at κ = 0 up to rounding (tested); the flat form is kept for it because it
//! does not round `F₃⁻¹ F₃ X − X`.

use nalgebra::Vector3;

use crate::coarse::Coarse;
use crate::periodic::PeriodicError;
use yarn_pattern::tile::Tile;

/// Inverse of the roll of [`Coarse::map`] with curvature `kappa` (1/m, ≠ 0) along `axis`
/// (0 = x, 1 = y): the point `(a, b, z)` (m) with `φ(a, b, z) = x` (valid for
/// `|z| < 1/|κ|`).
pub fn unroll(axis: usize, kappa: f64, x: &Vector3<f64>) -> Vector3<f64> {
    let c = 1.0 / kappa - x.z;
    let r = kappa.signum() * (x[axis] * x[axis] + c * c).sqrt();
    let angle = (x[axis] / r).atan2(c / r);
    let mut q = Vector3::new(0.0, 0.0, 1.0 / kappa - r);
    q[axis] = angle / kappa;
    q[1 - axis] = x[1 - axis];
    q
}

/// The material-space displacement rows `(Δx, Δy, Δz` (m)`, Δθ` (rad)`)` per vertex of the
/// equilibrium `dofs` (fluctuations `ũ`, then edge twists) of `tile` under `coarse`, flat or
/// bent (seed 004 Eq. 18; module documentation). `Δθ` is the twist change of the edge
/// leaving the vertex.
pub fn pullback(
    tile: &Tile,
    coarse: &Coarse,
    dofs: &[f64],
) -> Result<Vec<[f64; 4]>, PeriodicError> {
    match coarse.curvature.filter(|c| c.kappa != 0.0) {
        None => flat_pullback(tile, coarse, dofs),
        Some(c) => rolled_pullback(tile, coarse, dofs, Some((c.axis, c.kappa))),
    }
}

/// Twist change (rad) of the edge leaving vertex `v`; `n` is the number of vertices.
fn twist_change(tile: &Tile, dofs: &[f64], n: usize, outgoing: usize, v: usize) -> f64 {
    dofs[3 * n + outgoing] - tile.twists[v]
}

fn singular(m: impl std::fmt::Display) -> PeriodicError {
    PeriodicError::Invalid(format!("coarse map {m} is singular"))
}

/// Eq. 18 in-plane: `(F₂⁻¹ ũ_xy, ũ_z, Δθ)`.
fn flat_pullback(
    tile: &Tile,
    coarse: &Coarse,
    dofs: &[f64],
) -> Result<Vec<[f64; 4]>, PeriodicError> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let inverse = coarse.f.try_inverse().ok_or_else(|| singular(coarse.f))?;
    Ok((0..n)
        .map(|v| {
            let u = Vector3::new(dofs[3 * v], dofs[3 * v + 1], dofs[3 * v + 2]);
            let plane = inverse * u.xy();
            let theta = twist_change(tile, dofs, n, topology.outgoing(v), v);
            [plane.x, plane.y, u.z, theta]
        })
        .collect())
}

/// The general form `F₃⁻¹ φ⁻¹(φ(F₃ X) + R ũ) − X`, with φ the roll `(axis, κ)` (κ ≠ 0) or
/// the identity (`None`).
fn rolled_pullback(
    tile: &Tile,
    coarse: &Coarse,
    dofs: &[f64],
    roll: Option<(usize, f64)>,
) -> Result<Vec<[f64; 4]>, PeriodicError> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let inverse = coarse
        .f3()
        .try_inverse()
        .ok_or_else(|| singular(coarse.f))?;
    Ok((0..n)
        .map(|v| {
            let y = &tile.positions[v];
            let u = Vector3::new(dofs[3 * v], dofs[3 * v + 1], dofs[3 * v + 2]);
            let x = coarse.map(y) + coarse.frame(y) * u;
            let q = match roll {
                Some((axis, kappa)) => unroll(axis, kappa, &x),
                None => x,
            };
            let d = inverse * q - y;
            let theta = twist_change(tile, dofs, n, topology.outgoing(v), v);
            [d.x, d.y, d.z, theta]
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patterns::Pattern;
    use nalgebra::Matrix2;

    fn tile() -> Tile {
        let pattern = Pattern::PlainWeave;
        let mut params = pattern.default_params(1e-3);
        params.resolution = 3;
        pattern.generate(&params).unwrap()
    }

    /// Zero fluctuations and the rest twists.
    fn rest_dofs(tile: &Tile) -> Vec<f64> {
        let topology = tile.topology().unwrap();
        let n = tile.n_vertices();
        let mut dofs = vec![0.0; 3 * n + n];
        for v in 0..n {
            dofs[3 * n + topology.outgoing(v)] = tile.twists[v];
        }
        dofs
    }

    /// Some fluctuations (≈ 0.1 mm) and twist changes.
    fn perturbed_dofs(tile: &Tile) -> Vec<f64> {
        let mut dofs = rest_dofs(tile);
        for (i, d) in dofs.iter_mut().enumerate() {
            *d += 1e-4 * ((i as f64) * 0.7).sin();
        }
        dofs
    }

    /// Seed 004 Eq. 18: at zero strain and zero fluctuation ΔQ = 0, flat or bent.
    #[test]
    fn pullback_is_zero_at_rest() {
        let tile = tile();
        let dofs = rest_dofs(&tile);
        for coarse in [
            Coarse::identity(),
            Coarse::identity().bent(0, 0.0),
            Coarse::identity().bent(0, 40.0),
            Coarse::identity().bent(1, -25.0),
        ] {
            for row in pullback(&tile, &coarse, &dofs).unwrap() {
                for c in row {
                    assert!(c.abs() < 1e-16, "{row:?} under {coarse:?}");
                }
            }
        }
    }

    /// The flat form is the general form at κ = 0 (up to rounding), and the bent pullback
    /// tends to it as κ → 0: at κ = 1e-5 /m the roll moves a mm-sized tile by O(κ |X|²)
    /// ≈ 1e-10 m and unrolling rounds at ≈ 1e-16 / κ ≈ 1e-11 m, both well below 1e-9 m
    /// (displacements here are ≈ 1e-4 m).
    #[test]
    fn flat_and_bent_agree_at_zero_curvature() {
        let tile = tile();
        let dofs = perturbed_dofs(&tile);
        let flat = Coarse::in_plane(Matrix2::new(1.1, 0.05, 0.05, 0.95));
        let a = pullback(&tile, &flat, &dofs).unwrap();
        let b = rolled_pullback(&tile, &flat, &dofs, None).unwrap();
        let c = pullback(&tile, &flat.bent(1, 1e-5), &dofs).unwrap();
        for ((a, b), c) in a.iter().zip(&b).zip(&c) {
            for k in 0..4 {
                assert!((a[k] - b[k]).abs() < 1e-17, "{a:?} vs {b:?}");
                assert!((a[k] - c[k]).abs() < 1e-9, "{a:?} vs {c:?}");
            }
        }
    }

    /// `unroll` inverts the roll of [`Coarse::map`] under a sheared, stretched F₂, along x
    /// and y, for both signs of κ.
    #[test]
    fn unroll_inverts_the_roll() {
        let f = Matrix2::new(1.1, 0.05, 0.05, 0.95);
        for axis in 0..2 {
            for kappa in [-80.0, 25.0] {
                let coarse = Coarse::in_plane(f).bent(axis, kappa);
                let y = Vector3::new(0.003, -0.002, 0.0007);
                let q = unroll(axis, kappa, &coarse.map(&y));
                let back = coarse.f3().try_inverse().unwrap() * q;
                assert!((back - y).norm() < 1e-15, "{back} vs {y}");
            }
        }
    }

    /// A singular coarse map is an error, not a panic.
    #[test]
    fn singular_coarse_map_is_an_error() {
        let tile = tile();
        let dofs = rest_dofs(&tile);
        let coarse = Coarse::in_plane(Matrix2::zeros());
        assert!(pullback(&tile, &coarse, &dofs).is_err());
        assert!(pullback(&tile, &coarse.bent(0, 10.0), &dofs).is_err());
    }
}
