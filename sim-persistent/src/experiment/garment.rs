//! Garments knitted in the round from charts and dressed on a body mesh (issue 18; seed 000's
//! headline result is a sweater of 56 K loops on a character, Fig. 1, §5.3).
//!
//! - **Charts.** [`hat_chart`]: a 2 × 2 rib brim, a stockinette body and a crown that narrows
//!   in `sectors` decrease lines (K2TOG at the end of each sector, every other round, then
//!   every round) to one loop per sector. [`sweater_chart`]: a rib hem, a stockinette body and
//!   a yoke that narrows the same way to a neck opening of a given fraction of the body. Both
//!   are knitted in the round ([`Construction::Round`]: one yarn spiralling up a tube, rows
//!   along +y, [`crate::layout`]), with every stitch of [`crate::chart`].
//! - **Bodies.** [`revolved`]: a closed surface of revolution about the y axis with elliptic
//!   cross-sections (a profile of heights and semi-axes, capped at both ends); [`head`] and
//!   [`mannequin`] (hips, waist, chest, shoulders, neck and head) are profiles of it, written
//!   as OBJ for scene files by [`write_obj`].
//! - **Dressing.** [`Dressing::new`] lays the garment out and moves the body up the tube's
//!   axis as far as it goes while every yarn node and segment midpoint keeps a clearance from it
//!   (measured on the body mesh; a scan in 1 mm steps to the first contact, then bisection),
//!   so the garment starts around the body without touching it; then gravity (−y) and the stitch wrapping that ramps in over the
//!   first 0.1 s (the knit contracts, [`crate::forces::wrapping`]) pull it onto the body
//!   (frictionless penalty contact, [`crate::forces::obstacle`], nodes and segment midpoints).
//!
//! Yarn: Table 1 sweater (R = 0.75 mm), loop width 3 mm, Rayleigh α = 10 /s, β = 0.01 s,
//! every default force term, gravity along −y.

use std::path::Path;

use rod::geometry::V3;

use crate::chart::Chart;
use crate::forces::ForceSet;
use crate::forces::obstacle::mesh::{DEFAULT_REACH, TriangleMesh};
use crate::forces::obstacle::{Obstacle, Shape, contact_points};
use crate::integrator::{SimError, Simulator, StepSettings};
use crate::layout::{Layout, LayoutParams};
use crate::params::YarnParams;
use crate::topology::{Construction, Topology};

/// Loop width (m) of the garments: Table 1's sweater.
pub const LOOP_WIDTH: f64 = 3e-3;

/// Clearance (m) between a yarn surface and the body when the garment is laid out.
pub const CLEARANCE: f64 = 1e-3;

/// A round of `loops` plain knits.
fn plain(loops: usize) -> String {
    format!("K{loops}")
}

/// A decrease round of `sectors` repeats of `K{k} K2TOG`.
fn decrease(sectors: usize, k: usize) -> String {
    let unit = if k == 0 {
        "K2TOG".to_string()
    } else {
        format!("K{k} K2TOG")
    };
    vec![unit; sectors].join(" ")
}

/// The rounds of a narrowing in `sectors` lines from `sectors × width` loops to
/// `sectors × end` loops: a decrease every other round while the sectors are at least
/// `every_round_below` wide, then every round.
fn narrowing(sectors: usize, width: usize, end: usize, every_round_below: usize) -> Vec<String> {
    let mut rounds = Vec::new();
    let mut w = width;
    while w > end {
        rounds.push(decrease(sectors, w - 2));
        w -= 1;
        if w > end && w >= every_round_below {
            rounds.push(plain(sectors * w));
        }
    }
    rounds
}

/// A 2 × 2 rib round of `loops` (a multiple of 4).
fn rib(loops: usize) -> String {
    vec!["K2 P2"; loops / 4].join(" ")
}

/// The straight part of a garment knitted in the round: a cast-on round of `loops`, `rib`
/// rib rounds and `plain` plain rounds.
fn tube_rows(loops: usize, rib_rounds: usize, plain_rounds: usize) -> Vec<String> {
    let mut rows = vec![plain(loops)];
    rows.extend(std::iter::repeat_n(rib(loops), rib_rounds));
    rows.extend(std::iter::repeat_n(plain(loops), plain_rounds));
    rows
}

/// A hat (module documentation): `sectors × sector_width` loops around (a multiple of 4),
/// `brim` rib rounds, `body` plain rounds and a crown down to `sectors` loops. Errors if the
/// sizes do not make a hat.
pub fn hat_chart(
    sectors: usize,
    sector_width: usize,
    brim: usize,
    body: usize,
) -> anyhow::Result<Chart> {
    let loops = sectors * sector_width;
    anyhow::ensure!(
        sectors >= 3 && sector_width >= 2 && loops.is_multiple_of(4),
        "a hat needs ≥ 3 sectors of ≥ 2 loops and a multiple of 4 loops around, got {sectors} × {sector_width}"
    );
    let mut rows = tube_rows(loops, brim, body);
    rows.extend(narrowing(sectors, sector_width, 1, 5));
    Ok(Chart::parse(&rows.join("\n"))?)
}

/// A sweater body (module documentation): `sectors × sector_width` loops around (a multiple
/// of 4), `hem` rib rounds, `body` plain rounds and a yoke narrowing to `neck_width` loops per
/// sector. Errors if the sizes do not make one.
pub fn sweater_chart(
    sectors: usize,
    sector_width: usize,
    hem: usize,
    body: usize,
    neck_width: usize,
) -> anyhow::Result<Chart> {
    let loops = sectors * sector_width;
    anyhow::ensure!(
        sectors >= 3 && neck_width >= 1 && sector_width > neck_width && loops.is_multiple_of(4),
        "a sweater needs ≥ 3 sectors, a neck narrower than the body and a multiple of 4 loops \
         around, got {sectors} × {sector_width} → {neck_width}"
    );
    let mut rows = tube_rows(loops, hem, body);
    rows.extend(narrowing(sectors, sector_width, neck_width, usize::MAX));
    Ok(Chart::parse(&rows.join("\n"))?)
}

/// A body profile: heights (m, increasing) with the semi-axes along x and z (m) of the
/// elliptic cross-section there.
#[derive(Clone, Debug)]
pub struct Profile {
    /// `(y, a, c)`: height, semi-axis along x, semi-axis along z (m).
    pub rings: Vec<(f64, f64, f64)>,
}

impl Profile {
    /// The semi-axes at height `y` (linear between rings), `None` outside the profile.
    pub fn axes_at(&self, y: f64) -> Option<(f64, f64)> {
        let r = &self.rings;
        if y < r[0].0 || y > r[r.len() - 1].0 {
            return None;
        }
        let k = r.partition_point(|p| p.0 <= y).clamp(1, r.len() - 1);
        let (lo, hi) = (r[k - 1], r[k]);
        let t = if hi.0 > lo.0 {
            (y - lo.0) / (hi.0 - lo.0)
        } else {
            0.0
        };
        Some((lo.1 + t * (hi.1 - lo.1), lo.2 + t * (hi.2 - lo.2)))
    }

    /// Whether `p` (body frame) lies inside the body grown by `margin` (m) across the
    /// cross-section at its height (and within `margin` of the caps' heights). Not a distance
    /// bound where the profile slopes: [`Dressing::new`] measures clearance on the mesh.
    pub fn near(&self, p: &V3, margin: f64) -> bool {
        let (y0, y1) = (self.rings[0].0, self.rings[self.rings.len() - 1].0);
        let y = p.y.clamp(y0, y1);
        if (p.y - y).abs() > margin {
            return false;
        }
        let (a, c) = self.axes_at(y).expect("clamped into the profile");
        let (a, c) = (a + margin, c + margin);
        (p.x / a).powi(2) + (p.z / c).powi(2) <= 1.0
    }

    /// An ellipsoid of semi-axes `(a, b, c)` centred at height `b` (bottom at 0), sampled in
    /// `rings` rings.
    pub fn ellipsoid(a: f64, b: f64, c: f64, rings: usize) -> Self {
        let rings = (0..=rings)
            .map(|k| {
                let theta = std::f64::consts::PI * k as f64 / rings as f64;
                let s = (std::f64::consts::PI - theta).sin();
                (b - b * theta.cos(), a * s, c * s)
            })
            .collect();
        Self { rings }
    }
}

/// A closed surface of revolution of `profile` with `segments` vertices per ring, wound
/// counter-clockwise seen from outside: rings of zero radius become single vertices, and open
/// ends are capped with a centre vertex. Searched within `reach` (m).
pub fn revolved(profile: &Profile, segments: usize, reach: f64) -> Result<TriangleMesh, String> {
    if profile.rings.len() < 2 || segments < 3 {
        return Err("a surface of revolution needs ≥ 2 rings and ≥ 3 segments".into());
    }
    if profile.rings.windows(2).any(|w| w[1].0 < w[0].0) {
        return Err("profile heights must increase".into());
    }
    let mut vertices = Vec::new();
    // Per ring: the index of its first vertex and whether it is a single point.
    let mut rings = Vec::new();
    for &(y, a, c) in &profile.rings {
        if a <= 0.0 || c <= 0.0 {
            rings.push((vertices.len(), true));
            vertices.push(V3::new(0.0, y, 0.0));
        } else {
            rings.push((vertices.len(), false));
            for s in 0..segments {
                let phi = std::f64::consts::TAU * s as f64 / segments as f64;
                vertices.push(V3::new(a * phi.sin(), y, c * phi.cos()));
            }
        }
    }
    let mut triangles = Vec::new();
    let v = |ring: (usize, bool), s: usize| -> u32 {
        (if ring.1 {
            ring.0
        } else {
            ring.0 + s % segments
        }) as u32
    };
    for w in rings.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        for s in 0..segments {
            // Seen from outside with y up, φ grows to the right: (lo s, lo s+1, hi s+1) is
            // counter-clockwise.
            let (a, b, c, d) = (v(lo, s), v(lo, s + 1), v(hi, s + 1), v(hi, s));
            if a != b {
                triangles.push([a, b, c]);
            }
            if c != d {
                triangles.push([a, c, d]);
            }
        }
    }
    // Caps.
    for (end, (first, point)) in [(0, rings[0]), (1, rings[rings.len() - 1])] {
        if point {
            continue;
        }
        let y = profile.rings[if end == 0 { 0 } else { profile.rings.len() - 1 }].0;
        let centre = vertices.len() as u32;
        vertices.push(V3::new(0.0, y, 0.0));
        for s in 0..segments {
            let (a, b) = ((first + s) as u32, (first + (s + 1) % segments) as u32);
            // (centre, φ, φ + dφ) faces +y: the top cap's outside.
            triangles.push(if end == 0 {
                [centre, b, a]
            } else {
                [centre, a, b]
            });
        }
    }
    TriangleMesh::new(vertices, triangles, reach)
}

/// The head a hat of `loops` loops around is dressed on in the `garment` figure and its
/// tests: semi-axes 0.8, 0.9 and 0.85 times the laid-out hat's radius `loops · w / 2π`, so the
/// knit contracts onto it.
pub fn head_for_hat(loops: usize) -> Profile {
    let radius = loops as f64 * LOOP_WIDTH / std::f64::consts::TAU;
    head(0.8 * radius, 0.9 * radius, 0.85 * radius)
}

/// A head: an ellipsoid of semi-axes `(a, b, c)` (m) on a neck of radius `0.45 a` and height
/// `b`, bottom at 0.
pub fn head(a: f64, b: f64, c: f64) -> Profile {
    let neck = 0.45 * a;
    let mut rings = vec![(0.0, neck, neck), (b, neck, neck)];
    let skull = Profile::ellipsoid(a, b, c, 24);
    // The skull's rings from where it is as wide as the neck (below the equator) up.
    for &(y, ra, rc) in &skull.rings {
        let y = y + b;
        if ra >= neck || y > 2.0 * b {
            rings.push((y, ra, rc));
        }
    }
    Profile { rings }
}

/// A mannequin of height ≈ `height` (m): hips, waist, chest, shoulders, neck and head as
/// elliptic cross-sections, bottom at 0.
pub fn mannequin(height: f64) -> Profile {
    // Fractions of the height: (y, a, c), an adult torso from the hips up.
    let shape = [
        (0.00, 0.000, 0.000),
        (0.00, 0.180, 0.120),
        (0.10, 0.185, 0.125),
        (0.22, 0.160, 0.110),
        (0.36, 0.175, 0.125),
        (0.46, 0.185, 0.120),
        (0.52, 0.190, 0.105),
        (0.56, 0.150, 0.090),
        (0.585, 0.090, 0.070),
        (0.60, 0.055, 0.055),
        (0.68, 0.055, 0.055),
        (0.71, 0.080, 0.090),
        (0.78, 0.100, 0.115),
        (0.85, 0.095, 0.110),
        (0.90, 0.070, 0.080),
        (0.92, 0.000, 0.000),
    ];
    Profile {
        rings: shape
            .iter()
            .map(|&(y, a, c)| (y * height, a * height, c * height))
            .collect(),
    }
}

/// Writes `mesh` as an OBJ file (vertices in m, counter-clockwise faces), through the
/// workbench's OBJ writer.
pub fn write_obj(mesh: &TriangleMesh, path: &Path) -> anyhow::Result<()> {
    let points = mesh.vertices().iter().map(|v| [v.x, v.y, v.z]);
    let text = yarn_output::obj::triangles_to_string(
        points,
        mesh.triangles(),
        "sim-persistent body mesh (m)",
    );
    yarn_output::write_file(path, text.as_bytes())?;
    Ok(())
}

/// A garment laid out around a body and ready to be dropped onto it (module documentation).
pub struct Dressing {
    /// The simulator (gravity −y, the body as a mesh obstacle).
    pub sim: Simulator,
    /// The body mesh where it is (m).
    pub body: TriangleMesh,
    /// The body's height offset (m): its profile's `y = 0` is at this height.
    pub body_offset: f64,
    /// The yarn.
    pub params: YarnParams,
}

impl Dressing {
    /// Lays `chart` out in the round, places the body `profile` (revolved with `segments`
    /// vertices per ring) on the tube's axis as high as it goes with every yarn surface at
    /// least [`CLEARANCE`] away, and builds the simulator with `settings` (gravity along
    /// −y). Errors if the garment's tube is too narrow for the body.
    pub fn new(
        chart: &Chart,
        profile: &Profile,
        segments: usize,
        settings: StepSettings,
    ) -> anyhow::Result<Self> {
        let topology = Topology::knit_with(chart, Construction::Round)?;
        let mut params = YarnParams::sweater();
        params.gravity = V3::new(0.0, -9.81, 0.0);
        let layout = Layout::new(&topology, &LayoutParams::new(LOOP_WIDTH, params.radius))?;
        let margin = params.radius + CLEARANCE;
        let top = layout
            .positions
            .iter()
            .map(|p| p.y)
            .fold(f64::NEG_INFINITY, f64::max);
        let body_top = profile.rings[profile.rings.len() - 1].0;
        // The contact points: the nodes and the segment midpoints.
        let points = contact_points(&topology, &layout.positions);
        let body = revolved(profile, segments, DEFAULT_REACH).map_err(anyhow::Error::msg)?;
        // Clear: outside the profile and at least `margin` from the mesh's surface.
        let clear = |offset: f64| {
            points.iter().all(|p| {
                let local = p - V3::new(0.0, offset, 0.0);
                !profile.near(&local, 0.0)
                    && body
                        .signed_distance(&local)
                        .is_none_or(|(d, _, _)| d >= margin)
            })
        };
        // Move the body up the axis from below the garment in 1 mm steps to the first
        // contact, then bisect between the last clear and the first touching height.
        let bottom = layout
            .positions
            .iter()
            .map(|p| p.y)
            .fold(f64::INFINITY, f64::min);
        let mut lo = bottom - body_top - margin - 1e-3;
        let step = 1e-3;
        let mut hi = lo;
        while clear(hi) {
            lo = hi;
            hi += step;
            anyhow::ensure!(
                hi < top + margin,
                "the body passes through the garment without touching it (no narrowing holds it)"
            );
        }
        anyhow::ensure!(
            lo + body_top > bottom + margin,
            "the garment's tube is too narrow for the body: it touches the garment before \
             entering it (a yarn node within {margin} m)"
        );
        for _ in 0..30 {
            let mid = 0.5 * (lo + hi);
            if clear(mid) { lo = mid } else { hi = mid }
        }
        let body_offset = lo;
        let moved: Vec<V3> = body
            .vertices()
            .iter()
            .map(|v| v + V3::new(0.0, body_offset, 0.0))
            .collect();
        let body = body.with_vertices(moved).map_err(anyhow::Error::msg)?;
        let mut sim = Simulator::new(topology, &layout, params, ForceSet::default(), settings)?;
        sim.add_obstacles(&[
            Obstacle::new(Shape::mesh(body.clone()), None).map_err(anyhow::Error::msg)?
        ])?;
        Ok(Self {
            sim,
            body,
            body_offset,
            params,
        })
    }

    /// Runs `steps` steps; returns the Newton iterations.
    pub fn run(&mut self, steps: usize) -> Result<usize, SimError> {
        let mut iterations = 0;
        for _ in 0..steps {
            iterations += self.sim.step()?.newton_iterations;
        }
        Ok(iterations)
    }

    /// The lowest signed gap (m) of any yarn node or segment midpoint to the body surface
    /// (negative: penetration).
    pub fn lowest_gap(&self) -> f64 {
        let shape = &self
            .sim
            .obstacles()
            .first()
            .expect("the body is the first obstacle")
            .shape;
        contact_points(self.sim.topology(), &super::positions(&self.sim))
            .iter()
            .map(|x| shape.distance(x).0 - self.params.radius)
            .fold(f64::INFINITY, f64::min)
    }
}
