//! Geometric initial guesses of the knit and woven patterns ([`Pattern`]).

use super::PatternError;
use super::builder::{Yarn, tile_from_yarns};
use nalgebra::Vector3;
use std::f64::consts::{PI, TAU};
use yarn_pattern::tile::Tile;

/// The procedural patterns of the library.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pattern {
    /// Stockinette (all knit), 1 wale × 1 course.
    Stockinette,
    /// Garter (knit and purl courses alternating), 1 × 2.
    Garter,
    /// 1×1 rib (knit and purl wales alternating), 2 × 1.
    Rib1x1,
    /// 2×2 rib (two knit, two purl wales), 4 × 1.
    Rib2x2,
    /// Seed (knit and purl alternating in both directions): its primitive repeat, 2 × 1 on a
    /// lattice sheared by one loop per course ([`Tile::skew`] `= ½`); the rectangular 2 × 2
    /// repeat is [`Pattern::generate_rectangular`].
    Seed,
    /// Plain weave, 2 warp × 2 weft.
    PlainWeave,
    /// 2×2 basket weave, 4 × 4.
    BasketWeave,
    /// 5-harness satin (warp-faced, move 2), 5 × 5.
    Satin,
}

/// Geometric parameters of a pattern guess. For knits `spacing = [w, s]` (wale width and
/// course height, m) and `resolution` is vertices per stitch loop; for weaves `spacing =
/// [d_x, d_y]` (distance between neighbouring warp, resp. weft, yarns, m) and `resolution` is
/// vertices per yarn between consecutive crossings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatternParams {
    /// Yarn radius R (m).
    pub radius: f64,
    /// Loop / crossing spacing along x and y (m).
    pub spacing: [f64; 2],
    /// Vertices per stitch loop (knits, ≥ 8) or per crossing (weaves, ≥ 2).
    pub resolution: usize,
}

impl Pattern {
    /// Every pattern, knits first.
    pub const ALL: [Pattern; 8] = [
        Pattern::Stockinette,
        Pattern::Garter,
        Pattern::Rib1x1,
        Pattern::Rib2x2,
        Pattern::Seed,
        Pattern::PlainWeave,
        Pattern::BasketWeave,
        Pattern::Satin,
    ];

    /// A file-friendly name (`"stockinette"`, `"rib1x1"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Pattern::Stockinette => "stockinette",
            Pattern::Garter => "garter",
            Pattern::Rib1x1 => "rib1x1",
            Pattern::Rib2x2 => "rib2x2",
            Pattern::Seed => "seed",
            Pattern::PlainWeave => "plain",
            Pattern::BasketWeave => "basket",
            Pattern::Satin => "satin",
        }
    }

    /// The pattern with the given [`Pattern::name`], if any.
    pub fn from_name(name: &str) -> Option<Pattern> {
        Pattern::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether the pattern is knitted (otherwise woven).
    pub fn is_knit(self) -> bool {
        !matches!(
            self,
            Pattern::PlainWeave | Pattern::BasketWeave | Pattern::Satin
        )
    }

    /// Default parameters for yarn radius `radius` (m), at the scale of the real
    /// `stockinette.pyp` for R = 1 mm: knits `w = 7.5 R`, `s = 4 R`, 24 vertices per loop;
    /// weaves `d_x = d_y = 4 R`, 4 vertices per crossing.
    pub fn default_params(self, radius: f64) -> PatternParams {
        if self.is_knit() {
            let (w, s) = match self {
                Pattern::Stockinette => (7.5, 4.0),
                Pattern::Garter => (7.5, 6.0),
                Pattern::Seed => (8.5, 6.0),
                _ => (8.5, 4.0),
            };
            PatternParams {
                radius,
                spacing: [w * radius, s * radius],
                resolution: 24,
            }
        } else {
            PatternParams {
                radius,
                spacing: [4.0 * radius, 4.0 * radius],
                resolution: 4,
            }
        }
    }

    /// The repeat a tile of the pattern ([`Pattern::generate`]) holds, `[along x, along y]`:
    /// loops per course and courses of a knit, warps and wefts of a weave.
    pub fn repeat(self) -> [usize; 2] {
        if self.is_knit() {
            let stitches = self.stitches();
            [stitches[0].len(), stitches.len()]
        } else {
            let m = self.interlacing();
            [m.len(), m[0].len()]
        }
    }

    /// Stitch types (`+1` knit, `−1` purl) by course, for knits: the primitive repeat, whose
    /// course `rows` is course 0 moved by [`Pattern::course_shift`] loops.
    fn stitches(self) -> Vec<Vec<i8>> {
        match self {
            Pattern::Stockinette => vec![vec![1]],
            Pattern::Garter => vec![vec![1], vec![-1]],
            Pattern::Rib1x1 => vec![vec![1, -1]],
            Pattern::Rib2x2 => vec![vec![1, 1, -1, -1]],
            Pattern::Seed => vec![vec![1, -1]],
            _ => vec![],
        }
    }

    /// Loops by which the stitch chart moves along the course from one repeat of
    /// [`Pattern::stitches`] to the next one up: the knit tile's second period is
    /// `a₂ = (course_shift · w, rows · s)`. Zero for rectangular repeats and weaves.
    fn course_shift(self) -> usize {
        match self {
            Pattern::Seed => 1,
            _ => 0,
        }
    }

    /// The stitch chart unrolled onto its rectangular repeat: courses of the primitive repeat
    /// stacked, each moved by [`Pattern::course_shift`], until the shift is a whole number of
    /// repeats along the course.
    fn rectangular_stitches(self) -> Vec<Vec<i8>> {
        let types = self.stitches();
        let cols = types[0].len();
        let mut rows = Vec::new();
        let mut moved = 0;
        loop {
            rows.extend(types.iter().map(|course| {
                (0..cols)
                    .map(|i| course[(i + cols - moved) % cols])
                    .collect::<Vec<_>>()
            }));
            moved = (moved + self.course_shift()) % cols;
            if moved == 0 {
                return rows;
            }
        }
    }

    /// Interlacing matrix `M[warp][weft]` (`+1`: warp over), for weaves.
    fn interlacing(self) -> Vec<Vec<i8>> {
        match self {
            Pattern::PlainWeave => (0..2)
                .map(|i| {
                    (0..2)
                        .map(|k| if (i + k) % 2 == 0 { 1 } else { -1 })
                        .collect()
                })
                .collect(),
            Pattern::BasketWeave => (0..4)
                .map(|i| {
                    (0..4)
                        .map(|k| if (i / 2 + k / 2) % 2 == 0 { 1 } else { -1 })
                        .collect()
                })
                .collect(),
            Pattern::Satin => (0..5)
                .map(|i| {
                    (0..5)
                        .map(|k| if k == (2 * i) % 5 { -1 } else { 1 })
                        .collect()
                })
                .collect(),
            _ => vec![],
        }
    }

    /// The lattice (period and [`Tile::skew`]) and yarn polylines of the geometric guess (see
    /// the module documentation).
    pub fn yarns(self, params: &PatternParams) -> Result<(Lattice, Vec<Yarn>), PatternError> {
        self.yarns_of(params, false)
    }

    /// [`Pattern::yarns`] of the primitive repeat, or of the rectangular one.
    fn yarns_of(
        self,
        params: &PatternParams,
        rectangular: bool,
    ) -> Result<(Lattice, Vec<Yarn>), PatternError> {
        let PatternParams {
            radius,
            spacing,
            resolution,
        } = *params;
        for (name, v) in [
            ("radius", radius),
            ("spacing x", spacing[0]),
            ("spacing y", spacing[1]),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(PatternError::Invalid(format!(
                    "{name} must be positive and finite, found {v}"
                )));
            }
        }
        if self.is_knit() {
            if resolution < 8 {
                return Err(PatternError::Invalid(format!(
                    "knit resolution must be at least 8 vertices per loop, found {resolution}"
                )));
            }
            Ok(if rectangular {
                knit_yarns(&self.rectangular_stitches(), 0, radius, spacing, resolution)
            } else {
                let shift = self.course_shift();
                knit_yarns(&self.stitches(), shift, radius, spacing, resolution)
            })
        } else {
            if resolution < 2 {
                return Err(PatternError::Invalid(format!(
                    "weave resolution must be at least 2 vertices per crossing, found {resolution}"
                )));
            }
            let (period, yarns) = weave_yarns(&self.interlacing(), radius, spacing, resolution);
            Ok((Lattice { period, skew: 0.0 }, yarns))
        }
    }

    /// The geometric initial guess as a tile whose rest shape is its own geometry, on the
    /// pattern's primitive repeat ([`Pattern::repeat`]; sheared for the seed stitch).
    pub fn generate(self, params: &PatternParams) -> Result<Tile, PatternError> {
        let (lattice, yarns) = self.yarns(params)?;
        tile_from_yarns(lattice.period, lattice.skew, params.radius, &yarns)
    }

    /// [`Pattern::generate`] on the pattern's rectangular repeat (`skew = 0`): the same tile
    /// where the primitive repeat is rectangular, the 2 × 2 repeat of the seed stitch (twice
    /// the vertices of its primitive tile). For code that needs rectangular tiles, and to check
    /// a sheared tile against its rectangular repeat.
    pub fn generate_rectangular(self, params: &PatternParams) -> Result<Tile, PatternError> {
        let (lattice, yarns) = self.yarns_of(params, true)?;
        tile_from_yarns(lattice.period, lattice.skew, params.radius, &yarns)
    }
}

/// The periods `[px, py]` (m) and skew ([`Tile::skew`]) of a procedural tile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    /// Periods along x and y (m).
    pub period: [f64; 2],
    /// Lattice skew (unitless): the second period is `(skew · px, py)`.
    pub skew: f64,
}

/// Knit yarns for stitch types `types[course][wale]` whose repeat moves by `course_shift`
/// loops from one repeat up to the next; see the module documentation.
fn knit_yarns(
    types: &[Vec<i8>],
    course_shift: usize,
    radius: f64,
    [w, s]: [f64; 2],
    per_loop: usize,
) -> (Lattice, Vec<Yarn>) {
    let rows = types.len();
    let cols = types[0].len();
    let period = [cols as f64 * w, rows as f64 * s];
    let skew = course_shift as f64 / cols as f64;
    let h = 0.5 * s + 1.3 * radius;
    let z_amp = 1.25 * radius;
    let a = 0.25 * w;
    let t_b = 0.2;
    let mut yarns = Vec::new();
    for j in 0..rows {
        let y_c = (j as f64 + 0.5) * s - 0.5 * period[1];
        let mut points = Vec::with_capacity(cols * per_loop);
        for i in 0..cols {
            let x_c = (i as f64 + 0.5) * w - 0.5 * period[0];
            let sigma = f64::from(types[j][i]);
            // The loop above: in the next course, or in course 0 of the repeat above, which
            // is moved by course_shift loops.
            let up = if j + 1 < rows {
                types[j + 1][i]
            } else {
                types[0][(i + cols - course_shift % cols) % cols]
            };
            let left = types[j][(i + cols - 1) % cols];
            let right = types[j][(i + 1) % cols];
            for k in 0..per_loop {
                let t = TAU * k as f64 / per_loop as f64;
                let p = if up == types[j][i] {
                    -(2.0 * t).cos()
                } else {
                    -(3.0 * t).cos()
                };
                let mut g = 1.0;
                if left != types[j][i] && t < t_b {
                    g *= (0.5 * PI * t / t_b).sin();
                }
                if right != types[j][i] && TAU - t < t_b {
                    g *= (0.5 * PI * (TAU - t) / t_b).sin();
                }
                points.push(Vector3::new(
                    x_c + (t - PI) * w / TAU + a * (2.0 * t).sin(),
                    y_c - h * t.cos(),
                    z_amp * sigma * p * g,
                ));
            }
        }
        yarns.push(Yarn {
            points,
            shift: [1, 0],
        });
    }
    (Lattice { period, skew }, yarns)
}

/// Smooth (C¹) interpolation of crossing values `m[k]` at `u = k + ½` along a periodic yarn
/// of `n` crossings: half-cosine between consecutive crossings.
fn crossing_profile(m: impl Fn(usize) -> f64, n: usize, u: f64) -> f64 {
    let v = u - 0.5;
    let k = v.floor();
    let f = v - k;
    let k = (k as i64).rem_euclid(n as i64) as usize;
    let (m0, m1) = (m(k), m((k + 1) % n));
    0.5 * (m0 + m1) + 0.5 * (m0 - m1) * (PI * f).cos()
}

/// Warp and weft yarns for the interlacing matrix `m[warp][weft]`.
fn weave_yarns(
    m: &[Vec<i8>],
    radius: f64,
    [dx, dy]: [f64; 2],
    per_crossing: usize,
) -> ([f64; 2], Vec<Yarn>) {
    let n = m.len();
    let period = [n as f64 * dx, n as f64 * dy];
    let amp = radius;
    let samples = n * per_crossing;
    let mut yarns = Vec::new();
    for i in 0..n {
        let x = (i as f64 + 0.5) * dx - 0.5 * period[0];
        let points = (0..samples)
            .map(|k| {
                let u = 0.5 + k as f64 / per_crossing as f64;
                let z = amp * crossing_profile(|c| f64::from(m[i][c]), n, u);
                Vector3::new(x, u * dy - 0.5 * period[1], z)
            })
            .collect();
        yarns.push(Yarn {
            points,
            shift: [0, 1],
        });
    }
    for k in 0..n {
        let y = (k as f64 + 0.5) * dy - 0.5 * period[1];
        let points = (0..samples)
            .map(|s| {
                let u = 0.5 + s as f64 / per_crossing as f64;
                let z = -amp * crossing_profile(|c| f64::from(m[c][k]), n, u);
                Vector3::new(u * dx - 0.5 * period[0], y, z)
            })
            .collect();
        yarns.push(Yarn {
            points,
            shift: [1, 0],
        });
    }
    (period, yarns)
}
