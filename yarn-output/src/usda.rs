//! USD ASCII (`.usda`) yarn curves: one `BasisCurves` prim that Blender, Houdini and
//! Omniverse open directly.
//!
//! Written exactly as:
//! ```text
//! #usda 1.0
//! (
//!     defaultPrim = "Yarns"
//!     doc = "<comment>"
//!     metersPerUnit = 1
//!     upAxis = "Y"
//! )
//!
//! def BasisCurves "Yarns"
//! {
//!     uniform token type = "linear"
//!     uniform token wrap = "nonperiodic"
//!     int[] curveVertexCounts = [n₀, n₁, …]
//!     point3f[] points = [(x, y, z), …]
//!     float3[] extent = [(min), (max)]       (the points' bounds grown by R)
//!     float[] widths = [2R] (
//!         interpolation = "constant"
//!     )
//! }
//!
//! def Mesh "Mesh0"                      (one per mesh of UsdOptions::meshes, if any)
//! {
//!     int[] faceVertexCounts = [3, 3, …]
//!     int[] faceVertexIndices = [i, j, k, …]
//!     point3f[] points = [(x, y, z), …]
//!     float3[] extent = [(min), (max)]
//!     color3f[] primvars:displayColor = [(r, g, b)] (
//!         interpolation = "constant"
//!     )
//! }
//! ```
//! Points are in metres (`metersPerUnit = 1`). Every curve with at least two vertices is
//! written (linear curves need two); a closed curve with more than two vertices repeats its
//! first point, so one prim holds open and closed yarns alike. `widths` is the yarn
//! diameter. The doc string escapes `\` and `"`.
//!
//! [`Sequence`] writes a whole animation as one layer with time-sampled points and extents (a
//! USD *cache*), streamed frame by frame.

use std::io::Write;

use crate::error::{OutputError, Result};
use crate::polylines::{Polylines, UpAxis};
use crate::render::MeshLayer;

/// What the caller chooses for a `.usda` file.
#[derive(Clone, Copy, Debug)]
pub struct UsdOptions<'a> {
    /// Yarn radius R (m): the curves' constant width is `2R`.
    pub radius: f64,
    /// Up axis of the stage.
    pub up: UpAxis,
    /// The layer's doc string.
    pub comment: &'a str,
    /// Triangle meshes written beside the curves (obstacles, a body); usually none.
    pub meshes: &'a [MeshLayer<'a>],
}

/// Writes `lines` (and the meshes of `options`) as a `.usda` layer; fails when the radius is
/// not finite and positive or a mesh triangle indexes beyond its vertices.
pub fn write<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    options: &UsdOptions<'_>,
) -> Result<std::io::Result<()>> {
    if !(options.radius.is_finite() && options.radius > 0.0) {
        return Err(OutputError::Option {
            name: "radius",
            message: format!("expected a finite radius > 0 m, found {}", options.radius),
        });
    }
    for m in options.meshes {
        m.validate()?;
    }
    Ok(write_unchecked(w, lines, options))
}

fn write_unchecked<T: Copy + Into<f64>>(
    w: &mut dyn Write,
    lines: &Polylines<'_, T>,
    options: &UsdOptions<'_>,
) -> std::io::Result<()> {
    write_header(w, options.comment, options.up, None)?;
    let paths: Vec<Vec<usize>> = lines.edge_paths().map(|(_, p)| p).collect();
    let counts: Vec<String> = paths.iter().map(|p| p.len().to_string()).collect();
    writeln!(w, "    int[] curveVertexCounts = [{}]", counts.join(", "))?;
    write!(w, "    point3f[] points = [")?;
    for (i, k) in paths.iter().flatten().enumerate() {
        let [x, y, z] = lines.point(*k).map(|c| c as f32);
        let sep = if i == 0 { "" } else { ", " };
        write!(w, "{sep}({x}, {y}, {z})")?;
    }
    writeln!(w, "]")?;
    let [lo, hi] = extent(
        paths.iter().flatten().map(|&k| lines.point(k)),
        options.radius,
    );
    writeln!(w, "    float3[] extent = [{}]", extent_text(lo, hi))?;
    write_widths_and_close(w, options.radius)?;
    for (m, mesh) in options.meshes.iter().enumerate() {
        write_mesh_topology(w, m, mesh.triangles)?;
        write!(w, "    point3f[] points = [")?;
        for (i, p) in mesh.positions.iter().enumerate() {
            let [x, y, z] = p.map(|c| c as f32);
            let sep = if i == 0 { "" } else { ", " };
            write!(w, "{sep}({x}, {y}, {z})")?;
        }
        writeln!(w, "]")?;
        let [lo, hi] = extent(mesh.positions.iter().copied(), 0.0);
        writeln!(w, "    float3[] extent = [{}]", extent_text(lo, hi))?;
        write_mesh_colour(w, mesh.colour)?;
    }
    Ok(())
}

/// The `.usda` text of `lines` (see [`write()`]).
pub fn to_string<T: Copy + Into<f64>>(
    lines: &Polylines<'_, T>,
    options: &UsdOptions<'_>,
) -> Result<String> {
    let mut out = Vec::new();
    write(&mut out, lines, options)?.expect("writing to a Vec cannot fail");
    Ok(String::from_utf8(out).expect("USD text is UTF-8"))
}

/// Options of a [`Sequence`].
#[derive(Clone, Debug)]
pub struct SequenceOptions {
    /// Yarn radius R (m): the curves' constant width is `2R`.
    pub radius: f64,
    /// Up axis of the stage.
    pub up: UpAxis,
    /// The layer's doc string.
    pub comment: String,
    /// Time codes per second (> 0): frame `k` is time code `k`, so this is the frame rate in
    /// the simulated or animated time (`1 / (dt · every)` for a simulation writing every
    /// `every` steps of `dt`).
    pub frames_per_second: f64,
}

/// One time-sampled array attribute streamed to a side file: the entries `k: [...]` of its
/// `timeSamples` dictionary, in frame order, and the extent of each frame.
#[derive(Debug)]
struct Track {
    path: std::path::PathBuf,
    w: std::io::BufWriter<std::fs::File>,
    extents: Vec<[[f32; 3]; 2]>,
}

impl Track {
    fn create(path: std::path::PathBuf) -> Result<Self> {
        let file = std::fs::File::create(&path).map_err(|source| OutputError::Io {
            path: path.clone(),
            source,
        })?;
        Ok(Self {
            path,
            w: std::io::BufWriter::with_capacity(1 << 20, file),
            extents: Vec::new(),
        })
    }

    /// Appends frame `frame`'s points; the extent is their bounding box grown by `pad` (m).
    fn push(
        &mut self,
        frame: usize,
        points: impl Iterator<Item = [f64; 3]>,
        pad: f64,
    ) -> Result<()> {
        let io = |source| OutputError::Io {
            path: self.path.clone(),
            source,
        };
        let mut bounds = Bounds::default();
        write!(self.w, "        {frame}: [").map_err(io)?;
        for (i, p) in points.enumerate() {
            let [x, y, z] = p.map(|c| c as f32);
            let sep = if i == 0 { "" } else { ", " };
            write!(self.w, "{sep}({x}, {y}, {z})").map_err(io)?;
            bounds.add(p);
        }
        writeln!(self.w, "],").map_err(io)?;
        self.extents.push(bounds.extent(pad));
        Ok(())
    }

    /// Flushes the side file and copies it into `out` as `<indent><decl>.timeSamples = {…}`,
    /// followed by the extents as `float3[] extent.timeSamples`; removes the side file.
    fn finish_into(mut self, out: &mut dyn Write, decl: &str) -> std::io::Result<()> {
        self.w.flush()?;
        drop(self.w);
        writeln!(out, "    {decl}.timeSamples = {{")?;
        let mut side = std::fs::File::open(&self.path)?;
        std::io::copy(&mut side, out)?;
        writeln!(out, "    }}")?;
        writeln!(out, "    float3[] extent.timeSamples = {{")?;
        for (k, [lo, hi]) in self.extents.iter().enumerate() {
            writeln!(out, "        {k}: [{}],", extent_text(*lo, *hi))?;
        }
        writeln!(out, "    }}")?;
        std::fs::remove_file(&self.path)
    }
}

/// A mesh of a [`Sequence`]: its topology (fixed by the first frame) and its points' track.
#[derive(Debug)]
struct MeshTrack {
    triangles: Vec<[u32; 3]>,
    colour: [u8; 3],
    points: Track,
}

/// A USD ASCII *cache* of a whole sequence: one `.usda` layer whose yarn curves (and meshes)
/// carry `points` and `extent` as time samples, one per frame, so that Blender, Houdini, usdview
/// or Omniverse load the animation as one file.
///
/// Written as the single-frame layer of [`write()`] (prims `/Yarns`, `/Mesh0`, …), except:
/// ```text
/// #usda 1.0
/// (
///     defaultPrim = "Yarns"
///     doc = "<comment>"
///     endTimeCode = N − 1
///     framesPerSecond = fps
///     metersPerUnit = 1
///     startTimeCode = 0
///     timeCodesPerSecond = fps
///     upAxis = "Y"
/// )
/// def BasisCurves "Yarns"
/// {
///     …
///     int[] curveVertexCounts = [n₀, …]        (or curveVertexCounts.timeSamples when the
///                                               counts change between frames)
///     point3f[] points.timeSamples = { 0: [(x, y, z), …], 1: […], … }
///     float3[] extent.timeSamples = { 0: [(min), (max)], … }   (bounds grown by R)
///     float[] widths = [2R] ( interpolation = "constant" )
/// }
/// ```
/// Meshes keep the triangles of their first frame (a later frame with other triangles is an
/// error); their points are time-sampled. Frames are streamed: each time-sampled attribute
/// goes to a side file `<path>.<attr>.partial` as frames arrive, and [`Sequence::finish`]
/// assembles the layer (written to `<path>.partial`, then renamed onto `path`): the points
/// never accumulate in memory (only each frame's curve vertex counts and extents do), and an
/// interrupted run never leaves a truncated `path`.
#[derive(Debug)]
pub struct Sequence {
    path: std::path::PathBuf,
    options: SequenceOptions,
    points: Track,
    counts: Vec<Vec<usize>>,
    meshes: Option<Vec<MeshTrack>>,
}

impl Sequence {
    /// Starts a cache at `path`; fails when the radius or the frame rate is not finite and
    /// positive, or the side file cannot be created.
    pub fn create(path: &std::path::Path, options: SequenceOptions) -> Result<Self> {
        if !(options.radius.is_finite() && options.radius > 0.0) {
            return Err(OutputError::Option {
                name: "radius",
                message: format!("expected a finite radius > 0 m, found {}", options.radius),
            });
        }
        if !(options.frames_per_second.is_finite() && options.frames_per_second > 0.0) {
            return Err(OutputError::Option {
                name: "frames_per_second",
                message: format!(
                    "expected a finite frame rate > 0, found {}",
                    options.frames_per_second
                ),
            });
        }
        Ok(Self {
            points: Track::create(side_path(path, "points"))?,
            path: path.to_path_buf(),
            options,
            counts: Vec::new(),
            meshes: None,
        })
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> usize {
        self.counts.len()
    }

    /// Appends the next frame: the yarns `lines` and the meshes `meshes` (the same number of
    /// meshes, with the same triangles, in every frame).
    pub fn push<T: Copy + Into<f64>>(
        &mut self,
        lines: &Polylines<'_, T>,
        meshes: &[MeshLayer<'_>],
    ) -> Result<()> {
        lines.validate()?;
        for m in meshes {
            m.validate()?;
        }
        let frame = self.frames();
        match &self.meshes {
            None => {
                let mut tracks = Vec::with_capacity(meshes.len());
                for (k, m) in meshes.iter().enumerate() {
                    tracks.push(MeshTrack {
                        triangles: m.triangles.to_vec(),
                        colour: m.colour,
                        points: Track::create(side_path(&self.path, &format!("mesh{k}")))?,
                    });
                }
                self.meshes = Some(tracks);
            }
            Some(tracks) => {
                if tracks.len() != meshes.len() {
                    return Err(OutputError::Invalid(format!(
                        "{}: frame {frame} has {} meshes, frame 0 had {}; a USD cache keeps one \
                         set of meshes",
                        self.path.display(),
                        meshes.len(),
                        tracks.len()
                    )));
                }
                for (k, (t, m)) in tracks.iter().zip(meshes).enumerate() {
                    if t.triangles != m.triangles {
                        return Err(OutputError::Invalid(format!(
                            "{}: mesh {k} of frame {frame} has other triangles than in frame 0 \
                             ({} vs {}); a USD cache keeps one mesh topology",
                            self.path.display(),
                            m.triangles.len(),
                            t.triangles.len()
                        )));
                    }
                }
            }
        }
        let paths: Vec<Vec<usize>> = lines.edge_paths().map(|(_, p)| p).collect();
        self.points.push(
            frame,
            paths.iter().flatten().map(|&k| lines.point(k)),
            self.options.radius,
        )?;
        for (t, m) in self.meshes.iter_mut().flatten().zip(meshes) {
            t.points.push(frame, m.positions.iter().copied(), 0.0)?;
        }
        self.counts.push(paths.iter().map(Vec::len).collect());
        Ok(())
    }

    /// Writes the layer at the path given to [`Sequence::create`] and returns it; fails when
    /// no frame was pushed.
    pub fn finish(self) -> Result<std::path::PathBuf> {
        if self.counts.is_empty() {
            return Err(OutputError::Invalid(format!(
                "{}: a USD cache needs at least one frame",
                self.path.display()
            )));
        }
        let partial = side_path(&self.path, "");
        let io = |source| OutputError::Io {
            path: partial.clone(),
            source,
        };
        let file = std::fs::File::create(&partial).map_err(io)?;
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
        let path = self.path.clone();
        self.write_layer(&mut w)
            .and_then(|()| w.flush())
            .map_err(io)?;
        drop(w);
        std::fs::rename(&partial, &path).map_err(|source| OutputError::Io {
            path: path.clone(),
            source,
        })?;
        Ok(path)
    }

    fn write_layer(self, w: &mut dyn Write) -> std::io::Result<()> {
        let o = &self.options;
        let frames = (self.counts.len(), o.frames_per_second);
        write_header(w, &o.comment, o.up, Some(frames))?;
        let list = |c: &[usize]| {
            c.iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        };
        if self.counts.iter().all(|c| *c == self.counts[0]) {
            writeln!(
                w,
                "    int[] curveVertexCounts = [{}]",
                list(&self.counts[0])
            )?;
        } else {
            writeln!(w, "    int[] curveVertexCounts.timeSamples = {{")?;
            for (k, c) in self.counts.iter().enumerate() {
                writeln!(w, "        {k}: [{}],", list(c))?;
            }
            writeln!(w, "    }}")?;
        }
        let radius = o.radius;
        self.points.finish_into(w, "point3f[] points")?;
        write_widths_and_close(w, radius)?;
        for (m, mesh) in self.meshes.into_iter().flatten().enumerate() {
            write_mesh_topology(w, m, &mesh.triangles)?;
            mesh.points.finish_into(w, "point3f[] points")?;
            write_mesh_colour(w, mesh.colour)?;
        }
        Ok(())
    }
}

/// `<path>.<attr>.partial` (or `<path>.partial` for an empty `attr`).
fn side_path(path: &std::path::Path, attr: &str) -> std::path::PathBuf {
    let mut name = path.as_os_str().to_owned();
    if !attr.is_empty() {
        name.push(format!(".{attr}"));
    }
    name.push(".partial");
    name.into()
}

/// A running bounding box of finite points (m).
#[derive(Clone, Copy, Debug)]
struct Bounds {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Default for Bounds {
    fn default() -> Self {
        Self {
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
        }
    }
}

impl Bounds {
    fn add(&mut self, p: [f64; 3]) {
        if p.iter().all(|c| c.is_finite()) {
            for k in 0..3 {
                self.lo[k] = self.lo[k].min(p[k]);
                self.hi[k] = self.hi[k].max(p[k]);
            }
        }
    }

    /// `[min, max]` (f32) grown by `pad` on every side; `[0, 0]` without points (USD's
    /// `extent` of an empty prim).
    fn extent(&self, pad: f64) -> [[f32; 3]; 2] {
        if self.lo[0] > self.hi[0] {
            return [[0.0; 3]; 2];
        }
        [
            self.lo.map(|c| (c - pad) as f32),
            self.hi.map(|c| (c + pad) as f32),
        ]
    }
}

/// The extent of `points` grown by `pad` (see [`Bounds::extent`]).
fn extent(points: impl Iterator<Item = [f64; 3]>, pad: f64) -> [[f32; 3]; 2] {
    let mut b = Bounds::default();
    points.for_each(|p| b.add(p));
    b.extent(pad)
}

/// `(x, y, z), (x, y, z)` of an extent.
fn extent_text(lo: [f32; 3], hi: [f32; 3]) -> String {
    format!(
        "({}, {}, {}), ({}, {}, {})",
        lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
    )
}

/// The layer metadata and the opening of the `/Yarns` prim: `frames = Some((n, fps))` adds the
/// time range `0 … n − 1` and the rate of a [`Sequence`].
fn write_header(
    w: &mut dyn Write,
    comment: &str,
    up: UpAxis,
    frames: Option<(usize, f64)>,
) -> std::io::Result<()> {
    let doc = comment.replace('\\', "\\\\").replace('"', "\\\"");
    let up = match up {
        UpAxis::Y => "Y",
        UpAxis::Z => "Z",
    };
    writeln!(
        w,
        "#usda 1.0\n(\n    defaultPrim = \"Yarns\"\n    doc = \"{doc}\""
    )?;
    if let Some((n, fps)) = frames {
        writeln!(
            w,
            "    endTimeCode = {}\n    framesPerSecond = {fps}",
            n - 1
        )?;
    }
    writeln!(w, "    metersPerUnit = 1")?;
    if let Some((_, fps)) = frames {
        writeln!(w, "    startTimeCode = 0\n    timeCodesPerSecond = {fps}")?;
    }
    writeln!(w, "    upAxis = \"{up}\"\n)\n")?;
    writeln!(w, "def BasisCurves \"Yarns\"\n{{")?;
    writeln!(w, "    uniform token type = \"linear\"")?;
    writeln!(w, "    uniform token wrap = \"nonperiodic\"")
}

/// The curves' constant width `2R`, and the end of the `/Yarns` prim.
fn write_widths_and_close(w: &mut dyn Write, radius: f64) -> std::io::Result<()> {
    let width = (2.0 * radius) as f32;
    writeln!(
        w,
        "    float[] widths = [{width}] (\n        interpolation = \"constant\"\n    )\n}}"
    )
}

/// Opens `def Mesh "Mesh<m>"` and writes its triangles.
fn write_mesh_topology(w: &mut dyn Write, m: usize, triangles: &[[u32; 3]]) -> std::io::Result<()> {
    writeln!(w, "\ndef Mesh \"Mesh{m}\"\n{{")?;
    let counts = vec!["3"; triangles.len()].join(", ");
    writeln!(w, "    int[] faceVertexCounts = [{counts}]")?;
    let indices: Vec<String> = triangles.iter().flatten().map(u32::to_string).collect();
    writeln!(w, "    int[] faceVertexIndices = [{}]", indices.join(", "))
}

/// Writes a mesh's constant display colour and closes its prim.
fn write_mesh_colour(w: &mut dyn Write, colour: [u8; 3]) -> std::io::Result<()> {
    let [r, g, b] = colour.map(|c| f32::from(c) / 255.0);
    writeln!(
        w,
        "    color3f[] primvars:displayColor = [({r}, {g}, {b})] (\n        interpolation = \"constant\"\n    )\n}}"
    )
}

/// The checker of [`check_with_usd`] (Python, Pixar's `pxr` module).
const USD_CHECK: &str = include_str!("usd_cache_check.py");

/// Whether `python3` can import Pixar's USD library (`pip install usd-core`).
pub fn usd_available() -> bool {
    std::process::Command::new("python3")
        .args(["-c", "import pxr"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// [`check_with_usd`] where Pixar's USD library is available: `Ok(None)` without it, unless the
/// environment sets `WORKBENCH_REQUIRE_USD` (as CI does, with usd-core installed), which makes
/// a missing library an error instead. For the tests of every writer of caches.
pub fn check_with_usd_if_available(
    path: &std::path::Path,
    frames: usize,
    meshes: usize,
) -> Result<Option<String>> {
    if usd_available() {
        return check_with_usd(path, frames, meshes).map(Some);
    }
    if std::env::var_os("WORKBENCH_REQUIRE_USD").is_some() {
        return Err(OutputError::Invalid(
            "WORKBENCH_REQUIRE_USD is set but python3 cannot import pxr (pip install usd-core)"
                .into(),
        ));
    }
    Ok(None)
}

/// Opens the cache `path` with Pixar's USD library, as a user's tool would load it, and checks
/// it: `/Yarns` a linear `BasisCurves` with one constant width, frame range `0 … frames − 1`
/// at a positive rate, metres, Y or Z up, one points sample per frame as long as the frame's
/// curve vertex counts add up to, authored extents that hold the points and match USD's own
/// computed extents, and exactly `meshes` meshes with one points sample per frame. Runs
/// `python3` with the `usd-core` package ([`usd_available`]); returns the checker's report, one
/// line per frame, or an error with its message.
pub fn check_with_usd(path: &std::path::Path, frames: usize, meshes: usize) -> Result<String> {
    let out = std::process::Command::new("python3")
        .args(["-c", USD_CHECK])
        .arg(path)
        .args([frames.to_string(), meshes.to_string()])
        .output()
        .map_err(|source| OutputError::Io {
            path: "python3".into(),
            source,
        })?;
    if out.status.success() {
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    } else {
        Err(OutputError::Invalid(format!(
            "{}: USD rejects the cache: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )))
    }
}
