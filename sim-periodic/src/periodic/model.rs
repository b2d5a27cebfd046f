//! The yarn material model and the errors of periodic-tile problems.

use rod::contact::{BarrierPhase, Simpson};
use rod::stretch::StretchLaw;
use solver::SolveError;
use yarn_pattern::tile::TileError;

/// Yarn material parameters (SI). The defaults are illustrative values for a ~1 mm yarn, not
/// fitted ones; paper 002 §7 fits them to fabric tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YarnModel {
    /// Stretch law (seed 002 Eq. 5), stiffnesses in N.
    pub stretch: StretchLaw,
    /// Bending stiffness k_b (N·m²).
    pub bending: f64,
    /// Twist stiffness k_t (N·m²).
    pub twist: f64,
    /// Contact phases `[soft large-radius, stiff small-radius]` (seed 002 Eq. 7).
    pub contact: [BarrierPhase; 2],
    /// Simpson quadrature of the contact integral along each edge.
    pub quadrature: Simpson,
    /// Pairs of edges on one yarn strand closer than this along the yarn (m) are not in
    /// contact (they are neighbours).
    pub min_arc_separation: f64,
}

impl YarnModel {
    /// Illustrative defaults for yarn radius `r` (m): two-phase stretch `k₁ = 20 N`,
    /// `k₂ = 200 N` past 3 % strain; `k_b = 5e-6 N·m²`; `k_t = 4e-6 N·m²`; contact phases
    /// `(1e3 J/m², R₁ = r)` and `(1e6 J/m², R₂ = r/4)` (R₂ = 0.25 R as in seed 002 §6.3);
    /// Simpson with 4 intervals; neighbours within `4 r` along the yarn skipped.
    ///
    /// Why 4 intervals, not the paper's 3-point rule (2 intervals): the barrier is only felt at
    /// the quadrature points, and on the real stockinette tile (edges ≈ 1.2 R) under biaxial
    /// stretch (sx, sy) = (0.7, 0.25…0.7) two yarns squeeze between the 3 × 3 points of the
    /// 2-interval rule: with the collision filter ([`solver::Problem::max_step`]) Newton then
    /// stalls, without it the tile unravels (Ψ falls from 327 to 5 J/m²). With 4 intervals the
    /// closest approach stays at the stiff core (0.44 R at (0.7, 0, 0.7)) and every solve
    /// converges; Ψ at (−0.05, 0, −0.05) changes by 1.3 %.
    pub fn default_for_radius(r: f64) -> Self {
        Self {
            stretch: StretchLaw::TwoPhase {
                k1: 20.0,
                k2: 200.0,
                onset: 0.03,
            },
            bending: 5e-6,
            twist: 4e-6,
            contact: [
                BarrierPhase {
                    stiffness: 1e3,
                    radius: r,
                },
                BarrierPhase {
                    stiffness: 1e6,
                    radius: 0.25 * r,
                },
            ],
            quadrature: Simpson { intervals: 4 },
            min_arc_separation: 4.0 * r,
        }
    }

    /// The model of the shared yarn description (`rod::yarn`): its stretch law, bending and
    /// twist stiffnesses, and the contact phases of [`YarnModel::default_for_radius`] for its
    /// radius (soft phase at `R₁ = R`, stiff core at `R/4`). Friction and linear density
    /// have no counterpart: the tile is a frictionless quasi-static equilibrium.
    pub fn from_material(yarn: &rod::yarn::YarnMaterial) -> Result<Self, String> {
        yarn.validate()?;
        Ok(Self {
            stretch: yarn.stretch,
            bending: yarn.bending,
            twist: yarn.twist,
            ..Self::default_for_radius(yarn.radius)
        })
    }

    /// Centreline distance (m) below which two edges interact.
    pub fn contact_cutoff(&self) -> f64 {
        2.0 * self.contact[0].radius.max(self.contact[1].radius)
    }
}

/// Errors of periodic-tile problems.
#[derive(Debug, thiserror::Error)]
pub enum PeriodicError {
    /// The tile is inconsistent.
    #[error("invalid tile: {0}")]
    Tile(#[from] TileError),
    /// The solver failed (carries its report).
    #[error("equilibrium solve failed: {0}")]
    Solve(#[from] SolveError),
    /// The coarse deformation or the model is not admissible.
    #[error("invalid input: {0}")]
    Invalid(String),
}
