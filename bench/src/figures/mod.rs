//! The figure generators, one module per figure.
//!
//! Each module exposes `pub fn spec() -> FigureSpec`; list it in
//! [`crate::figure::all_figures`].

pub mod closed_loop;
pub mod cross_method;
pub mod deform_bending_models;
pub mod deform_compression_clamping;
pub mod deform_naive_vs_mechanics;
pub mod deform_sampling_density;
pub mod deform_throughput;
pub mod deform_time_vs_error;
pub mod periodic_bending;
pub mod periodic_curves;
pub mod periodic_databases;
pub mod periodic_tiles;
pub mod periodic_time_vs_error;
pub mod periodic_vs_reference;
pub mod persistent_curl;
pub mod persistent_garment;
pub mod persistent_knit_fidelity;
pub mod persistent_patterns_on_sphere;
pub mod persistent_plasticity;
pub mod persistent_pullout;
pub mod persistent_rest_shape;
pub mod persistent_rib_stretch;
pub mod persistent_stitches;
pub mod persistent_time_vs_error;
pub mod rod_cantilever;
pub mod rod_convergence;
pub mod shell_bending_fit;
pub mod shell_fit;
pub mod shell_fit_all;
pub mod shell_nh_vs_stvk;
pub mod shell_time_vs_error;
pub mod yarn_fit;
pub mod yarn_fit_ablations;
pub mod yarn_fit_seeds;
