//! Measures and renderings of a deformer's yarn output shared by the `deform-*` figures.

use deform_runtime::Deformer;
use yarn_output::render::{RenderOptions, Rendering, render_tubes};

/// `d`'s output rendered as tubes (radius `options.radius`).
pub fn tubes(d: &Deformer<f64>, options: &RenderOptions) -> anyhow::Result<Rendering> {
    let (e, o) = (d.embedding(), d.output());
    let lines = e.polylines(o);
    Ok(render_tubes(&lines, options)?)
}

/// RMS out-of-plane yarn displacement `z − X₃` of `d`'s output over all yarn vertices (m).
pub fn rms_out_of_plane(d: &Deformer<f64>) -> f64 {
    let e = d.embedding();
    let z = &d.output().z;
    let n = e.len().max(1) as f64;
    (e.material
        .iter()
        .zip(z)
        .map(|(m, z)| (z - m[2]).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
}
