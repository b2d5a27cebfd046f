//! The per-frame deformation on the CPU (paper 004 Algorithm 1, lines 4–13).
//!
//! [`Deformer::frame`] runs the mesh stage ([`crate::mesh::FrameGeometry::update`], which also
//! expands every face into the polynomials of [`crate::mesh::FacePoly`]) and then, in
//! parallel over yarn vertices (rayon, chunks of [`CHUNK`], batches of [`BATCH`] vertices per
//! phase), the per-vertex kernel ([`vertex_strain`] → database lookup → [`vertex_map`];
//! [`deform_vertex`] chains them for one vertex):
//!
//! 1. interpolate `I`, `II` from the triangle's corners (linear in the UV offset; or the face's
//!    values when [`DeformOptions::interpolate_forms`] is off);
//! 2. linearized bending `I(h) = I − 2h·II` with `h = X₃` (Eq. 7 / 22);
//! 3. compression clamping: eigenvalues of `I(h)` raised to at least `λmin` (§4.3); with
//!    clamping off they are still raised to [`MIN_EIGENVALUE`] so that inverted or collapsed
//!    faces give finite strains (counted);
//! 4. strains `sx = √I₁₁ − 1`, `sa = I₁₂/√(I₁₁I₂₂)`, `sy = √I₂₂ − 1` (Eq. 4);
//! 5. trilinear database lookup with nearest-sample clamping (§4.4);
//! 6. displacement in material space `X̂ = X + ΔQ` (Eq. 8);
//! 7. world mapping `x = φ(X̂₁, X̂₂) + X̂₃ n(X̂₁, X̂₂)` (Eq. 9) with Phong deformation
//!    `φ(X) = Σᵢ bᵢ(X) (xᵢ + Fᵢ (X − Uᵢ))` (James 2020) and the normalized interpolated vertex
//!    normal; or, when [`DeformOptions::phong`] is off, the affine map of the face and its
//!    normal. The twist is `θ = Θ + Δθ`.
//!
//! Work a frame does not need is skipped: faces whose corners all have `I = Id` and `II = 0`
//! (within [`DeformOptions::identity_tolerance`]) use the database's zero-strain displacement
//! of the pattern vertex instead of a lookup, and a frame whose input positions equal the
//! previous frame's (bit for bit) reuses the previous output entirely.
//!
//! The kernel never writes a non-finite value: if a result is not finite the vertex keeps its
//! previous output (initially its rest material position), and the event is counted.
//! No allocation happens per frame; results do not depend on the number of threads.

use std::time::Instant;

use rayon::prelude::*;
use sim_periodic::tile::Tile;

use crate::database::RuntimeDatabase;
use crate::embed::Embedding;
use crate::error::{DeformError, Result};
use crate::mesh::{FacePoly, FrameGeometry, MeshCounters, PolyOptions, RestMesh};
use crate::real::Real;

/// Yarn vertices per rayon task.
pub const CHUNK: usize = 8192;

/// Lower bound on the eigenvalues of `I(h)` when compression clamping is off: keeps strains
/// finite for collapsed or inverted faces (unitless; `√1e-6 − 1 ≈ −0.999`, below every
/// database range, so the lookup clamps to the most compressed sample anyway).
pub const MIN_EIGENVALUE: f64 = 1e-6;

/// Switches and parameters of the per-frame pipeline; every step can be turned off for
/// comparisons.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DeformOptions {
    /// Apply database displacements (off: naive embedding). Default on.
    pub displacement: bool,
    /// Linearized bending `I(h) = I − 2h·II` (Eq. 7). Default on.
    pub linearized_bending: bool,
    /// Compression clamping of the eigenvalues of `I(h)` (§4.3). Default on.
    pub clamp_compression: bool,
    /// Lower eigenvalue bound λmin of compression clamping (unitless, λ < 1 is compression).
    /// Default 0.8 (paper's default).
    pub lambda_min: f64,
    /// Interpolate vertex `I`, `II` (Shepard-distributed) to yarn vertices; off: per-face
    /// constant forms. Default on.
    pub interpolate_forms: bool,
    /// Phong deformation and interpolated normals for the world mapping; off: piecewise
    /// affine embedding with face normals. Default on.
    pub phong: bool,
    /// Skip lookups on faces with identity strain and no curvature. Default on.
    pub skip_identity: bool,
    /// Reuse the previous output when the input positions did not change. Default on.
    pub skip_static: bool,
    /// Tolerance of the identity test on `|I − Id|` entries and `|II|·R` (unitless).
    /// Default 1e-6.
    pub identity_tolerance: f64,
}

impl Default for DeformOptions {
    fn default() -> Self {
        Self {
            displacement: true,
            linearized_bending: true,
            clamp_compression: true,
            lambda_min: 0.8,
            interpolate_forms: true,
            phong: true,
            skip_identity: true,
            skip_static: true,
            identity_tolerance: 1e-6,
        }
    }
}

impl DeformOptions {
    /// Checks parameter ranges.
    pub fn validate(&self) -> Result<()> {
        if !(self.lambda_min.is_finite() && self.lambda_min > 0.0) {
            return Err(DeformError::Option {
                name: "lambda_min",
                message: format!("expected a finite value > 0, found {}", self.lambda_min),
            });
        }
        if !(self.identity_tolerance.is_finite() && self.identity_tolerance >= 0.0) {
            return Err(DeformError::Option {
                name: "identity_tolerance",
                message: format!(
                    "expected a finite value ≥ 0, found {}",
                    self.identity_tolerance
                ),
            });
        }
        Ok(())
    }
}

/// Per-vertex counters of a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct VertexCounters {
    /// Vertices processed.
    pub processed: usize,
    /// Vertices whose lookup was skipped (identity face).
    pub lookups_skipped: usize,
    /// Vertices whose `I(h)` eigenvalues were raised (by λmin or [`MIN_EIGENVALUE`]).
    pub clamped: usize,
    /// Vertices whose strains were not finite (zero-strain displacement used).
    pub nonfinite_strain: usize,
    /// Vertices whose output was not finite (previous output kept).
    pub nonfinite_output: usize,
}

impl std::ops::Add for VertexCounters {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            processed: self.processed + o.processed,
            lookups_skipped: self.lookups_skipped + o.lookups_skipped,
            clamped: self.clamped + o.clamped,
            nonfinite_strain: self.nonfinite_strain + o.nonfinite_strain,
            nonfinite_output: self.nonfinite_output + o.nonfinite_output,
        }
    }
}

/// Statistics of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FrameStats {
    /// Whether the frame was static (previous output reused, nothing computed).
    pub static_frame: bool,
    /// Mesh-stage counters.
    pub mesh: MeshCounters,
    /// Per-vertex counters.
    pub vertices: VertexCounters,
    /// Mesh stage wall time (s): face and vertex forms, normals.
    pub mesh_seconds: f64,
    /// Per-vertex stage wall time (s): strains, lookup, displacement, mapping.
    pub vertex_seconds: f64,
}

/// Yarn output, structure-of-arrays.
#[derive(Clone, Debug, Default)]
pub struct YarnOutput<T> {
    /// World x (m).
    pub x: Vec<T>,
    /// World y (m).
    pub y: Vec<T>,
    /// World z (m).
    pub z: Vec<T>,
    /// Twist θ (rad) of the edge starting at each vertex.
    pub twist: Vec<T>,
}

/// Read-only inputs of the per-vertex kernel.
#[derive(Clone, Copy, Debug)]
pub struct KernelInputs<'a, T> {
    /// Per-face polynomials of the frame.
    pub faces: &'a [FacePoly<T>],
    /// Per-face skip flags of the frame.
    pub skip: &'a [u32],
    /// The database.
    pub db: &'a RuntimeDatabase<T>,
    /// Zero-strain displacement per pattern vertex.
    pub rest_dq: &'a [[T; 4]],
    /// Rest twist Θ per pattern vertex (rad).
    pub twists: &'a [T],
    /// Options.
    pub options: &'a DeformOptions,
    /// `λmin` (or [`MIN_EIGENVALUE`] with clamping off) in `T`.
    pub eigen_floor: T,
}

/// Clamps the eigenvalues of the symmetric 2 × 2 `[a, b; b, c]` to at least `floor`;
/// returns the clamped matrix and whether anything changed.
#[inline(always)]
pub fn clamp_eigenvalues<T: Real>(i: [T; 3], floor: T) -> ([T; 3], bool) {
    let [a, b, c] = i;
    let half = T::from_f64(0.5);
    let m = half * (a + c);
    let h = half * (a - c);
    let d = (h * h + b * b).sqrt();
    let l2 = m - d;
    if l2 >= floor {
        return (i, false);
    }
    let l1 = (m + d).max(floor);
    if d > T::ZERO {
        // P₁ = (I − λ₂ Id) / (λ₁ − λ₂), the projector on the larger eigenvector.
        let inv = T::ONE / (d + d);
        let (p_a, p_b, p_c) = ((a - l2) * inv, b * inv, (c - l2) * inv);
        let k = l1 - floor;
        ([floor + k * p_a, k * p_b, floor + k * p_c], true)
    } else {
        ([floor, T::ZERO, floor], true)
    }
}

/// Strains `(sx, sa, sy)` of a first fundamental form `[I₁₁, I₁₂, I₂₂]` (Eq. 4).
#[inline(always)]
pub fn strains<T: Real>(i: [T; 3]) -> [T; 3] {
    let (a, c) = (i[0].sqrt(), i[2].sqrt());
    [a - T::ONE, i[1] / (a * c), c - T::ONE]
}

/// What the first phase of the kernel decided for one vertex.
#[derive(Clone, Copy, Debug)]
pub enum Displacement<T> {
    /// Known displacement `(Δx, Δy, Δz, Δθ)` (off, skipped, or fallback).
    Known([T; 4]),
    /// Look up the database at these strains `(sx, sa, sy)`.
    Lookup([T; 3]),
}

/// Phase 1 of the kernel for one yarn vertex (steps 1–4 of the module docs): the strains to
/// look up, or the displacement when no lookup is needed. `(du, dv)` is the UV offset from
/// the triangle's first corner (m), `height` is `X₃` (m).
#[inline(always)]
pub fn vertex_strain<T: Real>(
    input: &KernelInputs<'_, T>,
    triangle: u32,
    du: T,
    dv: T,
    height: T,
    tile_vertex: u32,
    counters: &mut VertexCounters,
) -> Displacement<T> {
    let o = input.options;
    if !o.displacement {
        return Displacement::Known([T::ZERO; 4]);
    }
    if o.skip_identity && input.skip[triangle as usize] != 0 {
        counters.lookups_skipped += 1;
        return Displacement::Known(input.rest_dq[tile_vertex as usize]);
    }
    let fp = &input.faces[triangle as usize];
    let mut i = [T::ZERO; 3];
    for c in 0..3 {
        i[c] = fp.i0[c] + fp.il[c] * du + fp.il[3 + c] * dv;
    }
    if o.linearized_bending {
        let two_h = height + height;
        for c in 0..3 {
            let ii = fp.ii0[c] + fp.iil[c] * du + fp.iil[3 + c] * dv;
            i[c] = i[c] - two_h * ii;
        }
    }
    let (i, clamped) = clamp_eigenvalues(i, input.eigen_floor);
    counters.clamped += usize::from(clamped);
    let s = strains(i);
    if s[0].is_finite() && s[1].is_finite() && s[2].is_finite() {
        Displacement::Lookup(s)
    } else {
        counters.nonfinite_strain += 1;
        Displacement::Known(input.rest_dq[tile_vertex as usize])
    }
}

/// Phase 3 of the kernel (steps 6–7): displaced material point mapped to world space; returns
/// the position (m) and the twist θ = Θ + Δθ (rad).
#[inline(always)]
pub fn vertex_map<T: Real>(
    input: &KernelInputs<'_, T>,
    triangle: u32,
    du: T,
    dv: T,
    height: T,
    tile_vertex: u32,
    dq: [T; 4],
) -> ([T; 3], T) {
    let fp = &input.faces[triangle as usize];
    let (u, v, h) = (du + dq[0], dv + dq[1], height + dq[2]);
    let (uu, uv, vv) = (u * u, u * v, v * v);
    let mut x = [T::ZERO; 3];
    let mut n = [T::ZERO; 3];
    for c in 0..3 {
        x[c] = fp.x0[c]
            + fp.xl[c] * u
            + fp.xl[3 + c] * v
            + fp.xq[c] * uu
            + fp.xq[3 + c] * uv
            + fp.xq[6 + c] * vv;
        n[c] = fp.n0[c] + fp.nl[c] * u + fp.nl[3 + c] * v;
    }
    let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    let n = if len2 > T::ZERO {
        let inv = T::ONE / len2.sqrt();
        [n[0] * inv, n[1] * inv, n[2] * inv]
    } else {
        fp.nf
    };
    for c in 0..3 {
        x[c] += h * n[c];
    }
    (x, input.twists[tile_vertex as usize] + dq[3])
}

/// One yarn vertex through all phases (the reference form of the batched loop in
/// [`Deformer::frame`]).
pub fn deform_vertex<T: Real>(
    input: &KernelInputs<'_, T>,
    triangle: u32,
    du: T,
    dv: T,
    height: T,
    tile_vertex: u32,
    counters: &mut VertexCounters,
) -> ([T; 3], T) {
    let dq = match vertex_strain(input, triangle, du, dv, height, tile_vertex, counters) {
        Displacement::Known(dq) => dq,
        Displacement::Lookup(s) => input.db.lookup(tile_vertex as usize, s),
    };
    vertex_map(input, triangle, du, dv, height, tile_vertex, dq)
}

/// Yarn vertices per batch of the CPU loop: each phase runs over a batch before the next, so
/// the long dependency chains of independent vertices (square roots, divisions, lookups)
/// overlap in the out-of-order core.
pub const BATCH: usize = 8;

/// The CPU deformer: everything needed to deform one embedded pattern per frame.
#[derive(Clone, Debug)]
pub struct Deformer<T> {
    mesh: RestMesh,
    embedding: Embedding<T>,
    db: RuntimeDatabase<T>,
    rest_dq: Vec<[T; 4]>,
    twists: Vec<T>,
    radius: f64,
    options: DeformOptions,
    geometry: FrameGeometry<T>,
    output: YarnOutput<T>,
    previous_input: Vec<[f64; 3]>,
    has_previous: bool,
}

impl<T: Real> Deformer<T> {
    /// A deformer for `embedding` (built on `mesh` from `tile`) with database `db`.
    pub fn new(
        mesh: RestMesh,
        tile: &Tile,
        embedding: Embedding<T>,
        db: RuntimeDatabase<T>,
        options: DeformOptions,
    ) -> Result<Self> {
        options.validate()?;
        if db.n_vertices() != tile.positions.len() {
            return Err(DeformError::VertexCountMismatch {
                database: db.n_vertices(),
                pattern: tile.positions.len(),
            });
        }
        let n = embedding.len();
        let output = YarnOutput {
            x: embedding
                .material
                .iter()
                .map(|m| T::from_f64(m[0]))
                .collect(),
            y: embedding
                .material
                .iter()
                .map(|m| T::from_f64(m[1]))
                .collect(),
            z: embedding
                .material
                .iter()
                .map(|m| T::from_f64(m[2]))
                .collect(),
            twist: vec![T::ZERO; n],
        };
        Ok(Self {
            geometry: FrameGeometry::new(&mesh),
            rest_dq: db.rest_displacements(),
            twists: tile.twists.iter().map(|&t| T::from_f64(t)).collect(),
            radius: tile.radius,
            previous_input: vec![[0.0; 3]; mesh.n_positions],
            has_previous: false,
            mesh,
            embedding,
            db,
            options,
            output,
        })
    }

    /// The options.
    pub fn options(&self) -> &DeformOptions {
        &self.options
    }

    /// Changes the options (forces recomputation on the next frame).
    pub fn set_options(&mut self, options: DeformOptions) -> Result<()> {
        options.validate()?;
        self.options = options;
        self.has_previous = false;
        Ok(())
    }

    /// The rest mesh.
    pub fn mesh(&self) -> &RestMesh {
        &self.mesh
    }

    /// The embedding.
    pub fn embedding(&self) -> &Embedding<T> {
        &self.embedding
    }

    /// The database.
    pub fn database(&self) -> &RuntimeDatabase<T> {
        &self.db
    }

    /// The mesh-stage buffers of the last frame.
    pub fn geometry(&self) -> &FrameGeometry<T> {
        &self.geometry
    }

    /// Zero-strain displacements per pattern vertex.
    pub fn rest_displacements(&self) -> &[[T; 4]] {
        &self.rest_dq
    }

    /// Rest twists per pattern vertex.
    pub fn twists(&self) -> &[T] {
        &self.twists
    }

    /// The output of the last frame.
    pub fn output(&self) -> &YarnOutput<T> {
        &self.output
    }

    /// The eigenvalue floor the kernel uses with the current options.
    pub fn eigen_floor(&self) -> T {
        T::from_f64(if self.options.clamp_compression {
            self.options.lambda_min
        } else {
            MIN_EIGENVALUE
        })
    }

    /// Runs the mesh stage only (used by the GPU back end, which runs the vertex stage).
    pub fn update_mesh(&mut self, positions: &[[f64; 3]]) -> Result<MeshCounters> {
        if positions.len() != self.mesh.n_positions {
            return Err(DeformError::Option {
                name: "positions",
                message: format!(
                    "expected {} vertex positions (as in the rest mesh), found {}",
                    self.mesh.n_positions,
                    positions.len()
                ),
            });
        }
        Ok(self.geometry.update(
            &self.mesh,
            positions,
            self.options.identity_tolerance,
            self.radius,
            PolyOptions {
                phong: self.options.phong,
                interpolate_forms: self.options.interpolate_forms,
            },
        ))
    }

    /// Deforms the pattern for one frame of mesh `positions` (one per OBJ position vertex, m).
    pub fn frame(&mut self, positions: &[[f64; 3]]) -> Result<FrameStats> {
        let is_static = self.options.skip_static
            && self.has_previous
            && positions.len() == self.previous_input.len()
            && positions
                .iter()
                .zip(&self.previous_input)
                .all(|(a, b)| a.map(f64::to_bits) == b.map(f64::to_bits));
        if is_static {
            return Ok(FrameStats {
                static_frame: true,
                ..FrameStats::default()
            });
        }
        let t0 = Instant::now();
        let mesh_counters = self.update_mesh(positions)?;
        self.previous_input.copy_from_slice(positions);
        self.has_previous = true;
        let t1 = Instant::now();
        let vertices = self.vertex_stage();
        let t2 = Instant::now();
        Ok(FrameStats {
            static_frame: false,
            mesh: mesh_counters,
            vertices,
            mesh_seconds: (t1 - t0).as_secs_f64(),
            vertex_seconds: (t2 - t1).as_secs_f64(),
        })
    }

    /// Deforms the pattern for one frame with the explicit bending model of Appendix C
    /// (Eq. 19, [`crate::bending`]) instead of linearized bending: same mesh stage, options
    /// (`linearized_bending` is ignored) and non-finite handling as [`Deformer::frame`], but
    /// no static-frame skipping (the next [`Deformer::frame`] recomputes too). `bending` must
    /// belong to this deformer's pattern (same vertex count; checked).
    pub fn frame_explicit(
        &mut self,
        positions: &[[f64; 3]],
        bending: &crate::bending::BendingDatabase<T>,
    ) -> Result<FrameStats> {
        let t0 = Instant::now();
        let mesh_counters = self.update_mesh(positions)?;
        self.has_previous = false;
        let t1 = Instant::now();
        let vertices = self.explicit_stage(bending)?;
        let t2 = Instant::now();
        Ok(FrameStats {
            static_frame: false,
            mesh: mesh_counters,
            vertices,
            mesh_seconds: (t1 - t0).as_secs_f64(),
            vertex_seconds: (t2 - t1).as_secs_f64(),
        })
    }

    fn explicit_stage(
        &mut self,
        bending: &crate::bending::BendingDatabase<T>,
    ) -> Result<VertexCounters> {
        if bending.n_vertices() != self.db.n_vertices() {
            return Err(DeformError::VertexCountMismatch {
                database: bending.n_vertices(),
                pattern: self.db.n_vertices(),
            });
        }
        let input = KernelInputs {
            faces: &self.geometry.face_poly,
            skip: &self.geometry.face_skip,
            db: &self.db,
            rest_dq: &self.rest_dq,
            twists: &self.twists,
            options: &self.options,
            eigen_floor: self.eigen_floor(),
        };
        let e = &self.embedding;
        let out = &mut self.output;
        Ok(out
            .x
            .par_chunks_mut(CHUNK)
            .zip(out.y.par_chunks_mut(CHUNK))
            .zip(out.z.par_chunks_mut(CHUNK))
            .zip(out.twist.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(chunk, (((xs, ys), zs), ts))| {
                let start = chunk * CHUNK;
                let mut counters = VertexCounters::default();
                for j in 0..xs.len() {
                    let k = start + j;
                    let (f, du, dv, h, v) = (
                        e.triangle[k],
                        e.du[k],
                        e.dv[k],
                        e.height[k],
                        e.tile_vertex[k],
                    );
                    let dq = crate::bending::explicit_displacement(
                        &input,
                        bending,
                        f,
                        du,
                        dv,
                        v,
                        &mut counters,
                    );
                    let (x, t) = vertex_map(&input, f, du, dv, h, v, dq);
                    if x.iter().all(|c| c.is_finite()) && t.is_finite() {
                        xs[j] = x[0];
                        ys[j] = x[1];
                        zs[j] = x[2];
                        ts[j] = t;
                    } else {
                        counters.nonfinite_output += 1;
                    }
                }
                counters.processed = xs.len();
                counters
            })
            .reduce(VertexCounters::default, |a, b| a + b))
    }

    fn vertex_stage(&mut self) -> VertexCounters {
        let input = KernelInputs {
            faces: &self.geometry.face_poly,
            skip: &self.geometry.face_skip,
            db: &self.db,
            rest_dq: &self.rest_dq,
            twists: &self.twists,
            options: &self.options,
            eigen_floor: self.eigen_floor(),
        };
        let e = &self.embedding;
        let out = &mut self.output;
        out.x
            .par_chunks_mut(CHUNK)
            .zip(out.y.par_chunks_mut(CHUNK))
            .zip(out.z.par_chunks_mut(CHUNK))
            .zip(out.twist.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(chunk, (((xs, ys), zs), ts))| {
                let start = chunk * CHUNK;
                let mut counters = VertexCounters::default();
                let mut phase = [Displacement::Known([T::ZERO; 4]); BATCH];
                let mut dq = [[T::ZERO; 4]; BATCH];
                for b0 in (0..xs.len()).step_by(BATCH) {
                    let len = BATCH.min(xs.len() - b0);
                    for j in 0..len {
                        let k = start + b0 + j;
                        phase[j] = vertex_strain(
                            &input,
                            e.triangle[k],
                            e.du[k],
                            e.dv[k],
                            e.height[k],
                            e.tile_vertex[k],
                            &mut counters,
                        );
                    }
                    for j in 0..len {
                        let k = start + b0 + j;
                        dq[j] = match phase[j] {
                            Displacement::Known(d) => d,
                            Displacement::Lookup(s) => {
                                input.db.lookup(e.tile_vertex[k] as usize, s)
                            }
                        };
                    }
                    for j in 0..len {
                        let k = start + b0 + j;
                        let (x, t) = vertex_map(
                            &input,
                            e.triangle[k],
                            e.du[k],
                            e.dv[k],
                            e.height[k],
                            e.tile_vertex[k],
                            dq[j],
                        );
                        if x.iter().all(|c| c.is_finite()) && t.is_finite() {
                            xs[b0 + j] = x[0];
                            ys[b0 + j] = x[1];
                            zs[b0 + j] = x[2];
                            ts[b0 + j] = t;
                        } else {
                            counters.nonfinite_output += 1;
                        }
                    }
                }
                counters.processed = xs.len();
                counters
            })
            .reduce(VertexCounters::default, |a, b| a + b)
    }
}
