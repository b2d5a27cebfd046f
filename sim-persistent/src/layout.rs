//! Initial positions and sliding coordinates from a topology (seed 000 §4.1, first paragraph:
//! "lay the loops and stitches following an input stitch map").
//!
//! **Knits.** Loop `(r, c)` spans `x ∈ [c w, (c + 1) w]` and `y ∈ [r h, (r + 1) h]` (`w` loop
//! width, `h` row height). The stitch contacts of row boundary `b` sit at height `y = b h`,
//! the left one at `x = (c + ¼) w`, the right one at `x = (c + ¾) w`. A contact's two nodes are
//! `contact_length` apart along a 45° axis: up-right for left contacts, up-left for right
//! contacts, so that each yarn turns by about 45° at each node (a rectangular loop would turn
//! by 90°, right at the onset of bending jamming, §4.1). The nodes are offset out of the plane
//! by `∓σ δ` (`lo`, `hi`) with `σ = +1` for a knit and `−1` for a purl (front view) and
//! `δ = out_of_plane`: the legs of a knit come from the back through the loop below to the
//! front. Bind-off nodes (top boundary) lie in the plane.
//!
//! Any chart: the loops a row makes are spaced `w` apart and centred on the cast-on, so a
//! decrease row is narrower and the legs of a decrease lean towards their new loop; the
//! cells of [`crate::topology::KnitMap`] give each loop its place. Stacked nodes are one
//! point. Knitted in the round, the same layout is wrapped round a tube whose circumference
//! is `w` times the loops of each row (front outwards, rows along +y).
//!
//! **Yarn per loop.** How much yarn a loop takes (the stitch length) follows from `w`, `h`,
//! the contact length and `δ`; [`LayoutParams::with_loop_length`] solves for the `δ` that
//! gives a required length, for example a relaxed periodic tile's (seed 000's `δ = R/4`
//! holds two thirds of a procedural tile's).
//!
//! **Weaves.** Crossing `(i, j)` sits at `(i w, j w, 0)`: `w` is the yarn spacing.
//!
//! **Sliding coordinates** start as the arc length of the polyline from the yarn's first node
//! (m), so every segment starts at its rest length (zero stretch). Bending is not at rest;
//! [`crate::rest_shape`] builds layouts from a relaxed characteristic rectangle instead (§4.1).
//! Nor is stitch wrapping: the stitch contacts start unwrapped (ψ ≈ 0), and the simulator
//! ramps the wrapping rest angles in ([`crate::forces::wrapping`]).

use crate::topology::{Construction, FabricKind, KnitMap, Side, Topology};
use rod::geometry::V3;

/// Geometric parameters of the initial layout (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayoutParams {
    /// Loop width `w` (m): course spacing of knits, yarn spacing of weaves. Seed 000 Table 1:
    /// 1–6 mm.
    pub loop_width: f64,
    /// Row height `h` (m), wale spacing of knits. Default: equal to the loop width.
    pub row_height: f64,
    /// Distance between the two nodes of a stitch contact (m). Not given in the paper;
    /// default: the yarn radius.
    pub contact_length: f64,
    /// Out-of-plane offset `δ` of stitch-contact nodes (m). Not given in the paper; default:
    /// a quarter of the yarn radius, which keeps every turn of the default layout below 70°
    /// (with `δ = R` a stockinette leg turns by ≈ 104°, past the jamming onset).
    pub out_of_plane: f64,
}

impl LayoutParams {
    /// Defaults for loop width `w` and yarn radius `r` (m): `h = w`, contact length `r`,
    /// offset `r/4`.
    pub fn new(loop_width: f64, yarn_radius: f64) -> Self {
        Self {
            loop_width,
            row_height: loop_width,
            contact_length: yarn_radius,
            out_of_plane: 0.25 * yarn_radius,
        }
    }

    /// Checks that all lengths are finite and positive and that the contact axis fits in a
    /// loop (`contact_length < min(w, h)/√2`, else heads, sinkers or legs get zero length).
    pub fn validate(&self) -> Result<(), LayoutError> {
        let all = [
            self.loop_width,
            self.row_height,
            self.contact_length,
            self.out_of_plane,
        ];
        if !all.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(LayoutError::InvalidParams(format!(
                "lengths must be finite and > 0: {self:?}"
            )));
        }
        if self.contact_length * std::f64::consts::SQRT_2 >= self.loop_width.min(self.row_height) {
            return Err(LayoutError::InvalidParams(format!(
                "contact length {} m does not fit in a {} × {} m loop",
                self.contact_length, self.loop_width, self.row_height
            )));
        }
        Ok(())
    }

    /// These parameters with the out-of-plane offset `δ` at which the layout of the knit
    /// `topology` holds `loop_length` metres of yarn per loop ([`Layout::yarn_per_loop`]): how
    /// much yarn a stitch takes is a property of the fabric (its *stitch length*, which
    /// knitters measure, and which a relaxed periodic tile has), while this layout's
    /// straight segments between the stitch-contact nodes hold whatever the loop width, row
    /// height and offset give them. In a flat knit the yarn per loop grows monotonically with
    /// `δ` (every segment's out-of-plane extent is a fixed multiple of it), so `δ` is found by
    /// bisection on `(0, w]`, to a relative 1e-12.
    ///
    /// Errors: a weave (its crossings lie in one plane), a knit in the round (its nodes lie at
    /// the tube's radius ± `δ`, so a segment between two inner nodes shortens as `δ` grows),
    /// a length that is not finite and positive, or one the layout cannot reach: below the
    /// flat layout's (`δ → 0`; a smaller loop width or row height is needed) or above the
    /// layout's at `δ = w`.
    pub fn with_loop_length(
        mut self,
        topology: &Topology,
        loop_length: f64,
    ) -> Result<Self, LayoutError> {
        self.validate()?;
        if !matches!(topology.kind, FabricKind::Knit(_)) {
            return Err(LayoutError::InvalidParams(
                "a loop length needs a knit: a weave's layout lies in one plane".into(),
            ));
        }
        if topology
            .knit
            .as_ref()
            .is_some_and(|map| map.construction == Construction::Round)
        {
            return Err(LayoutError::InvalidParams(
                "a loop length needs a knit laid out flat: in the round, the yarn per loop \
                 does not grow monotonically with the out-of-plane offset"
                    .into(),
            ));
        }
        if !(loop_length.is_finite() && loop_length > 0.0) {
            return Err(LayoutError::InvalidParams(format!(
                "the loop length must be finite and > 0, found {loop_length} m"
            )));
        }
        let length_at = |delta: f64| -> Result<f64, LayoutError> {
            let params = Self {
                out_of_plane: delta,
                ..self
            };
            Layout::new(topology, &params)?.yarn_per_loop(topology)
        };
        let (mut lo, mut hi) = (1e-9 * self.loop_width, self.loop_width);
        let (shortest, longest) = (length_at(lo)?, length_at(hi)?);
        if loop_length < shortest || loop_length > longest {
            return Err(LayoutError::InvalidParams(format!(
                "a loop length of {loop_length} m is out of this layout's reach: it holds \
                 {shortest} m per loop flat and {longest} m with an out-of-plane offset of one \
                 loop width ({} m); change the loop width or the row height",
                self.loop_width
            )));
        }
        while hi - lo > 1e-12 * hi {
            let mid = 0.5 * (lo + hi);
            if length_at(mid)? < loop_length {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        self.out_of_plane = 0.5 * (lo + hi);
        Ok(self)
    }
}

/// The gauge of a relaxed knit in yarn diameters `d = 2R`: its course spacing (loop width),
/// its row spacing and how much yarn one loop takes (its stitch length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gauge {
    /// Course spacing (loop width, d).
    pub loop_width: f64,
    /// Row spacing (d).
    pub row_height: f64,
    /// Yarn per loop (stitch length, d).
    pub yarn_per_loop: f64,
}

impl Gauge {
    /// A relaxed stockinette: the periodic tile of MADYPG's collection
    /// (`tests/data/patterns/stockinette.pyp`, MIT), period and yarn length over its loop
    /// count, in its own yarn diameter: loop width 3.76 d, row height 1.98 d, 13.2 d of yarn
    /// per loop. Seed 000's Table 1 layouts (3 mm loops for a 1.5 mm yarn, `h = w`) hold
    /// half that yarn.
    pub const RELAXED_STOCKINETTE: Gauge = Gauge {
        loop_width: 3.76,
        row_height: 1.98,
        yarn_per_loop: 13.2,
    };

    /// The gauge of knitters' units: `stitches` and `rows` per 10 cm, the stitch length
    /// (yarn per loop) in mm, for a yarn of diameter `diameter` (m).
    pub fn from_knitting(stitches: f64, rows: f64, stitch_length_mm: f64, diameter: f64) -> Self {
        Self {
            loop_width: 0.1 / stitches / diameter,
            row_height: 0.1 / rows / diameter,
            yarn_per_loop: 1e-3 * stitch_length_mm / diameter,
        }
    }
}

impl LayoutParams {
    /// The layout of the knit `topology` at `gauge` for a yarn of radius `radius` (m): loop
    /// width and row height from the gauge, the default contact length (`R`), and the
    /// out-of-plane offset that gives the gauge's yarn per loop
    /// ([`LayoutParams::with_loop_length`], whose errors it returns).
    pub fn at_gauge(topology: &Topology, radius: f64, gauge: Gauge) -> Result<Self, LayoutError> {
        let d = 2.0 * radius;
        let mut params = Self::new(gauge.loop_width * d, radius);
        params.row_height = gauge.row_height * d;
        params.with_loop_length(topology, gauge.yarn_per_loop * d)
    }
}

/// An invalid layout request.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LayoutError {
    /// A length is not finite and positive, or the contact does not fit in a loop.
    #[error("invalid layout parameters: {0}")]
    InvalidParams(String),
}

/// Initial node positions and sliding coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// Node positions (m), indexed like [`Topology::nodes`].
    pub positions: Vec<V3>,
    /// Sliding coordinate (m) of every node slot: `sliding[node][slot]`.
    pub sliding: Vec<Vec<f64>>,
}

impl Layout {
    /// Lays out `topology` (see the module documentation).
    pub fn new(topology: &Topology, params: &LayoutParams) -> Result<Self, LayoutError> {
        params.validate()?;
        let positions = match &topology.kind {
            FabricKind::Knit(_) => {
                let Some(map) = &topology.knit else {
                    return Err(LayoutError::InvalidParams(
                        "a knit topology without its knit map".into(),
                    ));
                };
                knit_positions(map, params, topology.nodes.len())
            }
            FabricKind::Weave { warps, .. } => (0..topology.nodes.len())
                .map(|n| {
                    let (i, j) = (n % warps, n / warps);
                    V3::new(
                        i as f64 * params.loop_width,
                        j as f64 * params.loop_width,
                        0.0,
                    )
                })
                .collect(),
        };
        let mut sliding: Vec<Vec<f64>> = topology
            .nodes
            .iter()
            .map(|n| vec![0.0; n.passes.len()])
            .collect();
        for yarn in &topology.yarns {
            let mut s = 0.0;
            for (i, p) in yarn.passes.iter().enumerate() {
                if i > 0 {
                    s += (positions[p.node] - positions[yarn.passes[i - 1].node]).norm();
                }
                sliding[p.node][p.slot] = s;
            }
        }
        Ok(Self { positions, sliding })
    }

    /// The mean yarn length per loop of a knit (m): the summed length of its yarns (their
    /// sliding-coordinate spans) over the loops its rows make. The yarn at the swatch's edges
    /// (where a row yarn ends or turns) is counted with the loops.
    pub fn yarn_per_loop(&self, topology: &Topology) -> Result<f64, LayoutError> {
        let loops: usize = match &topology.knit {
            Some(map) => map.loops_per_row.iter().sum(),
            None => 0,
        };
        if loops == 0 {
            return Err(LayoutError::InvalidParams(
                "yarn per loop needs a knit that makes loops".into(),
            ));
        }
        let u = |p: &crate::topology::Pass| self.sliding[p.node][p.slot];
        let yarn: f64 = (topology.yarns.iter())
            .filter_map(|y| Some(u(y.passes.last()?) - u(y.passes.first()?)))
            .sum();
        Ok(yarn / loops as f64)
    }
}

/// Node positions of a knit (module documentation): flat, or for [`Construction::Round`] on a
/// tube around the y axis of circumference `loops × w` per row (a cone where the rows shape),
/// its front outwards, rows along +y.
fn knit_positions(map: &KnitMap, params: &LayoutParams, n_nodes: usize) -> Vec<V3> {
    let mut pos = vec![V3::zeros(); n_nodes];
    let a = 0.5 * params.contact_length * std::f64::consts::FRAC_1_SQRT_2;
    let round = map.construction == Construction::Round;
    // Rows are centred on the cast-on's centre (knit.rs), which maps to the angle 0 of every
    // round, so a round of a different width does not rotate against its neighbours.
    let centre = 0.5 * map.loops_per_row.first().copied().unwrap_or(0) as f64 * params.loop_width;
    for (b, cells) in map.boundaries.iter().enumerate() {
        let y = b as f64 * params.row_height;
        for cell in cells {
            let dz = cell.sign * params.out_of_plane;
            let loops = map.loops_per_row[cell.row] as f64;
            for (side, xc, dir) in [
                (Side::Left, (cell.x - 0.25) * params.loop_width, 1.0),
                (Side::Right, (cell.x + 0.25) * params.loop_width, -1.0),
            ] {
                for (hi, p) in [
                    (false, V3::new(xc - dir * a, y - a, -dz)),
                    (true, V3::new(xc + dir * a, y + a, dz)),
                ] {
                    let p = if round {
                        // Unroll: x along the circumference, z outwards.
                        let radius = loops * params.loop_width / std::f64::consts::TAU;
                        let phi = (p.x - centre) / (radius + 1e-300);
                        let r = radius + p.z;
                        V3::new(r * phi.sin(), p.y, r * phi.cos())
                    } else {
                        p
                    };
                    pos[cell.nodes[side as usize][hi as usize]] = p;
                }
            }
        }
    }
    pos
}
