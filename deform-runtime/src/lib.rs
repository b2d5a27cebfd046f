//! # deform-runtime — mechanics-aware yarn deformation on animated meshes
//!
//! Implements §4 and Appendix C of Sperl, Narain and Wojtan, *Mechanics-Aware Deformation of
//! Yarn Pattern Geometry* (ACM TOG 40(4), 2021), "seed 004": embed a periodic yarn pattern in
//! the UV space of a triangle mesh, and per frame compute the fundamental forms I and II,
//! interpolate them with Phong deformation, look up the precomputed displacement database
//! ΔQ(sx, sa, sy) produced by `sim-periodic`, and map yarn vertices to world space — on the CPU
//! (rayon, f32 structure-of-arrays) and on the GPU (wgpu compute shaders).
//!
//! Status: not yet implemented (tracked by the `deform-runtime` issue).
