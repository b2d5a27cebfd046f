//! A small software renderer of yarn polylines as shaded tubes, and a minimal PNG encoder, for
//! figures and the `--png` / PNG frame output of the command-line tools.
//!
//! Every segment of every curve is a capsule of radius R (a cylinder with hemispherical caps,
//! so consecutive segments join smoothly; a one-vertex curve is a sphere). Under the
//! orthographic camera ([`Camera`]) each pixel is a ray along the view direction; the ray is
//! intersected exactly with the capsules whose screen-space bounding box contains the pixel,
//! and a per-pixel depth buffer keeps the nearest hit (so the result does not depend on the
//! drawing order). The shading normal is `(p − q) / R`, with `p` the hit point and `q` the
//! closest point of the segment's centreline to it; the colour is the curve's palette colour
//! times `ambient + (1 − ambient)·max(0, n·L)` (Lambert plus ambient).
//!
//! The view is fitted to the bounding box of the finite vertices grown by R ([`Framing::Auto`])
//! or given explicitly ([`Framing::Fixed`], e.g. to draw two results at the same scale);
//! [`Rendering::framing`] returns the framing used, always as [`Framing::Fixed`].
//!
//! Robustness: a vertex with a non-finite coordinate is skipped (the segments touching it are
//! not drawn) and counted in [`Rendering::skipped_vertices`]. Input with nothing to draw (no
//! curves, or no finite vertex) gives a blank image of the background colour with
//! [`Rendering::segments`] = 0; it is not an error, so an animation keeps one image per frame.
//! Invalid options (zero size, R ≤ 0, a degenerate camera) and inconsistent polylines are
//! errors ([`OutputError::Option`]).
//!
//! Triangle meshes (a body, an obstacle) can be drawn into the same depth buffer
//! ([`render_scene`] with [`MeshLayer`]s): each triangle is rasterized with its depth
//! interpolated linearly (exact under an orthographic camera) and flat-shaded with its face
//! normal facing the camera, in the layer's colour; [`Framing::Auto`] fits the meshes too.
//!
//! Images are written as 8-bit RGB PNG through the `png` crate ([`Image::to_png`]).

use std::path::Path;

use crate::error::{OutputError, Result};
use crate::polylines::Polylines;

/// An orthographic camera: where it looks and which way is up.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// View direction, from the eye into the scene (world, any length > 0). Default
    /// `[0, 0, −1]`: a top view of a sheet in the xy plane.
    pub direction: [f64; 3],
    /// Approximate up direction on screen (world); made orthogonal to `direction`. Must not be
    /// parallel to it. Default `[0, 1, 0]`.
    pub up: [f64; 3],
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
        }
    }
}

/// How world lengths map to pixels.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Framing {
    /// Fit the bounding box of the finite vertices, grown by R, into the image, leaving
    /// `margin` (a fraction of the image size on each side, in [0, 0.45]) free.
    Auto {
        /// Free border on each side as a fraction of the image width/height.
        margin: f64,
    },
    /// A fixed view.
    Fixed {
        /// Screen coordinates (m) of the image centre: world positions projected on the
        /// camera's right and up axes.
        center: [f64; 2],
        /// Scale (pixels per metre, > 0).
        pixels_per_metre: f64,
    },
}

/// Renderer settings.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderOptions {
    /// Image width (pixels, ≥ 1).
    pub width: u32,
    /// Image height (pixels, ≥ 1).
    pub height: u32,
    /// Tube radius R (m, > 0); usually the pattern's yarn radius.
    pub radius: f64,
    /// The camera.
    pub camera: Camera,
    /// The framing (default: auto-fit with a 4 % margin).
    pub framing: Framing,
    /// Direction towards the light in camera coordinates (right, up, into the screen); the
    /// default `[−0.4, 0.5, −1]` lights from the upper left, in front of the scene.
    pub light: [f64; 3],
    /// Ambient fraction of the shading, in [0, 1] (default 0.25).
    pub ambient: f64,
    /// Background colour (sRGB, default white).
    pub background: [u8; 3],
    /// Colours of the curves: curve `c` uses `palette[c % palette.len()]` (non-empty).
    pub palette: Vec<[u8; 3]>,
    /// Samples per pixel along each axis (1 … 8); the image is rendered at this multiple of
    /// its size and box-filtered down (anti-aliasing). Default 1.
    pub supersample: u32,
}

/// A palette of eight distinguishable colours (Okabe–Ito, without black).
pub const DEFAULT_PALETTE: [[u8; 3]; 8] = [
    [230, 159, 0],
    [86, 180, 233],
    [0, 158, 115],
    [240, 228, 66],
    [0, 114, 178],
    [213, 94, 0],
    [204, 121, 167],
    [120, 120, 120],
];

impl RenderOptions {
    /// Defaults for an image of `width × height` pixels and tubes of radius `radius` (m).
    pub fn new(width: u32, height: u32, radius: f64) -> Self {
        Self {
            width,
            height,
            radius,
            camera: Camera::default(),
            framing: Framing::Auto { margin: 0.04 },
            light: [-0.4, 0.5, -1.0],
            ambient: 0.25,
            background: [255, 255, 255],
            palette: DEFAULT_PALETTE.to_vec(),
            supersample: 1,
        }
    }

    /// Checks every option (done by [`render_tubes`] too); the camera is checked as well.
    pub fn validate(&self) -> Result<()> {
        basis(&self.camera)?;
        let bad = |name: &'static str, message: String| Err(OutputError::Option { name, message });
        let ss = u64::from(self.supersample);
        if self.width == 0
            || self.height == 0
            || u64::from(self.width) * u64::from(self.height) * ss * ss > MAX_PIXELS
        {
            return bad(
                "render size",
                format!(
                    "expected width, height ≥ 1 and at most {MAX_PIXELS} (super)samples, found {} × {} × {}²",
                    self.width, self.height, self.supersample
                ),
            );
        }
        if !(1..=8).contains(&self.supersample) {
            return bad(
                "supersample",
                format!("expected 1 … 8, found {}", self.supersample),
            );
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return bad(
                "radius",
                format!("expected a finite tube radius > 0 m, found {}", self.radius),
            );
        }
        if !(self.ambient.is_finite() && (0.0..=1.0).contains(&self.ambient)) {
            return bad(
                "ambient",
                format!("expected a value in [0, 1], found {}", self.ambient),
            );
        }
        if self.palette.is_empty() {
            return bad("palette", "expected at least one colour".into());
        }
        if normalize(self.light).is_none() {
            return bad(
                "light",
                format!(
                    "expected a finite non-zero direction, found {:?}",
                    self.light
                ),
            );
        }
        match self.framing {
            Framing::Auto { margin } if !(0.0..=0.45).contains(&margin) => bad(
                "framing",
                format!("expected a margin in [0, 0.45], found {margin}"),
            ),
            Framing::Fixed {
                center,
                pixels_per_metre,
            } if !(center.iter().all(|c| c.is_finite())
                && pixels_per_metre.is_finite()
                && pixels_per_metre > 0.0) =>
            {
                bad(
                    "framing",
                    format!(
                        "expected a finite centre and a scale > 0, found {center:?}, {pixels_per_metre}"
                    ),
                )
            }
            _ => Ok(()),
        }
    }
}

/// At most this many (super)samples per image (1 GiB of depth and colour buffers).
const MAX_PIXELS: u64 = 1 << 26;

/// An 8-bit RGB image, rows from top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// `3 · width · height` bytes, row-major from the top-left pixel.
    pub rgb: Vec<u8>,
}

impl Image {
    /// The colour of pixel `(x, y)` (column, row from the top).
    ///
    /// # Panics
    /// If the pixel is outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        assert!(x < self.width && y < self.height, "pixel outside the image");
        let k = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }

    /// The image as PNG bytes: 8-bit RGB, encoded by the `png` crate.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let encoded = encoder
            .write_header()
            .and_then(|mut writer| writer.write_image_data(&self.rgb));
        encoded.map_err(|e| OutputError::Invalid(format!("PNG encoding failed: {e}")))?;
        Ok(bytes)
    }

    /// Writes the image as a PNG file.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        crate::write_file(path, &self.to_png()?)
    }
}

/// A rendered image and what went into it.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendering {
    /// The image.
    pub image: Image,
    /// The framing used (always [`Framing::Fixed`]); pass it back in [`RenderOptions`] to draw
    /// another result at the same scale.
    pub framing: Framing,
    /// Segments drawn (a one-vertex curve counts as one).
    pub segments: usize,
    /// Vertices with a non-finite coordinate (not drawn).
    pub skipped_vertices: usize,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n.is_finite() && n > 0.0).then(|| a.map(|c| c / n))
}

/// The camera's (right, up, forward) basis.
fn basis(camera: &Camera) -> Result<[[f64; 3]; 3]> {
    let err = || OutputError::Option {
        name: "camera",
        message: format!(
            "expected finite non-zero, non-parallel direction and up, found {:?} and {:?}",
            camera.direction, camera.up
        ),
    };
    let f = normalize(camera.direction).ok_or_else(err)?;
    let up = normalize(camera.up).ok_or_else(err)?;
    let r = cross(f, up);
    if dot(r, r) < 1e-12 {
        return Err(err());
    }
    let r = normalize(r).ok_or_else(err)?;
    Ok([r, cross(r, f), f])
}

/// First intersection (depth along +z) of the line `(px, py, t)` with the capsule of radius
/// `r` around segment `a`–`b` (camera coordinates), or `None`.
fn hit_capsule(px: f64, py: f64, a: [f64; 3], b: [f64; 3], r: f64) -> Option<f64> {
    let r2 = r * r;
    let mut best = f64::INFINITY;
    let mut sphere = |c: [f64; 3]| {
        let (dx, dy) = (px - c[0], py - c[1]);
        let h = r2 - dx * dx - dy * dy;
        if h >= 0.0 {
            best = best.min(c[2] - h.sqrt());
        }
    };
    sphere(a);
    sphere(b);
    // Cylinder body: |(o − a) × ba|² = r²|ba|² with o = (px, py, t) (Inigo Quilez's form).
    let ba = sub(b, a);
    let baba = dot(ba, ba);
    let oa = [px - a[0], py - a[1], -a[2]];
    let bard = ba[2];
    let baoa = dot(ba, oa);
    let qa = baba - bard * bard;
    // A segment (nearly) along the view direction shows only its caps.
    if qa > 1e-12 * baba {
        let qb = baba * oa[2] - baoa * bard;
        let qc = baba * dot(oa, oa) - baoa * baoa - r2 * baba;
        let h = qb * qb - qa * qc;
        if h >= 0.0 {
            let t = (-qb - h.sqrt()) / qa;
            let y = baoa + t * bard;
            if y > 0.0 && y < baba {
                best = best.min(t);
            }
        }
    }
    best.is_finite().then_some(best)
}

/// A triangle mesh drawn with the tubes ([`render_scene`]).
#[derive(Clone, Copy, Debug)]
pub struct MeshLayer<'a> {
    /// Vertex positions (world, m).
    pub positions: &'a [[f64; 3]],
    /// Triangles as vertex indices.
    pub triangles: &'a [[u32; 3]],
    /// The mesh's colour (sRGB).
    pub colour: [u8; 3],
}

impl MeshLayer<'_> {
    /// Errors if a triangle indexes beyond the vertices.
    pub fn validate(&self) -> Result<()> {
        match self
            .triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= self.positions.len()))
        {
            Some(t) => Err(OutputError::Invalid(format!(
                "mesh triangle {t:?} indexes beyond its {} vertices",
                self.positions.len()
            ))),
            None => Ok(()),
        }
    }
}

/// Renders the curves of `lines` as tubes (see the module documentation).
pub fn render_tubes<T: Copy + Into<f64>>(
    lines: &Polylines<'_, T>,
    options: &RenderOptions,
) -> Result<Rendering> {
    render_scene(lines, &[], options)
}

/// Renders the curves of `lines` as tubes and the triangle `meshes` into one depth buffer
/// (see the module documentation). A triangle index beyond its mesh's vertices is an error;
/// triangles with a non-finite corner are skipped.
pub fn render_scene<T: Copy + Into<f64>>(
    lines: &Polylines<'_, T>,
    meshes: &[MeshLayer<'_>],
    options: &RenderOptions,
) -> Result<Rendering> {
    options.validate()?;
    lines.validate()?;
    for m in meshes {
        m.validate()?;
    }
    let camera_basis = basis(&options.camera)?;
    let (cam, skipped) = to_camera(lines, camera_basis);
    let [right, up, forward] = camera_basis;
    let mesh_cam: Vec<Vec<[f64; 3]>> = meshes
        .iter()
        .map(|m| {
            m.positions
                .iter()
                .map(|&p| [dot(p, right), dot(p, up), dot(p, forward)])
                .collect()
        })
        .collect();
    let fitted: Vec<[f64; 3]> = cam
        .iter()
        .chain(mesh_cam.iter().flatten())
        .copied()
        .collect();
    let (center, scale) = fit_view(&fitted, options);
    let mut canvas = Canvas::new(options, center, scale);
    for (m, vertices) in meshes.iter().zip(&mesh_cam) {
        for t in m.triangles {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            if [a, b, c].iter().flatten().all(|x| x.is_finite()) {
                canvas.draw_triangle(a, b, c, m.colour);
            }
        }
    }
    for c in 0..lines.n_curves() {
        let base = options.palette[c % options.palette.len()];
        draw_curve(&mut canvas, lines, c, &cam, base);
    }
    Ok(Rendering {
        image: Image {
            width: options.width,
            height: options.height,
            rgb: canvas.box_filter(options.width as usize, options.height as usize),
        },
        framing: Framing::Fixed {
            center,
            pixels_per_metre: scale,
        },
        segments: canvas.segments,
        skipped_vertices: skipped,
    })
}

/// Camera coordinates (screen x, screen y, depth) of every vertex of `lines` in the
/// `[right, up, forward]` basis; NaN marks a skipped vertex. Also returns the skipped count.
fn to_camera<T: Copy + Into<f64>>(
    lines: &Polylines<'_, T>,
    [right, up, forward]: [[f64; 3]; 3],
) -> (Vec<[f64; 3]>, usize) {
    let mut skipped = 0;
    let cam: Vec<[f64; 3]> = (0..lines.x.len())
        .map(|k| {
            let p = [lines.x[k].into(), lines.y[k].into(), lines.z[k].into()];
            if p.iter().all(|c| c.is_finite()) {
                [dot(p, right), dot(p, up), dot(p, forward)]
            } else {
                skipped += 1;
                [f64::NAN; 3]
            }
        })
        .collect();
    (cam, skipped)
}

/// The screen centre (m) and scale (pixels per metre) of the view: the fixed framing, or
/// the finite camera-space vertices' bounding box grown by R fitted into the image.
fn fit_view(cam: &[[f64; 3]], options: &RenderOptions) -> ([f64; 2], f64) {
    let radius = options.radius;
    let (w, h) = (f64::from(options.width), f64::from(options.height));
    match options.framing {
        Framing::Fixed {
            center,
            pixels_per_metre,
        } => (center, pixels_per_metre),
        Framing::Auto { margin } => {
            let mut lo = [f64::INFINITY; 2];
            let mut hi = [f64::NEG_INFINITY; 2];
            for p in cam.iter().filter(|p| p[0].is_finite()) {
                for d in 0..2 {
                    lo[d] = lo[d].min(p[d] - radius);
                    hi[d] = hi[d].max(p[d] + radius);
                }
            }
            if lo[0].is_finite() {
                let free = 1.0 - 2.0 * margin;
                let sx = free * w / (hi[0] - lo[0]);
                let sy = free * h / (hi[1] - lo[1]);
                ([0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])], sx.min(sy))
            } else {
                ([0.0, 0.0], 1.0)
            }
        }
    }
}

/// Draws the segments of curve `c` (a sphere for a one-vertex curve, the closing segment of a
/// closed one) whose end vertices are both finite, in the curve's colour `base`.
fn draw_curve<T>(
    canvas: &mut Canvas,
    lines: &Polylines<'_, T>,
    c: usize,
    cam: &[[f64; 3]],
    base: [u8; 3],
) {
    let (start, end) = (
        lines.curve_offsets[c] as usize,
        lines.curve_offsets[c + 1] as usize,
    );
    let finite = |k: usize| cam[k][0].is_finite();
    if end == start + 1 {
        if finite(start) {
            canvas.draw_capsule(cam[start], cam[start], base);
        }
        return;
    }
    for k in start + 1..end {
        if finite(k - 1) && finite(k) {
            canvas.draw_capsule(cam[k - 1], cam[k], base);
        }
    }
    if lines.closed[c] && end > start + 2 && finite(end - 1) && finite(start) {
        canvas.draw_capsule(cam[end - 1], cam[start], base);
    }
}

/// The supersampled image being drawn: depth and colour per sample, and the screen mapping.
struct Canvas {
    /// Screen coordinates (m) of the image centre.
    center: [f64; 2],
    /// Samples per metre.
    s: f64,
    /// Samples along x and y.
    sw: u32,
    sh: u32,
    /// Samples per pixel along each axis.
    ss: u32,
    /// Tube radius R (m).
    radius: f64,
    /// Unit direction towards the light (camera coordinates).
    light: [f64; 3],
    /// Ambient fraction of the shading.
    ambient: f64,
    /// Depth of the nearest hit per sample (`∞`: none).
    depth: Vec<f64>,
    /// Colour per sample.
    colour: Vec<[f32; 3]>,
    /// Segments drawn.
    segments: usize,
}

impl Canvas {
    /// A blank canvas of the background colour for the view `(center, scale)`.
    fn new(options: &RenderOptions, center: [f64; 2], scale: f64) -> Self {
        let ss = options.supersample;
        let (sw, sh) = (options.width * ss, options.height * ss);
        let n_samples = sw as usize * sh as usize;
        Self {
            center,
            s: scale * f64::from(ss),
            sw,
            sh,
            ss,
            radius: options.radius,
            light: normalize(options.light).expect("validated"),
            ambient: options.ambient,
            depth: vec![f64::INFINITY; n_samples],
            colour: vec![options.background.map(f32::from); n_samples],
            segments: 0,
        }
    }

    /// Screen x coordinate of the centre of sample column `i`.
    fn to_screen_x(&self, i: usize) -> f64 {
        self.center[0] + (i as f64 + 0.5 - 0.5 * f64::from(self.sw)) / self.s
    }

    /// Screen y coordinate of the centre of sample row `j`.
    fn to_screen_y(&self, j: usize) -> f64 {
        self.center[1] - (j as f64 + 0.5 - 0.5 * f64::from(self.sh)) / self.s
    }

    /// Sample columns covered by screen x in `[lo, hi]` (empty when outside).
    fn cols(&self, lo: f64, hi: f64) -> std::ops::Range<usize> {
        let (center, s, sw) = (self.center, self.s, self.sw);
        let a = ((lo - center[0]) * s + 0.5 * f64::from(sw) - 0.5)
            .ceil()
            .max(0.0);
        let b = ((hi - center[0]) * s + 0.5 * f64::from(sw) - 0.5)
            .floor()
            .min(f64::from(sw) - 1.0);
        a as usize..(b + 1.0).max(a) as usize
    }

    /// Sample rows covered by screen y in `[lo, hi]` (empty when outside).
    fn rows(&self, lo: f64, hi: f64) -> std::ops::Range<usize> {
        let (center, s, sh) = (self.center, self.s, self.sh);
        let a = ((center[1] - hi) * s + 0.5 * f64::from(sh) - 0.5)
            .ceil()
            .max(0.0);
        let b = ((center[1] - lo) * s + 0.5 * f64::from(sh) - 0.5)
            .floor()
            .min(f64::from(sh) - 1.0);
        a as usize..(b + 1.0).max(a) as usize
    }

    /// Draws triangle `a b c` (camera coordinates) in colour `base`, flat-shaded with its
    /// normal turned towards the camera, where it is nearer than what is drawn.
    fn draw_triangle(&mut self, a: [f64; 3], b: [f64; 3], c: [f64; 3], base: [u8; 3]) {
        let Some(mut normal) = normalize(cross(sub(b, a), sub(c, a))) else {
            return;
        };
        if normal[2] > 0.0 {
            normal = normal.map(|x| -x);
        }
        let lambert = dot(normal, self.light).max(0.0);
        let shade = (self.ambient + (1.0 - self.ambient) * lambert) as f32;
        let colour = base.map(|x| f32::from(x) * shade);
        // Screen-space edge functions: w_a, w_b, w_c ≥ 0 inside (either winding).
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        if area.abs() < 1e-30 {
            return;
        }
        let (xs, ys) = (
            self.cols(a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0])),
            self.rows(a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1])),
        );
        let edge = |p: [f64; 3], q: [f64; 3], x: f64, y: f64| {
            ((q[0] - p[0]) * (y - p[1]) - (x - p[0]) * (q[1] - p[1])) / area
        };
        for j in ys {
            let py = self.to_screen_y(j);
            for i in xs.clone() {
                let px = self.to_screen_x(i);
                let (wa, wb, wc) = (edge(b, c, px, py), edge(c, a, px, py), edge(a, b, px, py));
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let t = wa * a[2] + wb * b[2] + wc * c[2];
                let k = j * self.sw as usize + i;
                if t < self.depth[k] {
                    self.depth[k] = t;
                    self.colour[k] = colour;
                }
            }
        }
    }

    /// Draws the capsule around segment `a`–`b` (camera coordinates) in colour `base`, shaded
    /// Lambert plus ambient, where it is nearer than what is drawn.
    fn draw_capsule(&mut self, a: [f64; 3], b: [f64; 3], base: [u8; 3]) {
        self.segments += 1;
        let radius = self.radius;
        let ba = sub(b, a);
        let baba = dot(ba, ba);
        let (xs, ys) = (
            self.cols(a[0].min(b[0]) - radius, a[0].max(b[0]) + radius),
            self.rows(a[1].min(b[1]) - radius, a[1].max(b[1]) + radius),
        );
        for j in ys {
            let py = self.to_screen_y(j);
            for i in xs.clone() {
                let px = self.to_screen_x(i);
                let Some(t) = hit_capsule(px, py, a, b, radius) else {
                    continue;
                };
                let k = j * self.sw as usize + i;
                if t >= self.depth[k] {
                    continue;
                }
                self.depth[k] = t;
                let p = [px, py, t];
                let u = if baba > 0.0 {
                    (dot(sub(p, a), ba) / baba).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let q = [a[0] + u * ba[0], a[1] + u * ba[1], a[2] + u * ba[2]];
                let normal = sub(p, q).map(|c| c / radius);
                let lambert = dot(normal, self.light).max(0.0);
                let shade = (self.ambient + (1.0 - self.ambient) * lambert) as f32;
                self.colour[k] = base.map(|c| f32::from(c) * shade);
            }
        }
    }

    /// The image of `width × height` pixels: each pixel the box-filtered mean of its
    /// `ss × ss` samples, as 8-bit RGB.
    fn box_filter(&self, width: usize, height: usize) -> Vec<u8> {
        let ss = self.ss as usize;
        let norm = 1.0 / (ss * ss) as f32;
        let mut rgb = Vec::with_capacity(3 * width * height);
        for y in 0..height {
            for x in 0..width {
                let mut acc = [0.0f32; 3];
                for j in y * ss..(y + 1) * ss {
                    for i in x * ss..(x + 1) * ss {
                        let c = self.colour[j * self.sw as usize + i];
                        for d in 0..3 {
                            acc[d] += c[d];
                        }
                    }
                }
                rgb.extend(acc.map(|v| (v * norm).round().clamp(0.0, 255.0) as u8));
            }
        }
        rgb
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capsule_hits_match_closed_forms() {
        let r = 0.5;
        // Segment along x at depth 2: on the axis the hit is at depth 2 − r.
        let (a, b) = ([-1.0, 0.0, 2.0], [1.0, 0.0, 2.0]);
        assert!((hit_capsule(0.0, 0.0, a, b, r).unwrap() - 1.5).abs() < 1e-12);
        // Off-axis by y: depth 2 − √(r² − y²).
        let y: f64 = 0.3;
        let t = hit_capsule(0.2, y, a, b, r).unwrap();
        assert!((t - (2.0 - (r * r - y * y).sqrt())).abs() < 1e-12);
        // Beyond the end: the spherical cap.
        let t = hit_capsule(1.3, 0.0, a, b, r).unwrap();
        assert!((t - (2.0 - (r * r - 0.09f64).sqrt())).abs() < 1e-12);
        assert!(hit_capsule(0.0, 0.51, a, b, r).is_none());
        assert!(hit_capsule(1.51, 0.0, a, b, r).is_none());
        // Segment along the view direction: only its near cap is seen.
        let t = hit_capsule(0.0, 0.0, [0.0, 0.0, 1.0], [0.0, 0.0, 3.0], r).unwrap();
        assert!((t - 0.5).abs() < 1e-12);
        // Tilted segment: the hit point lies at distance r from the centreline.
        let (a, b) = ([-1.0, 0.0, 1.0], [1.0, 0.5, 3.0]);
        let t = hit_capsule(0.1, 0.2, a, b, r).unwrap();
        let p = [0.1, 0.2, t];
        let ba = sub(b, a);
        let u = (dot(sub(p, a), ba) / dot(ba, ba)).clamp(0.0, 1.0);
        let q = [a[0] + u * ba[0], a[1] + u * ba[1], a[2] + u * ba[2]];
        let d = dot(sub(p, q), sub(p, q)).sqrt();
        assert!((d - r).abs() < 1e-9, "distance {d}");
        // ... and nothing is hit in front of it: a slightly smaller depth lies outside.
        let p = [0.1, 0.2, t - 1e-6];
        let u = (dot(sub(p, a), ba) / dot(ba, ba)).clamp(0.0, 1.0);
        let q = [a[0] + u * ba[0], a[1] + u * ba[1], a[2] + u * ba[2]];
        assert!(dot(sub(p, q), sub(p, q)).sqrt() > r);
    }
}
