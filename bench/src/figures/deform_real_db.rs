//! Shared inputs of the `deform-*` figures that use *real* displacement databases: the
//! stockinette tile relaxed at zero strain and databases generated from it by
//! `sim_periodic::database::generate`, memoized in the run's [`RealCache`] (so a full
//! `reproduce-figures` run generates each density once), plus the test sheet and the error
//! measure the studies share.
//!
//! All databases sample the same strain box [`SX`] × [`SA`] × [`SY`] uniformly, so the grids
//! with 2, 3, 5 and 9 samples per axis are nested (every coarse sample is also a sample of the
//! denser grids).

use std::sync::{Arc, Mutex};

use anyhow::{Context, anyhow};
use deform_runtime::deform::YarnOutput;
use deform_runtime::obj::ObjMesh;
use deform_runtime::{Deformer, FrameStats, Real, synthetic};
use sim_periodic::database::{
    DatabaseSettings, Generated, generate, relax_reference, uniform_axis,
};
use sim_periodic::periodic::{EquilibriumSettings, YarnModel};
use yarn_pattern::pyp::read_pyp;
use yarn_pattern::tile::Tile;

use crate::FigureContext;

/// The pattern, relative to the workspace root.
pub const PATTERN: &str = "tests/data/patterns/stockinette.pyp";
/// Sampled range of `sx` (unitless); below ≈ −0.106 compression clamping (λmin = 0.8) applies.
pub const SX: [f64; 2] = [-0.1, 0.3];
/// Sampled range of `sa` (unitless).
pub const SA: [f64; 2] = [-0.2, 0.2];
/// Sampled range of `sy` (unitless).
pub const SY: [f64; 2] = [-0.1, 0.3];

/// The strain box a database samples: `[min, max]` of sx, sa and sy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrainBox {
    /// Range of `sx`.
    pub sx: [f64; 2],
    /// Range of `sa`.
    pub sa: [f64; 2],
    /// Range of `sy`.
    pub sy: [f64; 2],
}

/// The box of the deformer figures ([`SX`], [`SA`], [`SY`]).
pub const SMALL_BOX: StrainBox = StrainBox {
    sx: SX,
    sa: SA,
    sy: SY,
};

/// The full published range of seed 004's databases: sx, sy ∈ [−0.2, 1.0], sa ∈ [−0.7, 0.7].
pub const PUBLISHED_BOX: StrainBox = StrainBox {
    sx: [-0.2, 1.0],
    sa: [-0.7, 0.7],
    sy: [-0.2, 1.0],
};

/// The tile the databases are relative to.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The stockinette tile relaxed at zero strain (`relax_reference`).
    pub tile: Tile,
    /// The yarn model (`YarnModel::default_for_radius`).
    pub model: YarnModel,
    /// Wall time of the relaxation (s).
    pub relax_seconds: f64,
}

/// A generated database with its provenance.
#[derive(Debug)]
pub struct RealDatabase {
    /// Samples per axis.
    pub n: usize,
    /// The sampled strain box.
    pub strain_box: StrainBox,
    /// The generation result (database, per-sample records, wall time).
    pub generated: Generated,
}

impl RealDatabase {
    /// Sum of the per-sample solve times (s): the CPU-side cost, independent of how the
    /// continuation tree was parallelized.
    pub fn sample_seconds(&self) -> f64 {
        self.generated.samples.iter().map(|s| s.seconds).sum()
    }

    /// Total Newton iterations over all samples.
    pub fn iterations(&self) -> usize {
        self.generated.samples.iter().map(|s| s.iterations).sum()
    }
}

/// The real data of one figure run, in [`FigureContext::cache`]: the relaxed reference tile,
/// the in-plane databases by density and the bending databases
/// ([`super::deform_bending_db::bending`]), each computed on first use.
#[derive(Debug, Default)]
pub struct RealCache {
    reference: Mutex<Option<Arc<Reference>>>,
    databases: Mutex<Vec<Arc<RealDatabase>>>,
    /// Bending databases by (density, curvatures).
    pub(super) bending: Mutex<Vec<Arc<super::deform_bending_db::RealBending>>>,
}

/// The relaxed stockinette tile (relaxed once per run).
pub fn reference(ctx: &FigureContext) -> anyhow::Result<Arc<Reference>> {
    let cache = ctx.cache.get::<RealCache>();
    let mut slot = cache
        .reference
        .lock()
        .map_err(|_| anyhow!("reference tile lock poisoned"))?;
    if let Some(r) = slot.as_ref() {
        return Ok(r.clone());
    }
    let path = format!("{}/../{PATTERN}", env!("CARGO_MANIFEST_DIR"));
    let tile = read_pyp(&path)
        .with_context(|| format!("reading {PATTERN}"))?
        .tile;
    let model = YarnModel::default_for_radius(tile.radius);
    let (relaxed, report) = relax_reference(&tile, &model, &EquilibriumSettings::default())
        .context("relaxing the stockinette tile at zero strain")?;
    let r = Arc::new(Reference {
        tile: relaxed,
        model,
        relax_seconds: report.seconds,
    });
    *slot = Some(r.clone());
    Ok(r)
}

/// The uniform axes `[sx, sa, sy]` of [`SMALL_BOX`] with `n` samples each.
pub fn axes(n: usize) -> [Vec<f64>; 3] {
    axes_in(n, &SMALL_BOX)
}

/// The uniform axes `[sx, sa, sy]` of `b` with `n` samples each.
pub fn axes_in(n: usize, b: &StrainBox) -> [Vec<f64>; 3] {
    [
        uniform_axis(b.sx[0], b.sx[1], n),
        uniform_axis(b.sa[0], b.sa[1], n),
        uniform_axis(b.sy[0], b.sy[1], n),
    ]
}

/// The `n³` databases of every density in `densities`, with one progress bar of `ctx` over
/// all their samples.
pub fn databases(
    ctx: &FigureContext,
    densities: &[usize],
) -> anyhow::Result<Vec<Arc<RealDatabase>>> {
    databases_in(ctx, densities, &SMALL_BOX)
}

/// [`databases`] over the strain box `b`.
pub fn databases_in(
    ctx: &FigureContext,
    densities: &[usize],
    b: &StrainBox,
) -> anyhow::Result<Vec<Arc<RealDatabase>>> {
    let total: usize = densities.iter().map(|n| n * n * n).sum();
    let progress = ctx.progress(total as u64, "database samples");
    let dbs = densities
        .iter()
        .map(|&n| database_in(ctx, n, b, &|| progress.inc(1)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    progress.finish_and_clear();
    Ok(dbs)
}

/// The real `n³` database of the relaxed tile, generated on first use in this run
/// (`progress` is called after every solved sample) and reused afterwards.
pub fn database(
    ctx: &FigureContext,
    n: usize,
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<Arc<RealDatabase>> {
    database_in(ctx, n, &SMALL_BOX, progress)
}

/// [`database`] over the strain box `b`.
pub fn database_in(
    ctx: &FigureContext,
    n: usize,
    b: &StrainBox,
    progress: &(dyn Fn() + Sync),
) -> anyhow::Result<Arc<RealDatabase>> {
    let reference = reference(ctx)?;
    let run_cache = ctx.cache.get::<RealCache>();
    // Held during generation: figures run one after another, and a second caller for the
    // same density should wait rather than generate it again.
    let mut cache = run_cache
        .databases
        .lock()
        .map_err(|_| anyhow!("database cache lock poisoned"))?;
    if let Some(db) = cache.iter().find(|d| d.n == n && d.strain_box == *b) {
        return Ok(db.clone());
    }
    let generated = generate(
        &reference.tile,
        &reference.model,
        axes_in(n, b),
        &DatabaseSettings::default(),
        None,
        &|_| progress(),
    )
    .with_context(|| format!("generating the {n}³ database"))?;
    let db = Arc::new(RealDatabase {
        n,
        strain_box: *b,
        generated,
    });
    cache.push(db.clone());
    Ok(db)
}

/// A flat square sheet of `cells × cells` pattern periods meshed with `quads × quads` quads.
pub fn sheet(tile: &Tile, cells: f64, quads: usize) -> ObjMesh {
    synthetic::grid_mesh(quads, quads, cells * tile.period[0], cells * tile.period[1])
}

/// The test deformation of a sheet of UV size `size` (m): a smooth, non-uniform strain field
/// that stays inside the sampled box (`sx ≈ −0.05 … 0.27`, `sy ≈ −0.03 … 0.18`,
/// `|sa| ≲ 0.1`) plus a gentle out-of-plane bump (curvature for linearized bending).
pub fn test_field(uv: [f64; 2], size: [f64; 2]) -> [f64; 3] {
    let [u, v] = uv;
    let [w, h] = size;
    let (xi, eta) = (u / w, v / h);
    let pi = std::f64::consts::PI;
    [
        0.95 * u + 0.15 * w * xi * xi,
        0.5 * h + (v - 0.5 * h) * (0.97 + 0.2 * xi),
        0.04 * w.min(h) * (pi * xi).sin() * (pi * eta).sin(),
    ]
}

/// The test-field positions of `mesh` (a sheet from [`sheet`] of UV size `size`).
pub fn test_positions(mesh: &ObjMesh, size: [f64; 2]) -> Vec<[f64; 3]> {
    synthetic::map_uvs(mesh, |uv| test_field(uv, size))
}

/// RMS and maximum distance between two outputs of the same embedding, relative to `r`.
pub fn position_error<A: Real, B: Real>(a: &YarnOutput<A>, b: &YarnOutput<B>, r: f64) -> [f64; 2] {
    let n = a.x.len().min(b.x.len());
    let (mut sum, mut max) = (0.0f64, 0.0f64);
    for k in 0..n {
        let d2 = (a.x[k].as_() - b.x[k].as_()).powi(2)
            + (a.y[k].as_() - b.y[k].as_()).powi(2)
            + (a.z[k].as_() - b.z[k].as_()).powi(2);
        sum += d2;
        max = max.max(d2);
    }
    if n == 0 {
        return [0.0, 0.0];
    }
    [(sum / n as f64).sqrt() / r, max.sqrt() / r]
}

/// RMS distance / `r` between `d`'s output and the embedded rest (material) positions: the error
/// of a zero-strain frame, whose exact result is the relaxed pattern itself.
pub fn rest_error<T: Real>(d: &Deformer<T>, r: f64) -> f64 {
    let e = d.embedding();
    let o = d.output();
    let n = e.len();
    if n == 0 {
        return 0.0;
    }
    let sum: f64 = e
        .material
        .iter()
        .enumerate()
        .map(|(k, m)| {
            (o.x[k].as_() - m[0]).powi(2)
                + (o.y[k].as_() - m[1]).powi(2)
                + (o.z[k].as_() - m[2]).powi(2)
        })
        .sum();
    (sum / n as f64).sqrt() / r
}

/// Best-of-`frames` per-frame times `(mesh stage, per-vertex stage)` (s) of `d` on
/// `positions`, recomputing every frame (static-frame skipping off).
pub fn frame_seconds<T: Real>(
    d: &mut Deformer<T>,
    positions: &[[f64; 3]],
    frames: usize,
) -> anyhow::Result<(f64, f64)> {
    best_frame_seconds(d, frames, |d| d.frame(positions))
}

/// Best-of-`frames` per-frame times `(mesh stage, per-vertex stage)` (s) of `frame` run on
/// `d` (after one warm-up call), with static-frame skipping off; e.g.
/// `|d| d.frame_explicit(positions, &bending)` for the explicit bending model.
pub fn best_frame_seconds<T: Real>(
    d: &mut Deformer<T>,
    frames: usize,
    mut frame: impl FnMut(&mut Deformer<T>) -> deform_runtime::Result<FrameStats>,
) -> anyhow::Result<(f64, f64)> {
    let mut options = *d.options();
    options.skip_static = false;
    d.set_options(options)?;
    frame(d)?;
    let mut best = (f64::INFINITY, f64::INFINITY);
    for _ in 0..frames.max(1) {
        let s = frame(d)?;
        if s.mesh_seconds + s.vertex_seconds < best.0 + best.1 {
            best = (s.mesh_seconds, s.vertex_seconds);
        }
    }
    Ok(best)
}
