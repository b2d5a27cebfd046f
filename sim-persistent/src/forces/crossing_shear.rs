//! Shear at the crossings of woven cloth, with shear jamming (seed 000 §3.2.1, §4.1: the
//! shear jamming model of ref. 6, Cirio et al. 2014, which seed 000 adapts for bending
//! jamming).
//!
//! A crossing node `x₀` (one warp and one weft through it) has up to four *quadrants*: one
//! neighbour `x_a` along the weft (previous or next pass of the weft yarn) and one neighbour
//! `x_b` along the warp. Each quadrant carries the energy of the angle `φ` between its two
//! yarn edges `a = x_a − x₀` and `b = x_b − x₀` (the ref. 6 form, one "shear spring" per
//! pair of adjacent segments):
//!
//! ```text
//! V = ½ k_x L ψ(φ − φ₀),      ψ(γ) = φ_J(|γ|),
//! ```
//!
//! with `k_x` the shear stiffness (N), `L` the mean rest length of the two edges (m), `φ₀`
//! the rest angle (rad, taken from the layout: π/2 for the grid layouts of
//! [`crate::layout`]), and `φ_J` the jamming profile of [`rod::bending::Jamming`] (the same
//! smooth ×`factor` stiffening that seed 000 uses for bending jamming): `ψ = γ²` below the
//! jamming angle `γ_j`, and past it the stiffness `ψ''` grows smoothly from 2 to
//! `2·factor` over `width` rad. So for small shear `V = ½ k_x L (φ − φ₀)²` exactly; ψ is even
//! in γ, so shear in either sense jams. Under an in-plane shear by γ two quadrants of a
//! crossing open to `φ₀ + γ` and two close to `φ₀ − γ`, so an interior crossing stores
//! `2 k_x L ψ(γ)`.
//!
//! **Chain rule.** `V` is a function of `ĉ = cos(π − φ)`, the cosine of the turning angle
//! of the polyline `x_a → x₀ → x_b`, so the derivatives of `ĉ` come from
//! [`rod::bending::cosine_function_derivatives`] (shared with yarn bending). With
//! `φ = acos(−ĉ)`: `dφ/dĉ = 1/sin φ`, `d²φ/dĉ² = −cos φ/sin³ φ`. Undefined where the two yarns
//! are parallel at the crossing (`sin φ = 0`), far past jamming.
//!
//! **Documented choices.** The stencil acts on positions only (ref. 6 has no shear force on
//! the sliding coordinates) and `L` is fixed at its rest value (sliding does not change the
//! stiffness). Neither paper gives numbers for `k_x` or `γ_j`; see
//! [`CrossingShearParams`] for the defaults and their reasons. Assembled only for weaves
//! ([`crate::forces::ForceSet::crossing_shear`]).

use crate::state::DofMap;
use crate::topology::Topology;
use nalgebra::SVector;
use rod::bending::{Jamming, cosine_function_derivatives};
use rod::geometry::V3;
use rod::{Evaluation, Stencil};

/// Parameters of the crossing shear (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossingShearParams {
    /// Shear stiffness `k_x` (N). Ref. 6 writes it as `S R²` with a shear modulus S; neither
    /// paper lists a value. Default `2e-2 N`: with the yarn spacing `w = 3 mm` of the Table 1
    /// sweater and four quadrants per crossing (`L = w`), the fabric's initial shear rigidity
    /// is `G = 4 k_x L / w² = 4 k_x / w ≈ 27 N/m per rad ≈ 0.5 gf/cm/deg`, the low end of the
    /// KES shear rigidity of plain-woven fabrics (≈ 0.5–2 gf/cm/deg).
    pub stiffness: f64,
    /// Shear jamming: the profile in `|γ| = |φ − φ₀|` (rad). Default threshold
    /// `γ_j = π/3`, the geometric jamming angle `acos(2R/w)` of the Table 1 presets (all three
    /// have `w = 4R`): at that shear the spacing between neighbouring yarns, `w cos γ`,
    /// equals the yarn diameter. Width 0.1 rad and factor 1000 as bending jamming (seed 000
    /// §4.1: "three orders of magnitude").
    pub jamming: Jamming,
}

impl Default for CrossingShearParams {
    fn default() -> Self {
        Self {
            stiffness: 2e-2,
            jamming: Jamming {
                angle: std::f64::consts::FRAC_PI_3,
                ..Jamming::default()
            },
        }
    }
}

impl CrossingShearParams {
    /// Checks the ranges: `k_x ≥ 0`, `0 ≤ γ_j < π/2`, width > 0, factor ≥ 1, all finite.
    pub fn validate(&self) -> Result<(), String> {
        let j = &self.jamming;
        if !(self.stiffness.is_finite() && self.stiffness >= 0.0) {
            return Err(format!(
                "crossing shear stiffness must be finite and ≥ 0 N, got {}",
                self.stiffness
            ));
        }
        if !(j.angle.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&j.angle)) {
            return Err(format!(
                "crossing shear jamming angle must be in [0, π/2) rad, got {}",
                j.angle
            ));
        }
        if !(j.width.is_finite() && j.width > 0.0) {
            return Err(format!(
                "crossing shear jamming width must be finite and > 0 rad, got {}",
                j.width
            ));
        }
        if !(j.factor.is_finite() && j.factor >= 1.0) {
            return Err(format!(
                "crossing shear jamming factor must be finite and ≥ 1, got {}",
                j.factor
            ));
        }
        Ok(())
    }
}

/// The shear energy of one quadrant of a crossing (module documentation). DOFs
/// `(x_a, x₀, x_b)`: the weft neighbour, the crossing node and the warp neighbour (9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossingShear {
    /// Shear stiffness `k_x` (N).
    pub stiffness: f64,
    /// Length `L` (m): the mean rest length of the two edges.
    pub length: f64,
    /// Rest angle `φ₀` (rad) between the two edges.
    pub rest_angle: f64,
    /// Jamming profile in `|φ − φ₀|`.
    pub jamming: Jamming,
}

fn points(q: &SVector<f64, 9>) -> (V3, V3, V3) {
    (
        q.fixed_rows::<3>(0).into(),
        q.fixed_rows::<3>(3).into(),
        q.fixed_rows::<3>(6).into(),
    )
}

/// `(sin φ, cos φ)` of the angle at `x0` between `xa − x0` and `xb − x0`.
fn sine_cosine(xa: &V3, x0: &V3, xb: &V3) -> (f64, f64) {
    let (a, b) = (xa - x0, xb - x0);
    let n = a.norm() * b.norm();
    (a.cross(&b).norm() / n, a.dot(&b) / n)
}

impl CrossingShear {
    /// The angle φ (rad) at `x₀` between the edges to `x_a` and `x_b` (`q = (x_a, x₀, x_b)`).
    pub fn angle(q: &SVector<f64, 9>) -> f64 {
        let (xa, x0, xb) = points(q);
        let (s, c) = sine_cosine(&xa, &x0, &xb);
        s.atan2(c)
    }

    /// `(ψ, ψ', ψ'')` at shear angle γ (rad): the jamming profile evaluated at `|γ|`.
    pub fn shape(&self, gamma: f64) -> (f64, f64, f64) {
        let (p, dp, ddp) = self.jamming.profile(gamma.abs());
        (p, gamma.signum() * dp, ddp)
    }
}

impl Stencil<9> for CrossingShear {
    fn energy(&self, q: &SVector<f64, 9>) -> f64 {
        let gamma = Self::angle(q) - self.rest_angle;
        0.5 * self.stiffness * self.length * self.shape(gamma).0
    }

    fn eval(&self, q: &SVector<f64, 9>) -> Evaluation<9> {
        let (xa, x0, xb) = points(q);
        let (s, c) = sine_cosine(&xa, &x0, &xb);
        let gamma = s.atan2(c) - self.rest_angle;
        let (p, dp, ddp) = self.shape(gamma);
        let w = 0.5 * self.stiffness * self.length;
        // V(ĉ) with φ = acos(−ĉ): dφ/dĉ = 1/sin φ, d²φ/dĉ² = −cos φ/sin³ φ.
        let f1 = w * dp / s;
        let f2 = w * (ddp / (s * s) - dp * c / (s * s * s));
        let (gradient, hessian) = cosine_function_derivatives(&xa, &x0, &xb, f1, f2);
        Evaluation {
            energy: w * p,
            gradient,
            hessian,
        }
    }
}

/// The quadrants of the crossing at `node`: `[x_a, x₀, x_b]` node triples, one per
/// (weft neighbour, warp neighbour) pair that exists (4 inside the fabric, 2 on an edge, 1
/// at a corner). The weft is the node's slot 0 and the warp its slot 1
/// ([`Topology::weave`]); nodes without two yarns have none.
pub fn quadrants(topology: &Topology, node: usize) -> Vec<[usize; 3]> {
    let passes = &topology.nodes[node].passes;
    if passes.len() != 2 {
        return Vec::new();
    }
    let neighbours = |slot: usize| -> Vec<usize> {
        let np = passes[slot];
        let yarn = &topology.yarns[np.yarn].passes;
        let mut out = Vec::with_capacity(2);
        if np.index > 0 {
            out.push(yarn[np.index - 1].node);
        }
        if let Some(p) = yarn.get(np.index + 1) {
            out.push(p.node);
        }
        out
    };
    let (weft, warp) = (neighbours(0), neighbours(1));
    weft.iter()
        .flat_map(|&a| warp.iter().map(move |&b| [a, node, b]))
        .collect()
}

/// The crossing-shear stencils of every crossing of `topology` with their position DOFs,
/// rest angles and lengths taken from `q_rest` (normally the layout).
pub fn stencils(
    topology: &Topology,
    dofs: &DofMap,
    params: &CrossingShearParams,
    q_rest: &[f64],
) -> Vec<(CrossingShear, [usize; 9])> {
    let mut out = Vec::new();
    for crossing in &topology.crossings {
        for nodes in quadrants(topology, crossing.node) {
            let d: [usize; 9] = std::array::from_fn(|k| dofs.x(nodes[k / 3]) + k % 3);
            let rest = crate::state::gather(q_rest, &d);
            let (xa, x0, xb) = points(&rest);
            out.push((
                CrossingShear {
                    stiffness: params.stiffness,
                    length: 0.5 * ((xa - x0).norm() + (xb - x0).norm()),
                    rest_angle: CrossingShear::angle(&rest),
                    jamming: params.jamming,
                },
                d,
            ));
        }
    }
    out
}
