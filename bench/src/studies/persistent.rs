//! Rendering of persistent-contact swatches for the `curl` figure. The swatch experiments
//! themselves (settle, side clamps, rib stretch, load cycles, drops onto a sphere) live in
//! [`sim_persistent::experiment`].

use sim_persistent::integrator::Simulator;

/// `sim`'s yarns rendered as tubes of the yarn radius: the smooth rendering curves of
/// `sim_persistent::output` (each yarn offset by ±R from its contact nodes along the node
/// normal, Catmull-Rom between), seen along `direction` with `up` on screen, with the
/// simulator's mesh obstacles (a body) drawn in the same image.
pub fn render(
    sim: &Simulator,
    radius: f64,
    size: (u32, u32),
    direction: [f64; 3],
    up: [f64; 3],
) -> anyhow::Result<yarn_output::render::Rendering> {
    let framing = yarn_output::render::Framing::Auto { margin: 0.05 };
    render_framed(sim, radius, size, direction, up, framing)
}

/// [`render`] with the view `framing` (a fixed one draws several swatches at one scale).
pub fn render_framed(
    sim: &Simulator,
    radius: f64,
    size: (u32, u32),
    direction: [f64; 3],
    up: [f64; 3],
    framing: yarn_output::render::Framing,
) -> anyhow::Result<yarn_output::render::Rendering> {
    use sim_persistent::output::{CurveOptions, ObstacleMeshes, RenderCurves};
    use yarn_output::render::{Camera, RenderOptions};
    let curves = RenderCurves::from_simulator(
        sim,
        &CurveOptions {
            radius,
            samples_per_segment: 4,
        },
    )?;
    let options = RenderOptions {
        camera: Camera { direction, up },
        framing,
        supersample: 2,
        ..RenderOptions::new(size.0, size.1, radius)
    };
    let meshes = ObstacleMeshes::of(sim);
    Ok(curves.render_with(
        &options,
        &meshes.layers(),
        std::path::Path::new("figure image"),
    )?)
}
