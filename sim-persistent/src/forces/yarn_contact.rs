//! Yarn self-contact: segment–segment contact between yarn pieces that are not stitched
//! together (ours; seed 000 has none, its persistent contacts cover only the stitches).
//!
//! The persistent contacts of [`crate::topology`] hold the yarns together where they are
//! knitted or woven together, but nothing else keeps one yarn out of another: a stockinette
//! that curls would roll through itself, and the loops of neighbouring rows could pass
//! through each other. This term adds the contact of seed 002 (Eq. 7, the two-phase IPC
//! barrier of [`rod::contact::EdgeContact`]) between every pair of segments that
//!
//! - share no node (segments meeting at a node are joined there),
//! - share no stitch contact (the yarns through the two nodes of a stitch contact are held
//!   there by the persistent contact itself, [`crate::topology::StitchContact`]), and
//! - are not pieces of one yarn closer than [`YarnContact::min_arc_separation`] along it (a
//!   yarn touches itself around every bend), and
//! - were not laid out through each other (centrelines closer than
//!   [`YarnContact::crossing_distance`] in the layout the simulator starts from,
//!   [`Segments::exclude_crossed`]),
//!
//! so that the same contact law acts in both simulators of the workbench.
//!
//! **Energy.** `W = Σᵢ k_cᵢ L_a L_b ∫₀¹∫₀¹ f(min(D(a,b)/2Rᵢ, 1)²) da db` with the phases
//! `(k_c, R)` of [`YarnContact::phases`] (the soft one at the yarn radius, so that contact
//! starts where the yarn surfaces touch, `D = 2R = d`; a stiff one inside it), `L_a`, `L_b`
//! the segment lengths when the pair was found (frozen, so `W` is a potential between two
//! pair searches), Simpson's rule along each segment.
//!
//! **Broad phase.** An R-tree (`rstar`) of the segments' bounding boxes, grown by the search
//! distance, finds every pair within `cutoff + margin` ([`close_pairs`]). The pairs are kept
//! as a Verlet list: [`crate::integrator::Simulator`] searches again when a node has moved
//! more than half the margin since the last search, so no pair can come within the cutoff
//! unseen between two searches (each node moved less than `margin/2`).
//!
//! **Why a barrier and not a penalty.** The IPC barrier grows without bound as two segments
//! meet, so a Newton step that would pass one yarn through another is cut back by the line
//! search; a finite penalty lets a fast enough yarn through.

use crate::state::DofMap;
use crate::topology::Topology;
use rod::contact::{BarrierPhase, EdgeContact, Simpson, closest_points};
use rod::geometry::V3;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{AABB, RTree, RTreeObject};

/// One yarn segment: the segment `i` of yarn `yarn`, from pass `i` to pass `i + 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Yarn index.
    pub yarn: usize,
    /// The nodes at its two ends.
    pub nodes: [usize; 2],
    /// The stitch contact each end node belongs to, if any.
    pub contacts: [Option<usize>; 2],
}

/// The segments of a topology with what [`close_pairs`] needs to exclude pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct Segments {
    /// Every segment, yarn by yarn, in yarn order ([`Topology::segments`]).
    pub segments: Vec<Segment>,
    /// Index of each yarn's first segment in `segments` (and the total at the end).
    pub first: Vec<usize>,
    /// Pairs `(a, b)`, `a < b`, excluded because they were laid out through each other
    /// ([`Segments::exclude_crossed`]).
    pub crossed: std::collections::BTreeSet<(usize, usize)>,
}

impl Segments {
    /// The segments of `topology`.
    pub fn new(topology: &Topology) -> Self {
        let mut contact_of = vec![None; topology.nodes.len()];
        for (k, sc) in topology.stitch_contacts.iter().enumerate() {
            for &n in &sc.nodes {
                contact_of[n] = Some(k);
            }
        }
        let mut segments = Vec::new();
        let mut first = Vec::with_capacity(topology.yarns.len() + 1);
        for (y, yarn) in topology.yarns.iter().enumerate() {
            first.push(segments.len());
            for w in yarn.passes.windows(2) {
                let nodes = [w[0].node, w[1].node];
                segments.push(Segment {
                    yarn: y,
                    nodes,
                    contacts: nodes.map(|n| contact_of[n]),
                });
            }
        }
        first.push(segments.len());
        Self {
            segments,
            first,
            crossed: Default::default(),
        }
    }

    /// Excludes from contact, for good, every pair that `positions` (a layout) puts closer
    /// than `distance` (m; the simulator uses [`YarnContact::crossing_distance`]), and
    /// returns how many. Such segments were laid out through each other (the flat layout of
    /// a shaped or lace chart lets a leaning decrease leg cross its neighbours' legs), so
    /// contact cannot know on which side of each other they belong, and its barrier,
    /// infinite where centrelines meet, cannot start there. They are left to the persistent
    /// contacts. Pairs laid out farther apart are pushed apart by the contact ramp instead
    /// ([`crate::integrator`]).
    pub fn exclude_crossed(&mut self, positions: &[V3], distance: f64, min_arc: f64) -> usize {
        let pairs = close_pairs(self, positions, distance, min_arc);
        self.crossed.extend(pairs.iter().map(|p| (p.a, p.b)));
        pairs.len()
    }

    /// Arc length (m) at the start of every segment along its yarn at `positions`, and at
    /// the end of each yarn's last one (`arc[k + 1]` for segment `k` of a yarn is valid within
    /// the yarn: index `k + yarn + 1` in the returned list).
    fn arcs(&self, positions: &[V3]) -> Vec<f64> {
        let mut arc = Vec::with_capacity(self.segments.len() + self.first.len());
        for y in 0..self.first.len() - 1 {
            let mut s = 0.0;
            arc.push(s);
            for seg in &self.segments[self.first[y]..self.first[y + 1]] {
                s += (positions[seg.nodes[1]] - positions[seg.nodes[0]]).norm();
                arc.push(s);
            }
        }
        arc
    }

    /// Closest distance (m) between the centrelines of segments `a` and `b` at `positions`.
    pub fn distance(&self, a: usize, b: usize, positions: &[V3]) -> f64 {
        let (sa, sb) = (&self.segments[a], &self.segments[b]);
        let [p0, p1] = sa.nodes.map(|n| positions[n]);
        let [q0, q1] = sb.nodes.map(|n| positions[n]);
        closest_points(&p0, &p1, &q0, &q1).2
    }

    /// Whether segments `a` and `b` are excluded from contact (module documentation): they
    /// share a node or a stitch contact, were laid out through each other
    /// ([`Segments::exclude_crossed`]), or lie on one yarn less than `min_arc` apart along it
    /// (`arc` from [`Segments::arcs`]).
    fn excluded(&self, a: usize, b: usize, arc: &[f64], min_arc: f64) -> bool {
        let (sa, sb) = (&self.segments[a], &self.segments[b]);
        if sa.nodes.iter().any(|n| sb.nodes.contains(n)) {
            return true;
        }
        if self.crossed.contains(&(a.min(b), a.max(b))) {
            return true;
        }
        if sa
            .contacts
            .iter()
            .flatten()
            .any(|c| sb.contacts.contains(&Some(*c)))
        {
            return true;
        }
        if sa.yarn == sb.yarn {
            // Arc intervals [start, end] of each segment; index shift by the yarn number.
            let at = |k: usize| {
                let i = k + self.segments[k].yarn;
                (arc[i], arc[i + 1])
            };
            let ((a0, a1), (b0, b1)) = (at(a), at(b));
            let gap = (b0 - a1).max(a0 - b1).max(0.0);
            return gap < min_arc;
        }
        false
    }
}

/// A pair of segments within the search distance: indices into [`Segments::segments`]
/// (`a < b`) and their centreline distance (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosePair {
    /// First segment.
    pub a: usize,
    /// Second segment (`> a`).
    pub b: usize,
    /// Closest distance between the two centrelines (m).
    pub distance: f64,
}

/// Every pair of segments of `segments` closer than `distance` (m) at node `positions`,
/// except the excluded pairs (module documentation; `min_arc` in m), sorted by `(a, b)`.
/// Broad phase: an R-tree of the segments' boxes grown by `distance`.
pub fn close_pairs(
    segments: &Segments,
    positions: &[V3],
    distance: f64,
    min_arc: f64,
) -> Vec<ClosePair> {
    let boxes: Vec<GeomWithData<Rectangle<[f64; 3]>, usize>> = (segments.segments.iter())
        .enumerate()
        .map(|(k, s)| {
            let (p, q) = (positions[s.nodes[0]], positions[s.nodes[1]]);
            let lo = [p.x.min(q.x), p.y.min(q.y), p.z.min(q.z)];
            let hi = [p.x.max(q.x), p.y.max(q.y), p.z.max(q.z)];
            GeomWithData::new(Rectangle::from_corners(lo, hi), k)
        })
        .collect();
    let arc = segments.arcs(positions);
    let tree = RTree::bulk_load(boxes.clone());
    let mut pairs = Vec::new();
    for item in &boxes {
        let a = item.data;
        let env = item.geom().envelope();
        let (lo, hi) = (env.lower(), env.upper());
        let grown = AABB::from_corners(
            [lo[0] - distance, lo[1] - distance, lo[2] - distance],
            [hi[0] + distance, hi[1] + distance, hi[2] + distance],
        );
        for other in tree.locate_in_envelope_intersecting(grown) {
            let b = other.data;
            if b <= a || segments.excluded(a, b, &arc, min_arc) {
                continue;
            }
            let d = segments.distance(a, b, positions);
            if d < distance {
                pairs.push(ClosePair { a, b, distance: d });
            }
        }
    }
    pairs.sort_by_key(|p| (p.a, p.b));
    pairs
}

/// Parameters of yarn self-contact (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YarnContact {
    /// The barrier phases `(k_c (J/m²), R (m))`: contact acts below centreline distances
    /// `2R`. Default ([`YarnContact::for_yarn`]): the yarn radius with `k_c = k_b/R⁴`,
    /// and a stiff phase (`100 k_c`) at `0.8 R`, which stops deep penetrations below
    /// `0.8 d`. `k_c` is the smallest power of ten that keeps every unstitched pair of the
    /// free stockinette, garter, 2×2 rib and seed swatches laid out at Table 1's 3 mm
    /// loops, which start crowded, above 0.9 d (the `knit-fidelity` figure): a softer
    /// barrier lets them settle inside the soft phase.
    pub phases: [BarrierPhase; 2],
    /// Quadrature along each segment. Default: Simpson with 4 intervals (5 points: a
    /// segment of the default knit layouts is 1–2 yarn diameters long, so the points are at
    /// most half a diameter apart).
    pub quadrature: Simpson,
    /// Pieces of one yarn closer than this along it do not contact each other (m). Default:
    /// two yarn diameters (4R, as seed 002's `min_arc_separation`).
    pub min_arc_separation: f64,
    /// Extra search distance of the Verlet list (m). Default: one yarn diameter.
    pub margin: f64,
}

impl YarnContact {
    /// Defaults for a yarn of radius `radius` (m) and bending stiffness `k_b` (N·m²): the
    /// stiffness scales with `k_b/R⁴`, so that contact and bending forces keep their ratio
    /// across yarn sizes.
    pub fn for_yarn(radius: f64, bending_stiffness: f64) -> Self {
        let k = bending_stiffness / radius.powi(4);
        Self {
            phases: [
                BarrierPhase {
                    stiffness: k,
                    radius,
                },
                BarrierPhase {
                    stiffness: 100.0 * k,
                    radius: 0.8 * radius,
                },
            ],
            quadrature: Simpson { intervals: 4 },
            min_arc_separation: 4.0 * radius,
            margin: 2.0 * radius,
        }
    }

    /// Centreline distance (m) below which a pair of the starting layout counts as laid out
    /// through each other and is excluded from contact ([`Segments::exclude_crossed`]): the
    /// soft phase's radius (the yarn radius, half the contact distance). Closer pairs are
    /// more than half inside each other; the contact ramp cannot push them apart (with a
    /// tenth of it, the shaped chart of `tests/stacked.rs` stalls Newton as the ramp ends).
    pub fn crossing_distance(&self) -> f64 {
        self.phases[0].radius
    }

    /// Centreline distance (m) beyond which a pair has no energy.
    pub fn cutoff(&self) -> f64 {
        2.0 * self.phases[0].radius.max(self.phases[1].radius)
    }

    /// The contact stencils of every pair of `segments` within `cutoff + margin` at the node
    /// `positions`, with the position DOFs `(x_a0, x_a1, x_b0, x_b1)` of each.
    pub fn stencils(
        &self,
        segments: &Segments,
        dofs: &DofMap,
        positions: &[V3],
    ) -> Vec<(EdgeContact, [usize; 12])> {
        let pairs = close_pairs(
            segments,
            positions,
            self.cutoff() + self.margin,
            self.min_arc_separation,
        );
        pairs
            .iter()
            .map(|p| {
                let (sa, sb) = (&segments.segments[p.a], &segments.segments[p.b]);
                let nodes = [sa.nodes[0], sa.nodes[1], sb.nodes[0], sb.nodes[1]];
                let length = |s: &Segment| (positions[s.nodes[1]] - positions[s.nodes[0]]).norm();
                let contact = EdgeContact {
                    phases: self.phases,
                    rest_lengths: (length(sa), length(sb)),
                    quadrature: self.quadrature,
                };
                let d: [usize; 12] = std::array::from_fn(|k| dofs.x(nodes[k / 3]) + k % 3);
                (contact, d)
            })
            .collect()
    }

    /// Checks that the parameters are finite and in range.
    pub fn validate(&self) -> Result<(), String> {
        for p in &self.phases {
            if !(p.stiffness.is_finite() && p.stiffness >= 0.0) {
                return Err(format!(
                    "contact stiffness must be ≥ 0, got {}",
                    p.stiffness
                ));
            }
            if !(p.radius.is_finite() && p.radius > 0.0) {
                return Err(format!("contact radius must be > 0, got {}", p.radius));
            }
        }
        for (name, v) in [
            ("min_arc_separation", self.min_arc_separation),
            ("margin", self.margin),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "yarn contact {name} must be finite and ≥ 0, got {v}"
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::Chart;

    /// Brute force over all pairs agrees with the R-tree search, and no returned pair is
    /// excluded; a larger search distance finds a superset.
    #[test]
    fn the_broad_phase_finds_what_brute_force_finds() {
        let topo = Topology::knit(&Chart::stockinette(5, 4).unwrap());
        let segments = Segments::new(&topo);
        // A crumpled configuration: the layout folded by a deterministic perturbation.
        let positions: Vec<V3> = (0..topo.nodes.len())
            .map(|n| {
                let t = n as f64;
                V3::new(
                    1e-3 * (0.37 * t).sin(),
                    1e-3 * (0.23 * t).cos(),
                    1e-3 * (0.11 * t).sin(),
                )
            })
            .collect();
        let arc = segments.arcs(&positions);
        let (distance, min_arc) = (0.4e-3, 1.5e-3);
        let found = close_pairs(&segments, &positions, distance, min_arc);
        let n = segments.segments.len();
        let mut brute = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                if segments.excluded(a, b, &arc, min_arc) {
                    continue;
                }
                if segments.distance(a, b, &positions) < distance {
                    brute.push((a, b));
                }
            }
        }
        let ids: Vec<(usize, usize)> = found.iter().map(|p| (p.a, p.b)).collect();
        assert!(!ids.is_empty());
        assert_eq!(ids, brute);
        let wider = close_pairs(&segments, &positions, 2.0 * distance, min_arc);
        assert!(ids.iter().all(|p| wider.iter().any(|w| (w.a, w.b) == *p)));
    }

    /// The exclusions: segments meeting at a node, the segments through the two nodes of one
    /// stitch contact, and one yarn's pieces closer than `min_arc` along it.
    #[test]
    fn stitched_and_neighbouring_segments_are_excluded() {
        let topo = Topology::knit(&Chart::stockinette(3, 3).unwrap());
        let segments = Segments::new(&topo);
        let positions = vec![V3::zeros(); topo.nodes.len()];
        let arc = segments.arcs(&positions);
        let sc = &topo.stitch_contacts[0];
        let through = |n: usize| {
            (0..segments.segments.len())
                .filter(|&k| segments.segments[k].nodes.contains(&n))
                .collect::<Vec<_>>()
        };
        for &a in &through(sc.nodes[0]) {
            for &b in &through(sc.nodes[1]) {
                if a != b {
                    assert!(segments.excluded(a, b, &arc, 0.0), "{a} {b}");
                }
            }
        }
        // With all nodes at one point every pair of one yarn is within any positive arc
        // distance, and pairs of different yarns that share nothing are not excluded.
        assert!(segments.excluded(0, 3, &arc, 1e-9));
        let (y0, y1) = (segments.first[0], segments.first[1]);
        let other = (y1..segments.first[2])
            .find(|&b| !segments.excluded(y0, b, &arc, 0.0))
            .expect("a pair of rows that share no contact");
        assert_ne!(segments.segments[y0].yarn, segments.segments[other].yarn);
    }
}
