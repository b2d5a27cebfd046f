//! Yarn curves as structure-of-arrays coordinates plus CSR curve offsets.

use crate::error::{OutputError, Result};

/// A view of polylines: coordinates (m) as three arrays, curve `c` spanning vertices
/// `curve_offsets[c] .. curve_offsets[c + 1]`, and whether each curve is closed. The scalar is
/// `f32` or `f64` (anything that widens losslessly to `f64`).
#[derive(Clone, Copy, Debug)]
pub struct Polylines<'a, T> {
    /// x coordinates (m).
    pub x: &'a [T],
    /// y coordinates (m).
    pub y: &'a [T],
    /// z coordinates (m).
    pub z: &'a [T],
    /// CSR offsets of the curves: `n_curves + 1` non-decreasing entries, the last ≤ `x.len()`.
    pub curve_offsets: &'a [u32],
    /// Whether each curve is closed (its last vertex connects back to its first).
    pub closed: &'a [bool],
}

/// The up axis recorded in a file's header (`.bcc`, USD); the coordinates are never rotated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UpAxis {
    /// +y up (the simulators' convention: gravity along −y).
    #[default]
    Y,
    /// +z up (the deformer's convention: meshes in the xy plane, normals along +z).
    Z,
}

impl<T: Copy + Into<f64>> Polylines<'_, T> {
    /// Number of curves.
    pub fn n_curves(&self) -> usize {
        self.curve_offsets.len().saturating_sub(1)
    }

    /// Checks that the arrays agree (same lengths, offsets non-decreasing and in range, one
    /// closed flag per curve).
    pub fn validate(&self) -> Result<()> {
        let n = self.x.len();
        let ok = self.y.len() == n
            && self.z.len() == n
            && self.closed.len() == self.n_curves()
            && self.curve_offsets.windows(2).all(|w| w[0] <= w[1])
            && self.curve_offsets.last().is_none_or(|&e| e as usize <= n);
        if ok {
            return Ok(());
        }
        Err(OutputError::Option {
            name: "polylines",
            message: format!(
                "inconsistent polylines: {n} x, {} y, {} z, {} curve offsets (last {:?}), {} closed flags",
                self.y.len(),
                self.z.len(),
                self.curve_offsets.len(),
                self.curve_offsets.last(),
                self.closed.len()
            ),
        })
    }

    /// The vertex range and closed flag of each curve.
    pub fn curves(&self) -> impl Iterator<Item = (std::ops::Range<usize>, bool)> + '_ {
        self.curve_offsets
            .windows(2)
            .zip(self.closed)
            .map(|(w, &c)| (w[0] as usize..w[1] as usize, c))
    }

    /// Vertex `k` as `f64` (m).
    pub fn point(&self, k: usize) -> [f64; 3] {
        [self.x[k].into(), self.y[k].into(), self.z[k].into()]
    }

    /// The vertex indices along each curve's edges: its vertices in order, then the first
    /// again when the curve is closed and has more than two vertices. Curves with fewer than
    /// two vertices have no edges and are skipped.
    pub fn edge_paths(&self) -> impl Iterator<Item = (usize, Vec<usize>)> + '_ {
        self.curves()
            .enumerate()
            .filter(|(_, (r, _))| r.len() >= 2)
            .map(|(c, (r, closed))| {
                let mut path: Vec<usize> = r.clone().collect();
                if closed && r.len() > 2 {
                    path.push(r.start);
                }
                (c, path)
            })
    }

    /// Number of edges (segments) of all curves.
    pub fn edge_count(&self) -> usize {
        self.edge_paths().map(|(_, p)| p.len() - 1).sum()
    }
}

/// Owned polylines in `f64`, built curve by curve ([`PolylineBuf::push_curve`]);
/// [`PolylineBuf::view`] lends them to the writers.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolylineBuf {
    /// x coordinates (m).
    pub x: Vec<f64>,
    /// y coordinates (m).
    pub y: Vec<f64>,
    /// z coordinates (m).
    pub z: Vec<f64>,
    /// CSR offsets of the curves (starts with 0).
    pub curve_offsets: Vec<u32>,
    /// Whether each curve is closed.
    pub closed: Vec<bool>,
}

impl PolylineBuf {
    /// Appends one curve; fails when the vertex count no longer fits the `u32` offsets.
    pub fn push_curve(
        &mut self,
        points: impl IntoIterator<Item = [f64; 3]>,
        closed: bool,
    ) -> Result<()> {
        if self.curve_offsets.is_empty() {
            self.curve_offsets.push(0);
        }
        for [x, y, z] in points {
            self.x.push(x);
            self.y.push(y);
            self.z.push(z);
        }
        let end = u32::try_from(self.x.len()).map_err(|_| {
            OutputError::Invalid(format!(
                "{} vertices: too many for u32 curve offsets",
                self.x.len()
            ))
        })?;
        self.curve_offsets.push(end);
        self.closed.push(closed);
        Ok(())
    }

    /// The curves as a [`Polylines`] view.
    pub fn view(&self) -> Polylines<'_, f64> {
        Polylines {
            x: &self.x,
            y: &self.y,
            z: &self.z,
            curve_offsets: &self.curve_offsets,
            closed: &self.closed,
        }
    }
}
