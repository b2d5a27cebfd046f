//! # shell-fem — anisotropic thin shell fitted to fabric tests
//!
//! Implements §4.3 and §5 of Sperl, Sánchez-Banderas, Li, Wojtan and Otaduy,
//! *Estimation of Yarn-Level Simulation Models for Production Fabrics* (ACM TOG 41(4), 2022),
//! "seed 002" in this workspace:
//!
//! - the in-plane energy density Ψ of Eq. 1 (anisotropic StVK on the Green strain plus the
//!   area terms `k_n1 (J − 1)² + k_n2 log² J`) as a pointwise material law;
//! - triangle membrane elements and edge-hinge bending (`κ = 3θ/H`, Eq. 4);
//! - virtual stretch and pear-loop bending tests on a 10 cm × 6 cm swatch;
//! - the fit of Eq. 2 to real measurements and the uniform target curves of Eq. 3 consumed by
//!   `sim-periodic`'s yarn-parameter fit.
//!
//! Status: not yet implemented (tracked by the `shell-fem` issue). The crate exists so that the
//! workspace layout matches `ARCHITECTURE.md` from the first day.
