//! Triangle-mesh obstacles (a body, a head, a table): signed distance to a triangle mesh
//! through a bounding-volume hierarchy, and animated meshes (OBJ sequences).
//!
//! **Signed distance.** The closest point `c` of the mesh to `x` is found in an AABB tree of
//! the triangles (built top-down, median split of the centroids along the widest axis, at
//! most [`LEAF_SIZE`] triangles per leaf; a query visits children nearest first and prunes
//! boxes farther than the best point so far). The sign is that of `(x − c)·n` with the
//! angle-weighted pseudo-normal `n` of the closest feature (face, edge or vertex; Bærentzen &
//! Aanæs 2005), which classifies inside and outside exactly for a closed, consistently wound
//! mesh (vertices repeated at the same position, as along the seams of exported meshes, count
//! as one). Outward normals follow counter-clockwise winding (the OBJ convention); the interior
//! of a closed mesh, or the back of an open one, is solid. With `r = x − c` the signed
//! distance `φ = ±|r|` has, in the three regions of the closest feature,
//!
//! ```text
//! face:    ∇φ = n_f            ∇²φ = 0
//! edge e:  ∇φ = ±r/|r|         ∇²φ = ±(I − r̂r̂ᵀ − êêᵀ)/|r|
//! vertex:  ∇φ = ±r/|r|         ∇²φ = ±(I − r̂r̂ᵀ)/|r|
//! ```
//!
//! (exact within each region; on the mesh itself, `|r| → 0`, the pseudo-normal is the
//! gradient and the curvature term is dropped, where the penalty's `V'` vanishes anyway).
//!
//! **Reach.** Only points within [`TriangleMesh::reach`] of the surface are searched: a point
//! farther away, outside or inside, is reported as far outside (no contact). So a yarn
//! point that has sunk deeper than the reach (default [`DEFAULT_REACH`]) is let go instead of
//! being pushed through a thin part to the other side. The reach bounds the query's cost.
//!
//! **Animation.** [`MeshAnimation`] holds a sequence of frames with fixed triangles (an OBJ
//! sequence at a frame rate); its mesh at time `t` interpolates the vertices linearly between
//! the two frames around `t` and holds the last frame after the end. The simulator moves the
//! obstacle to the end of every (sub)step before solving it (the contact is with the
//! obstacle where it will be), rebuilding the tree: `O(n log n)` in the triangles, a small
//! part of a step for body-sized meshes (`benches/mesh_obstacle.rs` times the queries).

use nalgebra::Matrix3;
use rod::geometry::V3;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// Most triangles in a leaf of the tree.
pub const LEAF_SIZE: usize = 4;

/// Default reach (m) of a mesh's distance queries: 5 mm, ten yarn radii of the Table 1
/// sweater yarn; larger than a yarn point travels into the obstacle in a step at cloth
/// speeds, smaller than a body's thin parts.
pub const DEFAULT_REACH: f64 = 5e-3;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: V3,
    hi: V3,
}

impl Aabb {
    fn empty() -> Self {
        Self {
            lo: V3::repeat(f64::INFINITY),
            hi: V3::repeat(f64::NEG_INFINITY),
        }
    }

    fn grow(&mut self, p: &V3) {
        self.lo = self.lo.inf(p);
        self.hi = self.hi.sup(p);
    }

    /// Squared distance from `x` to the box (0 inside).
    fn distance2(&self, x: &V3) -> f64 {
        let d = (self.lo - x).sup(&(x - self.hi)).sup(&V3::zeros());
        d.norm_squared()
    }
}

/// A node of the flattened tree: a leaf holds `count > 0` triangles `order[start..start +
/// count]`; an inner node's children are the next node and node `start`.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    start: u32,
    count: u32,
}

/// The feature of a triangle that holds the closest point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// The interior of the face.
    Face,
    /// Edge `k` (from corner `k` to corner `k + 1 mod 3`).
    Edge(usize),
    /// Corner `k`.
    Vertex(usize),
}

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug)]
pub struct Closest {
    /// The closest point (m).
    pub point: V3,
    /// Its triangle.
    pub triangle: usize,
    /// Its feature of that triangle.
    pub feature: Feature,
    /// Squared distance (m²).
    pub distance2: f64,
}

/// A triangle mesh with pseudo-normals and a bounding-volume hierarchy (module documentation).
#[derive(Clone)]
pub struct TriangleMesh {
    vertices: Vec<V3>,
    triangles: Vec<[u32; 3]>,
    face_normals: Vec<V3>,
    /// Per triangle, the pseudo-normals of its edges `k → k + 1`.
    edge_normals: Vec<[V3; 3]>,
    vertex_normals: Vec<V3>,
    nodes: Vec<Node>,
    order: Vec<u32>,
    reach: f64,
}

impl std::fmt::Debug for TriangleMesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TriangleMesh")
            .field("vertices", &self.vertices.len())
            .field("triangles", &self.triangles.len())
            .field("reach", &self.reach)
            .finish()
    }
}

impl TriangleMesh {
    /// A mesh of `vertices` (m) and counter-clockwise `triangles`, searched within `reach` (m)
    /// of its surface. Errors name the first non-finite vertex, out-of-range index or invalid
    /// reach; an empty mesh is an error.
    pub fn new(vertices: Vec<V3>, triangles: Vec<[u32; 3]>, reach: f64) -> Result<Self, String> {
        if triangles.is_empty() {
            return Err("a mesh obstacle needs at least one triangle".into());
        }
        if !(reach.is_finite() && reach > 0.0) {
            return Err(format!("mesh reach must be finite and > 0 m, got {reach}"));
        }
        if let Some(i) = vertices
            .iter()
            .position(|v| !v.iter().all(|c| c.is_finite()))
        {
            return Err(format!("mesh vertex {} is not finite", i + 1));
        }
        if let Some(t) = triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= vertices.len()))
        {
            return Err(format!(
                "mesh triangle {} indexes a vertex beyond the {} vertices",
                t + 1,
                vertices.len()
            ));
        }
        let corners = |t: &[u32; 3]| t.map(|i| vertices[i as usize]);
        let face_normals: Vec<V3> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = corners(t);
                (b - a)
                    .cross(&(c - a))
                    .try_normalize(0.0)
                    .unwrap_or_else(V3::zeros)
            })
            .collect();
        // Vertices at the same position (the seams of exported meshes repeat them) are one
        // vertex for the pseudo-normals, so that a seam is not a border with one-sided normals.
        let mut first_at: HashMap<[u64; 3], u32> = HashMap::new();
        let canon: Vec<u32> = vertices
            .iter()
            .enumerate()
            .map(|(i, v)| {
                *first_at
                    .entry([v.x, v.y, v.z].map(|c| (c + 0.0).to_bits()))
                    .or_insert(i as u32)
            })
            .collect();
        let edge_key = |t: &[u32; 3], k: usize| {
            let (i, j) = (canon[t[k] as usize], canon[t[(k + 1) % 3] as usize]);
            (i.min(j), i.max(j))
        };
        // Angle-weighted vertex normals and summed edge normals (only their directions matter).
        let mut vertex_normals = vec![V3::zeros(); vertices.len()];
        let mut edge_sum: HashMap<(u32, u32), V3> = HashMap::new();
        for (t, n) in triangles.iter().zip(&face_normals) {
            let p = corners(t);
            for k in 0..3 {
                let (e1, e2) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                let angle = e1.angle(&e2);
                if angle.is_finite() {
                    vertex_normals[canon[t[k] as usize] as usize] += angle * n;
                }
                *edge_sum.entry(edge_key(t, k)).or_insert_with(V3::zeros) += n;
            }
        }
        for (i, &c) in canon.iter().enumerate() {
            vertex_normals[i] = vertex_normals[c as usize];
        }
        let edge_normals = triangles
            .iter()
            .map(|t| std::array::from_fn(|k| edge_sum[&edge_key(t, k)]))
            .collect();
        let mut mesh = Self {
            vertices,
            triangles,
            face_normals,
            edge_normals,
            vertex_normals,
            nodes: Vec::new(),
            order: Vec::new(),
            reach,
        };
        mesh.build_tree();
        Ok(mesh)
    }

    /// The vertices (m).
    pub fn vertices(&self) -> &[V3] {
        &self.vertices
    }

    /// The triangles (vertex indices, counter-clockwise seen from outside).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// How far from the surface (m) points are searched (module documentation).
    pub fn reach(&self) -> f64 {
        self.reach
    }

    fn corners(&self, t: usize) -> [V3; 3] {
        self.triangles[t].map(|i| self.vertices[i as usize])
    }

    fn build_tree(&mut self) {
        let centroids: Vec<V3> = (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                (a + b + c) / 3.0
            })
            .collect();
        self.order = (0..self.triangles.len() as u32).collect();
        self.nodes.clear();
        let n = self.order.len();
        self.build_node(&centroids, 0, n);
    }

    fn build_node(&mut self, centroids: &[V3], start: usize, end: usize) -> usize {
        let mut bounds = Aabb::empty();
        for &t in &self.order[start..end] {
            for p in self.corners(t as usize) {
                bounds.grow(&p);
            }
        }
        let index = self.nodes.len();
        self.nodes.push(Node {
            bounds,
            start: start as u32,
            count: (end - start) as u32,
        });
        if end - start <= LEAF_SIZE {
            return index;
        }
        let mut spread = Aabb::empty();
        for &t in &self.order[start..end] {
            spread.grow(&centroids[t as usize]);
        }
        let axis = (spread.hi - spread.lo).imax();
        let mid = (start + end) / 2;
        self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        self.build_node(centroids, start, mid);
        let right = self.build_node(centroids, mid, end);
        self.nodes[index].start = right as u32;
        self.nodes[index].count = 0;
        index
    }

    /// The closest point of the mesh to `x` if it is nearer than `max_distance` (m).
    pub fn closest(&self, x: &V3, max_distance: f64) -> Option<Closest> {
        let mut best: Option<Closest> = None;
        let mut best2 = max_distance * max_distance;
        // Depth-first without allocation: the stack holds at most one sibling per level of
        // the (balanced, median-split) tree plus the node itself.
        let mut stack = [0usize; 64];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let k = stack[len];
            let node = self.nodes[k];
            if node.bounds.distance2(x) >= best2 {
                continue;
            }
            if node.count > 0 {
                let range = node.start as usize..(node.start + node.count) as usize;
                for &t in &self.order[range] {
                    let [a, b, c] = self.corners(t as usize);
                    let (point, feature) = closest_on_triangle(x, &a, &b, &c);
                    let d2 = (x - point).norm_squared();
                    if d2 < best2 {
                        best2 = d2;
                        best = Some(Closest {
                            point,
                            triangle: t as usize,
                            feature,
                            distance2: d2,
                        });
                    }
                }
            } else {
                let (l, r) = (k + 1, node.start as usize);
                let (dl, dr) = (
                    self.nodes[l].bounds.distance2(x),
                    self.nodes[r].bounds.distance2(x),
                );
                // Nearest child last, so that it is searched first.
                let (far, near) = if dl < dr { (r, l) } else { (l, r) };
                stack[len] = far;
                stack[len + 1] = near;
                len += 2;
            }
        }
        best
    }

    /// The pseudo-normal of a closest feature (not normalized for edges and vertices).
    fn pseudo_normal(&self, c: &Closest) -> V3 {
        let t = self.triangles[c.triangle];
        match c.feature {
            Feature::Face => self.face_normals[c.triangle],
            Feature::Edge(k) => self.edge_normals[c.triangle][k],
            Feature::Vertex(k) => self.vertex_normals[t[k] as usize],
        }
    }

    /// Signed distance (m, positive outside) of `x` from the surface with its gradient and
    /// Hessian (module documentation), or `None` when `x` is farther than the reach.
    pub fn signed_distance(&self, x: &V3) -> Option<(f64, V3, Matrix3<f64>)> {
        let c = self.closest(x, self.reach)?;
        let n = self.pseudo_normal(&c);
        let r = x - c.point;
        let len = c.distance2.sqrt();
        let sign = if r.dot(&n) < 0.0 { -1.0 } else { 1.0 };
        if let Feature::Face = c.feature {
            let nf = self.face_normals[c.triangle];
            return Some((r.dot(&nf), nf, Matrix3::zeros()));
        }
        if len < 1e-12 * self.reach {
            return Some((
                0.0,
                n.try_normalize(0.0).unwrap_or_else(V3::z),
                Matrix3::zeros(),
            ));
        }
        let (mut r, mut len) = (r, len);
        let mut edge = None;
        if let Feature::Edge(k) = c.feature {
            let t = self.triangles[c.triangle];
            let [p0, p1] = [k, (k + 1) % 3].map(|i| self.vertices[t[i] as usize]);
            if let Some(e) = (p1 - p0).try_normalize(0.0) {
                // r ⟂ e exactly (the closest point's rounding along the edge would otherwise
                // leak into the gradient's tangential part).
                r -= e * e.dot(&r);
                len = r.norm();
                edge = Some(e);
            }
        }
        let u = r / len;
        let mut hess = Matrix3::identity() - u * u.transpose();
        if let Some(e) = edge {
            hess -= e * e.transpose();
        }
        Some((sign * len, sign * u, sign * hess / len))
    }

    /// A closed icosphere of `radius` (m) around `center`: an icosahedron whose faces are
    /// split in four `subdivisions` times (20 · 4ˢ triangles), vertices on the sphere.
    pub fn icosphere(
        center: V3,
        radius: f64,
        subdivisions: usize,
        reach: f64,
    ) -> Result<Self, String> {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut vertices: Vec<V3> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|p| V3::from(*p).normalize())
        .collect();
        let mut triangles: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
            let mut mid = |i: u32, j: u32, vertices: &mut Vec<V3>| -> u32 {
                *midpoint.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    let m = (vertices[i as usize] + vertices[j as usize]).normalize();
                    vertices.push(m);
                    (vertices.len() - 1) as u32
                })
            };
            let mut next = Vec::with_capacity(4 * triangles.len());
            for [a, b, c] in triangles {
                let (ab, bc, ca) = (
                    mid(a, b, &mut vertices),
                    mid(b, c, &mut vertices),
                    mid(c, a, &mut vertices),
                );
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            triangles = next;
        }
        let vertices = vertices.into_iter().map(|v| center + radius * v).collect();
        Self::new(vertices, triangles, reach)
    }

    /// The same triangles on `vertices` (m) of the same count (a frame of an animation).
    pub fn with_vertices(&self, vertices: Vec<V3>) -> Result<Self, String> {
        if vertices.len() != self.vertices.len() {
            return Err(format!(
                "expected {} vertices (as in the first frame), found {}",
                self.vertices.len(),
                vertices.len()
            ));
        }
        Self::new(vertices, self.triangles.clone(), self.reach)
    }

    /// Reads an OBJ file ([`yarn_output::obj_mesh`], UVs ignored), scaling its coordinates by
    /// `scale` (e.g. 0.001 for millimetres) and moving them by `offset` (m).
    pub fn read_obj(path: &Path, scale: f64, offset: V3, reach: f64) -> Result<Self, String> {
        let mesh = yarn_output::obj_mesh::read_obj(path, yarn_output::obj_mesh::Uv::Ignored)
            .map_err(|e| e.to_string())?;
        let vertices = mesh
            .positions
            .iter()
            .map(|p| V3::from(*p) * scale + offset)
            .collect();
        Self::new(vertices, mesh.tri_positions, reach)
            .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// The closest point of triangle `(a, b, c)` to `p` and the feature that holds it (Ericson,
/// *Real-Time Collision Detection*, §5.1.5).
pub fn closest_on_triangle(p: &V3, a: &V3, b: &V3, c: &V3) -> (V3, Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, Feature::Vertex(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + v * ab, Feature::Edge(0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + w * ac, Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + w * (c - b), Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (a + ab * v + ac * w, Feature::Face)
}

/// Checks a frame's vertices: `expected` of them (as in the first frame), all finite.
fn check_frame(expected: usize, vertices: &[V3]) -> Result<(), String> {
    if vertices.len() != expected {
        return Err(format!(
            "expected {expected} vertices (as in the first frame), found {}",
            vertices.len()
        ));
    }
    match vertices
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        Some(i) => Err(format!("vertex {} is not finite", i + 1)),
        None => Ok(()),
    }
}

/// An animated mesh: frames of the same triangles at a fixed frame rate (module
/// documentation).
#[derive(Clone, Debug)]
pub struct MeshAnimation {
    first: TriangleMesh,
    frames: Vec<Vec<V3>>,
    frame_time: f64,
}

impl MeshAnimation {
    /// An animation from `first` (frame 0, with the triangles and reach) and the vertices of
    /// every frame (frame 0 included) at `fps` frames per second. Errors if a frame's vertex
    /// count differs, a vertex is not finite, or `fps` is not > 0.
    pub fn new(first: TriangleMesh, frames: Vec<Vec<V3>>, fps: f64) -> Result<Self, String> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(format!("mesh animation fps must be > 0, got {fps}"));
        }
        if frames.is_empty() {
            return Err("a mesh animation needs at least one frame".into());
        }
        for (f, v) in frames.iter().enumerate() {
            check_frame(first.vertices.len(), v).map_err(|e| format!("frame {f}: {e}"))?;
        }
        Ok(Self {
            first,
            frames,
            frame_time: 1.0 / fps,
        })
    }

    /// Reads an OBJ sequence (`*` in the file name, numeric order,
    /// [`yarn_output::obj_mesh::expand_sequence`]) at `fps`, scaled and moved as
    /// [`TriangleMesh::read_obj`].
    pub fn read_obj_sequence(
        pattern: &str,
        fps: f64,
        scale: f64,
        offset: V3,
        reach: f64,
    ) -> Result<Self, String> {
        let files = yarn_output::obj_mesh::expand_sequence(pattern).map_err(|e| e.to_string())?;
        let first = TriangleMesh::read_obj(&files[0], scale, offset, reach)?;
        let mut frames = Vec::with_capacity(files.len());
        let mut buf = Vec::new();
        for f in &files {
            yarn_output::obj_mesh::read_obj_positions(f, &mut buf).map_err(|e| e.to_string())?;
            let frame: Vec<V3> = buf.iter().map(|p| V3::from(*p) * scale + offset).collect();
            check_frame(first.vertices.len(), &frame).map_err(|e| {
                format!(
                    "{}: {e} (the first frame is {})",
                    f.display(),
                    files[0].display()
                )
            })?;
            frames.push(frame);
        }
        Self::new(first, frames, fps).map_err(|e| format!("{pattern}: {e}"))
    }

    /// Number of frames.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// The mesh at time `t` (s): linear between frames, the first before 0 and the last
    /// after the end.
    pub fn at(&self, t: f64) -> TriangleMesh {
        let s = (t / self.frame_time).max(0.0);
        let last = self.frames.len() - 1;
        let i = (s.floor() as usize).min(last);
        let j = (i + 1).min(last);
        let w = if i == last { 0.0 } else { s - i as f64 };
        let vertices = self.frames[i]
            .iter()
            .zip(&self.frames[j])
            .map(|(a, b)| a + w * (b - a))
            .collect();
        self.first
            .with_vertices(vertices)
            .expect("frames were checked")
    }
}

/// A mesh obstacle's geometry now, and its animation if it moves.
#[derive(Clone, Debug)]
pub struct MeshShape {
    /// The mesh at [`MeshShape::time`].
    pub mesh: TriangleMesh,
    /// The animation (`None`: a static mesh).
    pub animation: Option<Arc<MeshAnimation>>,
    /// The time (s) the mesh is at.
    pub time: f64,
}
