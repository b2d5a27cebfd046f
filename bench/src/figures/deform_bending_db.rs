//! Shared inputs of the `deform-*` figures that use the explicit bending model of paper 004
//! Appendix C ([`deform_runtime::bending`]): *real* bending-direction databases built from
//! `sim-periodic` bent-tile solves, memoized per process like the in-plane databases of
//! [`super::deform_real_db`], and the curved test sheets.
//!
//! **Bending databases.** For every sample `s` of the real in-plane `n³` database
//! ([`super::deform_real_db`]) and every curvature κ of a small axis, the relaxed stockinette
//! tile is solved under `Coarse::from_strain(s).bent(axis, κ)` (rolled onto a cylinder along
//! the deformed x or y axis) with `sim_periodic::periodic::solve_equilibrium`, warm-started
//! from the in-plane sample's equilibrium (rebuilt from its database row and polished) and
//! continued outward in κ, halving failed steps. The displacement is pulled back through the
//! exact inverse of the roll, `X̂ = F₃⁻¹ φ⁻¹(x)`, `ΔQ = X̂ − X` (the bent counterpart of seed 004
//! Eq. 18); κ = 0 uses the in-plane database itself, so both models agree on flat sheets.
//!
//! The in-plane grids are nested ([`super::deform_real_db`]), so the bending databases of a
//! coarser grid are the dense ones restricted to the coarse samples ([`RealBending::restrict`]):
//! the same bent-tile problems, solved once.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, anyhow};
use deform_runtime::Real;
use deform_runtime::bending::BendingDatabase;
use nalgebra::Vector3;
use rayon::prelude::*;
use sim_periodic::coarse::{Coarse, Strain};
use sim_periodic::madypg::Database;
use sim_periodic::periodic::{EquilibriumSettings, YarnModel, solve_equilibrium};
use sim_periodic::tile::Tile;

use super::deform_real_db as real;
use crate::FigureContext;

/// Largest sampled curvature magnitude (1/m): a radius of ≈ 17 mm, ≈ 4 tile periods.
pub const KAPPA_MAX: f64 = 60.0;

/// Inverse of the roll of [`Coarse::map`] for `curvature` (`axis`, κ ≠ 0): the point
/// `(a, b, z)` with `φ(a, b, z) = x` (valid for `|z| < 1/|κ|`).
fn unroll(axis: usize, kappa: f64, x: &Vector3<f64>) -> Vector3<f64> {
    let c = 1.0 / kappa - x.z;
    let r = kappa.signum() * (x[axis] * x[axis] + c * c).sqrt();
    let angle = (x[axis] / r).atan2(c / r);
    let mut q = Vector3::new(0.0, 0.0, 1.0 / kappa - r);
    q[axis] = angle / kappa;
    q[1 - axis] = x[1 - axis];
    q
}

/// Material displacement rows `(Δx, Δy, Δz, Δθ)` of the equilibrium `dofs` of `tile` under
/// the bent `coarse` map: `ΔQ = F₃⁻¹ φ⁻¹(x) − X` per vertex, `Δθ` of its outgoing edge.
fn bent_displacements(tile: &Tile, coarse: &Coarse, dofs: &[f64]) -> anyhow::Result<Vec<[f32; 4]>> {
    let topology = tile.topology()?;
    let n = tile.n_vertices();
    let inverse = coarse.f3().try_inverse().context("singular coarse map")?;
    let roll = coarse.curvature.filter(|c| c.kappa != 0.0);
    Ok((0..n)
        .map(|v| {
            let y = &tile.positions[v];
            let u = Vector3::new(dofs[3 * v], dofs[3 * v + 1], dofs[3 * v + 2]);
            let x = coarse.map(y) + coarse.frame(y) * u;
            let q = match roll {
                Some(c) => unroll(c.axis, c.kappa, &x),
                None => x,
            };
            let d = inverse * q - y;
            let theta = dofs[3 * n + topology.outgoing(v)] - tile.twists[v];
            [d.x as f32, d.y as f32, d.z as f32, theta as f32]
        })
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
    /// `dofs`; halves the step up to `depth` times. Returns the DOFs and the number of solves.
    fn to(
        &self,
        (from, dofs): (f64, &[f64]),
        to: f64,
        depth: usize,
    ) -> anyhow::Result<(Vec<f64>, usize)> {
        let coarse = Coarse::from_strain(&self.strain).bent(self.axis, to);
        match solve_equilibrium(self.tile, self.model, coarse, Some(dofs), self.settings) {
            Ok(eq) => Ok((eq.dofs, 1)),
            Err(e) if depth == 0 => Err(e).with_context(|| {
                let s = &self.strain;
                format!(
                    "bending the tile along axis {} to κ = {to} 1/m at (sx, sa, sy) = ({}, {}, {})",
                    self.axis, s.sx, s.sa, s.sy
                )
            }),
            Err(_) => {
                let mid = 0.5 * (from + to);
                let (half, a) = self.to((from, dofs), mid, depth - 1)?;
                let (full, b) = self.to((mid, &half), to, depth - 1)?;
                Ok((full, a + b + 1))
            }
        }
    }
}

/// The bending-direction databases `[along x, along y]`, one per curvature of `kappas` (which
/// contains 0, where the in-plane database is used), and the number of equilibrium solves.
pub fn bending_databases(
    reference: &real::Reference,
    inplane: &Database,
    kappas: &[f64],
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<([Vec<Database>; 2], usize)> {
    let (tile, model) = (&reference.tile, &reference.model);
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
            let eq0 = solve_equilibrium(tile, model, flat_coarse, Some(&start), &settings)
                .with_context(|| format!("polishing the in-plane sample {s:?}"))?;
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

/// World position of UV point `uv` of a sheet rolled with curvature `kappa` (1/m) along the
/// unit in-plane direction `dir` (centre of curvature on the +z side); flat for κ = 0.
pub fn rolled(uv: [f64; 2], dir: [f64; 2], kappa: f64) -> [f64; 3] {
    let a = uv[0] * dir[0] + uv[1] * dir[1];
    let b = -uv[0] * dir[1] + uv[1] * dir[0];
    let (along, z) = if kappa == 0.0 {
        (a, 0.0)
    } else {
        ((kappa * a).sin() / kappa, (1.0 - (kappa * a).cos()) / kappa)
    };
    [along * dir[0] - b * dir[1], along * dir[1] + b * dir[0], z]
}

/// Real bending-direction databases of one in-plane density, with their provenance.
#[derive(Debug)]
pub struct RealBending {
    /// The in-plane database the samples bend (`n³`).
    pub inplane: Arc<real::RealDatabase>,
    /// Curvature samples κ (1/m), strictly increasing, containing 0.
    pub kappas: Vec<f64>,
    /// `[along x, along y]`, one database per curvature of [`RealBending::kappas`] (the
    /// in-plane database at κ = 0).
    pub along: [Vec<Database>; 2],
    /// Equilibrium solves (polishes, continuation steps and halvings).
    pub solves: usize,
    /// Wall time of the bent solves (s), excluding the in-plane database.
    pub seconds: f64,
}

impl RealBending {
    /// The explicit bending model ([`BendingDatabase`]) of these databases in precision `T`.
    pub fn model<T: Real>(&self, tile: &Tile) -> anyhow::Result<BendingDatabase<T>> {
        let [x, y] = &self.along;
        BendingDatabase::new(tile, &self.kappas, x, y).context("building the bending model")
    }

    /// The bending databases restricted to the strain samples of `coarse` (an in-plane
    /// database on a grid nested in this one, e.g. 3³ in 9³), with `coarse` itself at κ = 0 so
    /// that both models still agree on flat sheets.
    pub fn restrict(&self, coarse: &Database) -> anyhow::Result<[Vec<Database>; 2]> {
        let dense = &self.inplane.generated.database;
        if coarse.n_vertices != dense.n_vertices {
            return Err(anyhow!(
                "pattern mismatch: {} vs {} vertices",
                coarse.n_vertices,
                dense.n_vertices
            ));
        }
        let mut out: [Vec<Database>; 2] = [Vec::new(), Vec::new()];
        for (dbs, restricted) in self.along.iter().zip(&mut out) {
            for (db, &kappa) in dbs.iter().zip(&self.kappas) {
                restricted.push(if kappa == 0.0 {
                    coarse.clone()
                } else {
                    subsample(db, &coarse.axes)?
                });
            }
        }
        Ok(out)
    }
}

/// The rows of `db` at the strain samples `axes`, each of which must be a sample of `db`'s
/// axes (nested grids).
fn subsample(db: &Database, axes: &[Vec<f64>; 3]) -> anyhow::Result<Database> {
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

static BENDING: Mutex<Vec<Arc<RealBending>>> = Mutex::new(Vec::new());

/// The real bending databases of the `n³` in-plane database at curvatures `kappas` (1/m,
/// strictly increasing, containing 0), generated on first use in this process (with progress
/// bars of `ctx`) and reused afterwards.
pub fn bending(ctx: &FigureContext, n: usize, kappas: &[f64]) -> anyhow::Result<Arc<RealBending>> {
    let reference = real::reference()?;
    let progress = ctx.progress((n * n * n) as u64, "in-plane samples");
    let inplane = real::database(n, &|| progress.inc(1))?;
    progress.finish_and_clear();
    // Held during generation, as for the in-plane databases.
    let mut cache = BENDING
        .lock()
        .map_err(|_| anyhow!("bending database cache lock poisoned"))?;
    if let Some(b) = cache
        .iter()
        .find(|b| b.inplane.n == n && b.kappas == kappas)
    {
        return Ok(b.clone());
    }
    let progress = ctx.progress((n * n * n) as u64, "bent samples");
    let t = Instant::now();
    let (along, solves) =
        bending_databases(&reference, &inplane.generated.database, kappas, &|| {
            progress.inc(1)
        })?;
    let seconds = t.elapsed().as_secs_f64();
    progress.finish_and_clear();
    let b = Arc::new(RealBending {
        inplane,
        kappas: kappas.to_vec(),
        along,
        solves,
        seconds,
    });
    cache.push(b.clone());
    Ok(b)
}

/// World position of UV point `uv` of a sheet bent along the unit in-plane direction `dir`
/// with curvature `κ(a) = mean + amplitude · sin(2π a / wavelength)` (1/m) at arc length
/// `a = uv · dir`: an isometry of the plane (no in-plane strain), so every curvature in
/// `mean ± amplitude` occurs, with the centre of curvature on the `+z` side where κ > 0.
/// Returns the position and the unit normal there.
pub fn waved(
    uv: [f64; 2],
    dir: [f64; 2],
    [mean, amplitude]: [f64; 2],
    wavelength: f64,
) -> ([f64; 3], [f64; 3]) {
    let a = uv[0] * dir[0] + uv[1] * dir[1];
    let b = -uv[0] * dir[1] + uv[1] * dir[0];
    let k = 2.0 * std::f64::consts::PI / wavelength;
    // Tangent angle θ(t) = ∫₀ᵗ κ; position by Simpson's rule.
    let theta = |t: f64| mean * t + amplitude / k * (1.0 - (k * t).cos());
    let steps = 256;
    let hstep = a / steps as f64;
    let (mut along, mut z) = (0.0, 0.0);
    for i in 0..=steps {
        let w = if i == 0 || i == steps {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let (s, c) = theta(i as f64 * hstep).sin_cos();
        along += w * c;
        z += w * s;
    }
    along *= hstep / 3.0;
    z *= hstep / 3.0;
    let (s, c) = theta(a).sin_cos();
    (
        [along * dir[0] - b * dir[1], along * dir[1] + b * dir[0], z],
        [-s * dir[0], -s * dir[1], c],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unroll_inverts_the_roll() {
        let f = nalgebra::Matrix2::new(1.1, 0.05, 0.05, 0.95);
        for axis in 0..2 {
            for kappa in [-80.0, 25.0] {
                let coarse = Coarse::in_plane(f).bent(axis, kappa);
                let y = Vector3::new(0.003, -0.002, 0.0007);
                let q = unroll(axis, kappa, &coarse.map(&y));
                let back = coarse.f3().try_inverse().unwrap() * q;
                assert!((back - y).norm() < 1e-15, "{back} vs {y}");
            }
        }
    }

    #[test]
    fn subsampling_a_nested_grid_keeps_the_samples() {
        let path = format!("{}/../{}", env!("CARGO_MANIFEST_DIR"), real::PATTERN);
        let tile = sim_periodic::pyp::read_pyp(&path).unwrap().tile;
        let f = deform_runtime::synthetic::multilinear(tile.radius);
        let dense = deform_runtime::synthetic::database(&tile, real::axes(5), &f);
        let coarse = real::axes(3);
        let sub = subsample(&dense, &coarse).unwrap();
        let direct = deform_runtime::synthetic::database(&tile, coarse, &f);
        assert_eq!(sub, direct);
        assert!(subsample(&dense, &real::axes(4)).is_err());
    }

    #[test]
    fn waved_sheet_is_isometric_with_the_requested_curvature() {
        let (kappa, dir, wavelength) = ([25.0, 35.0], [0.6, 0.8], 0.2);
        let p = |t: f64| waved([t * dir[0], t * dir[1]], dir, kappa, wavelength).0;
        let n = |t: f64| waved([t * dir[0], t * dir[1]], dir, kappa, wavelength).1;
        for t in [0.013, 0.05, 0.137] {
            let (a, b) = (p(t - 1e-5), p(t + 1e-5));
            let speed = ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt() / 2e-5;
            assert!((speed - 1.0).abs() < 1e-6, "{speed}");
            // Curvature: second derivative along the normal.
            let (c, m, h) = (p(t), n(t), 1e-4);
            let (a, b) = (p(t - h), p(t + h));
            let dd: f64 = (0..3)
                .map(|k| (a[k] - 2.0 * c[k] + b[k]) / (h * h) * m[k])
                .sum();
            let want = kappa[0] + kappa[1] * (2.0 * std::f64::consts::PI * t / wavelength).sin();
            assert!((dd - want).abs() < 1e-3 * kappa[1], "{dd} vs {want}");
        }
        // Across the wave the sheet stays flat and unstretched.
        let a = waved([0.0, 0.0], dir, kappa, wavelength).0;
        let b = waved([-0.8, 0.6], dir, kappa, wavelength).0;
        let d = ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt();
        assert!((d - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rolled_sheet_has_the_requested_curvature() {
        // Unit speed along the roll direction and distance 1/κ from the axis.
        let (kappa, dir) = (40.0, [0.6, 0.8]);
        let p = |t: f64| rolled([t * dir[0], t * dir[1]], dir, kappa);
        let (a, b) = (p(0.01), p(0.01 + 1e-6));
        let speed = ((0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>()).sqrt() / 1e-6;
        assert!((speed - 1.0).abs() < 1e-6);
        let centre = [0.0, 0.0, 1.0 / kappa];
        let dist = ((0..3).map(|k| (a[k] - centre[k]).powi(2)).sum::<f64>()).sqrt();
        assert!((dist - 1.0 / kappa).abs() < 1e-12);
    }
}
