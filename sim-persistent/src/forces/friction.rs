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
//! **Explicit or implicit anchor update.** In the paper the anchors move only *after* a step
//! (explicit update, the simulator's default). Within the step a coordinate that slides
//! `Δu` then meets a spring force up to `k_f Δu`, far above `F_max` once `Δu > F_max/k_f`
//! (a few nanometres to micrometres for the Table 1 yarns): friction acts as a viscous
//! brake of coefficient ≈ `k_f dt`, and the explicit update reaches Coulomb's law only for
//! steps near `F_max/(k_f v)`, about a microsecond at cloth speeds.
//!
//! [`crate::integrator::StepSettings::friction_return_mapping`] makes the update implicit,
//! a *return mapping* as in plasticity: after a trial solve every coordinate is classified
//! ([`AnchoredSpring::classify`]) as sticking (its spring to the anchor of the step start)
//! or slipping in direction `s` (the constant Coulomb force `−s F_max`, energy
//! `s F_max (u − ū) − F_max²/(2 k_f)`, the Huber continuation of the spring), and the step
//! is re-solved with those modes until no mode changes. The converged step has every
//! slipping coordinate at exactly `F_max` and every sticking one within it: Eq. 5 holds at
//! the end of the step, not one step late. Each inner solve is smooth; only the modes switch
//! between solves (a Huber energy inside one Newton solve, tried earlier, stalled: its
//! stiffness switches from `k_f` to 0 over `F_max/k_f`). Static solves keep the explicit
//! update (without inertia nothing bounds a released coordinate within the solve).
//!
//! **Measured** (the `friction_dt` example with `--loop-contact`: a settled 4 × 4 rib,
//! Table 1 sweater yarn, pulled 8 mm at 0.1 m/s, with the segment floor and loop contact):
//!
//! | dt (ms) | explicit update: pull (N) | return mapping: pull (N) | Newton iterations (explicit / return mapping) |
//! |---|---|---|---|
//! | 1 | 2.68 | 4.23e-3 | 698 / 3 443 |
//! | 0.25 | 0.879 | 4.65e-3 | 1 649 / 8 163 |
//! | 0.1 | 0.384 | 4.33e-3 | 2 905 / 17 665 |
//! | 0.025 | 0.101 | 4.36e-3 | 8 852 / 57 822 |
//!
//! The explicit pull falls with the step toward the return mapping's, which hardly changes:
//! with Coulomb-consistent friction this rib's yarns slide through its barely compressed
//! contacts and it offers a few millinewtons over the whole pull, while the paper's update
//! at its 1 ms step makes it 600 times stiffer. A 4 × 4 garter pulled 1.2 mm along its
//! wales (`tests/friction.rs`) shows the same: the return mapping is 5 % / 24 % off its
//! 0.125 ms pull at 1 / 4 ms, the explicit update 150 % / 168 %. The return mapping costs
//! 4–7× the Newton iterations (3–11 re-solves per step while coordinates slip), its own
//! error grows to 33–58 % of a millinewton pull at 5–10 ms (`persistent-time-vs-error`),
//! and it needs [`super::segment_floor`]
//! (on by default): without it freely sliding yarns drain segments until their nodes meet
//! and the step fails (at 1.6–1.9 mm of that pull). Without [`super::loop_contact`] (off
//! by default) the return-mapping pulls complete but scatter (17–53 mN over the same
//! steps): adjacent loops then pass through each other. It is therefore opt-in; the
//! figures use the paper's update (`rib-stretch` also draws the return mapping's pull).
//!
//! The slip force is the Coulomb bound `F_max = μ λ` (Eq. 5), with λ the compression of the
//! coordinate's contacts estimated by Eqs. 3–4 at the state at the start of the step
//! ([`crate::forces::compression`], [`crate::integrator`]); a constant `F_max`
//! ([`crate::params::YarnParams::friction_max_force`]) is still available.
//!
//! **Parallel stacking** ([`ParallelSpring`]). "For parallel stacked yarns […] the sliding
//! degrees of freedom of both yarns must be involved": the heads of the loops a decrease
//! stacks (K2TOG, SSK, …; [`crate::topology`]) slide along one axis, and contact `i` between
//! stacked yarns `i` and `i + 1` gets one anchored spring on `Δuᵢ = uᵢ − uᵢ₊₁` with anchor
//! `Δūᵢ` (Eq. 5), slipping at `μ λᵢ` of that contact alone. Non-parallel pairs — the upper leg
//! against a head, a weave crossing — keep one spring per sliding coordinate, slipping at
//! `μ` times the compression of the coordinate's non-parallel contacts; a stacked head with
//! only parallel contacts has no spring of its own (it slides with its neighbours).

use nalgebra::{SMatrix, SVector};
use rod::{Evaluation, Stencil};

/// An anchored friction spring on one sliding coordinate (DOF `u`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnchoredSpring {
    /// Stick stiffness `k_f` (N/m).
    pub stiffness: f64,
    /// Anchor `ū` (m).
    pub anchor: f64,
    /// The mode within a step's return mapping: `None` while the coordinate sticks (the
    /// spring acts), `Some(slip)` while it slips (the constant Coulomb force acts). Outside a
    /// step it is `None`.
    pub slip: Option<Slip>,
}

/// A slipping coordinate of a step's return mapping (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slip {
    /// Direction `s = ±1` of `u − ū`.
    pub direction: f64,
    /// Coulomb bound `F_max ≥ 0` (N) of the step.
    pub force: f64,
}

impl AnchoredSpring {
    /// A spring of stiffness `stiffness` (N/m) anchored at `anchor` (m).
    pub fn new(stiffness: f64, anchor: f64) -> Self {
        Self {
            stiffness,
            anchor,
            slip: None,
        }
    }

    /// The return-mapping classification after a trial solve that left the coordinate at `u`
    /// with slip force `max_force` (N, ≥ 0): a sticking coordinate whose spring force exceeds
    /// `max_force` starts slipping in the direction of `u − ū`; a slipping one whose
    /// `s (u − ū)` fell back below the stick limit `max_force / k_f` sticks again. Returns
    /// whether the mode changed. The anchor does not move ([`finish_step`](Self::finish_step)
    /// moves it).
    pub fn classify(&mut self, u: f64, max_force: f64) -> bool {
        let stretch = u - self.anchor;
        let slipping = match self.slip {
            None => self.stiffness * stretch.abs() > max_force,
            Some(slip) => self.stiffness * slip.direction * stretch >= max_force,
        };
        let next = slipping.then(|| Slip {
            direction: match self.slip {
                Some(slip) => slip.direction,
                None => stretch.signum(),
            },
            force: max_force,
        });
        let changed = next.map(|s| s.direction) != self.slip.map(|s| s.direction);
        self.slip = next;
        changed
    }

    /// Ends a step at `u` with slip force `max_force`: a slipping coordinate's anchor moves
    /// to its maximal stick position `ū = u − s max_force/k_f` and the coordinate sticks
    /// again; a sticking one gets the explicit update of Eq. 5
    /// ([`update_anchor`](Self::update_anchor)), which moves nothing after a converged
    /// return mapping. Returns whether the anchor moved.
    pub fn finish_step(&mut self, u: f64, max_force: f64) -> bool {
        match self.slip.take() {
            Some(slip) => {
                self.anchor = u - slip.direction * max_force / self.stiffness;
                true
            }
            None => self.update_anchor(u, max_force),
        }
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
        match self.slip {
            None => 0.5 * self.stiffness * d * d,
            Some(Slip { direction, force }) => {
                direction * force * d - 0.5 * force * force / self.stiffness
            }
        }
    }

    fn eval(&self, q: &SVector<f64, 1>) -> Evaluation<1> {
        let d = q[0] - self.anchor;
        let (gradient, hessian) = match self.slip {
            None => (self.stiffness * d, self.stiffness),
            Some(Slip { direction, force }) => (direction * force, 0.0),
        };
        Evaluation {
            energy: self.energy(q),
            gradient: SVector::<f64, 1>::new(gradient),
            hessian: SMatrix::<f64, 1, 1>::new(hessian),
        }
    }
}

/// Eq. 5 for parallel stacked yarns: an anchored spring on `Δu = u_a − u_b` (DOFs
/// `[u_a, u_b]`, the yarn nearer the upper leg of the stack first), with the stick/slip rules
/// of [`AnchoredSpring`] applied to `Δu`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParallelSpring {
    /// The spring on `Δu` (its anchor is `Δū`, m).
    pub spring: AnchoredSpring,
}

impl ParallelSpring {
    /// A spring of stiffness `stiffness` (N/m) on `Δu` anchored at `anchor` (m).
    pub fn new(stiffness: f64, anchor: f64) -> Self {
        Self {
            spring: AnchoredSpring::new(stiffness, anchor),
        }
    }

    /// `Δu = u_a − u_b` at the spring's two coordinates.
    pub fn delta(ua: f64, ub: f64) -> f64 {
        ua - ub
    }
}

impl Stencil<2> for ParallelSpring {
    fn energy(&self, q: &SVector<f64, 2>) -> f64 {
        self.spring
            .energy(&SVector::<f64, 1>::new(Self::delta(q[0], q[1])))
    }

    fn eval(&self, q: &SVector<f64, 2>) -> Evaluation<2> {
        let e = self
            .spring
            .eval(&SVector::<f64, 1>::new(Self::delta(q[0], q[1])));
        let (g, k) = (e.gradient[0], e.hessian[(0, 0)]);
        Evaluation {
            energy: e.energy,
            gradient: SVector::<f64, 2>::new(g, -g),
            hessian: SMatrix::<f64, 2, 2>::new(k, -k, -k, k),
        }
    }
}
