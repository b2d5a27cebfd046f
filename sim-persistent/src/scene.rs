//! TOML scene files and yarn-curve output (issue 6: "a scene file … pattern, size, yarn
//! parameters (Table 1 presets), drivers, outputs, and which force terms exist").
//!
//! # Schema
//!
//! ```toml
//! dt = 1e-3            # time step (s); default 1e-3
//! steps = 300          # number of steps; required
//! output_every = 10    # write a frame every k steps (and the initial state); default 10
//!
//! [pattern]            # either a builder with a size …
//! builder = "rib"      # "stockinette", "garter", "rib", "seed"
//! width = 8            # stitches per row
//! height = 6           # rows
//! rib = [2, 2]         # knits and purls per rib repeat (builder "rib" only; default [2, 2])
//! # chart = "K4\nP4"   # … or a chart in the text format of `chart` (then no builder/size)
//!
//! [yarn]
//! preset = "sweater"   # Table 1: "sweater", "shirt", "pullover"; default "sweater"
//! # overrides, all optional (SI units): radius, young_modulus, bending_modulus,
//! # linear_density, wrapping_stiffness, friction_max_force, loop_width, gravity = [x, y, z]
//!
//! [damping]            # Rayleigh α (1/s) and β (s); defaults: the preset's Table 1 values
//! alpha = 10.0
//! beta = 0.0
//!
//! [forces]             # which terms exist; every one defaults to true
//! gravity = false
//! wrapping = true
//!
//! [[clamp]]            # pinned row-boundary nodes, optionally driven at a constant velocity
//! edge = "bind-off"    # "cast-on" (boundary 0) or "bind-off" (last boundary)
//! velocity = [0.0, 0.01, 0.0]   # m/s; default zero (a fixed clamp)
//! ```
//!
//! Unknown keys are errors (serde `deny_unknown_fields`); every parse error names the line and
//! column of the offending text ([`SceneError::Parse`]).
//!
//! # Output
//!
//! [`write_obj`] writes one Wavefront OBJ file per frame: a `v` line per contact node and an
//! `l` polyline per yarn through its nodes in yarn order (the straight segments the model
//! simulates; the smooth, normal-offset rendering curves of §3.2 are not done yet).

use crate::chart::{Chart, ChartError};
use crate::forces::ForceSet;
use crate::integrator::{SimError, Simulator, StepSettings};
use crate::layout::{Layout, LayoutError, LayoutParams};
use crate::params::YarnParams;
use crate::topology::{Side, Topology, knit_node};
use rod::geometry::V3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A scene that cannot be read or set up.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file cannot be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Malformed TOML, an unknown key or a value of the wrong type.
    #[error("{path}:{line}:{column}: {message}")]
    Parse {
        /// The file (or `<text>`).
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column (characters).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Well-formed but invalid (unknown builder or preset, missing size, bad values).
    #[error("invalid scene: {0}")]
    Invalid(String),
    /// The chart text of `[pattern] chart` is malformed.
    #[error("invalid chart in [pattern]: {0}")]
    Chart(#[from] ChartError),
    /// The layout parameters are invalid.
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// The simulator rejected the setup or a step failed.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// `[pattern]`.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// Builder name: `stockinette`, `garter`, `rib`, `seed`.
    pub builder: Option<String>,
    /// Stitches per row (with a builder).
    pub width: Option<usize>,
    /// Rows (with a builder).
    pub height: Option<usize>,
    /// `[knits, purls]` per rib repeat (builder `rib`).
    pub rib: Option<[usize; 2]>,
    /// A chart in the text format of [`crate::chart`] (instead of a builder).
    pub chart: Option<String>,
}

/// `[yarn]`: a Table 1 preset with optional overrides (SI units).
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct YarnSpec {
    /// `sweater` (default), `shirt` or `pullover`.
    pub preset: Option<String>,
    /// Yarn radius (m).
    pub radius: Option<f64>,
    /// Young modulus (Pa).
    pub young_modulus: Option<f64>,
    /// Bending modulus B of Table 1.
    pub bending_modulus: Option<f64>,
    /// Linear density (kg/m).
    pub linear_density: Option<f64>,
    /// Wrapping stiffness `k_w` (N).
    pub wrapping_stiffness: Option<f64>,
    /// Friction slip force (N).
    pub friction_max_force: Option<f64>,
    /// Loop width of the layout (m; default the preset's Table 1 value).
    pub loop_width: Option<f64>,
    /// Gravity (m/s²).
    pub gravity: Option<[f64; 3]>,
}

/// `[damping]`: Rayleigh coefficients.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DampingSpec {
    /// Mass damping α (1/s).
    pub alpha: Option<f64>,
    /// Stiffness damping β (s).
    pub beta: Option<f64>,
}

/// `[forces]`: which terms exist (all default to true).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ForcesSpec {
    /// Gravity.
    pub gravity: bool,
    /// Yarn stretch.
    pub stretch: bool,
    /// Bending with jamming.
    pub bending: bool,
    /// Stitch-contact length.
    pub stitch_length: bool,
    /// Sliding friction.
    pub friction: bool,
    /// Stitch wrapping.
    pub wrapping: bool,
}

impl Default for ForcesSpec {
    fn default() -> Self {
        let f = ForceSet::default();
        Self {
            gravity: f.gravity,
            stretch: f.stretch,
            bending: f.bending,
            stitch_length: f.stitch_length,
            friction: f.friction,
            wrapping: f.wrapping,
        }
    }
}

/// `[[clamp]]`: the nodes of a row boundary, pinned and moved at a constant velocity.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClampSpec {
    /// `cast-on` or `bind-off`.
    pub edge: String,
    /// Velocity (m/s); default zero.
    #[serde(default)]
    pub velocity: [f64; 3],
}

/// A scene file (module documentation).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Time step (s).
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Number of steps.
    pub steps: usize,
    /// Write a frame every `output_every` steps.
    #[serde(default = "default_output_every")]
    pub output_every: usize,
    /// The fabric.
    pub pattern: PatternSpec,
    /// Yarn parameters.
    #[serde(default)]
    pub yarn: YarnSpec,
    /// Rayleigh damping.
    #[serde(default)]
    pub damping: DampingSpec,
    /// Force terms.
    #[serde(default)]
    pub forces: ForcesSpec,
    /// Clamps.
    #[serde(default)]
    pub clamp: Vec<ClampSpec>,
}

fn default_dt() -> f64 {
    1e-3
}

fn default_output_every() -> usize {
    10
}

/// 1-based (line, column in characters) of byte offset `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// A simulator set up from a scene, with its clamps.
pub struct SceneRun {
    /// The simulator.
    pub sim: Simulator,
    /// Clamped nodes and their velocity (m/s).
    pub clamps: Vec<(Vec<usize>, V3)>,
}

impl Scene {
    /// Parses TOML `text`; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        toml::from_str::<Scene>(text).map_err(|e| {
            let (line, column) = e
                .span()
                .map(|s| line_column(text, s.start))
                .unwrap_or((1, 1));
            SceneError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                message: e.message().to_string(),
            }
        })
    }

    /// Reads and parses a scene file.
    pub fn read(path: &Path) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// The chart of `[pattern]`.
    pub fn chart(&self) -> Result<Chart, SceneError> {
        let p = &self.pattern;
        match (&p.builder, &p.chart) {
            (Some(_), Some(_)) | (None, None) => Err(SceneError::Invalid(
                "[pattern] needs exactly one of `builder` and `chart`".into(),
            )),
            (None, Some(text)) => {
                if p.width.is_some() || p.height.is_some() || p.rib.is_some() {
                    return Err(SceneError::Invalid(
                        "[pattern] `chart` sets the size itself: no width, height or rib".into(),
                    ));
                }
                Ok(Chart::parse(text)?)
            }
            (Some(builder), None) => {
                let (Some(w), Some(h)) = (p.width, p.height) else {
                    return Err(SceneError::Invalid(
                        "[pattern] a builder needs `width` and `height`".into(),
                    ));
                };
                if p.rib.is_some() && builder != "rib" {
                    return Err(SceneError::Invalid(format!(
                        "[pattern] `rib` only applies to builder \"rib\", not \"{builder}\""
                    )));
                }
                Ok(match builder.as_str() {
                    "stockinette" => Chart::stockinette(w, h)?,
                    "garter" => Chart::garter(w, h)?,
                    "seed" => Chart::seed(w, h)?,
                    "rib" => {
                        let [k, pu] = p.rib.unwrap_or([2, 2]);
                        Chart::rib(w, h, k, pu)?
                    }
                    other => {
                        return Err(SceneError::Invalid(format!(
                            "[pattern] unknown builder \"{other}\" (stockinette, garter, rib, seed)"
                        )));
                    }
                })
            }
        }
    }

    /// Yarn parameters, loop width (m) and Rayleigh (α, β) of `[yarn]` and `[damping]`.
    pub fn yarn(&self) -> Result<(YarnParams, f64, f64, f64), SceneError> {
        let y = &self.yarn;
        // Table 1: preset, loop width (m), Rayleigh α, β.
        let (mut params, loop_width, alpha, beta) = match y.preset.as_deref().unwrap_or("sweater") {
            "sweater" => (YarnParams::sweater(), 3e-3, 10.0, 0.01),
            "shirt" => (YarnParams::shirt(), 1e-3, 2.0, 0.1),
            "pullover" => (YarnParams::pullover(), 6e-3, 5.0, 0.01),
            other => {
                return Err(SceneError::Invalid(format!(
                    "[yarn] unknown preset \"{other}\" (sweater, shirt, pullover)"
                )));
            }
        };
        if let Some(r) = y.radius {
            // Keep the derived defaults consistent with the new radius.
            let mut p = YarnParams::new(r, params.young_modulus, params.bending_modulus);
            p.gravity = params.gravity;
            params = p;
        }
        let set = |slot: &mut f64, v: Option<f64>| {
            if let Some(v) = v {
                *slot = v;
            }
        };
        set(&mut params.young_modulus, y.young_modulus);
        set(&mut params.bending_modulus, y.bending_modulus);
        set(&mut params.linear_density, y.linear_density);
        set(&mut params.wrapping_stiffness, y.wrapping_stiffness);
        set(&mut params.friction_max_force, y.friction_max_force);
        if let Some(g) = y.gravity {
            params.gravity = V3::from(g);
        }
        params.validate().map_err(SceneError::Invalid)?;
        Ok((
            params,
            y.loop_width.unwrap_or(loop_width),
            self.damping.alpha.unwrap_or(alpha),
            self.damping.beta.unwrap_or(beta),
        ))
    }

    /// The simulator of the scene, with its clamps pinned.
    pub fn build(&self) -> Result<SceneRun, SceneError> {
        if self.output_every == 0 {
            return Err(SceneError::Invalid("output_every must be ≥ 1".into()));
        }
        let chart = self.chart()?;
        let (params, loop_width, alpha, beta) = self.yarn()?;
        let topology = Topology::knit(&chart);
        let layout = Layout::new(&topology, &LayoutParams::new(loop_width, params.radius))?;
        let f = &self.forces;
        let forces = ForceSet {
            gravity: f.gravity,
            stretch: f.stretch,
            bending: f.bending,
            stitch_length: f.stitch_length,
            friction: f.friction,
            wrapping: f.wrapping,
        };
        let settings = StepSettings {
            dt: self.dt,
            rayleigh_alpha: alpha,
            rayleigh_beta: beta,
            ..StepSettings::default()
        };
        let mut sim = Simulator::new(topology, &layout, params, forces, settings)?;
        let (w, h) = (chart.width(), chart.height());
        let mut clamps = Vec::new();
        for c in &self.clamp {
            let b = match c.edge.as_str() {
                "cast-on" => 0,
                "bind-off" => h,
                other => {
                    return Err(SceneError::Invalid(format!(
                        "[[clamp]] unknown edge \"{other}\" (cast-on, bind-off)"
                    )));
                }
            };
            let nodes: Vec<usize> = (0..w)
                .flat_map(|col| {
                    [Side::Left, Side::Right].into_iter().flat_map(move |s| {
                        [
                            knit_node(w, b, col, s, false),
                            knit_node(w, b, col, s, true),
                        ]
                    })
                })
                .collect();
            sim.pin_nodes(&nodes)?;
            clamps.push((nodes, V3::from(c.velocity)));
        }
        Ok(SceneRun { sim, clamps })
    }
}

impl SceneRun {
    /// Moves the clamps by one step of their drivers, then advances the simulator.
    pub fn step(&mut self) -> Result<(), SceneError> {
        let dt = self.sim.settings().dt;
        for (nodes, v) in &self.clamps {
            if v.norm() > 0.0 {
                self.sim.displace_pinned_nodes(nodes, *v * dt)?;
            }
        }
        self.sim.step()?;
        Ok(())
    }
}

/// The yarn curves of `sim` as OBJ text: `v` per node (m), `l` per yarn (module docs).
pub fn obj_text(sim: &Simulator) -> String {
    let mut out = String::from("# sim-persistent yarn curves (m): one polyline per yarn\n");
    let q = &sim.state().q;
    for n in 0..sim.topology().nodes.len() {
        let x = sim.dofs().position(q, n);
        out.push_str(&format!("v {:.9e} {:.9e} {:.9e}\n", x.x, x.y, x.z));
    }
    for yarn in &sim.topology().yarns {
        out.push('l');
        for p in &yarn.passes {
            out.push_str(&format!(" {}", p.node + 1));
        }
        out.push('\n');
    }
    out
}

/// Writes [`obj_text`] to `dir/frame_NNNNN.obj` and returns the path.
pub fn write_obj(sim: &Simulator, dir: &Path, frame: usize) -> Result<PathBuf, SceneError> {
    let path = dir.join(format!("frame_{frame:05}.obj"));
    std::fs::write(&path, obj_text(sim)).map_err(|source| SceneError::Io {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}
