//! # sim-persistent — yarn-level cloth with sliding persistent contacts
//!
//! Implements Cirio, Lopez-Moreno and Otaduy, *Yarn-Level Cloth Simulation with Sliding
//! Persistent Contacts* (IEEE TVCG 2017), "seed 000": yarns are segments between persistent
//! contact nodes `q = (x, u₁ … uₙ)` with one sliding (arc-length) coordinate per yarn, so no
//! contact detection is needed. Forces (§4): yarn stretch, bending with jamming (Eq. 1, from the
//! `rod` crate), stitch wrapping (Eq. 2, Appendix Eqs. 7–16), compression estimation at stacked
//! contacts (Eqs. 3–4), sliding friction (Eq. 5), stitch-contact length (Eq. 6); implicit Euler
//! integration through the `solver` crate.
//!
//! Status: not yet implemented (tracked by the `sim-persistent` issue).
