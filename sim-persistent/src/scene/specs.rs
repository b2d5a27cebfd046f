//! The tables of a scene file (`[pattern]`, `[yarn]`, `[damping]`, `[forces]`,
//! `[[clamp]]`, `[[obstacle]]`, `[crossing_shear]`) and their checks.

use super::SceneError;
use crate::chart::Chart;
use crate::experiment::clamps::{ClampSet, Grid};
use crate::forces::ForceSet;
use crate::topology::{Construction, Fabric};
use crate::weave::WeavePattern;
use rod::geometry::V3;
use serde::Deserialize;

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
    /// How a knit is knitted ([`Construction::name`]): `flat-per-row` (default: one yarn per
    /// row), `flat` (one continuous yarn turning at the row ends) or `round` (a tube).
    pub construction: Option<String>,
    /// Warp yarns (with a weave builder, ≥ 2).
    pub warps: Option<usize>,
    /// Weft yarns (with a weave builder, ≥ 2).
    pub wefts: Option<usize>,
    /// `[over, under]` of a twill (builder `twill`; default `[2, 1]`).
    pub twill: Option<[usize; 2]>,
    /// `[harness, step]` of a satin (builder `satin`; default `[5, 2]`).
    pub satin: Option<[usize; 2]>,
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
        let construction = match &self.construction {
            None => Construction::default(),
            Some(name) => Construction::from_name(name).ok_or_else(|| {
                bad(format!(
                    "construction \"{name}\" is not one of \"flat-per-row\", \"flat\", \"round\""
                ))
            })?,
        };
        match (&self.builder, &self.chart) {
            (Some(_), Some(_)) | (None, None) => {
                Err(bad("needs exactly one of `builder` and `chart`".into()))
            }
            (None, Some(text)) => {
                reject(&knit_size, "a chart (it sets the size itself)")?;
                reject(&weave_size, "a chart (it sets the size itself)")?;
                Ok(Fabric::Knit(Chart::parse(text)?, construction))
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
                    let chart = match builder.as_str() {
                        "stockinette" => Chart::stockinette(w, h)?,
                        "garter" => Chart::garter(w, h)?,
                        "seed" => Chart::seed(w, h)?,
                        _ => {
                            let [k, pu] = self.rib.unwrap_or([2, 2]);
                            Chart::rib(w, h, k, pu)?
                        }
                    };
                    Ok(Fabric::Knit(chart, construction))
                }
                "plain" | "twill" | "satin" => {
                    reject(&knit_size, &format!("weave builder \"{builder}\""))?;
                    if self.construction.is_some() {
                        return Err(bad(format!(
                            "`construction` applies to knits, not weave builder \"{builder}\""
                        )));
                    }
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
                    fabric.topology().map_err(super::pattern_error)?;
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
pub(super) fn de_pattern<'de, D: serde::Deserializer<'de>>(d: D) -> Result<PatternSpec, D::Error> {
    let spec = PatternSpec::deserialize(d)?;
    match spec.fabric() {
        Ok(_) => Ok(spec),
        Err(SceneError::Invalid(m)) => Err(serde::de::Error::custom(m)),
        Err(e) => Err(serde::de::Error::custom(format!("[pattern] {e}"))),
    }
}

/// A finite number `> 0` (a size, a modulus, a time step): refused at the value otherwise, so
/// that the error names its line.
pub(super) fn de_positive<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(serde::de::Error::custom(format!(
            "expected a finite number > 0, found {v}"
        )))
    }
}

/// [`de_positive`] for an optional key.
fn de_opt_positive<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    de_positive(d).map(Some)
}

/// A finite number `≥ 0` for an optional key (a damping or friction coefficient).
fn de_opt_non_negative<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v >= 0.0 {
        Ok(Some(v))
    } else {
        Err(serde::de::Error::custom(format!(
            "expected a finite number ≥ 0, found {v}"
        )))
    }
}

/// `[yarn]`: a Table 1 preset with optional overrides (SI units).
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct YarnSpec {
    /// `sweater` (default), `shirt` or `pullover`.
    pub preset: Option<String>,
    /// Yarn radius (m).
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub radius: Option<f64>,
    /// Young modulus (Pa).
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub young_modulus: Option<f64>,
    /// Bending modulus B of Table 1.
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub bending_modulus: Option<f64>,
    /// Linear density (kg/m).
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub linear_density: Option<f64>,
    /// Wrapping stiffness `k_w` (N).
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub wrapping_stiffness: Option<f64>,
    /// Where the stitch-wrapping rest angles come from ([`crate::params::WrappingRest`]):
    /// `"layout"` (default: the layout's angles turned by `wrapping_bias`) or `"paper"`
    /// (the paper's fixed quarter turn ψ₀ = ±π/2, ramped in from the layout).
    #[serde(default, deserialize_with = "de_wrapping_rest")]
    pub wrapping_rest: Option<String>,
    /// The wrapping bias β of `wrapping_rest = "layout"` (rad, in `[0, π)`; default
    /// [`crate::params::DEFAULT_WRAP_BIAS`]).
    #[serde(default, deserialize_with = "de_opt_non_negative")]
    pub wrapping_bias: Option<f64>,
    /// A constant friction slip force (N) instead of the Coulomb bound `μ λ`.
    #[serde(default, deserialize_with = "de_opt_non_negative")]
    pub friction_max_force: Option<f64>,
    /// Friction coefficient μ (Eq. 5; default 0.3).
    #[serde(default, deserialize_with = "de_opt_non_negative")]
    pub friction_coefficient: Option<f64>,
    /// Loop width of the layout (m; default the preset's Table 1 value).
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub loop_width: Option<f64>,
    /// Row height of a knit's layout (m; default the loop width).
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub row_height: Option<f64>,
    /// Yarn per loop of a knit's layout (m; the stitch length): the layout's out-of-plane
    /// offset is solved for it ([`crate::layout::LayoutParams::with_loop_length`]). Default:
    /// none, the offset is a quarter of the radius.
    #[serde(default, deserialize_with = "de_opt_positive")]
    pub loop_length: Option<f64>,
    /// A knit's gauge in knitters' units (`gauge = { stitches = 18, rows = 34,
    /// stitch_length_mm = 14.0 }`): it sets the loop width, row height and yarn per loop
    /// together ([`crate::layout::LayoutParams::at_gauge`]), so it excludes `loop_width`,
    /// `row_height` and `loop_length`.
    pub gauge: Option<KnitGaugeSpec>,
    /// Gravity (m/s²).
    pub gravity: Option<[f64; 3]>,
}

/// `[yarn] gauge`: a knit's gauge as knitters measure it on a relaxed swatch.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KnitGaugeSpec {
    /// Stitches (loops of a row) per 10 cm of width.
    pub stitches: f64,
    /// Rows per 10 cm of height.
    pub rows: f64,
    /// Yarn per stitch (mm): the stitch length.
    pub stitch_length_mm: f64,
}

/// `[damping]`: Rayleigh coefficients.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DampingSpec {
    /// Mass damping α (1/s).
    #[serde(default, deserialize_with = "de_opt_non_negative")]
    pub alpha: Option<f64>,
    /// Stiffness damping β (s).
    #[serde(default, deserialize_with = "de_opt_non_negative")]
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
    /// Yarn self-contact (default true, [`crate::forces::yarn_contact`]).
    pub yarn_contact: bool,
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
            yarn_contact: f.yarn_contact,
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

/// `[yarn] wrapping_rest`: `"layout"` or `"paper"`.
fn de_wrapping_rest<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    let rest = String::deserialize(d)?;
    if !matches!(rest.as_str(), "layout" | "paper") {
        return Err(serde::de::Error::custom(format!(
            "unknown wrapping rest \"{rest}\" (\"layout\" or \"paper\")"
        )));
    }
    Ok(Some(rest))
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

/// `[[obstacle]]`: a sphere (`centre`, `radius`), a plane (`point`, `normal`) or a triangle
/// mesh (`file`, optionally `scale`, `offset`, `reach`, and `fps` for an OBJ sequence) with an
/// optional `stiffness` (SI units), checked by [`super::Scene::parse`] (errors name the entry's
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
    /// A mesh's OBJ file, relative to the scene file; a `*` in the file name makes it a
    /// numbered sequence (an animation, needs `fps`).
    pub file: Option<String>,
    /// Frames per second of a mesh sequence.
    pub fps: Option<f64>,
    /// Factor from the mesh file's units to metres (default 1).
    pub scale: Option<f64>,
    /// Translation (m) of the scaled mesh (default zero).
    pub offset: Option<[f64; 3]>,
    /// How far from a mesh's surface (m) yarn points are searched (default
    /// [`crate::forces::obstacle::mesh::DEFAULT_REACH`]).
    pub reach: Option<f64>,
    /// Penalty stiffness (N/m); default `k_s/R` of the yarn.
    pub stiffness: Option<f64>,
    /// Sticking contact (default false): a node touching the obstacle at the end of a step
    /// is pinned where it is from then on ([`crate::experiment::sphere_drop::StickyContacts`],
    /// the stand-in for the obstacle's friction of the patterns-on-sphere figure).
    #[serde(default)]
    pub sticky: bool,
}

impl ObstacleSpec {
    /// The validated obstacle, or what is wrong with the entry; a mesh file is read relative
    /// to `base` (the scene file's directory).
    pub fn obstacle(
        &self,
        base: &std::path::Path,
    ) -> Result<crate::forces::obstacle::Obstacle, String> {
        use crate::forces::obstacle::mesh::{DEFAULT_REACH, MeshAnimation, TriangleMesh};
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
        let mesh_keys = [
            ("file", o.file.is_some()),
            ("fps", o.fps.is_some()),
            ("scale", o.scale.is_some()),
            ("offset", o.offset.is_some()),
            ("reach", o.reach.is_some()),
        ];
        let shape = match o.kind.as_str() {
            "sphere" => {
                stray(&mesh_keys)?;
                stray(&[("point", o.point.is_some()), ("normal", o.normal.is_some())])?;
                Shape::Sphere {
                    center: V3::from(o.centre.ok_or_else(|| need("centre"))?),
                    radius: o.radius.ok_or_else(|| need("radius"))?,
                }
            }
            "plane" => {
                stray(&mesh_keys)?;
                stray(&[
                    ("centre", o.centre.is_some()),
                    ("radius", o.radius.is_some()),
                ])?;
                Shape::Plane {
                    point: V3::from(o.point.ok_or_else(|| need("point"))?),
                    normal: V3::from(o.normal.ok_or_else(|| need("normal"))?),
                }
            }
            "mesh" => {
                stray(&[
                    ("centre", o.centre.is_some()),
                    ("radius", o.radius.is_some()),
                    ("point", o.point.is_some()),
                    ("normal", o.normal.is_some()),
                ])?;
                let file = o.file.as_ref().ok_or_else(|| need("file"))?;
                let scale = o.scale.unwrap_or(1.0);
                if !(scale.is_finite() && scale > 0.0) {
                    return Err(format!("[[obstacle]] `scale` must be > 0, got {scale}"));
                }
                let offset = V3::from(o.offset.unwrap_or([0.0; 3]));
                if !offset.iter().all(|c| c.is_finite()) {
                    return Err("[[obstacle]] `offset` must be finite".into());
                }
                let reach = o.reach.unwrap_or(DEFAULT_REACH);
                let path = base.join(file);
                let shown = path.display().to_string();
                if file.contains('*') {
                    let fps = o.fps.ok_or_else(|| {
                        "[[obstacle]] a mesh sequence (`*` in `file`) needs `fps`".to_string()
                    })?;
                    Shape::animated_mesh(
                        MeshAnimation::read_obj_sequence(&shown, fps, scale, offset, reach)
                            .map_err(|e| format!("[[obstacle]] {e}"))?,
                    )
                } else {
                    if o.fps.is_some() {
                        return Err(
                            "[[obstacle]] `fps` applies to mesh sequences only (`*` in `file`)"
                                .into(),
                        );
                    }
                    Shape::mesh(
                        TriangleMesh::read_obj(&path, scale, offset, reach)
                            .map_err(|e| format!("[[obstacle]] {e}"))?,
                    )
                }
            }
            other => {
                return Err(format!(
                    "[[obstacle]] unknown kind \"{other}\" (sphere, plane, mesh)"
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
