//! Shape measures of knit swatches: edge curl and width (seed 000 §3.1, §5.2.2, Figs. 5
//! and 7: stockinette curls, garter stays flat, rib compresses in width).
//!
//! **Material frame.** "Front" is the side the knit stitches face (the layout's `+z`, see
//! [`crate::layout`]). On a deformed swatch it is taken from the material itself: with the
//! course direction `x̂` (towards increasing columns) and the wale direction `ŷ` (towards
//! increasing rows) at a point, the front normal is `x̂ × ŷ`. So the measures do not depend
//! on rigid motions of the swatch.
//!
//! **Edge curl** ([`edge_curl`]). Along the course direction we follow the polyline of the
//! centroids `P_c` of each column's contact nodes on the middle row boundary, and along the
//! wale direction the centroids `P_b` of each row boundary's nodes in the two middle columns.
//! The tangent angle `θ` accumulates the signed turns between consecutive polyline segments
//! about the local transverse material axis, positive when the fabric bends towards the
//! front. The curl of an edge is the turn from the centre of the swatch out to that edge,
//! `θ_edge − θ_centre` for the right and top edges, `θ_centre − θ_edge` for the left and
//! bottom edges, so that **positive means the edge rolls towards the front** (a cylinder
//! rolled with its edges in front gives positive curls on both of its edges) and `±π` means
//! the edge has turned a half turn (accumulated, so rolls past π are measured as such).
//!
//! **Width** ([`course_width`]): the mean over the row boundaries `1 … H − 1` of the distance
//! between the centroids of the first and the last column's nodes (m) — what a ruler laid
//! across the swatch from side edge to side edge measures.

use crate::topology::{FabricKind, Side, Topology, knit_node};
use rod::geometry::V3;

/// Curl angles (rad) of the four edges of a knit swatch; positive: the edge rolls towards
/// the front (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeCurl {
    /// Left side edge (column 0), along the course direction.
    pub left: f64,
    /// Right side edge (last column), along the course direction.
    pub right: f64,
    /// Bottom edge (cast-on), along the wale direction.
    pub bottom: f64,
    /// Top edge (bind-off), along the wale direction.
    pub top: f64,
}

impl EdgeCurl {
    /// Mean curl of the side edges (course direction, rad).
    pub fn sides(&self) -> f64 {
        0.5 * (self.left + self.right)
    }

    /// Mean curl of the bottom and top edges (wale direction, rad).
    pub fn ends(&self) -> f64 {
        0.5 * (self.bottom + self.top)
    }

    /// Largest magnitude over the four edges (rad).
    pub fn max_abs(&self) -> f64 {
        [self.left, self.right, self.bottom, self.top]
            .iter()
            .fold(0.0, |m, v| m.max(v.abs()))
    }
}

/// A swatch that cannot be measured.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeasureError {
    /// Not a knit, too small (needs ≥ 3 columns and ≥ 3 rows), or positions of the wrong
    /// length.
    #[error("cannot measure: {0}")]
    Invalid(String),
}

/// Width and height (stitches, rows) of a knit topology, checked against `positions`.
pub(crate) fn knit_size(
    topology: &Topology,
    positions: &[V3],
) -> Result<(usize, usize), MeasureError> {
    let FabricKind::Knit(chart) = &topology.kind else {
        return Err(MeasureError::Invalid("not a knit".into()));
    };
    let (w, h) = (chart.width(), chart.height());
    let flat = topology
        .knit
        .as_ref()
        .is_some_and(|k| k.construction != crate::topology::Construction::Round);
    if !chart.is_rectangular() || !flat {
        return Err(MeasureError::Invalid(
            "edge measures need a rectangular K/P chart knitted flat".into(),
        ));
    }
    if w < 3 || h < 3 {
        return Err(MeasureError::Invalid(format!(
            "{w} × {h} stitches: needs ≥ 3 × 3"
        )));
    }
    if positions.len() != topology.nodes.len() {
        return Err(MeasureError::Invalid(format!(
            "{} positions for {} nodes",
            positions.len(),
            topology.nodes.len()
        )));
    }
    Ok((w, h))
}

/// Centroid of the four contact nodes of column `c` on row boundary `b`.
pub(crate) fn grid_cell(positions: &[V3], w: usize, b: usize, c: usize) -> V3 {
    let mut sum = V3::zeros();
    for side in [Side::Left, Side::Right] {
        for hi in [false, true] {
            sum += positions[knit_node(w, b, c, side, hi)];
        }
    }
    sum / 4.0
}

/// Accumulated tangent angle along `points`: one value per segment, starting at 0; each turn
/// is measured about `axis(k)` (the transverse axis between segments `k` and `k + 1`).
fn tangent_angles(points: &[V3], axis: impl Fn(usize) -> V3) -> Vec<f64> {
    let mut theta = vec![0.0];
    for k in 0..points.len() - 2 {
        let (t0, t1) = (points[k + 1] - points[k], points[k + 2] - points[k + 1]);
        let turn = t0.cross(&t1).dot(&axis(k).normalize()).atan2(t0.dot(&t1));
        theta.push(theta[k] + turn);
    }
    theta
}

/// The value at the centre of a list of segment angles (mean of the two middle ones for an
/// even count).
fn centre(theta: &[f64]) -> f64 {
    let n = theta.len();
    0.5 * (theta[(n - 1) / 2] + theta[n / 2])
}

/// Edge curls of a knit swatch at node `positions` (module documentation).
pub fn edge_curl(topology: &Topology, positions: &[V3]) -> Result<EdgeCurl, MeasureError> {
    let (w, h) = knit_size(topology, positions)?;
    // Course direction: columns along the middle boundary, turning about the wale axis
    // (front bending along +x turns the tangent about −ŷ).
    let bm = h / 2;
    let course: Vec<V3> = (0..w).map(|c| grid_cell(positions, w, bm, c)).collect();
    let wale_axis =
        |c: usize| grid_cell(positions, w, bm + 1, c) - grid_cell(positions, w, bm - 1, c);
    let theta_x = tangent_angles(&course, |k| -wale_axis(k + 1));
    // Wale direction: boundaries through the two middle columns, turning about the course
    // axis (front bending along +y turns the tangent about +x̂).
    let (c0, c1) = ((w - 1) / 2, w / 2 + usize::from(w % 2 == 1));
    let band = |b: usize| 0.5 * (grid_cell(positions, w, b, c0) + grid_cell(positions, w, b, c1));
    let wale: Vec<V3> = (0..=h).map(band).collect();
    let course_axis = |b: usize| grid_cell(positions, w, b, c1) - grid_cell(positions, w, b, c0);
    let theta_y = tangent_angles(&wale, |k| course_axis(k + 1));
    let (cx, cy) = (centre(&theta_x), centre(&theta_y));
    Ok(EdgeCurl {
        left: cx - theta_x[0],
        right: theta_x[theta_x.len() - 1] - cx,
        bottom: cy - theta_y[0],
        top: theta_y[theta_y.len() - 1] - cy,
    })
}

/// Side-to-side width of a knit swatch (m; module documentation).
pub fn course_width(topology: &Topology, positions: &[V3]) -> Result<f64, MeasureError> {
    let (w, h) = knit_size(topology, positions)?;
    let sum: f64 = (1..h)
        .map(|b| (grid_cell(positions, w, b, w - 1) - grid_cell(positions, w, b, 0)).norm())
        .sum();
    Ok(sum / (h - 1) as f64)
}
