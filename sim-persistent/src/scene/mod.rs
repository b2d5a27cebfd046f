//! TOML scene files and yarn-curve output (issue 6: "a scene file … pattern, size, yarn
//! parameters (Table 1 presets), drivers, outputs, and which force terms exist").
//!
//! # Schema
//!
//! ```toml
//! dt = 1e-3            # time step (s); default 1e-3
//! friction_return_mapping = 0   # re-solves per step for the implicit stick/slip decision
//!                      # of friction (crate::forces::friction), e.g. 20 (with
//!                      # [forces] loop_contact = true); default 0: the paper's explicit
//!                      # anchor update after each step
//! steps = 300          # number of steps; required
//! output_every = 10    # write a frame every k steps (and the initial state); default 10
//!                      # (the same as `[output] every`; give only one of them)
//!
//! [pattern]            # either a builder with a size …
//! builder = "rib"      # "stockinette", "garter", "rib", "seed"
//! width = 8            # stitches per row
//! height = 6           # rows
//! rib = [2, 2]         # knits and purls per rib repeat (builder "rib" only; default [2, 2])
//! # chart = "K4\nP4"   # … or a chart in the text format of `chart` (then no builder/size;
//!                      # any stitch of crate::chart: YO, K2TOG, SSK, M1L, KFB, …)
//! # construction = "flat"  # knits: "flat-per-row" (default: one yarn per row, ends tied),
//!                      # "flat" (one continuous yarn turning at the row ends) or "round"
//!                      # (a tube; crate::topology::Construction)
//! # builder = "twill"  # … or a weave: "plain", "twill", "satin" (crate::weave) with
//! # warps = 8          # warp yarns (columns, along y) and
//! # wefts = 8          # weft yarns (rows, along x), both ≥ 2; the yarn spacing is
//! #                    # `[yarn] loop_width`
//! # twill = [2, 1]     # crossings over / under (builder "twill" only; default [2, 1])
//! # satin = [5, 2]     # harness and step (builder "satin" only; default [5, 2])
//!
//! [yarn]
//! preset = "sweater"   # Table 1: "sweater", "shirt", "pullover"; default "sweater"
//! # overrides, all optional (SI units): radius, young_modulus, bending_modulus,
//! # linear_density, wrapping_stiffness, friction_coefficient, friction_max_force, loop_width,
//! # wrapping_rest ("layout", the default, or "paper": crate::params::WrappingRest),
//! # wrapping_bias (rad, layout only; default 0.1), gravity = [x, y, z]; for a knit's layout also row_height (default: the loop width) and
//! # loop_length (yarn per loop; the out-of-plane offset is solved for it, default R/4),
//! # or all three at once in knitters' units (per 10 cm and mm):
//! # gauge = { stitches = 18, rows = 34, stitch_length_mm = 14.0 }
//!
//! [damping]            # Rayleigh α (1/s) and β (s); defaults: the preset's Table 1 values
//! alpha = 10.0
//! beta = 0.0
//!
//! [forces]             # which terms exist; all default to true but loop_contact
//! gravity = false
//! wrapping = true
//! crossing_shear = true  # crossing shear with jamming (weaves only)
//! loop_contact = false   # contact between adjacent loops (knits only); default false
//! segment_floor = true   # floor on segments' material length (ours); default true
//! yarn_contact = true    # yarn self-contact (crate::forces::yarn_contact); default true
//!
//! [crossing_shear]     # weaves; all optional (crate::forces::crossing_shear)
//! stiffness = 2e-2     # k_x (N)
//! jamming_angle = 1.047 # γ_j (rad), in [0, π/2)
//! jamming_width = 0.1  # rad
//! jamming_factor = 1000.0
//!
//! [[obstacle]]         # any number; frictionless penalty contact (crate::forces::obstacle)
//! kind = "sphere"      # "sphere" (centre, radius), "plane" (point, normal) or "mesh":
//!                      # file = "body.obj" (relative to the scene file; "body_*.obj" is a
//!                      # numbered OBJ sequence, then fps = 30 is required), scale = 0.001
//!                      # (file units to m; default 1), offset = [x, y, z] (m; default 0),
//!                      # reach = 5e-3 (m; how far from the surface yarn points are
//!                      # searched, crate::forces::obstacle::mesh); yarn nodes and segment
//!                      # midpoints touch a mesh
//! centre = [0.0, 0.0, -0.02]   # m
//! radius = 0.01        # m
//! stiffness = 2e4      # N/m; optional, default k_s/R of the yarn
//! sticky = false       # true: a node that touches the obstacle (distance from its
//!                      # surface ≤ the yarn radius) at the end of a step is pinned there
//!                      # from then on (sticking contact, the μ → ∞ stand-in for friction
//!                      # of crate::experiment::sphere_drop); default false
//!
//! [[clamp]]            # any number; pinned nodes (crate::experiment::clamps::ClampSet),
//!                      # optionally driven at a constant velocity; exactly one of
//! edge = "bind-off"    # "cast-on" (row boundary 0), "bind-off" (last row boundary),
//!                      # "left" / "right" (every node of the first / last stitch column)
//! # column = 3         # … or every node of stitch column 3 (0-based, < width)
//! velocity = [0.0, 0.01, 0.0]   # m/s; default zero (a fixed clamp)
//!                      # (weaves: "cast-on" is weft 0, "bind-off" the last weft, "left" /
//!                      # "right" warp 0 / the last warp, `column = i` warp i; a chart
//!                      # that changes its width or is knitted in the round has only
//!                      # "cast-on" and "bind-off")
//!
//! [uniaxial]           # optional: the virtual swatch test (crate::experiment::uniaxial)
//!                      # instead of a time-stepped run; no [[clamp]] then (the test
//!                      # clamps the swatch itself) and `steps` is the damped settle
//!                      # between the clamps (steps × dt, mass damping α = 10 /s)
//! direction = "weft"   # "weft" (side clamps) or "warp" (cast-on / bind-off)
//! max_stretch = 0.4    # largest stretch s
//! load_steps = 20      # quasi-static load steps; each is a row of uniaxial.csv
//! settle_free = false  # settle free before clamping (default: clamped flat)
//! zero_force_start = false  # move the clamp to zero force first, as a test machine
//!                      # removes its preload (default: start at the layout's length)
//!
//! [output]             # all optional (crate::output::OutputSpec)
//! formats = ["obj", "ply", "bcc", "png"]   # also "nodes"; default ["obj"]
//! every = 10           # steps between frames (≥ 1)
//! samples = 8          # spline samples per segment (1 … 256)
//! bcc = "C0"           # "C0": control points, "PL": spline samples
//! png_size = [800, 600]
//! view = "front"       # "front", "back", "side", "oblique"
//! supersample = 2      # PNG anti-aliasing, 1 … 8
//! ```
//!
//! Unknown keys are errors (serde `deny_unknown_fields`); every parse error names the line and
//! column of the offending text ([`SceneError::Parse`]). A `[[clamp]]` with an unknown `edge`
//! is reported at the value, one with both or neither of `edge` and `column`, or a column
//! beyond the pattern, at the entry. `[pattern]` and `[output]` are
//! checked while parsing too: a bad `[output]` value is reported at the value, an
//! inconsistent `[pattern]` (unknown builder, missing size, a size key that does not apply,
//! a malformed chart) at the `[pattern]` header.
//!
//! # Output
//!
//! [`crate::output::FrameWriter`] writes each frame in the formats of `[output]`: the smooth,
//! normal-offset rendering curves of §3.2 as OBJ, PLY, `.bcc`, USD and PNG, optionally the
//! simulated node polylines ("nodes"), and with `"usd_cache"` one USD cache of the whole run
//! (`yarns.usda`, time-sampled, at one time code per written frame). [`write_obj`] / [`obj_text`] keep the former output:
//! a `v` line per contact node and an `l` polyline per yarn through its nodes in yarn order.

pub mod checkpoint;
mod specs;

pub use crate::topology::Fabric;
pub use specs::{
    ClampSpec, CrossingShearSpec, DampingSpec, ForcesSpec, KnitGaugeSpec, ObstacleSpec,
    PatternSpec, SceneCrossingShear, YarnSpec,
};

use crate::chart::{Chart, ChartError};
use crate::experiment::clamps::Grid;
use crate::experiment::sphere_drop::StickyContacts;
use crate::experiment::swatch::SwatchSettings;
use crate::experiment::uniaxial::{Pull, UniaxialTest};
use crate::forces::ForceSet;
use crate::integrator::{SimError, Simulator, StepSettings};
use crate::layout::{Gauge, Layout, LayoutError, LayoutParams};
use crate::output::{OutputError, OutputSpec};
use crate::params::{DEFAULT_WRAP_BIAS, WrappingRest, YarnParams};
use crate::topology::Topology;
use rod::geometry::V3;
use serde::Deserialize;
use specs::de_pattern;
use std::path::{Path, PathBuf};

/// A `[pattern]` whose chart or weave has no topology, as a scene error at the `[pattern]`
/// header.
fn pattern_error(e: crate::topology::TopologyError) -> SceneError {
    SceneError::Invalid(format!("[pattern] {e}"))
}

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
    /// Frame output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A run's checkpoint file is damaged or belongs to another run ([`checkpoint`]).
    #[error("checkpoint {path}: {problem}")]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// `output_every` (≥ 1).
fn de_output_every<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    let v = usize::deserialize(d)?;
    if v == 0 {
        return Err(serde::de::Error::custom("`output_every` must be ≥ 1 step"));
    }
    Ok(Some(v))
}

/// A scene file (module documentation).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Time step (s).
    #[serde(default = "default_dt", deserialize_with = "specs::de_positive")]
    pub dt: f64,
    /// Re-solves per step of the friction return mapping
    /// ([`StepSettings::friction_return_mapping`]; 0: explicit anchor update).
    #[serde(default = "default_friction_return_mapping")]
    pub friction_return_mapping: usize,
    /// Number of steps.
    pub steps: usize,
    /// Write a frame every `output_every` steps (≥ 1; the same as `[output] every`, see
    /// [`Scene::frame_every`]).
    #[serde(default, deserialize_with = "de_output_every")]
    pub output_every: Option<usize>,
    /// The fabric (checked while parsing).
    #[serde(deserialize_with = "de_pattern")]
    pub pattern: PatternSpec,
    /// Output formats and options.
    #[serde(default)]
    pub output: OutputSpec,
    /// Yarn parameters.
    #[serde(default)]
    pub yarn: YarnSpec,
    /// Rayleigh damping.
    #[serde(default)]
    pub damping: DampingSpec,
    /// Force terms.
    #[serde(default)]
    pub forces: ForcesSpec,
    /// Clamps with their place in the file (checked by [`Scene::parse`]).
    #[serde(default)]
    pub clamp: Vec<toml::Spanned<ClampSpec>>,
    /// Crossing-shear parameters (weaves).
    #[serde(default)]
    pub crossing_shear: SceneCrossingShear,
    /// Obstacles with their place in the file (none by default: then no obstacle terms
    /// exist).
    #[serde(default)]
    pub obstacle: Vec<toml::Spanned<ObstacleSpec>>,
    /// The virtual swatch test instead of a time-stepped run.
    #[serde(default)]
    pub uniaxial: Option<toml::Spanned<UniaxialSpec>>,
    /// The directory of the scene file (mesh files are relative to it).
    #[serde(skip)]
    pub base: std::path::PathBuf,
    /// The obstacles of `[[obstacle]]`, built once when the scene is parsed (so a mesh file
    /// is read once, and [`Scene::build`] uses what the parse checked).
    #[serde(skip)]
    obstacles: Vec<crate::forces::obstacle::Obstacle>,
}

/// `[uniaxial]`: the virtual swatch test ([`crate::experiment::uniaxial`]).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UniaxialSpec {
    /// `weft` or `warp`.
    pub direction: String,
    /// Largest stretch (unitless, > 0).
    pub max_stretch: f64,
    /// Quasi-static load steps (≥ 1).
    pub load_steps: usize,
    /// Settle free before clamping.
    #[serde(default)]
    pub settle_free: bool,
    /// Start at the clamp distance of zero force.
    #[serde(default)]
    pub zero_force_start: bool,
}

fn default_dt() -> f64 {
    1e-3
}

fn default_friction_return_mapping() -> usize {
    StepSettings::default().friction_return_mapping
}

/// Steps between frames when neither `output_every` nor `[output] every` is given.
pub const DEFAULT_OUTPUT_EVERY: usize = 10;

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
    /// The sticking obstacles (`sticky = true`) and the nodes they hold.
    pub sticky: StickyObstacles,
}

/// The obstacles of a scene with `sticky = true` and the contacts they hold.
#[derive(Clone, Debug)]
pub struct StickyObstacles {
    /// The sticking obstacles as indices into [`Simulator::obstacles`] (none: nothing is ever
    /// held), so that an animated mesh is tested where it is now.
    pub obstacles: Vec<usize>,
    /// The yarn radius (m): a node touches an obstacle when its distance from the surface is
    /// at most this.
    pub yarn_radius: f64,
    /// The nodes held so far.
    pub contacts: StickyContacts,
}

impl StickyObstacles {
    /// Pins the nodes of `sim` that touch a sticking obstacle and are not held yet.
    pub fn hold(&mut self, sim: &mut Simulator) -> Result<(), SimError> {
        if self.obstacles.is_empty() {
            return Ok(());
        }
        let q = &sim.state().q;
        let shapes: Vec<&crate::forces::obstacle::Shape> = self
            .obstacles
            .iter()
            .map(|&i| &sim.obstacles()[i].shape)
            .collect();
        let touching: Vec<usize> = (0..sim.topology().nodes.len())
            .filter(|&n| {
                let x = sim.dofs().position(q, n);
                shapes
                    .iter()
                    .any(|shape| shape.distance(&x).0 <= self.yarn_radius)
            })
            .collect();
        let time = sim.time();
        self.contacts.hold(sim, &touching, time)
    }
}

impl Scene {
    /// Parses TOML `text`; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let mut scene = Self::parse_fields(text, path)?;
        scene.base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let located = |span: std::ops::Range<usize>, message: String| {
            let (line, column) = line_column(text, span.start);
            SceneError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        };
        let obstacles = (scene.obstacle.iter())
            .map(|o| {
                (o.get_ref().obstacle(&scene.base)).map_err(|message| located(o.span(), message))
            })
            .collect::<Result<Vec<_>, _>>()?;
        scene.obstacles = obstacles;
        let grid = Grid::from(&scene.fabric()?);
        for c in &scene.clamp {
            if let Err(message) = c.get_ref().clamp_nodes(grid) {
                return Err(located(c.span(), message));
            }
        }
        if scene.output_every.is_some() && scene.output.every.is_some() {
            let (line, column) = toml::de::DeTable::parse(text)
                .ok()
                .and_then(|t| {
                    let output = t.get_ref().get("output")?;
                    let toml::de::DeValue::Table(o) = output.get_ref() else {
                        return None;
                    };
                    o.get("every").map(|v| line_column(text, v.span().start))
                })
                .unwrap_or((1, 1));
            return Err(SceneError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                message: "give either `output_every` or `[output] every`, not both".into(),
            });
        }
        Ok(scene)
    }

    /// Steps between output frames: `[output] every`, else `output_every`, else
    /// [`DEFAULT_OUTPUT_EVERY`].
    pub fn frame_every(&self) -> usize {
        self.output
            .every
            .or(self.output_every)
            .unwrap_or(DEFAULT_OUTPUT_EVERY)
    }

    fn parse_fields(text: &str, path: &Path) -> Result<Self, SceneError> {
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

    /// The chart of a knitted `[pattern]` (an error for a weave; see [`Scene::fabric`]).
    pub fn chart(&self) -> Result<Chart, SceneError> {
        match self.fabric()? {
            Fabric::Knit(chart, _) => Ok(chart),
            Fabric::Weave { .. } => Err(SceneError::Invalid(
                "[pattern] describes a weave, not a stitch chart".into(),
            )),
        }
    }

    /// The fabric of `[pattern]` ([`PatternSpec::fabric`]).
    pub fn fabric(&self) -> Result<Fabric, SceneError> {
        self.pattern.fabric()
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
        set(&mut params.friction_coefficient, y.friction_coefficient);
        if y.friction_max_force.is_some() {
            params.friction_max_force = y.friction_max_force;
        }
        if let Some(g) = y.gravity {
            params.gravity = V3::from(g);
        }
        params.wrapping_rest = match (y.wrapping_rest.as_deref(), y.wrapping_bias) {
            (Some("paper"), Some(_)) => {
                return Err(SceneError::Invalid(
                    "[yarn] wrapping_bias is for wrapping_rest = \"layout\"; the paper's rest \
                     angle is a fixed quarter turn"
                        .into(),
                ));
            }
            (Some("paper"), None) => WrappingRest::paper(),
            (_, bias) => WrappingRest::Layout {
                wrap: bias.unwrap_or(DEFAULT_WRAP_BIAS),
            },
        };
        params.validate().map_err(SceneError::Invalid)?;
        let gauge = self.knit_gauge(params.radius)?;
        Ok((
            params,
            (y.loop_width)
                .or(gauge.map(|g| g.loop_width * 2.0 * params.radius))
                .unwrap_or(loop_width),
            self.damping.alpha.unwrap_or(alpha),
            self.damping.beta.unwrap_or(beta),
        ))
    }

    /// The layout parameters of `[yarn]` for `topology`: loop width, row height and, with
    /// `loop_length`, the out-of-plane offset that gives the layout that yarn per loop.
    pub fn layout_params(&self, topology: &Topology) -> Result<LayoutParams, SceneError> {
        let (params, loop_width, ..) = self.yarn()?;
        if let Some(gauge) = self.knit_gauge(params.radius)? {
            if topology.knit.is_none() {
                return Err(SceneError::Invalid(
                    "[yarn] gauge is for knits: a weave's yarn spacing is loop_width".into(),
                ));
            }
            return LayoutParams::at_gauge(topology, params.radius, gauge)
                .map_err(|e| SceneError::Invalid(format!("[yarn] gauge: {e}")));
        }
        let mut layout = LayoutParams::new(loop_width, params.radius);
        if let Some(h) = self.yarn.row_height {
            if topology.knit.is_none() {
                return Err(SceneError::Invalid(
                    "[yarn] row_height is for knits: a weave's yarn spacing is loop_width".into(),
                ));
            }
            layout.row_height = h;
        }
        layout.validate()?;
        match self.yarn.loop_length {
            Some(length) => layout
                .with_loop_length(topology, length)
                .map_err(|e| SceneError::Invalid(format!("[yarn] loop_length: {e}"))),
            None => Ok(layout),
        }
    }

    /// `[yarn] gauge` in yarn diameters of a yarn of radius `radius` (m), checked: positive
    /// finite values, and none of the keys it sets given as well.
    fn knit_gauge(&self, radius: f64) -> Result<Option<Gauge>, SceneError> {
        let Some(g) = self.yarn.gauge else {
            return Ok(None);
        };
        for (key, set) in [
            ("loop_width", self.yarn.loop_width.is_some()),
            ("row_height", self.yarn.row_height.is_some()),
            ("loop_length", self.yarn.loop_length.is_some()),
        ] {
            if set {
                return Err(SceneError::Invalid(format!(
                    "[yarn] gauge sets the loop width, row height and loop length; remove \
                     `{key}` or the gauge"
                )));
            }
        }
        for (key, v) in [
            ("stitches", g.stitches),
            ("rows", g.rows),
            ("stitch_length_mm", g.stitch_length_mm),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SceneError::Invalid(format!(
                    "[yarn] gauge: `{key}` must be a finite number > 0, found {v}"
                )));
            }
        }
        Ok(Some(Gauge::from_knitting(
            g.stitches,
            g.rows,
            g.stitch_length_mm,
            2.0 * radius,
        )))
    }

    /// The virtual swatch test of `[uniaxial]`, if the scene has one: the scene's fabric,
    /// yarn, loop width, force terms and time step, with `steps × dt` of damped settle.
    pub fn uniaxial_test(&self) -> Result<Option<UniaxialTest>, SceneError> {
        let Some(spec) = &self.uniaxial else {
            return Ok(None);
        };
        let u = spec.get_ref();
        if !self.clamp.is_empty() {
            return Err(SceneError::Invalid(
                "[uniaxial] clamps the swatch itself: remove the [[clamp]] entries".into(),
            ));
        }
        if !self.obstacle.is_empty() {
            return Err(SceneError::Invalid(
                "[uniaxial] has no obstacles: remove the [[obstacle]] entries".into(),
            ));
        }
        if self.damping.alpha.is_some() || self.damping.beta.is_some() {
            return Err(SceneError::Invalid(
                "[uniaxial] settles with the swatch experiments' fixed mass damping (α = 10 /s): \
                 remove [damping]"
                    .into(),
            ));
        }
        if !(u.max_stretch.is_finite() && u.max_stretch > 0.0) || u.load_steps == 0 {
            return Err(SceneError::Invalid(format!(
                "[uniaxial] needs max_stretch > 0 and load_steps ≥ 1, found {} and {}",
                u.max_stretch, u.load_steps
            )));
        }
        let pull = Pull::parse(&u.direction)
            .map_err(|e| SceneError::Invalid(format!("[uniaxial] direction: {e}")))?;
        let (params, ..) = self.yarn()?;
        let settings = SwatchSettings {
            dt: self.dt,
            settle_time: self.steps as f64 * self.dt,
            forces: self.force_set(),
            friction_return_mapping: self.friction_return_mapping,
            params,
            ..SwatchSettings::default()
        };
        let fabric = self.fabric()?;
        let layout = self.layout_params(&fabric.topology().map_err(pattern_error)?)?;
        Ok(Some(UniaxialTest {
            fabric,
            pull,
            max_stretch: u.max_stretch,
            steps: u.load_steps,
            layout,
            settings,
            settle_free: u.settle_free,
            zero_force_start: u.zero_force_start,
        }))
    }

    /// The force terms of `[forces]`.
    fn force_set(&self) -> ForceSet {
        let f = &self.forces;
        ForceSet {
            gravity: f.gravity,
            stretch: f.stretch,
            bending: f.bending,
            stitch_length: f.stitch_length,
            friction: f.friction,
            wrapping: f.wrapping,
            crossing_shear: f.crossing_shear,
            crossing_shear_params: self.crossing_shear.0,
            loop_contact: f.loop_contact,
            segment_floor: f.segment_floor,
            yarn_contact: f.yarn_contact,
        }
    }

    /// The simulator of the scene, with its clamps pinned.
    pub fn build(&self) -> Result<SceneRun, SceneError> {
        if self.frame_every() == 0 {
            return Err(SceneError::Invalid("output_every must be ≥ 1".into()));
        }
        let fabric = self.fabric()?;
        let (params, _, alpha, beta) = self.yarn()?;
        let topology = fabric.topology().map_err(pattern_error)?;
        let layout = Layout::new(&topology, &self.layout_params(&topology)?)?;
        let forces = self.force_set();
        let settings = StepSettings {
            dt: self.dt,
            rayleigh_alpha: alpha,
            rayleigh_beta: beta,
            friction_return_mapping: self.friction_return_mapping,
            ..StepSettings::default()
        };
        let mut sim = Simulator::new(topology, &layout, params, forces, settings)?;
        sim.add_obstacles(&self.obstacles)?;
        let sticky = StickyObstacles {
            obstacles: (self.obstacle.iter().enumerate())
                .filter(|(_, spec)| spec.get_ref().sticky)
                .map(|(i, _)| i)
                .collect(),
            yarn_radius: params.radius,
            contacts: StickyContacts::new(sim.topology().nodes.len()),
        };
        let mut clamps = Vec::new();
        let grid = Grid::from(&fabric);
        for c in &self.clamp {
            let c = c.get_ref();
            let nodes = c.clamp_nodes(grid).map_err(SceneError::Invalid)?;
            sim.pin_nodes(&nodes)?;
            clamps.push((nodes, V3::from(c.velocity)));
        }
        Ok(SceneRun {
            sim,
            clamps,
            sticky,
        })
    }
}

impl SceneRun {
    /// Moves the clamps by one step of their drivers, advances the simulator, then pins the
    /// nodes that touch a sticking obstacle ([`StickyObstacles::hold`]).
    pub fn step(&mut self) -> Result<(), SceneError> {
        let dt = self.sim.settings().dt;
        for (nodes, v) in &self.clamps {
            if v.norm() > 0.0 {
                self.sim.displace_pinned_nodes(nodes, *v * dt)?;
            }
        }
        self.sim.step()?;
        self.sticky.hold(&mut self.sim)?;
        Ok(())
    }
}

/// The simulated yarn polylines of `sim` as OBJ text: `v` per node (m), `l` per yarn
/// ([`crate::output::nodes_obj_text`]).
pub fn obj_text(sim: &Simulator) -> String {
    crate::output::nodes_obj_text(sim)
}

/// Writes [`obj_text`] to `dir/frame_NNNNN.obj` and returns the path.
pub fn write_obj(sim: &Simulator, dir: &Path, frame: usize) -> Result<PathBuf, SceneError> {
    Ok(crate::output::write_nodes_obj(sim, dir, frame)?)
}
