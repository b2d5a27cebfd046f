//! `sim-periodic`: relax a tile, compute uniaxial curves, or generate a displacement database,
//! from a TOML config (see the library's `config` module for the schema).
//!
//! ```text
//! sim-periodic relax    run.toml   # out/relaxed.pyp, out/manifest-relax.json
//! sim-periodic curve    run.toml   # out/curve-<direction>.csv, out/manifest-curve.json
//! sim-periodic database run.toml   # out/database/{axes.txt,data.npy}, out/pattern.pyp,
//!                                  # out/samples.csv, out/manifest-database.json
//! sim-periodic fit      fit.toml   # out/fit.json, out/fitted-curves.csv, out/journal.jsonl,
//!                                  # out/manifest-fit.json (config: config::FitConfig)
//! sim-periodic campaign c.toml     # every fit × seed: out/<fit>/seed-<s>/, out/campaign.csv
//! ```
//!
//! `database` checkpoints every sample into `out/checkpoint/`, `fit` journals every objective
//! evaluation into `out/journal.jsonl`; rerunning the same command after an interruption
//! resumes from there with the same result.
//!
//! For job arrays (`scripts/slurm/`): `database run.toml --shard K/N` solves shard K of N
//! into the common checkpoint and `database run.toml --merge N` writes the database, bit for
//! bit that of a single run ([`sim_periodic::database::generate_shard`]); `campaign` takes the
//! same two options, with its tasks as the units.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use sim_periodic::config::Config;
use sim_periodic::curves::{CurveSettings, uniaxial_curve};
use sim_periodic::database::{
    DatabaseSettings, generate, generate_shard, merge_shards, relax_period, relax_reference,
};
use sim_periodic::shard::Shard;
use yarn_pattern::pyp::{read_pyp, write_pyp};

/// `fit` warns about a direction with fewer comfort-range samples than this: its part of the
/// comfort-range error rests on one sample or none.
const FEW_COMFORT_SAMPLES: usize = 2;

#[derive(Parser)]
#[command(
    name = "sim-periodic",
    version,
    about = "Periodic yarn tiles: relax, curves, databases"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Relax the tile at zero strain and write it as `.pyp`.
    Relax {
        /// TOML config.
        config: PathBuf,
    },
    /// Uniaxial stress–strain curves with zero orthogonal stress.
    Curve {
        /// TOML config.
        config: PathBuf,
    },
    /// Displacement database ΔQ(sx, sa, sy) (resumable; shardable for job arrays).
    Database {
        /// TOML config.
        config: PathBuf,
        /// Solve only shard K of N (0 <= K < N) into the common checkpoint, for a job array;
        /// `--merge N` then writes the database.
        #[arg(long, value_name = "K/N", conflicts_with = "merge")]
        shard: Option<Shard>,
        /// Merge the N finished shards of `--shard K/N` into the database (bit for bit that
        /// of a single run).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
        merge: Option<u64>,
    },
    /// Fit the yarn parameters to target curves (seed 002 §7; resumable).
    Fit {
        /// TOML config (see the library's `config::FitConfig`).
        config: PathBuf,
    },
    /// Every fit of a campaign with every seed, then the merged table `campaign.csv`
    /// (resumable; shardable for job arrays; see the library's `campaign`).
    Campaign {
        /// TOML campaign file.
        campaign: PathBuf,
        /// Run only the tasks of shard K of N (0 <= K < N); `--merge N` then writes the table.
        #[arg(long, value_name = "K/N", conflicts_with = "merge")]
        shard: Option<Shard>,
        /// Merge the N finished shards of `--shard K/N` into `campaign.csv`.
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
        merge: Option<u64>,
    },
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Relax { config } => relax(&config),
        Command::Curve { config } => curve(&config),
        Command::Database {
            config,
            shard,
            merge,
        } => database(&config, shard, merge.map(|n| n as usize)),
        Command::Fit { config } => fit(&config),
        Command::Campaign {
            campaign,
            shard,
            merge,
        } => run_campaign(&campaign, shard, merge.map(|n| n as usize)),
    }
}

struct Setup {
    config: Config,
    tile: yarn_pattern::tile::Tile,
    model: sim_periodic::periodic::YarnModel,
}

fn setup(path: &Path) -> Result<Setup> {
    let config = Config::read(path)?;
    config.validate(path)?;
    let read = read_pyp(&config.tile)?;
    for block in &read.defaulted {
        eprintln!(
            "note: {} has no {} block; using its default",
            config.tile.display(),
            block.name()
        );
    }
    let model = config.model(read.tile.radius, path)?;
    std::fs::create_dir_all(&config.out)
        .with_context(|| format!("creating {}", config.out.display()))?;
    Ok(Setup {
        config,
        tile: read.tile,
        model,
    })
}

fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))
}

fn bar(len: u64, msg: &'static str) -> ProgressBar {
    let style = ProgressStyle::with_template("{msg:10} [{bar:30}] {pos}/{len} {elapsed} eta {eta}")
        .expect("valid template")
        .progress_chars("=> ");
    ProgressBar::new(len).with_style(style).with_message(msg)
}

/// The reference tile of `curve` and `database`: relaxed at zero strain, with its period
/// relaxed to zero normal stress unless the config says otherwise.
fn reference(
    s: &Setup,
    settings: &sim_periodic::periodic::EquilibriumSettings,
) -> Result<yarn_pattern::tile::Tile> {
    if s.config.relax_period {
        let (tile, period) = relax_period(&s.tile, &s.model, settings, 1e-6)?;
        eprintln!(
            "period relaxed by ({:.4}, {:.4}) in {} solves",
            period.stretch[0], period.stretch[1], period.solves
        );
        Ok(tile)
    } else {
        Ok(relax_reference(&s.tile, &s.model, settings)?.0)
    }
}

fn relax(path: &Path) -> Result<()> {
    let s = setup(path)?;
    let t = Instant::now();
    let (relaxed, report) = relax_reference(&s.tile, &s.model, &s.config.equilibrium())?;
    let out = s.config.out.join("relaxed.pyp");
    write_pyp(&relaxed, &out)?;
    write_json(
        &s.config.out.join("manifest-relax.json"),
        &json!({
            "command": "relax",
            "config": path.display().to_string(),
            "tile": s.config.tile.display().to_string(),
            "model": format!("{:?}", s.model),
            "newton_iterations": report.iterations,
            "energy_density_j_per_m2": report.density,
            "seconds": t.elapsed().as_secs_f64(),
        }),
    )?;
    println!(
        "relaxed {} vertices in {} Newton iterations ({:.2} s) -> {}",
        s.tile.n_vertices(),
        report.total_iterations(),
        t.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}

fn curve(path: &Path) -> Result<()> {
    let s = setup(path)?;
    let (directions, stretches) = s.config.curve(path)?;
    let settings = CurveSettings {
        equilibrium: s.config.equilibrium(),
        exact_slope: s.config.curve.exact_slope,
        compression_dof: s.config.curve.compression_dof,
        ..CurveSettings::default()
    };
    let t = Instant::now();
    let relaxed = reference(&s, &settings.equilibrium)?;
    let progress = bar(directions.len() as u64, "curves");
    let mut files = Vec::new();
    for d in directions {
        let points = uniaxial_curve(&relaxed, &s.model, d, &stretches, &settings)?;
        let file = s.config.out.join(format!("curve-{}.csv", d.name()));
        let mut f =
            std::fs::File::create(&file).with_context(|| format!("creating {}", file.display()))?;
        writeln!(
            f,
            "s,c,sigma_s_n_per_m,sigma_c_n_per_m,psi_j_per_m2,solves,newton_iterations"
        )?;
        for p in &points {
            if ![p.s, p.c, p.sigma_s, p.sigma_c, p.density]
                .iter()
                .all(|v| v.is_finite())
            {
                bail!("non-finite curve point at s = {} ({})", p.s, d.name());
            }
            writeln!(
                f,
                "{},{},{},{},{},{},{}",
                p.s, p.c, p.sigma_s, p.sigma_c, p.density, p.solves, p.iterations
            )?;
        }
        files.push(file.display().to_string());
        progress.inc(1);
    }
    progress.finish_and_clear();
    write_json(
        &s.config.out.join("manifest-curve.json"),
        &json!({
            "command": "curve",
            "config": path.display().to_string(),
            "tile": s.config.tile.display().to_string(),
            "model": format!("{:?}", s.model),
            "stretches": stretches,
            "files": files,
            "seconds": t.elapsed().as_secs_f64(),
        }),
    )?;
    println!("curves written to {}", s.config.out.display());
    Ok(())
}

fn database(path: &Path, shard: Option<Shard>, merge: Option<usize>) -> Result<()> {
    let s = setup(path)?;
    let db = &s.config.database;
    let settings = DatabaseSettings {
        equilibrium: s.config.equilibrium(),
        fill_unsolved: db.fill_unsolved,
        ..DatabaseSettings::default()
    };
    let axes = [db.sx.values(), db.sa.values(), db.sy.values()];
    let t = Instant::now();
    let relaxed = reference(&s, &settings.equilibrium)?;
    let total: usize = axes.iter().map(Vec::len).product();
    let checkpoint = s.config.out.join("checkpoint");
    if let Some(shard) = shard {
        let per_shard = total.div_ceil(shard.count) as u64;
        let progress = bar(per_shard, "samples");
        let report = generate_shard(
            &relaxed,
            &s.model,
            axes,
            &settings,
            &checkpoint,
            shard,
            &|_| progress.inc(1),
        )?;
        progress.finish_and_clear();
        println!(
            "shard {shard}: {} sa lines, {} samples ({} resumed, {} failed) in {:.1} s -> {}",
            report.completion.units,
            report.samples.len(),
            report.samples.iter().filter(|r| r.resumed).count(),
            report.completion.failed.len(),
            report.seconds,
            checkpoint.join(shard.record_name()).display()
        );
        return Ok(());
    }
    let progress = bar(total as u64, "samples");
    let generated = match merge {
        Some(count) => merge_shards(
            &relaxed,
            &s.model,
            axes.clone(),
            &settings,
            &checkpoint,
            count,
            &|_| progress.inc(1),
        )?,
        None => generate(
            &relaxed,
            &s.model,
            axes.clone(),
            &settings,
            Some(&checkpoint),
            &|_| progress.inc(1),
        )?,
    };
    progress.finish_and_clear();
    let db_dir = s.config.out.join("database");
    generated.database.write(&db_dir)?;
    write_pyp(&relaxed, s.config.out.join("pattern.pyp"))?;
    let samples_file = s.config.out.join("samples.csv");
    let mut f = std::fs::File::create(&samples_file)
        .with_context(|| format!("creating {}", samples_file.display()))?;
    writeln!(
        f,
        "isx,isa,isy,sx,sa,sy,psi_j_per_m2,p11,p21,p12,p22,newton_iterations,substeps,seconds,resumed,solved"
    )?;
    for r in &generated.samples {
        let p = r.stress;
        writeln!(
            f,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.index[0],
            r.index[1],
            r.index[2],
            r.strain.sx,
            r.strain.sa,
            r.strain.sy,
            r.density,
            p[(0, 0)],
            p[(1, 0)],
            p[(0, 1)],
            p[(1, 1)],
            r.iterations,
            r.substeps,
            r.seconds,
            r.resumed,
            r.solved
        )?;
    }
    let resumed = generated.samples.iter().filter(|r| r.resumed).count();
    let unsolved: Vec<[f64; 3]> = generated
        .samples
        .iter()
        .filter(|r| !r.solved)
        .map(|r| [r.strain.sx, r.strain.sa, r.strain.sy])
        .collect();
    let iterations: usize = generated.samples.iter().map(|r| r.iterations).sum();
    write_json(
        &s.config.out.join("manifest-database.json"),
        &json!({
            "command": "database",
            "config": path.display().to_string(),
            "tile": s.config.tile.display().to_string(),
            "vertices": relaxed.n_vertices(),
            "axes": { "sx": axes[0], "sa": axes[1], "sy": axes[2] },
            "model": format!("{:?}", s.model),
            "newton": format!("{:?}", settings.equilibrium.newton),
            "max_bisections": settings.max_bisections,
            "relax_period": s.config.relax_period,
            "period_m": relaxed.period,
            "samples": total,
            "merged_shards": merge,
            "samples_resumed": resumed,
            "fill_unsolved": settings.fill_unsolved,
            "samples_unsolved": unsolved.len(),
            "unsolved_strains_sx_sa_sy": unsolved,
            "newton_iterations": iterations,
            "generation_seconds": generated.seconds,
            "total_seconds": t.elapsed().as_secs_f64(),
            "threads": rayon::current_num_threads(),
        }),
    )?;
    println!(
        "{total} samples ({resumed} resumed) in {:.1} s -> {}",
        generated.seconds,
        db_dir.display()
    );
    if !unsolved.is_empty() {
        eprintln!(
            "warning: {} of {total} samples could not be solved and were filled from their \
             continuation parents (solved = false in {}): {unsolved:?}",
            unsolved.len(),
            samples_file.display()
        );
    }
    Ok(())
}

fn fit(path: &Path) -> Result<()> {
    run_fit(sim_periodic::config::FitConfig::read(path)?, path)
}

/// A campaign ([`sim_periodic::campaign`]): the tasks of `shard` (all without one), each a
/// `fit` with the task's seed and output folder; a failed task is reported and recorded, the
/// others go on. Then, without a shard or with `--merge N`, the merged table.
fn run_campaign(path: &Path, shard: Option<Shard>, merge: Option<usize>) -> Result<()> {
    use sim_periodic::campaign::{Campaign, SHARD_KIND, TABLE_FILE};
    use sim_periodic::shard::{Completion, check_complete, write_completion};
    let campaign = Campaign::read(path)?;
    let fingerprint = campaign.fingerprint()?;
    let tasks = campaign.tasks();
    let failed: Vec<usize> = if let Some(count) = merge {
        let records = check_complete(&campaign.out, SHARD_KIND, count, &fingerprint)?;
        let mut failed = Vec::new();
        for r in records {
            for f in r.failed {
                let number = f.split(':').next().and_then(|n| n.trim().parse().ok());
                failed.push(number.with_context(|| {
                    format!(
                        "shard {}/{}: unreadable failed task {f:?}",
                        r.index, r.count
                    )
                })?);
            }
        }
        failed
    } else {
        let shard = shard.unwrap_or(Shard::ALL);
        let (mut failed, mut failed_numbers) = (Vec::new(), Vec::new());
        let owned: Vec<_> = tasks.iter().filter(|t| shard.owns(t.number)).collect();
        for task in &owned {
            eprintln!(
                "task {} of {}: {} seed {} -> {}",
                task.number + 1,
                tasks.len(),
                task.name,
                task.seed,
                task.out.display()
            );
            let mut config = sim_periodic::config::FitConfig::read(&task.fit)?;
            config.fit.seed = task.seed;
            config.out = task.out.clone();
            if let Err(e) = run_fit(config, &task.fit) {
                eprintln!("error: task {} failed: {e:#}", task.number);
                failed.push(format!(
                    "{}: {} seed {}: {e:#}",
                    task.number, task.name, task.seed
                ));
                failed_numbers.push(task.number);
            }
        }
        if shard != Shard::ALL {
            write_completion(
                &campaign.out,
                &Completion {
                    kind: SHARD_KIND.into(),
                    index: shard.index,
                    count: shard.count,
                    fingerprint,
                    units: owned.len(),
                    failed: failed.clone(),
                },
            )?;
            println!(
                "shard {shard}: {} tasks ({} failed) -> {}",
                owned.len(),
                failed.len(),
                campaign.out.join(shard.record_name()).display()
            );
            return Ok(());
        }
        failed_numbers
    };
    let rows = sim_periodic::campaign::merge(&campaign, &failed)?;
    println!(
        "{} tasks ({} failed) -> {}",
        rows.len(),
        failed.len(),
        campaign.out.join(TABLE_FILE).display()
    );
    // The spread over seeds of each fit's comfort-range error.
    for fit in &campaign.fits {
        let mut errors: Vec<f64> = rows
            .iter()
            .filter(|r| &r.task.fit == fit)
            .filter_map(|r| r.result.as_ref()?["comfort_error"].as_f64())
            .collect();
        errors.sort_by(f64::total_cmp);
        if let (Some(lo), Some(hi)) = (errors.first(), errors.last()) {
            println!(
                "  {:24} comfort-range error {:.2} – {:.2} % over {} seeds",
                rows.iter()
                    .find(|r| &r.task.fit == fit)
                    .map_or("", |r| r.task.name.as_str()),
                100.0 * lo,
                100.0 * hi,
                errors.len()
            );
        }
    }
    if !failed.is_empty() {
        bail!(
            "{} of {} tasks failed (status = failed in {})",
            failed.len(),
            rows.len(),
            campaign.out.join(TABLE_FILE).display()
        );
    }
    Ok(())
}

fn run_fit(config: sim_periodic::config::FitConfig, path: &Path) -> Result<()> {
    use sim_periodic::config::BoundConfig;
    use sim_periodic::fit::{
        Bound, Journal, Parameter, ParameterSpace, Progress, Targets, estimated_radius,
        fingerprint, stretched_geometry,
    };
    use sim_periodic::patterns::Pattern;
    let (geometry, radius) = match (&config.tile, &config.pattern) {
        (Some(tile), None) => {
            if config.resolution.is_some() {
                bail!(
                    "{}: `resolution` applies to a procedural `pattern`, not to a `tile` file",
                    path.display()
                );
            }
            let t = read_pyp(tile)?.tile;
            let r = t.radius;
            (t, r)
        }
        (None, Some(name)) => {
            let pattern = Pattern::from_name(name).with_context(|| {
                format!(
                    "{}: unknown pattern {name:?}; expected one of {}",
                    path.display(),
                    Pattern::ALL.map(|p| p.name()).join(", ")
                )
            })?;
            let r = config.radius.unwrap_or(1e-3);
            if !(r.is_finite() && r > 0.0) {
                bail!("{}: radius must be positive (m), found {r}", path.display());
            }
            let mut params = pattern.default_params(r);
            params.resolution = config.resolution.unwrap_or(params.resolution);
            let tile = pattern
                .generate(&params)
                .with_context(|| format!("{}: pattern {name:?}", path.display()))?;
            (tile, r)
        }
        (Some(_), Some(_)) | (None, None) => bail!(
            "{}: give exactly one of `tile` (a .pyp file) and `pattern` (a procedural pattern)",
            path.display()
        ),
    };
    let model = config.model(radius, path)?;
    let settings = config.settings(path)?;
    let targets = Targets::read(&config.targets)?;
    let r_est = estimated_radius(&geometry, &model)?;
    let paper = ParameterSpace::paper(&model, r_est)?;
    let space = if config.parameters.is_empty() {
        paper
    } else {
        let mut free = Vec::new();
        for (name, bound) in &config.parameters {
            let parameter = Parameter::from_name(name).with_context(|| {
                format!(
                    "{}: [parameters] has no parameter {name:?}; expected one of {}",
                    path.display(),
                    Parameter::ALL.map(|p| p.name()).join(", ")
                )
            })?;
            let (min, max) = match bound {
                BoundConfig::Range([min, max]) => (*min, *max),
                BoundConfig::Named(n) if n == "paper" => {
                    let b = paper
                        .free
                        .iter()
                        .find(|b| b.parameter == parameter)
                        .with_context(|| {
                            format!(
                                "{}: parameter {name} has no paper bounds with this stretch law",
                                path.display()
                            )
                        })?;
                    (b.min, b.max)
                }
                BoundConfig::Named(n) => bail!(
                    "{}: [parameters] {name} must be \"paper\" or [min, max], found {n:?}",
                    path.display()
                ),
            };
            free.push(Bound {
                parameter,
                min,
                max,
            });
        }
        free.sort_by_key(|b| b.parameter);
        ParameterSpace::new(paper.base, free)?
    };
    std::fs::create_dir_all(&config.out)
        .with_context(|| format!("creating {}", config.out.display()))?;
    let journal_path = config.out.join("journal.jsonl");
    let journal = Journal::open(
        &journal_path,
        &fingerprint(&geometry, &targets, &space, &settings),
    )?;
    let resumed = journal.len();
    if resumed > 0 {
        eprintln!(
            "resuming: {resumed} evaluations journaled in {}",
            journal_path.display()
        );
    }
    let swarm_total = settings
        .swarm
        .as_ref()
        .map_or(0, |s| s.particles as u64 * (s.iterations + 1));
    let swarm_bar = bar(swarm_total, "swarm");
    let local_bar = ProgressBar::new_spinner().with_message("local");
    let t = Instant::now();
    let result = sim_periodic::fit::fit(
        &geometry,
        &targets,
        &space,
        &settings,
        &journal,
        &|p: &Progress| match p.phase {
            "swarm" => {
                swarm_bar.inc(1);
                swarm_bar.set_message(format!("swarm g={:.3e}", p.best));
            }
            _ => {
                swarm_bar.finish_and_clear();
                local_bar.set_message(format!(
                    "local: {} evaluations, g = {:.3e}",
                    p.evaluations, p.best
                ));
                local_bar.tick();
            }
        },
    )?;
    swarm_bar.finish_and_clear();
    local_bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();

    let curves = config.out.join("fitted-curves.csv");
    let mut f =
        std::fs::File::create(&curves).with_context(|| format!("creating {}", curves.display()))?;
    writeln!(f, "direction,s,target_sigma,sigma,target_c,c,comfort")?;
    for p in &result.evaluation.samples {
        writeln!(
            f,
            "{},{},{},{},{},{},{}",
            p.direction.name(),
            p.target.s,
            p.target.sigma,
            p.sigma,
            p.target.c,
            p.c,
            p.comfort
        )?;
    }
    let parameters: Vec<serde_json::Value> = space
        .free
        .iter()
        .zip(&result.values)
        .zip(&result.x)
        .map(|((b, v), x)| {
            json!({
                "name": b.parameter.name(),
                "value": v,
                "min": b.min,
                "max": b.max,
                "normalized": x,
                "log_scale": b.parameter.log_scale(),
            })
        })
        .collect();
    let e = &result.evaluation;
    let comfort_samples = e.comfort_samples();
    // With geometric parameters the model belongs to the stretched input geometry.
    let fitted_geometry = if result.geometry_stretch != [1.0, 1.0] {
        let file = config.out.join("fitted-geometry.pyp");
        write_pyp(
            &stretched_geometry(&geometry, result.geometry_stretch)?,
            &file,
        )?;
        Some(file.display().to_string())
    } else {
        None
    };
    let summary = json!({
        "parameters": parameters,
        "model": format!("{:?}", result.model),
        "geometry_stretch": result.geometry_stretch,
        "fitted_geometry": fitted_geometry,
        "objective": e.value,
        "comfort_error": e.comfort_error,
        "power_error": e.power_error,
        "compression_error": e.compression_error,
        "comfort_samples": comfort_samples.iter().map(|(d, n)| (d.name().to_string(), json!(n))).collect::<serde_json::Map<_, _>>(),
        "rest_stress_n_per_m": [e.rest_stress[(0, 0)], e.rest_stress[(1, 0)], e.rest_stress[(0, 1)], e.rest_stress[(1, 1)]],
        "swarm_best": result.swarm_best.as_ref().map(|(x, g)| json!({"normalized": x, "objective": g})),
        "evaluations": { "swarm": result.evaluations[0], "local": result.evaluations[1] },
        "failed_evaluations": result.failed,
        "phase_seconds": { "swarm": result.seconds[0], "local": result.seconds[1] },
        "local_status": result.local_status,
    });
    write_json(&config.out.join("fit.json"), &summary)?;
    write_json(
        &config.out.join("manifest-fit.json"),
        &json!({
            "command": "fit",
            "version": env!("CARGO_PKG_VERSION"),
            "config": path.display().to_string(),
            "targets": config.targets.display().to_string(),
            "geometry": config.tile.as_ref().map(|t| t.display().to_string()).or(config.pattern.clone()),
            "vertices": geometry.n_vertices(),
            "r_est_m": r_est,
            "settings": format!("{settings:?}"),
            "journaled_before_start": resumed,
            "seconds": seconds,
            "threads": rayon::current_num_threads(),
        }),
    )?;
    println!(
        "fit in {seconds:.1} s ({} swarm + {} local evaluations, {resumed} from the journal): \
         comfort-range error {:.2} % over {} samples, objective {:.3e} -> {}",
        result.evaluations[0],
        result.evaluations[1],
        100.0 * e.comfort_error,
        comfort_samples.iter().map(|(_, n)| n).sum::<usize>(),
        e.value,
        config.out.join("fit.json").display()
    );
    for (d, n) in comfort_samples
        .iter()
        .filter(|(_, n)| *n < FEW_COMFORT_SAMPLES)
    {
        eprintln!(
            "warning: the {} comfort range holds {n} of the samples with s > 0, so its part of \
             the comfort-range error rests on {n}; sample_layout = \"comfort-half\" puts half \
             of the samples there",
            d.name()
        );
    }
    for (b, v) in space.free.iter().zip(&result.values) {
        println!("  {:18} {v:.6e}", b.parameter.name());
    }
    Ok(())
}
