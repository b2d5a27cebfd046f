//! Yarns, persistent contact nodes and stitch contacts (seed 000 §3.2).
//!
//! A [`Topology`] is the combinatorial part of a fabric:
//!
//! - **Nodes** are persistent contacts `q = (x, u₁ … uₙ)` (seed 000 §3.2): one position and one
//!   sliding (arc-length) coordinate per yarn pass through the node. The data structures allow
//!   any `n ≥ 1` (stacked stitches, §3.2.3, come later); the builders here make `n = 1`
//!   (fabric edges) and `n = 2` nodes.
//! - **Yarns** are ordered lists of [`Pass`]es: which node the yarn goes through and which of
//!   the node's sliding coordinates is this yarn's. The yarn is straight between consecutive
//!   passes (a segment).
//! - **Stitch contacts** (knits, §3.2.2) are node pairs: where a loop of row `r` goes through
//!   the loop of row `r − 1`, the two yarns wrap around each other along a short stretch whose
//!   two end points are two contact nodes shared by both yarns. Each loop has two stitch
//!   contacts with the loop below (left and right leg) and two with the loop above, hence
//!   shares 8 nodes, and `N` loops make about `4N` nodes and `20N` DoFs (§3.2.2).
//! - **Crossings** (weaves, §3.2.1): one node shared by a warp and a weft yarn (5 DoFs).
//!
//! **Knit construction.** The chart's loop `(r, c)` sits in row `r`, column `c`. Row-boundary
//! `b ∈ 0..=H` lies below row `b` (so boundary `b` holds the stitch contacts between the head
//! of loop `(b − 1, c)` and the legs of loop `(b, c)`). Every boundary has, per column, a left
//! and a right contact with a `lo` and a `hi` node. Yarn `r` (one yarn per row, left to right)
//! visits per loop
//!
//! ```text
//! (b=r, L, lo) (r, L, hi) (r+1, L, lo) (r+1, L, hi) (r+1, R, hi) (r+1, R, lo) (r, R, hi) (r, R, lo)
//!  foot ─────── left leg ──────────── head ─────────────────────── right leg ──────── foot
//! ```
//!
//! so both yarns of a contact traverse its two nodes consecutively and in the same order.
//! Boundary 0 (cast-on) and boundary `H` (bind-off) nodes carry only one yarn. Simplification:
//! a real knit is one continuous yarn turning back at the row ends (§3.1); here each row is
//! its own yarn whose ends are tied to the fabric (pinned sliding). The row-end turns are
//! future work.
//!
//! **Stable edges.** A node with a single yarn has that yarn's sliding coordinate pinned (a
//! one-yarn node is a material point of the yarn: this keeps the cast-on and bind-off loops
//! from unravelling), and so has the first and the last pass of every yarn (yarn ends are tied
//! to the fabric, §3.1). See [`NodePass::sliding_pinned`].

use crate::chart::{Chart, Stitch};
use crate::weave::WeavePattern;

/// One pass of a yarn through a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pass {
    /// Node index.
    pub node: usize,
    /// Which of the node's sliding coordinates belongs to this pass (index into
    /// [`Node::passes`]).
    pub slot: usize,
}

/// A yarn: the ordered nodes it goes through.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Yarn {
    /// Passes in yarn order (arc length increases along the list).
    pub passes: Vec<Pass>,
}

/// One sliding coordinate of a node: which yarn pass it belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodePass {
    /// Yarn index.
    pub yarn: usize,
    /// Index of the pass within the yarn.
    pub index: usize,
    /// Whether this sliding coordinate is held fixed (one-yarn nodes and yarn ends; see the
    /// module documentation).
    pub sliding_pinned: bool,
}

/// A persistent contact node `q = (x, u₁ … uₙ)`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Node {
    /// The `n` yarn passes through the node, one sliding coordinate each (slot order).
    pub passes: Vec<NodePass>,
}

/// Which leg of a loop a stitch contact belongs to (front view).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Left leg.
    Left,
    /// Right leg.
    Right,
}

/// A two-yarn stitch contact (seed 000 §3.2.2, Fig. 8): two nodes shared by the leg of the
/// upper loop and the head of the lower loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StitchContact {
    /// The contact's end nodes `[q₀, q₁]` (Fig. 8) in yarn order: both yarns visit `q₀` then
    /// `q₁` (`lo` then `hi` for left contacts, `hi` then `lo` for right contacts).
    pub nodes: [usize; 2],
    /// `[upper, lower]`: the yarn of the row whose legs go through (row `r`), and the yarn of
    /// the row whose head they go through (row `r − 1`).
    pub yarns: [usize; 2],
    /// The stitch (knit or purl, front view) of the upper loop.
    pub stitch: Stitch,
    /// Row of the upper loop (≥ 1).
    pub row: usize,
    /// Column of both loops.
    pub column: usize,
    /// Which leg of the upper loop.
    pub side: Side,
}

/// A warp × weft crossing of a weave (seed 000 §3.2.1): one node shared by both yarns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crossing {
    /// The node.
    pub node: usize,
    /// Warp column `i` and weft row `j`.
    pub warp: usize,
    /// Weft row `j`.
    pub weft: usize,
    /// Whether the warp lies on top (used for crimp and rendering offsets).
    pub warp_over: bool,
}

/// What a topology was built from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FabricKind {
    /// A knit from a chart.
    Knit(Chart),
    /// A `warps × wefts` weave.
    Weave {
        /// The weave pattern.
        pattern: WeavePattern,
        /// Number of warp yarns (columns).
        warps: usize,
        /// Number of weft yarns (rows).
        wefts: usize,
    },
}

/// A topology that cannot be built.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TopologyError {
    /// Invalid size or pattern parameters.
    #[error("invalid fabric: {0}")]
    Invalid(String),
}

/// Nodes, yarns, stitch contacts and crossings of a fabric (see the module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Contact nodes.
    pub nodes: Vec<Node>,
    /// Yarns as ordered node passes.
    pub yarns: Vec<Yarn>,
    /// Two-yarn stitch contacts (knits).
    pub stitch_contacts: Vec<StitchContact>,
    /// Crossings (weaves).
    pub crossings: Vec<Crossing>,
    /// What the topology was built from.
    pub kind: FabricKind,
}

/// Node index of (boundary `b`, column `c`, side, end) in a knit of width `w`.
pub fn knit_node(w: usize, b: usize, c: usize, side: Side, hi: bool) -> usize {
    ((b * w + c) * 2 + side as usize) * 2 + hi as usize
}

/// Every node of row boundary `b` of a knit of width `w` (both contacts of every column, `lo`
/// then `hi`, columns left to right): a clamp over a cast-on (`b = 0`), bind-off (`b = H`) or
/// interior row boundary.
pub fn knit_boundary_nodes(w: usize, b: usize) -> Vec<usize> {
    (0..w)
        .flat_map(|c| {
            [Side::Left, Side::Right]
                .into_iter()
                .flat_map(move |s| [knit_node(w, b, c, s, false), knit_node(w, b, c, s, true)])
        })
        .collect()
}

/// Every node of column `c` of a knit `w` wide and `h` rows tall (all boundaries `0..=h`, both
/// contacts, `lo` then `hi`): a clamp over a side edge.
pub fn knit_column_nodes(w: usize, h: usize, c: usize) -> Vec<usize> {
    (0..=h)
        .flat_map(|b| {
            [Side::Left, Side::Right]
                .into_iter()
                .flat_map(move |s| [knit_node(w, b, c, s, false), knit_node(w, b, c, s, true)])
        })
        .collect()
}

impl Topology {
    /// The knit of `chart`: one yarn per row, two nodes per stitch contact (module docs).
    pub fn knit(chart: &Chart) -> Self {
        let (w, h) = (chart.width(), chart.height());
        let node = |b, c, side, hi| knit_node(w, b, c, side, hi);
        let yarn_nodes: Vec<Vec<usize>> = (0..h)
            .map(|r| {
                (0..w)
                    .flat_map(|c| {
                        [
                            node(r, c, Side::Left, false),
                            node(r, c, Side::Left, true),
                            node(r + 1, c, Side::Left, false),
                            node(r + 1, c, Side::Left, true),
                            node(r + 1, c, Side::Right, true),
                            node(r + 1, c, Side::Right, false),
                            node(r, c, Side::Right, true),
                            node(r, c, Side::Right, false),
                        ]
                    })
                    .collect()
            })
            .collect();
        let mut stitch_contacts = Vec::new();
        for b in 1..h {
            for c in 0..w {
                for side in [Side::Left, Side::Right] {
                    // Both yarns run up-right through left contacts (lo → hi) and down-right
                    // through right contacts (hi → lo).
                    let lo_first = side == Side::Left;
                    stitch_contacts.push(StitchContact {
                        nodes: [node(b, c, side, !lo_first), node(b, c, side, lo_first)],
                        yarns: [b, b - 1],
                        stitch: chart.stitch(b, c),
                        row: b,
                        column: c,
                        side,
                    });
                }
            }
        }
        let n_nodes = 4 * w * (h + 1);
        let mut topo = Self::from_yarn_nodes(n_nodes, &yarn_nodes, FabricKind::Knit(chart.clone()));
        topo.stitch_contacts = stitch_contacts;
        topo
    }

    /// A `warps × wefts` weave: node `j · warps + i` is the crossing of warp `i` and weft `j`;
    /// yarns `0..wefts` are the wefts (along x), yarns `wefts..wefts + warps` the warps.
    /// Slot 0 of every node is the weft, slot 1 the warp.
    pub fn weave(pattern: WeavePattern, warps: usize, wefts: usize) -> Result<Self, TopologyError> {
        pattern.validate().map_err(TopologyError::Invalid)?;
        if warps < 2 || wefts < 2 {
            return Err(TopologyError::Invalid(format!(
                "weave {warps} × {wefts}: needs ≥ 2 warps and ≥ 2 wefts"
            )));
        }
        let mut yarn_nodes: Vec<Vec<usize>> = (0..wefts)
            .map(|j| (0..warps).map(|i| j * warps + i).collect())
            .collect();
        yarn_nodes.extend((0..warps).map(|i| (0..wefts).map(|j| j * warps + i).collect()));
        let kind = FabricKind::Weave {
            pattern,
            warps,
            wefts,
        };
        let mut topo = Self::from_yarn_nodes(warps * wefts, &yarn_nodes, kind);
        topo.crossings = (0..wefts)
            .flat_map(|j| {
                (0..warps).map(move |i| Crossing {
                    node: j * warps + i,
                    warp: i,
                    weft: j,
                    warp_over: pattern.warp_over(i, j),
                })
            })
            .collect();
        Ok(topo)
    }

    /// Builds nodes and yarns from per-yarn node lists; slots are numbered in yarn order
    /// (yarn 0's passes first). Applies the pinning rules of the module documentation.
    fn from_yarn_nodes(n_nodes: usize, yarn_nodes: &[Vec<usize>], kind: FabricKind) -> Self {
        let mut nodes = vec![Node { passes: Vec::new() }; n_nodes];
        let yarns = yarn_nodes
            .iter()
            .enumerate()
            .map(|(y, list)| Yarn {
                passes: list
                    .iter()
                    .enumerate()
                    .map(|(index, &n)| {
                        let slot = nodes[n].passes.len();
                        nodes[n].passes.push(NodePass {
                            yarn: y,
                            index,
                            sliding_pinned: index == 0 || index + 1 == list.len(),
                        });
                        Pass { node: n, slot }
                    })
                    .collect(),
            })
            .collect();
        for node in &mut nodes {
            if node.passes.len() == 1 {
                node.passes[0].sliding_pinned = true;
            }
        }
        Self {
            nodes,
            yarns,
            stitch_contacts: Vec::new(),
            crossings: Vec::new(),
            kind,
        }
    }

    /// Number of sliding coordinates over all nodes (`Σ n`).
    pub fn n_passes(&self) -> usize {
        self.nodes.iter().map(|n| n.passes.len()).sum()
    }

    /// Number of generalized coordinates: `Σ (3 + n)` over the nodes.
    pub fn n_dofs(&self) -> usize {
        3 * self.nodes.len() + self.n_passes()
    }

    /// Segments `(yarn, pass index i)` between passes `i` and `i + 1` of each yarn.
    pub fn segments(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.yarns
            .iter()
            .enumerate()
            .flat_map(|(y, yarn)| (0..yarn.passes.len().saturating_sub(1)).map(move |i| (y, i)))
    }

    /// Interior passes `(yarn, pass index i)` with a pass on both sides (bending stencils).
    pub fn bends(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.yarns
            .iter()
            .enumerate()
            .flat_map(|(y, yarn)| (1..yarn.passes.len().saturating_sub(1)).map(move |i| (y, i)))
    }

    /// Checks the cross references between yarns and nodes; `Err` describes the first
    /// inconsistency (used by tests and after hand-made edits).
    pub fn validate(&self) -> Result<(), TopologyError> {
        let bad = |m: String| Err(TopologyError::Invalid(m));
        for (y, yarn) in self.yarns.iter().enumerate() {
            if yarn.passes.len() < 2 {
                return bad(format!("yarn {y} has fewer than 2 passes"));
            }
            for (i, p) in yarn.passes.iter().enumerate() {
                let Some(np) = self.nodes.get(p.node).and_then(|n| n.passes.get(p.slot)) else {
                    return bad(format!("yarn {y} pass {i} points to a missing node slot"));
                };
                if np.yarn != y || np.index != i {
                    return bad(format!(
                        "yarn {y} pass {i}: node {} slot {} disagrees",
                        p.node, p.slot
                    ));
                }
                if i > 0 && yarn.passes[i - 1].node == p.node {
                    return bad(format!("yarn {y} visits node {} twice in a row", p.node));
                }
            }
        }
        for (n, node) in self.nodes.iter().enumerate() {
            if node.passes.is_empty() {
                return bad(format!("node {n} has no yarn"));
            }
            for (s, np) in node.passes.iter().enumerate() {
                let ok = self
                    .yarns
                    .get(np.yarn)
                    .and_then(|y| y.passes.get(np.index))
                    .is_some_and(|p| p.node == n && p.slot == s);
                if !ok {
                    return bad(format!("node {n} slot {s} is not on its yarn"));
                }
            }
        }
        for (k, sc) in self.stitch_contacts.iter().enumerate() {
            for &y in &sc.yarns {
                let i0 = self.pass_index(sc.nodes[0], y);
                let i1 = self.pass_index(sc.nodes[1], y);
                match (i0, i1) {
                    (Some(a), Some(b)) if b == a + 1 => {}
                    _ => return bad(format!("stitch contact {k}: yarn {y} does not run q₀ → q₁")),
                }
            }
        }
        Ok(())
    }

    /// Index within yarn `yarn` of its (first) pass through `node`, if any.
    pub fn pass_index(&self, node: usize, yarn: usize) -> Option<usize> {
        self.nodes[node]
            .passes
            .iter()
            .find(|p| p.yarn == yarn)
            .map(|p| p.index)
    }
}
