//! Clamp sets: which contact nodes a clamp holds (row boundaries, side columns, any column),
//! for knits and weaves, and the pair of side clamps of the stretch experiments (seed 000
//! §4.5, §5.2.3).

use std::fmt;

use rod::geometry::V3;

use super::swatch::{centroid, positions};
use crate::integrator::Simulator;
use crate::topology::Fabric;
use crate::topology::{Construction, knit_boundary_nodes, knit_column_nodes};

/// The node grid of a swatch, as far as clamps need it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Grid {
    /// A knit `width` stitches wide (its cast-on) and `height` rows tall
    /// ([`crate::topology::Topology::knit_with`]).
    Knit {
        /// Stitches per row (of the cast-on).
        width: usize,
        /// Rows.
        height: usize,
        /// `None` for a rectangular K/P chart knitted flat, whose nodes form the grid of
        /// [`crate::topology::knit_node`]; otherwise `(first node, loops)` of the bind-off
        /// boundary (the last nodes of the topology; side and column clamps then do not
        /// apply).
        shaped: Option<(usize, usize)>,
    },
    /// A weave; node `j · warps + i` is the crossing of warp `i` and weft `j`
    /// ([`crate::topology::Topology::weave`]).
    Weave {
        /// Warp yarns (columns, along y).
        warps: usize,
        /// Weft yarns (rows, along x).
        wefts: usize,
    },
}

impl From<&Fabric> for Grid {
    fn from(fabric: &Fabric) -> Self {
        match fabric {
            Fabric::Knit(chart, construction) => {
                let flat = *construction != Construction::Round;
                let shaped = (!(flat && chart.is_rectangular())).then(|| {
                    // Cells: one per loop pulled through something, plus the bind-off's.
                    let cells: usize = (0..chart.height())
                        .flat_map(|r| chart.row(r).iter())
                        .filter(|s| s.makes_contacts())
                        .map(|s| s.produces())
                        .sum();
                    (4 * cells, chart.loops_made(chart.height() - 1))
                });
                Grid::Knit {
                    width: chart.width(),
                    height: chart.height(),
                    shaped,
                }
            }
            Fabric::Weave { warps, wefts, .. } => Grid::Weave {
                warps: *warps,
                wefts: *wefts,
            },
        }
    }
}

/// The nodes a clamp holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClampSet {
    /// Knit: the nodes of row boundary 0; weave: weft 0.
    CastOn,
    /// Knit: the nodes of the last row boundary; weave: the last weft.
    BindOff,
    /// Knit: every node of the first stitch column; weave: warp 0.
    Left,
    /// Knit: every node of the last stitch column; weave: the last warp.
    Right,
    /// Knit: every node of stitch column `c` (0-based); weave: warp `c`.
    Column(usize),
}

impl ClampSet {
    /// The set named `edge` in scene files: `cast-on`, `bind-off`, `left` or `right`.
    pub fn from_edge(edge: &str) -> Option<Self> {
        match edge {
            "cast-on" => Some(Self::CastOn),
            "bind-off" => Some(Self::BindOff),
            "left" => Some(Self::Left),
            "right" => Some(Self::Right),
            _ => None,
        }
    }

    /// The clamped nodes of a swatch with node grid `grid`, or why there are none (a column
    /// out of range).
    pub fn nodes(self, grid: Grid) -> Result<Vec<usize>, String> {
        let columns = match grid {
            Grid::Knit { width, .. } => width,
            Grid::Weave { warps, .. } => warps,
        };
        let column = match self {
            Self::CastOn | Self::BindOff => None,
            Self::Left => Some(0),
            Self::Right => Some(
                columns
                    .checked_sub(1)
                    .ok_or_else(|| "a swatch without columns has no right side".to_string())?,
            ),
            Self::Column(c) if c < columns => Some(c),
            Self::Column(c) => {
                return Err(format!(
                    "clamp column {c} is out of range: the swatch has {columns} columns (0-based)"
                ));
            }
        };
        let last_row = self == Self::BindOff;
        if let Grid::Knit {
            width,
            shaped: Some((bind_off, loops)),
            ..
        } = grid
        {
            return match column {
                None if last_row => Ok((bind_off..bind_off + 4 * loops).collect()),
                None => Ok((0..4 * width).collect()),
                Some(_) => Err(format!(
                    "clamp `{self}` needs a rectangular K/P chart knitted flat; this chart \
                     changes its width or is knitted in the round (clamp the cast-on or the \
                     bind-off instead)"
                )),
            };
        }
        Ok(match (grid, column) {
            (Grid::Knit { width, height, .. }, Some(c)) => knit_column_nodes(width, height, c),
            (Grid::Knit { width, height, .. }, None) => {
                knit_boundary_nodes(width, if last_row { height } else { 0 })
            }
            (Grid::Weave { warps, wefts }, Some(i)) => (0..wefts).map(|j| j * warps + i).collect(),
            (Grid::Weave { warps, wefts }, None) => {
                let j = if last_row { wefts - 1 } else { 0 };
                (0..warps).map(|i| j * warps + i).collect()
            }
        })
    }
}

impl fmt::Display for ClampSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::CastOn => write!(f, "cast-on"),
            Self::BindOff => write!(f, "bind-off"),
            Self::Left => write!(f, "left"),
            Self::Right => write!(f, "right"),
            Self::Column(c) => write!(f, "column {c}"),
        }
    }
}

/// Clamps over the first and last columns of a knit `w` stitches wide and `h` rows tall,
/// pinned where the nodes are now.
pub struct SideClamps {
    /// Nodes of the left clamp.
    pub left: Vec<usize>,
    /// Nodes of the right clamp.
    pub right: Vec<usize>,
    /// Unit vector from the left clamp's centroid to the right one's.
    pub axis: V3,
    /// Distance between the centroids (m).
    pub distance: f64,
}

impl SideClamps {
    /// Pins both clamps of `sim`.
    pub fn pin(sim: &mut Simulator, w: usize, h: usize) -> anyhow::Result<Self> {
        if let (crate::topology::FabricKind::Knit(chart), Some(map)) =
            (&sim.topology().kind, &sim.topology().knit)
        {
            anyhow::ensure!(
                chart.is_rectangular() && map.construction != Construction::Round,
                "side clamps need a rectangular K/P chart knitted flat"
            );
        }
        let grid = Grid::Knit {
            width: w,
            height: h,
            shaped: None,
        };
        let left = ClampSet::Left.nodes(grid).map_err(anyhow::Error::msg)?;
        let right = ClampSet::Right.nodes(grid).map_err(anyhow::Error::msg)?;
        sim.pin_nodes(&left)?;
        sim.pin_nodes(&right)?;
        let p = positions(sim);
        let span = centroid(&p, &right) - centroid(&p, &left);
        Ok(Self {
            left,
            right,
            axis: span.normalize(),
            distance: span.norm(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::Chart;
    use crate::layout::{Layout, LayoutParams};
    use crate::topology::Topology;
    use crate::weave::WeavePattern;

    /// On a 4 × 3 stockinette the side clamps hold every node of the first / last stitch
    /// column (4 per boundary), the row clamps the nodes of boundary 0 / 3; the left column
    /// lies left of the right one in the layout.
    #[test]
    fn knit_clamp_sets() {
        let chart = Chart::stockinette(4, 3).unwrap();
        let grid = Grid::from(&Fabric::Knit(chart.clone(), Construction::FlatPerRow));
        assert_eq!(
            grid,
            Grid::Knit {
                width: 4,
                height: 3,
                shaped: None,
            }
        );
        let topo = Topology::knit(&chart);
        let layout = Layout::new(&topo, &LayoutParams::new(3e-3, 0.75e-3)).unwrap();
        let left = ClampSet::Left.nodes(grid).unwrap();
        let right = ClampSet::Right.nodes(grid).unwrap();
        assert_eq!(left, knit_column_nodes(4, 3, 0));
        assert_eq!(right, ClampSet::Column(3).nodes(grid).unwrap());
        assert_eq!(left.len(), 4 * 4);
        assert!(left.iter().all(|n| !right.contains(n)));
        let x = |nodes: &[usize]| centroid(&layout.positions, nodes).x;
        assert!(x(&left) < x(&ClampSet::Column(1).nodes(grid).unwrap()));
        assert!(x(&ClampSet::Column(2).nodes(grid).unwrap()) < x(&right));
        let cast_on = ClampSet::CastOn.nodes(grid).unwrap();
        let bind_off = ClampSet::BindOff.nodes(grid).unwrap();
        assert_eq!(cast_on, knit_boundary_nodes(4, 0));
        assert_eq!(bind_off, knit_boundary_nodes(4, 3));
        let y = |nodes: &[usize]| centroid(&layout.positions, nodes).y;
        assert!(y(&cast_on) < y(&bind_off));
        for n in left.iter().chain(&right).chain(&cast_on).chain(&bind_off) {
            assert!(*n < topo.nodes.len());
        }
        let err = ClampSet::Column(4).nodes(grid).unwrap_err();
        assert!(
            err.contains("column 4") && err.contains("4 columns"),
            "{err}"
        );
    }

    /// On a shaped chart and on a tube the cast-on and bind-off clamps hold the boundary nodes
    /// of the topology; side clamps are refused with the reason.
    #[test]
    fn shaped_and_round_clamp_sets() {
        let chart = Chart::parse("K5\nK K2TOG YO K2 YO\nK KFB K3 P\nK2TOG K3 SSK\n").unwrap();
        for construction in [
            Construction::FlatPerRow,
            Construction::Flat,
            Construction::Round,
        ] {
            let topo = Topology::knit_with(&chart, construction).unwrap();
            let grid = Grid::from(&Fabric::Knit(chart.clone(), construction));
            assert_eq!(
                ClampSet::CastOn.nodes(grid).unwrap(),
                topo.boundary_nodes(0)
            );
            assert_eq!(
                ClampSet::BindOff.nodes(grid).unwrap(),
                topo.boundary_nodes(4)
            );
            let err = ClampSet::Left.nodes(grid).unwrap_err();
            assert!(err.contains("rectangular"), "{err}");
        }
        // A rectangular chart in the round is a tube: no side edges either.
        let tube = Fabric::Knit(Chart::stockinette(4, 3).unwrap(), Construction::Round);
        assert!(ClampSet::Right.nodes(Grid::from(&tube)).is_err());
    }

    /// On a 3-warp × 4-weft weave: columns are warps, rows are wefts.
    #[test]
    fn weave_clamp_sets() {
        let fabric = Fabric::Weave {
            pattern: WeavePattern::Plain,
            warps: 3,
            wefts: 4,
        };
        let grid = Grid::from(&fabric);
        let nodes = |s: ClampSet| s.nodes(grid).unwrap();
        assert_eq!(nodes(ClampSet::CastOn), vec![0, 1, 2]);
        assert_eq!(nodes(ClampSet::BindOff), vec![9, 10, 11]);
        assert_eq!(nodes(ClampSet::Left), vec![0, 3, 6, 9]);
        assert_eq!(nodes(ClampSet::Right), vec![2, 5, 8, 11]);
        assert_eq!(nodes(ClampSet::Column(1)), vec![1, 4, 7, 10]);
        assert!(ClampSet::Column(3).nodes(grid).is_err());
        assert_eq!(ClampSet::from_edge("left"), Some(ClampSet::Left));
        assert_eq!(ClampSet::from_edge("top"), None);
    }
}
