//! USD ASCII (`.usda`) yarn curves: one `BasisCurves` prim that Blender, Houdini and
//! Omniverse open directly.
//!
//! Written exactly as:
//! ```text
//! #usda 1.0
//! (
//!     defaultPrim = "Yarns"
//!     doc = "<comment>"
//!     metersPerUnit = 1
//!     upAxis = "Y"
//! )
//!
//! def BasisCurves "Yarns"
//! {
//!     uniform token type = "linear"
//!     uniform token wrap = "nonperiodic"
//!     int[] curveVertexCounts = [n₀, n₁, …]
//!     point3f[] points = [(x, y, z), …]
//!     float[] widths = [2R] (
//!         interpolation = "constant"
//!     )
//! }
//!
//! def Mesh "Mesh0"                      (one per mesh of UsdOptions::meshes, if any)
//! {
//!     int[] faceVertexCounts = [3, 3, …]
//!     int[] faceVertexIndices = [i, j, k, …]
//!     point3f[] points = [(x, y, z), …]
//!     color3f[] primvars:displayColor = [(r, g, b)] (
//!         interpolation = "constant"
//!     )
//! }
//! ```
//! Points are in metres (`metersPerUnit = 1`). Every curve with at least two vertices is
//! written (linear curves need two); a closed curve with more than two vertices repeats its
//! first point, so one prim holds open and closed yarns alike. `widths` is the yarn
//! diameter. The doc string escapes `\` and `"`.

use std::io::Write;

use crate::error::{OutputError, Result};
use crate::polylines::{Polylines, UpAxis};
use crate::render::MeshLayer;

/// What the caller chooses for a `.usda` file.
#[derive(Clone, Copy, Debug)]
pub struct UsdOptions<'a> {
    /// Yarn radius R (m): the curves' constant width is `2R`.
    pub radius: f64,
    /// Up axis of the stage.
    pub up: UpAxis,
    /// The layer's doc string.
    pub comment: &'a str,
    /// Triangle meshes written beside the curves (obstacles, a body); usually none.
    pub meshes: &'a [MeshLayer<'a>],
}

/// Writes `lines` (and the meshes of `options`) as a `.usda` layer; fails when the radius is
/// not finite and positive or a mesh triangle indexes beyond its vertices.
pub fn write<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    options: &UsdOptions<'_>,
) -> Result<std::io::Result<()>> {
    if !(options.radius.is_finite() && options.radius > 0.0) {
        return Err(OutputError::Option {
            name: "radius",
            message: format!("expected a finite radius > 0 m, found {}", options.radius),
        });
    }
    for m in options.meshes {
        m.validate()?;
    }
    Ok(write_unchecked(w, lines, options))
}

fn write_unchecked<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    options: &UsdOptions<'_>,
) -> std::io::Result<()> {
    let doc = options.comment.replace('\\', "\\\\").replace('"', "\\\"");
    let up = match options.up {
        UpAxis::Y => "Y",
        UpAxis::Z => "Z",
    };
    writeln!(
        w,
        "#usda 1.0\n(\n    defaultPrim = \"Yarns\"\n    doc = \"{doc}\""
    )?;
    writeln!(w, "    metersPerUnit = 1\n    upAxis = \"{up}\"\n)\n")?;
    writeln!(w, "def BasisCurves \"Yarns\"\n{{")?;
    writeln!(w, "    uniform token type = \"linear\"")?;
    writeln!(w, "    uniform token wrap = \"nonperiodic\"")?;
    let paths: Vec<Vec<usize>> = lines.edge_paths().map(|(_, p)| p).collect();
    let counts: Vec<String> = paths.iter().map(|p| p.len().to_string()).collect();
    writeln!(w, "    int[] curveVertexCounts = [{}]", counts.join(", "))?;
    write!(w, "    point3f[] points = [")?;
    for (i, k) in paths.iter().flatten().enumerate() {
        let [x, y, z] = lines.point(*k).map(|c| c as f32);
        let sep = if i == 0 { "" } else { ", " };
        write!(w, "{sep}({x}, {y}, {z})")?;
    }
    writeln!(w, "]")?;
    let width = (2.0 * options.radius) as f32;
    writeln!(
        w,
        "    float[] widths = [{width}] (\n        interpolation = \"constant\"\n    )"
    )?;
    writeln!(w, "}}")?;
    for (m, mesh) in options.meshes.iter().enumerate() {
        writeln!(w, "\ndef Mesh \"Mesh{m}\"\n{{")?;
        let counts = vec!["3"; mesh.triangles.len()].join(", ");
        writeln!(w, "    int[] faceVertexCounts = [{counts}]")?;
        let indices: Vec<String> = mesh
            .triangles
            .iter()
            .flatten()
            .map(u32::to_string)
            .collect();
        writeln!(w, "    int[] faceVertexIndices = [{}]", indices.join(", "))?;
        write!(w, "    point3f[] points = [")?;
        for (i, p) in mesh.positions.iter().enumerate() {
            let [x, y, z] = p.map(|c| c as f32);
            let sep = if i == 0 { "" } else { ", " };
            write!(w, "{sep}({x}, {y}, {z})")?;
        }
        writeln!(w, "]")?;
        let [r, g, b] = mesh.colour.map(|c| f32::from(c) / 255.0);
        writeln!(
            w,
            "    color3f[] primvars:displayColor = [({r}, {g}, {b})] (\n        interpolation = \"constant\"\n    )\n}}"
        )?;
    }
    Ok(())
}

/// The `.usda` text of `lines` (see [`write`]).
pub fn to_string<T: Copy + Into<f64>>(
    lines: &Polylines<'_, T>,
    options: &UsdOptions<'_>,
) -> Result<String> {
    let mut out = Vec::new();
    write(&mut out, lines, options)?.expect("writing to a Vec cannot fail");
    Ok(String::from_utf8(out).expect("USD text is UTF-8"))
}
