//! Contact pairs: the broad phase over the 3 × 3 periodic images (skipping neighbours along
//! one yarn strand), the deformed segments of a problem's pairs and their closest approach.

use super::{PeriodicError, PeriodicTile, YarnModel};
use crate::coarse::Coarse;
use nalgebra::Vector3;
use rod::contact::closest_points;
use yarn_pattern::tile::Tile;

/// An unordered pair of edges in contact: edge `b` taken in the image shifted by `image`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ContactPair {
    /// First edge.
    pub a: usize,
    /// Second edge.
    pub b: usize,
    /// Period shift of edge `b`'s copy.
    pub image: [i32; 2],
}

impl PeriodicTile<'_> {
    /// The smallest centre-line distance (m) between the two edges of any contact pair of this
    /// problem at the DOFs `x` (`+∞` without pairs).
    pub fn closest_approach(&self, x: &[f64]) -> f64 {
        self.pair_segments(x)
            .map(|(_, [a0, a1, b0, b1])| closest_points(&a0, &a1, &b0, &b1).2)
            .fold(f64::INFINITY, f64::min)
    }

    /// Every contact pair with the deformed end points `[a0, a1, b0, b1]` of its two edges.
    pub(super) fn pair_segments<'a>(
        &'a self,
        x: &'a [f64],
    ) -> impl Iterator<Item = (&'a ContactPair, [Vector3<f64>; 4])> + 'a {
        let (tile, c) = (self.tile, self.coarse);
        let pos = move |v: usize, shift: [i32; 2]| {
            let y = tile.positions[v] + tile.period_offset(shift);
            c.map(&y) + c.frame(&y) * Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2])
        };
        self.pairs.iter().map(move |p| {
            let (ea, eb) = (tile.edges[p.a], tile.edges[p.b]);
            let [i, j] = p.image;
            let ends = [
                pos(ea.v0, [0, 0]),
                pos(ea.v1, ea.shift),
                pos(eb.v0, p.image),
                pos(eb.v1, [eb.shift[0] + i, eb.shift[1] + j]),
            ];
            (p, ends)
        })
    }

    /// Contact pairs within `cutoff · margin` at DOFs `x` (broad phase over the 3 × 3 images).
    pub fn find_pairs(
        tile: &Tile,
        model: &YarnModel,
        coarse: &Coarse,
        x: &[f64],
        margin: f64,
    ) -> Result<Vec<ContactPair>, PeriodicError> {
        let topology = tile.topology()?;
        let n = tile.n_vertices();
        let pos = |v: usize, shift: [i32; 2]| {
            let y = tile.positions[v] + tile.period_offset(shift);
            coarse.map(&y) + coarse.frame(&y) * Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2])
        };
        // Arc position of every edge's start along its loop, loop lengths and total shifts.
        let loops = topology.loops();
        let mut loop_of = vec![0; n];
        let mut arc = vec![0.0; n];
        let mut loop_len = vec![0.0; loops.len()];
        let mut loop_shift = vec![[0i32; 2]; loops.len()];
        // Cumulative period shift of the edges before each edge along its loop: edge e (image
        // 0) continues the strand of the loop's first edge taken in image −cum[e].
        let mut cum = vec![[0i32; 2]; n];
        for (l, lp) in loops.iter().enumerate() {
            let mut s = 0.0;
            for &e in lp {
                loop_of[e] = l;
                arc[e] = s;
                cum[e] = loop_shift[l];
                s += tile.rest_lengths[e];
                loop_shift[l][0] += tile.edges[e].shift[0];
                loop_shift[l][1] += tile.edges[e].shift[1];
            }
            loop_len[l] = s;
        }
        // Distance along the yarn between edge a and edge b taken in image `t`, if both lie on
        // one yarn strand: a loop with total shift S continues into its image S, so, with d =
        // t − cum[b] + cum[a], the copies are on one strand iff d = k S (k integer), and b is k
        // loop lengths further along. A loop closed inside the tile (S = 0) is one strand only
        // for d = 0, measured around the loop.
        let arc_gap = |a: usize, b: usize, t: [i32; 2]| -> Option<f64> {
            let l = loop_of[a];
            if loop_of[b] != l {
                return None;
            }
            let s = loop_shift[l];
            let t = [t[0] - cum[b][0] + cum[a][0], t[1] - cum[b][1] + cum[a][1]];
            let k = if t == [0, 0] {
                0
            } else if s[0] != 0 && t[0] % s[0] == 0 {
                t[0] / s[0]
            } else if s[0] == 0 && s[1] != 0 && t[1] % s[1] == 0 {
                t[1] / s[1]
            } else {
                return None;
            };
            if [k * s[0], k * s[1]] != t {
                return None;
            }
            let (la, lb) = (tile.rest_lengths[a], tile.rest_lengths[b]);
            let interval_gap = |sa: f64, sb: f64| (sb - (sa + la)).max(sa - (sb + lb)).max(0.0);
            let sb = arc[b] + k as f64 * loop_len[l];
            let gap = if s == [0, 0] {
                [-1.0, 0.0, 1.0]
                    .iter()
                    .map(|w| interval_gap(arc[a], sb + w * loop_len[l]))
                    .fold(f64::INFINITY, f64::min)
            } else {
                interval_gap(arc[a], sb)
            };
            Some(gap)
        };
        let cutoff = model.contact_cutoff() * margin;
        // Every edge's end points in each of the 3 × 3 images (index 3(i+1) + (j+1)), mapped
        // once, and their bounding boxes: a pair whose boxes are farther apart than the cutoff
        // along some axis cannot come within it, so it skips the segment distance.
        let images: [[i32; 2]; 9] = std::array::from_fn(|k| [k as i32 / 3 - 1, k as i32 % 3 - 1]);
        let ends: Vec<[[Vector3<f64>; 2]; 9]> = (0..n)
            .map(|e| {
                let ed = tile.edges[e];
                std::array::from_fn(|k| {
                    let [i, j] = images[k];
                    [
                        pos(ed.v0, [i, j]),
                        pos(ed.v1, [ed.shift[0] + i, ed.shift[1] + j]),
                    ]
                })
            })
            .collect();
        let apart = |p: &[Vector3<f64>; 2], q: &[Vector3<f64>; 2]| {
            (0..3).any(|k| {
                p[0][k].min(p[1][k]) - q[0][k].max(q[1][k]) >= cutoff
                    || q[0][k].min(q[1][k]) - p[0][k].max(p[1][k]) >= cutoff
            })
        };
        let mut pairs = Vec::new();
        for a in 0..n {
            let [a0, a1] = ends[a][4];
            for b in a..n {
                for (k, &t) in images.iter().enumerate() {
                    if a == b && (t <= [0, 0]) {
                        continue; // an edge with itself only in half of the images
                    }
                    let [b0, b1] = ends[b][k];
                    if apart(&[a0, a1], &[b0, b1]) {
                        continue;
                    }
                    if let Some(gap) = arc_gap(a, b, t)
                        && gap < model.min_arc_separation
                    {
                        continue;
                    }
                    if closest_points(&a0, &a1, &b0, &b1).2 < cutoff {
                        pairs.push(ContactPair { a, b, image: t });
                    }
                }
            }
        }
        Ok(pairs)
    }
}
