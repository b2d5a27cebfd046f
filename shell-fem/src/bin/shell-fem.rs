//! `shell-fem` command line: fit the thin-shell in-plane model to uniaxial measurements (and,
//! with `--bending FILE`, the bending stiffnesses to pear-loop data `direction,d,r`), and emit
//! the uniform target curves of Eq. 3.
//!
//! ```text
//! shell-fem fit --data tests/data/measurements/acrylic-yarn-stockinette-x.csv \
//!               --data warp=tests/data/measurements/acrylic-yarn-stockinette-y.csv --out out/
//! shell-fem curves --params out/params.json --out out/curves
//! shell-fem fit-all tests/data/measurements --out out/all     # every fabric × model
//! ```

use std::path::{Path, PathBuf};
use std::time::Instant;
use yarn_pattern::direction::Direction;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use shell_fem::bending_fit::{
    BendingFitConfig, BendingFitResult, BendingTarget, DEFAULT_INITIAL, fit_bending,
    read_bending_csv, unidentified,
};
use shell_fem::csv_io::CsvTable;
use shell_fem::curves::TargetCurves;
use shell_fem::fabrics::{FabricFitOptions, discover, fit_fabric, holdout};
use shell_fem::fit::{
    ErrorReport, FitConfig, FitResult, VirtualTest, Weighting, fit, initial_guess_for, targets,
};
use shell_fem::material::{InPlaneParams, Material, Model};
use shell_fem::measurements::{
    BinOptions, Measurement, direction_from_name, is_stitch_csv, read_direction_csv,
    read_stitch_csv,
};
use shell_fem::pear_loop::PearLoopConfig;
use shell_fem::swatch::SwatchConfig;

#[derive(Parser)]
#[command(
    name = "shell-fem",
    version,
    about = "Anisotropic thin shell fitted to fabric stretch tests (seed 002, §5)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum ModelArg {
    /// Eq. 1: anisotropic StVK + area terms.
    Augmented,
    /// Plain anisotropic StVK.
    Stvk,
    /// Beyond the paper: Eq. 1 with exponential stiffening per direction (rates bx, by).
    Stiffening,
}

#[derive(Clone, Copy, ValueEnum)]
enum WeightArg {
    /// Normalize by the mean measured value per direction (paper).
    Mean,
    /// Relative residuals.
    Relative,
}

#[derive(Clone, Copy, ValueEnum)]
enum TestArg {
    /// The paper's clamped 10 cm × 6 cm swatch (FEM).
    Swatch,
    /// Homogeneous uniaxial stress, for strains measured locally on the specimen.
    Uniaxial,
}

/// Swatch, target and optimizer options shared by `fit` and `fit-all`.
#[derive(Args)]
struct FitArgs {
    /// Virtual test: `swatch` (paper) or `uniaxial` (homogeneous, no FEM).
    #[arg(long, value_enum, default_value_t = TestArg::Swatch)]
    test: TestArg,
    /// Cells along the swatch length (even).
    #[arg(long, default_value_t = 20)]
    nx: usize,
    /// Cells across the swatch width.
    #[arg(long, default_value_t = 12)]
    ny: usize,
    /// Targets per direction.
    #[arg(long, default_value_t = 6)]
    targets: usize,
    /// Strain bins for stitch-by-stitch data.
    #[arg(long, default_value_t = 24)]
    bins: usize,
    /// Maximum Levenberg–Marquardt iterations per fit.
    #[arg(long, default_value_t = 200)]
    max_iterations: usize,
}

impl FitArgs {
    fn test(&self) -> VirtualTest {
        match self.test {
            TestArg::Swatch => VirtualTest::Swatch,
            TestArg::Uniaxial => VirtualTest::Uniaxial,
        }
    }

    fn swatch(&self) -> SwatchConfig {
        SwatchConfig {
            nx: self.nx,
            ny: self.ny,
            ..SwatchConfig::default()
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Fit {kxx, kxy, kyy, kss, kn1, kn2} to measurements (Eq. 2) and write parameters,
    /// a run manifest, the fit table and the uniform target curves.
    Fit {
        /// Measurement file: a stitch-by-stitch CSV (direction from the name: `…-x.csv`,
        /// `…_y.csv`, `…-x-new.csv`, `…_garterxnew.csv`, `…-course.csv`, …; or `DIR=path` with
        /// DIR weft|bias|warp) or a `direction,s,f_s,c` CSV.
        #[arg(long, required = true)]
        data: Vec<String>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        fit: FitArgs,
        /// Material model.
        #[arg(long, value_enum, default_value_t = ModelArg::Augmented)]
        model: ModelArg,
        /// Residual weighting: `mean` (paper: per-direction mean) or `relative`.
        #[arg(long, value_enum, default_value_t = WeightArg::Mean)]
        weighting: WeightArg,
        /// Pear-loop data, a CSV `direction,d,r` (d in m): also fit the bending stiffnesses
        /// {k_θ weft, bias, warp} (§5.2) with the fitted in-plane material.
        #[arg(long)]
        bending: Option<PathBuf>,
        /// Cells along the pear-loop strip.
        #[arg(long, default_value_t = 40)]
        pear_nx: usize,
        /// Cells across the pear-loop strip.
        #[arg(long, default_value_t = 4)]
        pear_ny: usize,
        /// Largest curvature (1/m) of the bending target curves (with `--bending`).
        #[arg(long, default_value_t = 100.0)]
        kappa_max: f64,
    },
    /// Fit every fabric of a folder of measurements (files grouped into fabrics by name) with
    /// each model; write a summary table (paper metric at the targets and at every bin, and a
    /// held-out extrapolation check), the fits as JSON and each fit's uniform target curves.
    FitAll {
        /// Folder of measurement CSVs.
        dir: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Models to fit (comma-separated).
        #[arg(long, value_enum, value_delimiter = ',', default_values_t = [ModelArg::Stvk, ModelArg::Augmented, ModelArg::Stiffening])]
        models: Vec<ModelArg>,
        #[command(flatten)]
        fit: FitArgs,
        /// Also fit the lower fraction of each stretch range and report the error above it
        /// (0 = off).
        #[arg(long, default_value_t = 0.0)]
        holdout: f64,
    },
    /// Uniform target curves {s, c, σ_s} (Eq. 3) from a parameter file.
    Curves {
        /// `params.json` written by `fit`, or a JSON object with kxx … kn2 (N/m).
        #[arg(long)]
        params: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Stretch range per direction, `weft=0.5` (repeatable; default 0.5 for all three).
        #[arg(long)]
        range: Vec<String>,
        /// Samples per curve.
        #[arg(long, default_value_t = 21)]
        samples: usize,
        /// Material model.
        #[arg(long, value_enum, default_value_t = ModelArg::Augmented)]
        model: ModelArg,
    },
}

fn model(m: ModelArg) -> Model {
    match m {
        ModelArg::Augmented => Model::Augmented,
        ModelArg::Stvk => Model::StVK,
        ModelArg::Stiffening => Model::Stiffening,
    }
}

/// One line per direction and one overall: the paper metric and the per-point relative error.
fn print_errors(label: &str, e: &ErrorReport) {
    println!(
        "{label}: paper metric (error / mean measured datum): force {:.2} %, compression {:.2} % \
         | mean per-point relative error: force {:.2} %, compression {:.2} %",
        100.0 * e.force_error,
        100.0 * e.compression_error,
        100.0 * e.force_rel_error,
        100.0 * e.compression_rel_error
    );
    for d in &e.directions {
        println!(
            "  {}: force {:.2} %, compression {:.2} % | per point: force {:.2} %, compression {:.2} %",
            d.direction.name(),
            100.0 * d.force_error,
            100.0 * d.compression_error,
            100.0 * d.force_rel_error,
            100.0 * d.compression_rel_error
        );
    }
}

fn load(spec: &str, bins: &BinOptions) -> Result<Vec<Measurement>> {
    let (dir, path) = match spec.split_once('=') {
        Some((d, p)) => (
            Some(
                Direction::parse(d)
                    .with_context(|| format!("unknown direction `{d}` in `{spec}`"))?,
            ),
            Path::new(p),
        ),
        None => (None, Path::new(spec)),
    };
    if is_stitch_csv(path)? {
        let d = dir.or_else(|| direction_from_name(path)).with_context(|| {
            format!(
                "cannot tell the direction of {} from its name (expected e.g. `…-x.csv`, \
                 `…_y.csv`, `…-x-new.csv`, `…_garterxnew.csv`, `…-course.csv`); pass DIR=path",
                path.display()
            )
        })?;
        Ok(vec![read_stitch_csv(path, d, bins)?])
    } else {
        Ok(read_direction_csv(path)?)
    }
}

fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

fn ensure_finite(v: &serde_json::Value, what: &str) -> Result<()> {
    // serde_json writes non-finite floats as null: refuse rather than write them.
    fn walk(v: &serde_json::Value) -> bool {
        match v {
            serde_json::Value::Null => false,
            serde_json::Value::Array(a) => a.iter().all(walk),
            serde_json::Value::Object(o) => o.values().all(walk),
            _ => true,
        }
    }
    if !walk(v) {
        bail!("{what} contains a non-finite number; not written");
    }
    Ok(())
}

/// Options of the bending part of `fit`.
struct BendingArgs {
    data: Option<PathBuf>,
    pear_nx: usize,
    pear_ny: usize,
    kappa_max: f64,
}

/// Fits `{k_θ}` to the pear-loop CSV with the fitted in-plane material; writes
/// `bending.json` and `bending_fit.csv`, returns the result.
fn run_bending_fit(
    tg: &[BendingTarget],
    args: &BendingArgs,
    material: Material,
    out: &Path,
) -> Result<BendingFitResult> {
    let mut dirs: Vec<Direction> = tg.iter().map(|t| t.direction).collect();
    dirs.sort();
    dirs.dedup();
    let cfg = BendingFitConfig {
        pear: PearLoopConfig {
            nx: args.pear_nx,
            ny: args.pear_ny,
            ..PearLoopConfig::default()
        },
        material,
        fixed: unidentified(&dirs),
        ..BendingFitConfig::default()
    };
    let bar = ProgressBar::new(cfg.max_iterations as u64);
    bar.set_style(ProgressStyle::with_template(
        "{spinner} bending LM {pos}/{len} {msg} [{elapsed}]",
    )?);
    let mut cb = |it: usize, cost: f64| {
        bar.set_position(it as u64);
        bar.set_message(format!("cost {cost:.4e}"));
    };
    let r = fit_bending(tg, DEFAULT_INITIAL, &cfg, Some(&mut cb))?;
    bar.finish_and_clear();
    let j = serde_json::to_value(&r)?;
    ensure_finite(&j, "bending fit result")?;
    write(
        &out.join("bending.json"),
        &serde_json::to_string_pretty(&j)?,
    )?;
    let mut table = CsvTable::new(&["direction", "d", "r_measured", "r_fit"]);
    for (t, s) in r.targets.iter().zip(&r.simulated) {
        table.row([
            t.direction.name().to_string(),
            t.d.to_string(),
            t.ratio.to_string(),
            s.ratio.to_string(),
        ]);
    }
    write(&out.join("bending_fit.csv"), &table.finish())?;
    println!(
        "bending: fitted {:?}, mean relative ratio error {:.2} % ({} LM iterations, {:.1} s; {})",
        r.params,
        100.0 * r.ratio_rel_error,
        r.iterations,
        r.seconds,
        r.termination
    );
    Ok(r)
}

fn run_fit(
    data: &[String],
    out: &Path,
    args: &FitArgs,
    m: Model,
    weighting: Weighting,
    bending: &BendingArgs,
) -> Result<()> {
    let (swatch, n_targets, bins) = (args.swatch(), args.targets, args.bins);
    if !(bending.kappa_max.is_finite() && bending.kappa_max > 0.0) {
        bail!(
            "--kappa-max must be finite and > 0, got {}",
            bending.kappa_max
        );
    }
    // Read the pear-loop data first, so a malformed file fails before the in-plane fit.
    let bending_targets = bending.data.as_deref().map(read_bending_csv).transpose()?;
    let start = Instant::now();
    let bin_opts = BinOptions {
        bins,
        swatch_width: swatch.width,
    };
    let mut measurements = Vec::new();
    for spec in data {
        measurements.extend(load(spec, &bin_opts)?);
    }
    let mut dirs: Vec<Direction> = measurements.iter().map(|m| m.direction).collect();
    dirs.sort();
    if dirs.windows(2).any(|w| w[0] == w[1]) {
        bail!("a direction is given twice: {dirs:?}");
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let tg = targets(&measurements, n_targets);
    let initial = initial_guess_for(m, &measurements, swatch.width);
    // Without a bias test the shear stiffness is not identifiable: hold it at its guess.
    let mut cfg = FitConfig {
        test: args.test(),
        swatch,
        weighting,
        max_iterations: args.max_iterations,
        ..FitConfig::for_model(m)
    };
    cfg.fixed[3] = !dirs.contains(&Direction::Bias);
    let fixed = cfg.fixed;
    let bar = ProgressBar::new(cfg.max_iterations as u64);
    bar.set_style(ProgressStyle::with_template(
        "{spinner} LM {pos}/{len} {msg} [{elapsed}]",
    )?);
    let mut cb = |it: usize, cost: f64| {
        bar.set_position(it as u64);
        bar.set_message(format!("cost {cost:.4e}"));
    };
    let result: FitResult = fit(&tg, initial, &cfg, Some(&mut cb))?;
    bar.finish_and_clear();
    let ranges: Vec<(Direction, f64)> = measurements
        .iter()
        .map(|m| (m.direction, m.s_max()))
        .collect();
    let material = Material {
        params: result.params,
        model: m,
    };
    let bending_result = match &bending_targets {
        Some(tg) => Some(run_bending_fit(tg, bending, material, out)?),
        None => None,
    };
    let curves = TargetCurves::generate(
        &material,
        &ranges,
        21,
        bending_result
            .as_ref()
            .map(|r| (&r.params, bending.kappa_max)),
    )?;
    let params_json = serde_json::to_value(&result)?;
    ensure_finite(&params_json, "fit result")?;
    write(
        &out.join("params.json"),
        &serde_json::to_string_pretty(&params_json)?,
    )?;
    let mut table = CsvTable::new(&[
        "direction",
        "s",
        "force_measured",
        "force_fit",
        "compression_measured",
        "compression_fit",
    ]);
    for (t, s) in result.targets.iter().zip(&result.simulated) {
        table.row([
            t.direction.name().to_string(),
            t.s.to_string(),
            t.force.to_string(),
            s.force.to_string(),
            t.compression.to_string(),
            s.compression.to_string(),
        ]);
    }
    write(&out.join("fit.csv"), &table.finish())?;
    let curves_json = serde_json::to_value(&curves)?;
    ensure_finite(&curves_json, "target curves")?;
    write(
        &out.join("curves.json"),
        &serde_json::to_string_pretty(&curves_json)?,
    )?;
    write(&out.join("curves.csv"), &curves.to_csv())?;
    let manifest = json!({
        "tool": "shell-fem fit",
        "version": env!("CARGO_PKG_VERSION"),
        "data": data,
        "model": format!("{m:?}"),
        "test": cfg.test.name(),
        "swatch": {"length_m": cfg.swatch.length, "width_m": cfg.swatch.width, "nx": cfg.swatch.nx, "ny": cfg.swatch.ny},
        "targets_per_direction": n_targets,
        "bins": bins,
        "weighting": format!("{weighting:?}"),
        "fixed_parameters": InPlaneParams::NAMES.iter().zip(fixed).filter(|(_, f)| *f).map(|(n, _)| *n).collect::<Vec<_>>(),
        "lm_iterations": result.iterations,
        "termination": result.termination,
        "fit_seconds": result.seconds,
        "total_seconds": start.elapsed().as_secs_f64(),
        "errors": result.errors,
        "bending": bending_result.as_ref().map(|r| json!({
            "data": bending.data,
            "pear_loop": {"nx": bending.pear_nx, "ny": bending.pear_ny},
            "initial": r.initial,
            "params": r.params,
            "ratio_rel_error": r.ratio_rel_error,
            "lm_iterations": r.iterations,
            "termination": r.termination,
            "fit_seconds": r.seconds,
            "kappa_max_per_m": bending.kappa_max,
        })),
    });
    write(
        &out.join("manifest.json"),
        &serde_json::to_string_pretty(&manifest)?,
    )?;
    println!(
        "fitted {:?} ({} LM iterations, {:.1} s; {})",
        result.params, result.iterations, result.seconds, result.termination
    );
    print_errors("fit", &result.errors);
    Ok(())
}

/// Options of `fit-all`.
struct FitAllArgs {
    models: Vec<Model>,
    opts: FabricFitOptions,
    bins: usize,
    holdout: f64,
}

fn run_fit_all(dir: &Path, out: &Path, args: &FitAllArgs) -> Result<()> {
    let bin_opts = BinOptions {
        bins: args.bins,
        swatch_width: args.opts.swatch.width,
    };
    if args.holdout != 0.0 && !(args.holdout > 0.0 && args.holdout < 1.0) {
        bail!(
            "--holdout must be 0 (off) or in (0, 1), got {}",
            args.holdout
        );
    }
    let fabrics = discover(dir, &bin_opts)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let bar = ProgressBar::new((fabrics.len() * args.models.len()) as u64);
    bar.set_style(ProgressStyle::with_template(
        "{spinner} fit {pos}/{len} {msg} [{elapsed}]",
    )?);
    let mut table = CsvTable::new(&[
        "fabric",
        "model",
        "direction",
        "force_error",
        "compression_error",
        "force_rel_error",
        "compression_rel_error",
        "bins_force_error",
        "bins_compression_error",
        "holdout_force_error",
        "holdout_compression_error",
        "seconds",
    ]);
    let mut fits = Vec::new();
    for fabric in &fabrics {
        for &m in &args.models {
            bar.set_message(format!("{} ({})", fabric.name, m.name()));
            let f = fit_fabric(fabric, m, &args.opts)
                .with_context(|| format!("fitting {} with the {} model", fabric.name, m.name()))?;
            let held = if args.holdout > 0.0 {
                Some(
                    holdout(fabric, m, args.holdout, &args.opts).with_context(|| {
                        format!(
                            "hold-out fit of {} with the {} model",
                            fabric.name,
                            m.name()
                        )
                    })?,
                )
            } else {
                None
            };
            let e = &f.fit.errors;
            let h = |get: fn(&ErrorReport) -> f64| {
                held.as_ref()
                    .map_or(String::new(), |h| get(&h.held_out).to_string())
            };
            let head = [fabric.name.clone(), m.name().to_string()];
            table.row(head.iter().cloned().chain([
                "all".to_string(),
                e.force_error.to_string(),
                e.compression_error.to_string(),
                e.force_rel_error.to_string(),
                e.compression_rel_error.to_string(),
                f.all_bins.force_error.to_string(),
                f.all_bins.compression_error.to_string(),
                h(|r| r.force_error),
                h(|r| r.compression_error),
                f.fit.seconds.to_string(),
            ]));
            for (d, b) in e.directions.iter().zip(&f.all_bins.directions) {
                table.row(head.iter().cloned().chain([
                    d.direction.name().to_string(),
                    d.force_error.to_string(),
                    d.compression_error.to_string(),
                    d.force_rel_error.to_string(),
                    d.compression_rel_error.to_string(),
                    b.force_error.to_string(),
                    b.compression_error.to_string(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]));
            }
            let material = Material {
                params: f.fit.params,
                model: m,
            };
            let ranges: Vec<(Direction, f64)> = fabric
                .measurements
                .iter()
                .map(|x| (x.direction, x.s_max()))
                .collect();
            let curves = TargetCurves::generate(&material, &ranges, 21, None)?;
            write(
                &out.join(format!("{}-{}-curves.csv", fabric.name, m.name())),
                &curves.to_csv(),
            )?;
            bar.suspend(|| {
                println!(
                    "{:<28} {:<10} force {:6.2} %  compression {:6.2} %  (all bins {:6.2} % / {:6.2} %{}) {:.1} s",
                    fabric.name,
                    m.name(),
                    100.0 * e.force_error,
                    100.0 * e.compression_error,
                    100.0 * f.all_bins.force_error,
                    100.0 * f.all_bins.compression_error,
                    held.as_ref().map_or(String::new(), |h| format!(
                        "; held out above {:.0} %: {:.2} % / {:.2} %",
                        100.0 * h.fraction,
                        100.0 * h.held_out.force_error,
                        100.0 * h.held_out.compression_error
                    )),
                    f.fit.seconds
                );
            });
            fits.push(json!({"fit": f, "holdout": held}));
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    write(&out.join("summary.csv"), &table.finish())?;
    let j = serde_json::Value::Array(fits);
    write(&out.join("fits.json"), &serde_json::to_string_pretty(&j)?)?;
    write(
        &out.join("manifest.json"),
        &serde_json::to_string_pretty(&json!({
            "tool": "shell-fem fit-all", "version": env!("CARGO_PKG_VERSION"),
            "dir": dir, "fabrics": fabrics.iter().map(|f| &f.name).collect::<Vec<_>>(),
            "models": args.models.iter().map(|m| m.name()).collect::<Vec<_>>(),
            "targets_per_direction": args.opts.targets, "bins": args.bins,
            "test": args.opts.test.name(), "swatch": {"nx": args.opts.swatch.nx, "ny": args.opts.swatch.ny},
            "holdout_fraction": args.holdout,
            "metric": "paper (§5.1): Σ|sim − measured| / Σ|measured| per direction, mean over directions",
        }))?,
    )?;
    println!("wrote {}", out.join("summary.csv").display());
    Ok(())
}

fn run_curves(params: &Path, out: &Path, range: &[String], samples: usize, m: Model) -> Result<()> {
    let text =
        std::fs::read_to_string(params).with_context(|| format!("reading {}", params.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", params.display()))?;
    let p: InPlaneParams = serde_json::from_value(v.get("params").cloned().unwrap_or(v))
        .with_context(|| {
            format!(
                "{}: expected kxx, kxy, kyy, kss, kn1, kn2",
                params.display()
            )
        })?;
    let mut ranges = Vec::new();
    for r in range {
        let (d, s) = r
            .split_once('=')
            .with_context(|| format!("range `{r}`: expected DIR=S"))?;
        let d = Direction::parse(d).with_context(|| format!("unknown direction `{d}`"))?;
        let s: f64 = s
            .parse()
            .with_context(|| format!("range `{r}`: `{s}` is not a number"))?;
        ranges.push((d, s));
    }
    if ranges.is_empty() {
        ranges = Direction::ALL.iter().map(|&d| (d, 0.5)).collect();
    }
    let curves = TargetCurves::generate(
        &Material {
            params: p,
            model: m,
        },
        &ranges,
        samples,
        None,
    )?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let j = serde_json::to_value(&curves)?;
    ensure_finite(&j, "target curves")?;
    write(&out.join("curves.json"), &serde_json::to_string_pretty(&j)?)?;
    write(&out.join("curves.csv"), &curves.to_csv())?;
    write(
        &out.join("manifest.json"),
        &serde_json::to_string_pretty(&json!({
            "tool": "shell-fem curves", "version": env!("CARGO_PKG_VERSION"),
            "params": p, "model": format!("{m:?}"), "samples": samples,
            "ranges": ranges.iter().map(|(d, s)| json!({"direction": d.name(), "s_max": s})).collect::<Vec<_>>(),
        }))?,
    )?;
    println!("wrote {}", out.join("curves.csv").display());
    Ok(())
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Fit {
            data,
            out,
            fit,
            model: m,
            weighting,
            bending,
            pear_nx,
            pear_ny,
            kappa_max,
        } => {
            let w = match weighting {
                WeightArg::Mean => Weighting::DirectionMean,
                WeightArg::Relative => Weighting::Relative,
            };
            run_fit(
                &data,
                &out,
                &fit,
                model(m),
                w,
                &BendingArgs {
                    data: bending,
                    pear_nx,
                    pear_ny,
                    kappa_max,
                },
            )
        }
        Command::FitAll {
            dir,
            out,
            models,
            fit,
            holdout,
        } => run_fit_all(
            &dir,
            &out,
            &FitAllArgs {
                models: models.into_iter().map(model).collect(),
                opts: FabricFitOptions {
                    targets: fit.targets,
                    test: fit.test(),
                    swatch: fit.swatch(),
                    max_iterations: fit.max_iterations,
                    ..FabricFitOptions::default()
                },
                bins: fit.bins,
                holdout,
            },
        ),
        Command::Curves {
            params,
            out,
            range,
            samples,
            model: m,
        } => run_curves(&params, &out, &range, samples, model(m)),
    }
}
