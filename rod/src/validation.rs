//! Reference configurations with closed-form energies, shared by tests and figures.
//!
//! A smooth rod of bending stiffness `k_b` and curvature κ stores `½ k_b κ² ds` per unit arc
//! length. Sampling a circle or a helix with `n` segments and summing a discrete bending
//! energy must approach the integral as `n` grows; the rate is the discretization's order.

use crate::bending::{AngleBending, BinormalBending, Jamming};
use crate::geometry::V3;
use crate::stencil::Stencil;
use nalgebra::SVector;

/// Which discrete bending energy to sum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BendingModel {
    /// [`BinormalBending`] (Bergou curvature binormal, seed 002 Eq. 6 with κ̄ = 0).
    Binormal,
    /// [`AngleBending`] (seed 000 Eq. 1), without jamming, arc lengths from the rest lengths.
    Angle,
}

/// A helix `(a cos t, a sin t, b t)`: radius `a` (m), pitch `2πb` (m). `b = 0` is a circle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Helix {
    /// Radius a (m).
    pub radius: f64,
    /// Rise per radian b (m).
    pub rise: f64,
}

impl Helix {
    /// The circle used by the convergence test and figure: radius 1 cm.
    pub const REFERENCE_CIRCLE: Helix = Helix {
        radius: 0.01,
        rise: 0.0,
    };
    /// The helix used by the convergence test and figure: radius 1 cm, rise 4 mm per radian.
    pub const REFERENCE_HELIX: Helix = Helix {
        radius: 0.01,
        rise: 0.004,
    };

    /// Curvature `a/(a² + b²)` (1/m).
    pub fn curvature(&self) -> f64 {
        self.radius / (self.radius.powi(2) + self.rise.powi(2))
    }

    /// Arc length per radian of the parameter (m).
    pub fn speed(&self) -> f64 {
        (self.radius.powi(2) + self.rise.powi(2)).sqrt()
    }

    /// Point at parameter t (rad).
    pub fn point(&self, t: f64) -> V3 {
        V3::new(self.radius * t.cos(), self.radius * t.sin(), self.rise * t)
    }
}

/// Discrete and continuous bending energy (J) of the helix over the parameter range
/// `[0, span]` (rad) sampled with `n` equal segments, rest lengths equal to the sampled chords
/// (a rod at rest in its straight state, bent onto the helix). With `closed` (a full circle,
/// `rise = 0`, `span = 2π`) every vertex is interior; otherwise the continuous reference
/// integrates over the arc covered by the interior vertices' Voronoi regions.
pub fn helix_bending_energy(
    model: BendingModel,
    helix: &Helix,
    span: f64,
    n: usize,
    closed: bool,
    stiffness: f64,
) -> (f64, f64) {
    let pts: Vec<V3> = (0..=n)
        .map(|i| helix.point(span * i as f64 / n as f64))
        .collect();
    // Closed curves wrap around (pts[n] duplicates pts[0]); open ones keep both ends free.
    let interior: Vec<usize> = if closed {
        (0..n).collect()
    } else {
        (1..n).collect()
    };
    let mut discrete = 0.0;
    for &i in &interior {
        let prev = if closed { (i + n - 1) % n } else { i - 1 };
        let (x0, x1, x2) = (pts[prev], pts[i], pts[i + 1]);
        let (la, lb) = ((x1 - x0).norm(), (x2 - x1).norm());
        discrete += match model {
            BendingModel::Binormal => {
                let mut q = SVector::<f64, 9>::zeros();
                q.fixed_rows_mut::<3>(0).copy_from(&x0);
                q.fixed_rows_mut::<3>(3).copy_from(&x1);
                q.fixed_rows_mut::<3>(6).copy_from(&x2);
                BinormalBending {
                    stiffness,
                    rest_lengths: (la, lb),
                }
                .energy(&q)
            }
            BendingModel::Angle => {
                let mut q = SVector::<f64, 12>::zeros();
                q.fixed_rows_mut::<3>(0).copy_from(&x0);
                q.fixed_rows_mut::<3>(4).copy_from(&x1);
                q.fixed_rows_mut::<3>(8).copy_from(&x2);
                q[7] = la;
                q[11] = la + lb;
                AngleBending {
                    stiffness,
                    jamming: Jamming::none(),
                }
                .energy(&q)
            }
        };
    }
    let arc = helix.speed() * span;
    let covered = if closed {
        arc
    } else {
        arc * (n as f64 - 1.0) / n as f64
    };
    let continuous = 0.5 * stiffness * helix.curvature().powi(2) * covered;
    (discrete, continuous)
}

/// Least-squares slope of `log(err)` against `log(n)`: the measured order is its negative.
pub fn measured_order(ns: &[usize], errors: &[f64]) -> f64 {
    let xs: Vec<f64> = ns.iter().map(|&n| (n as f64).ln()).collect();
    let ys: Vec<f64> = errors.iter().map(|e| e.ln()).collect();
    let m = xs.len() as f64;
    let (sx, sy) = (xs.iter().sum::<f64>() / m, ys.iter().sum::<f64>() / m);
    let cov: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - sx) * (y - sy)).sum();
    let var: f64 = xs.iter().map(|x| (x - sx).powi(2)).sum();
    -cov / var
}

/// `|discrete − continuous| / continuous` of [`helix_bending_energy`] (the stiffness cancels).
pub fn relative_bending_error(
    model: BendingModel,
    helix: &Helix,
    span: f64,
    n: usize,
    closed: bool,
) -> f64 {
    let (d, c) = helix_bending_energy(model, helix, span, n, closed, 1.0);
    ((d - c) / c).abs()
}
