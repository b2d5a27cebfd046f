//! Sliding friction with anchored springs (seed 000 Eq. 5, §4.4; woven-cloth formulation).
//!
//! Coulomb friction on a sliding coordinate `u` is modelled by a spring to an anchor `ū`:
//!
//! ```text
//! F_u = −k_f (u − ū)              if stick (|k_f (u − ū)| ≤ F_max)
//! F_u = −sign(u − ū) F_max        if slip                                  (Eq. 5)
//! ```
//!
//! During a step the spring `V = ½ k_f (u − ū)²` acts with a fixed anchor (a smooth, convex
//! term for Newton); after the step, a coordinate whose spring force exceeds `F_max` slips:
//! its anchor moves to the maximal stick position `ū = u − sign(u − ū) F_max/k_f` ("we adjust
//! each anchor point according to the deviation of the corresponding sliding coordinate from
//! its maximal stick position"). Slipping dissipates energy and leaves plastic deformation.
//!
//! **The friction force depends on the time step** (the likely cause of the dt-dependence
//! that `persistent-time-vs-error` measures). Within a step a coordinate that slides
//! `Δu` meets a spring force up to `k_f Δu`, far above `F_max` once `Δu > F_max/k_f` (a few
//! nanometres to micrometres for the Table 1 yarns): friction grows with the step; measured
//! rib-stretch pulls differ by 0.55–8× their peak between dt = 0.5–10 ms and 0.25 ms. Capping the spring force at `F_max` inside the solve
//! (Huber or pseudo-Huber energies) was tried: its stiffness switches from `k_f` to 0 over
//! `F_max/k_f`, and the step Newton solves of a settling rib then stalled (50 iterations,
//! residual 1e-3 N), so the anchored spring of the paper stays.
//!
//! The slip force is the Coulomb bound `F_max = μ λ` (Eq. 5), with λ the compression of the
//! coordinate's contacts estimated by Eqs. 3–4 at the state at the start of the step
//! ([`crate::forces::compression`], [`crate::integrator`]); a constant `F_max`
//! ([`crate::params::YarnParams::friction_max_force`]) is still available.
//!
//! **Non-parallel stacking only.** Every contact node of the current topologies joins two
//! yarns with different sliding directions — a weave crossing (warp ⟂ weft), or a knit
//! stitch-contact node, where the leg of the upper loop and the head of the lower loop
//! cross (both run through the contact's two nodes, but they wrap around each other there
//! and leave the contact in different directions) — so each yarn's sliding coordinate
//! has its own spring ("for non-parallel stacked yarns, friction is modeled using anchored
//! springs on each yarn's sliding coordinate independently", §4.4). The pair spring of
//! Eq. 5 on `Δu = uᵢ − uᵢ₊₁` is for parallel stacked yarns, which only stacked stitches
//! (K2TOG, SSK; reserved in [`crate::chart`], no topology yet) create; it is not
//! implemented.

use nalgebra::{SMatrix, SVector};
use rod::{Evaluation, Stencil};

/// An anchored friction spring on one sliding coordinate (DOF `u`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnchoredSpring {
    /// Stick stiffness `k_f` (N/m).
    pub stiffness: f64,
    /// Anchor `ū` (m).
    pub anchor: f64,
}

impl AnchoredSpring {
    /// A spring of stiffness `stiffness` (N/m) anchored at `anchor` (m).
    pub fn new(stiffness: f64, anchor: f64) -> Self {
        Self { stiffness, anchor }
    }

    /// The stick/slip update of Eq. 5 after a step at sliding coordinate `u` (m) with slip
    /// force `max_force` (N, ≥ 0). Returns whether the coordinate slipped.
    pub fn update_anchor(&mut self, u: f64, max_force: f64) -> bool {
        let stretch = u - self.anchor;
        if self.stiffness * stretch.abs() <= max_force {
            return false;
        }
        self.anchor = u - stretch.signum() * max_force / self.stiffness;
        true
    }
}

impl Stencil<1> for AnchoredSpring {
    fn energy(&self, q: &SVector<f64, 1>) -> f64 {
        let d = q[0] - self.anchor;
        0.5 * self.stiffness * d * d
    }

    fn eval(&self, q: &SVector<f64, 1>) -> Evaluation<1> {
        let d = q[0] - self.anchor;
        Evaluation {
            energy: 0.5 * self.stiffness * d * d,
            gradient: SVector::<f64, 1>::new(self.stiffness * d),
            hessian: SMatrix::<f64, 1, 1>::new(self.stiffness),
        }
    }
}
