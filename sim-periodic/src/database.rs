//! Generation of the displacement database ΔQ(sx, sa, sy) of a tile (seed 004 §3.2).
//!
//! **Reference.** The database is relative to the tile *relaxed at zero strain*
//! ([`relax_reference`]): its positions and twists are replaced by the equilibrium ones, so
//! that ΔQ = 0 at zero strain up to the solver tolerance, and the runtime deforms that relaxed
//! pattern (write it next to the database as `.pyp`).
//!
//! **Sample.** For every grid point `(sx[i], sa[j], sy[k])` the tile is solved to equilibrium
//! under `F₂ = √I` with the no-sliding constraint (seed 004 Eq. 3), and the fluctuation is
//! pulled back into material space (seed 004 Eq. 18, in-plane: `X̂ = X + diag(√I⁻¹, 1) ũ`):
//!
//! ```text
//! ΔQ_v = (F₃⁻¹ ũ_v, θ_{out(v)} − Θ_{out(v)})
//! ```
//!
//! with `θ_{out(v)}` the twist angle of the edge leaving vertex `v`.
//!
//! **Continuation.** Samples are solved along a tree rooted at the grid point nearest zero
//! strain: first along the `sx` line through it, then, in parallel for every `sx`, along `sy`,
//! then, in parallel for every `(sx, sy)`, along `sa` — each sample warm-started from its
//! neighbour one step closer to the root. A step whose Newton solve fails is split in half
//! (up to [`DatabaseSettings::max_bisections`] times). A sample its line still cannot reach
//! is left to a repair pass once all lines are done: one sample at a time, in grid order, it
//! is continued from each solved grid neighbour in the fixed order −sx, +sx, −sy, +sy, −sa,
//! +sa until one succeeds (on the procedural satin, 9³ over the full range, this solves the
//! one sample that the sa line misses, (−0.2, 0.175, 0.55)); only then is it reported as
//! failed. Where several equilibria exist (jammed states), a sample gets the one this path
//! reaches, so the database is the same on every run, after a resume and with any thread
//! count.
//!
//! **Warm start.** The neighbour's fluctuation is carried over with its *material*
//! displacement held, `ũ' = F₂' F₂⁻¹ ũ`, i.e. its ΔQ (Eq. 18) is the prediction, not its
//! world-space `ũ`: under the new strain the yarn structure is stretched with the fabric
//! instead of left where it was. Together with the solver's larger augmentation this took the
//! `periodic-databases` benchmark (9³, full range, dev profile, 2 threads) from 42.9 s to
//! 35.7 s on the real stockinette and from 79.8 s with 2 unsolved samples to 23.5 s with none
//! on the procedural seed.
//!
//! **Unsolvable samples.** Every Newton step is filtered so that no yarn passes through
//! another ([`crate::periodic::PeriodicTile`]'s `max_step`). Far out in the strain range
//! (e.g. 100 % weft with 25 % warp stretch and shear on the real stockinette with the
//! illustrative yarn model) the tile then has no reachable equilibrium: the yarns are pulled
//! into each other until Newton stalls against the filter. Such a sample is an error by
//! default; with [`DatabaseSettings::fill_unsolved`] it is filled from its continuation parent,
//! flagged in its [`SampleRecord`] and reported, so a long run still yields a complete grid.
//!
//! **Resumability.** With a checkpoint directory, every finished sample is written there at
//! once (atomically: temporary file, then rename) with its DOFs; a rerun with the same inputs
//! loads them and solves only what is missing. A fingerprint of the inputs (tile, model, axes,
//! settings) guards against resuming with different inputs.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use nalgebra::Matrix2;
use rayon::prelude::*;
use solver::checksum::fnv1a;
use solver::{DenseEval, DenseNewtonError, DenseNewtonSettings, Probe, StepError, newton_dense};

use crate::coarse::{Coarse, Strain};
use crate::patterns::{PatternError, RelaxReport, RelaxSettings, relax};
use crate::periodic::{
    Equilibrium, EquilibriumSettings, PeriodicError, PeriodicTile, YarnModel, initial_dofs,
    solve_equilibrium,
};
use crate::shard::{Completion, Shard, ShardError, check_complete, write_completion};
use yarn_pattern::madypg::{AXIS_NAMES, Database, DatabaseError};
use yarn_pattern::tile::Tile;

/// Settings of a database generation.
#[derive(Clone, Debug)]
pub struct DatabaseSettings {
    /// Settings of every equilibrium solve.
    pub equilibrium: EquilibriumSettings,
    /// How often a failed continuation step may be halved. Default 4 (steps down to 1/16).
    pub max_bisections: usize,
    /// Newton iterations a warm-started attempt may take before its step is halved instead;
    /// the last allowed halving gets the full `equilibrium.newton.max_iterations`. Default 200
    /// (no cap with the default settings): on the stockinette 5³ grid a cap of 40 made the
    /// jammed corner (−0.2, −0.7, −0.2) fail, while uncapped attempts reach it.
    pub attempt_iterations: usize,
    /// When a sample cannot be solved even with halved steps, fill it from its continuation
    /// parent (the last solved sample on its line: that equilibrium's fluctuation, pulled
    /// back under the sample's own strain) and go on, instead of stopping with
    /// [`GenerationError::Solve`]. Such samples have [`SampleRecord::solved`] `false`, their
    /// Ψ and stress are those of the parent's state under the sample's strain (not an
    /// equilibrium), they are not checkpointed (a resumed run tries them again), and the
    /// CLI reports them. Default `false`.
    pub fill_unsolved: bool,
}

impl Default for DatabaseSettings {
    fn default() -> Self {
        Self {
            equilibrium: EquilibriumSettings::default(),
            max_bisections: 4,
            attempt_iterations: 200,
            fill_unsolved: false,
        }
    }
}

/// Errors of database generation.
#[derive(Debug, thiserror::Error)]
pub enum GenerationError {
    /// An axis is invalid (see [`yarn_pattern::madypg`]).
    #[error(transparent)]
    Database(#[from] DatabaseError),
    /// A grid point is not an admissible strain.
    #[error(
        "sample (sx, sa, sy) = ({}, {}, {}) is not admissible: need sx, sy > -1 and |sa| < 1",
        .0.sx, .0.sa, .0.sy
    )]
    Inadmissible(Strain),
    /// The tile could not be solved at a sample, even with halved steps.
    #[error(
        "no equilibrium at (sx, sa, sy) = ({}, {}, {}) after {bisections} step halvings: {source}",
        strain.sx, strain.sa, strain.sy
    )]
    Solve {
        /// The sample.
        strain: Strain,
        /// Halvings tried.
        bisections: usize,
        /// The last solver error.
        source: PeriodicError,
    },
    /// The relaxation at zero strain failed.
    #[error("relaxing the tile at zero strain failed: {0}")]
    Relax(PatternError),
    /// A checkpoint could not be read or written, or belongs to other inputs.
    #[error("checkpoint {}: {problem}", path.display())]
    Checkpoint {
        /// The file or directory.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// A sample a shard could not solve (marked in the checkpoint, [`generate_shard`]) that
    /// the merge's repair pass could not reach either.
    #[error(
        "no equilibrium at (sx, sa, sy) = ({}, {}, {}) (marked failed by its shard): {problem}",
        strain.sx, strain.sa, strain.sy
    )]
    ShardUnsolved {
        /// The sample.
        strain: Strain,
        /// The shard's error.
        problem: String,
    },
    /// The shards of a merge are incomplete or belong to other inputs.
    #[error(transparent)]
    Shard(#[from] ShardError),
    /// A solve produced a non-finite value (never written to a database).
    #[error("non-finite result at (sx, sa, sy) = ({}, {}, {})", .0.sx, .0.sa, .0.sy)]
    NonFinite(Strain),
}

/// One solved sample.
#[derive(Clone, Debug)]
pub struct SampleRecord {
    /// Grid indices `(isx, isa, isy)`.
    pub index: [usize; 3],
    /// The strain.
    pub strain: Strain,
    /// Energy density Ψ (J/m²).
    pub density: f64,
    /// Gathered stress ∂Ψ/∂F₂ (N/m).
    pub stress: Matrix2<f64>,
    /// Newton iterations (all sub-steps).
    pub iterations: usize,
    /// Continuation sub-steps used (1 when the direct warm start converged).
    pub substeps: usize,
    /// Wall time of this sample's solves (s); 0 when loaded from a checkpoint.
    pub seconds: f64,
    /// Whether it was loaded from a checkpoint rather than solved.
    pub resumed: bool,
    /// `false` for a sample filled from its continuation parent
    /// ([`DatabaseSettings::fill_unsolved`]).
    pub solved: bool,
}

/// The result of [`generate`].
#[derive(Clone, Debug)]
pub struct Generated {
    /// The displacement database (relative to the reference tile given to [`generate`]).
    pub database: Database,
    /// Per-sample records, in database order (`isx` fastest, then `isa`, then `isy`).
    pub samples: Vec<SampleRecord>,
    /// Total wall time (s).
    pub seconds: f64,
}

/// Relaxes `tile` at zero strain without changing its rest shape: solve, re-base the tile on
/// the solution (positions, twists, directors transported, see [`crate::patterns::rebase`]),
/// and repeat until a solve moves it by less than 1e-10 m ([`crate::patterns::relax`] with no
/// rest-shape reset rounds). The result is the reference the database is relative to.
pub fn relax_reference(
    tile: &Tile,
    model: &YarnModel,
    settings: &EquilibriumSettings,
) -> Result<(Tile, RelaxReport), GenerationError> {
    let settings = RelaxSettings {
        rounds: 0,
        equilibrium: settings.clone(),
        ..RelaxSettings::default()
    };
    relax(tile, model, &settings).map_err(GenerationError::Relax)
}

/// The outcome of [`relax_period`].
#[derive(Clone, Debug)]
pub struct PeriodRelaxation {
    /// Stretch `(F₁₁, F₂₂)` applied to the period (unitless).
    pub stretch: [f64; 2],
    /// Remaining coarse stress `∂Ψ/∂F₂` (N/m) of the new tile at zero strain.
    pub stress: Matrix2<f64>,
    /// Equilibrium solves used.
    pub solves: usize,
}

/// Finds the tile period at which the relaxed tile carries no normal coarse stress
/// (`P₁₁ = P₂₂ = 0` under `F₂ = diag(a, b)`, [`solver::newton_dense`] on `(a, b)` with a finite-difference
/// Jacobian of the gathered stress, each stress an equilibrium solve), then re-bases the tile
/// on that state ([`crate::patterns::rebase_stretched`]) and settles it with
/// [`relax_reference`]. A file tile relaxed with a yarn model other than its own is otherwise
/// pre-stressed at its nominal period, and its curves start at a non-zero stress. The shear
/// stress `P₁₂` is left as is (reported). `tol` is in N/m.
pub fn relax_period(
    tile: &Tile,
    model: &YarnModel,
    settings: &EquilibriumSettings,
    tol: f64,
) -> Result<(Tile, PeriodRelaxation), GenerationError> {
    // Re-basing and settling moves the state slightly (the transported frames change the
    // energy at first order in the move), so repeat until the settled tile meets `tol`.
    let mut current = tile.clone();
    let mut total = PeriodRelaxation {
        stretch: [1.0, 1.0],
        stress: Matrix2::zeros(),
        solves: 0,
    };
    for _ in 0..4 {
        let (next, step) = relax_period_once(&current, model, settings, tol)?;
        current = next;
        total.stretch = [
            total.stretch[0] * step.stretch[0],
            total.stretch[1] * step.stretch[1],
        ];
        total.stress = step.stress;
        total.solves += step.solves;
        if step.stress[(0, 0)].abs().max(step.stress[(1, 1)].abs()) <= tol {
            return Ok((current, total));
        }
    }
    Err(GenerationError::Relax(PatternError::Invalid(format!(
        "the settled period still carries |P| = {:.3e} N/m > {tol} N/m",
        total.stress[(0, 0)].abs().max(total.stress[(1, 1)].abs())
    ))))
}

fn relax_period_once(
    tile: &Tile,
    model: &YarnModel,
    settings: &EquilibriumSettings,
    tol: f64,
) -> Result<(Tile, PeriodRelaxation), GenerationError> {
    let (tile, _) = relax_reference(tile, model, settings)?;
    let mut solves = 0;
    // Every residual is an equilibrium solve, warm-started from the last iterate's (so the
    // finite-difference probes start from the state they perturb).
    let mut warm: Option<Vec<f64>> = None;
    let newton = DenseNewtonSettings {
        residual_tol: tol,
        max_iterations: 20,
        fd_step: 1e-4,
        max_step: 0.05, // at most 5 % per step
    };
    let root = newton_dense([1.0, 1.0], &newton, |ab, probe| {
        let coarse = Coarse::in_plane(Matrix2::new(ab[0], 0.0, 0.0, ab[1]));
        solves += 1;
        let eq = solve_equilibrium(&tile, model, coarse, warm.as_deref(), settings).map_err(
            |source| GenerationError::Solve {
                strain: coarse.strain(),
                bisections: 0,
                source,
            },
        )?;
        if probe == Probe::Point {
            warm = Some(eq.dofs.clone());
        }
        Ok(DenseEval {
            residual: [eq.stress[(0, 0)], eq.stress[(1, 1)]],
            jacobian: None,
            data: eq,
        })
    })
    .map_err(|e| match e {
        DenseNewtonError::Eval { source, .. } => source,
        DenseNewtonError::Singular(_) => GenerationError::Relax(PatternError::Invalid(
            "the period stiffness is singular".into(),
        )),
        e => GenerationError::Relax(PatternError::Invalid(format!(
            "the period did not relax to |P| <= {tol} N/m: {e}"
        ))),
    })?;
    let relaxed = crate::patterns::rebase_stretched(&tile, root.x, &root.data.dofs)
        .map_err(GenerationError::Relax)?;
    let (relaxed, report) = relax_reference(&relaxed, model, settings)?;
    Ok((
        relaxed,
        PeriodRelaxation {
            stretch: root.x,
            stress: report.stress,
            solves: solves + report.iterations.len(),
        },
    ))
}

/// The material-space displacement rows `(Δx, Δy, Δz, Δθ)` of the equilibrium DOFs `dofs`
/// under the `coarse` map (seed 004 Eq. 18), per vertex: [`crate::pullback::pullback`].
pub fn material_displacements(
    tile: &Tile,
    coarse: &Coarse,
    dofs: &[f64],
) -> Result<Vec<[f64; 4]>, PeriodicError> {
    crate::pullback::pullback(tile, coarse, dofs)
}

/// Generates the database of the (already relaxed, see [`relax_reference`]) `tile` over
/// `axes = [sx, sa, sy]`, optionally checkpointing into `checkpoint`, calling `progress` after
/// every finished sample (from worker threads).
pub fn generate(
    tile: &Tile,
    model: &YarnModel,
    axes: [Vec<f64>; 3],
    settings: &DatabaseSettings,
    checkpoint: Option<&Path>,
    progress: &(dyn Fn(&SampleRecord) + Sync),
) -> Result<Generated, GenerationError> {
    match run(
        tile,
        model,
        axes,
        settings,
        checkpoint,
        Plan::Full,
        progress,
    )? {
        Outcome::Database(generated) => Ok(generated),
        Outcome::Shard(_) => unreachable!("a full run yields a database"),
    }
}

/// What one shard of a sharded generation did ([`generate_shard`]).
#[derive(Clone, Debug)]
pub struct ShardReport {
    /// The shard's completion record (also written into the checkpoint folder).
    pub completion: Completion,
    /// Records of the samples this shard owns, in database order.
    pub samples: Vec<SampleRecord>,
    /// Wall time (s).
    pub seconds: f64,
}

/// One shard of a database generation for a job array (see [`crate::shard`]); all shards and
/// the merge share one `checkpoint` folder (a shared file system on a cluster).
///
/// **The continuation rule across shards.** The units are the `sa` lines, one per grid pair
/// `(sx[i], sy[k])`, numbered `i + n_sx k`; shard `K` of `N` owns the lines with number
/// `mod N = K` and every sample on them. To reach its lines a shard walks the same tree as
/// [`generate`] (root, the `sx` line, the `sy` lines, then its `sa` lines), but only the
/// branches that lead to its own lines, so each sample is continued from the same parent as
/// in a single run and is the same to the last bit. Samples on a shared branch are solved by
/// every shard that needs them (identical, written once to the common checkpoint). A sample
/// no continuation reaches is marked as failed in the checkpoint (`sample-….failed`); the
/// repair pass of [`generate`] needs the whole grid and runs in [`merge_shards`].
///
/// Rerunning a killed shard resumes from the checkpoint like [`generate`]. When the shard is
/// done it writes `shard-K-of-N.json` ([`crate::shard::Completion`]) there.
pub fn generate_shard(
    tile: &Tile,
    model: &YarnModel,
    axes: [Vec<f64>; 3],
    settings: &DatabaseSettings,
    checkpoint: &Path,
    shard: Shard,
    progress: &(dyn Fn(&SampleRecord) + Sync),
) -> Result<ShardReport, GenerationError> {
    match run(
        tile,
        model,
        axes,
        settings,
        Some(checkpoint),
        Plan::Shard(shard),
        progress,
    )? {
        Outcome::Shard(report) => Ok(report),
        Outcome::Database(_) => unreachable!("a shard yields a report"),
    }
}

/// The merge of `count` shards ([`generate_shard`]) in `checkpoint`: checks that every shard
/// finished for these inputs, then assembles the database from the checkpointed samples and
/// runs the repair pass of [`generate`] on the samples the shards marked as failed. Solves
/// nothing else: a sample that is neither checkpointed nor marked is an error naming the
/// shard that owns it. The database equals that of a single [`generate`] bit for bit.
pub fn merge_shards(
    tile: &Tile,
    model: &YarnModel,
    axes: [Vec<f64>; 3],
    settings: &DatabaseSettings,
    checkpoint: &Path,
    count: usize,
    progress: &(dyn Fn(&SampleRecord) + Sync),
) -> Result<Generated, GenerationError> {
    match run(
        tile,
        model,
        axes,
        settings,
        Some(checkpoint),
        Plan::Merge(count),
        progress,
    )? {
        Outcome::Database(generated) => Ok(generated),
        Outcome::Shard(_) => unreachable!("a merge yields a database"),
    }
}

/// What [`run`] does.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Plan {
    /// The whole grid.
    Full,
    /// The lines of one shard, no repair.
    Shard(Shard),
    /// Assemble the shards' checkpoint of `count` shards, repair.
    Merge(usize),
}

enum Outcome {
    Database(Generated),
    Shard(ShardReport),
}

/// The completion record kind of database shards.
const SHARD_KIND: &str = "database";

fn run(
    tile: &Tile,
    model: &YarnModel,
    axes: [Vec<f64>; 3],
    settings: &DatabaseSettings,
    checkpoint: Option<&Path>,
    plan: Plan,
    progress: &(dyn Fn(&SampleRecord) + Sync),
) -> Result<Outcome, GenerationError> {
    let start = Instant::now();
    // Validate the axes exactly as the database file format does.
    let empty = Database {
        axes: axes.clone(),
        n_vertices: 0,
        data: vec![],
    };
    empty.validate()?;
    let dims = [axes[0].len(), axes[1].len(), axes[2].len()];
    for &sx in &axes[0] {
        for &sa in &axes[1] {
            for &sy in &axes[2] {
                let strain = Strain { sx, sa, sy };
                if strain.validated().is_none() {
                    return Err(GenerationError::Inadmissible(strain));
                }
            }
        }
    }
    let store = Checkpoint::open(checkpoint, tile, model, &axes, settings)?;
    if let (Plan::Merge(count), Some(dir)) = (plan, &store.dir) {
        check_complete(dir, SHARD_KIND, count, &store.fingerprint)?;
    }
    let rest = initial_dofs(tile).map_err(|e| GenerationError::Relax(e.into()))?;
    let root = [0, 1, 2].map(|k| nearest_to_zero(&axes[k]));
    let flat = |[i, j, k]: [usize; 3]| i + dims[0] * (j + dims[1] * k);
    let strain_at = |[i, j, k]: [usize; 3]| Strain {
        sx: axes[0][i],
        sa: axes[1][j],
        sy: axes[2][k],
    };
    // The sa line (unit) a sample belongs to.
    let unit = |[i, _, k]: [usize; 3]| i + dims[0] * k;
    let owned = |index: [usize; 3]| match plan {
        Plan::Shard(shard) => shard.owns(unit(index)),
        _ => true,
    };
    let results: Mutex<Vec<Option<Solved>>> = Mutex::new(vec![None; dims.iter().product()]);
    // The continuation error of every sample filled (for now) from its parent.
    let failures: Mutex<Vec<(usize, GenerationError)>> = Mutex::new(vec![]);

    // Solves (or loads) the sample at `index`, warm-started from `from` (strain, DOFs);
    // returns the equilibrium its children continue from (the parent's when unsolved).
    let solve = |index: [usize; 3], from: (Strain, &[f64])| -> Result<Parent, GenerationError> {
        let strain = strain_at(index);
        let (record, parent) = match store.load(index, strain, tile)? {
            Some((record, dofs)) => (record, (strain, dofs)),
            None => {
                let (record, parent, failure) = match plan {
                    Plan::Merge(count) => {
                        let marked = store.load_failure(index)?.ok_or_else(|| {
                            GenerationError::Checkpoint {
                                path: store.path(index).unwrap_or_default(),
                                problem: format!(
                                    "missing: shard {} reports it finished but did not \
                                     checkpoint this sample or mark it failed",
                                    Shard::owner(unit(index), count)
                                ),
                            }
                        })?;
                        let (record, parent) =
                            filled_sample(tile, model, index, strain, from, settings)?;
                        let failure = GenerationError::ShardUnsolved {
                            strain,
                            problem: marked,
                        };
                        (record, parent, Some(failure))
                    }
                    _ => solve_or_fill(tile, model, index, strain, from, settings)?,
                };
                if record.solved {
                    store.save(&record, &parent.1)?;
                } else if let Some(e) = failure {
                    if matches!(plan, Plan::Shard(_)) {
                        store.save_failure(index, &e)?;
                    }
                    failures
                        .lock()
                        .expect("failures lock")
                        .push((flat(index), e));
                }
                (record, parent)
            }
        };
        if record.solved && owned(index) {
            progress(&record);
        }
        results.lock().expect("results lock")[flat(index)] = Some((record, parent.clone()));
        Ok(parent)
    };
    // Solves the samples along one axis outward from `seed` (already solved), down to index
    // `lo` and up to index `hi` (inclusive).
    let line = |axis: usize,
                seed: [usize; 3],
                from: Parent,
                (lo, hi): (usize, usize)|
     -> Result<(), GenerationError> {
        let walk = |range: Box<dyn Iterator<Item = usize> + Send>| -> Result<(), GenerationError> {
            let mut prev = from.clone();
            for i in range {
                let mut index = seed;
                index[axis] = i;
                prev = solve(index, (prev.0, &prev.1))?;
            }
            Ok(())
        };
        let (up, down) = rayon::join(
            || walk(Box::new(seed[axis] + 1..=hi)),
            || walk(Box::new((lo..seed[axis]).rev())),
        );
        up.and(down)
    };
    let parent_at = |index: [usize; 3]| -> Parent {
        results.lock().expect("results lock")[flat(index)]
            .as_ref()
            .map(|(_, p)| p.clone())
            .expect("continuation parent solved before its children")
    };
    // The extent `(lo, hi)` of the indices in `needed` together with `seed`.
    let extent = |seed: usize, needed: &mut dyn Iterator<Item = usize>| {
        needed.fold((seed, seed), |(lo, hi), i| (lo.min(i), hi.max(i)))
    };

    // Root, then the sx line, then sy lines per sx, then sa lines per (sx, sy); a shard only
    // walks the branches that lead to its own sa lines.
    let lines: Vec<[usize; 2]> = (0..dims[0] * dims[2])
        .map(|ik| [ik % dims[0], ik / dims[0]])
        .filter(|&[i, k]| owned([i, root[1], k]))
        .collect();
    let root_parent = solve(root, (Strain::ZERO, &rest))?;
    let sx_range = extent(root[0], &mut lines.iter().map(|l| l[0]));
    line(0, root, root_parent, sx_range)?;
    let sx_needed: Vec<usize> = (sx_range.0..=sx_range.1)
        .filter(|&i| lines.iter().any(|l| l[0] == i))
        .collect();
    sx_needed.into_par_iter().try_for_each(|i| {
        let seed = [i, root[1], root[2]];
        let sy_range = extent(
            root[2],
            &mut lines.iter().filter(|l| l[0] == i).map(|l| l[1]),
        );
        line(2, seed, parent_at(seed), sy_range)
    })?;
    lines.par_iter().try_for_each(|&[i, k]| {
        let seed = [i, root[1], k];
        line(1, seed, parent_at(seed), (0, dims[1] - 1))
    })?;

    let mut results = results.into_inner().expect("results lock");
    if let Plan::Shard(shard) = plan {
        let failures = failures.into_inner().expect("failures lock");
        let samples: Vec<SampleRecord> = results
            .into_iter()
            .flatten()
            .map(|(record, _)| record)
            .filter(|r| owned(r.index))
            .collect();
        let mut failed: Vec<(usize, String)> = failures
            .into_iter()
            .filter(|(f, _)| owned(unravel(dims, *f)))
            .map(|(f, e)| (f, e.to_string()))
            .collect();
        failed.sort();
        let completion = Completion {
            kind: SHARD_KIND.into(),
            index: shard.index,
            count: shard.count,
            fingerprint: store.fingerprint.clone(),
            units: lines.len(),
            failed: failed.into_iter().map(|(_, e)| e).collect(),
        };
        if let Some(dir) = &store.dir {
            write_completion(dir, &completion)?;
        }
        return Ok(Outcome::Shard(ShardReport {
            completion,
            samples,
            seconds: start.elapsed().as_secs_f64(),
        }));
    }
    let mut failures = failures.into_inner().expect("failures lock");
    failures.sort_by_key(|(f, _)| *f);
    // Repair: a sample its line could not reach is tried again from each solved grid
    // neighbour, in a fixed order, after all lines are done and one sample at a time, so the
    // result does not depend on thread timing. Its children on the line have already
    // continued from its parent, as for a filled sample. Repaired samples are not
    // checkpointed: a resumed run reaches them the same way again.
    for (f, error) in failures {
        let index = unravel(dims, f);
        let strain = strain_at(index);
        let t = Instant::now();
        let mut repaired = None;
        for (axis, delta) in [(0, -1), (0, 1), (2, -1), (2, 1), (1, -1), (1, 1)] {
            let Some(i) = index[axis]
                .checked_add_signed(delta)
                .filter(|&i| i < dims[axis])
            else {
                continue;
            };
            let mut neighbour = index;
            neighbour[axis] = i;
            let Some((record, (from, dofs))) = &results[flat(neighbour)] else {
                continue;
            };
            if !record.solved {
                continue;
            }
            if let Ok((eq, iterations, substeps)) =
                continue_to(tile, model, (*from, dofs), strain, settings)
            {
                repaired = Some((eq, iterations, substeps));
                break;
            }
        }
        match repaired {
            Some(solved) => {
                let filled = results[f].as_ref().map_or(0.0, |(r, _)| r.seconds);
                let solved =
                    solved_sample(index, strain, solved, filled + t.elapsed().as_secs_f64())?;
                progress(&solved.0);
                results[f] = Some(solved);
            }
            None if settings.fill_unsolved => {
                if let Some((record, _)) = &results[f] {
                    progress(record);
                }
            }
            None => return Err(error),
        }
    }
    let (database, samples) = database_from(tile, axes, results)?;
    Ok(Outcome::Database(Generated {
        database,
        samples,
        seconds: start.elapsed().as_secs_f64(),
    }))
}

/// The grid index `(isx, isa, isy)` of flat sample number `f` (`isx` fastest).
fn unravel(dims: [usize; 3], f: usize) -> [usize; 3] {
    [
        f % dims[0],
        (f / dims[0]) % dims[1],
        f / (dims[0] * dims[1]),
    ]
}

/// An equilibrium children continue from: its strain and DOFs.
type Parent = (Strain, Vec<f64>);

/// A finished sample and the equilibrium behind its row (its own, or its parent's when
/// unsolved).
type Solved = (SampleRecord, Parent);

/// The record and state of a sample solved by [`continue_to`] (its equilibrium, Newton
/// iterations and sub-steps) in `seconds`; a non-finite result is an error.
fn solved_sample(
    index: [usize; 3],
    strain: Strain,
    (eq, iterations, substeps): (Equilibrium, usize, usize),
    seconds: f64,
) -> Result<Solved, GenerationError> {
    if !eq.dofs.iter().all(|v| v.is_finite()) || !eq.density.is_finite() {
        return Err(GenerationError::NonFinite(strain));
    }
    let record = SampleRecord {
        index,
        strain,
        density: eq.density,
        stress: eq.stress,
        iterations,
        substeps,
        seconds,
        resumed: false,
        solved: true,
    };
    Ok((record, (strain, eq.dofs)))
}

/// Solves the sample `index` (strain `strain_at(index)`) for [`generate`], continuing from
/// `from` ([`continue_to`]). A sample the continuation cannot reach gets, for now, the state of
/// `from`'s DOFs under its strain (unsolved; [`generate`] tries to repair it later) and the
/// continuation error. Returns its record, the equilibrium its children continue from (`from`
/// itself when unsolved) and that error.
fn solve_or_fill(
    tile: &Tile,
    model: &YarnModel,
    index: [usize; 3],
    strain: Strain,
    from: (Strain, &[f64]),
    settings: &DatabaseSettings,
) -> Result<(SampleRecord, Parent, Option<GenerationError>), GenerationError> {
    let t = Instant::now();
    match continue_to(tile, model, from, strain, settings) {
        Ok(solved) => {
            let (record, parent) = solved_sample(index, strain, solved, t.elapsed().as_secs_f64())?;
            Ok((record, parent, None))
        }
        Err(error @ GenerationError::Solve { .. }) => {
            let (mut record, parent) = filled_sample(tile, model, index, strain, from, settings)?;
            record.seconds = t.elapsed().as_secs_f64();
            Ok((record, parent, Some(error)))
        }
        Err(e) => Err(e),
    }
}

/// The unsolved sample `index` filled from its continuation parent `from`: the parent's DOFs
/// under the sample's strain; children continue from `from` itself.
fn filled_sample(
    tile: &Tile,
    model: &YarnModel,
    index: [usize; 3],
    strain: Strain,
    from: (Strain, &[f64]),
    settings: &DatabaseSettings,
) -> Result<Solved, GenerationError> {
    let (density, stress) =
        state_under(tile, model, strain, from.1, settings).map_err(|source| {
            GenerationError::Solve {
                strain,
                bisections: 0,
                source,
            }
        })?;
    if !density.is_finite() || !stress.iter().all(|v| v.is_finite()) {
        return Err(GenerationError::NonFinite(strain));
    }
    let record = SampleRecord {
        index,
        strain,
        density,
        stress,
        iterations: 0,
        substeps: 0,
        seconds: 0.0,
        resumed: false,
        solved: false,
    };
    Ok((record, (from.0, from.1.to_vec())))
}

/// The database of [`generate`]'s finished samples (in flat sample order): the material
/// displacement rows of every sample's equilibrium, and the sample records.
fn database_from(
    tile: &Tile,
    axes: [Vec<f64>; 3],
    results: Vec<Option<Solved>>,
) -> Result<(Database, Vec<SampleRecord>), GenerationError> {
    let dims = [axes[0].len(), axes[1].len(), axes[2].len()];
    let n = tile.n_vertices();
    let mut data = vec![[0f32; 4]; n * dims.iter().product::<usize>()];
    let mut samples = Vec::with_capacity(results.len());
    let database_index =
        |v: usize, [i, j, k]: [usize; 3]| i + dims[0] * (j + dims[1] * (k + dims[2] * v));
    for slot in results {
        let (record, (_, dofs)) = slot.expect("every sample solved or filled");
        let coarse = Coarse::from_strain(&record.strain);
        let rows = material_displacements(tile, &coarse, &dofs).map_err(|source| {
            GenerationError::Solve {
                strain: record.strain,
                bisections: 0,
                source,
            }
        })?;
        for (v, row) in rows.iter().enumerate() {
            if !row.iter().all(|x| x.is_finite()) {
                return Err(GenerationError::NonFinite(record.strain));
            }
            data[database_index(v, record.index)] = row.map(|x| x as f32);
        }
        samples.push(record);
    }
    let database = Database {
        axes,
        n_vertices: n,
        data,
    };
    database.validate()?;
    Ok((database, samples))
}

/// Ψ and the gathered stress of the DOFs `dofs` under `strain` (not an equilibrium there).
fn state_under(
    tile: &Tile,
    model: &YarnModel,
    strain: Strain,
    dofs: &[f64],
    settings: &DatabaseSettings,
) -> Result<(f64, Matrix2<f64>), PeriodicError> {
    let coarse = Coarse::from_strain(&strain);
    let margin = settings.equilibrium.pair_margin;
    let pairs = PeriodicTile::find_pairs(tile, model, &coarse, dofs, margin)?;
    let problem = PeriodicTile::new(tile, *model, coarse, pairs)?;
    let energy = solver::Assembler::new(&problem)?.energy(&problem, dofs)?;
    Ok((energy / problem.area(), problem.stress(dofs)))
}

impl DatabaseSettings {
    /// The settings that determine a solved sample, for the checkpoint fingerprint
    /// ([`DatabaseSettings::fill_unsolved`] does not: unsolved samples are never checkpointed).
    fn solved_fingerprint(&self) -> String {
        format!(
            "DatabaseSettings {{ equilibrium: {:?}, max_bisections: {:?}, attempt_iterations: {:?} }}",
            self.equilibrium, self.max_bisections, self.attempt_iterations
        )
    }

    /// Equilibrium settings of an attempt that may still be halved.
    fn attempt(&self) -> EquilibriumSettings {
        let mut s = self.equilibrium.clone();
        s.newton.max_iterations = s.newton.max_iterations.min(self.attempt_iterations);
        s
    }
}

/// Solves for `target` warm-started at `from` (a strain and its equilibrium DOFs), halving the
/// step when an attempt fails, up to `settings.max_bisections` times (so at most
/// `2^max_bisections` sub-steps; [`solver::bisect`], midpoints `(a + b)/2` per strain
/// component). Returns the equilibrium, the Newton iterations and the
/// number of sub-steps.
pub fn continue_to(
    tile: &Tile,
    model: &YarnModel,
    from: (Strain, &[f64]),
    target: Strain,
    settings: &DatabaseSettings,
) -> Result<(Equilibrium, usize, usize), GenerationError> {
    let mut last: Option<Equilibrium> = None;
    let mut iterations = 0;
    let midpoint = |a: &Strain, b: &Strain| Strain {
        sx: 0.5 * (a.sx + b.sx),
        sa: 0.5 * (a.sa + b.sa),
        sy: 0.5 * (a.sy + b.sy),
    };
    let report = solver::bisect(
        (from.0, target),
        settings.max_bisections,
        |(a, b)| {
            let mid = midpoint(a, b);
            ((*a, mid), (mid, *b))
        },
        |&(_, to), attempt| {
            // The last allowed halving gets the full Newton budget.
            let equilibrium = if attempt.last_chance {
                settings.equilibrium.clone()
            } else {
                settings.attempt()
            };
            let (warm, warm_coarse) = last
                .as_ref()
                .map_or((from.1, Coarse::from_strain(&from.0)), |eq| {
                    (eq.dofs.as_slice(), eq.coarse)
                });
            let coarse = Coarse::from_strain(&to);
            let warm = material_warm_start(warm, &warm_coarse, &coarse);
            let eq = solve_equilibrium(tile, model, coarse, Some(&warm), &equilibrium)
                .map_err(StepError::Halve)?;
            iterations += eq.iterations;
            last = Some(eq);
            Ok(())
        },
    )
    .map_err(|e| GenerationError::Solve {
        strain: target,
        bisections: e.depth,
        source: e.source,
    })?;
    let eq = last.expect("a successful continuation solved at least one step");
    Ok((eq, iterations, report.steps))
}

/// The fluctuation `ũ` of an equilibrium under `from`, carried to `to` with its material
/// displacement held: `ũ' = F₂' F₂⁻¹ ũ` in-plane (twists unchanged). Admissible strains have
/// invertible `F₂`; were one singular, the fluctuation would be carried over unchanged.
pub(crate) fn material_warm_start(dofs: &[f64], from: &Coarse, to: &Coarse) -> Vec<f64> {
    let map = from
        .f
        .try_inverse()
        .map_or_else(nalgebra::Matrix2::identity, |inv| to.f * inv);
    let mut out = dofs.to_vec();
    for v in 0..dofs.len() / 4 {
        let u = map * nalgebra::Vector2::new(dofs[3 * v], dofs[3 * v + 1]);
        (out[3 * v], out[3 * v + 1]) = (u.x, u.y);
    }
    out
}

/// Index of the sample closest to zero.
fn nearest_to_zero(values: &[f64]) -> usize {
    (0..values.len())
        .min_by(|&a, &b| values[a].abs().total_cmp(&values[b].abs()))
        .unwrap_or(0)
}

/// The sample store of a resumable generation (a no-op without a directory).
struct Checkpoint {
    dir: Option<PathBuf>,
    /// Fingerprint of the inputs (empty without a directory).
    fingerprint: String,
}

const CHECKPOINT_MAGIC: &[u8; 8] = b"YWDBCK01";
const FINGERPRINT_FILE: &str = "fingerprint.txt";

impl Checkpoint {
    fn open(
        dir: Option<&Path>,
        tile: &Tile,
        model: &YarnModel,
        axes: &[Vec<f64>; 3],
        settings: &DatabaseSettings,
    ) -> Result<Self, GenerationError> {
        let Some(dir) = dir else {
            return Ok(Self {
                dir: None,
                fingerprint: String::new(),
            });
        };
        let problem = |path: &Path, problem: String| GenerationError::Checkpoint {
            path: path.to_path_buf(),
            problem,
        };
        std::fs::create_dir_all(dir).map_err(|e| problem(dir, e.to_string()))?;
        let fingerprint = format!(
            "{:016x}\n",
            fnv1a(
                format!(
                    "{tile:?}|{model:?}|{axes:?}|{}|{AXIS_NAMES:?}",
                    settings.solved_fingerprint()
                )
                .as_bytes()
            )
        );
        let path = dir.join(FINGERPRINT_FILE);
        match std::fs::read_to_string(&path) {
            Ok(existing) if existing == fingerprint => {}
            Ok(_) => {
                return Err(problem(
                    &path,
                    "was written for different inputs (tile, model, axes or settings); \
                     remove the checkpoint directory or use the original inputs"
                        .into(),
                ));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                std::fs::write(&path, &fingerprint).map_err(|e| problem(&path, e.to_string()))?;
            }
            Err(e) => return Err(problem(&path, e.to_string())),
        }
        Ok(Self {
            dir: Some(dir.to_path_buf()),
            fingerprint: fingerprint.trim().to_string(),
        })
    }

    fn path(&self, index: [usize; 3]) -> Option<PathBuf> {
        let [i, j, k] = index;
        self.dir
            .as_ref()
            .map(|d| d.join(format!("sample-{i:02}-{j:02}-{k:02}.bin")))
    }

    /// Layout: magic, then little-endian f64s: density, stress (4, column-major),
    /// iterations, substeps, seconds, number of DOFs, DOFs.
    fn save(&self, record: &SampleRecord, dofs: &[f64]) -> Result<(), GenerationError> {
        let Some(path) = self.path(record.index) else {
            return Ok(());
        };
        let mut bytes = CHECKPOINT_MAGIC.to_vec();
        let header = [
            record.density,
            record.stress[(0, 0)],
            record.stress[(1, 0)],
            record.stress[(0, 1)],
            record.stress[(1, 1)],
            record.iterations as f64,
            record.substeps as f64,
            record.seconds,
            dofs.len() as f64,
        ];
        for v in header.iter().chain(dofs) {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        write_atomically(&path, &bytes)
    }

    /// The failure marker of sample `index` (written by a shard, read by the merge).
    fn failure_path(&self, index: [usize; 3]) -> Option<PathBuf> {
        self.path(index).map(|p| p.with_extension("failed"))
    }

    /// Marks sample `index` as one the continuation could not reach, with the error.
    fn save_failure(
        &self,
        index: [usize; 3],
        error: &GenerationError,
    ) -> Result<(), GenerationError> {
        match self.failure_path(index) {
            Some(path) => write_atomically(&path, format!("{error}\n").as_bytes()),
            None => Ok(()),
        }
    }

    /// The error a shard marked sample `index` with, if any.
    fn load_failure(&self, index: [usize; 3]) -> Result<Option<String>, GenerationError> {
        let Some(path) = self.failure_path(index) else {
            return Ok(None);
        };
        match std::fs::read_to_string(&path) {
            Ok(text) => Ok(Some(text.trim().to_string())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(GenerationError::Checkpoint {
                path,
                problem: e.to_string(),
            }),
        }
    }

    fn load(
        &self,
        index: [usize; 3],
        strain: Strain,
        tile: &Tile,
    ) -> Result<Option<(SampleRecord, Vec<f64>)>, GenerationError> {
        let Some(path) = self.path(index) else {
            return Ok(None);
        };
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => {
                return Err(GenerationError::Checkpoint {
                    path,
                    problem: e.to_string(),
                });
            }
        };
        let bad = |problem: &str| GenerationError::Checkpoint {
            path: path.clone(),
            problem: problem.to_string(),
        };
        let body = bytes
            .strip_prefix(CHECKPOINT_MAGIC.as_slice())
            .ok_or_else(|| bad("not a sample checkpoint (bad magic)"))?;
        if body.len() % 8 != 0 || body.len() < 9 * 8 {
            return Err(bad("truncated"));
        }
        let values: Vec<f64> = body
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        let n_dofs = 4 * tile.n_vertices();
        if values[8] != n_dofs as f64 || values.len() != 9 + n_dofs {
            return Err(bad(&format!("expected {n_dofs} DOFs")));
        }
        if !values.iter().all(|v| v.is_finite()) {
            return Err(bad("contains non-finite values"));
        }
        let record = SampleRecord {
            index,
            strain,
            density: values[0],
            stress: Matrix2::new(values[1], values[3], values[2], values[4]),
            iterations: values[5] as usize,
            substeps: values[6] as usize,
            seconds: 0.0,
            resumed: true,
            solved: true,
        };
        Ok(Some((record, values[9..].to_vec())))
    }
}

/// [`crate::shard::write_atomically`] with the error of a checkpoint.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), GenerationError> {
    crate::shard::write_atomically(path, bytes).map_err(|e| GenerationError::Checkpoint {
        path: path.to_path_buf(),
        problem: e.to_string(),
    })
}

/// `n` samples of `[lo, hi]`, uniform.
pub fn uniform_axis(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    match n {
        0 => vec![],
        1 => vec![0.5 * (lo + hi)],
        _ => (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}
