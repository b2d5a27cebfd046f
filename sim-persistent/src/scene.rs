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
//! # chart = "K4\nP4"   # … or a chart in the text format of `chart` (then no builder/size)
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
//! # gravity = [x, y, z]
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
//!
//! [crossing_shear]     # weaves; all optional (crate::forces::crossing_shear)
//! stiffness = 2e-2     # k_x (N)
//! jamming_angle = 1.047 # γ_j (rad), in [0, π/2)
//! jamming_width = 0.1  # rad
//! jamming_factor = 1000.0
//!
//! [[obstacle]]         # any number; frictionless penalty contact (crate::forces::obstacle)
//! kind = "sphere"      # "sphere" (centre, radius) or "plane" (point, normal)
//! centre = [0.0, 0.0, -0.02]   # m
//! radius = 0.01        # m
//! stiffness = 2e4      # N/m; optional, default k_s/R of the yarn
//!
//! [[clamp]]            # any number; pinned nodes (crate::experiment::clamps::ClampSet),
//!                      # optionally driven at a constant velocity; exactly one of
//! edge = "bind-off"    # "cast-on" (row boundary 0), "bind-off" (last row boundary),
//!                      # "left" / "right" (every node of the first / last stitch column)
//! # column = 3         # … or every node of stitch column 3 (0-based, < width)
//! velocity = [0.0, 0.01, 0.0]   # m/s; default zero (a fixed clamp)
//!                      # (weaves: "cast-on" is weft 0, "bind-off" the last weft, "left" /
//!                      # "right" warp 0 / the last warp, `column = i` warp i)
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
//! normal-offset rendering curves of §3.2 as OBJ, PLY, `.bcc` and PNG, and optionally the
//! simulated node polylines ("nodes"). [`write_obj`] / [`obj_text`] keep the former output:
//! a `v` line per contact node and an `l` polyline per yarn through its nodes in yarn order.

use crate::chart::{Chart, ChartError};
use crate::experiment::clamps::{ClampSet, Grid};
use crate::forces::ForceSet;
use crate::integrator::{SimError, Simulator, StepSettings};
use crate::layout::{Layout, LayoutError, LayoutParams};
use crate::output::{OutputError, OutputSpec};
use crate::params::YarnParams;
use crate::topology::Topology;
use crate::weave::WeavePattern;
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
    /// Frame output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// `[pattern]`.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// Builder name: knits `stockinette`, `garter`, `rib`, `seed`; weaves `plain`, `twill`,
    /// `satin`.
    pub builder: Option<String>,
    /// Stitches per row (with a knit builder).
    pub width: Option<usize>,
    /// Rows (with a knit builder).
    pub height: Option<usize>,
    /// `[knits, purls]` per rib repeat (builder `rib`).
    pub rib: Option<[usize; 2]>,
    /// A chart in the text format of [`crate::chart`] (instead of a builder).
    pub chart: Option<String>,
    /// Warp yarns (with a weave builder, ≥ 2).
    pub warps: Option<usize>,
    /// Weft yarns (with a weave builder, ≥ 2).
    pub wefts: Option<usize>,
    /// `[over, under]` of a twill (builder `twill`; default `[2, 1]`).
    pub twill: Option<[usize; 2]>,
    /// `[harness, step]` of a satin (builder `satin`; default `[5, 2]`).
    pub satin: Option<[usize; 2]>,
}

/// The fabric a `[pattern]` describes.
#[derive(Clone, Debug, PartialEq)]
pub enum Fabric {
    /// A knit from a stitch chart.
    Knit(Chart),
    /// A woven fabric ([`Topology::weave`]).
    Weave {
        /// The weave pattern.
        pattern: WeavePattern,
        /// Warp yarns.
        warps: usize,
        /// Weft yarns.
        wefts: usize,
    },
}

impl Fabric {
    /// The topology of the fabric.
    pub fn topology(&self) -> Result<Topology, SceneError> {
        match self {
            Fabric::Knit(chart) => Ok(Topology::knit(chart)),
            Fabric::Weave {
                pattern,
                warps,
                wefts,
            } => Topology::weave(*pattern, *warps, *wefts)
                .map_err(|e| SceneError::Invalid(format!("[pattern] {e}"))),
        }
    }
}

impl PatternSpec {
    /// The fabric: a chart, a knit builder or a weave builder, with the keys that apply to it.
    pub fn fabric(&self) -> Result<Fabric, SceneError> {
        let bad = |m: String| SceneError::Invalid(format!("[pattern] {m}"));
        let set = |name: &'static str, given: bool| given.then_some(name);
        let knit_size = [
            set("width", self.width.is_some()),
            set("height", self.height.is_some()),
            set("rib", self.rib.is_some()),
        ];
        let weave_size = [
            set("warps", self.warps.is_some()),
            set("wefts", self.wefts.is_some()),
            set("twill", self.twill.is_some()),
            set("satin", self.satin.is_some()),
        ];
        let reject = |keys: &[Option<&'static str>], what: &str| -> Result<(), SceneError> {
            match keys.iter().flatten().next() {
                Some(k) => Err(bad(format!("`{k}` does not apply to {what}"))),
                None => Ok(()),
            }
        };
        match (&self.builder, &self.chart) {
            (Some(_), Some(_)) | (None, None) => {
                Err(bad("needs exactly one of `builder` and `chart`".into()))
            }
            (None, Some(text)) => {
                reject(&knit_size, "a chart (it sets the size itself)")?;
                reject(&weave_size, "a chart (it sets the size itself)")?;
                Ok(Fabric::Knit(Chart::parse(text)?))
            }
            (Some(builder), None) => match builder.as_str() {
                "stockinette" | "garter" | "seed" | "rib" => {
                    reject(&weave_size, &format!("knit builder \"{builder}\""))?;
                    let (Some(w), Some(h)) = (self.width, self.height) else {
                        return Err(bad(format!(
                            "builder \"{builder}\" needs `width` and `height`"
                        )));
                    };
                    if self.rib.is_some() && builder != "rib" {
                        return Err(bad(format!(
                            "`rib` only applies to builder \"rib\", not \"{builder}\""
                        )));
                    }
                    Ok(Fabric::Knit(match builder.as_str() {
                        "stockinette" => Chart::stockinette(w, h)?,
                        "garter" => Chart::garter(w, h)?,
                        "seed" => Chart::seed(w, h)?,
                        _ => {
                            let [k, pu] = self.rib.unwrap_or([2, 2]);
                            Chart::rib(w, h, k, pu)?
                        }
                    }))
                }
                "plain" | "twill" | "satin" => {
                    reject(&knit_size, &format!("weave builder \"{builder}\""))?;
                    let (Some(warps), Some(wefts)) = (self.warps, self.wefts) else {
                        return Err(bad(format!(
                            "builder \"{builder}\" needs `warps` and `wefts`"
                        )));
                    };
                    if self.twill.is_some() && builder != "twill" {
                        return Err(bad(format!(
                            "`twill` only applies to builder \"twill\", not \"{builder}\""
                        )));
                    }
                    if self.satin.is_some() && builder != "satin" {
                        return Err(bad(format!(
                            "`satin` only applies to builder \"satin\", not \"{builder}\""
                        )));
                    }
                    let pattern = match builder.as_str() {
                        "plain" => WeavePattern::Plain,
                        "twill" => {
                            let [over, under] = self.twill.unwrap_or([2, 1]);
                            WeavePattern::Twill { over, under }
                        }
                        _ => {
                            let [harness, step] = self.satin.unwrap_or([5, 2]);
                            WeavePattern::Satin { harness, step }
                        }
                    };
                    let fabric = Fabric::Weave {
                        pattern,
                        warps,
                        wefts,
                    };
                    fabric.topology()?;
                    Ok(fabric)
                }
                other => Err(bad(format!(
                    "unknown builder \"{other}\" (stockinette, garter, rib, seed, plain, twill, satin)"
                ))),
            },
        }
    }
}

/// Deserializes `[pattern]` and checks it ([`PatternSpec::fabric`]), so that an inconsistent
/// table is reported at its line.
fn de_pattern<'de, D: serde::Deserializer<'de>>(d: D) -> Result<PatternSpec, D::Error> {
    let spec = PatternSpec::deserialize(d)?;
    match spec.fabric() {
        Ok(_) => Ok(spec),
        Err(SceneError::Invalid(m)) => Err(serde::de::Error::custom(m)),
        Err(e) => Err(serde::de::Error::custom(format!("[pattern] {e}"))),
    }
}

/// `output_every` (≥ 1).
fn de_output_every<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    let v = usize::deserialize(d)?;
    if v == 0 {
        return Err(serde::de::Error::custom("`output_every` must be ≥ 1 step"));
    }
    Ok(Some(v))
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
    /// A constant friction slip force (N) instead of the Coulomb bound `μ λ`.
    pub friction_max_force: Option<f64>,
    /// Friction coefficient μ (Eq. 5; default 0.3).
    pub friction_coefficient: Option<f64>,
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

/// `[forces]`: which terms exist (all default to true except `loop_contact`).
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
    /// Crossing shear with jamming (weaves only).
    pub crossing_shear: bool,
    /// Contact between adjacent loops (knits only; default false,
    /// [`crate::forces::loop_contact`]).
    pub loop_contact: bool,
    /// Floor on the material length of segments (default true,
    /// [`crate::forces::segment_floor`]).
    pub segment_floor: bool,
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
            crossing_shear: f.crossing_shear,
            loop_contact: f.loop_contact,
            segment_floor: f.segment_floor,
        }
    }
}

/// `[[clamp]]`: a clamp set ([`ClampSet`]: a row boundary, a side or a column), pinned and
/// moved at a constant velocity.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClampSpec {
    /// `cast-on`, `bind-off`, `left` or `right` ([`ClampSet::from_edge`]; checked while
    /// parsing); exactly one of `edge` and `column`.
    #[serde(default, deserialize_with = "de_edge")]
    pub edge: Option<String>,
    /// A stitch column (knits) or warp (weaves), 0-based.
    pub column: Option<usize>,
    /// Velocity (m/s, finite); default zero.
    #[serde(default, deserialize_with = "de_velocity")]
    pub velocity: [f64; 3],
}

impl ClampSpec {
    /// The clamp set of the entry, or what is wrong with it.
    pub fn set(&self) -> Result<ClampSet, String> {
        match (&self.edge, self.column) {
            (Some(edge), None) => ClampSet::from_edge(edge)
                .ok_or_else(|| format!("[[clamp]] unknown edge \"{edge}\" ({CLAMP_EDGES})")),
            (None, Some(c)) => Ok(ClampSet::Column(c)),
            _ => Err("[[clamp]] needs exactly one of `edge` and `column`".into()),
        }
    }
}

/// The `edge` names of `[[clamp]]`.
const CLAMP_EDGES: &str = "cast-on, bind-off, left, right";

impl ClampSpec {
    /// The nodes the entry clamps on a swatch with node grid `grid`, or what is wrong.
    pub fn clamp_nodes(&self, grid: Grid) -> Result<Vec<usize>, String> {
        self.set()?
            .nodes(grid)
            .map_err(|e| format!("[[clamp]] {e}"))
    }
}

/// A clamp `edge` name ([`ClampSet::from_edge`]).
fn de_edge<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    let edge = String::deserialize(d)?;
    if ClampSet::from_edge(&edge).is_none() {
        return Err(serde::de::Error::custom(format!(
            "unknown clamp edge \"{edge}\" ({CLAMP_EDGES})"
        )));
    }
    Ok(Some(edge))
}

/// A clamp velocity: three finite numbers (m/s).
fn de_velocity<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v = <[f64; 3]>::deserialize(d)?;
    if !v.iter().all(|c| c.is_finite()) {
        return Err(serde::de::Error::custom(format!(
            "clamp `velocity` must be three finite numbers (m/s), found {v:?}"
        )));
    }
    Ok(v)
}

/// `[[obstacle]]`: a sphere (`centre`, `radius`) or a plane (`point`, `normal`) with an
/// optional `stiffness` (SI units), checked by [`Scene::parse`] (errors name the entry's
/// line).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// `sphere` or `plane`.
    pub kind: String,
    /// Sphere centre (m).
    pub centre: Option<[f64; 3]>,
    /// Sphere radius (m).
    pub radius: Option<f64>,
    /// A point of the plane (m).
    pub point: Option<[f64; 3]>,
    /// The plane's outward normal (any non-zero length).
    pub normal: Option<[f64; 3]>,
    /// Penalty stiffness (N/m); default `k_s/R` of the yarn.
    pub stiffness: Option<f64>,
}

impl ObstacleSpec {
    /// The validated obstacle, or what is wrong with the entry.
    pub fn obstacle(&self) -> Result<crate::forces::obstacle::Obstacle, String> {
        use crate::forces::obstacle::{Obstacle, Shape};
        let o = self;
        let stray = |keys: &[(&str, bool)]| -> Result<(), String> {
            match keys.iter().find(|(_, given)| *given) {
                Some((k, _)) => Err(format!(
                    "[[obstacle]] `{k}` does not apply to kind \"{}\"",
                    o.kind
                )),
                None => Ok(()),
            }
        };
        let need = |k: &str| format!("[[obstacle]] kind \"{}\" needs `{k}`", o.kind);
        let shape = match o.kind.as_str() {
            "sphere" => {
                stray(&[("point", o.point.is_some()), ("normal", o.normal.is_some())])?;
                Shape::Sphere {
                    center: V3::from(o.centre.ok_or_else(|| need("centre"))?),
                    radius: o.radius.ok_or_else(|| need("radius"))?,
                }
            }
            "plane" => {
                stray(&[
                    ("centre", o.centre.is_some()),
                    ("radius", o.radius.is_some()),
                ])?;
                Shape::Plane {
                    point: V3::from(o.point.ok_or_else(|| need("point"))?),
                    normal: V3::from(o.normal.ok_or_else(|| need("normal"))?),
                }
            }
            other => {
                return Err(format!(
                    "[[obstacle]] unknown kind \"{other}\" (sphere, plane)"
                ));
            }
        };
        Obstacle::new(shape, o.stiffness).map_err(|e| format!("[[obstacle]] {e}"))
    }
}

/// The keys of `[crossing_shear]` (see [`SceneCrossingShear`]).
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrossingShearSpec {
    /// Shear stiffness `k_x` (N).
    pub stiffness: Option<f64>,
    /// Jamming threshold γ_j (rad).
    pub jamming_angle: Option<f64>,
    /// Width of the jamming transition (rad).
    pub jamming_width: Option<f64>,
    /// Stiffness factor once jammed.
    pub jamming_factor: Option<f64>,
}

/// `[crossing_shear]`: overrides of [`crate::forces::crossing_shear::CrossingShearParams`]
/// (weaves), checked while parsing.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(try_from = "CrossingShearSpec")]
pub struct SceneCrossingShear(pub crate::forces::crossing_shear::CrossingShearParams);

impl TryFrom<CrossingShearSpec> for SceneCrossingShear {
    type Error = String;

    fn try_from(c: CrossingShearSpec) -> Result<Self, String> {
        let mut p = crate::forces::crossing_shear::CrossingShearParams::default();
        let set = |slot: &mut f64, v: Option<f64>| {
            if let Some(v) = v {
                *slot = v;
            }
        };
        set(&mut p.stiffness, c.stiffness);
        set(&mut p.jamming.angle, c.jamming_angle);
        set(&mut p.jamming.width, c.jamming_width);
        set(&mut p.jamming.factor, c.jamming_factor);
        p.validate().map_err(|e| format!("[crossing_shear] {e}"))?;
        Ok(SceneCrossingShear(p))
    }
}

/// A scene file (module documentation).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Time step (s).
    #[serde(default = "default_dt")]
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
}

impl Scene {
    /// Parses TOML `text`; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let scene = Self::parse_fields(text, path)?;
        let located = |span: std::ops::Range<usize>, message: String| {
            let (line, column) = line_column(text, span.start);
            SceneError::Parse {
                path: path.to_path_buf(),
                line,
                column,
                message,
            }
        };
        for o in &scene.obstacle {
            if let Err(message) = o.get_ref().obstacle() {
                return Err(located(o.span(), message));
            }
        }
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
            Fabric::Knit(chart) => Ok(chart),
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
        if self.frame_every() == 0 {
            return Err(SceneError::Invalid("output_every must be ≥ 1".into()));
        }
        let fabric = self.fabric()?;
        let (params, loop_width, alpha, beta) = self.yarn()?;
        let topology = fabric.topology()?;
        let layout = Layout::new(&topology, &LayoutParams::new(loop_width, params.radius))?;
        let f = &self.forces;
        let forces = ForceSet {
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
        };
        let settings = StepSettings {
            dt: self.dt,
            rayleigh_alpha: alpha,
            rayleigh_beta: beta,
            friction_return_mapping: self.friction_return_mapping,
            ..StepSettings::default()
        };
        let mut sim = Simulator::new(topology, &layout, params, forces, settings)?;
        let obstacles = self
            .obstacle
            .iter()
            .map(|o| o.get_ref().obstacle().map_err(SceneError::Invalid))
            .collect::<Result<Vec<_>, _>>()?;
        sim.add_obstacles(&obstacles)?;
        let mut clamps = Vec::new();
        let grid = Grid::from(&fabric);
        for c in &self.clamp {
            let c = c.get_ref();
            let nodes = c.clamp_nodes(grid).map_err(SceneError::Invalid)?;
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

/// The simulated yarn polylines of `sim` as OBJ text: `v` per node (m), `l` per yarn
/// ([`crate::output::nodes_obj_text`]).
pub fn obj_text(sim: &Simulator) -> String {
    crate::output::nodes_obj_text(sim)
}

/// Writes [`obj_text`] to `dir/frame_NNNNN.obj` and returns the path.
pub fn write_obj(sim: &Simulator, dir: &Path, frame: usize) -> Result<PathBuf, SceneError> {
    Ok(crate::output::write_nodes_obj(sim, dir, frame)?)
}
