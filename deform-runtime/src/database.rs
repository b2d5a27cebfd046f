//! The displacement database ΔQ(sx, sa, sy) prepared for per-frame lookups (paper 004 §3.3,
//! §4.4).
//!
//! [`RuntimeDatabase`] is built from a [`yarn_pattern::madypg::Database`] after checking it
//! against the pattern (same vertex count, finite values). Storage is converted to the
//! run-time scalar `T` and laid out for the lookup, **sample-major and component-major**: for
//! each strain sample, in the MADYPG order `r = isx + |SX|(isa + |SA| isy)`, and each
//! component `c` of `(Δx, Δy, Δz, Δθ)`, the values of every pattern vertex in turn, at
//! `(4r + c) · n_vertices + slot(vertex)` ([`RuntimeDatabase::index`]). The slots number the
//! pattern vertices along the tile's yarns ([`RuntimeDatabase::slot`]), whatever order the
//! file lists them in. (The MADYPG file is vertex-major: one block of samples per vertex.)
//! Consecutive yarn vertices are then consecutive slots at nearly the same strain, so a batch
//! of lookups that falls in one sample cell reads each corner's component as one contiguous
//! vector ([`crate::lanes`]) instead of eight values `|SX|·|SA|·|SY|` samples apart.
//!
//! Lookups interpolate trilinearly on the (possibly non-uniform) sample axes and clamp
//! strains outside the sampled range to the nearest sample (paper 004 §4.4: "constant
//! extrapolation"), so they never extrapolate.

use yarn_pattern::madypg::Database;
use yarn_pattern::tile::{Tile, Topology};

use crate::error::{DeformError, Result};
use crate::real::Real;

/// Where a strain value falls on one sample axis: the two bracketing samples and the weight
/// of the upper one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisWeight<T> {
    /// Index of the lower sample.
    pub lo: u32,
    /// Index of the upper sample (`lo + 1`, or `lo` for a single-sample axis).
    pub hi: u32,
    /// Weight of the upper sample in `[0, 1]` (0 below the range, 1 above it).
    pub t: T,
}

/// Locates `s` on the strictly increasing `axis` (non-empty), clamping outside the range.
/// A NaN `s` is treated as the first sample.
#[inline(always)]
pub fn locate<T: Real>(axis: &[T], s: T) -> AxisWeight<T> {
    let n = axis.len();
    if n < 2 || s.partial_cmp(&axis[0]) != Some(std::cmp::Ordering::Greater) {
        return AxisWeight {
            lo: 0,
            hi: if n < 2 { 0 } else { 1 },
            t: T::zero(),
        };
    }
    if s >= axis[n - 1] {
        return AxisWeight {
            lo: (n - 2) as u32,
            hi: (n - 1) as u32,
            t: T::one(),
        };
    }
    // axis[0] < s < axis[n-1]: the interval [axis[k], axis[k+1]) containing s.
    let mut k = 0;
    while k + 2 < n && axis[k + 1] <= s {
        k += 1;
    }
    let t = (s - axis[k]) / (axis[k + 1] - axis[k]);
    AxisWeight {
        lo: k as u32,
        hi: (k + 1) as u32,
        t,
    }
}

/// A validated displacement database in run-time precision `T`.
#[derive(Clone, Debug)]
pub struct RuntimeDatabase<T> {
    /// Sample values of `sx`, `sa`, `sy` (unitless), strictly increasing.
    axes: [Vec<T>; 3],
    /// Number of pattern vertices.
    n_vertices: usize,
    /// Storage slot of each pattern vertex: vertices numbered along the tile's yarns.
    slots: Vec<u32>,
    /// Displacements `(Δx, Δy, Δz, Δθ)` (m, m, m, rad), sample- and component-major (see the
    /// module docs).
    texels: Vec<T>,
    /// Index of the sample closest to zero strain on each axis.
    zero_sample: [usize; 3],
    /// For uniformly spaced axes: `(first sample, 1 / spacing)`, enabling O(1) location.
    uniform: [Option<(T, T)>; 3],
    /// When all three axes are uniform with ≥ 2 samples: `(first samples, inverse spacings)`.
    all_uniform: Option<([T; 3], [T; 3])>,
}

/// Locates `s` on a uniform axis of `n ≥ 2` samples starting at `a0` with inverse spacing
/// `inv_h`, clamping outside the range; NaN maps to the first sample.
#[inline(always)]
pub fn locate_uniform<T: Real>(n: usize, a0: T, inv_h: T, s: T) -> AxisWeight<T> {
    let last = T::from_f64((n - 1) as f64);
    let t = (s - a0) * inv_h;
    // Comparisons instead of `max`/`min` (cheaper on baseline x86-64); NaN fails `t > 0`.
    let t = if t > T::zero() { t } else { T::zero() };
    let t = if t < last { t } else { last };
    // Integer part, at most n − 2 so that `hi` stays in range (t = n − 1 gives weight 1).
    let k = t.to_index().min(n as u32 - 2);
    AxisWeight {
        lo: k,
        hi: k + 1,
        t: t - T::from_f64(f64::from(k)),
    }
}

impl<T: Real> RuntimeDatabase<T> {
    /// Converts `db` after checking it against `tile`: vertex counts must agree and every
    /// value must be finite. The axes are validated by `db.validate()`.
    pub fn new(db: &Database, tile: &Tile) -> Result<Self> {
        db.validate()?;
        if db.n_vertices != tile.positions.len() {
            return Err(DeformError::VertexCountMismatch {
                database: db.n_vertices,
                pattern: tile.positions.len(),
            });
        }
        let per_vertex = db.samples_per_vertex();
        if let Some((row, values)) = db
            .data
            .iter()
            .enumerate()
            .find(|(_, r)| r.iter().any(|x| !x.is_finite()))
        {
            return Err(DeformError::NonFiniteData {
                row,
                vertex: row / per_vertex,
                values: *values,
            });
        }
        let axes = [0, 1, 2].map(|k| db.axes[k].iter().map(|&a| T::from_f64(a)).collect());
        let n = db.n_vertices;
        let slots = yarn_order(tile);
        let mut vertex_of = vec![0; n];
        for (v, &s) in slots.iter().enumerate() {
            vertex_of[s as usize] = v;
        }
        let texels = (0..per_vertex * 4 * n)
            .map(|k| {
                let (sample, c, slot) = (k / (4 * n), (k / n) % 4, k % n);
                T::from_f64(f64::from(db.data[vertex_of[slot] * per_vertex + sample][c]))
            })
            .collect();
        let zero_sample = [0, 1, 2].map(|k| {
            let axis = &db.axes[k];
            (0..axis.len())
                .min_by(|&a, &b| axis[a].abs().total_cmp(&axis[b].abs()))
                .unwrap_or(0)
        });
        let uniform = [0, 1, 2].map(|k| {
            let a = &db.axes[k];
            let n = a.len();
            if n < 2 {
                return None;
            }
            let h = (a[n - 1] - a[0]) / (n - 1) as f64;
            // Uniform when every sample is within 1e-9 spacings of its regular position.
            let regular = (0..n).all(|j| (a[j] - (a[0] + j as f64 * h)).abs() <= 1e-9 * h);
            regular.then(|| (T::from_f64(a[0]), T::from_f64(1.0 / h)))
        });
        let all_uniform = match uniform {
            [Some(x), Some(a), Some(y)] => Some(([x.0, a.0, y.0], [x.1, a.1, y.1])),
            _ => None,
        };
        Ok(Self {
            axes,
            n_vertices: db.n_vertices,
            slots,
            texels,
            zero_sample,
            uniform,
            all_uniform,
        })
    }

    /// Number of pattern vertices.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Sample values of axis `k` (0: sx, 1: sa, 2: sy).
    pub fn axis(&self, k: usize) -> &[T] {
        &self.axes[k]
    }

    /// Number of samples per axis `[|SX|, |SA|, |SY|]`.
    pub fn shape(&self) -> [usize; 3] {
        [0, 1, 2].map(|k| self.axes[k].len())
    }

    /// The displacements, sample- and component-major (see the module docs): component `c`
    /// of sample `r` of vertex `v` at [`Self::index`]`(r, c, v)`.
    pub fn texels(&self) -> &[T] {
        &self.texels
    }

    /// Position in [`Self::texels`] of component `c` of sample `r` (MADYPG order) of the
    /// pattern vertex in storage slot `slot`.
    #[inline(always)]
    pub fn index(&self, r: usize, c: usize, slot: usize) -> usize {
        (4 * r + c) * self.n_vertices + slot
    }

    /// The storage slot of pattern vertex `v` (see the module docs).
    #[inline(always)]
    pub fn slot(&self, v: usize) -> usize {
        self.slots[v] as usize
    }

    /// The displacements in pattern-vertex order: component `c` of sample `r` of vertex `v`
    /// at `(4r + c) · n_vertices + v` (the GPU back end's layout).
    pub fn texels_by_vertex(&self) -> Vec<T> {
        let n = self.n_vertices;
        (0..self.texels.len())
            .map(|k| self.texels[k - k % n + self.slot(k % n)])
            .collect()
    }

    /// Size of the texel storage in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.texels.len() * std::mem::size_of::<T>()
    }

    /// For each axis, `(first sample, 1 / spacing)` if the samples are uniformly spaced.
    pub fn uniform_axes(&self) -> [Option<(T, T)>; 3] {
        self.uniform
    }

    /// Index of the sample nearest to zero on each axis.
    pub fn zero_sample(&self) -> [usize; 3] {
        self.zero_sample
    }

    /// When all three axes are uniform with at least two samples each: their first samples
    /// and inverse spacings (the O(1) location of [`locate_uniform`]).
    pub fn uniform_grid(&self) -> Option<([T; 3], [T; 3])> {
        self.all_uniform
    }

    /// Axis weights of the strain `(sx, sa, sy)`, clamped to the sampled range.
    #[inline(always)]
    pub fn weights(&self, s: [T; 3]) -> [AxisWeight<T>; 3] {
        if let Some((a0, inv)) = self.all_uniform {
            return [
                locate_uniform(self.axes[0].len(), a0[0], inv[0], s[0]),
                locate_uniform(self.axes[1].len(), a0[1], inv[1], s[1]),
                locate_uniform(self.axes[2].len(), a0[2], inv[2], s[2]),
            ];
        }
        [0, 1, 2].map(|k| match self.uniform[k] {
            Some((a0, inv_h)) => locate_uniform(self.axes[k].len(), a0, inv_h, s[k]),
            None => locate(&self.axes[k], s[k]),
        })
    }

    /// Trilinear interpolation of vertex `vertex`'s displacement at precomputed weights.
    /// `vertex` must be below [`Self::n_vertices`] (checked by the caller's embedding).
    #[inline(always)]
    pub fn interpolate(&self, vertex: usize, w: &[AxisWeight<T>; 3]) -> [T; 4] {
        let [nx, na, _] = self.shape();
        let row = |ia: u32, iy: u32| nx * (ia as usize + na * iy as usize);
        let mut out = [T::zero(); 4];
        let corners = [
            (w[1].lo, w[2].lo, (T::one() - w[1].t) * (T::one() - w[2].t)),
            (w[1].hi, w[2].lo, w[1].t * (T::one() - w[2].t)),
            (w[1].lo, w[2].hi, (T::one() - w[1].t) * w[2].t),
            (w[1].hi, w[2].hi, w[1].t * w[2].t),
        ];
        let (tx0, tx1) = (T::one() - w[0].t, w[0].t);
        let slot = self.slot(vertex);
        for (ia, iy, wy) in corners {
            let r = row(ia, iy);
            let (ra, rb) = (r + w[0].lo as usize, r + w[0].hi as usize);
            for c in 0..4 {
                let a = self.texels[self.index(ra, c, slot)];
                let b = self.texels[self.index(rb, c, slot)];
                out[c] += wy * (tx0 * a + tx1 * b);
            }
        }
        out
    }

    /// Displacement `(Δx, Δy, Δz, Δθ)` of pattern vertex `vertex` at strain `(sx, sa, sy)`.
    #[inline(always)]
    pub fn lookup(&self, vertex: usize, s: [T; 3]) -> [T; 4] {
        self.interpolate(vertex, &self.weights(s))
    }

    /// The stored displacement of every pattern vertex at zero strain (the sample nearest to
    /// zero on each axis, interpolated at exactly `(0, 0, 0)`); used for faces whose lookup
    /// is skipped so that skipping does not change results.
    pub fn rest_displacements(&self) -> Vec<[T; 4]> {
        (0..self.n_vertices)
            .map(|v| self.lookup(v, [T::zero(); 3]))
            .collect()
    }
}

/// Storage slots of the pattern vertices: the vertices in the order of the tile's yarn loops
/// ([`Topology::loops`], each edge's start vertex), or in file order if the tile has no valid
/// topology.
fn yarn_order(tile: &Tile) -> Vec<u32> {
    let n = tile.positions.len();
    let identity = || (0..n as u32).collect();
    let Ok(topology) = Topology::new(tile) else {
        return identity();
    };
    let mut slots = vec![u32::MAX; n];
    let mut next = 0u32;
    for lp in topology.loops() {
        for e in lp {
            let v = tile.edges[e].v0;
            if slots[v] == u32::MAX {
                slots[v] = next;
                next += 1;
            }
        }
    }
    if next as usize == n {
        slots
    } else {
        identity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locate_clamps_and_interpolates_on_non_uniform_axes() {
        let axis = [-0.2f64, 0.0, 0.1, 0.5];
        let w = locate(&axis, -1.0);
        assert_eq!((w.lo, w.hi, w.t), (0, 1, 0.0));
        let w = locate(&axis, 2.0);
        assert_eq!((w.lo, w.hi, w.t), (2, 3, 1.0));
        let w = locate(&axis, 0.3);
        assert_eq!((w.lo, w.hi), (2, 3));
        assert!((w.t - 0.5).abs() < 1e-15);
        let w = locate(&axis, 0.0);
        assert_eq!((w.lo, w.hi), (1, 2));
        assert_eq!(w.t, 0.0);
        let w = locate(&axis, f64::NAN);
        assert_eq!((w.lo, w.t), (0, 0.0));
        // The uniform fast path agrees with the search on a uniform axis.
        let axis = [-0.2f64, 0.1, 0.4, 0.7, 1.0];
        for s in [-1.0, -0.2, 0.0, 0.1, 0.25, 0.7, 0.99, 1.0, 3.0, f64::NAN] {
            let a = locate(&axis, s);
            let b = locate_uniform(5, -0.2, 1.0 / 0.3, s);
            let va = axis[a.lo as usize] * (1.0 - a.t) + axis[a.hi as usize] * a.t;
            let vb = axis[b.lo as usize] * (1.0 - b.t) + axis[b.hi as usize] * b.t;
            assert!((va - vb).abs() < 1e-12, "s = {s}: {a:?} vs {b:?}");
        }
        let w = locate(&[0.5f64], 3.0);
        assert_eq!((w.lo, w.hi, w.t), (0, 0, 0.0));
    }
}
