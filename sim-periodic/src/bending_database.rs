//! Bending-direction displacement databases of a tile (seed 004 Appendix C, Eq. 19): for
//! every sample `s` of an in-plane `ΔQ(sx, sa, sy)` database ([`crate::database`]) and every
//! curvature κ (1/m) of a small axis, the tile is solved under
//! `Coarse::from_strain(s).bent(axis, κ)` (rolled onto a cylinder along the deformed x or y
//! axis, [`Coarse::bent`]) with [`solve_equilibrium`], warm-started from the in-plane
//! sample's equilibrium (rebuilt from its database row and polished) and continued outward
//! in κ, halving failed steps. The displacement is pulled back through the exact inverse of
//! the roll ([`crate::pullback`], the bent counterpart of seed 004 Eq. 18); κ = 0 uses the
//! in-plane database itself, so the explicit bending model and the in-plane model agree on
//! flat sheets.
//!
//! On nested strain grids the databases of a coarser grid are the dense ones restricted to
//! the coarse samples ([`restrict_to_axes`]): the same bent-tile problems, solved once.

use anyhow::{Context, anyhow};
use nalgebra::Vector3;
use rayon::prelude::*;
use solver::StepError;

use crate::coarse::{Coarse, Strain};
use crate::periodic::{EquilibriumSettings, YarnModel, solve_equilibrium};
use crate::pullback::pullback;
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

/// Material displacement rows `(Δx, Δy, Δz, Δθ)` (m, rad) of the equilibrium `dofs` of
/// `tile` under the bent `coarse` map ([`pullback`]), in single precision.
fn bent_displacements(tile: &Tile, coarse: &Coarse, dofs: &[f64]) -> anyhow::Result<Vec<[f32; 4]>> {
    Ok(pullback(tile, coarse, dofs)
        .context("pulling back a bent sample")?
        .into_iter()
        .map(|r| r.map(|c| c as f32))
        .collect())
}

/// The equilibrium DOFs of the in-plane sample at row block `sample` of `db` (fluctuations
/// `F₃ ΔQ`, twists `Θ + Δθ`), before polishing.
fn inplane_dofs(
    tile: &Tile,
    db: &Database,
    index: [usize; 3],
    coarse: &Coarse,
) -> anyhow::Result<Vec<f64>> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let f3 = coarse.f3();
    let mut x = vec![0.0; 4 * n];
    for v in 0..n {
        let row = db.data[db.index(v, index[0], index[1], index[2])];
        let u = f3 * Vector3::new(f64::from(row[0]), f64::from(row[1]), f64::from(row[2]));
        x[3 * v..3 * v + 3].copy_from_slice(u.as_slice());
        x[3 * n + topology.outgoing(v)] = tile.twists[v] + f64::from(row[3]);
    }
    Ok(x)
}

/// One in-plane sample bent along one axis: what [`Bend::to`] solves.
struct Bend<'a> {
    tile: &'a Tile,
    model: &'a YarnModel,
    settings: &'a EquilibriumSettings,
    strain: Strain,
    axis: usize,
}

impl Bend<'_> {
    /// Solves the tile bent by `to` (1/m), continuing from curvature `from` with equilibrium
    /// `dofs`; a failed step is halved up to `depth` times ([`solver::bisect`], midpoints
    /// `(from + to)/2`). Returns the DOFs and the number of solves (failed ones included).
    fn to(
        &self,
        (from, dofs): (f64, &[f64]),
        to: f64,
        depth: usize,
    ) -> anyhow::Result<(Vec<f64>, usize)> {
        let mut last: Option<Vec<f64>> = None;
        let report = solver::bisect(
            (from, to),
            depth,
            |&(a, b)| {
                let mid = 0.5 * (a + b);
                ((a, mid), (mid, b))
            },
            |&(_, k), _| {
                let coarse = Coarse::from_strain(&self.strain).bent(self.axis, k);
                let warm = last.as_deref().unwrap_or(dofs);
                let eq =
                    solve_equilibrium(self.tile, self.model, coarse, Some(warm), self.settings)
                        .map_err(StepError::Halve)?;
                last = Some(eq.dofs);
                Ok(())
            },
        )
        .map_err(|e| {
            let s = &self.strain;
            anyhow::Error::new(e.source).context(format!(
                "bending the tile along axis {} to κ = {} 1/m at (sx, sa, sy) = ({}, {}, {})",
                self.axis, e.failed.1, s.sx, s.sa, s.sy
            ))
        })?;
        let dofs = last.expect("a successful continuation solved at least one step");
        Ok((dofs, report.steps + report.halvings))
    }
}

/// The bending-direction databases `[along x, along y]`, one per curvature of `kappas` (which
/// contains 0, where the in-plane database is used), and the number of equilibrium solves.
pub fn bending_databases(
    tile: &Tile,
    model: &YarnModel,
    inplane: &Database,
    kappas: &[f64],
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<([Vec<Database>; 2], usize)> {
    let settings = EquilibriumSettings::default();
    let dims = [0, 1, 2].map(|k| inplane.axes[k].len());
    let n_samples = dims.iter().product::<usize>();
    // Per sample: rows[axis][kappa] (the in-plane rows for κ = 0), solves.
    type Rows = Vec<Vec<[f32; 4]>>;
    let per_sample = (0..n_samples)
        .into_par_iter()
        .map(|flat| -> anyhow::Result<([Rows; 2], usize)> {
            let index = [
                flat % dims[0],
                (flat / dims[0]) % dims[1],
                flat / (dims[0] * dims[1]),
            ];
            let s = Strain {
                sx: inplane.axes[0][index[0]],
                sa: inplane.axes[1][index[1]],
                sy: inplane.axes[2][index[2]],
            };
            let flat_coarse = Coarse::from_strain(&s);
            let start = inplane_dofs(tile, inplane, index, &flat_coarse)?;
            // Polished from the in-plane database's (f32) displacements; if Newton stalls from
            // there, once more from the solver's own start.
            let eq0 = match solve_equilibrium(tile, model, flat_coarse, Some(&start), &settings) {
                Ok(eq) => eq,
                Err(first) => solve_equilibrium(tile, model, flat_coarse, None, &settings)
                    .with_context(|| {
                        format!(
                            "polishing the in-plane sample {s:?} (from the database's \
                             displacements: {first}; then from the solver's start)"
                        )
                    })?,
            };
            let zero_rows: Vec<[f32; 4]> = (0..tile.n_vertices())
                .map(|v| inplane.data[inplane.index(v, index[0], index[1], index[2])])
                .collect();
            let mut solves = 1;
            let mut out: [Rows; 2] = [vec![vec![]; kappas.len()], vec![vec![]; kappas.len()]];
            for (axis, rows) in out.iter_mut().enumerate() {
                // Outward from κ = 0 on both sides, each step warm-started from the last.
                let zero = kappas
                    .iter()
                    .position(|&k| k == 0.0)
                    .expect("κ = 0 sampled");
                rows[zero] = zero_rows.clone();
                let bend = Bend {
                    tile,
                    model,
                    settings: &settings,
                    strain: s,
                    axis,
                };
                for side in [
                    (zero + 1..kappas.len()).collect::<Vec<_>>(),
                    (0..zero).rev().collect(),
                ] {
                    let (mut from, mut dofs) = (0.0, eq0.dofs.clone());
                    for k in side {
                        let to = kappas[k];
                        let (next, used) = bend.to((from, &dofs), to, 4)?;
                        solves += used;
                        let coarse = flat_coarse.bent(axis, to);
                        rows[k] = bent_displacements(tile, &coarse, &next)?;
                        (from, dofs) = (to, next);
                    }
                }
            }
            progress();
            Ok((out, solves))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let n = tile.n_vertices();
    let mut solves = 0;
    let mut dbs: [Vec<Database>; 2] = [0, 1].map(|_| {
        kappas
            .iter()
            .map(|_| Database {
                axes: inplane.axes.clone(),
                n_vertices: n,
                data: vec![[0.0; 4]; inplane.data.len()],
            })
            .collect()
    });
    for (flat, (rows, used)) in per_sample.into_iter().enumerate() {
        solves += used;
        let index = [
            flat % dims[0],
            (flat / dims[0]) % dims[1],
            flat / (dims[0] * dims[1]),
        ];
        for axis in 0..2 {
            for (k, db) in dbs[axis].iter_mut().enumerate() {
                for v in 0..n {
                    let row = db.index(v, index[0], index[1], index[2]);
                    db.data[row] = rows[axis][k][v];
                }
            }
        }
    }
    Ok((dbs, solves))
}

/// The rows of `db` at the strain samples `axes`, each of which must be a sample of `db`'s
/// axes (nested grids, e.g. 3³ in 9³; relative tolerance 1e-12).
pub fn restrict_to_axes(db: &Database, axes: &[Vec<f64>; 3]) -> anyhow::Result<Database> {
    // Index of every coarse sample on the dense axes.
    let map = |k: usize| {
        axes[k]
            .iter()
            .map(|&c| {
                db.axes[k]
                    .iter()
                    .position(|&d| (d - c).abs() <= 1e-12 * (1.0 + c.abs()))
                    .ok_or_else(|| anyhow!("strain sample {c} of axis {k} is not nested"))
            })
            .collect::<anyhow::Result<Vec<usize>>>()
    };
    let (ix, ia, iy) = (map(0)?, map(1)?, map(2)?);
    // Rows in the order of `Database::index`: sx fastest, then sa, sy, vertex.
    let mut data = Vec::with_capacity(db.n_vertices * ix.len() * ia.len() * iy.len());
    for v in 0..db.n_vertices {
        for &y in &iy {
            for &a in &ia {
                for &x in &ix {
                    data.push(db.data[db.index(v, x, a, y)]);
                }
            }
        }
    }
    Ok(Database {
        axes: axes.clone(),
        n_vertices: db.n_vertices,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-vertex database on `axes` whose rows encode their sample indices.
    fn indexed(axes: [Vec<f64>; 3]) -> Database {
        let mut db = Database {
            axes,
            n_vertices: 2,
            data: Vec::new(),
        };
        let [nx, na, ny] = [0, 1, 2].map(|k| db.axes[k].len());
        db.data = vec![[0.0; 4]; 2 * nx * na * ny];
        for v in 0..2 {
            for (i, &x) in db.axes[0].clone().iter().enumerate() {
                for (j, &a) in db.axes[1].clone().iter().enumerate() {
                    for (k, &y) in db.axes[2].clone().iter().enumerate() {
                        let row = db.index(v, i, j, k);
                        db.data[row] = [x as f32, a as f32, y as f32, v as f32];
                    }
                }
            }
        }
        db
    }

    /// Restricting a 5 × 3 × 3 grid to nested 3 × 2 × 1 samples keeps exactly their rows;
    /// a sample that is not on the dense grid is an error.
    #[test]
    fn restriction_keeps_the_nested_samples() {
        let dense = indexed([
            vec![-0.1, 0.0, 0.1, 0.2, 0.3],
            vec![-0.2, 0.0, 0.2],
            vec![-0.1, 0.1, 0.3],
        ]);
        let axes = [vec![-0.1, 0.1, 0.3], vec![-0.2, 0.2], vec![0.1]];
        let coarse = restrict_to_axes(&dense, &axes).unwrap();
        assert_eq!(coarse, indexed(axes.clone()));
        let off_grid = [vec![-0.1, 0.05], vec![0.0], vec![0.1]];
        assert!(restrict_to_axes(&dense, &off_grid).is_err());
    }
}
