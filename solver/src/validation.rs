//! Validation problems with known answers, shared by the tests and the figures.
//!
//! | module | contents |
//! |---|---|
//! | [`cantilever`] | a clamped discrete elastic rod under a tip load (a [`crate::Terms`] model solved by [`crate::NewtonSolver`]) against Euler–Bernoulli theory and the elastica |

pub mod cantilever;
