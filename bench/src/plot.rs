//! A small line-chart helper that writes every plot as both PNG and SVG.
//!
//! ```no_run
//! use bench::plot::{LineChart, Series};
//! # fn main() -> anyhow::Result<()> {
//! let n = [4.0, 8.0, 16.0, 32.0];
//! let err: Vec<(f64, f64)> = n.iter().map(|&n| (n, 1.0 / (n * n))).collect();
//! LineChart::new("Convergence")
//!     .x_label("segments")
//!     .y_label("relative error")
//!     .log_x()
//!     .log_y()
//!     .series(Series::line_markers("discrete rod", err))
//!     .series(Series::dashed("O(h²)", [(4.0, 0.1), (32.0, 0.1 / 64.0)]))
//!     .hline("tolerance", 1e-3)
//!     .save(std::path::Path::new("out"), "convergence")?; // out/convergence.{png,svg}
//! # Ok(())
//! # }
//! ```
//!
//! Text is rendered with the embedded DejaVu Sans font, so no system font
//! libraries are needed.

use std::ops::Range;
use std::path::Path;
use std::sync::Once;

use anyhow::{Context, bail};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::register_font;

/// Font family name under which the embedded font is registered.
const FONT: &str = "sans-serif";

/// Size of a single-panel chart, in pixels (SVG uses the same units).
const SINGLE_SIZE: (u32, u32) = (960, 640);
/// Size of a two-panel chart, in pixels.
const PAIR_SIZE: (u32, u32) = (1600, 640);

/// Series colours, in order (the "tab10" palette, then black and dark red, so that an eleventh
/// or twelfth series is not drawn in the first ones' colours).
const PALETTE: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
    RGBColor(128, 0, 0),
];

/// Registers the embedded font with plotters (once per process).
fn ensure_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let bytes = include_bytes!("../assets/DejaVuSans.ttf");
        if register_font(FONT, FontStyle::Normal, bytes).is_err() {
            panic!("bench/assets/DejaVuSans.ttf is not a valid font");
        }
    });
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Solid line.
    Line,
    /// Filled circles only.
    Markers,
    /// Filled triangles only (a second marker shape, to tell two families of points apart).
    Triangles,
    /// Solid line with filled circles at the data points.
    LineMarkers,
    /// Dashed line, for reference curves (closed form, paper data, slopes).
    Dashed,
}

/// One named curve of a chart. A point that cannot be drawn (not finite, or not positive on
/// a log axis) is left out; in a line it breaks the line, so NaN separates pieces of one
/// curve.
#[derive(Debug, Clone)]
pub struct Series {
    name: String,
    points: Vec<(f64, f64)>,
    style: Style,
}

impl Series {
    /// A series with an explicit style.
    pub fn new(
        name: impl Into<String>,
        points: impl IntoIterator<Item = (f64, f64)>,
        style: Style,
    ) -> Self {
        Self {
            name: name.into(),
            points: points.into_iter().collect(),
            style,
        }
    }

    /// A solid line.
    pub fn line(name: impl Into<String>, points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Self::new(name, points, Style::Line)
    }

    /// Markers only (e.g. measured data).
    pub fn markers(name: impl Into<String>, points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Self::new(name, points, Style::Markers)
    }

    /// Triangle markers only (a second family of measured data next to [`Series::markers`]).
    pub fn triangles(
        name: impl Into<String>,
        points: impl IntoIterator<Item = (f64, f64)>,
    ) -> Self {
        Self::new(name, points, Style::Triangles)
    }

    /// A solid line with markers at the data points.
    pub fn line_markers(
        name: impl Into<String>,
        points: impl IntoIterator<Item = (f64, f64)>,
    ) -> Self {
        Self::new(name, points, Style::LineMarkers)
    }

    /// A dashed reference curve (closed form, paper values, slope guide).
    pub fn dashed(name: impl Into<String>, points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Self::new(name, points, Style::Dashed)
    }
}

/// Where the legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    /// The corner with the fewest data points in it.
    #[default]
    Auto,
    /// Upper left corner.
    UpperLeft,
    /// Upper right corner.
    UpperRight,
    /// Lower left corner.
    LowerLeft,
    /// Lower right corner.
    LowerRight,
}

/// A line chart: title, axis labels, optional log axes, named series and
/// dashed horizontal reference lines. Colours are assigned in order: series
/// first, then horizontal lines.
#[derive(Debug, Clone)]
pub struct LineChart {
    title: String,
    x_label: String,
    y_label: String,
    log_x: bool,
    log_y: bool,
    series: Vec<Series>,
    hlines: Vec<(String, f64)>,
    legend: Legend,
}

impl LineChart {
    /// An empty chart with the given title.
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            x_label: String::new(),
            y_label: String::new(),
            log_x: false,
            log_y: false,
            series: Vec::new(),
            hlines: Vec::new(),
            legend: Legend::Auto,
        }
    }

    /// Sets the x-axis label.
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = label.into();
        self
    }

    /// Sets the y-axis label.
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = label.into();
        self
    }

    /// Logarithmic x axis (non-positive x values are skipped).
    pub fn log_x(mut self) -> Self {
        self.log_x = true;
        self
    }

    /// Logarithmic y axis (non-positive y values are skipped).
    pub fn log_y(mut self) -> Self {
        self.log_y = true;
        self
    }

    /// Adds a series.
    pub fn series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Adds a dashed horizontal reference line `y = value` across the chart.
    pub fn hline(mut self, name: impl Into<String>, value: f64) -> Self {
        self.hlines.push((name.into(), value));
        self
    }

    /// Overrides the legend position (default: [`Legend::Auto`]).
    pub fn legend(mut self, legend: Legend) -> Self {
        self.legend = legend;
        self
    }

    /// The plotted x and y ranges; fails if there is nothing to plot.
    fn ranges(&self) -> anyhow::Result<(Range<f64>, Range<f64>)> {
        let all_points = || self.series.iter().flat_map(|s| s.points.iter());
        if all_points().next().is_none() {
            bail!("chart {:?} has no data points", self.title);
        }
        let x = axis_range(all_points().map(|p| p.0), self.log_x)
            .with_context(|| format!("x axis of chart {:?}", self.title))?;
        let y_values = all_points()
            .map(|p| p.1)
            .chain(self.hlines.iter().map(|h| h.1));
        let y = axis_range(y_values, self.log_y)
            .with_context(|| format!("y axis of chart {:?}", self.title))?;
        Ok((x, y))
    }

    /// Writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`.
    pub fn save(&self, dir: &Path, stem: &str) -> anyhow::Result<()> {
        save_panels(&[self], dir, stem, SINGLE_SIZE)
    }
}

/// The points `(x, y)` of columns `x` and `y` of `data`, row by row (for a [`Series`]).
///
/// # Panics
/// If `data` has no column of either name.
pub fn column_points(data: &yarn_output::table::Table, x: &str, y: &str) -> Vec<(f64, f64)> {
    let column = |name: &str| data.column(name).expect("column exists");
    column(x).into_iter().zip(column(y)).collect()
}

/// Writes two charts side by side as `<dir>/<stem>.png` and `<dir>/<stem>.svg`
/// (e.g. a curve on the left and per-term energy shares on the right).
pub fn save_side_by_side(
    left: &LineChart,
    right: &LineChart,
    dir: &Path,
    stem: &str,
) -> anyhow::Result<()> {
    save_panels(&[left, right], dir, stem, PAIR_SIZE)
}

/// Writes charts in a grid of `cols` columns (row by row) as `<dir>/<stem>.png` and
/// `<dir>/<stem>.svg`, each panel the size of a single chart scaled by `scale`.
pub fn save_grid(
    charts: &[&LineChart],
    cols: usize,
    scale: f64,
    dir: &Path,
    stem: &str,
) -> anyhow::Result<()> {
    if charts.is_empty() || cols == 0 {
        bail!("{stem}: a grid needs charts and at least one column");
    }
    let rows = charts.len().div_ceil(cols);
    let (w, h) = (
        (SINGLE_SIZE.0 as f64 * scale) as u32,
        (SINGLE_SIZE.1 as f64 * scale) as u32,
    );
    save_layout(
        charts,
        (rows, cols),
        dir,
        stem,
        (w * cols as u32, h * rows as u32),
    )
}

fn save_panels(
    charts: &[&LineChart],
    dir: &Path,
    stem: &str,
    size: (u32, u32),
) -> anyhow::Result<()> {
    save_layout(charts, (1, charts.len()), dir, stem, size)
}

fn save_layout(
    charts: &[&LineChart],
    layout: (usize, usize),
    dir: &Path,
    stem: &str,
    size: (u32, u32),
) -> anyhow::Result<()> {
    ensure_font();
    // Fail before creating any file.
    for chart in charts {
        chart.ranges()?;
    }
    let png = dir.join(format!("{stem}.png"));
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        draw_panels(&root, charts, layout).with_context(|| format!("drawing {}", png.display()))?;
        root.present()
            .with_context(|| format!("writing {}", png.display()))?;
    }
    let svg = dir.join(format!("{stem}.svg"));
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw_panels(&root, charts, layout).with_context(|| format!("drawing {}", svg.display()))?;
        root.present()
            .with_context(|| format!("writing {}", svg.display()))?;
    }
    Ok(())
}

/// Height of the caption band above each image of [`save_images`] (pixels).
const CAPTION_HEIGHT: u32 = 36;

/// Writes rendered images (e.g. `yarn_output::render` tube images) side by side, each with
/// a caption above it, as `<dir>/<stem>.png` (raster only: no SVG). The file is written by the
/// plotters bitmap backend, so it is deflate-compressed, unlike the renderer's own stored-block
/// PNG encoder.
pub fn save_images(
    panels: &[(&str, &yarn_output::render::Image)],
    dir: &Path,
    stem: &str,
) -> anyhow::Result<()> {
    if panels.is_empty() {
        bail!("{stem}: no images to save");
    }
    ensure_font();
    let width: u32 = panels.iter().map(|(_, image)| image.width).sum();
    let height = CAPTION_HEIGHT
        + panels
            .iter()
            .map(|(_, image)| image.height)
            .max()
            .unwrap_or(0);
    let png = dir.join(format!("{stem}.png"));
    {
        let root = BitMapBackend::new(&png, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let caption = (FONT, 22).into_font().color(&BLACK);
        let mut x0 = 0i32;
        for (title, image) in panels {
            root.draw_text(title, &caption, (x0 + 12, 8))?;
            for y in 0..image.height {
                for x in 0..image.width {
                    let [r, g, b] = image.pixel(x, y);
                    if [r, g, b] != [255, 255, 255] {
                        let at = (x0 + x as i32, (CAPTION_HEIGHT + y) as i32);
                        root.draw_pixel(at, &RGBColor(r, g, b))?;
                    }
                }
            }
            x0 += image.width as i32;
        }
        root.present()
            .with_context(|| format!("writing {}", png.display()))?;
    }
    Ok(())
}

fn draw_panels<DB>(
    root: &DrawingArea<DB, Shift>,
    charts: &[&LineChart],
    layout: (usize, usize),
) -> anyhow::Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    for (area, chart) in root.split_evenly(layout).iter().zip(charts) {
        draw_chart(area, chart)?;
    }
    Ok(())
}

/// Picks linear or log coordinates for each axis, then draws.
fn draw_chart<DB>(area: &DrawingArea<DB, Shift>, chart: &LineChart) -> anyhow::Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
{
    let (x, y) = chart.ranges()?;
    let legend = legend_position(chart, &x, &y);
    match (chart.log_x, chart.log_y) {
        (false, false) => draw_on(area, chart, x.clone(), y, x, legend),
        (true, false) => draw_on(area, chart, x.clone().log_scale(), y, x, legend),
        (false, true) => draw_on(area, chart, x.clone(), y.log_scale(), x, legend),
        (true, true) => draw_on(area, chart, x.clone().log_scale(), y.log_scale(), x, legend),
    }
}

fn draw_on<DB, X, Y>(
    area: &DrawingArea<DB, Shift>,
    chart: &LineChart,
    x_coord: X,
    y_coord: Y,
    x_range: Range<f64>,
    legend: SeriesLabelPosition,
) -> anyhow::Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut cc = ChartBuilder::on(area)
        .caption(&chart.title, (FONT, 24))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(84)
        .build_cartesian_2d(x_coord, y_coord)?;
    // A tick at zero computed as a rounding residue (e.g. 2.8e-17) is printed as 0.
    let (xs, ys) = (zero_snap(&cc.x_range()), zero_snap(&cc.y_range()));
    cc.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_label_formatter(&|v| tick_label(if v.abs() < xs { 0.0 } else { *v }))
        .y_label_formatter(&|v| tick_label(if v.abs() < ys { 0.0 } else { *v }))
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 18))
        .light_line_style(BLACK.mix(0.04))
        .bold_line_style(BLACK.mix(0.12))
        .draw()?;

    let drawable = |p: &&(f64, f64)| {
        p.0.is_finite()
            && p.1.is_finite()
            && (!chart.log_x || p.0 > 0.0)
            && (!chart.log_y || p.1 > 0.0)
    };
    for (i, s) in chart.series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let line = color.stroke_width(2);
        let dot = color.filled();
        let pts: Vec<(f64, f64)> = s.points.iter().filter(drawable).copied().collect();
        // Lines break where a point cannot be drawn (NaN or, on a log axis, non-positive):
        // runs after the first are drawn without a legend entry, the first with it.
        let mut runs: Vec<Vec<(f64, f64)>> = s
            .points
            .split(|p| !drawable(&p))
            .filter(|r| !r.is_empty())
            .map(<[(f64, f64)]>::to_vec)
            .collect();
        let first = if runs.is_empty() {
            Vec::new()
        } else {
            runs.remove(0)
        };
        let lines = matches!(s.style, Style::Line | Style::LineMarkers | Style::Dashed);
        for run in runs.into_iter().filter(|_| lines) {
            if matches!(s.style, Style::Dashed) {
                cc.draw_series(DashedLineSeries::new(run, 8, 5, line))?;
            } else {
                cc.draw_series(LineSeries::new(run, line))?;
            }
        }
        let anno = match s.style {
            Style::Line => cc
                .draw_series(LineSeries::new(first, line))?
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 24, y)], line)),
            Style::Markers => cc
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, dot)))?
                .legend(move |(x, y)| Circle::new((x + 12, y), 4, dot)),
            Style::Triangles => cc
                .draw_series(pts.iter().map(|&p| TriangleMarker::new(p, 6, dot)))?
                .legend(move |(x, y)| TriangleMarker::new((x + 12, y), 6, dot)),
            Style::LineMarkers => {
                cc.draw_series(pts.iter().map(|&p| Circle::new(p, 4, dot)))?;
                cc.draw_series(LineSeries::new(first, line))?
                    .legend(move |(x, y)| {
                        EmptyElement::at((x, y))
                            + PathElement::new([(0, 0), (24, 0)], line)
                            + Circle::new((12, 0), 4, dot)
                    })
            }
            Style::Dashed => cc
                .draw_series(DashedLineSeries::new(first, 8, 5, line))?
                .legend(move |(x, y)| DashedPathElement::new([(x, y), (x + 24, y)], 7, 4, line)),
        };
        if !s.name.is_empty() {
            anno.label(s.name.as_str());
        }
    }
    for (k, (name, value)) in chart.hlines.iter().enumerate() {
        if !value.is_finite() || (chart.log_y && *value <= 0.0) {
            continue;
        }
        let color = PALETTE[(chart.series.len() + k) % PALETTE.len()];
        let line = color.stroke_width(2);
        let pts = [(x_range.start, *value), (x_range.end, *value)];
        let anno = cc
            .draw_series(DashedLineSeries::new(pts, 8, 5, line))?
            .legend(move |(x, y)| DashedPathElement::new([(x, y), (x + 24, y)], 7, 4, line));
        if !name.is_empty() {
            anno.label(name.as_str());
        }
    }

    let has_labels = chart.series.iter().any(|s| !s.name.is_empty())
        || chart.hlines.iter().any(|h| !h.0.is_empty());
    if has_labels {
        cc.configure_series_labels()
            .position(legend)
            .margin(12)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font((FONT, 15))
            .draw()?;
    }
    Ok(())
}

/// The plotted range of one axis: padded by 5 % on linear axes, widened to
/// whole decades on log axes.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> anyhow::Result<Range<f64>> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        bail!(if log {
            "no positive finite values to plot on a log axis"
        } else {
            "no finite values to plot"
        });
    }
    if log {
        // Whole decades: plotters labels and grids a log axis from its first
        // power of ten, so decade ends keep both ends labelled and gridded.
        let lo_dec = (lo.log10() + 1e-9).floor();
        let hi_dec = (hi.log10() - 1e-9).ceil().max(lo_dec + 1.0);
        // Widen by a hair so rounding in plotters' tick loop keeps the end decades.
        Ok(10f64.powf(lo_dec) * (1.0 - 1e-9)..10f64.powf(hi_dec) * (1.0 + 1e-9))
    } else {
        let span = hi - lo;
        let pad = if span > 0.0 {
            0.05 * span
        } else if hi != 0.0 {
            0.1 * hi.abs()
        } else {
            1.0
        };
        Ok(lo - pad..hi + pad)
    }
}

/// Position on an axis as a fraction in [0, 1].
fn fraction(v: f64, range: &Range<f64>, log: bool) -> f64 {
    if log {
        (v.log10() - range.start.log10()) / (range.end.log10() - range.start.log10())
    } else {
        (v - range.start) / (range.end - range.start)
    }
}

/// The legend's corner: the requested one, or the corner region holding the
/// fewest (densely sampled) curve points.
fn legend_position(chart: &LineChart, x: &Range<f64>, y: &Range<f64>) -> SeriesLabelPosition {
    let corners = [
        SeriesLabelPosition::UpperRight,
        SeriesLabelPosition::UpperLeft,
        SeriesLabelPosition::LowerRight,
        SeriesLabelPosition::LowerLeft,
    ];
    match chart.legend {
        Legend::UpperRight => return corners[0].clone(),
        Legend::UpperLeft => return corners[1].clone(),
        Legend::LowerRight => return corners[2].clone(),
        Legend::LowerLeft => return corners[3].clone(),
        Legend::Auto => {}
    }
    let mut counts = [0usize; 4];
    let mut count = |fx: f64, fy: f64| {
        let right = fx > 0.55;
        let left = fx < 0.45;
        let top = fy > 0.6;
        let bottom = fy < 0.4;
        for (k, hit) in [right && top, left && top, right && bottom, left && bottom]
            .into_iter()
            .enumerate()
        {
            counts[k] += usize::from(hit);
        }
    };
    for s in &chart.series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|p| {
                p.0.is_finite()
                    && p.1.is_finite()
                    && (!chart.log_x || p.0 > 0.0)
                    && (!chart.log_y || p.1 > 0.0)
            })
            .map(|p| (fraction(p.0, x, chart.log_x), fraction(p.1, y, chart.log_y)))
            .collect();
        for &(fx, fy) in &pts {
            count(fx, fy);
        }
        if !matches!(s.style, Style::Markers | Style::Triangles) {
            for w in pts.windows(2) {
                for t in 1..10 {
                    let t = f64::from(t) / 10.0;
                    count(
                        w[0].0 + t * (w[1].0 - w[0].0),
                        w[0].1 + t * (w[1].1 - w[0].1),
                    );
                }
            }
        }
    }
    for (_, v) in &chart.hlines {
        if v.is_finite() && (!chart.log_y || *v > 0.0) {
            let fy = fraction(*v, y, chart.log_y);
            for t in 0..=10 {
                count(f64::from(t) / 10.0, fy);
            }
        }
    }
    let best = (0..4).min_by_key(|&k| counts[k]).unwrap_or(0);
    corners[best].clone()
}

/// Compact tick labels: `0.25`, `1200`, `1e-6`, `2.5e4`.
/// Values below this magnitude are zero on an axis `range`: 1e-9 of its span when it crosses
/// zero (linear axes), else 0 (log axes never do).
fn zero_snap(range: &Range<f64>) -> f64 {
    if range.start < 0.0 && range.end > 0.0 {
        1e-9 * (range.end - range.start)
    } else {
        0.0
    }
}

fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".to_string()
    } else if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{exp}", trim_zeros(mantissa))
    } else {
        trim_zeros(&format!("{v:.6}")).to_string()
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_compact() {
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(1200.0), "1200");
        assert_eq!(tick_label(1e-6), "1e-6");
        assert_eq!(tick_label(25000.0 * 10.0), "2.5e5");
    }

    #[test]
    fn images_are_saved_side_by_side_with_captions() {
        use yarn_output::render::Image;
        let dir = std::env::temp_dir().join(format!("bench-save-images-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let image = |width: u32, height: u32, v: u8| Image {
            width,
            height,
            rgb: vec![v; 3 * (width * height) as usize],
        };
        let (a, b) = (image(30, 20, 10), image(50, 40, 200));
        save_images(&[("a", &a), ("b", &b)], &dir, "pair").unwrap();
        let png = std::fs::read(dir.join("pair.png")).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[12..16], b"IHDR");
        let size = |o: usize| u32::from_be_bytes(png[o..o + 4].try_into().unwrap());
        assert_eq!((size(16), size(20)), (80, 40 + CAPTION_HEIGHT));
        assert!(save_images(&[], &dir, "none").is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Draws every style on linear and log axes. The files are left in
    /// `<temp>/bench-plot-selftest/` for eyeballing.
    #[test]
    fn draws_png_and_svg() {
        let dir = std::env::temp_dir().join("bench-plot-selftest");
        std::fs::create_dir_all(&dir).unwrap();
        let n: Vec<f64> = (2..=7).map(|k| f64::from(1 << k)).collect();
        let convergence = LineChart::new("Tip deflection error")
            .x_label("segments")
            .y_label("relative error")
            .log_x()
            .log_y()
            .series(Series::line_markers(
                "discrete rod",
                n.iter().map(|&n| (n, 0.8 / (n * n))),
            ))
            .series(Series::markers(
                "paper",
                n.iter().map(|&n| (n, 1.1 / (n * n))),
            ))
            .series(Series::dashed("O(h²)", [(4.0, 0.2), (128.0, 0.2 / 1024.0)]))
            .hline("tolerance", 1e-3);
        convergence.save(&dir, "single-log").unwrap();

        let shares = LineChart::new("Energy share per term")
            .x_label("load step")
            .y_label("share of total energy")
            .series(Series::line(
                "stretch",
                (0..=10).map(|i| (f64::from(i), 0.1 + 0.03 * f64::from(i))),
            ))
            .series(Series::line(
                "bend",
                (0..=10).map(|i| (f64::from(i), 0.7 - 0.04 * f64::from(i))),
            ))
            .series(Series::line(
                "twist",
                (0..=10).map(|i| (f64::from(i), 0.2 + 0.01 * f64::from(i))),
            ));
        save_side_by_side(&convergence, &shares, &dir, "pair").unwrap();

        for file in ["single-log.png", "single-log.svg", "pair.png", "pair.svg"] {
            let len = std::fs::metadata(dir.join(file)).unwrap().len();
            assert!(len > 1000, "{file} is only {len} bytes");
        }
        let empty = LineChart::new("empty").save(&dir, "empty").unwrap_err();
        assert!(empty.to_string().contains("no data"), "{empty}");
        assert!(!dir.join("empty.png").exists());
    }

    #[test]
    fn log_range_snaps_to_decades() {
        let close = |r: &Range<f64>, a: f64, b: f64| {
            (r.start / a - 1.0).abs() < 1e-8 && (r.end / b - 1.0).abs() < 1e-8
        };
        let r = axis_range([0.003, 0.4, -1.0].into_iter(), true).unwrap();
        assert!(close(&r, 1e-3, 1.0), "{r:?}");
        let r = axis_range([4.0, 128.0].into_iter(), true).unwrap();
        assert!(close(&r, 1.0, 1000.0), "{r:?}");
        let r = axis_range([1000.0].into_iter(), true).unwrap();
        assert!(close(&r, 1e3, 1e4), "{r:?}");
        assert!(axis_range([-1.0, 0.0].into_iter(), true).is_err());
    }
}
