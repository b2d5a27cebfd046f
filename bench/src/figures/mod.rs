//! The figure generators, one module per figure.
//!
//! Each module exposes `pub fn spec() -> FigureSpec`; list it in
//! [`crate::figure::all_figures`].

pub mod rod_cantilever;
pub mod rod_convergence;
