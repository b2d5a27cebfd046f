//! The rest mesh in material (UV) space and its per-frame geometry: deformation gradients,
//! fundamental forms, normals, and their distribution to mesh vertices (paper 004 §4.1, §4.5).
//!
//! Mesh vertices are *split* at UV seams: a mesh vertex is a unique (position, UV) pair of
//! the OBJ corners, so every triangle has one consistent material-space shape. Normals are
//! accumulated per *position* vertex, so they stay continuous across seams. Triangles whose
//! UV area vanishes cannot embed anything and are dropped (counted in
//! [`RestMesh::dropped_degenerate_uv`]).
//!
//! Per frame ([`FrameGeometry::update`]):
//! - per face: `F = Ds Dm⁻¹` (3 × 2, world edges over UV edges), `I = FᵀF`, the UV-oriented
//!   unit normal `n = F₁ × F₂ / |F₁ × F₂|`, and `II = FᵀΛF` with the triangle-averaged shape
//!   operator of Grinspun et al. 2006, `Λ = Σₑ θₑ |e| / (2A) tₑ tₑᵀ` (θₑ the signed dihedral
//!   angle at edge e, positive when the neighbour bends towards +n, tₑ the in-plane unit
//!   normal of e, A the world area). With this sign `II = −∇φᵀ∇n` (paper 004 Appendix A): a
//!   sphere with outward normals has `II = −I / r`.
//! - per mesh vertex: Shepard-weighted averages of the incident faces' `F`, `I`, `II`, with the
//!   modified Shepard weight `w = A_uv / |c − X|²` (UV area over squared UV distance from the
//!   vertex to the face centroid), normalized per vertex. `F` per vertex drives Phong
//!   deformation (James 2020); `I`, `II` per vertex are interpolated to yarn vertices.
//!
//! Robustness: non-finite input positions are replaced by the vertex's last finite position
//! (or the rest UV position lifted to z = 0 on the first frame); faces whose world area is
//! below `1e-12 ×` their squared edge lengths are *degenerate*: they keep `F` and `I` (which
//! stay finite) but contribute no normal and `II = 0`. Both are counted.

use std::collections::HashMap;

use crate::error::{DeformError, Result};
use crate::obj::ObjMesh;
use crate::real::Real;

/// Relative area below which a world triangle is treated as degenerate (no normal, no
/// curvature): `|F₁ × F₂| ≤ DEGENERATE · (|F₁|² + |F₂|²)`. Small enough to keep slivers that
/// still have a well-defined normal in f64.
pub const DEGENERATE: f64 = 1e-12;

/// The rest mesh: topology, material-space shapes and precomputed weights.
#[derive(Clone, Debug)]
pub struct RestMesh {
    /// Number of position vertices of the OBJ.
    pub n_positions: usize,
    /// Position index of each mesh (split) vertex.
    pub vertex_position: Vec<u32>,
    /// UV (material) coordinates of each mesh vertex (m, scaled).
    pub vertex_uv: Vec<[f64; 2]>,
    /// Kept triangles as mesh-vertex indices.
    pub triangles: Vec<[u32; 3]>,
    /// `Dm⁻¹` per kept triangle (1/m), row-major.
    pub dm_inv: Vec<[f64; 4]>,
    /// Signed UV area per kept triangle (m²).
    pub uv_area: Vec<f64>,
    /// For each triangle and local edge k (opposite corner k): the neighbouring triangle and
    /// the position index of its corner opposite the shared edge (`u32::MAX` on boundaries).
    pub neighbours: Vec<[(u32, u32); 3]>,
    /// CSR offsets of the faces incident to each mesh vertex.
    pub vertex_faces_offsets: Vec<u32>,
    /// Incident faces (CSR values).
    pub vertex_faces: Vec<u32>,
    /// Normalized modified Shepard weights (CSR values).
    pub vertex_face_weights: Vec<f64>,
    /// CSR offsets of the faces incident to each position vertex (for normals).
    pub position_faces_offsets: Vec<u32>,
    /// Faces incident to each position vertex.
    pub position_faces: Vec<u32>,
    /// Triangles of the OBJ dropped because their UV area is (near) zero.
    pub dropped_degenerate_uv: usize,
    /// The UV scale applied (UV units to metres).
    pub uv_scale: f64,
}

fn csr(n: usize, pairs: &[(u32, u32)]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; n + 1];
    for &(a, _) in pairs {
        offsets[a as usize + 1] += 1;
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut values = vec![0u32; pairs.len()];
    for &(a, b) in pairs {
        values[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
    }
    (offsets, values)
}

impl RestMesh {
    /// Builds the rest mesh of an OBJ with UVs multiplied by `uv_scale` (UV units → m).
    pub fn new(obj: &ObjMesh, uv_scale: f64) -> Result<Self> {
        if !(uv_scale.is_finite() && uv_scale > 0.0) {
            return Err(DeformError::Option {
                name: "uv_scale",
                message: format!("expected a finite positive scale, found {uv_scale}"),
            });
        }
        let mut split: HashMap<(u32, u32), u32> = HashMap::new();
        let mut vertex_position = Vec::new();
        let mut vertex_uv = Vec::new();
        let mut triangles = Vec::new();
        let mut dm_inv = Vec::new();
        let mut uv_area = Vec::new();
        let mut dropped = 0;
        for (tp, tu) in obj.tri_positions.iter().zip(&obj.tri_uvs) {
            let uv = tu.map(|k| obj.uvs[k as usize].map(|x| x * uv_scale));
            let e1 = [uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]];
            let e2 = [uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]];
            let det = e1[0] * e2[1] - e1[1] * e2[0];
            let scale = e1[0] * e1[0] + e1[1] * e1[1] + e2[0] * e2[0] + e2[1] * e2[1];
            // UV triangles with no area cannot embed yarn vertices; relative threshold.
            if det.abs().partial_cmp(&(1e-12 * scale)) != Some(std::cmp::Ordering::Greater) {
                dropped += 1;
                continue;
            }
            let mut tri = [0u32; 3];
            for c in 0..3 {
                let key = (tp[c], tu[c]);
                let next = vertex_position.len() as u32;
                tri[c] = *split.entry(key).or_insert_with(|| {
                    vertex_position.push(tp[c]);
                    vertex_uv.push(uv[c]);
                    next
                });
            }
            triangles.push(tri);
            dm_inv.push([e2[1] / det, -e2[0] / det, -e1[1] / det, e1[0] / det]);
            uv_area.push(0.5 * det);
        }
        let nf = triangles.len();
        let tri_pos: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|v| vertex_position[v as usize]))
            .collect();
        // Edge adjacency by position indices (continuous across UV seams).
        let mut edge_faces: HashMap<(u32, u32), Vec<(u32, u32)>> = HashMap::new();
        for (f, t) in tri_pos.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                edge_faces
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push((f as u32, k as u32));
            }
        }
        let mut neighbours = vec![[(u32::MAX, u32::MAX); 3]; nf];
        for faces in edge_faces.values() {
            // Manifold edges only; non-manifold edges are treated as boundaries.
            if let [(f, k), (g, l)] = faces[..] {
                neighbours[f as usize][k as usize] = (g, tri_pos[g as usize][l as usize]);
                neighbours[g as usize][l as usize] = (f, tri_pos[f as usize][k as usize]);
            }
        }
        let nv = vertex_position.len();
        let pairs: Vec<(u32, u32)> = triangles
            .iter()
            .enumerate()
            .flat_map(|(f, t)| t.map(|v| (v, f as u32)))
            .collect();
        let (vertex_faces_offsets, vertex_faces) = csr(nv, &pairs);
        let mut vertex_face_weights = vec![0.0; vertex_faces.len()];
        for v in 0..nv {
            let range = vertex_faces_offsets[v] as usize..vertex_faces_offsets[v + 1] as usize;
            let x = vertex_uv[v];
            let mut total = 0.0;
            for j in range.clone() {
                let f = vertex_faces[j] as usize;
                let c = triangles[f].map(|w| vertex_uv[w as usize]);
                let cx = (c[0][0] + c[1][0] + c[2][0]) / 3.0 - x[0];
                let cy = (c[0][1] + c[1][1] + c[2][1]) / 3.0 - x[1];
                let w = uv_area[f].abs() / (cx * cx + cy * cy);
                vertex_face_weights[j] = w;
                total += w;
            }
            for j in range {
                vertex_face_weights[j] /= total;
            }
        }
        let pairs: Vec<(u32, u32)> = tri_pos
            .iter()
            .enumerate()
            .flat_map(|(f, t)| t.map(|p| (p, f as u32)))
            .collect();
        let (position_faces_offsets, position_faces) = csr(obj.positions.len(), &pairs);
        Ok(Self {
            n_positions: obj.positions.len(),
            vertex_position,
            vertex_uv,
            triangles,
            dm_inv,
            uv_area,
            neighbours,
            vertex_faces_offsets,
            vertex_faces,
            vertex_face_weights,
            position_faces_offsets,
            position_faces,
            dropped_degenerate_uv: dropped,
            uv_scale,
        })
    }

    /// Number of mesh (split) vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertex_position.len()
    }

    /// Number of kept triangles.
    pub fn n_faces(&self) -> usize {
        self.triangles.len()
    }

    /// Total UV area (m²).
    pub fn total_uv_area(&self) -> f64 {
        self.uv_area.iter().map(|a| a.abs()).sum()
    }
}

/// Per-face quantities of one frame (f64; faces are few compared to yarn vertices).
#[derive(Clone, Copy, Debug, Default)]
pub struct FaceFrame {
    /// Deformation gradient columns `F₁ = ∂φ/∂X₁`, `F₂ = ∂φ/∂X₂` (unitless).
    pub f: [[f64; 3]; 2],
    /// Unit normal oriented by the UV orientation (zero when degenerate).
    pub n: [f64; 3],
    /// World area (m²).
    pub area: f64,
    /// `I = FᵀF` as `[I₁₁, I₁₂, I₂₂]` (unitless).
    pub i: [f64; 3],
    /// `II = FᵀΛF` as `[II₁₁, II₁₂, II₂₂]` (1/m).
    pub ii: [f64; 3],
    /// Whether the world triangle is degenerate.
    pub degenerate: bool,
}

/// Per-mesh-vertex quantities of one frame (f64).
#[derive(Clone, Copy, Debug, Default)]
pub struct VertexFrame {
    /// World position (m).
    pub p: [f64; 3],
    /// Unit normal (position-vertex average).
    pub n: [f64; 3],
    /// Shepard-averaged deformation gradient, columns `F₁`, `F₂` (unitless).
    pub f: [[f64; 3]; 2],
    /// Shepard-averaged `I` as `[I₁₁, I₁₂, I₂₂]` (unitless).
    pub i: [f64; 3],
    /// Shepard-averaged `II` as `[II₁₁, II₁₂, II₂₂]` (1/m).
    pub ii: [f64; 3],
}

/// Number of scalars of one [`FacePoly`] (including the skip flag and padding), the stride
/// of the GPU face buffer.
pub const FACE_POLY_LEN: usize = 48;

/// Everything the per-vertex kernel needs from one face in one frame, as polynomials in the
/// UV offset `d = X − U₀` from the face's first corner (m):
///
/// - world point `x(d) = x₀ + L d + Q(d, d)` — Phong deformation
///   `Σᵢ bᵢ(d) (xᵢ + Fᵢ (d − Eᵢ))` expanded (quadratic because the barycentrics `bᵢ` are
///   linear in `d`), or the affine face map when Phong is off (`Q = 0`);
/// - normal `n(d) = n₀ + N d` (to be normalized) — interpolated vertex normals, or the face
///   normal (`N = 0`);
/// - `I(d) = I₀ + G d` and `II(d) = II₀ + H d` — interpolated vertex forms, or face forms.
///
/// Expanding per face turns three vertex gathers and the barycentric algebra per yarn vertex
/// into one contiguous 192-byte (f32) read and a few fused multiply-adds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct FacePoly<T> {
    /// `x₀` (m).
    pub x0: [T; 3],
    /// Linear part: `∂x/∂d₁` then `∂x/∂d₂` (unitless).
    pub xl: [T; 6],
    /// Quadratic part: coefficients of `d₁²`, `d₁d₂`, `d₂²` (1/m), 3 components each.
    pub xq: [T; 9],
    /// `n₀` (unitless).
    pub n0: [T; 3],
    /// `∂n/∂d₁`, `∂n/∂d₂` (1/m).
    pub nl: [T; 6],
    /// `I₀ = [I₁₁, I₁₂, I₂₂]` (unitless).
    pub i0: [T; 3],
    /// `∂I/∂d₁`, `∂I/∂d₂` (1/m).
    pub il: [T; 6],
    /// `II₀` (1/m).
    pub ii0: [T; 3],
    /// `∂II/∂d₁`, `∂II/∂d₂` (1/m²).
    pub iil: [T; 6],
    /// Face normal, used when `n(d)` vanishes (unitless).
    pub nf: [T; 3],
}

/// Which interpolations the face polynomials encode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PolyOptions {
    /// Phong deformation and interpolated normals (else affine map and face normal).
    pub phong: bool,
    /// Interpolated vertex forms (else face forms).
    pub interpolate_forms: bool,
}

/// Counters of the mesh stage of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MeshCounters {
    /// Non-finite input positions replaced by the last finite ones.
    pub positions_replaced: usize,
    /// World-degenerate faces (no normal, no curvature).
    pub faces_degenerate: usize,
    /// Faces whose lookup can be skipped (identity strain, no curvature).
    pub faces_identity: usize,
}

/// Buffers of the mesh stage, allocated once and reused every frame.
#[derive(Clone, Debug)]
pub struct FrameGeometry<T> {
    /// Sanitized positions (m), per position vertex.
    pub positions: Vec<[f64; 3]>,
    /// Per face.
    pub faces: Vec<FaceFrame>,
    /// Per face, kernel polynomials.
    pub face_poly: Vec<FacePoly<T>>,
    /// Per face: 1 when the lookup can be skipped (identity `I`, zero `II` at every corner
    /// and on the face), else 0.
    pub face_skip: Vec<u32>,
    /// Per position vertex normals.
    pub position_normals: Vec<[f64; 3]>,
    /// Per mesh vertex.
    pub vertices: Vec<VertexFrame>,
    vertex_identity: Vec<bool>,
    initialized: bool,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

impl<T: Real> FrameGeometry<T> {
    /// Buffers for `mesh`.
    pub fn new(mesh: &RestMesh) -> Self {
        Self {
            positions: vec![[0.0; 3]; mesh.n_positions],
            faces: vec![FaceFrame::default(); mesh.n_faces()],
            face_poly: vec![FacePoly::default(); mesh.n_faces()],
            face_skip: vec![0; mesh.n_faces()],
            position_normals: vec![[0.0; 3]; mesh.n_positions],
            vertices: vec![VertexFrame::default(); mesh.n_vertices()],
            vertex_identity: vec![false; mesh.n_vertices()],
            initialized: false,
        }
    }

    /// Recomputes everything from the frame's `input` positions (one per OBJ position
    /// vertex; the caller checks the count). `identity_tolerance` bounds `|I − Id|` and
    /// `|II|·R` entries for the skip flag (`radius` R in m).
    pub fn update(
        &mut self,
        mesh: &RestMesh,
        input: &[[f64; 3]],
        identity_tolerance: f64,
        radius: f64,
        poly: PolyOptions,
    ) -> MeshCounters {
        let mut counters = MeshCounters {
            positions_replaced: self.sanitize_positions(mesh, input),
            ..MeshCounters::default()
        };
        counters.faces_degenerate = self.update_face_frames(mesh);
        self.update_second_forms(mesh);
        self.update_position_normals(mesh);
        let scale_ii = radius.max(f64::MIN_POSITIVE);
        self.update_vertex_averages(mesh, identity_tolerance, scale_ii);
        counters.faces_identity = self.update_face_polys(mesh, identity_tolerance, scale_ii, poly);
        counters
    }

    /// Copies the finite input positions and replaces non-finite ones by the last finite
    /// position (on the first frame: the rest UV position); returns the replacements.
    fn sanitize_positions(&mut self, mesh: &RestMesh, input: &[[f64; 3]]) -> usize {
        let mut replaced = 0;
        for (p, (q, &x)) in self.positions.iter_mut().zip(input.iter().enumerate()) {
            if x.iter().all(|c| c.is_finite()) {
                *p = x;
            } else {
                replaced += 1;
                if !self.initialized {
                    // First frame: fall back to the rest UV position of a split vertex of
                    // this position (or the origin when the vertex is unused).
                    *p = mesh
                        .vertex_position
                        .iter()
                        .position(|&vp| vp as usize == q)
                        .map(|v| [mesh.vertex_uv[v][0], mesh.vertex_uv[v][1], 0.0])
                        .unwrap_or([0.0; 3]);
                }
            }
        }
        self.initialized = true;
        replaced
    }

    /// Per face: `F = Ds Dm⁻¹`, `I = FᵀF`, the unit normal and the world area; returns the
    /// number of world-degenerate faces.
    fn update_face_frames(&mut self, mesh: &RestMesh) -> usize {
        let mut degenerate_faces = 0;
        for (f, t) in mesh.triangles.iter().enumerate() {
            let p = t.map(|v| self.positions[mesh.vertex_position[v as usize] as usize]);
            let (d1, d2) = (sub(p[1], p[0]), sub(p[2], p[0]));
            let m = mesh.dm_inv[f];
            let f1 = [0, 1, 2].map(|c| d1[c] * m[0] + d2[c] * m[2]);
            let f2 = [0, 1, 2].map(|c| d1[c] * m[1] + d2[c] * m[3]);
            let c = cross(f1, f2);
            let len = norm(c);
            let degenerate = len.partial_cmp(&(DEGENERATE * (dot(f1, f1) + dot(f2, f2))))
                != Some(std::cmp::Ordering::Greater);
            let ff = &mut self.faces[f];
            ff.f = [f1, f2];
            ff.i = [dot(f1, f1), dot(f1, f2), dot(f2, f2)];
            ff.degenerate = degenerate;
            if degenerate {
                degenerate_faces += 1;
                ff.n = [0.0; 3];
                ff.area = 0.0;
            } else {
                ff.n = c.map(|x| x / len);
                ff.area = len * mesh.uv_area[f].abs();
            }
        }
        degenerate_faces
    }

    /// Per face: `II = FᵀΛF` from the signed dihedral angles (zero when degenerate or not
    /// finite).
    fn update_second_forms(&mut self, mesh: &RestMesh) {
        for f in 0..mesh.n_faces() {
            let ii = self.dihedral_second_form(mesh, f);
            self.faces[f].ii = if ii.iter().all(|x| x.is_finite()) {
                ii
            } else {
                [0.0; 3]
            };
        }
    }

    /// `II = FᵀΛF` of face `f` with the shape operator `Λ = Σₑ θₑ |e| / (2A) tₑ tₑᵀ` over its
    /// edges shared with non-degenerate neighbours (zero for a degenerate face).
    fn dihedral_second_form(&self, mesh: &RestMesh, f: usize) -> [f64; 3] {
        let ff = self.faces[f];
        let mut ii = [0.0; 3];
        if ff.degenerate {
            return ii;
        }
        let t = mesh.triangles[f].map(|v| mesh.vertex_position[v as usize] as usize);
        for k in 0..3 {
            let (g, opp) = mesh.neighbours[f][k];
            if g == u32::MAX || self.faces[g as usize].degenerate {
                continue;
            }
            let (a, b) = (
                self.positions[t[(k + 1) % 3]],
                self.positions[t[(k + 2) % 3]],
            );
            let e = sub(b, a);
            let elen = norm(e);
            let ng = self.faces[g as usize].n;
            let angle = norm(cross(ff.n, ng)).atan2(dot(ff.n, ng));
            let side = dot(ff.n, sub(self.positions[opp as usize], a));
            let theta = if side >= 0.0 { angle } else { -angle };
            // In-plane unit normal of the edge.
            let te = cross(ff.n, e).map(|x| x / elen);
            let beta = theta * elen / (2.0 * ff.area);
            let g1 = dot(ff.f[0], te);
            let g2 = dot(ff.f[1], te);
            ii[0] += beta * g1 * g1;
            ii[1] += beta * g1 * g2;
            ii[2] += beta * g2 * g2;
        }
        ii
    }

    /// Position-vertex normals: area-weighted face normals (the previous normal, or the UV
    /// plane normal, where no face is usable).
    fn update_position_normals(&mut self, mesh: &RestMesh) {
        for q in 0..mesh.n_positions {
            let range = mesh.position_faces_offsets[q] as usize
                ..mesh.position_faces_offsets[q + 1] as usize;
            let mut n = [0.0; 3];
            for &f in &mesh.position_faces[range] {
                let ff = &self.faces[f as usize];
                for c in 0..3 {
                    n[c] += ff.area * ff.n[c];
                }
            }
            let len = norm(n);
            if len > 0.0 && len.is_finite() {
                self.position_normals[q] = n.map(|x| x / len);
            } else if norm(self.position_normals[q]).partial_cmp(&0.0)
                != Some(std::cmp::Ordering::Greater)
            {
                // No usable face this frame and none before: the UV plane normal.
                self.position_normals[q] = [0.0, 0.0, 1.0];
            }
        }
    }

    /// Mesh vertices: Shepard averages of the incident faces' `F`, `I`, `II`, and whether the
    /// vertex forms are the identity (`|II|` scaled by `scale_ii` = R).
    fn update_vertex_averages(&mut self, mesh: &RestMesh, identity_tolerance: f64, scale_ii: f64) {
        for v in 0..mesh.n_vertices() {
            let range =
                mesh.vertex_faces_offsets[v] as usize..mesh.vertex_faces_offsets[v + 1] as usize;
            let mut fsum = [0.0; 6];
            let mut isum = [0.0; 3];
            let mut iisum = [0.0; 3];
            for j in range {
                let w = mesh.vertex_face_weights[j];
                let ff = &self.faces[mesh.vertex_faces[j] as usize];
                for c in 0..3 {
                    fsum[c] += w * ff.f[0][c];
                    fsum[3 + c] += w * ff.f[1][c];
                    isum[c] += w * ff.i[c];
                    iisum[c] += w * ff.ii[c];
                }
            }
            let q = mesh.vertex_position[v] as usize;
            self.vertex_identity[v] =
                forms_are_identity(&isum, &iisum, identity_tolerance, scale_ii);
            self.vertices[v] = VertexFrame {
                p: self.positions[q],
                n: self.position_normals[q],
                f: [[fsum[0], fsum[1], fsum[2]], [fsum[3], fsum[4], fsum[5]]],
                i: isum,
                ii: iisum,
            };
        }
    }

    /// Per face: the skip flag and the kernel polynomials; returns the number of skippable
    /// (identity) faces.
    fn update_face_polys(
        &mut self,
        mesh: &RestMesh,
        identity_tolerance: f64,
        scale_ii: f64,
        poly: PolyOptions,
    ) -> usize {
        let mut identity_faces = 0;
        for (f, t) in mesh.triangles.iter().enumerate() {
            let ff = &self.faces[f];
            let skip = t.iter().all(|&v| self.vertex_identity[v as usize])
                && forms_are_identity(&ff.i, &ff.ii, identity_tolerance, scale_ii);
            identity_faces += usize::from(skip);
            let n = if ff.degenerate {
                self.corner_normal_mean(mesh, t)
            } else {
                ff.n
            };
            self.face_skip[f] = u32::from(skip);
            let vs = t.map(|v| &self.vertices[v as usize]);
            self.face_poly[f] = face_poly(mesh, f, ff, n, vs, poly);
        }
        identity_faces
    }

    /// The normalized mean of the corner normals of triangle `t` (the UV plane normal if it
    /// vanishes): the normal a degenerate face borrows.
    fn corner_normal_mean(&self, mesh: &RestMesh, t: &[u32; 3]) -> [f64; 3] {
        let mut n = [0.0; 3];
        for &v in t {
            let nv = self.position_normals[mesh.vertex_position[v as usize] as usize];
            for c in 0..3 {
                n[c] += nv[c];
            }
        }
        let len = norm(n);
        if len > 0.0 {
            n.map(|x| x / len)
        } else {
            [0.0, 0.0, 1.0]
        }
    }
}

/// Whether `I = [I₁₁, I₁₂, I₂₂]` is the identity and `II` vanishes, entry by entry within
/// `tolerance` (`|II|` scaled by `scale_ii`, the yarn radius).
fn forms_are_identity(i: &[f64; 3], ii: &[f64; 3], tolerance: f64, scale_ii: f64) -> bool {
    (i[0] - 1.0).abs() <= tolerance
        && i[1].abs() <= tolerance
        && (i[2] - 1.0).abs() <= tolerance
        && ii.iter().all(|x| x.abs() * scale_ii <= tolerance)
}

/// Expands the face polynomials of [`FacePoly`] (see there) for face `f`.
fn face_poly<T: Real>(
    mesh: &RestMesh,
    f: usize,
    ff: &FaceFrame,
    nf: [f64; 3],
    vs: [&VertexFrame; 3],
    poly: PolyOptions,
) -> FacePoly<T> {
    let m = mesh.dm_inv[f];
    // Barycentric gradients: b₁ = m₀d₁ + m₁d₂, b₂ = m₂d₁ + m₃d₂, b₀ = 1 − b₁ − b₂.
    let gamma = [[-m[0] - m[2], -m[1] - m[3]], [m[0], m[1]], [m[2], m[3]]];
    // Linear interpolation q(d) = q₀ + Σᵢ qᵢ γᵢ·d of per-vertex values.
    let lin = |q: [[f64; 3]; 3]| -> ([f64; 3], [f64; 6]) {
        let mut g = [0.0; 6];
        for i in 0..3 {
            for c in 0..3 {
                g[c] += q[i][c] * gamma[i][0];
                g[3 + c] += q[i][c] * gamma[i][1];
            }
        }
        (q[0], g)
    };
    let t = mesh.triangles[f];
    let u0 = mesh.vertex_uv[t[0] as usize];
    let e = t.map(|v| {
        let u = mesh.vertex_uv[v as usize];
        [u[0] - u0[0], u[1] - u0[1]]
    });
    let (x0, xl, xq, n0, nl) = if poly.phong {
        // yᵢ(d) = aᵢ + Fᵢ d with aᵢ = xᵢ − Fᵢ Eᵢ;  x(d) = Σ (βᵢ + γᵢ·d)(aᵢ + Fᵢ d), β = (1, 0, 0).
        let a: [[f64; 3]; 3] = [0, 1, 2].map(|i| {
            let v = vs[i];
            [0, 1, 2].map(|c| v.p[c] - v.f[0][c] * e[i][0] - v.f[1][c] * e[i][1])
        });
        let mut xl = [0.0; 6];
        let mut xq = [0.0; 9];
        for c in 0..3 {
            xl[c] = vs[0].f[0][c];
            xl[3 + c] = vs[0].f[1][c];
            for i in 0..3 {
                xl[c] += a[i][c] * gamma[i][0];
                xl[3 + c] += a[i][c] * gamma[i][1];
                let fi = vs[i].f;
                xq[c] += gamma[i][0] * fi[0][c];
                xq[3 + c] += gamma[i][0] * fi[1][c] + gamma[i][1] * fi[0][c];
                xq[6 + c] += gamma[i][1] * fi[1][c];
            }
        }
        let (n0, nl) = lin(vs.map(|v| v.n));
        (a[0], xl, xq, n0, nl)
    } else {
        let p0 = vs[0].p;
        let xl = [
            ff.f[0][0], ff.f[0][1], ff.f[0][2], ff.f[1][0], ff.f[1][1], ff.f[1][2],
        ];
        (p0, xl, [0.0; 9], nf, [0.0; 6])
    };
    let ((i0, il), (ii0, iil)) = if poly.interpolate_forms {
        (lin(vs.map(|v| v.i)), lin(vs.map(|v| v.ii)))
    } else {
        ((ff.i, [0.0; 6]), (ff.ii, [0.0; 6]))
    };
    FacePoly {
        x0: x0.map(T::from_f64),
        xl: xl.map(T::from_f64),
        xq: xq.map(T::from_f64),
        n0: n0.map(T::from_f64),
        nl: nl.map(T::from_f64),
        i0: i0.map(T::from_f64),
        il: il.map(T::from_f64),
        ii0: ii0.map(T::from_f64),
        iil: iil.map(T::from_f64),
        nf: nf.map(T::from_f64),
    }
}
