//! Knit fidelity: does a simulated knit keep the shape of knitting? (seed 000 §4.1–§4.2,
//! Figs. 5–7: loops that stay open, stitches that stay where they were knitted, edge curl.)
//!
//! Every measure is taken on node positions and is independent of rigid motions. Lengths are
//! reported in yarn diameters `d = 2R`. With the grid of a rectangular K/P chart knitted
//! flat (cells `(b, c)`: the centroid of the four contact nodes of column `c` on row
//! boundary `b`, as in [`crate::measure`]) and **interior cells** those at least two loops
//! from every edge (`2 ≤ b ≤ H − 2`, `2 ≤ c ≤ W − 3`):
//!
//! - **Gauge**: the course spacing `|P(b, c+1) − P(b, c)|` and the row spacing
//!   `|P(b+1, c) − P(b, c)|` between interior cells: median, 10th and 90th percentiles.
//! - **Turn per loop / per row**: the angle between consecutive steps of the course polyline
//!   `P(b, ·)` (resp. the wale polyline `P(·, c)`) at interior cells, in degrees: a flat
//!   fabric turns by 0, a fabric rolled with radius ρ by about `spacing/ρ` per cell.
//! - **Kept width / height**: the straight distance between the two edge cells of the
//!   middle row boundary (resp. the middle column) over the distance along the polyline:
//!   1 for a flat fabric, less for a curled or crumpled one.
//! - **Smallest roll radius** (in `d`): along those two middle polylines, the smallest
//!   `spacing/turn` over their cells: the tightest curl anywhere, edges included.
//!
//! For any knit (any chart):
//!
//! - **Unstitched approach**: the closest distance between two segments that are not
//!   stitched together (the exclusions of [`crate::forces::yarn_contact`]: sharing no node,
//!   no stitch contact, and not within two yarn diameters along one yarn), in `d`, and the
//!   fraction of segments with such a neighbour closer than 0.9 d. Two yarns that do not
//!   interpenetrate stay ≥ 1 d apart.
//! - **Wrapping-pair states**: the fraction of wrapping pairs
//!   ([`crate::forces::wrapping::wrap_pairs`]) with a wing within `asin 0.2 ≈ 11.5°` of the
//!   contact axis (the degenerate-wing state).
//! - **Leg joints**: the turn angle of the yarn at every stitch-contact node (degrees),
//!   and the fraction below 80° (bending jamming starts at 90°, §4.1).

use crate::forces::wrapping::wrap_pairs;
use crate::forces::yarn_contact::{Segments, close_pairs};
use crate::measure::{MeasureError, grid_cell, knit_size};
use crate::topology::Topology;
use rod::geometry::V3;

/// Median, 10th and 90th percentile of a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// 10th percentile.
    pub p10: f64,
    /// Median.
    pub median: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of `values` (nearest-rank percentiles); `None` if empty.
    pub fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let at = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        Some(Self {
            p10: at(0.1),
            median: at(0.5),
            p90: at(0.9),
            max: v[v.len() - 1],
        })
    }
}

/// Shape measures of a rectangular flat knit (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridShape {
    /// Course spacing between interior cells (d).
    pub course: Spread,
    /// Row spacing between interior cells (d).
    pub row: Spread,
    /// Turn per loop along the courses at interior cells (degrees).
    pub turn_per_loop: Spread,
    /// Turn per row along the wales at interior cells (degrees).
    pub turn_per_row: Spread,
    /// Straight over along-the-fabric distance, course direction (middle row boundary).
    pub kept_width: f64,
    /// Straight over along-the-fabric distance, wale direction (middle column).
    pub kept_height: f64,
    /// Smallest roll radius along the middle row boundary and the middle column (d).
    pub min_roll_radius: f64,
}

/// Interpenetration and stitch measures of any knit (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contacts {
    /// Closest distance between two segments not stitched together (d); infinite if no
    /// pair is within 2 d.
    pub closest_unstitched: f64,
    /// Fraction of segments with an unstitched neighbour closer than 0.9 d.
    pub under_09: f64,
    /// Fraction of wrapping pairs with a wing within asin 0.2 of the contact axis.
    pub degenerate_wings: f64,
    /// Turn of the yarn at the stitch-contact nodes (degrees; `None` without stitch
    /// contacts).
    pub leg_joint: Option<Spread>,
    /// Fraction of leg joints turning by less than 80°.
    pub leg_joints_below_80: f64,
}

/// Grid shape measures of a rectangular flat K/P knit at `positions`, lengths in units of
/// `diameter` (m). Errors unless the chart is rectangular, flat and at least 6 × 6 (so that
/// it has interior cells with interior neighbours).
pub fn grid_shape(
    topology: &Topology,
    positions: &[V3],
    diameter: f64,
) -> Result<GridShape, MeasureError> {
    let (w, h) = knit_size(topology, positions)?;
    if w < 6 || h < 6 {
        return Err(MeasureError::Invalid(format!(
            "{w} × {h} stitches: fidelity measures need ≥ 6 × 6"
        )));
    }
    let p = |b: usize, c: usize| grid_cell(positions, w, b, c);
    let (mut course, mut row, mut turn_c, mut turn_r) = (vec![], vec![], vec![], vec![]);
    let angle = |a: V3, b: V3| a.angle(&b).to_degrees();
    for b in 2..=h - 2 {
        for c in 2..=w - 3 {
            if c < w - 3 {
                course.push((p(b, c + 1) - p(b, c)).norm() / diameter);
            }
            if b < h - 2 {
                row.push((p(b + 1, c) - p(b, c)).norm() / diameter);
            }
            turn_c.push(angle(p(b, c) - p(b, c - 1), p(b, c + 1) - p(b, c)));
            turn_r.push(angle(p(b, c) - p(b - 1, c), p(b + 1, c) - p(b, c)));
        }
    }
    let course_line: Vec<V3> = (0..w).map(|c| p(h / 2, c)).collect();
    let wale_line: Vec<V3> = (0..=h).map(|b| p(b, w / 2)).collect();
    let kept = |line: &[V3]| {
        let along: f64 = line.windows(2).map(|s| (s[1] - s[0]).norm()).sum();
        (line[line.len() - 1] - line[0]).norm() / along
    };
    let roll = |line: &[V3]| {
        line.windows(3)
            .map(|s| {
                let (a, b) = (s[1] - s[0], s[2] - s[1]);
                let turn = a.angle(&b);
                match turn > 0.0 {
                    true => 0.5 * (a.norm() + b.norm()) / turn / diameter,
                    false => f64::INFINITY, // straight: no roll
                }
            })
            .fold(f64::INFINITY, f64::min)
    };
    let spread = |v: &[f64]| Spread::of(v).expect("interior cells exist");
    Ok(GridShape {
        course: spread(&course),
        row: spread(&row),
        turn_per_loop: spread(&turn_c),
        turn_per_row: spread(&turn_r),
        kept_width: kept(&course_line),
        kept_height: kept(&wale_line),
        min_roll_radius: roll(&course_line).min(roll(&wale_line)),
    })
}

/// Interpenetration and stitch measures of any knit at `positions` (module documentation),
/// for a yarn of diameter `diameter` (m). Errors if `positions` has the wrong length.
pub fn contacts(
    topology: &Topology,
    positions: &[V3],
    diameter: f64,
) -> Result<Contacts, MeasureError> {
    if positions.len() != topology.nodes.len() {
        return Err(MeasureError::Invalid(format!(
            "{} positions for {} nodes",
            positions.len(),
            topology.nodes.len()
        )));
    }
    let segments = Segments::new(topology);
    let pairs = close_pairs(&segments, positions, 2.0 * diameter, 2.0 * diameter);
    let closest = pairs
        .iter()
        .map(|p| p.distance)
        .fold(f64::INFINITY, f64::min)
        / diameter;
    let mut near = vec![false; segments.segments.len()];
    for p in pairs.iter().filter(|p| p.distance < 0.9 * diameter) {
        near[p.a] = true;
        near[p.b] = true;
    }
    let n_segments = near.len().max(1);
    let under_09 = near.iter().filter(|&&n| n).count() as f64 / n_segments as f64;
    let (mut pairs_total, mut degenerate) = (0usize, 0usize);
    for sc in &topology.stitch_contacts {
        for [q0, q1, q4, q3] in wrap_pairs(topology, sc).into_iter().flatten() {
            let axis = positions[q1] - positions[q0];
            let sine = |wing: V3| axis.cross(&wing).norm() / (axis.norm() * wing.norm());
            let (sa, sb) = (
                sine(positions[q4] - positions[q0]),
                sine(positions[q3] - positions[q1]),
            );
            pairs_total += 1;
            degenerate += usize::from(sa.min(sb) < 0.2);
        }
    }
    let mut joints = Vec::new();
    let in_contact: std::collections::HashSet<usize> = (topology.stitch_contacts.iter())
        .flat_map(|sc| sc.nodes)
        .collect();
    for yarn in &topology.yarns {
        for w in yarn.passes.windows(3) {
            if in_contact.contains(&w[1].node) {
                let (a, b) = (
                    positions[w[1].node] - positions[w[0].node],
                    positions[w[2].node] - positions[w[1].node],
                );
                joints.push(a.angle(&b).to_degrees());
            }
        }
    }
    let below = joints.iter().filter(|&&a| a < 80.0).count() as f64 / joints.len().max(1) as f64;
    Ok(Contacts {
        closest_unstitched: closest,
        under_09,
        degenerate_wings: degenerate as f64 / pairs_total.max(1) as f64,
        leg_joint: Spread::of(&joints),
        leg_joints_below_80: below,
    })
}
