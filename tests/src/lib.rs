//! Cross-method validation and reference-curve regression tests live in `tests/tests/`.

/// The README's snippets, run as doctests so that they keep working.
#[doc = include_str!("../../README.md")]
pub mod readme {}
