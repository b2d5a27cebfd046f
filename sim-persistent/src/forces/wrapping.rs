//! Stitch wrapping (seed 000 Eq. 2, §4.2; Appendix Eqs. 7–13).
//!
//! At a stitch contact with nodes `q₀`, `q₁` the yarns are wrapped around each other around
//! the central axis `e = (x₁ − x₀)/‖x₁ − x₀‖` (Eq. 7). For a pair of opposite segments — the
//! segment of one yarn from `q₀` to its neighbour `q₄` and the segment of the other yarn from
//! `q₁` to its neighbour `q₃` (Fig. 8) — the triangles `(q₀, q₁, q₄)` and `(q₀, q₃, q₁)` have
//! normals along
//!
//! ```text
//! v_a = (x₄ − x₁) × (x₀ − x₁),      v_b = (x₀ − x₁) × (x₃ − x₁)       (Eqs. 9–10)
//! ```
//!
//! and the wrapping angle ψ is the angle between them, with `e` as the hinge (Eq. 13). The
//! energy is
//!
//! ```text
//! V = ½ k_w L (ψ − ψ₀)²                                                (Eq. 2)
//! ```
//!
//! with `L` the rest length of the stitch contact and ψ₀ = π/2 in the paper.
//!
//! **Signed angle.** Eq. 13 takes `ψ = arccos(n_a·n_b) ∈ [0, π]`, whose derivative is
//! singular where the triangles are coplanar (ψ = 0 or π; a flat layout starts at ψ ≈ 0).
//! We use the signed angle from `n_a` to `n_b` about `e`,
//! `ψ = atan2(e · (v_a × v_b), v_a · v_b) ∈ (−π, π]`, whose magnitude is Eq. 13's angle and
//! which is smooth through ψ = 0; the sign of ψ₀ then selects the sense of wrapping
//! (opposite for knit and purl stitches, which are mirror images through the fabric plane).
//!
//! **Degenerate wings.** ψ is undefined where a wing lies along the axis (`v_a = 0` or
//! `v_b = 0`: the yarn runs straight through the contact, with no wrapping plane), and its
//! gradient grows like `1/|v_a|` there (Eq. 14). This happens at the side edges, where the
//! upper yarn of a contact is tied off (one yarn per row, see [`crate::topology`]) and the
//! lower yarn's bending turns the contact axis into its leg. We therefore blend Eq. 2 with
//! the energy of an unwrapped pair,
//!
//! ```text
//! V = ½ k_w L (w (ψ − ψ₀)² + (1 − w) ψ₀²),
//! w = (1 + c²)² s_a² s_b² / ((s_a² + c²)(s_b² + c²)),
//! ```
//!
//! with `s_a`, `s_b` the sines of the angles between each wing (`x₄ − x₀`, `x₃ − x₁`) and
//! the axis and `c` = [`DEGENERATE_WING_SIN`]: `w = 1` for wings perpendicular to the axis,
//! `w ≥ 0.98` at 45°, and `w → 0` like `s²` as a wing collapses, so that the energy and its
//! gradient stay bounded and continuous. A collapsed wing costs what a pair at ψ = 0 costs,
//! `½ k_w L ψ₀²`, so the guard only guards the numerics: folding a wing onto the axis is
//! never a way to shed wrapping energy (with the weight alone, `V → 0` there, and 20–45 %
//! of the pairs of settled free swatches under the paper's ψ₀ ended in that state). The
//! blend is ours, not the paper's. Without it the degenerate configurations make Newton fail
//! (the energy jumps across the degenerate set).
//!
//! **Derivatives.** Exact, by the chain rule through seven scalar invariants of the relative
//! vectors `(x₁ − x₀, x₄ − x₀, x₃ − x₁)` (dot products and the triple product, see
//! [`StitchWrap::eval`](rod::Stencil::eval)): the scalar function of the invariants is
//! differentiated by hyper-dual numbers (`rod::hyperdual`), the invariants in closed form.
//! This replaces the Appendix's Eqs. 14–16 (same quantities, fewer terms to get wrong).
//!
//! **Sign of ψ₀ per contact** ([`rest_angle_sign`]). In a real stockinette seen from the
//! knit side, the legs of the loops lie in front and the heads and sinker arcs behind (the
//! purl bumps of the back). At a contact of [`crate::topology`] the two pairs of opposite
//! segments are (sinker of the upper yarn, head of the lower yarn) and (leg of the upper
//! yarn, leg of the lower yarn); folding the first pair to the back and the second to the
//! front gives, with the pair and hinge orders of [`wrap_pairs`], ψ > 0 for both pairs of a
//! left-leg contact and ψ < 0 for both pairs of a right-leg contact (the right leg is the
//! mirror image of the left one, and a mirror flips a signed angle). A purl is the knit
//! mirrored through the fabric plane, so its signs are the opposite. Hence
//! `ψ₀ = σ χ |ψ₀|` with `σ = +1` knit, `−1` purl and `χ = +1` left leg, `−1` right leg. The
//! crate's wrapping tests check these signs on exactly that folded configuration.
//!
//! **No flat wrapped layout.** To first order in the out-of-plane slopes, ψ of a pair is,
//! up to sign and a positive factor, the sum of the outward slopes of its two segments (for
//! a left-leg contact: ψ ∝ −(sinker + head slopes) for the first pair and ∝ +(leg slopes)
//! for the second), and a straight segment shared by two
//! contacts has opposite outward slopes at its two ends. So a flat (or merely offset)
//! layout cannot have all contacts wrapped the same way: uniform wrapping needs the fabric
//! to bend (the second-order slope `−κ ℓ/2` has the same sign at both ends) — which is the
//! curl of §3.1/§5.2.2. The layout therefore starts unwrapped (ψ ≈ 0) and the simulator
//! ramps the rest angles from the layout's angles to ψ₀ during an initial settling phase
//! ([`crate::integrator::StepSettings::wrapping_ramp_time`]).

use crate::topology::{Side, StitchContact, Topology};
use nalgebra::{Matrix3, SMatrix, SVector};
use rod::geometry::V3;
use rod::hyperdual::{self, Real, Vec3};
use rod::{Evaluation, Stencil};

/// Eq. 2 for one pair of opposite segments. DOFs `(x₀, x₁, x₄, x₃)` (12): the stitch
/// contact's nodes `q₀`, `q₁`, the neighbour `q₄` of `q₀` on one yarn and the neighbour `q₃`
/// of `q₁` on the other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StitchWrap {
    /// Wrapping stiffness `k_w` (N; Table 1: 1e-2).
    pub stiffness: f64,
    /// Rest length `L` of the stitch contact (m).
    pub rest_length: f64,
    /// Rest angle ψ₀ (rad; ±π/2 in the paper). The simulator may ramp it
    /// ([`crate::integrator::StepSettings::wrapping_ramp_time`]).
    pub rest_angle: f64,
}

/// Scale `c` of the degenerate-wing weight of [`StitchWrap`] (sine of the wing–axis angle).
/// Below `sin ≈ c` (≈ 6°) the wrapping torque fades out and the energy tends to that of an
/// unwrapped pair; at the 45° wings of the layout the
/// weight is 0.98.
pub const DEGENERATE_WING_SIN: f64 = 0.1;

impl StitchWrap {
    /// The signed wrapping angle ψ (rad) of the module documentation over any scalar, at
    /// `q = (x₀, x₁, x₄, x₃)`.
    pub fn angle<T: Real>(q: &[T; 12]) -> T {
        let (a, p, r) = relative(q);
        angle_relative(a, p, r)
    }

    /// The degenerate-wing weight `w ∈ [0, 1]` of the module documentation at
    /// `q = (x₀, x₁, x₄, x₃)`.
    pub fn weight<T: Real>(q: &[T; 12]) -> T {
        let (a, p, r) = relative(q);
        weight_relative(a, p, r)
    }

    /// Eq. 2 blended by the degenerate-wing weight (module documentation) as a function of
    /// the seven invariants `s = (a·a, p·p, r·r, a·p, a·r, p·r, a·(p × r))` of the relative
    /// vectors `(a, p, r) = (x₁ − x₀, x₄ − x₀, x₃ − x₁)`. With `v_a = a × p`, `v_b = r × a`,
    /// `e·(v_a × v_b) = −|a| a·(p × r)` and `|a| v_a·v_b = |a| ((a·r)(a·p) − (a·a)(p·r))`, so
    /// `ψ = atan2(−|a| a·(p × r), (a·r)(a·p) − (a·a)(p·r))` (the common factor `|a| > 0`
    /// dropped), and `s_a² = 1 − (a·p)²/((a·a)(p·p))`, `s_b² = 1 − (a·r)²/((a·a)(r·r))`.
    fn energy_of_invariants<T: Real>(&self, s: &[T; 7]) -> T {
        let [aa, pp, rr, ap, ar, pr, det] = *s;
        let psi = (-(aa.sqrt() * det)).atan2(ar * ap - aa * pr);
        let sa = T::cst(1.0) - ap * ap / (aa * pp);
        let sb = T::cst(1.0) - ar * ar / (aa * rr);
        let c2 = T::cst(DEGENERATE_WING_SIN * DEGENERATE_WING_SIN);
        let one = T::cst(1.0);
        let weight = (one + c2) * (one + c2) * sa * sb / ((sa + c2) * (sb + c2));
        let rest = T::cst(self.rest_angle);
        let d = psi - rest;
        T::cst(0.5 * self.stiffness * self.rest_length)
            * (weight * d * d + (one - weight) * rest * rest)
    }
}

/// `(a, p, r) = (x₁ − x₀, x₄ − x₀, x₃ − x₁)` of `q = (x₀, x₁, x₄, x₃)`.
fn relative<T: Real>(q: &[T; 12]) -> (Vec3<T>, Vec3<T>, Vec3<T>) {
    let x = |k: usize| Vec3([q[3 * k], q[3 * k + 1], q[3 * k + 2]]);
    let (x0, x1, x4, x3) = (x(0), x(1), x(2), x(3));
    (x1 - x0, x4 - x0, x3 - x1)
}

/// ψ from the relative vectors: `v_a = (x₄ − x₁) × (x₀ − x₁) = a × p` (Eq. 9),
/// `v_b = (x₀ − x₁) × (x₃ − x₁) = r × a` (Eq. 10), hinge `a` (Eq. 7, unnormalized: atan2 is
/// scale invariant).
fn angle_relative<T: Real>(a: Vec3<T>, p: Vec3<T>, r: Vec3<T>) -> T {
    let va = a.cross(&p);
    let vb = r.cross(&a);
    let sin = a.dot(&va.cross(&vb));
    let cos = a.norm() * va.dot(&vb);
    sin.atan2(cos)
}

/// The degenerate-wing weight from the relative vectors (wings `p`, `r`, axis `a`).
fn weight_relative<T: Real>(a: Vec3<T>, p: Vec3<T>, r: Vec3<T>) -> T {
    let (va, vb) = (p.cross(&a), r.cross(&a));
    let l2 = a.dot(&a);
    // sin² of the angle between each wing and the axis.
    let sa = va.dot(&va) / (p.dot(&p) * l2);
    let sb = vb.dot(&vb) / (r.dot(&r) * l2);
    let c2 = T::cst(DEGENERATE_WING_SIN * DEGENERATE_WING_SIN);
    let one = T::cst(1.0);
    (one + c2) * (one + c2) * sa * sb / ((sa + c2) * (sb + c2))
}

/// The skew matrix `[v]×` with `[v]× w = v × w`.
fn skew(v: &V3) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The invariants `s` of [`StitchWrap::energy_of_invariants`] at `q = (x₀, x₁, x₄, x₃)`, their
/// Jacobian `∂s/∂q` (7 × 12) and, if `hessian_weights` is given, `Σ_i F_i ∂²s_i/∂q²`.
fn invariants(
    q: &SVector<f64, 12>,
    hessian_weights: Option<&SVector<f64, 7>>,
) -> ([f64; 7], SMatrix<f64, 7, 12>, SMatrix<f64, 12, 12>) {
    let x = |k: usize| V3::new(q[3 * k], q[3 * k + 1], q[3 * k + 2]);
    let (x0, x1, x4, x3) = (x(0), x(1), x(2), x(3));
    let (a, p, r) = (x1 - x0, x4 - x0, x3 - x1);
    let s = [
        a.dot(&a),
        p.dot(&p),
        r.dot(&r),
        a.dot(&p),
        a.dot(&r),
        p.dot(&r),
        a.dot(&p.cross(&r)),
    ];
    // ∂s/∂(a, p, r) (7 × 9), then the chain to q: ∂a = ∂x₁ − ∂x₀, ∂p = ∂x₄ − ∂x₀,
    // ∂r = ∂x₃ − ∂x₁ (blocks of q: x₀ 0, x₁ 1, x₄ 2, x₃ 3).
    let mut ds = SMatrix::<f64, 7, 9>::zeros();
    let mut put = |row: usize, block: usize, v: V3| {
        for k in 0..3 {
            ds[(row, 3 * block + k)] += v[k];
        }
    };
    put(0, 0, 2.0 * a);
    put(1, 1, 2.0 * p);
    put(2, 2, 2.0 * r);
    put(3, 0, p);
    put(3, 1, a);
    put(4, 0, r);
    put(4, 2, a);
    put(5, 1, r);
    put(5, 2, p);
    put(6, 0, p.cross(&r));
    put(6, 1, r.cross(&a));
    put(6, 2, a.cross(&p));
    let t = relative_jacobian();
    let mut h = SMatrix::<f64, 12, 12>::zeros();
    if let Some(f) = hessian_weights {
        // Σ_i F_i ∂²s_i/∂(a, p, r)²: dot products have constant identity blocks, the triple
        // product the skew blocks ∂²/∂a∂p = −[r]×, ∂²/∂a∂r = [p]×, ∂²/∂p∂r = −[a]×.
        let mut h9 = SMatrix::<f64, 9, 9>::zeros();
        let i3 = Matrix3::<f64>::identity();
        let mut add = |bi: usize, bj: usize, m: Matrix3<f64>| {
            let mut v = h9.fixed_view_mut::<3, 3>(3 * bi, 3 * bj);
            v += m;
            if bi != bj {
                let mut w = h9.fixed_view_mut::<3, 3>(3 * bj, 3 * bi);
                w += m.transpose();
            }
        };
        add(0, 0, 2.0 * f[0] * i3);
        add(1, 1, 2.0 * f[1] * i3);
        add(2, 2, 2.0 * f[2] * i3);
        add(0, 1, f[3] * i3);
        add(0, 2, f[4] * i3);
        add(1, 2, f[5] * i3);
        add(0, 1, -f[6] * skew(&r));
        add(0, 2, f[6] * skew(&p));
        add(1, 2, -f[6] * skew(&a));
        h = t.transpose() * h9 * t;
    }
    (s, ds * t, h)
}

/// `∂(a, p, r)/∂(x₀, x₁, x₄, x₃)` (9 × 12, entries 0 and ±1).
fn relative_jacobian() -> SMatrix<f64, 9, 12> {
    let mut t = SMatrix::<f64, 9, 12>::zeros();
    // (row block, [(column block, sign)]): a = x₁ − x₀, p = x₄ − x₀, r = x₃ − x₁.
    let blocks = [
        (0, [(1, 1.0), (0, -1.0)]),
        (1, [(2, 1.0), (0, -1.0)]),
        (2, [(3, 1.0), (1, -1.0)]),
    ];
    for (row, cols) in blocks {
        for (col, sign) in cols {
            for k in 0..3 {
                t[(3 * row + k, 3 * col + k)] = sign;
            }
        }
    }
    t
}

/// Exact derivatives by the chain rule through the seven invariants: hyper-dual numbers
/// differentiate the scalar function of the invariants (28 cheap passes), the invariants'
/// own derivatives are closed form.
impl Stencil<12> for StitchWrap {
    fn energy(&self, q: &SVector<f64, 12>) -> f64 {
        let (s, _, _) = invariants(q, None);
        self.energy_of_invariants(&s)
    }

    fn eval(&self, q: &SVector<f64, 12>) -> Evaluation<12> {
        let (s, _, _) = invariants(q, None);
        let (energy, f, ff) =
            hyperdual::gradient_and_hessian(&SVector::from(s), |x| self.energy_of_invariants(x));
        let (_, ds, h) = invariants(q, Some(&f));
        Evaluation {
            energy,
            gradient: ds.transpose() * f,
            hessian: ds.transpose() * ff * ds + h,
        }
    }

    fn energy_and_gradient(&self, q: &SVector<f64, 12>) -> (f64, SVector<f64, 12>) {
        let (s, ds, _) = invariants(q, None);
        let (energy, f) = hyperdual::gradient(&SVector::from(s), |x| self.energy_of_invariants(x));
        (energy, ds.transpose() * f)
    }
}

/// The sign `σ χ` of the rest angle ψ₀ of both pairs of `contact` (see the module
/// documentation): `+1` for the left leg of a knit and the right leg of a purl, `−1` for the
/// right leg of a knit and the left leg of a purl.
pub fn rest_angle_sign(contact: &StitchContact) -> f64 {
    let side = match contact.side {
        Side::Left => 1.0,
        Side::Right => -1.0,
    };
    contact.sign.signum() * side
}

/// The pairs of opposite segments of a stitch contact as node quadruples `[q₀, q₁, q₄, q₃]`
/// for [`StitchWrap`] (Fig. 8), two per head through the contact (§4.2: every pair of yarns
/// but the parallel ones, i.e. the upper leg with each stacked head): the upper yarn's
/// neighbour beyond `q₀` with the head's neighbour beyond `q₁`, and — the same with the roles
/// of the two contact nodes swapped — the upper yarn's neighbour beyond `q₁` with the head's
/// neighbour beyond `q₀`. "Beyond" is away from the contact along the yarn, whichever way the
/// yarn runs. A pair is `None` where a yarn ends at the contact.
pub fn wrap_pairs(topology: &Topology, contact: &StitchContact) -> Vec<Option<[usize; 4]>> {
    let [q0, q1] = contact.nodes;
    let up = &contact.upper;
    let pair = |a: usize, b: usize, wa: Option<usize>, wb: Option<usize>| Some([a, b, wa?, wb?]);
    contact
        .lower
        .iter()
        .flat_map(|low| {
            [
                pair(
                    q0,
                    q1,
                    topology.strand_outer(up, 0),
                    topology.strand_outer(low, 1),
                ),
                pair(
                    q1,
                    q0,
                    topology.strand_outer(up, 1),
                    topology.strand_outer(low, 0),
                ),
            ]
        })
        .collect()
}

/// The yarn passes of the wings of [`wrap_pairs`], pair for pair (the `None` pairs left out,
/// so entry `k` belongs to the `k`-th wrapping term [`crate::forces::build_terms`] builds from
/// `contact`): `[[(node, slot) at q₀, at q₄], [(node, slot) at q₁, at q₃]]` of Fig. 8 for the
/// pair's two wings — the upper leg's wing and the wing of the head it wraps with. The
/// compression estimate gives each wing's force to its own yarn pass: the heads of a decrease
/// join the same two nodes, so the nodes alone do not say which head a wing belongs to.
pub fn wrap_wings(topology: &Topology, contact: &StitchContact) -> Vec<[[(usize, usize); 2]; 2]> {
    let up = &contact.upper;
    let up_slots = topology.strand_slots(up);
    contact
        .lower
        .iter()
        .flat_map(|low| {
            let low_slots = topology.strand_slots(low);
            let wing = |at: (usize, usize), beyond: Option<(usize, usize)>| Some([at, beyond?]);
            let pair =
                |a: Option<[(usize, usize); 2]>, b: Option<[(usize, usize); 2]>| Some([a?, b?]);
            [
                pair(
                    wing(up_slots[0], topology.strand_outer_pass(up, 0)),
                    wing(low_slots[1], topology.strand_outer_pass(low, 1)),
                ),
                pair(
                    wing(up_slots[1], topology.strand_outer_pass(up, 1)),
                    wing(low_slots[0], topology.strand_outer_pass(low, 0)),
                ),
            ]
        })
        .flatten()
        .collect()
}
