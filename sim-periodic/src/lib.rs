//! # sim-periodic — periodic yarn tiles under a prescribed coarse deformation
//!
//! The solver shared by two papers:
//!
//! - Sperl et al. 2022, *Estimation of Yarn-Level Simulation Models for Production Fabrics*
//!   (seed 002), §6 (yarn model: two-phase stretch Eq. 5, bending Eq. 6, two-phase barrier
//!   contact Eq. 7) and §7.1 (periodic simulation, homogenized stress Eq. 10);
//! - Sperl, Narain and Wojtan 2021, *Mechanics-Aware Deformation of Yarn Pattern Geometry*
//!   (seed 004), §3 (displacement database ΔQ(sx, sa, sy), no-sliding constraint Eq. 3,
//!   material-space pullback Eq. 18, bending from I and II in Appendix A).
//!
//! The yarn energies come from the `rod` crate; Newton and sparse assembly from `solver`; the
//! tile, its `.pyp` file format and the database layout from the leaf crate `yarn-pattern`
//! (`yarn_pattern::{tile, pyp, madypg}`).
//!
//! | module | contents |
//! |---|---|
//! | [`coarse`] | coarse deformation: in-plane from seed 004 strains or uniaxial (s, c), optional single curvature |
//! | [`config`] | TOML configuration of the `sim-periodic` command line |
//! | [`curves`] | uniaxial curves {s, c, σ_s} along weft / bias / warp with a root-find for zero orthogonal stress; bending curves {κ, Ψ, dΨ/dκ} |
//! | [`database`] | displacement database generation: relaxed reference, continuation over the strain grid, pullback (Eq. 18), resumable checkpoints |
//! | [`pullback`] | material-space pullback of an equilibrium, seed 004 Eq. 18, for flat and bent (rolled) tiles |
//! | [`bending_database`] | bending-direction databases per curvature (seed 004 Appendix C) from an in-plane database, restriction to nested grids |
//! | [`periodic`] | the tile energy under a coarse deformation, constraints, equilibrium, stress |
//! | [`fit`] | yarn-parameter estimation (seed 002 §7): rest-shape estimation, the objective of Eq. 11, particle swarm then COBYLA, resumable journal |
//! | [`reference`](mod@reference) | our database of a published tile against the published table; per-term forces on the file geometry |
//! | [`campaign`] | fit campaigns: every fit config × every seed as shardable tasks, merged into one table |
//! | [`shard`] | deterministic shards of long runs for job arrays, and the completion records their merge checks |
//! | [`patterns`] | procedural pattern library: tile builder from yarn polylines, knit and weave guesses, relaxation |
//!
//! Bending is single curvature along either tile axis (the tile rolled onto a cylinder,
//! [`coarse::Curvature`]); displacement databases are in-plane (sx, sa, sy), with bending
//! databases per curvature beside them ([`bending_database`]).

pub mod bending_database;
pub mod campaign;
pub mod coarse;
pub mod config;
pub mod curves;
pub mod database;
pub mod fit;
pub mod patterns;
pub mod periodic;
pub mod pullback;
pub mod reference;
pub mod shard;
