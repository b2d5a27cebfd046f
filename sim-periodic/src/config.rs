//! TOML configuration of the `sim-periodic` command line (`relax`, `curve`, `database`; `fit`
//! has its own file, [`FitConfig`]).
//!
//! One file describes the tile, the yarn model, the solver and what to compute; paths are
//! relative to the config file. Unknown keys are errors (with line and column), so typos do not
//! silently fall back to defaults. Every section but `tile`/`out` is optional.
//!
//! ```toml
//! tile = "stockinette.pyp"      # a .pyp file
//! out = "out/stockinette"       # output directory
//! relax_period = true           # curve/database: relax the period to zero normal stress first
//!
//! [model]                       # defaults: YarnModel::default_for_radius(tile radius)
//! k1 = 20.0                     # soft stretch stiffness (N)
//! k2 = 200.0                    # stiff stretch stiffness (N)
//! onset = 0.03                  # onset strain of the stiff phase
//! bending = 5e-6                # k_b (N m²)
//! twist = 4e-6                  # k_t (N m²); 0 disables twist
//! contact_stiffness = [1e3, 1e6]      # soft / stiff barrier phase (J/m²)
//! contact_radius = [1.0, 0.25]        # phase radii in units of the yarn radius
//! simpson_intervals = 4         # contact quadrature intervals per edge (even)
//!
//! [solver]
//! gradient_abs_tol = 1e-9       # J/m (N)
//! gradient_rel_tol = 1e-9
//! max_iterations = 200
//! stall_iterations = 40         # fail after this many iterations without progress; 0: never
//!
//! [curve]                       # `curve`: uniaxial curves with zero orthogonal stress
//! directions = ["weft", "bias", "warp"]
//! max_stretch = 0.5
//! points = 11
//! exact_slope = false           # true: Newton steps on c with the exact dσ_c/dc
//! compression_dof = true        # weft and warp: c as a DOF of one Newton solve per point
//!
//! [database]                    # `database`: ΔQ over a strain grid
//! sx = { min = -0.2, max = 1.0, n = 9 }   # or an explicit list: sx = [-0.2, 0.0, 0.5]
//! sa = { min = -0.7, max = 0.7, n = 9 }
//! sy = { min = -0.2, max = 1.0, n = 9 }
//! fill_unsolved = false         # true: fill unsolvable samples from their parent, report them
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use yarn_pattern::direction::Direction;

use serde::Deserialize;

use crate::database::uniform_axis;
use crate::periodic::{EquilibriumSettings, YarnModel};
use rod::contact::Simpson;
use rod::stretch::StretchLaw;

/// A parsed config file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// The tile (`.pyp`), relative to the config file.
    pub tile: PathBuf,
    /// Output directory, relative to the config file.
    pub out: PathBuf,
    /// Before `curve` and `database`, find the period at which the relaxed tile carries no
    /// normal stress ([`crate::database::relax_period`]). Default true.
    #[serde(default = "yes")]
    pub relax_period: bool,
    /// Yarn model overrides.
    #[serde(default)]
    pub model: ModelConfig,
    /// Solver overrides.
    #[serde(default)]
    pub solver: SolverConfig,
    /// Curve settings.
    #[serde(default)]
    pub curve: CurveConfig,
    /// Database settings.
    #[serde(default)]
    pub database: DatabaseConfig,
}

/// Yarn model overrides (see [`YarnModel`]); absent keys keep the defaults.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelConfig {
    /// Soft stretch stiffness k₁ (N).
    pub k1: Option<f64>,
    /// Stiff stretch stiffness k₂ (N).
    pub k2: Option<f64>,
    /// Onset strain of the stiff phase.
    pub onset: Option<f64>,
    /// Bending stiffness (N·m²).
    pub bending: Option<f64>,
    /// Twist stiffness (N·m²).
    pub twist: Option<f64>,
    /// Barrier stiffness of the two phases (J/m²).
    pub contact_stiffness: Option<[f64; 2]>,
    /// Barrier radius of the two phases in yarn radii.
    pub contact_radius: Option<[f64; 2]>,
    /// Simpson intervals per edge (even, ≥ 2).
    pub simpson_intervals: Option<usize>,
}

impl ModelConfig {
    /// The yarn model for yarn radius `r` (m) with the overrides applied.
    pub fn model(&self, r: f64, path: &Path) -> Result<YarnModel, ConfigError> {
        let bad = |message: String| {
            Err(ConfigError::Invalid {
                message,
                path: path.to_path_buf(),
            })
        };
        let mut model = YarnModel::default_for_radius(r);
        let m = self;
        if let StretchLaw::TwoPhase { k1, k2, onset } = &mut model.stretch {
            *k1 = m.k1.unwrap_or(*k1);
            *k2 = m.k2.unwrap_or(*k2);
            *onset = m.onset.unwrap_or(*onset);
            let finite = k1.is_finite() && k2.is_finite() && onset.is_finite();
            if !(finite && *k1 > 0.0 && *k2 > 0.0 && *onset >= 0.0) {
                return bad(format!(
                    "[model] needs finite k1 > 0, k2 > 0, onset >= 0 (got {k1}, {k2}, {onset})"
                ));
            }
        }
        model.bending = m.bending.unwrap_or(model.bending);
        model.twist = m.twist.unwrap_or(model.twist);
        let finite = model.bending.is_finite() && model.twist.is_finite();
        if !(finite && model.bending > 0.0 && model.twist >= 0.0) {
            return bad(format!(
                "[model] needs finite bending > 0 and twist >= 0 (got {}, {})",
                model.bending, model.twist
            ));
        }
        if let Some(k) = m.contact_stiffness {
            for (phase, k) in model.contact.iter_mut().zip(k) {
                if !(k > 0.0 && k.is_finite()) {
                    return bad(format!("[model] contact_stiffness must be > 0, got {k}"));
                }
                phase.stiffness = k;
            }
        }
        if let Some(f) = m.contact_radius {
            for (phase, f) in model.contact.iter_mut().zip(f) {
                if !(f > 0.0 && f.is_finite()) {
                    return bad(format!("[model] contact_radius must be > 0, got {f}"));
                }
                phase.radius = f * r;
            }
        }
        if let Some(n) = m.simpson_intervals {
            model.quadrature = Simpson::new(n).ok_or_else(|| ConfigError::Invalid {
                message: format!("[model] simpson_intervals must be even and >= 2, got {n}"),
                path: path.to_path_buf(),
            })?;
        }
        Ok(model)
    }
}

/// Newton overrides.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverConfig {
    /// Absolute gradient tolerance (J/m).
    pub gradient_abs_tol: Option<f64>,
    /// Relative gradient tolerance.
    pub gradient_rel_tol: Option<f64>,
    /// Iteration cap.
    pub max_iterations: Option<usize>,
    /// Iterations without progress after which a solve fails (0: never;
    /// [`crate::periodic::STALL_ITERATIONS`] by default).
    pub stall_iterations: Option<usize>,
}

impl SolverConfig {
    /// Equilibrium settings with the overrides applied.
    pub fn equilibrium(&self) -> EquilibriumSettings {
        let mut s = EquilibriumSettings::default();
        let c = self;
        s.newton.gradient_abs_tol = c.gradient_abs_tol.unwrap_or(s.newton.gradient_abs_tol);
        s.newton.gradient_rel_tol = c.gradient_rel_tol.unwrap_or(s.newton.gradient_rel_tol);
        s.newton.max_iterations = c.max_iterations.unwrap_or(s.newton.max_iterations);
        s.newton.stall_iterations = c.stall_iterations.unwrap_or(s.newton.stall_iterations);
        s
    }
}

/// Curve settings.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveConfig {
    /// Directions (`weft`, `bias`, `warp`).
    #[serde(default = "all_directions")]
    pub directions: Vec<String>,
    /// Largest stretch.
    #[serde(default = "default_max_stretch")]
    pub max_stretch: f64,
    /// Points from 0 to `max_stretch` (≥ 2).
    #[serde(default = "default_points")]
    pub points: usize,
    /// Newton steps with the exact slope in the compression root-finds
    /// ([`crate::curves::CurveSettings::exact_slope`]; default `false`).
    #[serde(default)]
    pub exact_slope: bool,
    /// Along weft and warp, one Newton solve per point with the compression as a DOF
    /// ([`crate::curves::CurveSettings::compression_dof`]; default `true`).
    #[serde(default = "yes")]
    pub compression_dof: bool,
}

impl Default for CurveConfig {
    fn default() -> Self {
        Self {
            directions: all_directions(),
            max_stretch: default_max_stretch(),
            points: default_points(),
            exact_slope: false,
            compression_dof: true,
        }
    }
}

fn yes() -> bool {
    true
}

fn all_directions() -> Vec<String> {
    vec!["weft".into(), "bias".into(), "warp".into()]
}
fn default_max_stretch() -> f64 {
    0.5
}
fn default_points() -> usize {
    11
}

/// An axis: explicit values or a uniform range.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum AxisConfig {
    /// Explicit sample values (strictly increasing).
    List(Vec<f64>),
    /// `n` uniform samples from `min` to `max`.
    Range {
        /// First value.
        min: f64,
        /// Last value.
        max: f64,
        /// Number of samples.
        n: usize,
    },
}

impl AxisConfig {
    /// The sample values.
    pub fn values(&self) -> Vec<f64> {
        match self {
            AxisConfig::List(v) => v.clone(),
            AxisConfig::Range { min, max, n } => uniform_axis(*min, *max, *n),
        }
    }
}

/// Database settings (defaults: the 9³ grid of seed 004 over sx, sy ∈ [−0.2, 1], sa ∈
/// [−0.7, 0.7]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatabaseConfig {
    /// sx samples.
    #[serde(default = "default_stretch_axis")]
    pub sx: AxisConfig,
    /// sa samples.
    #[serde(default = "default_shear_axis")]
    pub sa: AxisConfig,
    /// sy samples.
    #[serde(default = "default_stretch_axis")]
    pub sy: AxisConfig,
    /// Fill a sample that cannot be solved from its continuation parent and go on
    /// ([`crate::database::DatabaseSettings::fill_unsolved`]); default false (stop with
    /// the error).
    #[serde(default)]
    pub fill_unsolved: bool,
}

impl Default for DatabaseConfig {
    fn default() -> Self {
        Self {
            sx: default_stretch_axis(),
            sa: default_shear_axis(),
            sy: default_stretch_axis(),
            fill_unsolved: false,
        }
    }
}

fn default_stretch_axis() -> AxisConfig {
    AxisConfig::Range {
        min: -0.2,
        max: 1.0,
        n: 9,
    }
}
fn default_shear_axis() -> AxisConfig {
    AxisConfig::Range {
        min: -0.7,
        max: 0.7,
        n: 9,
    }
}

/// Errors of reading a config.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// The TOML is malformed or has unknown/mistyped keys.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A value is out of range.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// What is wrong.
        message: String,
        /// The config file.
        path: PathBuf,
    },
}

impl Config {
    /// Reads `path`; relative paths inside are resolved against its directory.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let mut config: Self = read_toml(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        config.tile = base.join(&config.tile);
        config.out = base.join(&config.out);
        Ok(config)
    }

    /// Parses TOML `text` (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        parse_toml(text, path)
    }

    /// Checks the values the parser cannot: `[solver]` tolerances finite and positive and an
    /// iteration cap ≥ 1, `[database]` axes as the database format requires
    /// ([`yarn_pattern::madypg::Database::validate`]). Errors name the file and the key. `[model]` is checked by
    /// [`Config::model`], `[curve]` by [`Config::curve`].
    pub fn validate(&self, path: &Path) -> Result<(), ConfigError> {
        let bad = |message: String| ConfigError::Invalid {
            message,
            path: path.to_path_buf(),
        };
        let s = &self.solver;
        for (key, value) in [
            ("gradient_abs_tol", s.gradient_abs_tol),
            ("gradient_rel_tol", s.gradient_rel_tol),
        ] {
            if let Some(v) = value.filter(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(bad(format!(
                    "[solver] {key} must be a finite tolerance > 0, found {v}"
                )));
            }
        }
        if s.max_iterations == Some(0) {
            return Err(bad("[solver] max_iterations must be at least 1".into()));
        }
        // The axes as the database format checks them (non-empty, finite, increasing).
        let d = &self.database;
        yarn_pattern::madypg::Database {
            axes: [d.sx.values(), d.sa.values(), d.sy.values()],
            n_vertices: 0,
            data: vec![],
        }
        .validate()
        .map_err(|e| bad(format!("[database]: {e}")))?;
        Ok(())
    }

    /// The yarn model for yarn radius `r` (m) with the overrides applied.
    pub fn model(&self, r: f64, path: &Path) -> Result<YarnModel, ConfigError> {
        self.model.model(r, path)
    }

    /// Equilibrium settings with the overrides applied.
    pub fn equilibrium(&self) -> EquilibriumSettings {
        self.solver.equilibrium()
    }

    /// The curve directions and stretches.
    pub fn curve(&self, path: &Path) -> Result<(Vec<Direction>, Vec<f64>), ConfigError> {
        let c = &self.curve;
        let mut directions = Vec::new();
        for name in &c.directions {
            let d = Direction::ALL
                .into_iter()
                .find(|d| d.name() == name)
                .ok_or_else(|| ConfigError::Invalid {
                    message: format!(
                        "[curve] unknown direction {name:?} (expected weft, bias or warp)"
                    ),
                    path: path.to_path_buf(),
                })?;
            directions.push(d);
        }
        if !(c.points >= 2 && c.max_stretch > 0.0 && c.max_stretch.is_finite()) {
            return Err(ConfigError::Invalid {
                message: format!(
                    "[curve] needs points >= 2 and max_stretch > 0 (got {}, {})",
                    c.points, c.max_stretch
                ),
                path: path.to_path_buf(),
            });
        }
        Ok((directions, uniform_axis(0.0, c.max_stretch, c.points)))
    }
}

/// The config of `sim-periodic fit` (seed 002 §7): target curves, the input yarn geometry,
/// the fixed yarn inputs, the parameters to fit and the optimizer. Paths are relative to the
/// file; unknown keys are errors.
///
/// ```toml
/// targets = "curves.csv"        # shell-fem curves output (kind,direction,x,c,sigma)
/// pattern = "stockinette"       # a procedural pattern's input geometry, or
/// # tile = "stockinette.pyp"    # a yarn geometry file
/// radius = 1e-3                 # yarn radius of the procedural pattern (m)
/// resolution = 16               # its vertices per loop (knits) or per crossing (weaves);
///                               # default: the pattern's own (24 per loop, 4 per crossing)
/// out = "fit"                   # output directory (journal, fit.json, fitted-curves.csv)
///
/// [model]                       # the fixed inputs, as for the other commands (k2, k_c2, ...)
/// k2 = 200.0
///
/// [parameters]                  # optional; default: the paper's five with its bounds
/// k1 = "paper"                  # or explicit bounds [min, max] in SI units
/// bending = [1e-8, 1e-4]
/// # k2 = [10.0, 1000.0]         # beyond the paper: free the stiff stretch stiffness too
///                               # (explicit bounds only; the paper fixes it)
/// # geometry_x = [0.8, 1.3]     # beyond the paper: stretch the input geometry along x / y
/// # geometry_y = [0.8, 1.3]     # before the rest-shape estimation (fit.json names the
///                               # stretched geometry, fitted-geometry.pyp)
///
/// [fit]
/// rest_shape = true             # estimate the rest shape for every candidate (§7.2)
/// linear_stretch = false        # true: a linear stretch law, k = k2 (the ablation of Fig. 16)
/// swarm = true                  # particle swarm before the local search
/// particles = 16
/// swarm_iterations = 6
/// seed = 2022
/// restarts = 1                  # independent swarms (seeds seed, seed + 1, …), lowest g wins
/// inertia = [0.7213, 0.7213]    # swarm inertia weight, first and last iteration (paper: [0.9, 0.1])
/// swarm_samples = 7             # stress samples per direction in the swarm
/// local = "levenberg-marquardt" # or "cobyla" (the paper's)
/// local_samples = 20
/// sample_layout = "even"        # or "comfort-half": half of the samples in the comfort range
///                               # (beyond the paper; the yarn-fit figure's)
/// local_evaluations = 60
/// local_starts = 1              # Levenberg–Marquardt from this many distinct swarm points
///                               # (in parallel; the yarn-fit figure uses 3)
/// local_geometry = true         # Levenberg–Marquardt refines geometry_x / geometry_y too
/// compression_nodes = 3
/// comfort_stress = 33.333       # N/m: 2 N on the paper's 6 cm swatch
/// ```
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitConfig {
    /// Target curves (CSV), relative to the config file.
    pub targets: PathBuf,
    /// A yarn geometry file (`.pyp`); exclusive with `pattern`.
    pub tile: Option<PathBuf>,
    /// A procedural pattern name; exclusive with `tile`.
    pub pattern: Option<String>,
    /// Yarn radius of the procedural pattern (m). Default 1e-3.
    pub radius: Option<f64>,
    /// Vertices per stitch loop (knits) or per crossing (weaves) of the procedural pattern.
    /// Default: [`crate::patterns::Pattern::default_params`]'s.
    pub resolution: Option<usize>,
    /// Output directory, relative to the config file.
    pub out: PathBuf,
    /// The fixed yarn inputs.
    #[serde(default)]
    pub model: ModelConfig,
    /// Solver overrides.
    #[serde(default)]
    pub solver: SolverConfig,
    /// Parameters to fit: name → `"paper"` or `[min, max]`.
    #[serde(default)]
    pub parameters: BTreeMap<String, BoundConfig>,
    /// Optimizer settings.
    #[serde(default)]
    pub fit: FitOptions,
}

/// A parameter's bounds in a [`FitConfig`].
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum BoundConfig {
    /// `"paper"`: the bounds of seed 002 §7.3.2.
    Named(String),
    /// `[min, max]` (SI).
    Range([f64; 2]),
}

/// Optimizer settings of a [`FitConfig`] (defaults: [`crate::fit::FitSettings::default`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FitOptions {
    /// Estimate the rest shape for every candidate (§7.2).
    pub rest_shape: bool,
    /// A linear stretch law (`k` from `k2`) instead of the two-phase one.
    pub linear_stretch: bool,
    /// Run the particle swarm before the local search.
    pub swarm: bool,
    /// Swarm particles.
    pub particles: usize,
    /// Swarm iterations.
    pub swarm_iterations: u64,
    /// Swarm seed.
    pub seed: u64,
    /// Independent restarts ([`crate::fit::SwarmSettings::restarts`]).
    pub restarts: usize,
    /// The swarm's inertia weight at its first and last iteration
    /// ([`crate::fit::SwarmSettings::inertia`]).
    pub inertia: [f64; 2],
    /// Stress samples per direction in the swarm.
    pub swarm_samples: usize,
    /// `levenberg-marquardt` or `cobyla`.
    pub local: String,
    /// Stress samples per direction in the local search.
    pub local_samples: usize,
    /// `even` or `comfort-half` ([`crate::fit::SampleLayout`]), for both phases.
    pub sample_layout: String,
    /// Most local evaluations (COBYLA) or iterations (Levenberg–Marquardt).
    pub local_evaluations: usize,
    /// Levenberg–Marquardt starts ([`crate::fit::FitSettings::local_starts`]).
    pub local_starts: usize,
    /// Levenberg–Marquardt refines the geometric parameters too
    /// ([`crate::fit::FitSettings::local_geometry`]).
    pub local_geometry: bool,
    /// Compression root-finds per direction.
    pub compression_nodes: usize,
    /// End of the comfort range as a target stress (N/m).
    pub comfort_stress: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        let s = crate::fit::FitSettings::default();
        let swarm = s.swarm.clone().unwrap_or_default();
        Self {
            rest_shape: s.swarm_objective.rest_shape,
            linear_stretch: false,
            swarm: s.swarm.is_some(),
            particles: swarm.particles,
            swarm_iterations: swarm.iterations,
            seed: swarm.seed,
            restarts: swarm.restarts,
            inertia: [swarm.inertia.0, swarm.inertia.1],
            swarm_samples: s.swarm_objective.samples,
            local: name_of(LOCAL_METHODS, s.local).into(),
            local_samples: s.local_objective.samples,
            sample_layout: name_of(SAMPLE_LAYOUTS, s.local_objective.layout).into(),
            local_evaluations: s.local_evaluations,
            local_starts: s.local_starts,
            local_geometry: s.local_geometry,
            compression_nodes: s.local_objective.compression_nodes,
            comfort_stress: s.local_objective.comfort_stress,
        }
    }
}

impl FitConfig {
    /// Reads `path`; relative paths inside are resolved against its directory.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let mut config: Self = read_toml(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        config.targets = base.join(&config.targets);
        config.out = base.join(&config.out);
        config.tile = config.tile.map(|t| base.join(t));
        Ok(config)
    }

    /// Parses TOML `text` (`path` names it in errors; paths inside stay as written).
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        parse_toml(text, path)
    }

    /// The yarn model for radius `r` (m): the overrides, and the linear law if asked for.
    pub fn model(&self, r: f64, path: &Path) -> Result<YarnModel, ConfigError> {
        let mut model = self.model.model(r, path)?;
        if self.fit.linear_stretch {
            let k = match model.stretch {
                StretchLaw::TwoPhase { k2, .. } => k2,
                StretchLaw::Linear { k } => k,
            };
            model.stretch = StretchLaw::Linear { k };
        }
        Ok(model)
    }

    /// The fit settings.
    pub fn settings(&self, path: &Path) -> Result<crate::fit::FitSettings, ConfigError> {
        use crate::fit::{FitSettings, ObjectiveSettings, SwarmSettings};
        let f = &self.fit;
        let bad = |message: String| ConfigError::Invalid {
            message,
            path: path.to_path_buf(),
        };
        let local = choice(path, "local", &f.local, LOCAL_METHODS)?;
        let layout = choice(path, "sample_layout", &f.sample_layout, SAMPLE_LAYOUTS)?;
        if f.swarm_samples < 2 || f.local_samples < 2 || f.compression_nodes < 2 {
            return Err(bad(format!(
                "[fit] swarm_samples, local_samples and compression_nodes must be at least 2, \
                 found {}, {}, {}",
                f.swarm_samples, f.local_samples, f.compression_nodes
            )));
        }
        if !(f.comfort_stress.is_finite() && f.comfort_stress > 0.0) {
            return Err(bad(format!(
                "[fit] comfort_stress must be positive (N/m), found {}",
                f.comfort_stress
            )));
        }
        if f.swarm && (f.particles < 2 || f.restarts < 1) {
            return Err(bad(format!(
                "[fit] a swarm needs particles ≥ 2 and restarts ≥ 1, found particles = {}, \
                 restarts = {}",
                f.particles, f.restarts
            )));
        }
        if !f.inertia.iter().all(|w| w.is_finite()) {
            return Err(bad(format!(
                "[fit] inertia must be finite, found {:?}",
                f.inertia
            )));
        }
        if f.local_evaluations < 1 || f.local_starts < 1 {
            return Err(bad(format!(
                "[fit] local_evaluations and local_starts must be at least 1, found {} and {}",
                f.local_evaluations, f.local_starts
            )));
        }
        let curve = crate::curves::CurveSettings {
            equilibrium: self.solver.equilibrium(),
            ..Default::default()
        };
        let objective = |samples: usize| ObjectiveSettings {
            samples,
            compression_nodes: f.compression_nodes,
            comfort_stress: f.comfort_stress,
            rest_shape: f.rest_shape,
            stress_free_period: true,
            relax: crate::patterns::RelaxSettings {
                equilibrium: curve.equilibrium.clone(),
                ..Default::default()
            },
            curve: curve.clone(),
            layout,
        };
        Ok(FitSettings {
            swarm: f.swarm.then_some(SwarmSettings {
                particles: f.particles,
                iterations: f.swarm_iterations,
                seed: f.seed,
                inertia: (f.inertia[0], f.inertia[1]),
                restarts: f.restarts,
            }),
            start: None,
            swarm_objective: objective(f.swarm_samples),
            local_objective: objective(f.local_samples),
            local,
            local_evaluations: f.local_evaluations,
            local_starts: f.local_starts,
            local_geometry: f.local_geometry,
            ..FitSettings::default()
        })
    }
}

/// The names of the `[fit]` key `local`.
const LOCAL_METHODS: [(&str, crate::fit::LocalMethod); 2] = [
    (
        "levenberg-marquardt",
        crate::fit::LocalMethod::LevenbergMarquardt,
    ),
    ("cobyla", crate::fit::LocalMethod::Cobyla),
];

/// The names of the `[fit]` key `sample_layout`.
const SAMPLE_LAYOUTS: [(&str, crate::fit::SampleLayout); 2] = [
    ("even", crate::fit::SampleLayout::Even),
    ("comfort-half", crate::fit::SampleLayout::ComfortHalf),
];

/// The name of `value` among `options`.
fn name_of<T: PartialEq>(options: [(&'static str, T); 2], value: T) -> &'static str {
    options
        .into_iter()
        .find(|(_, v)| *v == value)
        .map(|(name, _)| name)
        .expect("every value has a name")
}

/// The value of the `[fit]` key `key` that `value` names among two `(name, value)` options;
/// any other name is an error naming `path` and both names.
fn choice<T>(
    path: &Path,
    key: &str,
    value: &str,
    options: [(&str, T); 2],
) -> Result<T, ConfigError> {
    let names = [options[0].0, options[1].0];
    options
        .into_iter()
        .find(|(name, _)| *name == value)
        .map(|(_, v)| v)
        .ok_or_else(|| ConfigError::Invalid {
            message: format!(
                "[fit] {key} must be {:?} or {:?}, found {value:?}",
                names[0], names[1]
            ),
            path: path.to_path_buf(),
        })
}

/// Reads and parses the TOML file `path` (errors name it, with line and column).
fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_toml(&text, path)
}

/// Parses TOML `text` read from `path` (named in errors, with line and column).
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(
    text: &str,
    path: &Path,
) -> Result<T, ConfigError> {
    toml::from_str::<T>(text).map_err(|e| {
        let (line, column) = e
            .span()
            .map(|s| line_column(text, s.start))
            .unwrap_or((1, 1));
        ConfigError::Parse {
            path: path.to_path_buf(),
            line,
            column,
            message: e.message().to_string(),
        }
    })
}

/// 1-based (line, column) of byte offset `at` in `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_keys_and_bad_types_are_located() {
        let path = Path::new("run.toml");
        let e = Config::parse(
            "tile = \"a.pyp\"\nout = \"o\"\n[model]\nbendng = 1.0\n",
            path,
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("run.toml:4:"), "{e}");
        assert!(e.contains("bendng"), "{e}");
        let e = Config::parse(
            "tile = \"a.pyp\"\nout = \"o\"\n[curve]\npoints = \"many\"\n",
            path,
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("run.toml:4:"), "{e}");
    }

    #[test]
    fn defaults_and_axes() {
        let c = Config::parse(
            "tile = \"a.pyp\"\nout = \"o\"\n[database]\nsa = [-0.5, 0.0, 0.5]\n",
            Path::new("x.toml"),
        )
        .unwrap();
        assert_eq!(c.database.sa.values(), vec![-0.5, 0.0, 0.5]);
        assert_eq!(c.database.sx.values().len(), 9);
        let (dirs, s) = c.curve(Path::new("x.toml")).unwrap();
        assert_eq!(dirs.len(), 3);
        assert_eq!(s.len(), 11);
        let bad = Config::parse(
            "tile = \"a.pyp\"\nout = \"o\"\n[curve]\ndirections = [\"diagonal\"]\n",
            Path::new("x.toml"),
        )
        .unwrap();
        assert!(
            bad.curve(Path::new("x.toml"))
                .unwrap_err()
                .to_string()
                .contains("diagonal")
        );
    }

    /// A minimal config with `body` under `[section]`.
    fn with_section(section: &str, body: &str) -> Result<Config, ConfigError> {
        Config::parse(
            &format!("tile = \"a.pyp\"\nout = \"o\"\n[{section}]\n{body}"),
            Path::new("x.toml"),
        )
    }

    #[test]
    fn the_stall_test_can_be_set_or_switched_off() {
        let parse = |body: &str| {
            with_section("solver", body)
                .unwrap()
                .solver
                .equilibrium()
                .newton
                .stall_iterations
        };
        assert_eq!(parse(""), crate::periodic::STALL_ITERATIONS);
        assert_eq!(parse("stall_iterations = 0\n"), 0);
        assert_eq!(parse("stall_iterations = 12\n"), 12);
    }

    #[test]
    fn newton_steps_on_the_compression_are_opt_in() {
        let parse = |body: &str| with_section("curve", body).unwrap().curve.exact_slope;
        assert!(!parse(""));
        assert!(parse("exact_slope = true\n"));
        let err = with_section("curve", "exact_slope = 1\n").unwrap_err();
        assert!(err.to_string().contains("x.toml"), "{err}");
    }

    #[test]
    fn the_compression_dof_is_on_unless_switched_off() {
        let parse = |body: &str| with_section("curve", body).unwrap().curve.compression_dof;
        assert!(parse(""));
        assert!(!parse("compression_dof = false\n"));
        let err = with_section("curve", "compression_dof = \"no\"\n").unwrap_err();
        assert!(err.to_string().contains("x.toml"), "{err}");
    }
}
