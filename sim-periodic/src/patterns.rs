//! Procedural periodic yarn patterns: a builder from periodic yarn polylines to a [`Tile`],
//! geometric initial guesses for eight knit and woven patterns, and their relaxation to a
//! stable rest state (issue 4, "Tiles and patterns"; seed 002 §7.1–7.2, seed 004 §3).
//!
//! # Building a tile from polylines ([`tile_from_yarns`])
//!
//! A [`Yarn`] is a closed periodic polyline: its points in *unwrapped* coordinates, continuing
//! after the last point to the first point shifted by `shift` periods. The builder
//!
//! - wraps every point into the centred cell `[−pₓ/2, pₓ/2) × [−p_y/2, p_y/2)` and gives each
//!   edge the period shift between the cells of its two (unwrapped) end points, so edges that
//!   cross the tile boundary carry non-zero shifts;
//! - sets rest lengths to the edge lengths;
//! - sets the reference director `d₁` of each yarn's first edge to the component of `e_z`
//!   orthogonal to it (any orthogonal unit vector if the edge is vertical) and parallel
//!   transports it edge to edge along the yarn (Bergou 2008 §4.1);
//! - sets reference twists to [`rod::geometry::reference_twist`] of consecutive frames: zero
//!   (to round-off) except at the vertex that closes each yarn, which carries the holonomy of
//!   the transport around the periodic yarn;
//! - sets edge twist angles θ to zero and, through [`reset_rest_shape`], the rest curvatures
//!   to the material curvature of the stencil of [`rod::material_bending`] and the rest twists
//!   to the total twist `θᶠ − θᵉ + m_ref` of [`rod::twist`], so the given geometry is exactly
//!   the rest state of the stretch, bending and twist energies (zero energy and gradient).
//!
//! # Knit patterns (stockinette, garter, 1×1 rib, 2×2 rib, seed)
//!
//! A knit tile has `cols` wales (x, spacing `w`) and `rows` courses (y, spacing `s`); each
//! course is one yarn with shift `(1, 0)`, made of `cols` stitch loops. A stitch centred at
//! `(x_c, y_c)` is the classic parametric knit loop, `t ∈ [0, 2π)`:
//!
//! ```text
//! x(t) = x_c + (t − π) w / (2π) + (w/4) sin 2t     sinker at t = 0, head at t = π
//! y(t) = y_c − h cos t                             h = s/2 + 1.3 R (loop height 2h)
//! z(t) = Z σ p(t) g(t)                             Z = 1.25 R
//! ```
//!
//! The `sin 2t` term makes the legs narrow at the bottom (where they pass through the loop
//! below) and wide at the top (the head, through which the loop above passes); the loops of
//! course `j + 1`, shifted by `s`, overlap the heads of course `j` by `2h − s = 2.6 R` (rows
//! interlock with the row below, as in the real `stockinette.pyp`, whose loops have
//! `w ≈ 7.5 R`, `s ≈ 4 R`, `h ≈ 3.3 R`, `|z| ≤ 1.3 R`).
//!
//! The over/under (z) follows from the stitch types `σ = +1` (knit) or `−1` (purl) of the
//! stitch itself (`σ`, which decides how this loop meets the loop below) and of the stitch
//! above it in the same wale (`σ_up`, how the loop above meets this one). In a knit stitch the
//! new loop is pulled through the old one from back to front: its legs pass *in front of* the
//! old head and its sinkers *behind* the old legs. Hence:
//!
//! - `σ_up = σ` (stockinette, ribs): `p(t) = −cos 2t` — sinker and head behind, legs in front
//!   for a knit stitch; a purl stitch (`σ = −1`) is the knit loop mirrored in z;
//! - `σ_up ≠ σ` (garter, seed): `p(t) = −cos 3t` — sinker behind, lower legs in front, upper
//!   legs behind and head in front for a knit stitch (and mirrored for purl), so that the
//!   purl loop above meets this loop mirrored;
//! - where a knit stitch meets a purl stitch in the same course (ribs, seed), the sinker
//!   between them has to pass from one face to the other: `g(t) = sin(π t / (2 t_b))` ramps z
//!   to zero at that stitch boundary over `t_b = 0.2` (a C¹ join; `g = 1` elsewhere).
//!
//! Default spacings ([`Pattern::default_params`]) differ per pattern so that the guess has no
//! deep overlaps: the face changes of garter and seed (`−cos 3t`) need more course height
//! (`s = 6 R`), and the knit–purl sinkers of ribs and seed more wale width (`w = 8.5 R`).
//! The closest non-neighbouring segments of the guesses are then 0.72–0.88 × 2R apart at 24
//! vertices per loop (0.64–0.66 × 2R for ribs and seed at 16, where chords cut the ramps).
//!
//! Tiles (wales × courses, stitch types by row): stockinette 1×1 `[K]`; garter 1×2 `[K], [P]`;
//! 1×1 rib 2×1 `[K P]`; 2×2 rib 4×1 `[K K P P]`; seed 2×2 `[K P], [P K]`. The period is
//! `(cols · w, rows · s)`.
//!
//! # Woven patterns (plain, 2×2 basket, 5-harness satin)
//!
//! An interlacing matrix `M[i][k] = ±1` (`+1`: warp `i` over weft `k`) of size `n × n` gives
//! `n` warp yarns along y (at `x = (i + ½) d_x`, shift `(0, 1)`) and `n` weft yarns along x
//! (at `y = (k + ½) d_y`, shift `(1, 0)`), period `(n d_x, n d_y)`. Along a warp, z passes
//! through `A M[i][k]` at each crossing with a C¹ half-cosine between crossings (flat over
//! floats, a sinusoid where the yarn changes side); the weft is the same with `−A M[i][k]`.
//! `A = R`, so crossing yarns are `2A = 2R` apart: they touch. Plain weave: `n = 2`,
//! checkerboard; basket: `n = 4`, checkerboard of 2 × 2 blocks; satin: `n = 5`, warp over
//! four wefts and under one, the under crossing moving by 2 from warp to warp.
//!
//! # Relaxation ([`relax`]) and what is reset
//!
//! The guess's rest shape is its own geometry, so only contacts (centre-line distance below
//! the soft contact range `2R₁`) exert forces on it. Following seed 002 §7.2 (rest-shape
//! estimation: "alternating equilibrium solves with resetting of yarn rest shapes at the
//! current configuration", rest-length change bounded to 20 %), [`relax`] runs
//! [`RelaxSettings::rounds`] rounds of
//!
//! 1. an equilibrium solve at zero coarse strain ([`solve_equilibrium`], which errors on
//!    non-convergence; contacts push the yarns apart),
//! 2. moving the tile to the solution ([`rebase`]: positions, twist angles, transported
//!    reference frames) and resetting the **whole rest shape** there ([`reset_rest_shape`]):
//!    rest lengths (clamped to ±[`RelaxSettings::max_rest_length_change`] of the guess's),
//!    rest curvatures and rest twists,
//!
//! and then a **final** equilibrium solve whose solution becomes the tile's positions
//! *without* a further reset. Re-basing the reference frames onto the solution by parallel
//! transport changes the stencils' energy function slightly (transporting old → new rest edge →
//! current edge differs from old → current by a holonomy rotation that is first order in the
//! displacement), so the final solve is repeated — rebase, solve — until the tile moves less
//! than [`RelaxSettings::settle_tolerance`] (displacements shrink roughly quadratically:
//! 0.2 R, 1e-7 m, 1e-9 m, 1e-12 m on the garter tile); not settling within
//! [`RelaxSettings::max_settle_solves`] is an error. Why no reset after the last solve: resetting after the last solve would make the stored
//! positions stress-free in stretch, bending and twist while contacts still push, so the
//! stored tile would not be an equilibrium and every later solve would first move it (the
//! displacement database requires ΔQ ≈ 0 at zero strain). Resetting during the rounds makes the
//! displacements that contacts impose on the guess permanent (as the plasticity of knitting
//! that seed 002 §7.2 invokes does) instead of storing them as bending and stretch stress; each
//! round moves the yarns less than the one before, and the final solve leaves a stable,
//! slightly pre-tensed state with small balanced forces between bending, stretch and contact,
//! the rest state seed 002 §7.2 aims for. The period is not changed, so the relaxed tile may
//! carry a small coarse stress at zero strain ([`RelaxReport::stress`]).
//!
//! All lengths in metres.

use crate::coarse::Coarse;
use crate::periodic::{
    Equilibrium, EquilibriumSettings, PeriodicError, PeriodicTile, YarnModel, initial_dofs,
    solve_equilibrium,
};
use crate::tile::{Edge, Tile, TileError};
use nalgebra::{Matrix2, SVector, Vector2, Vector3};
use rod::contact::closest_points;
use rod::geometry::{Frame, reference_twist};
use rod::material_bending::MaterialBending;
use rod::twist::Twist;
use std::f64::consts::{PI, TAU};
use std::time::Instant;

/// Errors of pattern generation and relaxation.
#[derive(Debug, thiserror::Error)]
pub enum PatternError {
    /// A parameter or an input polyline is not admissible.
    #[error("invalid pattern input: {0}")]
    Invalid(String),
    /// The built tile is inconsistent.
    #[error("invalid tile: {0}")]
    Tile(#[from] TileError),
    /// An equilibrium solve failed (non-convergence included).
    #[error("relaxation failed: {0}")]
    Periodic(#[from] PeriodicError),
}

/// One closed periodic yarn: `points` in unwrapped coordinates (m); after the last point the
/// yarn continues to `points[0]` shifted by `shift` periods.
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

/// Builds a tile from periodic yarn polylines; see the [module documentation](self) for the
/// rest shape and frames. Vertices are numbered yarn by yarn in point order, edge `e` starts at
/// vertex `e`. Errors on a non-positive period or radius, non-finite points, a yarn with too
/// few points, a zero-length edge or a yarn closing on itself with a zero shift and fewer than
/// 3 points.
pub fn tile_from_yarns(
    period: [f64; 2],
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
        let offset = |s: [i32; 2]| {
            Vector3::new(
                f64::from(s[0]) * period[0],
                f64::from(s[1]) * period[1],
                0.0,
            )
        };
        let cells: Vec<[i32; 2]> = yarn
            .points
            .iter()
            .map(|p| [cell(p.x, period[0]), cell(p.y, period[1])])
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

/// The procedural patterns of the library.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pattern {
    /// Stockinette (all knit), 1 wale × 1 course.
    Stockinette,
    /// Garter (knit and purl courses alternating), 1 × 2.
    Garter,
    /// 1×1 rib (knit and purl wales alternating), 2 × 1.
    Rib1x1,
    /// 2×2 rib (two knit, two purl wales), 4 × 1.
    Rib2x2,
    /// Seed (knit and purl alternating in both directions), 2 × 2.
    Seed,
    /// Plain weave, 2 warp × 2 weft.
    PlainWeave,
    /// 2×2 basket weave, 4 × 4.
    BasketWeave,
    /// 5-harness satin (warp-faced, move 2), 5 × 5.
    Satin,
}

/// Geometric parameters of a pattern guess. For knits `spacing = [w, s]` (wale width and
/// course height, m) and `resolution` is vertices per stitch loop; for weaves `spacing =
/// [d_x, d_y]` (distance between neighbouring warp, resp. weft, yarns, m) and `resolution` is
/// vertices per yarn between consecutive crossings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatternParams {
    /// Yarn radius R (m).
    pub radius: f64,
    /// Loop / crossing spacing along x and y (m).
    pub spacing: [f64; 2],
    /// Vertices per stitch loop (knits, ≥ 8) or per crossing (weaves, ≥ 2).
    pub resolution: usize,
}

impl Pattern {
    /// Every pattern, knits first.
    pub const ALL: [Pattern; 8] = [
        Pattern::Stockinette,
        Pattern::Garter,
        Pattern::Rib1x1,
        Pattern::Rib2x2,
        Pattern::Seed,
        Pattern::PlainWeave,
        Pattern::BasketWeave,
        Pattern::Satin,
    ];

    /// A file-friendly name (`"stockinette"`, `"rib1x1"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Pattern::Stockinette => "stockinette",
            Pattern::Garter => "garter",
            Pattern::Rib1x1 => "rib1x1",
            Pattern::Rib2x2 => "rib2x2",
            Pattern::Seed => "seed",
            Pattern::PlainWeave => "plain",
            Pattern::BasketWeave => "basket",
            Pattern::Satin => "satin",
        }
    }

    /// The pattern with the given [`Pattern::name`], if any.
    pub fn from_name(name: &str) -> Option<Pattern> {
        Pattern::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether the pattern is knitted (otherwise woven).
    pub fn is_knit(self) -> bool {
        !matches!(
            self,
            Pattern::PlainWeave | Pattern::BasketWeave | Pattern::Satin
        )
    }

    /// Default parameters for yarn radius `radius` (m), at the scale of the real
    /// `stockinette.pyp` for R = 1 mm: knits `w = 7.5 R`, `s = 4 R`, 24 vertices per loop;
    /// weaves `d_x = d_y = 4 R`, 4 vertices per crossing.
    pub fn default_params(self, radius: f64) -> PatternParams {
        if self.is_knit() {
            let (w, s) = match self {
                Pattern::Stockinette => (7.5, 4.0),
                Pattern::Garter => (7.5, 6.0),
                Pattern::Seed => (8.5, 6.0),
                _ => (8.5, 4.0),
            };
            PatternParams {
                radius,
                spacing: [w * radius, s * radius],
                resolution: 24,
            }
        } else {
            PatternParams {
                radius,
                spacing: [4.0 * radius, 4.0 * radius],
                resolution: 4,
            }
        }
    }

    /// Stitch types (`+1` knit, `−1` purl) by course, for knits.
    fn stitches(self) -> Vec<Vec<i8>> {
        match self {
            Pattern::Stockinette => vec![vec![1]],
            Pattern::Garter => vec![vec![1], vec![-1]],
            Pattern::Rib1x1 => vec![vec![1, -1]],
            Pattern::Rib2x2 => vec![vec![1, 1, -1, -1]],
            Pattern::Seed => vec![vec![1, -1], vec![-1, 1]],
            _ => vec![],
        }
    }

    /// Interlacing matrix `M[warp][weft]` (`+1`: warp over), for weaves.
    fn interlacing(self) -> Vec<Vec<i8>> {
        match self {
            Pattern::PlainWeave => (0..2)
                .map(|i| {
                    (0..2)
                        .map(|k| if (i + k) % 2 == 0 { 1 } else { -1 })
                        .collect()
                })
                .collect(),
            Pattern::BasketWeave => (0..4)
                .map(|i| {
                    (0..4)
                        .map(|k| if (i / 2 + k / 2) % 2 == 0 { 1 } else { -1 })
                        .collect()
                })
                .collect(),
            Pattern::Satin => (0..5)
                .map(|i| {
                    (0..5)
                        .map(|k| if k == (2 * i) % 5 { -1 } else { 1 })
                        .collect()
                })
                .collect(),
            _ => vec![],
        }
    }

    /// The period and yarn polylines of the geometric guess (see the module documentation).
    pub fn yarns(self, params: &PatternParams) -> Result<([f64; 2], Vec<Yarn>), PatternError> {
        let PatternParams {
            radius,
            spacing,
            resolution,
        } = *params;
        for (name, v) in [
            ("radius", radius),
            ("spacing x", spacing[0]),
            ("spacing y", spacing[1]),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(PatternError::Invalid(format!(
                    "{name} must be positive and finite, found {v}"
                )));
            }
        }
        if self.is_knit() {
            if resolution < 8 {
                return Err(PatternError::Invalid(format!(
                    "knit resolution must be at least 8 vertices per loop, found {resolution}"
                )));
            }
            Ok(knit_yarns(&self.stitches(), radius, spacing, resolution))
        } else {
            if resolution < 2 {
                return Err(PatternError::Invalid(format!(
                    "weave resolution must be at least 2 vertices per crossing, found {resolution}"
                )));
            }
            Ok(weave_yarns(
                &self.interlacing(),
                radius,
                spacing,
                resolution,
            ))
        }
    }

    /// The geometric initial guess as a tile whose rest shape is its own geometry.
    pub fn generate(self, params: &PatternParams) -> Result<Tile, PatternError> {
        let (period, yarns) = self.yarns(params)?;
        tile_from_yarns(period, params.radius, &yarns)
    }
}

/// Knit yarns for stitch types `types[course][wale]`; see the module documentation.
fn knit_yarns(
    types: &[Vec<i8>],
    radius: f64,
    [w, s]: [f64; 2],
    per_loop: usize,
) -> ([f64; 2], Vec<Yarn>) {
    let rows = types.len();
    let cols = types[0].len();
    let period = [cols as f64 * w, rows as f64 * s];
    let h = 0.5 * s + 1.3 * radius;
    let z_amp = 1.25 * radius;
    let a = 0.25 * w;
    let t_b = 0.2;
    let mut yarns = Vec::new();
    for j in 0..rows {
        let y_c = (j as f64 + 0.5) * s - 0.5 * period[1];
        let mut points = Vec::with_capacity(cols * per_loop);
        for i in 0..cols {
            let x_c = (i as f64 + 0.5) * w - 0.5 * period[0];
            let sigma = f64::from(types[j][i]);
            let up = types[(j + 1) % rows][i];
            let left = types[j][(i + cols - 1) % cols];
            let right = types[j][(i + 1) % cols];
            for k in 0..per_loop {
                let t = TAU * k as f64 / per_loop as f64;
                let p = if up == types[j][i] {
                    -(2.0 * t).cos()
                } else {
                    -(3.0 * t).cos()
                };
                let mut g = 1.0;
                if left != types[j][i] && t < t_b {
                    g *= (0.5 * PI * t / t_b).sin();
                }
                if right != types[j][i] && TAU - t < t_b {
                    g *= (0.5 * PI * (TAU - t) / t_b).sin();
                }
                points.push(Vector3::new(
                    x_c + (t - PI) * w / TAU + a * (2.0 * t).sin(),
                    y_c - h * t.cos(),
                    z_amp * sigma * p * g,
                ));
            }
        }
        yarns.push(Yarn {
            points,
            shift: [1, 0],
        });
    }
    (period, yarns)
}

/// Smooth (C¹) interpolation of crossing values `m[k]` at `u = k + ½` along a periodic yarn
/// of `n` crossings: half-cosine between consecutive crossings.
fn crossing_profile(m: impl Fn(usize) -> f64, n: usize, u: f64) -> f64 {
    let v = u - 0.5;
    let k = v.floor();
    let f = v - k;
    let k = (k as i64).rem_euclid(n as i64) as usize;
    let (m0, m1) = (m(k), m((k + 1) % n));
    0.5 * (m0 + m1) + 0.5 * (m0 - m1) * (PI * f).cos()
}

/// Warp and weft yarns for the interlacing matrix `m[warp][weft]`.
fn weave_yarns(
    m: &[Vec<i8>],
    radius: f64,
    [dx, dy]: [f64; 2],
    per_crossing: usize,
) -> ([f64; 2], Vec<Yarn>) {
    let n = m.len();
    let period = [n as f64 * dx, n as f64 * dy];
    let amp = radius;
    let samples = n * per_crossing;
    let mut yarns = Vec::new();
    for i in 0..n {
        let x = (i as f64 + 0.5) * dx - 0.5 * period[0];
        let points = (0..samples)
            .map(|k| {
                let u = 0.5 + k as f64 / per_crossing as f64;
                let z = amp * crossing_profile(|c| f64::from(m[i][c]), n, u);
                Vector3::new(x, u * dy - 0.5 * period[1], z)
            })
            .collect();
        yarns.push(Yarn {
            points,
            shift: [0, 1],
        });
    }
    for k in 0..n {
        let y = (k as f64 + 0.5) * dy - 0.5 * period[1];
        let points = (0..samples)
            .map(|s| {
                let u = 0.5 + s as f64 / per_crossing as f64;
                let z = -amp * crossing_profile(|c| f64::from(m[c][k]), n, u);
                Vector3::new(u * dx - 0.5 * period[0], y, z)
            })
            .collect();
        yarns.push(Yarn {
            points,
            shift: [1, 0],
        });
    }
    (period, yarns)
}

/// Settings of [`relax`].
#[derive(Clone, Debug)]
pub struct RelaxSettings {
    /// Solve-and-reset rounds before the final solve (seed 002 §7.2). Default 2.
    pub rounds: usize,
    /// Bound on the relative change of each rest length from the guess's over all resets
    /// (seed 002 §7.2 uses 20 %). Default 0.2.
    pub max_rest_length_change: f64,
    /// The final solves are repeated until the largest vertex displacement of one is below
    /// this (m). Default 1e-10.
    pub settle_tolerance: f64,
    /// At most this many final solves. Default 6.
    pub max_settle_solves: usize,
    /// Settings of every equilibrium solve.
    pub equilibrium: EquilibriumSettings,
}

impl Default for RelaxSettings {
    fn default() -> Self {
        Self {
            rounds: 2,
            max_rest_length_change: 0.2,
            settle_tolerance: 1e-10,
            max_settle_solves: 6,
            equilibrium: EquilibriumSettings::default(),
        }
    }
}

/// What [`relax`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct RelaxReport {
    /// Newton iterations of each equilibrium solve (the rounds, then the final solves).
    pub iterations: Vec<usize>,
    /// Largest vertex displacement (m) of each solve.
    pub max_displacement: Vec<f64>,
    /// Energy density Ψ (J/m²) of the relaxed tile at zero strain.
    pub density: f64,
    /// Coarse stress `∂Ψ/∂F₂` (N/m) of the relaxed tile at zero strain.
    pub stress: Matrix2<f64>,
    /// Wall time of the whole relaxation (s).
    pub seconds: f64,
}

impl RelaxReport {
    /// Newton iterations summed over all solves.
    pub fn total_iterations(&self) -> usize {
        self.iterations.iter().sum()
    }
}

/// Relaxes `tile` at zero coarse strain; see the [module documentation](self) for the rounds
/// and what is reset. Returns the relaxed tile (its positions are an equilibrium of its rest
/// shape) and a report. Errors if a solve does not converge.
pub fn relax(
    tile: &Tile,
    model: &YarnModel,
    settings: &RelaxSettings,
) -> Result<(Tile, RelaxReport), PatternError> {
    let f = settings.max_rest_length_change;
    if !(f.is_finite() && (0.0..1.0).contains(&f)) {
        return Err(PatternError::Invalid(format!(
            "max_rest_length_change must be in [0, 1), found {f}"
        )));
    }
    if !(settings.settle_tolerance.is_finite() && settings.settle_tolerance > 0.0)
        || settings.max_settle_solves == 0
    {
        return Err(PatternError::Invalid(format!(
            "settle_tolerance must be positive and max_settle_solves at least 1, found {} and {}",
            settings.settle_tolerance, settings.max_settle_solves
        )));
    }
    let start = Instant::now();
    tile.validate()?;
    let l0 = tile.rest_lengths.clone();
    let mut current = tile.clone();
    let mut iterations = Vec::new();
    let mut max_displacement = Vec::new();
    let mut solve = |tile: &Tile| -> Result<(Tile, Equilibrium, f64), PatternError> {
        let eq = solve_equilibrium(tile, model, Coarse::identity(), None, &settings.equilibrium)?;
        let moved = (0..tile.n_vertices())
            .map(|v| Vector3::new(eq.dofs[3 * v], eq.dofs[3 * v + 1], eq.dofs[3 * v + 2]).norm())
            .fold(0.0, f64::max);
        iterations.push(eq.iterations);
        max_displacement.push(moved);
        Ok((rebase(tile, &eq.dofs)?, eq, moved))
    };
    for _ in 0..settings.rounds {
        current = solve(&current)?.0;
        reset_rest_shape(&mut current, Some((&l0, f)))?;
    }
    for _ in 0..settings.max_settle_solves {
        let (next, eq, moved) = solve(&current)?;
        current = next;
        if moved < settings.settle_tolerance {
            return Ok((
                current,
                RelaxReport {
                    iterations,
                    max_displacement,
                    density: eq.density,
                    stress: eq.stress,
                    seconds: start.elapsed().as_secs_f64(),
                },
            ));
        }
    }
    Err(PatternError::Invalid(format!(
        "the relaxed tile did not settle: the last of {} final solves moved it by {:.3e} m \
         (tolerance {:.3e} m)",
        settings.max_settle_solves,
        max_displacement.last().copied().unwrap_or(f64::NAN),
        settings.settle_tolerance
    )))
}

/// The closest pair of non-neighbouring yarn edges of a tile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    /// Centre-line distance (m).
    pub distance: f64,
    /// First edge.
    pub a: usize,
    /// Second edge.
    pub b: usize,
    /// Period shift of edge `b`'s copy.
    pub image: [i32; 2],
}

/// The smallest centre-line distance between two edges of `tile` at rest, over the 3 × 3
/// periodic images, excluding pairs closer than `model.min_arc_separation` along one yarn
/// (neighbours). `None` if no such pair is closer than twice the contact cutoff.
pub fn min_clearance(tile: &Tile, model: &YarnModel) -> Result<Option<Clearance>, PatternError> {
    let x = initial_dofs(tile)?;
    let pairs = PeriodicTile::find_pairs(tile, model, &Coarse::identity(), &x, 2.0)?;
    let mut best: Option<Clearance> = None;
    for p in pairs {
        let (ea, eb) = (tile.edges[p.a], tile.edges[p.b]);
        let a0 = tile.positions[ea.v0];
        let a1 = tile.edge_end_shifted(p.a);
        let b0 = tile.positions[eb.v0] + tile.period_offset(p.image);
        let b1 = tile.edge_end_shifted(p.b) + tile.period_offset(p.image);
        let d = closest_points(&a0, &a1, &b0, &b1).2;
        if best.is_none_or(|c| d < c.distance) {
            best = Some(Clearance {
                distance: d,
                a: p.a,
                b: p.b,
                image: p.image,
            });
        }
    }
    Ok(best)
}
