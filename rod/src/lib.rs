//! # rod — shared rod mathematics for yarn-level cloth
//!
//! Geometry and per-stencil energies of yarn segments, shared by the three methods of the
//! workbench. Every energy term implements [`Stencil`]: energy, gradient and Hessian on a
//! fixed-size DOF vector, and has an asserting finite-difference test through [`fd`].
//! No I/O, no solvers, no allocation in the stencil evaluations.
//!
//! | module | contents | source |
//! |---|---|---|
//! | [`geometry`] | edges, tangents, turning angle, curvature binormal, parallel transport, frames, reference twist | Bergou et al. 2008/2010 |
//! | [`stretch`] | linear and two-phase stretch laws; fixed-length and sliding-coordinate segments | seed 002 Eq. 5; seed 000 §3.2 |
//! | [`bending`] | angle bending with jamming; curvature-binormal bending | seed 000 Eq. 1, §4.1; seed 002 Eq. 6 (κ̄ = 0) |
//! | [`material_bending`] | bending with rest curvature in the material frame, with twist DOFs | seed 002 Eq. 6; Bergou 2010 |
//! | [`twist`] | twist with reference twist of transported frames | Bergou 2008/2010 |
//! | [`contact`] | segment closest points; two-phase barrier contact with Simpson quadrature | seed 002 Eq. 7 |
//! | [`hyperdual`] | exact second derivatives by forward differentiation (the reference the jets are checked against) | Fike & Alonso 2011 |
//! | [`jet`] | value, gradient and Hessian in one pass (second-order forward mode); with closed-form pieces (`frame_jets`) for the material-frame terms | — |
//! | [`spd`] | projection of small symmetric Hessians onto the PSD cone | — |
//! | [`validation`] | circle and helix references with closed-form bending energy | — |
//! | [`fd`] | the finite-difference derivative-check harness used by every crate | — |
//! | [`yarn`] | the one yarn description both simulators build their models from, and what carries over between them | — |
//!
//! Units: SI throughout (m, N, J, rad). Sign conventions: gradients are `∂W/∂q` (forces are
//! their negatives).

pub mod bending;
pub mod contact;
pub mod fd;
pub(crate) mod frame_jets;
pub mod geometry;
pub mod hyperdual;
pub mod jet;
pub mod material_bending;
pub mod spd;
pub mod stencil;
pub mod stretch;
pub mod twist;
pub mod validation;
pub mod yarn;

pub use stencil::{Evaluation, Stencil};
