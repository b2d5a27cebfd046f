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
//! - knit stitch contact (§3.2.2), both of its nodes: the upper loop's leg has `k = +σ` and the
//!   lower loop's head `k = −σ`, `σ = +1` for a knit and `−1` for a purl (front view): the
//!   legs come from the back through the loop below and lie in front of its head, so on the
//!   front of a knit the heads hide behind the legs of the next row (the same convention as
//!   the layout's `±σδ` node offsets, [`crate::layout`]);
//! - any other node with `m ≥ 2` passes (reserved for stacked stitches): slot `s` gets
//!   `k = 2s − (m − 1)`, so consecutive slots are `2R` apart.
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
//! - **PNG** ([`RenderCurves::render`], `.png`): the samples drawn as shaded tubes of radius
//!   `R` by [`yarn_output::render`] (orthographic, depth-buffered, one palette colour per
//!   yarn), 8-bit RGB.
//! - **Nodes OBJ** ([`nodes_obj_text`], `.nodes.obj`): the simulated geometry itself — one `v`
//!   per contact node and one `l` per yarn through its passes (the straight segments).

use crate::integrator::Simulator;
use crate::topology::Topology;
use nalgebra::{Matrix3, SymmetricEigen};
use rod::geometry::V3;
use serde::{Deserialize, Deserializer};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use yarn_output::bcc::{BccHeader, CurveType};
use yarn_output::render::{Camera, Framing, RenderOptions, Rendering, render_tubes};
use yarn_output::usda::UsdOptions;
use yarn_output::{PolylineBuf, UpAxis};

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

/// Neighbourhoods whose second covariance eigenvalue is at most this fraction of the largest
/// are collinear: their plane, hence their normal, is undetermined (module documentation).
pub const COLLINEAR_RATIO: f64 = 1e-6;

/// Most spline samples per segment accepted by [`CurveOptions`].
pub const MAX_SAMPLES_PER_SEGMENT: usize = 256;

/// Where a node normal comes from (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalSource {
    /// Fitted to the node and its neighbours.
    Fitted,
    /// Degenerate neighbourhood: mean of the neighbours' fitted normals.
    Neighbours,
    /// Degenerate neighbourhood without fitted neighbours: the fabric normal.
    Fabric,
}

/// Unit normals of the contact nodes, consistently oriented (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct NodeNormals {
    /// Unit normal per node (dimensionless).
    pub normals: Vec<V3>,
    /// How each normal was obtained.
    pub sources: Vec<NormalSource>,
    /// The fabric normal `g` (unit) used for orientation and as the last fallback.
    pub fabric: V3,
}

/// Eigenvalues (ascending) and unit eigenvectors of the covariance of `points` about their
/// mean, or `None` if it cannot be computed (no points, non-finite values).
fn covariance_eigen(points: &[V3]) -> Option<([f64; 3], [V3; 3])> {
    if points.is_empty() {
        return None;
    }
    let mean = points.iter().sum::<V3>() / points.len() as f64;
    let mut m = Matrix3::<f64>::zeros();
    for p in points {
        let d = p - mean;
        m += d * d.transpose();
    }
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let eig = SymmetricEigen::try_new(m, f64::EPSILON, 1000)?;
    let mut idx = [0, 1, 2];
    idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let vectors = idx.map(|i| eig.eigenvectors.column(i).into_owned());
    if !vectors.iter().all(|v| v.iter().all(|c| c.is_finite())) {
        return None;
    }
    Some((idx.map(|i| eig.eigenvalues[i]), vectors))
}

/// The unit normal of the plane fitted to `points` (smallest-eigenvalue eigenvector of their
/// covariance), or `None` when they are fewer than three, not finite, or (nearly) collinear
/// ([`COLLINEAR_RATIO`]). The sign is arbitrary.
pub fn fit_plane_normal(points: &[V3]) -> Option<V3> {
    if points.len() < 3 {
        return None;
    }
    let (l, v) = covariance_eigen(points)?;
    (l[2] > 0.0 && l[1] > COLLINEAR_RATIO * l[2]).then(|| v[0].normalize())
}

/// `v` signed so that its first clearly non-zero component among (z, y, x) is positive.
fn canonical_sign(v: V3) -> V3 {
    for c in [2, 1, 0] {
        if v[c].abs() > 1e-9 {
            return if v[c] < 0.0 { -v } else { v };
        }
    }
    v
}

/// The fabric normal `g` of the finite `positions` (module documentation).
fn fabric_normal(positions: &[V3]) -> V3 {
    let finite: Vec<V3> = positions
        .iter()
        .copied()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .collect();
    if let Some(n) = fit_plane_normal(&finite) {
        return canonical_sign(n);
    }
    if let Some((l, v)) = covariance_eigen(&finite)
        && l[2] > 0.0
    {
        let d = v[2];
        let axis = [V3::z(), V3::y(), V3::x()]
            .into_iter()
            .min_by(|a, b| a.dot(&d).abs().total_cmp(&b.dot(&d).abs()))
            .unwrap_or(V3::z());
        let n = axis - axis.dot(&d) * d;
        if n.norm() > 1e-12 {
            return canonical_sign(n.normalize());
        }
    }
    V3::z()
}

/// Neighbours of every node along all yarns through it (previous and next pass), each once.
fn neighbours(topology: &Topology) -> Vec<Vec<usize>> {
    let n_nodes = topology.nodes.len();
    let mut nbrs = vec![Vec::new(); n_nodes];
    for yarn in &topology.yarns {
        for w in yarn.passes.windows(2) {
            let (a, b) = (w[0].node, w[1].node);
            if a < n_nodes && b < n_nodes && a != b {
                nbrs[a].push(b);
                nbrs[b].push(a);
            }
        }
    }
    for list in &mut nbrs {
        list.sort_unstable();
        list.dedup();
    }
    nbrs
}

/// Fitted, consistently oriented node normals with fallbacks (module documentation).
/// `positions` has one entry per node of `topology` (checked).
pub fn node_normals(topology: &Topology, positions: &[V3]) -> Result<NodeNormals, OutputError> {
    let n_nodes = topology.nodes.len();
    if positions.len() != n_nodes {
        return Err(OutputError::Invalid(format!(
            "{} positions for {n_nodes} nodes",
            positions.len()
        )));
    }
    let finite = |p: &V3| p.iter().all(|c| c.is_finite());
    let nbrs = neighbours(topology);
    let fitted: Vec<Option<V3>> = (0..n_nodes)
        .map(|n| {
            if !finite(&positions[n]) {
                return None;
            }
            let mut pts = vec![positions[n]];
            pts.extend(nbrs[n].iter().map(|&m| positions[m]).filter(finite));
            fit_plane_normal(&pts)
        })
        .collect();
    let g = fabric_normal(positions);
    // Breadth-first orientation from seeds in order of alignment with g.
    let mut seeds: Vec<usize> = (0..n_nodes).filter(|&n| fitted[n].is_some()).collect();
    let align = |n: usize| fitted[n].map_or(0.0, |v| v.dot(&g).abs());
    seeds.sort_by(|&a, &b| align(b).total_cmp(&align(a)).then(a.cmp(&b)));
    let mut oriented: Vec<Option<V3>> = vec![None; n_nodes];
    let mut reference: Vec<Option<V3>> = vec![None; n_nodes];
    let mut queue = VecDeque::new();
    for seed in seeds {
        if reference[seed].is_some() {
            continue;
        }
        let v = fitted[seed].unwrap_or(g);
        let v = if v.dot(&g) < 0.0 { -v } else { v };
        oriented[seed] = Some(v);
        reference[seed] = Some(v);
        queue.push_back(seed);
        while let Some(u) = queue.pop_front() {
            let r = reference[u].unwrap_or(g);
            for &m in &nbrs[u] {
                if reference[m].is_some() {
                    continue;
                }
                match fitted[m] {
                    Some(v) => {
                        let v = if v.dot(&r) < 0.0 { -v } else { v };
                        oriented[m] = Some(v);
                        reference[m] = Some(v);
                    }
                    None => reference[m] = Some(r),
                }
                queue.push_back(m);
            }
        }
    }
    let mut normals = Vec::with_capacity(n_nodes);
    let mut sources = Vec::with_capacity(n_nodes);
    for n in 0..n_nodes {
        if let Some(v) = oriented[n] {
            normals.push(v);
            sources.push(NormalSource::Fitted);
            continue;
        }
        let mean: V3 = nbrs[n].iter().filter_map(|&m| oriented[m]).sum();
        if mean.norm() > 1e-9 {
            normals.push(mean.normalize());
            sources.push(NormalSource::Neighbours);
        } else {
            let r = reference[n].unwrap_or(g);
            normals.push(if g.dot(&r) < 0.0 { -g } else { g });
            sources.push(NormalSource::Fabric);
        }
    }
    Ok(NodeNormals {
        normals,
        sources,
        fabric: g,
    })
}

/// Side factor `k` of every node slot, `sides[node][slot]`: the pass is offset by `k R n̂`
/// (module documentation: weave crossings by which yarn is on top, stitch contacts by
/// knit/purl, one-yarn nodes not at all).
pub fn offset_sides(topology: &Topology) -> Vec<Vec<f64>> {
    let mut sides: Vec<Vec<f64>> = topology
        .nodes
        .iter()
        .map(|node| {
            let m = node.passes.len();
            if m < 2 {
                vec![0.0; m]
            } else {
                (0..m).map(|s| (2 * s) as f64 - (m - 1) as f64).collect()
            }
        })
        .collect();
    // Weave crossings: yarn `j` is weft `j` (Topology::weave); the other yarn is the warp.
    for c in &topology.crossings {
        let warp_side = if c.warp_over { 1.0 } else { -1.0 };
        if let Some(node) = topology.nodes.get(c.node)
            && node.passes.len() >= 2
        {
            for (s, p) in node.passes.iter().enumerate() {
                sides[c.node][s] = if p.yarn == c.weft {
                    -warp_side
                } else {
                    warp_side
                };
            }
        }
    }
    let mut set = |node: usize, yarn: usize, k: f64| {
        if let Some(slots) = topology.nodes.get(node)
            && slots.passes.len() >= 2
            && let Some(s) = slots.passes.iter().position(|p| p.yarn == yarn)
        {
            sides[node][s] = k;
        }
    };
    for sc in &topology.stitch_contacts {
        let sigma = sc.stitch.sign();
        for &node in &sc.nodes {
            set(node, sc.yarns[0], sigma);
            set(node, sc.yarns[1], -sigma);
        }
    }
    sides
}

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
    fn polylines(&self, samples: bool) -> Result<PolylineBuf, OutputError> {
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
        let options = UsdOptions {
            radius,
            up: UpAxis::Y,
            comment: COMMENT,
        };
        Ok(yarn_output::usda::to_string(
            &self.polylines(true)?.view(),
            &options,
        )?)
    }

    /// Renders the samples as tubes with [`yarn_output::render::render_tubes`]; `path`
    /// only names the image in errors.
    pub fn render(&self, options: &RenderOptions, path: &Path) -> Result<Rendering, OutputError> {
        render_tubes(&self.polylines(true)?.view(), options).map_err(|e| OutputError::Render {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
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

/// An output file format of `[output] formats`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Rendering curves as OBJ polylines (`frame_NNNNN.obj`).
    Obj,
    /// Rendering curves as ASCII PLY (`frame_NNNNN.ply`).
    Ply,
    /// Rendering curves as `.bcc` (`frame_NNNNN.bcc`).
    Bcc,
    /// Rendering curves as USD ASCII `BasisCurves` (`frame_NNNNN.usda`).
    Usda,
    /// Tube rendering as PNG (`frame_NNNNN.png`).
    Png,
    /// The simulated node polylines as OBJ (`frame_NNNNN.nodes.obj`).
    Nodes,
}

impl Format {
    /// The file name of frame `frame` in this format.
    pub fn file_name(self, frame: usize) -> String {
        let ext = match self {
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Bcc => "bcc",
            Format::Usda => "usda",
            Format::Png => "png",
            Format::Nodes => "nodes.obj",
        };
        format!("frame_{frame:05}.{ext}")
    }
}

/// A PNG camera preset of `[output] view`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum View {
    /// From `+z` (the fabric front in the layout), y up.
    #[default]
    Front,
    /// From `−z` (the fabric back), y up.
    Back,
    /// From `+x` (the swatch edge-on), y up.
    Side,
    /// From the front, above and to the right, y up.
    Oblique,
}

impl View {
    /// The orthographic camera of the preset.
    pub fn camera(self) -> Camera {
        let direction = match self {
            View::Front => [0.0, 0.0, -1.0],
            View::Back => [0.0, 0.0, 1.0],
            View::Side => [-1.0, 0.0, 0.0],
            View::Oblique => [-0.5, -0.6, -1.0],
        };
        Camera {
            direction,
            up: [0.0, 1.0, 0.0],
        }
    }
}

/// The `[output]` section of a scene (see [`crate::scene`]); every value is checked while
/// parsing, so a bad one is reported at its line (the renderer's total pixel budget, image
/// size × supersampling², is checked when the first image is rendered).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Formats written per frame (non-empty, no repeats; default `["obj"]`).
    #[serde(deserialize_with = "de_formats")]
    pub formats: Vec<Format>,
    /// Write a frame every `every` steps (≥ 1); `None`: the scene's `output_every` or 10.
    #[serde(deserialize_with = "de_every")]
    pub every: Option<usize>,
    /// Spline samples per segment (1 … [`MAX_SAMPLES_PER_SEGMENT`], default 8).
    #[serde(deserialize_with = "de_samples")]
    pub samples: usize,
    /// Points written to `.bcc` files (`"C0"` control points, default; `"PL"` samples).
    pub bcc: BccCurve,
    /// PNG width and height (pixels, each 1 … 8192; default 800 × 600).
    #[serde(deserialize_with = "de_png_size")]
    pub png_size: [u32; 2],
    /// PNG camera preset (default `"front"`).
    pub view: View,
    /// PNG supersampling per axis (1 … 8, default 2).
    #[serde(deserialize_with = "de_supersample")]
    pub supersample: u32,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            formats: vec![Format::Obj],
            every: None,
            samples: 8,
            bcc: BccCurve::C0,
            png_size: [800, 600],
            view: View::Front,
            supersample: 2,
        }
    }
}

fn de_formats<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Format>, D::Error> {
    let v = Vec::<Format>::deserialize(d)?;
    if v.is_empty() {
        return Err(serde::de::Error::custom(
            "`formats` needs at least one of \"obj\", \"ply\", \"bcc\", \"usda\", \"png\", \"nodes\"",
        ));
    }
    for (i, f) in v.iter().enumerate() {
        if v[..i].contains(f) {
            return Err(serde::de::Error::custom(format!(
                "format {f:?} is listed twice"
            )));
        }
    }
    Ok(v)
}

fn de_every<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    let v = usize::deserialize(d)?;
    if v == 0 {
        return Err(serde::de::Error::custom("`every` must be ≥ 1 step"));
    }
    Ok(Some(v))
}

fn de_samples<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if !(1..=MAX_SAMPLES_PER_SEGMENT).contains(&v) {
        return Err(serde::de::Error::custom(format!(
            "`samples` must be 1 … {MAX_SAMPLES_PER_SEGMENT} per segment, found {v}"
        )));
    }
    Ok(v)
}

fn de_png_size<'de, D: Deserializer<'de>>(d: D) -> Result<[u32; 2], D::Error> {
    let v = <[u32; 2]>::deserialize(d)?;
    if !v.iter().all(|s| (1..=8192).contains(s)) {
        return Err(serde::de::Error::custom(format!(
            "`png_size` must be [width, height] with each 1 … 8192 pixels, found {v:?}"
        )));
    }
    Ok(v)
}

fn de_supersample<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    let v = u32::deserialize(d)?;
    if !(1..=8).contains(&v) {
        return Err(serde::de::Error::custom(format!(
            "`supersample` must be 1 … 8, found {v}"
        )));
    }
    Ok(v)
}

/// Writes the frames of a run in the formats of an [`OutputSpec`]: `dir/frame_NNNNN.<ext>`,
/// frames numbered from 0. PNG frames share the framing of the first one (auto-fitted with a
/// 10 % margin), so an animation keeps one scale.
#[derive(Clone, Debug)]
pub struct FrameWriter {
    dir: PathBuf,
    spec: OutputSpec,
    curve: CurveOptions,
    framing: Option<Framing>,
    next: usize,
}

impl FrameWriter {
    /// A writer into `dir` (which must exist) for yarns of radius `radius` (m).
    pub fn new(dir: &Path, spec: &OutputSpec, radius: f64) -> Result<Self, OutputError> {
        let curve = CurveOptions {
            radius,
            samples_per_segment: spec.samples,
        };
        curve.validate()?;
        Ok(Self {
            dir: dir.to_path_buf(),
            spec: spec.clone(),
            curve,
            framing: None,
            next: 0,
        })
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.next
    }

    /// Writes the next frame of `sim` in every format; returns the files written.
    pub fn write(&mut self, sim: &Simulator) -> Result<Vec<PathBuf>, OutputError> {
        let frame = self.next;
        let needs_curves = self.spec.formats.iter().any(|f| *f != Format::Nodes);
        let curves = if needs_curves {
            Some(RenderCurves::from_simulator(sim, &self.curve)?)
        } else {
            None
        };
        let mut paths = Vec::with_capacity(self.spec.formats.len());
        for &format in &self.spec.formats {
            let path = self.dir.join(format.file_name(frame));
            match (format, &curves) {
                (Format::Nodes, _) => write_file(&path, nodes_obj_text(sim).as_bytes())?,
                (Format::Obj, Some(c)) => write_file(&path, c.obj_text()?.as_bytes())?,
                (Format::Ply, Some(c)) => write_file(&path, c.ply_text()?.as_bytes())?,
                (Format::Bcc, Some(c)) => write_file(&path, &c.bcc_bytes(self.spec.bcc)?)?,
                (Format::Usda, Some(c)) => {
                    write_file(&path, c.usda_text(self.curve.radius)?.as_bytes())?
                }
                (Format::Png, Some(c)) => {
                    let mut options = RenderOptions::new(
                        self.spec.png_size[0],
                        self.spec.png_size[1],
                        self.curve.radius,
                    );
                    options.camera = self.spec.view.camera();
                    options.supersample = self.spec.supersample;
                    options.framing = self.framing.unwrap_or(Framing::Auto { margin: 0.1 });
                    let r = c.render(&options, &path)?;
                    if r.segments > 0 {
                        self.framing.get_or_insert(r.framing);
                    }
                    write_file(&path, &r.image.to_png()?)?;
                }
                (_, None) => {
                    return Err(OutputError::Invalid("rendering curves missing".into()));
                }
            }
            paths.push(path);
        }
        self.next += 1;
        Ok(paths)
    }
}
