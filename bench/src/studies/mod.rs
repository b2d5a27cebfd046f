//! Computations behind the figures, kept apart from plotting so tests can call them directly.

pub mod cantilever;
pub mod periodic;
pub mod persistent;
