//! Rendering curves: centripetal Catmull-Rom samples through the offset node positions, and
//! their OBJ, PLY, BCC, USD and PNG forms (module documentation of [`crate::output`]).

use super::normals::{NodeNormals, node_normals, offset_sides};
use super::{BCC_INFO, COMMENT, OutputError};
use crate::integrator::Simulator;
use crate::topology::Topology;
use rod::geometry::V3;
use serde::Deserialize;
use std::path::Path;
use yarn_output::bcc::{BccHeader, CurveType};
use yarn_output::render::{MeshLayer, RenderOptions, Rendering, render_scene};
use yarn_output::usda::UsdOptions;
use yarn_output::{PolylineBuf, UpAxis};

/// Most spline samples per segment accepted by [`CurveOptions`].
pub const MAX_SAMPLES_PER_SEGMENT: usize = 256;

/// Samples of the centripetal Catmull-Rom spline through `points` with `samples_per_segment`
/// samples per segment (module documentation): `(N − 1) m + 1` points for `N ≥ 2` points,
/// the points themselves for `N ≤ 1`. `samples_per_segment = 0` is treated as 1.
pub fn catmull_rom(points: &[V3], samples_per_segment: usize) -> Vec<V3> {
    let n = points.len();
    if n < 2 {
        return points.to_vec();
    }
    let m = samples_per_segment.max(1);
    // Knot intervals of the extended list p₋₁, p₀ … p_{N−1}, p_N.
    let mut ext = Vec::with_capacity(n + 2);
    ext.push(2.0 * points[0] - points[1]);
    ext.extend_from_slice(points);
    ext.push(2.0 * points[n - 1] - points[n - 2]);
    let raw: Vec<f64> = ext
        .windows(2)
        .map(|w| (w[1] - w[0]).norm().sqrt())
        .collect();
    let good: Vec<f64> = raw
        .iter()
        .copied()
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    let floor = if good.is_empty() {
        1.0
    } else {
        1e-6 * good.iter().sum::<f64>() / good.len() as f64
    };
    let dt: Vec<f64> = raw
        .iter()
        .map(|&d| if d.is_finite() && d > floor { d } else { floor })
        .collect();
    let mut out = Vec::with_capacity((n - 1) * m + 1);
    for i in 0..n - 1 {
        let (p0, p1, p2, p3) = (ext[i], ext[i + 1], ext[i + 2], ext[i + 3]);
        let (t0, t1) = (0.0, dt[i]);
        let t2 = t1 + dt[i + 1];
        let t3 = t2 + dt[i + 2];
        for j in 0..m {
            let t = t1 + (t2 - t1) * j as f64 / m as f64;
            let lerp = |a: V3, b: V3, ta: f64, tb: f64| {
                (tb - t) / (tb - ta) * a + (t - ta) / (tb - ta) * b
            };
            let a1 = lerp(p0, p1, t0, t1);
            let a2 = lerp(p1, p2, t1, t2);
            let a3 = lerp(p2, p3, t2, t3);
            let b1 = lerp(a1, a2, t0, t2);
            let b2 = lerp(a2, a3, t1, t3);
            out.push(lerp(b1, b2, t1, t2));
        }
    }
    out.push(points[n - 1]);
    out
}

/// Options of the rendering curves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveOptions {
    /// Yarn radius `R` (m): the offset of each yarn from a contact node.
    pub radius: f64,
    /// Spline samples per segment between consecutive passes (1 … [`MAX_SAMPLES_PER_SEGMENT`]).
    pub samples_per_segment: usize,
}

impl CurveOptions {
    /// Checks that `R` is finite and positive and the sample count in range.
    pub fn validate(&self) -> Result<(), OutputError> {
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(OutputError::Invalid(format!(
                "yarn radius must be finite and > 0 m, found {}",
                self.radius
            )));
        }
        if !(1..=MAX_SAMPLES_PER_SEGMENT).contains(&self.samples_per_segment) {
            return Err(OutputError::Invalid(format!(
                "samples per segment must be 1 … {MAX_SAMPLES_PER_SEGMENT}, found {}",
                self.samples_per_segment
            )));
        }
        Ok(())
    }
}

/// Which points a `.bcc` file holds (module documentation, "File formats").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum BccCurve {
    /// `"C0"`: the offset control points, as a uniform Catmull-Rom curve.
    #[default]
    C0,
    /// `"PL"`: the spline samples, as a polyline.
    #[serde(rename = "PL")]
    Pl,
}

/// The smooth rendering curves of a fabric state (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderCurves {
    /// Node normals and their sources.
    pub normals: NodeNormals,
    /// Offset control points per yarn (m), one per pass.
    pub control_points: Vec<Vec<V3>>,
    /// Spline samples per yarn (m).
    pub samples: Vec<Vec<V3>>,
    /// Samples per segment used.
    pub samples_per_segment: usize,
    /// Nodes with a non-finite position.
    pub non_finite_nodes: usize,
}

impl RenderCurves {
    /// The curves of `topology` with node positions `positions` (m, one per node).
    pub fn new(
        topology: &Topology,
        positions: &[V3],
        options: &CurveOptions,
    ) -> Result<Self, OutputError> {
        options.validate()?;
        let normals = node_normals(topology, positions)?;
        let sides = offset_sides(topology);
        let n_nodes = topology.nodes.len();
        let mut control_points = Vec::with_capacity(topology.yarns.len());
        for (y, yarn) in topology.yarns.iter().enumerate() {
            let mut pts = Vec::with_capacity(yarn.passes.len());
            for (i, p) in yarn.passes.iter().enumerate() {
                let Some(k) = sides.get(p.node).and_then(|s| s.get(p.slot)) else {
                    return Err(OutputError::Invalid(format!(
                        "yarn {y} pass {i} refers to node {} slot {} of {n_nodes} nodes",
                        p.node, p.slot
                    )));
                };
                pts.push(positions[p.node] + *k * options.radius * normals.normals[p.node]);
            }
            control_points.push(pts);
        }
        let samples = control_points
            .iter()
            .map(|pts| catmull_rom(pts, options.samples_per_segment))
            .collect();
        let non_finite_nodes = positions
            .iter()
            .filter(|p| !p.iter().all(|c| c.is_finite()))
            .count();
        Ok(Self {
            normals,
            control_points,
            samples,
            samples_per_segment: options.samples_per_segment,
            non_finite_nodes,
        })
    }

    /// The curves of the simulator's current state.
    pub fn from_simulator(sim: &Simulator, options: &CurveOptions) -> Result<Self, OutputError> {
        let q = &sim.state().q;
        let positions: Vec<V3> = (0..sim.topology().nodes.len())
            .map(|n| sim.dofs().position(q, n))
            .collect();
        Self::new(sim.topology(), &positions, options)
    }

    /// Total number of spline samples.
    pub fn sample_count(&self) -> usize {
        self.samples.iter().map(Vec::len).sum()
    }

    /// Total number of spline segments (polyline edges).
    pub fn edge_count(&self) -> usize {
        self.samples.iter().map(|s| s.len().saturating_sub(1)).sum()
    }

    /// The spline samples (`samples = true`) or the offset control points as open polylines.
    pub(crate) fn polylines(&self, samples: bool) -> Result<PolylineBuf, OutputError> {
        let curves = if samples {
            &self.samples
        } else {
            &self.control_points
        };
        let as_arrays = curves.iter().map(|c| c.iter().map(|p| [p.x, p.y, p.z]));
        let mut buf = PolylineBuf::default();
        for c in as_arrays {
            buf.push_curve(c, false)?;
        }
        Ok(buf)
    }

    /// OBJ text of the samples ([`yarn_output::obj`]): `v` per sample, `l` per yarn.
    pub fn obj_text(&self) -> Result<String, OutputError> {
        Ok(yarn_output::obj::to_string(
            &self.polylines(true)?.view(),
            COMMENT,
        ))
    }

    /// ASCII PLY text of the samples with a `yarn` property ([`yarn_output::ply`]).
    pub fn ply_text(&self) -> Result<String, OutputError> {
        Ok(yarn_output::ply::to_string(
            &self.polylines(true)?.view(),
            COMMENT,
        ))
    }

    /// `.bcc` bytes ([`yarn_output::bcc`], up axis Y) of the control points (`C0`) or the
    /// samples (`PL`).
    pub fn bcc_bytes(&self, curve: BccCurve) -> Result<Vec<u8>, OutputError> {
        let (samples, curve) = match curve {
            BccCurve::C0 => (false, CurveType::CatmullRom),
            BccCurve::Pl => (true, CurveType::Polyline),
        };
        let header = BccHeader {
            curve,
            up: UpAxis::Y,
            info: BCC_INFO,
        };
        Ok(yarn_output::bcc::to_bytes(
            &self.polylines(samples)?.view(),
            &header,
        )?)
    }

    /// USD ASCII text of the samples ([`yarn_output::usda`], up axis Y, width `2R`).
    pub fn usda_text(&self, radius: f64) -> Result<String, OutputError> {
        self.usda_text_with(radius, &[])
    }

    /// [`RenderCurves::usda_text`] with triangle meshes (e.g. the mesh obstacles,
    /// [`crate::output::ObstacleMeshes`]) written beside the yarns as `Mesh` prims.
    pub fn usda_text_with(
        &self,
        radius: f64,
        meshes: &[MeshLayer<'_>],
    ) -> Result<String, OutputError> {
        let options = UsdOptions {
            radius,
            up: UpAxis::Y,
            comment: COMMENT,
            meshes,
        };
        Ok(yarn_output::usda::to_string(
            &self.polylines(true)?.view(),
            &options,
        )?)
    }

    /// Renders the samples as tubes with [`yarn_output::render::render_tubes`]; `path`
    /// only names the image in errors.
    pub fn render(&self, options: &RenderOptions, path: &Path) -> Result<Rendering, OutputError> {
        self.render_with(options, &[], path)
    }

    /// [`RenderCurves::render`] with triangle meshes drawn into the same image
    /// ([`yarn_output::render::render_scene`]).
    pub fn render_with(
        &self,
        options: &RenderOptions,
        meshes: &[MeshLayer<'_>],
        path: &Path,
    ) -> Result<Rendering, OutputError> {
        render_scene(&self.polylines(true)?.view(), meshes, options).map_err(|e| {
            OutputError::Render {
                path: path.to_path_buf(),
                message: e.to_string(),
            }
        })
    }
}
