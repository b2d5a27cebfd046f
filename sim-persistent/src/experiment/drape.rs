//! Drape measures of a swatch over a sphere (seed 000 §5.2.1 gives images only; these
//! follow the drape coefficient of fabric testing): the **drape ratio**, the projected area
//! on the horizontal plane (convex hull of the nodes) of the draped swatch over that of the
//! settled flat swatch (1: flat; smaller is more drape); the **corner drop**, the mean height
//! of the four layout corners below a yarn resting on the sphere's pole; the deepest
//! **penetration** of a node into the sphere (in R).

use rod::geometry::V3;

use crate::integrator::Simulator;

/// Area (m²) of the convex hull of the points' (x, y) projections (monotone chain).
pub fn projected_area(points: &[V3]) -> f64 {
    let mut p: Vec<(f64, f64)> = points.iter().map(|v| (v.x, v.y)).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup();
    if p.len() < 3 {
        return 0.0;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    let m = hull.len();
    0.5 * (0..m)
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % m]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        .abs()
}

/// The four layout corners: the nodes extremal in x + y and x − y.
pub fn corners(layout: &[V3]) -> [usize; 4] {
    let arg = |f: &dyn Fn(&V3) -> f64| {
        (0..layout.len())
            .max_by(|&a, &b| f(&layout[a]).total_cmp(&f(&layout[b])))
            .expect("a swatch has nodes")
    };
    [
        arg(&|v| v.x + v.y),
        arg(&|v| -v.x - v.y),
        arg(&|v| v.x - v.y),
        arg(&|v| v.y - v.x),
    ]
}

/// Total yarn length (m): the span of the sliding coordinates of every yarn.
pub fn yarn_length(sim: &Simulator) -> f64 {
    let q = &sim.state().q;
    sim.topology()
        .yarns
        .iter()
        .map(|y| {
            let (first, last) = (y.passes[0], y.passes[y.passes.len() - 1]);
            (q[sim.dofs().u(last.node, last.slot)] - q[sim.dofs().u(first.node, first.slot)]).abs()
        })
        .sum()
}

/// One measurement of a dropped swatch ([`super::sphere_drop`]).
#[derive(Clone, Copy, Debug)]
pub struct DrapeSample {
    /// Time since the release (s).
    pub time: f64,
    /// Kinetic energy (J).
    pub kinetic: f64,
    /// rms node speed `√(2 E_kin / M)` (m/s), M the yarn mass.
    pub rms_speed: f64,
    /// Projected area over the flat projected area ([`projected_area`]; 1: flat).
    pub drape_ratio: f64,
    /// Mean height of the four layout corners below a yarn resting on the sphere's pole (m).
    pub corner_drop: f64,
    /// Deepest penetration of a node into the sphere (in yarn radii R).
    pub penetration: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{Layout, LayoutParams};
    use crate::topology::Topology;
    use crate::weave::WeavePattern;

    /// The hull area of a square's corners with interior and duplicate points is the
    /// square's area; collinear and too few points give zero; heights are ignored.
    #[test]
    fn projected_area_is_the_convex_hull_area() {
        let mut pts = vec![
            V3::new(0.0, 0.0, 1.0),
            V3::new(2.0, 0.0, -3.0),
            V3::new(2.0, 2.0, 0.0),
            V3::new(0.0, 2.0, 5.0),
            V3::new(1.0, 1.0, 0.0),
            V3::new(0.5, 1.5, 2.0),
            V3::new(2.0, 2.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
        ];
        assert!((projected_area(&pts) - 4.0).abs() < 1e-12);
        // A point outside grows the hull by the triangle it adds.
        pts.push(V3::new(1.0, -1.0, 0.0));
        assert!((projected_area(&pts) - 5.0).abs() < 1e-12);
        let line: Vec<V3> = (0..5)
            .map(|k| V3::new(k as f64, 2.0 * k as f64, 0.0))
            .collect();
        assert_eq!(projected_area(&line), 0.0);
        assert_eq!(projected_area(&pts[..2]), 0.0);
    }

    /// The corners of a weave layout are its four corner crossings.
    #[test]
    fn corners_of_a_weave_layout() {
        let n = 4;
        let topo = Topology::weave(WeavePattern::Plain, n, n).unwrap();
        let layout = Layout::new(
            &topo,
            &LayoutParams::new(crate::experiment::swatch::LOOP_WIDTH, 0.75e-3),
        )
        .unwrap();
        let mut c = corners(&layout.positions).to_vec();
        c.sort_unstable();
        assert_eq!(c, vec![0, n - 1, n * (n - 1), n * n - 1]);
    }
}
