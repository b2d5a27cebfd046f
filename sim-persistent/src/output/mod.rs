//! Rendering curves of the yarns and frame output: OBJ, PLY, `.bcc` and PNG (seed 000 §3.2).
//!
//! The simulated yarns are straight segments between contact nodes, and both yarns of a
//! contact pass through the same node position. For rendering, seed 000 §3.2 draws "smooth
//! splines through the nodes", with each yarn offset from the node along the normal of a plane
//! fitted to the node and its neighbours. [`RenderCurves`] does this in three steps.
//!
//! **1. Node normals** ([`node_normals`]). For node `n`, the points are `x_n` and the positions
//! of its neighbours along every yarn through it (the previous and the next pass of each
//! yarn, each neighbour once). The normal is the eigenvector of the smallest eigenvalue of the
//! points' covariance matrix about their mean (the direction of the smallest singular value
//! of the centred points, i.e. the total-least-squares plane). The neighbourhood is
//! *degenerate* when it has fewer than three finite points, or the covariance eigenvalues
//! `λ₀ ≤ λ₁ ≤ λ₂` have `λ₁ ≤ 10⁻⁶ λ₂` ([`COLLINEAR_RATIO`]: collinear or coincident points,
//! where the plane is undetermined), or `x_n` is not finite.
//!
//! **Orientation.** The *fabric normal* `g` is the same fit over all finite node positions
//! (for a degenerate fabric: the first of z, y, x least aligned with the principal direction,
//! made orthogonal to it; `+z` if all nodes coincide), signed so that its first clearly
//! non-zero component among (z, y, x) is positive: for a flat swatch in the layout (the
//! xy plane, front view from `+z`), `g = +z`. Fitted normals are then oriented by breadth-first
//! propagation along the yarns: a seed (the unvisited fitted node whose normal is most aligned
//! with `g`) takes the sign of `g`, and each newly reached node takes the sign that agrees
//! with the node it was reached from (a degenerate node passes its predecessor's reference on).
//! This stays consistent on strongly curled swatches, where a single global reference would
//! flip normals around a roll. **Fallback:** a degenerate node takes the normalized mean of
//! its neighbours' oriented fitted normals ([`NormalSource::Neighbours`]), or `g` (signed like
//! its reference) when it has none ([`NormalSource::Fabric`]).
//!
//! **2. Offsets** ([`offset_sides`]). Yarn pass `s` of node `n` is moved to
//! `x_n + k R n̂_n`, `R` the yarn radius, with the side factor `k`:
//!
//! - one-yarn node (fabric edges): `k = 0` (not offset);
//! - weave crossing (§3.2.1): the yarn on top ([`crate::topology::Crossing::warp_over`]) has
//!   `k = +1`, the other `k = −1` (the normal points to the fabric front, `+z` in the layout);
//! - knit stitch contact (§3.2.2), both of its nodes: the stack front to back
//!   ([`crate::topology::Topology::knit_stacks`]) gets `k = m − 1, m − 3, …, −(m − 1)`; for a
//!   two-yarn stitch the upper loop's leg has `k = +σ` and the lower loop's head `k = −σ`,
//!   `σ = +1` for a knit and `−1` for a purl (front view): the legs come from the back through
//!   the loop below and lie in front of its head, so on the front of a knit the heads hide
//!   behind the legs of the next row (the same convention as the layout's `±σδ` node
//!   offsets, [`crate::layout`]); the heads a decrease stacks follow in stacking order;
//! - any other node with `m ≥ 2` passes: slot `s` gets `k = 2s − (m − 1)`, so consecutive
//!   slots are `2R` apart.
//!
//! Two yarns of a two-yarn node therefore end up exactly `2R` apart along the normal: tubes of
//! radius `R` touching at the node.
//!
//! **3. Splines** ([`catmull_rom`]). Each yarn is a centripetal Catmull-Rom spline (knot
//! intervals `|pᵢ₊₁ − pᵢ|^½`, Barry–Goldman evaluation) through its offset points, with
//! reflected phantom end points `p₋₁ = 2p₀ − p₁`, `p_N = 2p_{N−1} − p_{N−2}` (zero curvature at
//! the yarn ends). Segment `i` is sampled at `t = tᵢ + (j/m)(tᵢ₊₁ − tᵢ)`, `j = 0 … m − 1`, and
//! the last point closes the curve: `(N − 1) m + 1` samples for `N` passes, with sample
//! `i m` equal to `pᵢ` (up to rounding). Centripetal knots avoid the cusps and
//! self-intersections of uniform Catmull-Rom on the short stitch-contact segments. A knot
//! interval that is zero (coincident points) or not finite is replaced by 10⁻⁶ of the mean
//! finite interval of the yarn (or 1 if there is none), so evaluation never divides by zero.
//!
//! **Robustness.** Nothing here panics on bad geometry: a node with a non-finite position
//! gets a fallback normal and a non-finite offset point, which makes the spline samples of the
//! (at most four) segments around it non-finite; the other samples are unaffected.
//! [`RenderCurves::non_finite_nodes`] counts such nodes. The text writers print non-finite
//! values as `NaN`/`inf`, the PNG renderer skips them. Invalid options (radius ≤ 0, zero
//! samples, a position list that does not match the topology) are [`OutputError::Invalid`].
//!
//! # File formats (one file per frame `frame_NNNNN.<ext>`)
//!
//! The curves are written by the workbench's one set of writers, `yarn-output`, whose module
//! documentation gives each format exactly:
//!
//! - **OBJ** ([`RenderCurves::obj_text`], `.obj`, [`yarn_output::obj`]): `v` per spline sample
//!   (metres), yarn after yarn, one `l` per yarn with ≥ 2 samples; comment [`COMMENT`].
//! - **PLY** ([`RenderCurves::ply_text`], `.ply`, [`yarn_output::ply`]): ASCII, vertices and
//!   edges with a `yarn` property.
//! - **`.bcc`** ([`RenderCurves::bcc_bytes`], [`yarn_output::bcc`]): up axis Y (the layout's rows
//!   grow along +y and gravity is −y), info [`BCC_INFO`], all yarns open. Curve type
//!   [`BccCurve::C0`] (default) writes the offset control points `pᵢ` (the format's uniform
//!   Catmull-Rom: a reader's uniform spline passes through the same points as our
//!   centripetal one but differs slightly between them), [`BccCurve::Pl`] writes the spline
//!   samples as a polyline (exactly the OBJ/PLY geometry).
//! - **USD** ([`RenderCurves::usda_text`], `.usda`, [`yarn_output::usda`]): one linear
//!   `BasisCurves` prim of the samples, width `2R`, up axis Y.
//! - **USD cache** (`usd_cache`, one `yarns.usda` per run, [`yarn_output::usda::Sequence`]):
//!   the same prims with time-sampled points and extents, one time code per frame at the
//!   run's frame rate, so that Blender, Houdini or usdview load the animation as one file;
//!   written by [`FrameWriter::finish`].
//! - **PNG** ([`RenderCurves::render`], `.png`): the samples drawn as shaded tubes of radius
//!   `R` by [`yarn_output::render`] (orthographic, depth-buffered, one palette colour per
//!   yarn), 8-bit RGB.
//! - **Nodes OBJ** ([`nodes_obj_text`], `.nodes.obj`): the simulated geometry itself — one `v`
//!   per contact node and one `l` per yarn through its passes (the straight segments).
//! - **Mesh obstacles** ([`ObstacleMeshes`]) are drawn into the PNG frames and written as
//!   `Mesh` prims beside the yarns into the USD frames and cache (OBJ, PLY and `.bcc` hold
//!   yarns only).

mod curves;
mod frames;
mod normals;

pub use curves::{BccCurve, CurveOptions, MAX_SAMPLES_PER_SEGMENT, RenderCurves, catmull_rom};
pub use frames::{CACHE_FILE, Format, FrameWriter, OutputSpec, View};
pub use normals::{
    COLLINEAR_RATIO, NodeNormals, NormalSource, fit_plane_normal, node_normals, offset_sides,
};

use crate::integrator::Simulator;
use std::path::{Path, PathBuf};

/// Output that cannot be produced.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file cannot be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Invalid options or positions that do not match the topology.
    #[error("invalid output request: {0}")]
    Invalid(String),
    /// A yarn-output writer rejected the request.
    #[error(transparent)]
    Output(#[from] yarn_output::OutputError),
    /// The tube renderer rejected the request.
    #[error("rendering {path}: {message}")]
    Render {
        /// The image file.
        path: PathBuf,
        /// The renderer's message.
        message: String,
    },
}

/// The colour of mesh obstacles in images and USD files (a light skin tone).
pub const OBSTACLE_COLOUR: [u8; 3] = [222, 196, 170];

/// The mesh obstacles of a simulator where they are now (static, or where the last step moved
/// an animated one), owned so that [`ObstacleMeshes::layers`] can lend them to the renderer
/// and the USD writer.
#[derive(Clone, Debug, Default)]
pub struct ObstacleMeshes {
    meshes: Vec<OwnedMesh>,
}

/// Vertex positions (m) and triangles of one mesh.
type OwnedMesh = (Vec<[f64; 3]>, Vec<[u32; 3]>);

impl ObstacleMeshes {
    /// The mesh obstacles of `sim` (none: spheres and planes are not drawn).
    pub fn of(sim: &Simulator) -> Self {
        let meshes = sim
            .obstacles()
            .iter()
            .filter_map(|o| match &o.shape {
                crate::forces::obstacle::Shape::Mesh(m) => Some((
                    m.mesh.vertices().iter().map(|v| [v.x, v.y, v.z]).collect(),
                    m.mesh.triangles().to_vec(),
                )),
                _ => None,
            })
            .collect();
        Self { meshes }
    }

    /// The meshes as layers of [`OBSTACLE_COLOUR`].
    pub fn layers(&self) -> Vec<yarn_output::render::MeshLayer<'_>> {
        self.meshes
            .iter()
            .map(|(positions, triangles)| yarn_output::render::MeshLayer {
                positions,
                triangles,
                colour: OBSTACLE_COLOUR,
            })
            .collect()
    }
}

/// The comment line of our OBJ, PLY and USD files.
pub const COMMENT: &str = "sim-persistent yarn rendering curves (m), seed 000 §3.2";

/// The 40-byte info field of our `.bcc` headers (zero padded).
pub const BCC_INFO: &str = "sim-persistent yarns (m), seed 000";

/// The simulated geometry as OBJ text: `v` per contact node (m), `l` per yarn through its
/// passes (the straight segments; the behaviour of the former `scene::obj_text`).
pub fn nodes_obj_text(sim: &Simulator) -> String {
    let q = &sim.state().q;
    let points = (0..sim.topology().nodes.len()).map(|n| {
        let x = sim.dofs().position(q, n);
        [x.x, x.y, x.z]
    });
    let paths: Vec<Vec<usize>> = (sim.topology().yarns.iter())
        .map(|yarn| yarn.passes.iter().map(|p| p.node).collect())
        .collect();
    yarn_output::obj::indexed_to_string(
        points,
        &paths,
        "sim-persistent yarn curves (m): one polyline per yarn",
    )
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    std::fs::write(path, bytes).map_err(|source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes [`nodes_obj_text`] to `dir/frame_NNNNN.obj` and returns the path (the file name of
/// the former `scene::write_obj`).
pub fn write_nodes_obj(sim: &Simulator, dir: &Path, frame: usize) -> Result<PathBuf, OutputError> {
    let path = dir.join(format!("frame_{frame:05}.obj"));
    write_file(&path, nodes_obj_text(sim).as_bytes())?;
    Ok(path)
}
