//! The `[output]` table of a scene and the [`FrameWriter`] that writes its frames.

use super::curves::{BccCurve, CurveOptions, MAX_SAMPLES_PER_SEGMENT, RenderCurves};
use super::{OutputError, nodes_obj_text, write_file};
use crate::integrator::Simulator;
use serde::{Deserialize, Deserializer};
use std::path::{Path, PathBuf};
use yarn_output::UpAxis;
use yarn_output::render::{Camera, Framing, RenderOptions};
use yarn_output::usda::{Sequence, SequenceOptions};

/// An output file format of `[output] formats`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Rendering curves as OBJ polylines (`frame_NNNNN.obj`).
    Obj,
    /// Rendering curves as ASCII PLY (`frame_NNNNN.ply`).
    Ply,
    /// Rendering curves as `.bcc` (`frame_NNNNN.bcc`).
    Bcc,
    /// Rendering curves as USD ASCII `BasisCurves` (`frame_NNNNN.usda`).
    Usda,
    /// Tube rendering as PNG (`frame_NNNNN.png`).
    Png,
    /// The simulated node polylines as OBJ (`frame_NNNNN.nodes.obj`).
    Nodes,
    /// One USD cache of the whole run (`yarns.usda`): the rendering curves and the
    /// obstacles with time-sampled points and extents, one time code per frame
    /// ([`yarn_output::usda::Sequence`]), written when the run finishes.
    #[serde(rename = "usd_cache")]
    UsdCache,
}

impl Format {
    /// The file name of frame `frame` in this format (the one cache file for
    /// [`Format::UsdCache`]).
    pub fn file_name(self, frame: usize) -> String {
        let ext = match self {
            Format::UsdCache => return CACHE_FILE.to_string(),
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Bcc => "bcc",
            Format::Usda => "usda",
            Format::Png => "png",
            Format::Nodes => "nodes.obj",
        };
        format!("frame_{frame:05}.{ext}")
    }
}

/// The file name of the run's USD cache ([`Format::UsdCache`]).
pub const CACHE_FILE: &str = "yarns.usda";

/// A PNG camera preset of `[output] view`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum View {
    /// From `+z` (the fabric front in the layout), y up.
    #[default]
    Front,
    /// From `−z` (the fabric back), y up.
    Back,
    /// From `+x` (the swatch edge-on), y up.
    Side,
    /// From the front, above and to the right, y up.
    Oblique,
}

impl View {
    /// The orthographic camera of the preset.
    pub fn camera(self) -> Camera {
        let direction = match self {
            View::Front => [0.0, 0.0, -1.0],
            View::Back => [0.0, 0.0, 1.0],
            View::Side => [-1.0, 0.0, 0.0],
            View::Oblique => [-0.5, -0.6, -1.0],
        };
        Camera {
            direction,
            up: [0.0, 1.0, 0.0],
        }
    }
}

/// The `[output]` section of a scene (see [`crate::scene`]); every value is checked while
/// parsing, so a bad one is reported at its line (the renderer's total pixel budget, image
/// size × supersampling², is checked when the first image is rendered).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Formats written per frame (non-empty, no repeats; default `["obj"]`).
    #[serde(deserialize_with = "de_formats")]
    pub formats: Vec<Format>,
    /// Write a frame every `every` steps (≥ 1); `None`: the scene's `output_every` or 10.
    #[serde(deserialize_with = "de_every")]
    pub every: Option<usize>,
    /// Spline samples per segment (1 … [`MAX_SAMPLES_PER_SEGMENT`], default 8).
    #[serde(deserialize_with = "de_samples")]
    pub samples: usize,
    /// Points written to `.bcc` files (`"C0"` control points, default; `"PL"` samples).
    pub bcc: BccCurve,
    /// PNG width and height (pixels, each 1 … 8192; default 800 × 600).
    #[serde(deserialize_with = "de_png_size")]
    pub png_size: [u32; 2],
    /// PNG camera preset (default `"front"`).
    pub view: View,
    /// PNG supersampling per axis (1 … 8, default 2).
    #[serde(deserialize_with = "de_supersample")]
    pub supersample: u32,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            formats: vec![Format::Obj],
            every: None,
            samples: 8,
            bcc: BccCurve::C0,
            png_size: [800, 600],
            view: View::Front,
            supersample: 2,
        }
    }
}

fn de_formats<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Format>, D::Error> {
    let v = Vec::<Format>::deserialize(d)?;
    if v.is_empty() {
        return Err(serde::de::Error::custom(
            "`formats` needs at least one of \"obj\", \"ply\", \"bcc\", \"usda\", \"usd_cache\", \"png\", \"nodes\"",
        ));
    }
    for (i, f) in v.iter().enumerate() {
        if v[..i].contains(f) {
            return Err(serde::de::Error::custom(format!(
                "format {f:?} is listed twice"
            )));
        }
    }
    Ok(v)
}

fn de_every<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    let v = usize::deserialize(d)?;
    if v == 0 {
        return Err(serde::de::Error::custom("`every` must be ≥ 1 step"));
    }
    Ok(Some(v))
}

fn de_samples<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if !(1..=MAX_SAMPLES_PER_SEGMENT).contains(&v) {
        return Err(serde::de::Error::custom(format!(
            "`samples` must be 1 … {MAX_SAMPLES_PER_SEGMENT} per segment, found {v}"
        )));
    }
    Ok(v)
}

fn de_png_size<'de, D: Deserializer<'de>>(d: D) -> Result<[u32; 2], D::Error> {
    let v = <[u32; 2]>::deserialize(d)?;
    if !v.iter().all(|s| (1..=8192).contains(s)) {
        return Err(serde::de::Error::custom(format!(
            "`png_size` must be [width, height] with each 1 … 8192 pixels, found {v:?}"
        )));
    }
    Ok(v)
}

fn de_supersample<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    let v = u32::deserialize(d)?;
    if !(1..=8).contains(&v) {
        return Err(serde::de::Error::custom(format!(
            "`supersample` must be 1 … 8, found {v}"
        )));
    }
    Ok(v)
}

/// Writes the frames of a run in the formats of an [`OutputSpec`]: `dir/frame_NNNNN.<ext>`,
/// frames numbered from 0, and the run's USD cache `dir/yarns.usda` when
/// [`FrameWriter::finish`] is called. PNG frames share the framing of the first one
/// (auto-fitted with a 10 % margin), so an animation keeps one scale.
#[derive(Debug)]
pub struct FrameWriter {
    dir: PathBuf,
    spec: OutputSpec,
    curve: CurveOptions,
    framing: Option<Framing>,
    cache: Option<Sequence>,
    next: usize,
}

impl FrameWriter {
    /// A writer into `dir` (which must exist) for yarns of radius `radius` (m), with
    /// `frame_interval` seconds of simulated time between frames (the USD cache's frame rate
    /// is its inverse).
    pub fn new(
        dir: &Path,
        spec: &OutputSpec,
        radius: f64,
        frame_interval: f64,
    ) -> Result<Self, OutputError> {
        let curve = CurveOptions {
            radius,
            samples_per_segment: spec.samples,
        };
        curve.validate()?;
        let cache = if spec.formats.contains(&Format::UsdCache) {
            let options = SequenceOptions {
                radius,
                up: UpAxis::Y,
                comment: super::COMMENT.to_string(),
                frames_per_second: 1.0 / frame_interval,
            };
            Some(Sequence::create(&dir.join(CACHE_FILE), options)?)
        } else {
            None
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            spec: spec.clone(),
            curve,
            framing: None,
            cache,
            next: 0,
        })
    }

    /// Writes the USD cache of the frames so far (if `[output] formats` asks for one) and
    /// returns its path.
    pub fn finish(self) -> Result<Option<PathBuf>, OutputError> {
        Ok(self.cache.map(Sequence::finish).transpose()?)
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.next
    }

    /// The framing the PNG frames share (set by the first PNG frame drawn).
    pub fn framing(&self) -> Option<Framing> {
        self.framing
    }

    /// Continues a run resumed from a checkpoint: the next frame is number `frames`, PNG
    /// frames keep `framing`. Refused with a USD cache, which streams every frame of the
    /// run into one file that a checkpoint does not hold.
    pub fn resume_at(
        &mut self,
        frames: usize,
        framing: Option<Framing>,
    ) -> Result<(), OutputError> {
        if self.cache.is_some() {
            return Err(OutputError::Invalid(
                "a run writing a USD cache (formats = [\"usd_cache\"]) cannot be resumed: \
                 the cache holds every frame of the run; rerun it from the start"
                    .into(),
            ));
        }
        self.next = frames;
        self.framing = framing;
        Ok(())
    }

    /// Writes the next frame of `sim` in every format; returns the files written.
    pub fn write(&mut self, sim: &Simulator) -> Result<Vec<PathBuf>, OutputError> {
        let frame = self.next;
        let needs_curves = self.spec.formats.iter().any(|f| *f != Format::Nodes);
        let curves = if needs_curves {
            Some(RenderCurves::from_simulator(sim, &self.curve)?)
        } else {
            None
        };
        let obstacles = super::ObstacleMeshes::of(sim);
        let layers = obstacles.layers();
        let mut paths = Vec::with_capacity(self.spec.formats.len());
        for &format in &self.spec.formats {
            let path = self.dir.join(format.file_name(frame));
            match (format, &curves) {
                (Format::Nodes, _) => write_file(&path, nodes_obj_text(sim).as_bytes())?,
                (Format::UsdCache, Some(c)) => {
                    let cache = self.cache.as_mut().expect("created with the format");
                    cache.push(&c.polylines(true)?.view(), &layers)?;
                    continue;
                }
                (Format::Obj, Some(c)) => write_file(&path, c.obj_text()?.as_bytes())?,
                (Format::Ply, Some(c)) => write_file(&path, c.ply_text()?.as_bytes())?,
                (Format::Bcc, Some(c)) => write_file(&path, &c.bcc_bytes(self.spec.bcc)?)?,
                (Format::Usda, Some(c)) => write_file(
                    &path,
                    c.usda_text_with(self.curve.radius, &layers)?.as_bytes(),
                )?,
                (Format::Png, Some(c)) => {
                    let mut options = RenderOptions::new(
                        self.spec.png_size[0],
                        self.spec.png_size[1],
                        self.curve.radius,
                    );
                    options.camera = self.spec.view.camera();
                    options.supersample = self.spec.supersample;
                    options.framing = self.framing.unwrap_or(Framing::Auto { margin: 0.1 });
                    let r = c.render_with(&options, &layers, &path)?;
                    if r.segments > 0 {
                        self.framing.get_or_insert(r.framing);
                    }
                    write_file(&path, &r.image.to_png()?)?;
                }
                (_, None) => {
                    return Err(OutputError::Invalid("rendering curves missing".into()));
                }
            }
            paths.push(path);
        }
        self.next += 1;
        Ok(paths)
    }
}
