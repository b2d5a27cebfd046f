//! The periodic yarn tile: rest geometry, rest shape and reference frames of the yarn loops in
//! one period of a fabric (seed 002 §7.1, seed 004 §3).
//!
//! A tile has `n` vertices and `n` edges. Edge `e` runs from vertex `v0` to the copy of vertex
//! `v1` shifted by `shift[0] · a₁ + shift[1] · a₂`, the tile's periods ([`Tile::period_offset`]:
//! `a₁ = (px, 0)`, `a₂ = (skew · px, py)`, rectangular when `skew = 0`), so a yarn that leaves
//! the tile through one side re-enters through the opposite side. Every vertex starts exactly
//! one edge and ends exactly one edge, so the edges form closed periodic yarn loops
//! ([`Topology::loops`]).
//!
//! Edges are stored in file order: edge `e` does **not** necessarily start at vertex `e`
//! (in the stockinette tile, edge 0 is `49 → 0 + (1, 0)`). Always use [`Edge::v0`] /
//! [`Edge::v1`], or [`Topology::outgoing`] / [`Topology::incoming`].
//!
//! Units: SI (m, rad).

use nalgebra::Vector3;

/// One yarn edge of a periodic tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// Start vertex.
    pub v0: usize,
    /// End vertex (before the shift).
    pub v1: usize,
    /// The edge ends at the copy of `v1` shifted by `shift[0] · a₁ + shift[1] · a₂` (integer
    /// numbers of periods, [`Tile::period_offset`]).
    pub shift: [i32; 2],
}

/// A periodic yarn tile (the contents of a `.pyp` file, see [`crate::pyp`]).
///
/// Per-vertex arrays have `n` entries, per-edge arrays have `n` entries (as many edges as
/// vertices). [`Tile::validate`] checks the consistency of all of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    /// Tile period `[px, py]` along x and y (m).
    pub period: [f64; 2],
    /// Lattice skew (unitless): the tile's periods are `a₁ = (px, 0)` and
    /// `a₂ = (skew · px, py)`. Zero for a rectangular tile; a sheared lattice holds a
    /// pattern's primitive repeat when the rectangular one is larger (the seed stitch repeats
    /// after one loop sideways and one course up: `skew = ½` on a tile of two loops, half the
    /// vertices of its 2 × 2 rectangular repeat). In `[−½, ½]`, so the 3 × 3 periodic images
    /// around the tile still hold its nearest neighbours. Scaling `px` scales `a₂`'s x
    /// component with it.
    pub skew: f64,
    /// Yarn radius (m).
    pub radius: f64,
    /// Rest vertex positions `X` (m), per vertex.
    pub positions: Vec<Vector3<f64>>,
    /// Twist angle θ (rad) of the edge that **starts** at each vertex (the `t` column of
    /// `*Q`), per vertex.
    pub twists: Vec<f64>,
    /// The edges, in file order.
    pub edges: Vec<Edge>,
    /// Rest length (m), per edge (indexed like [`Tile::edges`]; `.pyp` files list it by
    /// start vertex, see [`crate::pyp`]).
    pub rest_lengths: Vec<f64>,
    /// Rest curvature (material-frame components κ₁, κ₂, unitless), per vertex.
    pub rest_curvatures: Vec<[f64; 2]>,
    /// Rest twist (rad), per vertex.
    pub rest_twists: Vec<f64>,
    /// Reference director `d1` (unitless, nominally a unit vector orthogonal to the edge),
    /// per edge (indexed like [`Tile::edges`]; `.pyp` files list it by start vertex).
    pub reference_directors: Vec<Vector3<f64>>,
    /// Reference twist (rad), per vertex.
    pub reference_twists: Vec<f64>,
}

/// Why a [`Tile`] is inconsistent.
///
/// Indices are 0-based vertex or edge indices; [`TileError::location`] tells which array and
/// entry an error refers to.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TileError {
    /// The tile has no vertices.
    #[error("the tile has no vertices (expected n ≥ 1)")]
    Empty,
    /// An array has the wrong number of entries.
    #[error("{field} has {got} entries, expected {expected} (one per vertex / edge)")]
    LengthMismatch {
        /// Field name (as in [`Tile`]).
        field: &'static str,
        /// Expected number of entries (`n`).
        expected: usize,
        /// Actual number of entries.
        got: usize,
    },
    /// The period or the radius is not a positive finite number.
    #[error("{field} must be positive and finite, found {value}")]
    NonPositive {
        /// `"period[0]"`, `"period[1]"` or `"radius"`.
        field: &'static str,
        /// The offending value.
        value: f64,
    },
    /// The lattice skew is not a finite number in `[−½, ½]`.
    #[error("skew must be a finite number in [-0.5, 0.5], found {value}")]
    Skew {
        /// The offending value.
        value: f64,
    },
    /// A value is NaN or infinite.
    #[error("{field}[{index}] is not finite")]
    NonFinite {
        /// Field name (as in [`Tile`]).
        field: &'static str,
        /// Vertex or edge index.
        index: usize,
    },
    /// An edge names a vertex that does not exist.
    #[error("edge {edge} refers to vertex {vertex}, expected a vertex index < n = {n}")]
    VertexOutOfRange {
        /// Edge index.
        edge: usize,
        /// The out-of-range vertex index.
        vertex: usize,
        /// Number of vertices.
        n: usize,
    },
    /// Two edges start at the same vertex.
    #[error(
        "vertex {vertex} starts two edges ({first} and {second}); expected exactly one outgoing edge per vertex"
    )]
    TwoOutgoing {
        /// The vertex.
        vertex: usize,
        /// The first edge starting there.
        first: usize,
        /// The second edge starting there.
        second: usize,
    },
    /// Two edges end at the same vertex.
    #[error(
        "vertex {vertex} ends two edges ({first} and {second}); expected exactly one incoming edge per vertex"
    )]
    TwoIncoming {
        /// The vertex.
        vertex: usize,
        /// The first edge ending there.
        first: usize,
        /// The second edge ending there.
        second: usize,
    },
    /// A rest length is zero or negative.
    #[error("rest length of edge {edge} must be positive, found {value} m")]
    NonPositiveRestLength {
        /// Edge index.
        edge: usize,
        /// The offending rest length (m).
        value: f64,
    },
}

/// What a [`TileError`] refers to: a field of [`Tile`] and, for array fields, an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileErrorLocation {
    /// Field name (as in [`Tile`]).
    pub field: &'static str,
    /// Vertex or edge index for per-vertex / per-edge fields; `None` for whole-tile errors.
    pub index: Option<usize>,
}

impl TileError {
    /// The field and entry this error refers to, for reporting (for example the line of a
    /// file). `None` for [`TileError::Empty`].
    pub fn location(&self) -> Option<TileErrorLocation> {
        let at = |field, index| Some(TileErrorLocation { field, index });
        match *self {
            Self::Empty => None,
            Self::LengthMismatch { field, .. } | Self::NonPositive { field, .. } => at(field, None),
            Self::Skew { .. } => at("skew", None),
            Self::NonFinite { field, index } => at(field, Some(index)),
            Self::VertexOutOfRange { edge, .. } => at("edges", Some(edge)),
            Self::TwoOutgoing { second, .. } | Self::TwoIncoming { second, .. } => {
                at("edges", Some(second))
            }
            Self::NonPositiveRestLength { edge, .. } => at("rest_lengths", Some(edge)),
        }
    }
}

/// Outgoing and incoming edge of every vertex of a valid [`Tile`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topology {
    outgoing: Vec<usize>,
    incoming: Vec<usize>,
    /// `next[e]`: the edge that follows edge `e` along its yarn (the outgoing edge of `v1`).
    next: Vec<usize>,
}

impl Topology {
    /// Builds the topology of `tile`, which must pass [`Tile::validate`].
    pub fn new(tile: &Tile) -> Result<Self, TileError> {
        tile.validate()?;
        // After validation every vertex has exactly one outgoing and one incoming edge.
        let n = tile.n_vertices();
        let mut outgoing = vec![0; n];
        let mut incoming = vec![0; n];
        for (e, edge) in tile.edges.iter().enumerate() {
            outgoing[edge.v0] = e;
            incoming[edge.v1] = e;
        }
        let next = tile.edges.iter().map(|edge| outgoing[edge.v1]).collect();
        Ok(Self {
            outgoing,
            incoming,
            next,
        })
    }

    /// Number of vertices (= number of edges).
    pub fn n_vertices(&self) -> usize {
        self.outgoing.len()
    }

    /// The edge that starts at vertex `v`. Panics if `v ≥ n`.
    pub fn outgoing(&self, v: usize) -> usize {
        self.outgoing[v]
    }

    /// The edge that ends at vertex `v`. Panics if `v ≥ n`.
    pub fn incoming(&self, v: usize) -> usize {
        self.incoming[v]
    }

    /// The edge that follows edge `e` along its yarn (the outgoing edge of its end vertex).
    /// Panics if `e ≥ n`.
    pub fn next_edge(&self, e: usize) -> usize {
        self.next[e]
    }

    /// The closed periodic yarn loops, each as the ordered list of its edges, following
    /// outgoing edges. Loops are listed in order of their smallest edge index, and each loop
    /// starts at that edge.
    pub fn loops(&self) -> Vec<Vec<usize>> {
        let mut visited = vec![false; self.next.len()];
        let mut loops = Vec::new();
        for start in 0..self.next.len() {
            if visited[start] {
                continue;
            }
            let mut lp = Vec::new();
            let mut e = start;
            while !visited[e] {
                visited[e] = true;
                lp.push(e);
                e = self.next[e];
            }
            loops.push(lp);
        }
        loops
    }
}

impl Tile {
    /// Number of vertices `n` (the length of [`Tile::positions`]).
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Checks that the tile is consistent: `n ≥ 1`; every array has `n` entries; period and
    /// radius are positive and finite; all numbers are finite; edge vertex indices are in
    /// range; every vertex starts exactly one edge and ends exactly one edge; rest lengths
    /// are positive; the skew is in `[−½, ½]`.
    pub fn validate(&self) -> Result<(), TileError> {
        let n = self.n_vertices();
        if n == 0 {
            return Err(TileError::Empty);
        }
        let lengths = [
            ("twists", self.twists.len()),
            ("edges", self.edges.len()),
            ("rest_lengths", self.rest_lengths.len()),
            ("rest_curvatures", self.rest_curvatures.len()),
            ("rest_twists", self.rest_twists.len()),
            ("reference_directors", self.reference_directors.len()),
            ("reference_twists", self.reference_twists.len()),
        ];
        for (field, got) in lengths {
            if got != n {
                return Err(TileError::LengthMismatch {
                    field,
                    expected: n,
                    got,
                });
            }
        }
        for (field, value) in [
            ("period[0]", self.period[0]),
            ("period[1]", self.period[1]),
            ("radius", self.radius),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(TileError::NonPositive { field, value });
            }
        }
        if self.skew.is_nan() || self.skew.abs() > 0.5 {
            return Err(TileError::Skew { value: self.skew });
        }
        check_finite(
            "positions",
            self.positions
                .iter()
                .map(|p| p.iter().all(|x| x.is_finite())),
        )?;
        check_finite("twists", self.twists.iter().map(|x| x.is_finite()))?;
        check_finite(
            "rest_lengths",
            self.rest_lengths.iter().map(|x| x.is_finite()),
        )?;
        check_finite(
            "rest_curvatures",
            self.rest_curvatures
                .iter()
                .map(|k| k.iter().all(|x| x.is_finite())),
        )?;
        check_finite(
            "rest_twists",
            self.rest_twists.iter().map(|x| x.is_finite()),
        )?;
        check_finite(
            "reference_directors",
            self.reference_directors
                .iter()
                .map(|d| d.iter().all(|x| x.is_finite())),
        )?;
        check_finite(
            "reference_twists",
            self.reference_twists.iter().map(|x| x.is_finite()),
        )?;

        let mut outgoing: Vec<Option<usize>> = vec![None; n];
        let mut incoming: Vec<Option<usize>> = vec![None; n];
        for (e, edge) in self.edges.iter().enumerate() {
            for vertex in [edge.v0, edge.v1] {
                if vertex >= n {
                    return Err(TileError::VertexOutOfRange { edge: e, vertex, n });
                }
            }
            if let Some(first) = outgoing[edge.v0] {
                return Err(TileError::TwoOutgoing {
                    vertex: edge.v0,
                    first,
                    second: e,
                });
            }
            outgoing[edge.v0] = Some(e);
            if let Some(first) = incoming[edge.v1] {
                return Err(TileError::TwoIncoming {
                    vertex: edge.v1,
                    first,
                    second: e,
                });
            }
            incoming[edge.v1] = Some(e);
        }
        // n edges, n vertices and no vertex with two outgoing (incoming) edges: by counting,
        // every vertex has exactly one outgoing and one incoming edge.

        for (edge, &value) in self.rest_lengths.iter().enumerate() {
            if value <= 0.0 {
                return Err(TileError::NonPositiveRestLength { edge, value });
            }
        }
        Ok(())
    }

    /// Validates the tile and builds its [`Topology`] (outgoing / incoming edges, loops).
    pub fn topology(&self) -> Result<Topology, TileError> {
        Topology::new(self)
    }

    /// The translation (m) of the periodic copy shifted by `shift` periods:
    /// `shift[0] · a₁ + shift[1] · a₂ = ((shift[0] + skew · shift[1]) · px, shift[1] · py, 0)`.
    pub fn period_offset(&self, shift: [i32; 2]) -> Vector3<f64> {
        lattice_offset(self.period, self.skew, shift)
    }

    /// Rest position (m) of the end of edge `e`, including the periodic shift:
    /// `X_v1 + shift.x · a₁ + shift.y · a₂` ([`Tile::period_offset`]). Panics if `e` or its
    /// vertices are out of range (not the case for a validated tile).
    pub fn edge_end_shifted(&self, e: usize) -> Vector3<f64> {
        let edge = self.edges[e];
        self.positions[edge.v1] + self.period_offset(edge.shift)
    }

    /// Rest edge vector (m) of edge `e`: [`Tile::edge_end_shifted`] minus `X_v0`. Panics if
    /// `e` or its vertices are out of range (not the case for a validated tile).
    pub fn edge_vector(&self, e: usize) -> Vector3<f64> {
        self.edge_end_shifted(e) - self.positions[self.edges[e].v0]
    }
}

/// The translation (m) `shift[0] · a₁ + shift[1] · a₂` of the lattice with periods `period`
/// and skew `skew` (see [`Tile::skew`]), for code that builds a tile.
pub fn lattice_offset(period: [f64; 2], skew: f64, shift: [i32; 2]) -> Vector3<f64> {
    let [sx, sy] = shift.map(f64::from);
    Vector3::new((sx + skew * sy) * period[0], sy * period[1], 0.0)
}

/// `NonFinite` error for the first entry of `field` whose `ok` flag is false.
fn check_finite(field: &'static str, ok: impl Iterator<Item = bool>) -> Result<(), TileError> {
    for (index, ok) in ok.enumerate() {
        if !ok {
            return Err(TileError::NonFinite { field, index });
        }
    }
    Ok(())
}
