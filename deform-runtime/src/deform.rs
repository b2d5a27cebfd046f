//! The per-frame deformation on the CPU (paper 004 Algorithm 1, lines 4–13).
//!
//! [`Deformer::frame`] runs the mesh stage ([`crate::mesh::FrameGeometry::update`], which also
//! expands every face into the polynomials of [`crate::mesh::FacePoly`]) and then, in
//! parallel over yarn vertices (rayon, chunks of [`CHUNK`]), the per-vertex kernel
//! ([`vertex_strain`] → database lookup → [`vertex_map`]; [`deform_vertex`] chains them for
//! one vertex, and [`crate::lanes`] runs the same arithmetic on batches of eight vertices in
//! SIMD lanes, bit for bit):
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
use yarn_pattern::tile::Tile;

use crate::database::RuntimeDatabase;
use crate::embed::Embedding;
use crate::error::{DeformError, Result};
use crate::lanes::each_vertex;
use crate::mesh::{FrameGeometry, MeshCounters, PolyOptions, RestMesh};
use crate::real::Real;

pub use crate::kernel::{
    DeformOptions, Displacement, FrameStats, KernelInputs, MIN_EIGENVALUE, VertexCounters,
    YarnOutput, clamp_eigenvalues, deform_vertex, strains, vertex_map, vertex_strain,
};

/// Yarn vertices per rayon task.
pub const CHUNK: usize = 8192;

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
            twist: vec![T::zero(); n],
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
        Ok(self.map_chunks(|input, e, start, out, counters| {
            each_vertex(e, start, 0, out, counters, |f, du, dv, h, v, counters| {
                let dq =
                    crate::bending::explicit_displacement(input, bending, f, du, dv, v, counters);
                vertex_map(input, f, du, dv, h, v, dq)
            });
        }))
    }

    /// The per-vertex stage: in `f32`, the SIMD kernel of [`crate::lanes`]; in `f64` (the
    /// reference precision), [`deform_vertex`] vertex by vertex. Both give the same bits for
    /// the same inputs in `f32`.
    fn vertex_stage(&mut self) -> VertexCounters {
        if let Some(d) = (self as &mut dyn std::any::Any).downcast_mut::<Deformer<f32>>() {
            return d.map_chunks(crate::lanes::run);
        }
        self.map_chunks(|input, e, start, out, counters| {
            each_vertex(e, start, 0, out, counters, |f, du, dv, h, v, counters| {
                deform_vertex(input, f, du, dv, h, v, counters)
            });
        })
    }

    /// Runs `chunk(input, embedding, start, [x, y, z, twist], counters)` on the output in
    /// parallel chunks of [`CHUNK`] vertices (`start`: the chunk's first vertex) and sums the
    /// counters (`processed` set to the chunk length).
    fn map_chunks(
        &mut self,
        chunk: impl Fn(&KernelInputs<T>, &Embedding<T>, usize, &mut [&mut [T]; 4], &mut VertexCounters)
        + Sync,
    ) -> VertexCounters {
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
            .map(|(c, (((xs, ys), zs), ts))| {
                let mut counters = VertexCounters::default();
                let n = xs.len();
                chunk(&input, e, c * CHUNK, &mut [xs, ys, zs, ts], &mut counters);
                counters.processed = n;
                counters
            })
            .reduce(VertexCounters::default, |a, b| a + b)
    }
}
