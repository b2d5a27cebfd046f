//! Yarns, persistent contact nodes and stitch contacts (seed 000 §3.2).
//!
//! A [`Topology`] is the combinatorial part of a fabric:
//!
//! - **Nodes** are persistent contacts `q = (x, u₁ … uₙ)` (seed 000 §3.2): one position and one
//!   sliding (arc-length) coordinate per yarn pass through the node. The data structures allow
//!   any `n ≥ 1`: `n = 1` at fabric edges, `n = 2` for simple stitches and crossings, `n > 2`
//!   for the stacked stitches of decreases (§3.2.3).
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
//! **Knit construction** ([`knit`]). Row-boundary `b ∈ 0..=H` lies below row `b`; it holds
//! one cell of four nodes (left and right contact, `lo` and `hi` each) per loop of row `b`
//! that is pulled through something, and boundary `H` (bind-off) one per loop of the last
//! row. For a rectangular K/P chart, cell `c` of boundary `b` is column `c` and the nodes are
//! [`knit_node`]`(w, b, c, side, hi)`; yarn `r` (one yarn per row, left to right) visits per loop
//!
//! ```text
//! (b=r, L, lo) (r, L, hi) (r+1, L, lo) (r+1, L, hi) (r+1, R, hi) (r+1, R, lo) (r, R, hi) (r, R, lo)
//!  foot ─────── left leg ──────────── head ─────────────────────── right leg ──────── foot
//! ```
//!
//! Decreases stack the heads of two or three loops in the cell of the new loop: its nodes
//! then carry `2 + n` yarn passes (§3.2.3); increases, yarn-overs and slipped loops follow
//! [`knit`]. Boundary 0 (cast-on) and boundary `H` (bind-off) nodes carry only one yarn.
//! [`Construction`] says how the rows are joined: each row its own yarn whose ends are
//! tied to the fabric (pinned sliding; the first version's model and the default), one
//! continuous yarn turning back at the row ends (§3.1: "when the yarn reaches the end of a
//! row, it is typically bent back to form the next row"), or one yarn spiralling round a
//! tube. A [`StitchContact`] names its yarn passes as [`Strand`]s, so one yarn may pass a
//! contact several times (a decrease of one row's loops, or the rows of a continuous yarn)
//! and in either direction.
//!
//! **Stable edges.** A node with a single yarn has that yarn's sliding coordinate pinned (a
//! one-yarn node is a material point of the yarn: this keeps the cast-on and bind-off loops
//! from unravelling), and so has the first and the last pass of every yarn (yarn ends are tied
//! to the fabric, §3.1). See [`NodePass::sliding_pinned`].

pub mod knit;

use crate::chart::Chart;
use crate::weave::WeavePattern;
pub use knit::{Cell, KnitMap};

/// Per node, the new slot of every old slot (`None` for a removed pass):
/// [`Topology::without_passes`].
pub type SlotMap = Vec<Vec<Option<usize>>>;

/// How the rows of a knit are joined into yarns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Construction {
    /// Flat, each row its own yarn, left to right, tied to the fabric at both ends.
    #[default]
    FlatPerRow,
    /// Flat, one continuous yarn from the cast-on to the bind-off: row 0 left to right, and
    /// the yarn turns back at each row end (odd rows right to left, front view).
    Flat,
    /// In the round: one yarn spiralling round a tube, every round left to right (front view,
    /// the outside of the tube); the last loop of a round is the neighbour of its first.
    Round,
}

impl Construction {
    /// The name in scene files: `flat-per-row`, `flat` or `round`.
    pub fn name(self) -> &'static str {
        match self {
            Self::FlatPerRow => "flat-per-row",
            Self::Flat => "flat",
            Self::Round => "round",
        }
    }

    /// The construction named `name` ([`Construction::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::FlatPerRow, Self::Flat, Self::Round]
            .into_iter()
            .find(|c| c.name() == name)
    }
}

/// One yarn's way through the two nodes of a stitch contact: pass `index` of `yarn` is at
/// the contact's `q₀`, and the pass at `q₁` is the next one (`forward`) or the previous one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strand {
    /// Yarn index.
    pub yarn: usize,
    /// Index of the pass at `q₀` within the yarn.
    pub index: usize,
    /// Whether the yarn runs `q₀ → q₁` (else `q₁ → q₀`).
    pub forward: bool,
}

impl Strand {
    /// Pass indices at `[q₀, q₁]`.
    pub fn indices(&self) -> [usize; 2] {
        if self.forward {
            [self.index, self.index + 1]
        } else {
            [self.index, self.index - 1]
        }
    }
}

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

/// A stitch contact (seed 000 §3.2.2–§3.2.3, Fig. 8): two nodes shared by the leg of the upper
/// loop and the head(s) of the loop(s) it is pulled through (stacked for decreases), or a
/// lifted bar.
#[derive(Clone, Debug, PartialEq)]
pub struct StitchContact {
    /// The contact's end nodes `[q₀, q₁]` (Fig. 8) in geometric order: `lo → hi` for left
    /// contacts, `hi → lo` for right contacts (a row knitted left to right runs this way).
    pub nodes: [usize; 2],
    /// The leg of the upper loop (row `row`).
    pub upper: Strand,
    /// The heads it goes through, in stacking order (top first; one for a simple stitch).
    pub lower: Vec<Strand>,
    /// Out-of-plane sign of the upper loop's stitch ([`crate::chart::Stitch::sign`]: `+1`
    /// knit-type, `−1` purl-type).
    pub sign: f64,
    /// Row of the upper loop (≥ 1).
    pub row: usize,
    /// Index of the upper loop within its row (the column of a rectangular chart).
    pub column: usize,
    /// Which leg of the upper loop.
    pub side: Side,
}

impl StitchContact {
    /// Every strand: the upper one first, then the lower ones in stacking order.
    pub fn strands(&self) -> impl Iterator<Item = &Strand> {
        std::iter::once(&self.upper).chain(&self.lower)
    }

    /// The yarn passes through the contact's nodes front to back: for a knit-type stitch the
    /// upper leg (pulled through to the front), then the heads top first; for a purl-type
    /// stitch the heads top first, then the upper leg (pulled through to the back; seen from
    /// the front a P2TOG's left loop lies in front of its right one, as a K2TOG's does).
    pub fn front_to_back(&self) -> Vec<Strand> {
        if self.sign < 0.0 {
            self.lower.iter().chain([&self.upper]).copied().collect()
        } else {
            self.strands().copied().collect()
        }
    }
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
#[derive(Clone, Debug, PartialEq)]
pub struct Topology {
    /// Contact nodes.
    pub nodes: Vec<Node>,
    /// Yarns as ordered node passes.
    pub yarns: Vec<Yarn>,
    /// Stitch contacts (knits): an upper leg and one or more stacked heads.
    pub stitch_contacts: Vec<StitchContact>,
    /// Crossings (weaves).
    pub crossings: Vec<Crossing>,
    /// What the topology was built from.
    pub kind: FabricKind,
    /// Where the nodes of a knit lie in its structure (`None` for weaves).
    pub knit: Option<KnitMap>,
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
    /// The knit of `chart` with one yarn per row ([`Construction::FlatPerRow`]; module
    /// documentation).
    pub fn knit(chart: &Chart) -> Self {
        knit::build(chart, Construction::FlatPerRow)
    }

    /// The knit of `chart` knitted as `construction` (module documentation). Errors for a
    /// tube of fewer than 3 stitches.
    pub fn knit_with(chart: &Chart, construction: Construction) -> Result<Self, TopologyError> {
        if construction == Construction::Round
            && let Some(r) = (0..chart.height()).find(|&r| chart.loops_made(r) < 3)
        {
            return Err(TopologyError::Invalid(format!(
                "a tube knitted in the round needs ≥ 3 loops in every round; round {r} (0-based) makes {}",
                chart.loops_made(r)
            )));
        }
        let topo = knit::build(chart, construction);
        // A yarn-over at a turning edge of a continuous flat yarn would make the yarn pass
        // one node twice in a row (the yarn-over's head and the next row's first foot).
        topo.validate().map_err(|e| {
            TopologyError::Invalid(format!(
                "the chart cannot be knitted as `{}`: {e} (a yarn-over at the end of a row that \
                 the yarn turns at is not supported; work a stitch before it at the edge, or \
                 knit the chart with one yarn per row)",
                construction.name()
            ))
        })?;
        Ok(topo)
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
    pub(crate) fn from_yarn_nodes(
        n_nodes: usize,
        yarn_nodes: &[Vec<usize>],
        kind: FabricKind,
    ) -> Self {
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
            knit: None,
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
            for st in sc.strands() {
                let ok = st.forward || st.index > 0;
                let at = |i: usize| self.yarns.get(st.yarn)?.passes.get(i).map(|p| p.node);
                let [i0, i1] = st.indices();
                if !ok || at(i0) != Some(sc.nodes[0]) || at(i1) != Some(sc.nodes[1]) {
                    return bad(format!(
                        "stitch contact {k}: yarn {} does not run through q₀ and q₁ at pass {}",
                        st.yarn, st.index
                    ));
                }
            }
        }
        Ok(())
    }

    /// `(node, slot)` of the pass `index` of `yarn`.
    pub fn pass_slot(&self, yarn: usize, index: usize) -> (usize, usize) {
        let p = self.yarns[yarn].passes[index];
        (p.node, p.slot)
    }

    /// `[(node, slot) at q₀, (node, slot) at q₁]` of a strand.
    pub fn strand_slots(&self, strand: &Strand) -> [(usize, usize); 2] {
        strand.indices().map(|i| self.pass_slot(strand.yarn, i))
    }

    /// The node on `strand`'s yarn next to the contact node `end` (0 = `q₀`, 1 = `q₁`) away
    /// from the contact (`q₄`/`q₃` of Fig. 8), if the yarn goes on.
    pub fn strand_outer(&self, strand: &Strand, end: usize) -> Option<usize> {
        self.strand_outer_pass(strand, end).map(|(n, _)| n)
    }

    /// `(node, slot)` of the pass of [`Topology::strand_outer`].
    pub fn strand_outer_pass(&self, strand: &Strand, end: usize) -> Option<(usize, usize)> {
        let [i0, i1] = strand.indices();
        let (i, other) = if end == 0 { (i0, i1) } else { (i1, i0) };
        let j = if i > other {
            i.checked_add(1)?
        } else {
            i.checked_sub(1)?
        };
        self.yarns[strand.yarn]
            .passes
            .get(j)
            .map(|p| (p.node, p.slot))
    }

    /// The stack of every node front to back, as slots, with per adjacent pair whether the two
    /// yarns are parallel (two heads stacked by a decrease that run the same way: they slide
    /// along one axis, seed 000 §4.4). `None` for nodes that are not on a stitch contact.
    pub fn knit_stacks(&self) -> Vec<Option<(Vec<usize>, Vec<bool>)>> {
        let mut out = vec![None; self.nodes.len()];
        for sc in &self.stitch_contacts {
            let order = sc.front_to_back();
            for (end, &node) in sc.nodes.iter().enumerate() {
                let slots: Vec<usize> = order
                    .iter()
                    .map(|st| self.strand_slots(st)[end].1)
                    .collect();
                // The heads are parallel when they all run the same way through the contact.
                // A stack with heads running opposite ways (a slipped loop stacked with a
                // loop of the next row of a continuous yarn) slides in opposite senses: all
                // its yarns get independent springs (so the parallel pairs of a stack always
                // form one chain from the upper leg's end, which friction_springs relies on).
                let aligned = sc.lower.iter().all(|st| st.forward == sc.lower[0].forward);
                let parallel = order
                    .windows(2)
                    .map(|w| aligned && w[0] != sc.upper && w[1] != sc.upper)
                    .collect();
                out[node] = Some((slots, parallel));
            }
        }
        out
    }

    /// Index within yarn `yarn` of its (first) pass through `node`, if any.
    pub fn pass_index(&self, node: usize, yarn: usize) -> Option<usize> {
        self.nodes[node]
            .passes
            .iter()
            .find(|p| p.yarn == yarn)
            .map(|p| p.index)
    }

    /// The topology after yarn passes `(yarn, pass index)` left their nodes: contact breaking
    /// at a yarn end (seed 000 §5.2.4: "break the required contacts by turning 5-DoF nodes
    /// into two 3-DoF nodes"). Every removed pass must be the first or the last pass of its
    /// yarn (one per end), and its node must keep another yarn; node indices do not change.
    /// Returns the new topology and, per node, the new slot of every old slot (`None` for a
    /// removed pass).
    ///
    /// Stitch contacts lose the removed strands (a contact without its upper leg or without
    /// any head is dropped); a node left with one yarn gets that yarn's sliding pinned (a
    /// one-yarn node is a material point); the yarn's new end pass inherits the removed end
    /// pass's pinning (a free end stays free). Errors name the offending pass.
    pub fn without_passes(
        &self,
        removed: &[(usize, usize)],
    ) -> Result<(Self, SlotMap), TopologyError> {
        let bad = |m: String| Err(TopologyError::Invalid(m));
        let mut drop_first = vec![false; self.yarns.len()];
        let mut drop_last = vec![false; self.yarns.len()];
        for &(y, i) in removed {
            let Some(yarn) = self.yarns.get(y) else {
                return bad(format!("no yarn {y}"));
            };
            let n = yarn.passes.len();
            let end = if i == 0 {
                &mut drop_first[y]
            } else if i + 1 == n {
                &mut drop_last[y]
            } else {
                return bad(format!(
                    "yarn {y} pass {i} is not an end of the yarn (0 or {})",
                    n.saturating_sub(1)
                ));
            };
            if *end {
                return bad(format!("yarn {y} pass {i} listed twice"));
            }
            *end = true;
            if n < 3 {
                return bad(format!("yarn {y} would keep fewer than two passes"));
            }
            let node = yarn.passes[i].node;
            if self.nodes[node].passes.len() < 2 {
                return bad(format!(
                    "yarn {y} pass {i}: node {node} has no other yarn (a yarn cannot leave its own material point)"
                ));
            }
        }
        let keep = |y: usize, i: usize| {
            !(drop_first[y] && i == 0 || drop_last[y] && i + 1 == self.yarns[y].passes.len())
        };
        let shift = |y: usize| usize::from(drop_first[y]);
        // Surviving passes per yarn, with their old pinning.
        let yarn_nodes: Vec<Vec<usize>> = self
            .yarns
            .iter()
            .enumerate()
            .map(|(y, yarn)| {
                yarn.passes
                    .iter()
                    .enumerate()
                    .filter(|&(i, _)| keep(y, i))
                    .map(|(_, p)| p.node)
                    .collect()
            })
            .collect();
        let mut topo = Self::from_yarn_nodes(self.nodes.len(), &yarn_nodes, self.kind.clone());
        topo.knit = self.knit.clone();
        // Pinning: old flags; ends inherit the removed end's flag; one-yarn nodes pinned.
        for (y, yarn) in self.yarns.iter().enumerate() {
            let n = yarn.passes.len();
            for (i, p) in yarn.passes.iter().enumerate() {
                if !keep(y, i) {
                    continue;
                }
                let mut pinned = self.nodes[p.node].passes[p.slot].sliding_pinned;
                let new_first = drop_first[y] && i == 1;
                if new_first || drop_last[y] && i + 2 == n {
                    let end = if new_first { 0 } else { n - 1 };
                    let q = yarn.passes[end];
                    pinned = self.nodes[q.node].passes[q.slot].sliding_pinned;
                }
                let np = topo.yarns[y].passes[i - shift(y)];
                topo.nodes[np.node].passes[np.slot].sliding_pinned = pinned;
            }
        }
        for node in &mut topo.nodes {
            if node.passes.len() == 1 {
                node.passes[0].sliding_pinned = true;
            }
        }
        // Slot map: old (node, slot) → new slot.
        let mut map: Vec<Vec<Option<usize>>> = self
            .nodes
            .iter()
            .map(|n| vec![None; n.passes.len()])
            .collect();
        for (y, yarn) in self.yarns.iter().enumerate() {
            for (i, p) in yarn.passes.iter().enumerate() {
                if keep(y, i) {
                    map[p.node][p.slot] = Some(topo.yarns[y].passes[i - shift(y)].slot);
                }
            }
        }
        let moved = |st: &Strand| -> Option<Strand> {
            let [a, b] = st.indices();
            (keep(st.yarn, a) && keep(st.yarn, b)).then(|| Strand {
                index: st.index - shift(st.yarn),
                ..*st
            })
        };
        topo.stitch_contacts = self
            .stitch_contacts
            .iter()
            .filter_map(|sc| {
                let upper = moved(&sc.upper)?;
                let lower: Vec<Strand> = sc.lower.iter().filter_map(moved).collect();
                (!lower.is_empty()).then(|| StitchContact {
                    upper,
                    lower,
                    ..sc.clone()
                })
            })
            .collect();
        topo.crossings = self
            .crossings
            .iter()
            .filter(|c| topo.nodes[c.node].passes.len() >= 2)
            .copied()
            .collect();
        topo.validate()?;
        Ok((topo, map))
    }

    /// Every node of row boundary `b` of a knit (cells left to right, each `L lo, L hi,
    /// R lo, R hi`; for a rectangular chart [`knit_boundary_nodes`]); empty for a weave or
    /// a boundary out of range.
    pub fn boundary_nodes(&self, b: usize) -> Vec<usize> {
        match &self.knit {
            Some(k) if b < k.boundaries.len() => k.boundary_nodes(b),
            _ => Vec::new(),
        }
    }
}

/// A fabric to build a [`Topology`] for: a knit from a stitch chart knitted as its
/// [`Construction`] says, or a woven fabric. The `[pattern]` of a scene describes one
/// ([`crate::scene::PatternSpec::fabric`]); the experiments take one.
#[derive(Clone, Debug, PartialEq)]
pub enum Fabric {
    /// A knit from a stitch chart, knitted as the [`Construction`] says.
    Knit(Chart, Construction),
    /// A woven fabric ([`Topology::weave`]).
    Weave {
        /// The weave pattern.
        pattern: WeavePattern,
        /// Warp yarns.
        warps: usize,
        /// Weft yarns.
        wefts: usize,
    },
}

impl Fabric {
    /// The topology of the fabric.
    pub fn topology(&self) -> Result<Topology, TopologyError> {
        match self {
            Fabric::Knit(chart, construction) => Topology::knit_with(chart, *construction),
            Fabric::Weave {
                pattern,
                warps,
                wefts,
            } => Topology::weave(*pattern, *warps, *wefts),
        }
    }
}
