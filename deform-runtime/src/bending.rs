//! The explicit bending model of paper 004 Appendix C (Eq. 19), the reference the linearized
//! model `I(h) = I − 2h·II` (Eq. 22–23, [`crate::deform`]) is compared against.
//!
//! Tileability allows only singly curved tiles, so displacements are sampled for in-plane
//! strain combined with bending along either in-plane axis: `ΔQ_X1(s, κ)` and `ΔQ_X2(s, κ)`,
//! 4-D databases over `(sx, sa, sy, κ)` ([`BendingDatabase`]). Here "bending along X1 by κ"
//! means the sample of `sim-periodic` under `Coarse::from_strain(s).bent(0, κ)`: the tile
//! stretched by `F = √I` and rolled onto a cylinder of curvature κ (1/m) along the deformed x
//! axis, centre of curvature on the `+z` (normal) side.
//!
//! Per yarn vertex the model takes `I` and `II` (interpolated as for the linearized model,
//! `I` compression-clamped), the strains `s` of `I`, and the curvature tensor in the deformed,
//! orthonormal in-plane coordinates `(a, b) = F X` ([`curvature_tensor`]):
//! `K = F⁻¹ II F⁻¹` with `F = √I`. With the eigenvalues λ₁, λ₂ of `K` and `c` the cosine of
//! the angle between the deformed x axis and the eigenvector of λ₁ (Eq. 19):
//!
//! ```text
//! ΔQ(s, II) = c² ΔQ_X1(s, λ₁) + (1 − c²) ΔQ_X1(s, λ₂)
//!           + c² ΔQ_X2(s, λ₂) + (1 − c²) ΔQ_X2(s, λ₁) − ΔQ_X1(s, 0),
//! ```
//!
//! five 4-D lookups (each two trilinear lookups and a linear interpolation in κ, with the same
//! nearest-sample clamping as the 3-D database), against one 3-D lookup for the linearized
//! model. It reproduces the samples exactly when the bend is along X1 or X2, and for data
//! linear in κ it equals `ΔQ(s) + K₁₁ ∂_κΔQ_X1 + K₂₂ ∂_κΔQ_X2` for any orientation.
//!
//! [`crate::Deformer::frame_explicit`] runs a frame with this model on the CPU.

use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

use crate::database::{RuntimeDatabase, locate};
use crate::error::{DeformError, Result};
use crate::kernel::{KernelInputs, VertexCounters, clamp_eigenvalues, strains};
use crate::real::Real;

/// The two 4-D databases `ΔQ_X1(s, κ)` and `ΔQ_X2(s, κ)` of the explicit bending model, each
/// stored as one 3-D [`RuntimeDatabase`] per curvature sample.
#[derive(Clone, Debug)]
pub struct BendingDatabase<T> {
    /// Curvature samples κ (1/m), strictly increasing, shared by both directions.
    kappas: Vec<T>,
    /// `along[axis][k]`: the database bent along `axis` by `kappas[k]`.
    along: [Vec<RuntimeDatabase<T>>; 2],
}

impl<T: Real> BendingDatabase<T> {
    /// Builds the model from `kappas` (1/m, at least two, strictly increasing, finite) and per
    /// curvature sample one database bent along x (`along_x[k]`) and one along y
    /// (`along_y[k]`), all with the same strain axes and checked against `tile` like the 3-D
    /// database.
    pub fn new(
        tile: &Tile,
        kappas: &[f64],
        along_x: &[Database],
        along_y: &[Database],
    ) -> Result<Self> {
        let bad = |message: String| DeformError::Option {
            name: "bending database",
            message,
        };
        if kappas.len() < 2
            || !kappas.iter().all(|k| k.is_finite())
            || !kappas.windows(2).all(|w| w[0] < w[1])
        {
            return Err(bad(format!(
                "expected at least two finite, strictly increasing curvatures, found {kappas:?}"
            )));
        }
        if along_x.len() != kappas.len() || along_y.len() != kappas.len() {
            return Err(bad(format!(
                "expected one database per curvature sample ({}), found {} along x and {} along y",
                kappas.len(),
                along_x.len(),
                along_y.len()
            )));
        }
        let axes = &along_x[0].axes;
        if let Some((k, db)) = along_x
            .iter()
            .chain(along_y)
            .enumerate()
            .find(|(_, db)| &db.axes != axes)
        {
            return Err(bad(format!(
                "database {k} has strain axes {:?}, the first has {axes:?}",
                db.axes
            )));
        }
        let convert = |dbs: &[Database]| -> Result<Vec<RuntimeDatabase<T>>> {
            dbs.iter()
                .map(|db| RuntimeDatabase::new(db, tile))
                .collect()
        };
        Ok(Self {
            kappas: kappas.iter().map(|&k| T::from_f64(k)).collect(),
            along: [convert(along_x)?, convert(along_y)?],
        })
    }

    /// Curvature samples κ (1/m).
    pub fn kappas(&self) -> &[T] {
        &self.kappas
    }

    /// Pattern vertices.
    pub fn n_vertices(&self) -> usize {
        self.along[0][0].n_vertices()
    }

    /// Memory of the stored displacements (bytes).
    pub fn memory_bytes(&self) -> usize {
        self.along
            .iter()
            .flatten()
            .map(|db| db.memory_bytes())
            .sum()
    }

    /// `ΔQ_axis(s, κ)` of pattern vertex `vertex` (axis 0 = X1, 1 = X2): trilinear in `s`,
    /// linear in κ, clamped to the sampled ranges.
    #[inline(always)]
    pub fn lookup(&self, axis: usize, vertex: usize, s: [T; 3], kappa: T) -> [T; 4] {
        let dbs = &self.along[axis];
        self.lookup_weighted(dbs, vertex, &dbs[0].weights(s), kappa)
    }

    #[inline(always)]
    fn lookup_weighted(
        &self,
        dbs: &[RuntimeDatabase<T>],
        vertex: usize,
        w: &[crate::database::AxisWeight<T>; 3],
        kappa: T,
    ) -> [T; 4] {
        let wk = locate(&self.kappas, kappa);
        let a = dbs[wk.lo as usize].interpolate(vertex, w);
        let b = dbs[wk.hi as usize].interpolate(vertex, w);
        let mut out = [T::zero(); 4];
        for c in 0..4 {
            out[c] = (T::one() - wk.t) * a[c] + wk.t * b[c];
        }
        out
    }

    /// Eq. 19: the displacement of pattern vertex `vertex` at strains `s` and curvature
    /// tensor `k = [K₁₁, K₁₂, K₂₂]` (1/m, deformed in-plane coordinates, [`curvature_tensor`]).
    #[inline(always)]
    pub fn displacement(&self, vertex: usize, s: [T; 3], k: [T; 3]) -> [T; 4] {
        let (l1, l2, c2) = principal_curvatures(k);
        // Both directions share the strain axes, so the strain weights are computed once.
        let w = self.along[0][0].weights(s);
        let [x, y] = &self.along;
        let x1 = self.lookup_weighted(x, vertex, &w, l1);
        let x2 = self.lookup_weighted(x, vertex, &w, l2);
        let y2 = self.lookup_weighted(y, vertex, &w, l2);
        let y1 = self.lookup_weighted(y, vertex, &w, l1);
        let zero = self.lookup_weighted(x, vertex, &w, T::zero());
        let d2 = T::one() - c2;
        let mut out = [T::zero(); 4];
        for c in 0..4 {
            out[c] = c2 * x1[c] + d2 * x2[c] + c2 * y2[c] + d2 * y1[c] - zero[c];
        }
        out
    }
}

/// The curvature tensor `K = F⁻¹ II F⁻¹` (1/m) in the deformed orthonormal coordinates
/// `(a, b) = F X` of the first fundamental form `i = [I₁₁, I₁₂, I₂₂]` (symmetric positive
/// definite, e.g. clamped) and the second fundamental form `ii` (1/m), with `F = √I` the
/// symmetric square root (as `yarn_pattern::strain::Coarse::from_strain`).
#[inline(always)]
pub fn curvature_tensor<T: Real>(i: [T; 3], ii: [T; 3]) -> [T; 3] {
    let [a, b, c] = i;
    // √I = (I + √det I · Id) / √(tr I + 2 √det I).
    let s = (a * c - b * b).sqrt();
    let t = T::one() / (a + c + s + s).sqrt();
    let (f11, f12, f22) = ((a + s) * t, b * t, (c + s) * t);
    let inv_det = T::one() / (f11 * f22 - f12 * f12);
    let (g11, g12, g22) = (f22 * inv_det, -f12 * inv_det, f11 * inv_det);
    // K = G II G with G = F⁻¹ (all symmetric).
    let [p, q, r] = ii;
    let (m11, m12) = (g11 * p + g12 * q, g11 * q + g12 * r);
    let (m21, m22) = (g12 * p + g22 * q, g12 * q + g22 * r);
    [
        m11 * g11 + m12 * g12,
        m11 * g12 + m12 * g22,
        m21 * g12 + m22 * g22,
    ]
}

/// Eigenvalues `λ₁ ≥ λ₂` of the symmetric `k = [K₁₁, K₁₂, K₂₂]` and `c²`, the squared cosine
/// between the first axis and the eigenvector of λ₁ (1 when `K` is isotropic, where any
/// direction is an eigenvector).
#[inline(always)]
pub fn principal_curvatures<T: Real>(k: [T; 3]) -> (T, T, T) {
    let half = T::from_f64(0.5);
    let m = half * (k[0] + k[2]);
    let h = half * (k[0] - k[2]);
    let d = (h * h + k[1] * k[1]).sqrt();
    // c² = P₁₁ of the projector P₁ = (K − λ₂ Id) / (λ₁ − λ₂).
    let c2 = if d > T::zero() {
        (h + d) / (d + d)
    } else {
        T::one()
    };
    (m + d, m - d, c2)
}

/// The explicit model's displacement of one yarn vertex (the counterpart of
/// [`crate::deform::vertex_strain`] plus the lookup): interpolated `I` (clamped at the
/// kernel's eigenvalue floor, no `h` term) and `II` of the vertex's triangle at UV offset
/// `(du, dv)` (m), strains, curvature tensor and Eq. 19. Honours the `displacement` and
/// `skip_identity` options; non-finite strains or curvatures fall back to the zero-strain
/// displacement (counted like the linearized kernel).
#[inline(always)]
pub fn explicit_displacement<T: Real>(
    input: &KernelInputs<'_, T>,
    bending: &BendingDatabase<T>,
    triangle: u32,
    du: T,
    dv: T,
    tile_vertex: u32,
    counters: &mut VertexCounters,
) -> [T; 4] {
    let o = input.options;
    if !o.displacement {
        return [T::zero(); 4];
    }
    if o.skip_identity && input.skip[triangle as usize] != 0 {
        counters.lookups_skipped += 1;
        return input.rest_dq[tile_vertex as usize];
    }
    let fp = &input.faces[triangle as usize];
    let mut i = [T::zero(); 3];
    let mut ii = [T::zero(); 3];
    for c in 0..3 {
        i[c] = fp.i0[c] + fp.il[c] * du + fp.il[3 + c] * dv;
        ii[c] = fp.ii0[c] + fp.iil[c] * du + fp.iil[3 + c] * dv;
    }
    let (i, clamped) = clamp_eigenvalues(i, input.eigen_floor);
    counters.clamped += usize::from(clamped);
    let s = strains(i);
    let k = curvature_tensor(i, ii);
    if s.iter().chain(&k).all(|v| v.is_finite()) {
        bending.displacement(tile_vertex as usize, s, k)
    } else {
        counters.nonfinite_strain += 1;
        input.rest_dq[tile_vertex as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curvature_tensor_of_a_stretched_cylinder() {
        // F = diag(1.2, 0.9): II = Fᵀ(κ e₁e₁ᵀ)F has II₁₁ = 1.44 κ; K recovers κ e₁e₁ᵀ.
        let kappa: f64 = 30.0;
        let i = [1.44, 0.0, 0.81];
        let k = curvature_tensor(i, [1.44 * kappa, 0.0, 0.0]);
        assert!((k[0] - kappa).abs() < 1e-12 && k[1].abs() < 1e-12 && k[2].abs() < 1e-12);
        // Sheared I: K = F⁻¹ II F⁻¹ undoes II = F K F for a symmetric F = √I.
        let f = [1.1, 0.15, 0.95];
        let i = [
            f[0] * f[0] + f[1] * f[1],
            f[1] * (f[0] + f[2]),
            f[1] * f[1] + f[2] * f[2],
        ];
        let k0 = [12.0, -5.0, 3.0];
        let mul = |a: [f64; 3], b: [f64; 3]| {
            [
                [a[0] * b[0] + a[1] * b[1], a[0] * b[1] + a[1] * b[2]],
                [a[1] * b[0] + a[2] * b[1], a[1] * b[1] + a[2] * b[2]],
            ]
        };
        let fk = mul(f, k0);
        let ii = [
            fk[0][0] * f[0] + fk[0][1] * f[1],
            fk[0][0] * f[1] + fk[0][1] * f[2],
            fk[1][0] * f[1] + fk[1][1] * f[2],
        ];
        let k = curvature_tensor(i, ii);
        for c in 0..3 {
            assert!((k[c] - k0[c]).abs() < 1e-10, "{k:?} vs {k0:?}");
        }
    }

    #[test]
    fn principal_curvatures_and_direction() {
        let (l1, l2, c2) = principal_curvatures([5.0, 0.0, -2.0]);
        assert_eq!((l1, l2, c2), (5.0, -2.0, 1.0));
        let (l1, l2, c2) = principal_curvatures([-2.0, 0.0, 5.0]);
        assert_eq!((l1, l2, c2), (5.0, -2.0, 0.0));
        // Bend along the diagonal: K = κ/2 [1 1; 1 1].
        let (l1, l2, c2) = principal_curvatures([2.0f64, 2.0, 2.0]);
        assert!((l1 - 4.0).abs() < 1e-12 && l2.abs() < 1e-12 && (c2 - 0.5).abs() < 1e-12);
        let (l1, l2, c2) = principal_curvatures([3.0, 0.0, 3.0]);
        assert_eq!((l1, l2, c2), (3.0, 3.0, 1.0));
    }
}
