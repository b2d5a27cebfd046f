//! Cross-method validation and reference-curve regression tests live in `tests/tests/`.
