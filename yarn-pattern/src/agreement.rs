//! Agreement of two displacement databases ΔQ(sx, sa, sy) of the same tile (seed 004 §3):
//! the metric the `periodic-vs-reference` study judges our tables by against published ones.
//!
//! **Per sample.** Both fields are compared on the tile's vertices after removing each field's
//! own rigid translation (its mean displacement over the vertices): a table's translation is
//! set by its solver's constraint choice (which vertex is held, the zero mean fluctuation), not
//! by the mechanics, and the runtime cannot see it once the pattern is tiled. With `a_v`, `b_v`
//! the translation-free displacements of vertex `v` (ours, the reference) over `n` vertices:
//!
//! ```text
//! correlation = Σ_v a_v·b_v / √(Σ_v |a_v|² Σ_v |b_v|²)
//! RMS difference = √(Σ_v |a_v − b_v|² / n),   RMS of a field = √(Σ_v |a_v|² / n)
//! ```
//!
//! and the twist change Δθ is compared separately (RMS difference in rad).
//!
//! **Over the table** the same sums are pooled over every sample, so the table's correlation
//! weights a sample by the size of its displacements (the zero-strain sample, where both are
//! zero, adds nothing) and its RMS is over all vertex–sample pairs.
//!
//! **Re-basing.** A table is relative to the tile it was computed from. [`Database::offset_by`]
//! re-expresses it relative to another tile with the same vertices and period (adds the
//! per-vertex difference of the two tiles' positions and twists to every sample), so a table
//! computed from a tile we relaxed can be compared with one relative to the file's geometry.

use crate::madypg::{AXIS_NAMES, Database};

/// How the two fields of one sample agree (lengths in m, twists in rad).
#[derive(Clone, Debug, PartialEq)]
pub struct SampleAgreement {
    /// Grid indices `(isx, isa, isy)`.
    pub index: [usize; 3],
    /// The sample's strain `(sx, sa, sy)` (unitless).
    pub strain: [f64; 3],
    /// Correlation of the translation-free position fields (NaN where either is zero).
    pub correlation: f64,
    /// RMS over vertices of the difference of the translation-free positions (m).
    pub rms_difference: f64,
    /// RMS over vertices of our translation-free positions (m).
    pub rms_ours: f64,
    /// RMS over vertices of the reference's translation-free positions (m).
    pub rms_reference: f64,
    /// RMS over vertices of the twist difference (rad).
    pub rms_twist_difference: f64,
}

/// How two databases of one tile agree, per sample and pooled over the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Agreement {
    /// One entry per sample, in database order (`isx` fastest, then `isa`, then `isy`).
    pub samples: Vec<SampleAgreement>,
    /// Correlation pooled over every sample.
    pub correlation: f64,
    /// RMS difference over every vertex and sample (m).
    pub rms_difference: f64,
    /// RMS of the reference over every vertex and sample (m).
    pub rms_reference: f64,
    /// RMS twist difference over every vertex and sample (rad).
    pub rms_twist_difference: f64,
}

/// Why two databases cannot be compared.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AgreementError {
    /// Different numbers of vertices.
    #[error("the databases have {ours} and {reference} vertices; they must be of the same tile")]
    Vertices {
        /// Our vertex count.
        ours: usize,
        /// The reference's.
        reference: usize,
    },
    /// An axis differs.
    #[error("axis {axis} differs: {ours:?} against {reference:?} (the samples must agree to 1e-9)")]
    Axis {
        /// Axis name.
        axis: &'static str,
        /// Our samples.
        ours: Vec<f64>,
        /// The reference's samples.
        reference: Vec<f64>,
    },
    /// An offset list of the wrong length.
    #[error("expected one offset per vertex ({expected}), found {found}")]
    Offsets {
        /// Vertices of the database.
        expected: usize,
        /// Offsets given.
        found: usize,
    },
}

/// Samples of two axes agree if they differ by at most this (published axes are written with
/// ten decimals, e.g. `0.1666666667`).
const AXIS_TOLERANCE: f64 = 1e-9;

impl Database {
    /// This table relative to another tile with the same vertices and period: `offsets[v]` is
    /// that tile's position and twist subtracted from this table's tile's, `(Δx, Δy, Δz, Δθ)`
    /// (m, rad), added to vertex `v` of every sample (see the [module docs](self)).
    pub fn offset_by(&self, offsets: &[[f64; 4]]) -> Result<Database, AgreementError> {
        if offsets.len() != self.n_vertices {
            return Err(AgreementError::Offsets {
                expected: self.n_vertices,
                found: offsets.len(),
            });
        }
        let per_vertex = self.samples_per_vertex();
        let mut out = self.clone();
        for (row, value) in out.data.iter_mut().enumerate() {
            let o = offsets[row / per_vertex];
            for c in 0..4 {
                value[c] = (f64::from(value[c]) + o[c]) as f32;
            }
        }
        Ok(out)
    }

    /// The positions (m) of sample `[isx, isa, isy]`, per vertex, with the sample's mean
    /// translation removed: the field the metric compares. Panics if the index is off the axes.
    pub fn translation_free(&self, index: [usize; 3]) -> Vec<[f64; 3]> {
        let [isx, isa, isy] = index;
        let rows: Vec<[f64; 4]> = (0..self.n_vertices)
            .map(|v| self.data[self.index(v, isx, isa, isy)].map(f64::from))
            .collect();
        without_mean(&rows)
    }

    /// How this table agrees with `reference`, a table of the same tile on the same axes; see
    /// the [module docs](self) for the metric.
    pub fn agreement(&self, reference: &Database) -> Result<Agreement, AgreementError> {
        if self.n_vertices != reference.n_vertices {
            return Err(AgreementError::Vertices {
                ours: self.n_vertices,
                reference: reference.n_vertices,
            });
        }
        for (k, axis) in AXIS_NAMES.into_iter().enumerate() {
            let (a, b) = (&self.axes[k], &reference.axes[k]);
            if a.len() != b.len() || a.iter().zip(b).any(|(x, y)| (x - y).abs() > AXIS_TOLERANCE) {
                return Err(AgreementError::Axis {
                    axis,
                    ours: a.clone(),
                    reference: b.clone(),
                });
            }
        }
        let n = self.n_vertices;
        let mut samples = Vec::with_capacity(self.samples_per_vertex());
        let mut pooled = Sums::default();
        for isy in 0..self.axes[2].len() {
            for isa in 0..self.axes[1].len() {
                for isx in 0..self.axes[0].len() {
                    let field = |d: &Database| -> Vec<[f64; 4]> {
                        (0..n)
                            .map(|v| d.data[d.index(v, isx, isa, isy)].map(f64::from))
                            .collect()
                    };
                    let sums = Sums::of(&field(self), &field(reference));
                    pooled.add(&sums);
                    samples.push(SampleAgreement {
                        index: [isx, isa, isy],
                        strain: [self.axes[0][isx], self.axes[1][isa], self.axes[2][isy]],
                        correlation: sums.correlation(),
                        rms_difference: sums.rms(sums.dd),
                        rms_ours: sums.rms(sums.aa),
                        rms_reference: sums.rms(sums.bb),
                        rms_twist_difference: sums.rms(sums.twist),
                    });
                }
            }
        }
        Ok(Agreement {
            samples,
            correlation: pooled.correlation(),
            rms_difference: pooled.rms(pooled.dd),
            rms_reference: pooled.rms(pooled.bb),
            rms_twist_difference: pooled.rms(pooled.twist),
        })
    }
}

/// The positions of a sample's rows `[x, y, z, θ]` with their mean removed.
fn without_mean(rows: &[[f64; 4]]) -> Vec<[f64; 3]> {
    let mut m = [0.0; 3];
    for row in rows {
        for c in 0..3 {
            m[c] += row[c] / rows.len() as f64;
        }
    }
    rows.iter()
        .map(|row| std::array::from_fn(|c| row[c] - m[c]))
        .collect()
}

/// Sums of products of two translation-free fields, over vertices (and samples when pooled).
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    ab: f64,
    aa: f64,
    bb: f64,
    dd: f64,
    twist: f64,
    count: f64,
}

impl Sums {
    fn of(a: &[[f64; 4]], b: &[[f64; 4]]) -> Self {
        let (fa, fb) = (without_mean(a), without_mean(b));
        let mut s = Sums {
            count: a.len() as f64,
            ..Sums::default()
        };
        for (((p, q), x), y) in a.iter().zip(b).zip(&fa).zip(&fb) {
            for c in 0..3 {
                let (x, y) = (x[c], y[c]);
                s.ab += x * y;
                s.aa += x * x;
                s.bb += y * y;
                s.dd += (x - y) * (x - y);
            }
            s.twist += (p[3] - q[3]).powi(2);
        }
        s
    }

    fn add(&mut self, o: &Sums) {
        self.ab += o.ab;
        self.aa += o.aa;
        self.bb += o.bb;
        self.dd += o.dd;
        self.twist += o.twist;
        self.count += o.count;
    }

    fn correlation(&self) -> f64 {
        let norm = (self.aa * self.bb).sqrt();
        if norm > 0.0 { self.ab / norm } else { f64::NAN }
    }

    fn rms(&self, sum: f64) -> f64 {
        (sum / self.count).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(values: impl Fn(usize, usize) -> [f32; 4]) -> Database {
        let axes = [vec![0.0, 0.5], vec![0.0], vec![-0.1, 0.0, 0.2]];
        let n = 3;
        let mut db = Database {
            axes,
            n_vertices: n,
            data: vec![[0.0; 4]; n * 6],
        };
        for v in 0..n {
            for s in 0..6 {
                db.data[v * 6 + s] = values(v, s);
            }
        }
        db
    }

    #[test]
    fn a_table_agrees_with_itself_and_with_itself_translated() {
        let a = table(|v, s| {
            [
                v as f32 * 1e-3,
                (s * v) as f32 * 2e-4,
                -(s as f32) * 1e-4,
                0.1,
            ]
        });
        let same = a.agreement(&a).unwrap();
        assert!((same.correlation - 1.0).abs() < 1e-12);
        assert_eq!(same.rms_difference, 0.0);
        // A rigid translation per sample changes nothing; a twist offset is seen.
        let moved = a.offset_by(&[[1e-3, -2e-3, 5e-4, 0.05]; 3]).unwrap();
        let m = moved.agreement(&a).unwrap();
        assert!((m.correlation - 1.0).abs() < 1e-6, "{}", m.correlation);
        assert!(m.rms_difference < 1e-9, "{}", m.rms_difference);
        assert!((m.rms_twist_difference - 0.05).abs() < 1e-6);
        // The compared fields: zero mean, and the same for the translated table.
        let (fa, fm) = (
            a.translation_free([0, 0, 0]),
            moved.translation_free([0, 0, 0]),
        );
        let mean_x: f64 = fa.iter().map(|p| p[0]).sum::<f64>() / fa.len() as f64;
        assert!(mean_x.abs() < 1e-12 && fa.iter().any(|p| p[0].abs() > 1e-4));
        for (p, q) in fa.iter().zip(&fm) {
            assert!((0..3).all(|c| (p[c] - q[c]).abs() < 1e-9), "{p:?} vs {q:?}");
        }
    }

    #[test]
    fn opposite_fields_anticorrelate_and_differ_by_twice_their_size() {
        let a = table(|v, _| [(v as f32 - 1.0) * 1e-3, 0.0, 0.0, 0.0]);
        let b = table(|v, _| [(1.0 - v as f32) * 1e-3, 0.0, 0.0, 0.0]);
        let g = a.agreement(&b).unwrap();
        assert!((g.correlation + 1.0).abs() < 1e-12);
        // Vertices at −1, 0, +1 mm: RMS of each field √(2/3) mm, of the difference twice that.
        let rms = (2.0f64 / 3.0).sqrt() * 1e-3;
        assert!((g.rms_reference - rms).abs() < 1e-9);
        assert!((g.rms_difference - 2.0 * rms).abs() < 1e-9);
        assert_eq!(g.samples.len(), 6);
        assert_eq!(g.samples[1].strain, [0.5, 0.0, -0.1]);
    }

    #[test]
    fn tables_of_other_tiles_or_axes_are_refused() {
        let a = table(|_, _| [0.0; 4]);
        let mut b = a.clone();
        b.axes[2][2] = 0.25;
        assert!(matches!(
            a.agreement(&b),
            Err(AgreementError::Axis { axis: "sy", .. })
        ));
        let c = Database {
            n_vertices: 2,
            data: vec![[0.0; 4]; 12],
            ..a.clone()
        };
        assert!(matches!(
            a.agreement(&c),
            Err(AgreementError::Vertices {
                ours: 3,
                reference: 2
            })
        ));
        assert!(matches!(
            a.offset_by(&[[0.0; 4]; 2]),
            Err(AgreementError::Offsets {
                expected: 3,
                found: 2
            })
        ));
    }
}
