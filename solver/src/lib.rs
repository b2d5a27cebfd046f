//! # solver — shared numerics for the yarn-level cloth workbench
//!
//! Minimization of energies that are sums of small per-stencil terms (the `rod` crate's
//! stretch, bending and contact stencils, shell elements, …) over a global DOF vector:
//!
//! | module | contents |
//! |---|---|
//! | [`assembly`] | the [`Problem`] trait; [`Assembler`]: fixed-pattern, parallel, deterministic sparse assembly of energy, gradient and (optionally SPD-projected) Hessian |
//! | [`newton`] | [`minimize`] / [`NewtonSolver`]: Newton with backtracking line search, Dirichlet DOFs, adaptive diagonal regularization, sparse Cholesky with reused symbolic analysis or preconditioned CG ([`LinearSolver`]); optional fixed-iteration mode (linearized steps) |
//! | [`pcg`] | [`Pcg`]: preconditioned conjugate gradients (Jacobi or IC(0)) on the assembled lower-triangle Hessian, deterministic parallel matrix–vector products; [`PcgTraffic`]: the least bytes an IC-CG solve streams (its memory roofline) |
//! | [`terms`] | [`Terms`]: the one term container (a [`Problem`]): heterogeneous terms ([`LocalEnergy`], [`RodTerm`] for any `rod::Stencil<N>`) with DOF indices and optional affine offsets |
//! | [`constrained`] | [`minimize_constrained`] / [`ConstrainedNewtonSolver`]: Newton under linear equality constraints `Cx = d` via the augmented KKT system (sparse Cholesky of `H + μI + ρĈᵀĈ`, Schur complement on the constraints) |
//! | [`roots`] | [`find_root`]: safeguarded 1-D root finding in a sign-change bracket (Newton with a derivative, bisection without); [`secant`]: from one start point without a bracket (secant, Illinois regula falsi once bracketed, clipped steps, retries of failed evaluations) |
//! | [`dense_newton`] | [`newton_dense`]: Newton for a few equations in as many unknowns (analytic or forward-difference Jacobian, damped steps, loud failure) |
//! | [`lm`] | [`bounded_lm`]: bounded Levenberg–Marquardt for small least-squares fits (scaled parameters, active set, extra constraints) |
//! | [`qp`] | [`qp::nonnegative_least_squares`]: small convex QPs through `clarabel` (interior point) with an exact active-set polish |
//! | [`checksum`] | [`checksum::fnv1a`]: the stable 64-bit checksum of fingerprints and checkpoint files |
//! | [`continuation`] | [`march`] (load stepping with step halving and growth) and [`bisect`] (recursive halving of a segment) |
//! | [`validation`] | problems with known answers: [`validation::cantilever`] (a clamped rod under a tip load vs beam theory and the elastica) |
//!
//! Design rules:
//!
//! - **Fixed pattern.** The sparsity pattern, the scatter map from every local Hessian entry
//!   into the CSC value array and the symbolic factorization are computed once per solver and
//!   reused for every iteration (and every later solve with the same stencils).
//! - **Determinism.** Stencils are evaluated in parallel into private parts of flat buffers,
//!   and every output sums its local pieces in stencil order (a gather, parallel over the
//!   outputs); the sparse factorizations (and the IC(0) preconditioner)
//!   run sequentially, and the conjugate gradients sum in fixed chunks. Results are
//!   bit-identical for any rayon thread count.
//! - **Loud failure.** Bad input is an `Err`, never a panic; a minimization that does not
//!   converge returns an `Err` carrying its [`NewtonReport`].
//! - **Units.** SI throughout; gradients are `∂E/∂x` (forces are their negatives). Tolerances
//!   are documented with their units on [`NewtonSettings`].
//!
//! Finite-difference derivative checks live in `rod::fd`, not here.
//!
//! ## Example
//!
//! Four linear springs on a line with both ends clamped; the minimizer spaces the points evenly.
//!
//! ```
//! use solver::{NewtonSettings, Problem, minimize};
//!
//! /// Springs of stiffness `k` (N/m) and rest length `l0` (m) between points on a line.
//! struct Chain { k: f64, l0: f64, edges: Vec<[usize; 2]> }
//!
//! impl Problem for Chain {
//!     fn n_dofs(&self) -> usize { self.edges.len() + 1 }
//!     fn n_stencils(&self) -> usize { self.edges.len() }
//!     fn stencil_dofs(&self, k: usize) -> &[usize] { &self.edges[k] }
//!     fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
//!         let [a, b] = self.edges[k];
//!         let s = x[b] - x[a] - self.l0; // extension (m)
//!         grad[0] = -self.k * s;
//!         grad[1] = self.k * s;
//!         if let Some(h) = hess {
//!             h.copy_from_slice(&[self.k, -self.k, -self.k, self.k]); // column-major 2 × 2
//!         }
//!         0.5 * self.k * s * s
//!     }
//! }
//!
//! let chain = Chain { k: 100.0, l0: 0.1, edges: (0..4).map(|i| [i, i + 1]).collect() };
//! let mut x = vec![0.0, 0.0, 0.0, 0.0, 1.0]; // ends clamped at 0 m and 1 m
//! let fixed = [true, false, false, false, true];
//! let report = minimize(&chain, &mut x, &fixed, &NewtonSettings::default())?;
//! assert!(report.converged());
//! assert_eq!(report.iterations, 1); // quadratic energy: one Newton step
//! for (i, xi) in x.iter().enumerate() {
//!     assert!((xi - 0.25 * i as f64).abs() < 1e-12);
//! }
//! # Ok::<(), solver::SolveError>(())
//! ```

pub mod assembly;
pub mod checksum;
pub mod constrained;
pub mod continuation;
pub mod dense_newton;
mod error;
mod linalg;
pub mod lm;
pub mod newton;
mod pattern;
pub mod pcg;
pub mod qp;
pub mod roots;
pub mod terms;
pub mod validation;

pub use assembly::{
    Assembled, Assembler, Problem, eval_rod_stencil, eval_rod_stencil_energy_offset,
    eval_rod_stencil_offset,
};
pub use constrained::{ConstrainedNewtonSolver, LinearConstraints, minimize_constrained};
pub use continuation::{
    Attempt, ContinuationError, ContinuationReport, MarchError, MarchSettings, StepError, bisect,
    march,
};
pub use dense_newton::{
    DenseEval, DenseNewtonError, DenseNewtonReport, DenseNewtonSettings, DenseRoot, Probe,
    newton_dense,
};
pub use error::SolveError;
pub use lm::{
    LmBounds, LmCommit, LmError, LmEval, LmOutcome, LmSettings, LmTermination, bounded_lm,
};
pub use newton::{
    LinearSolver, NewtonReport, NewtonSettings, NewtonSolver, NewtonTimings, Termination, minimize,
};
pub use pcg::{Pcg, PcgFailure, PcgReport, PcgSettings, PcgTraffic, Preconditioner};
pub use roots::{
    Bracket, Root, RootError, RootEval, RootReport, RootSettings, SecantError, SecantEval,
    SecantReport, SecantRoot, SecantSettings, find_root, secant,
};
pub use terms::{CloneTerm, Concat, LocalEnergy, LocalVector, MAX_TERM_DOFS, RodTerm, Terms};
