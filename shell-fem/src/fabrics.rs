//! Fitting a folder of fabric measurements: files grouped into fabrics by name, one in-plane fit
//! per fabric and model, errors at the fit targets, at every measured bin and on a held-out
//! part of the stretch range.
//!
//! **Grouping.** A stitch-by-stitch file's fabric and direction come from its name
//! ([`crate::measurements::split_name`]: `acrylic-yarn-garter-x.csv` and `…-y.csv` are one fabric;
//! `babyredo_stockxnew.csv` and `babyredo_stockinettey.csv` are another). A per-direction
//! `direction,s,f_s,c` file is a fabric of its own (named by its stem).
//!
//! **Held-out checks.** A fit sees `n` targets per direction. Two checks use data it did not
//! see: [`FabricFit::all_bins`] compares the fitted swatch with every measured bin (most bins
//! lie between targets), and [`holdout`] fits only the lower part of each direction's stretch
//! range and measures the error on the upper part (extrapolation).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use yarn_pattern::direction::Direction;

use serde::{Deserialize, Serialize};

use crate::ShellError;
use crate::fit::{
    ErrorReport, FitConfig, FitResult, Simulator, Target, VirtualTest, fit,
    initial_guess_for_config, targets,
};
use crate::material::{InPlaneParams, Model};
use crate::measurements::{
    BinOptions, Measurement, is_stitch_csv, read_direction_csv, read_stitch_csv, split_name,
};
use crate::swatch::SwatchConfig;

/// The measurements of one fabric.
#[derive(Clone, Debug, PartialEq)]
pub struct Fabric {
    /// Fabric name (from the file names).
    pub name: String,
    /// One measurement per direction, in [`Direction::ALL`] order.
    pub measurements: Vec<Measurement>,
}

/// Reads every `*.csv` in `dir` (sorted by name) and groups the files into fabrics (module
/// docs). Errors name the file that cannot be placed or a direction given twice.
pub fn discover(dir: &Path, bins: &BinOptions) -> Result<Vec<Fabric>, ShellError> {
    let entries = std::fs::read_dir(dir).map_err(|source| ShellError::Io {
        file: dir.display().to_string(),
        source,
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")))
        .collect();
    files.sort();
    let mut fabrics: BTreeMap<String, Vec<Measurement>> = BTreeMap::new();
    for path in &files {
        let file = path.display().to_string();
        let (name, found) = if is_stitch_csv(path)? {
            let (name, direction) = split_name(path).ok_or_else(|| ShellError::Data {
                file: file.clone(),
                line: 0,
                problem: "cannot tell the fabric and direction from the file name; expected \
                          `<fabric>-x.csv`/`-y.csv` (also `_x`, `-weft`, `-course`, `-wale`, \
                          `<pattern>x` such as `garterx`, optionally followed by `new`)"
                    .into(),
            })?;
            (name, vec![read_stitch_csv(path, direction, bins)?])
        } else {
            let stem = path
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            (stem, read_direction_csv(path)?)
        };
        let entry = fabrics.entry(name.clone()).or_default();
        for m in found {
            if let Some(other) = entry.iter().find(|o| o.direction == m.direction) {
                return Err(ShellError::Data {
                    file,
                    line: 0,
                    problem: format!(
                        "fabric `{name}` has two {} tests (also {})",
                        m.direction.name(),
                        other.source
                    ),
                });
            }
            entry.push(m);
        }
    }
    if fabrics.is_empty() {
        return Err(ShellError::Data {
            file: dir.display().to_string(),
            line: 0,
            problem: "no *.csv measurement files".into(),
        });
    }
    Ok(fabrics
        .into_iter()
        .map(|(name, mut measurements)| {
            measurements.sort_by_key(|m| m.direction);
            Fabric { name, measurements }
        })
        .collect())
}

/// Settings of [`fit_fabric`].
#[derive(Clone, Debug, PartialEq)]
pub struct FabricFitOptions {
    /// Targets per direction (the paper's 6).
    pub targets: usize,
    /// Virtual test (default the paper's clamped swatch).
    pub test: VirtualTest,
    /// Swatch of the virtual tests.
    pub swatch: SwatchConfig,
    /// Swatches of single directions in place of `swatch`
    /// ([`FitConfig::direction_swatches`]). Default none.
    pub direction_swatches: BTreeMap<Direction, SwatchConfig>,
    /// Maximum LM iterations.
    pub max_iterations: usize,
}

impl Default for FabricFitOptions {
    fn default() -> Self {
        Self {
            targets: 6,
            test: VirtualTest::Swatch,
            swatch: SwatchConfig::default(),
            direction_swatches: BTreeMap::new(),
            max_iterations: 200,
        }
    }
}

/// One fabric fitted with one model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FabricFit {
    /// Fabric name.
    pub fabric: String,
    /// The fit (parameters, errors at the targets).
    pub fit: FitResult,
    /// Every measured bin, as measured.
    pub bins: Vec<Target>,
    /// The fitted swatch at every measured bin.
    pub bins_simulated: Vec<Target>,
    /// Errors at every measured bin (most are not fit targets).
    pub all_bins: ErrorReport,
}

/// Every measured bin of `measurements` as a [`Target`].
pub fn bin_targets(measurements: &[Measurement]) -> Vec<Target> {
    measurements
        .iter()
        .flat_map(|m| {
            m.points.iter().map(|p| Target {
                direction: m.direction,
                s: p.s,
                force: p.force,
                compression: p.compression,
            })
        })
        .collect()
}

/// The fit configuration used for `model` on `measurements`: [`FitConfig::for_model`], with
/// `kss` held when there is no bias test (it is then not identifiable).
pub fn fit_config(
    model: Model,
    measurements: &[Measurement],
    opts: &FabricFitOptions,
) -> FitConfig {
    let mut cfg = FitConfig::for_model(model);
    cfg.test = opts.test;
    cfg.swatch = opts.swatch.clone();
    cfg.direction_swatches = opts.direction_swatches.clone();
    cfg.max_iterations = opts.max_iterations;
    cfg.fixed[3] = !measurements.iter().any(|m| m.direction == Direction::Bias);
    cfg
}

/// Fits `model` to `opts.targets` targets per direction of `measurements` with
/// [`fit_config`], from [`initial_guess_for_config`]. A clamped-swatch fit starts from the
/// homogeneous uniaxial fit of the same targets (milliseconds; its optimum is close, so the
/// FEM fit needs fewer iterations); the reported time includes that pre-fit.
fn fit_measurements(
    model: Model,
    measurements: &[Measurement],
    opts: &FabricFitOptions,
) -> Result<FitResult, ShellError> {
    let cfg = fit_config(model, measurements, opts);
    let tg = targets(measurements, opts.targets);
    let mut initial = initial_guess_for_config(model, measurements, &cfg);
    let mut pre_seconds = 0.0;
    if cfg.test == VirtualTest::Swatch {
        let homogeneous = FitConfig {
            test: VirtualTest::Uniaxial,
            ..cfg.clone()
        };
        // A failed pre-fit (e.g. StVK inverting in the homogeneous test) only costs the warm
        // start: the swatch fit then starts from the guess.
        if let Ok(pre) = fit(&tg, initial, &homogeneous, None) {
            initial = pre.params;
            pre_seconds = pre.seconds;
        }
    }
    let mut result = fit(&tg, initial, &cfg, None)?;
    result.seconds += pre_seconds;
    Ok(result)
}

/// Simulates `params` at `points` and compares.
fn evaluate(
    model: Model,
    params: &InPlaneParams,
    points: &[Target],
    opts: &FabricFitOptions,
) -> Result<(Vec<Target>, ErrorReport), ShellError> {
    let mut sim = Simulator::with_swatches(
        opts.test,
        &opts.swatch,
        &opts.direction_swatches,
        model,
        points,
    )?;
    let values = sim.simulate(params, points)?;
    let simulated: Vec<Target> = points
        .iter()
        .zip(values)
        .map(|(t, (force, compression))| Target {
            force,
            compression,
            ..*t
        })
        .collect();
    let report = ErrorReport::new(points, &simulated);
    Ok((simulated, report))
}

/// Fits `fabric` with `model` (Eq. 2 with the paper's weights) and evaluates the fit at every
/// measured bin.
pub fn fit_fabric(
    fabric: &Fabric,
    model: Model,
    opts: &FabricFitOptions,
) -> Result<FabricFit, ShellError> {
    let m = &fabric.measurements;
    let result = fit_measurements(model, m, opts)?;
    let bins = bin_targets(m);
    let (bins_simulated, all_bins) = evaluate(model, &result.params, &bins, opts)?;
    Ok(FabricFit {
        fabric: fabric.name.clone(),
        fit: result,
        bins,
        bins_simulated,
        all_bins,
    })
}

/// Result of the extrapolation check [`holdout`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Holdout {
    /// Fraction of each direction's stretch range that was fitted.
    pub fraction: f64,
    /// Errors at the fitted part's targets.
    pub fitted: ErrorReport,
    /// Errors at the measured bins above the fitted part (never seen by the fit).
    pub held_out: ErrorReport,
}

/// Fits `model` to the bins with `s ≤ fraction · s_max` of each direction and measures the
/// error on the bins above (module docs).
pub fn holdout(
    fabric: &Fabric,
    model: Model,
    fraction: f64,
    opts: &FabricFitOptions,
) -> Result<Holdout, ShellError> {
    if !(fraction > 0.0 && fraction < 1.0) {
        return Err(ShellError::InvalidInput(format!(
            "hold-out fraction must be in (0, 1), got {fraction}"
        )));
    }
    let (mut lower, mut upper) = (Vec::new(), Vec::new());
    for m in &fabric.measurements {
        let cut = fraction * m.s_max();
        let (lo, hi): (Vec<_>, Vec<_>) = m.points.iter().partition(|p| p.s <= cut);
        if lo.len() < 2 || hi.is_empty() {
            return Err(ShellError::InvalidInput(format!(
                "{}: too few bins on one side of the hold-out cut s = {cut:.3}",
                m.source
            )));
        }
        lower.push(Measurement {
            points: lo,
            ..m.clone()
        });
        upper.push(Measurement {
            points: hi,
            ..m.clone()
        });
    }
    let result = fit_measurements(model, &lower, opts)?;
    let (_, held_out) = evaluate(model, &result.params, &bin_targets(&upper), opts)?;
    Ok(Holdout {
        fraction,
        fitted: result.errors,
        held_out,
    })
}
