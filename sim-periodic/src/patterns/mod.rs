//! Procedural periodic yarn patterns: a builder from periodic yarn polylines to a [`Tile`],
//! geometric initial guesses for eight knit and woven patterns, and their relaxation to a
//! stable rest state (issue 4, "Tiles and patterns"; seed 002 §7.1–7.2, seed 004 §3).
//!
//! # Building a tile from polylines ([`tile_from_yarns`])
//!
//! A [`Yarn`] is a closed periodic polyline: its points in *unwrapped* coordinates, continuing
//! after the last point to the first point shifted by `shift` periods. The builder
//!
//! - wraps every point into the centred cell `[−pₓ/2, pₓ/2) × [−p_y/2, p_y/2)` (on a sheared
//!   lattice, [`Tile::skew`](yarn_pattern::tile::Tile::skew), the course band first, then the
//!   cell along it) and gives each edge the period shift between the cells of its two
//!   (unwrapped) end points, so edges that cross the tile boundary carry non-zero shifts;
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
//! Tiles (wales × courses, stitch types by row): stockinette 1×1 `[K]`; garter 1×2 `[K], [P]`; 1×1
//! rib 2×1 `[K P]`; 2×2 rib 4×1 `[K K P P]`; seed 2×1 `[K P]` on a sheared lattice. The periods are
//! `a₁ = (cols · w, 0)` and `a₂ = (m · w, rows · s)`, where the chart repeats `m` loops further
//! along each `rows` courses up: `m = 0` except for seed, whose next course is its first moved by
//! one loop (`[P K]`), so its primitive tile holds two loops (`skew = m / cols = ½`) instead of the
//! four of its rectangular 2 × 2 repeat `[K P], [P K]` ([`Pattern::generate_rectangular`]). The
//! primitive tile is the rectangular one with the pattern's translation symmetry imposed: its
//! equilibria, copied into the rectangular repeat, have the same energy density and stress there
//! and leave only the copied no-sliding constraint forces (`tests/patterns.rs`, under stretch,
//! shear and compression: agreement to 1e-12 relative), and a Newton iteration costs about half
//! (the `yarn_objective` benchmark: 1.47 against 2.99 ms on the acrylic seed, 1.43 against 2.69 ms
//! on the babyredo seed). Relaxed and solved on their own (measured once with throw-away code), the two tiles differ by where the no-sliding constraint pins each yarn (the start
//! of its first edge across the tile boundary, at a different place of the loop in each course of
//! the rectangular tile; sliding is not an exact symmetry of a discrete yarn): at 16 vertices per
//! loop, Ψ by 0.2 % at rest and 5.6 % at 20 % stretch along x. The loop above the last course is
//! found in course 0 of the repeat above, moved by `m`.
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

mod builder;
mod procedural;
mod relaxation;

pub use builder::{Yarn, rebase, rebase_stretched, reset_rest_shape, tile_from_yarns};
pub use procedural::{Lattice, Pattern, PatternParams};
pub use relaxation::{Clearance, RelaxReport, RelaxSettings, min_clearance, relax};

use crate::periodic::PeriodicError;
use yarn_pattern::tile::TileError;
#[cfg(doc)]
use {crate::periodic::solve_equilibrium, yarn_pattern::tile::Tile};

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
