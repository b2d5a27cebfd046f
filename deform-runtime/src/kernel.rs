//! The per-vertex deformation kernel shared by the linearized model ([`crate::deform`]) and
//! the explicit bending model ([`crate::bending`]): options, counters, clamped strains of
//! `I(h)`, the database lookup and the map of one yarn vertex (paper 004 §4, Eqs. 7–17).

use crate::database::RuntimeDatabase;
use crate::error::{DeformError, Result};
use crate::mesh::{FacePoly, MeshCounters};
use crate::real::Real;

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
    if d > T::zero() {
        // P₁ = (I − λ₂ Id) / (λ₁ − λ₂), the projector on the larger eigenvector.
        let inv = T::one() / (d + d);
        let (p_a, p_b, p_c) = ((a - l2) * inv, b * inv, (c - l2) * inv);
        let k = l1 - floor;
        ([floor + k * p_a, k * p_b, floor + k * p_c], true)
    } else {
        ([floor, T::zero(), floor], true)
    }
}

/// Strains `(sx, sa, sy)` of a first fundamental form `[I₁₁, I₁₂, I₂₂]` (Eq. 4).
#[inline(always)]
pub fn strains<T: Real>(i: [T; 3]) -> [T; 3] {
    let (a, c) = (i[0].sqrt(), i[2].sqrt());
    [a - T::one(), i[1] / (a * c), c - T::one()]
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
        return Displacement::Known([T::zero(); 4]);
    }
    if o.skip_identity && input.skip[triangle as usize] != 0 {
        counters.lookups_skipped += 1;
        return Displacement::Known(input.rest_dq[tile_vertex as usize]);
    }
    let fp = &input.faces[triangle as usize];
    let mut i = [T::zero(); 3];
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
    let mut x = [T::zero(); 3];
    let mut n = [T::zero(); 3];
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
    let n = if len2 > T::zero() {
        let inv = T::one() / len2.sqrt();
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
/// [`crate::deform::Deformer::frame`]).
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
