//! The builder from periodic yarn polylines to a [`Tile`] ([`tile_from_yarns`]), rest-shape
//! resets and re-basing a tile on a solution.

use super::PatternError;
use nalgebra::{SVector, Vector2, Vector3};
use rod::geometry::{Frame, reference_twist};
use rod::material_bending::MaterialBending;
use rod::twist::Twist;
use yarn_pattern::tile::{Edge, Tile, lattice_offset};

/// One closed periodic yarn: `points` in unwrapped coordinates (m); after the last point the
/// yarn continues to `points[0]` shifted by `shift` periods (`shift[0] a₁ + shift[1] a₂`,
/// [`Tile::period_offset`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Yarn {
    /// Centre-line points (m), at least 2 (3 with a zero shift).
    pub points: Vec<Vector3<f64>>,
    /// Period shift from the last point back to the first (`[0, 0]` for a yarn closed inside
    /// the tile).
    pub shift: [i32; 2],
}

/// Cell index of coordinate `x` for a centred cell of width `p`.
fn cell(x: f64, p: f64) -> i32 {
    ((x + 0.5 * p) / p).floor() as i32
}

/// Lattice cell `[i, j]` of point `p` for periods `a₁ = (px, 0)`, `a₂ = (skew px, py)`: the
/// course band `j` first, then the cell along it.
fn lattice_cell(p: &Vector3<f64>, period: [f64; 2], skew: f64) -> [i32; 2] {
    let j = cell(p.y, period[1]);
    [cell(p.x - skew * f64::from(j) * period[0], period[0]), j]
}

/// Builds a tile of periods `period` and lattice skew `skew` ([`Tile::skew`]) from periodic
/// yarn polylines; see the [module documentation](super) for the rest shape and frames.
/// Vertices are numbered yarn by yarn in point order, edge `e` starts at vertex `e`. Errors on a
/// non-positive period or radius, a skew outside `[−½, ½]` (through [`Tile::validate`]),
/// non-finite points, a yarn with too few points, a zero-length edge or a yarn closing on
/// itself with a zero shift and fewer than 3 points.
pub fn tile_from_yarns(
    period: [f64; 2],
    skew: f64,
    radius: f64,
    yarns: &[Yarn],
) -> Result<Tile, PatternError> {
    for (name, v) in [
        ("period x", period[0]),
        ("period y", period[1]),
        ("radius", radius),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(PatternError::Invalid(format!(
                "{name} must be positive and finite, found {v}"
            )));
        }
    }
    if yarns.is_empty() {
        return Err(PatternError::Invalid("no yarns given".into()));
    }
    let mut positions = Vec::new();
    let mut edges = Vec::new();
    let mut reference_directors = Vec::new();
    for (y, yarn) in yarns.iter().enumerate() {
        let m = yarn.points.len();
        let min = if yarn.shift == [0, 0] { 3 } else { 2 };
        if m < min {
            return Err(PatternError::Invalid(format!(
                "yarn {y} has {m} points, expected at least {min}"
            )));
        }
        if let Some(k) = yarn
            .points
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(PatternError::Invalid(format!(
                "point {k} of yarn {y} is not finite"
            )));
        }
        let offset = |s: [i32; 2]| lattice_offset(period, skew, s);
        let cells: Vec<[i32; 2]> = yarn
            .points
            .iter()
            .map(|p| lattice_cell(p, period, skew))
            .collect();
        let base = positions.len();
        let mut frame: Option<Frame> = None;
        for k in 0..m {
            positions.push(yarn.points[k] - offset(cells[k]));
            let (next, next_cell, v1) = if k + 1 < m {
                (yarn.points[k + 1], cells[k + 1], base + k + 1)
            } else {
                let c = [cells[0][0] + yarn.shift[0], cells[0][1] + yarn.shift[1]];
                (yarn.points[0] + offset(yarn.shift), c, base)
            };
            let e = next - yarn.points[k];
            if e.norm() <= 1e-9 * radius {
                return Err(PatternError::Invalid(format!(
                    "edge from point {k} of yarn {y} has zero length"
                )));
            }
            edges.push(Edge {
                v0: base + k,
                v1,
                shift: [next_cell[0] - cells[k][0], next_cell[1] - cells[k][1]],
            });
            let f = match frame {
                None => Frame::new(&e, &Vector3::z()).or_else(|| Frame::any_for(&e)),
                Some(prev) => prev.transported_to(&e),
            }
            .ok_or_else(|| {
                PatternError::Invalid(format!(
                    "cannot build a frame on edge {k} of yarn {y} (degenerate or folded back)"
                ))
            })?;
            reference_directors.push(f.d1);
            frame = Some(f);
        }
    }
    let n = positions.len();
    let mut tile = Tile {
        period,
        skew,
        radius,
        positions,
        twists: vec![0.0; n],
        edges,
        rest_lengths: vec![1.0; n],
        rest_curvatures: vec![[0.0; 2]; n],
        rest_twists: vec![0.0; n],
        reference_directors,
        reference_twists: vec![0.0; n],
    };
    let topology = tile.topology()?;
    let frames = rest_frames(&tile)?;
    for v in 0..n {
        let (a, b) = (topology.incoming(v), topology.outgoing(v));
        tile.reference_twists[v] = reference_twist(&frames[a], &frames[b]);
    }
    reset_rest_shape(&mut tile, None)?;
    Ok(tile)
}

/// The rest frame of every edge: tangent along the rest edge, `d₁` the tile's reference
/// director (made orthogonal), as [`PeriodicTile`] builds them.
fn rest_frames(tile: &Tile) -> Result<Vec<Frame>, PatternError> {
    (0..tile.n_vertices())
        .map(|e| {
            let ev = tile.edge_vector(e);
            Frame::new(&ev, &tile.reference_directors[e])
                .or_else(|| Frame::any_for(&ev))
                .ok_or_else(|| PatternError::Invalid(format!("edge {e} has zero length")))
        })
        .collect()
}

/// The 11 stencil DOFs `(x₀, x₁, x₂, θᵉ, θᶠ)` at vertex `v` of `tile` with its own twists,
/// and the incoming / outgoing edges.
fn vertex_stencil(
    tile: &Tile,
    v: usize,
    a: usize,
    b: usize,
    twist: impl Fn(usize) -> f64,
) -> SVector<f64, 11> {
    let ea = tile.edges[a];
    let x0 = tile.positions[ea.v0] - tile.period_offset(ea.shift);
    let x1 = tile.positions[v];
    let x2 = tile.edge_end_shifted(b);
    let mut q = SVector::<f64, 11>::zeros();
    for (k, p) in [x0, x1, x2].iter().enumerate() {
        q.fixed_rows_mut::<3>(3 * k).copy_from(p);
    }
    q[9] = twist(a);
    q[10] = twist(b);
    q
}

/// Resets the rest shape of `tile` to its current geometry (positions, reference frames, twist
/// angles): rest lengths to the edge lengths, rest curvatures to the material curvature of the
/// bending stencil, rest twists to the total twist `θᶠ − θᵉ + m_ref`. With `bound = Some((L₀,
/// f))` each new rest length is clamped to `[(1 − f) L₀[e], (1 + f) L₀[e]]` (`0 ≤ f < 1`,
/// `L₀ > 0`; anything else is an error).
pub fn reset_rest_shape(tile: &mut Tile, bound: Option<(&[f64], f64)>) -> Result<(), PatternError> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    if let Some((l0, f)) = bound {
        if l0.len() != n {
            return Err(PatternError::Invalid(format!(
                "rest-length bound has {} entries, expected {n}",
                l0.len()
            )));
        }
        if !(f.is_finite() && (0.0..1.0).contains(&f)) {
            return Err(PatternError::Invalid(format!(
                "rest-length change bound must be in [0, 1), found {f}"
            )));
        }
        if let Some(e) = l0.iter().position(|l| !(l.is_finite() && *l > 0.0)) {
            return Err(PatternError::Invalid(format!(
                "reference rest length of edge {e} must be positive and finite, found {}",
                l0[e]
            )));
        }
    }
    let frames = rest_frames(tile)?;
    for e in 0..n {
        let mut l = tile.edge_vector(e).norm();
        if let Some((l0, f)) = bound {
            l = l.clamp((1.0 - f) * l0[e], (1.0 + f) * l0[e]);
        }
        tile.rest_lengths[e] = l;
    }
    let theta: Vec<f64> = (0..n).map(|e| tile.twists[tile.edges[e].v0]).collect();
    for v in 0..n {
        let (a, b) = (topology.incoming(v), topology.outgoing(v));
        let q = vertex_stencil(tile, v, a, b, |e| theta[e]);
        let rest_lengths = (tile.rest_lengths[a], tile.rest_lengths[b]);
        let bend = MaterialBending {
            stiffness: 1.0,
            rest_lengths,
            rest_curvature: Vector2::zeros(),
            reference: (frames[a], frames[b]),
        };
        let k = bend.curvature(&q);
        tile.rest_curvatures[v] = [k.x, k.y];
        let twist = Twist {
            stiffness: 1.0,
            rest_lengths,
            rest_twist: 0.0,
            reference: (frames[a], frames[b]),
            reference_twist: tile.reference_twists[v],
        };
        tile.rest_twists[v] = twist.twist(&q);
    }
    tile.validate()?;
    Ok(())
}

/// Moves `tile` to the equilibrium DOFs `dofs` at **zero coarse strain** (fluctuations then
/// edge twist angles, as in [`crate::periodic::Equilibrium::dofs`]), keeping its rest shape:
/// positions `X + ũ`, twist angles θ, reference directors parallel transported onto the new
/// edges and reference twists continued (as the stencils do), so the new tile describes the
/// same material frames and the same energy at its zero DOFs.
pub fn rebase(tile: &Tile, dofs: &[f64]) -> Result<Tile, PatternError> {
    rebase_stretched(tile, [1.0, 1.0], dofs)
}

/// [`rebase`] under the coarse stretch `F₂ = diag(stretch)` (unitless, > 0): positions
/// `F X + ũ` and period `(F₁₁ pₓ, F₂₂ p_y)`, so the new tile at zero strain is the old one at
/// `F` (used to relax the period, [`crate::database::relax_period`]).
pub fn rebase_stretched(
    tile: &Tile,
    stretch: [f64; 2],
    dofs: &[f64],
) -> Result<Tile, PatternError> {
    if !stretch.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(PatternError::Invalid(format!(
            "stretch {stretch:?} must be finite and positive"
        )));
    }
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    if dofs.len() != 4 * n {
        return Err(PatternError::Invalid(format!(
            "got {} DOFs, expected {}",
            dofs.len(),
            4 * n
        )));
    }
    if !dofs.iter().all(|x| x.is_finite()) {
        return Err(PatternError::Invalid("non-finite DOFs".into()));
    }
    let old_frames = rest_frames(tile)?;
    let mut out = tile.clone();
    out.period = [stretch[0] * tile.period[0], stretch[1] * tile.period[1]];
    for v in 0..n {
        let p = tile.positions[v];
        out.positions[v] = Vector3::new(stretch[0] * p.x, stretch[1] * p.y, p.z)
            + Vector3::new(dofs[3 * v], dofs[3 * v + 1], dofs[3 * v + 2]);
    }
    for e in 0..n {
        let f = old_frames[e]
            .transported_to(&out.edge_vector(e))
            .ok_or_else(|| PatternError::Invalid(format!("edge {e} collapsed")))?;
        out.reference_directors[e] = f.d1;
        out.twists[tile.edges[e].v0] = dofs[3 * n + e];
    }
    for v in 0..n {
        let (a, b) = (topology.incoming(v), topology.outgoing(v));
        let q = vertex_stencil(&out, v, a, b, |_| 0.0);
        let twist = Twist {
            stiffness: 1.0,
            rest_lengths: (tile.rest_lengths[a], tile.rest_lengths[b]),
            rest_twist: 0.0,
            reference: (old_frames[a], old_frames[b]),
            reference_twist: tile.reference_twists[v],
        };
        out.reference_twists[v] = twist.twist(&q);
    }
    out.validate()?;
    Ok(out)
}
