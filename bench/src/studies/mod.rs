//! Computations behind the figures, kept apart from plotting so tests can call them directly.

pub mod periodic;
/// Tube rendering of persistent-contact swatches (the experiments: `sim_persistent::experiment`).
pub mod persistent;
