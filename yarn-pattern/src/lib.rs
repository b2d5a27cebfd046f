//! # yarn-pattern — periodic yarn pattern data
//!
//! The data that the periodic solver (`sim-periodic`) produces and the deformer
//! (`deform-runtime`) consumes, without any solver: a leaf crate on nalgebra.
//!
//! | module | contents |
//! |---|---|
//! | [`agreement`] | how two displacement databases of one tile agree (per-sample correlation, RMS), re-basing a table onto another tile |
//! | [`direction`] | the fabric test directions weft / bias / warp (optional serde) |
//! | [`tile`] | the periodic tile (vertices, periodic edges, rest shape, reference frames), its topology |
//! | [`pyp`] | `.pyp` read/write with located errors (HYLC / MADYPG convention) |
//! | [`madypg`] | displacement database ΔQ(sx, sa, sy) layout: `axes.txt` + `data.npy` (seed 004 §3) |
//! | [`strain`] | in-plane strains (sx, sa, sy) of seed 004 Eq. 4, `I` and `F₂ = √I` |

pub mod agreement;
pub mod direction;
pub mod madypg;
pub mod pyp;
pub mod strain;
pub mod tile;
