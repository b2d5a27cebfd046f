//! Computations behind the figures, kept apart from plotting so tests can call them directly.

/// Out-of-plane displacement and tube rendering of deformer output (`deform-*` figures).
pub mod deform;
pub mod deform_databases;
pub mod periodic;
/// Tube rendering of persistent-contact swatches (the experiments: `sim_persistent::experiment`).
pub mod persistent;
