//! Yarn–yarn contact between two edges.
//!
//! - [`closest_points`]: robust closest points of two segments (parallel and degenerate cases
//!   included), used for broad phases and diagnostics.
//! - [`EdgeContact`] — seed 002, Eq. 7: the two-phase barrier
//!   `W = Σᵢ k_cᵢ L_a L_b ∫₀¹∫₀¹ f(min(D(a,b)/2Rᵢ, 1)²) da db`,
//!   `f(x) = −(x − 1)² log x` (Li et al. 2020's IPC barrier on relative squared distance),
//!   `D(a, b)` the distance between the points at parameters `a`, `b` of the two edges, the
//!   double integral evaluated with composite Simpson's rule.

use crate::geometry::V3;
use crate::stencil::{Evaluation, Stencil};
use nalgebra::SVector;

/// Closest points of segments `[p0, p1]` and `[q0, q1]`: returns `(s, t, distance)` with the
/// points `p0 + s (p1 − p0)` and `q0 + t (q1 − q0)`, `s, t ∈ [0, 1]`. Handles zero-length and
/// parallel segments (then one of the closest pairs is returned). After Ericson, *Real-Time
/// Collision Detection* §5.1.9.
pub fn closest_points(p0: &V3, p1: &V3, q0: &V3, q1: &V3) -> (f64, f64, f64) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    // Relative threshold for "zero length" (squared lengths).
    let tiny = f64::EPSILON * (a + e + r.norm_squared()).max(f64::MIN_POSITIVE);
    let (s, t) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            // Parallel segments have denom ≈ 0: pick s = 0 and let the clamping below resolve t.
            let mut s = if denom > f64::EPSILON * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let dist = ((p0 + s * d1) - (q0 + t * d2)).norm();
    (s, t, dist)
}

/// The IPC barrier `f(x) = −(x − 1)² log x` on `x ∈ (0, 1]` with `(f, f', f'')`; zero for
/// `x ≥ 1` (C² there: `f(1) = f'(1) = 0`, `f''(1) = 0`).
pub fn barrier(x: f64) -> (f64, f64, f64) {
    if x >= 1.0 {
        return (0.0, 0.0, 0.0);
    }
    let l = x.ln();
    let y = x - 1.0;
    (
        -y * y * l,
        -2.0 * y * l - y * y / x,
        -2.0 * l - 4.0 * y / x + y * y / (x * x),
    )
}

/// One barrier phase: stiffness `k_c` (J/m², so that `k_c L_a L_b` is an energy) and contact
/// radius `R` (m): the barrier acts for centreline distances `D < 2R`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarrierPhase {
    /// Stiffness k_c (J/m²).
    pub stiffness: f64,
    /// Contact radius R (m).
    pub radius: f64,
}

/// Composite Simpson's rule on `[0, 1]` with an even number of intervals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Simpson {
    /// Number of intervals per edge (even, ≥ 2). 2 gives the classic 3-point rule.
    pub intervals: usize,
}

impl Simpson {
    /// The rule with `intervals` intervals; `None` unless even and ≥ 2.
    pub fn new(intervals: usize) -> Option<Self> {
        (intervals >= 2 && intervals.is_multiple_of(2)).then_some(Self { intervals })
    }

    /// Node `i` (0 ..= intervals) and its weight.
    pub fn node(&self, i: usize) -> (f64, f64) {
        let n = self.intervals;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        (i as f64 / n as f64, w / (3.0 * n as f64))
    }
}

impl Default for Simpson {
    fn default() -> Self {
        Self { intervals: 2 }
    }
}

/// Seed 002 Eq. 7 between edges `a = [x_a0, x_a1]` and `b = [x_b0, x_b1]`; DOFs
/// `(x_a0, x_a1, x_b0, x_b1)` (12). The caller skips pairs of neighbouring edges along one
/// yarn (they always touch) and pairs farther apart than `2 max Rᵢ` (broad phase; the energy
/// is exactly zero there, see [`EdgeContact::cutoff`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeContact {
    /// The barrier phases: seed 002 uses a soft large-radius and a stiff small-radius one.
    pub phases: [BarrierPhase; 2],
    /// Rest lengths `(L_a, L_b)` of the two edges (m).
    pub rest_lengths: (f64, f64),
    /// Quadrature along each edge.
    pub quadrature: Simpson,
}

impl EdgeContact {
    /// Centreline distance (m) beyond which the energy is zero.
    pub fn cutoff(&self) -> f64 {
        2.0 * self.phases[0].radius.max(self.phases[1].radius)
    }

    fn split(q: &SVector<f64, 12>) -> [V3; 4] {
        std::array::from_fn(|k| q.fixed_rows::<3>(3 * k).into())
    }

    /// Visits every quadrature point with its combined weight and the point-difference
    /// coefficients `c` (so that `d = Σ c_k x_k`).
    fn for_each_point(&self, mut visit: impl FnMut(f64, [f64; 4])) {
        let n = self.quadrature.intervals;
        for i in 0..=n {
            let (a, wa) = self.quadrature.node(i);
            for j in 0..=n {
                let (b, wb) = self.quadrature.node(j);
                visit(wa * wb, [1.0 - a, a, -(1.0 - b), -b]);
            }
        }
    }

    fn scale(&self) -> f64 {
        self.rest_lengths.0 * self.rest_lengths.1
    }
}

impl Stencil<12> for EdgeContact {
    fn energy(&self, q: &SVector<f64, 12>) -> f64 {
        let x = Self::split(q);
        let mut e = 0.0;
        self.for_each_point(|w, c| {
            let d: V3 = (0..4).map(|k| c[k] * x[k]).sum();
            let d2 = d.norm_squared();
            for p in &self.phases {
                e += w * p.stiffness * barrier(d2 / (4.0 * p.radius * p.radius)).0;
            }
        });
        self.scale() * e
    }

    fn eval(&self, q: &SVector<f64, 12>) -> Evaluation<12> {
        let x = Self::split(q);
        let mut out = Evaluation::<12>::zero();
        let s = self.scale();
        // With g(d) = f(|d|²/4R²) and d = Σ c_a x_a at each point: ∇_a g = c_a f' 2d/4R² and
        // ∇²_ab g = c_a c_b (f'' (2d)(2d)ᵀ/(4R²)² + f' 2I/4R²). Summed over the points, the
        // Hessian is a sum of rank-one terms `α u uᵀ` with `u = c ⊗ d` (12 entries) plus
        // `(Σ β c cᵀ) ⊗ I`, accumulated as such instead of block by block.
        let mut isotropic = [[0.0; 4]; 4];
        self.for_each_point(|w, c| {
            let d: V3 = (0..4).map(|k| c[k] * x[k]).sum();
            let d2 = d.norm_squared();
            for p in &self.phases {
                let r2 = 4.0 * p.radius * p.radius;
                let (f, f1, f2) = barrier(d2 / r2);
                if f1 == 0.0 && f2 == 0.0 {
                    continue;
                }
                let k = s * w * p.stiffness;
                let beta = 2.0 * f1 / r2;
                let alpha = 4.0 * f2 / (r2 * r2);
                out.energy += k * f;
                let u: [f64; 12] = std::array::from_fn(|i| c[i / 3] * d[i % 3]);
                for (i, ui) in u.iter().enumerate() {
                    out.gradient[i] += k * beta * ui;
                }
                let ku = u.map(|ui| k * alpha * ui);
                for (j, kuj) in ku.iter().enumerate() {
                    let mut column = out.hessian.column_mut(j);
                    for (hij, ui) in column.iter_mut().zip(&u) {
                        *hij += ui * kuj;
                    }
                }
                for (a, row) in isotropic.iter_mut().enumerate() {
                    for (b, entry) in row.iter_mut().enumerate() {
                        *entry += k * beta * c[a] * c[b];
                    }
                }
            }
        });
        for (a, row) in isotropic.iter().enumerate() {
            for (b, &entry) in row.iter().enumerate() {
                for i in 0..3 {
                    out.hessian[(3 * a + i, 3 * b + i)] += entry;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent reference: the distance from p(s) to segment q is convex in s, so a
    /// ternary search over s finds the minimum to round-off.
    fn reference_distance(p0: &V3, p1: &V3, q0: &V3, q1: &V3) -> f64 {
        let to_q = |s: f64| {
            let p = p0 + s * (p1 - p0);
            let d = q1 - q0;
            let t = if d.norm_squared() > 0.0 {
                ((p - q0).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (q0 + t * d)).norm()
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..200 {
            let m1 = lo + (hi - lo) / 3.0;
            let m2 = hi - (hi - lo) / 3.0;
            if to_q(m1) < to_q(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        to_q(0.5 * (lo + hi))
    }

    #[test]
    fn closest_points_cases() {
        let v = V3::new;
        // Crossing segments 1 apart.
        let (s, t, d) = closest_points(
            &v(-1., 0., 0.),
            &v(1., 0., 0.),
            &v(0., -1., 1.),
            &v(0., 1., 1.),
        );
        assert!((s - 0.5).abs() < 1e-15 && (t - 0.5).abs() < 1e-15 && (d - 1.0).abs() < 1e-15);
        // Parallel overlapping segments.
        let (_, _, d) = closest_points(
            &v(0., 0., 0.),
            &v(2., 0., 0.),
            &v(1., 0.3, 0.),
            &v(3., 0.3, 0.),
        );
        assert!((d - 0.3).abs() < 1e-15);
        // Parallel, disjoint along the axis.
        let (s, t, d) = closest_points(
            &v(0., 0., 0.),
            &v(1., 0., 0.),
            &v(2., 0., 0.),
            &v(3., 0., 0.),
        );
        assert!((s - 1.0).abs() < 1e-15 && t.abs() < 1e-15 && (d - 1.0).abs() < 1e-15);
        // A point and a segment.
        let (_, t, d) = closest_points(
            &v(0.5, 1., 0.),
            &v(0.5, 1., 0.),
            &v(0., 0., 0.),
            &v(1., 0., 0.),
        );
        assert!((t - 0.5).abs() < 1e-15 && (d - 1.0).abs() < 1e-15);
        // Two points.
        let (_, _, d) = closest_points(
            &v(0., 0., 0.),
            &v(0., 0., 0.),
            &v(0., 3., 4.),
            &v(0., 3., 4.),
        );
        assert!((d - 5.0).abs() < 1e-15);
    }

    #[test]
    fn closest_points_match_a_ternary_search_on_random_segments() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..200 {
            let p: [V3; 4] = std::array::from_fn(|_| V3::new(rnd(), rnd(), rnd()));
            let (s, t, d) = closest_points(&p[0], &p[1], &p[2], &p[3]);
            let reference = reference_distance(&p[0], &p[1], &p[2], &p[3]);
            assert!(
                (reference - d).abs() < 1e-12,
                "reference {reference} vs {d}"
            );
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t));
        }
    }

    #[test]
    fn barrier_is_zero_and_flat_at_contact_radius() {
        assert_eq!(barrier(1.0), (0.0, 0.0, 0.0));
        let (f, f1, f2) = barrier(1.0 - 1e-6);
        assert!(f.abs() < 1e-17 && f1.abs() < 1e-11 && f2.abs() < 1e-5);
        assert!(barrier(1e-3).0 > barrier(1e-2).0);
    }

    #[test]
    fn simpson_integrates_cubics_exactly() {
        for n in [2, 4, 8] {
            let rule = Simpson::new(n).unwrap();
            let integral: f64 = (0..=n)
                .map(|i| {
                    let (x, w) = rule.node(i);
                    w * (4.0 * x * x * x - x + 2.0)
                })
                .sum();
            assert!((integral - 2.5).abs() < 1e-14);
        }
        assert!(Simpson::new(3).is_none() && Simpson::new(0).is_none());
    }
}
