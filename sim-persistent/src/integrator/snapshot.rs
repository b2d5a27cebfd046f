//! What a simulator carries from one step to the next, for checkpoints of long runs
//! (`sim-persistent run --resume`, [`crate::scene::checkpoint`]).
//!
//! The state of a step is the coordinates and velocities, the time, the Dirichlet DOFs (pins
//! can be added during a run, e.g. by sticking obstacles) and the friction anchors `ū`
//! (Eq. 5). Everything else that persists between steps is a cache: the Verlet list of yarn
//! contact pairs, the lagged Rayleigh-β matrices, the Newton solver's pattern, carried shift
//! and run count. A restored simulator starts with those caches empty, so a run that is
//! checkpointed empties them at every checkpoint too ([`Simulator::flush_caches`]): then a
//! resumed run repeats the uninterrupted one bit for bit. The time-driven parts (obstacle
//! motion, the wrapping ramp) follow from the time and are set to it on restore.

use super::{SimError, Simulator};
use crate::forces::friction::{AnchoredSpring, ParallelSpring};

/// The step-to-step state of a [`Simulator`] (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Simulated time (s).
    pub time: f64,
    /// Generalized coordinates `q`.
    pub q: Vec<f64>,
    /// Velocities `q̇`.
    pub v: Vec<f64>,
    /// Dirichlet DOFs.
    pub fixed: Vec<bool>,
    /// Anchors `ū` (m) of the friction springs, single springs then parallel pairs, in term
    /// order.
    pub anchors: Vec<f64>,
}

impl Simulator {
    /// The state a checkpoint needs (module documentation).
    pub fn snapshot(&self) -> Snapshot {
        let single = self
            .elastic
            .iter_of::<AnchoredSpring, 1>()
            .map(|(_, s)| s.anchor);
        let pairs = self
            .elastic
            .iter_of::<ParallelSpring, 2>()
            .map(|(_, p)| p.spring.anchor);
        Snapshot {
            time: self.time,
            q: self.state.q.clone(),
            v: self.state.v.clone(),
            fixed: self.fixed.clone(),
            anchors: single.chain(pairs).collect(),
        }
    }

    /// Restores a [`Simulator::snapshot`] of a simulator built the same way (same scene);
    /// the caches start empty. Errors, changing nothing, when the sizes do not match.
    pub fn restore(&mut self, snapshot: &Snapshot) -> Result<(), SimError> {
        let n = self.dofs.n_dofs();
        let springs = self.elastic.iter_of::<AnchoredSpring, 1>().count()
            + self.elastic.iter_of::<ParallelSpring, 2>().count();
        let sizes = [snapshot.q.len(), snapshot.v.len(), snapshot.fixed.len()];
        if sizes != [n; 3] || snapshot.anchors.len() != springs {
            return Err(SimError::Invalid(format!(
                "the snapshot holds {} coordinates and {} friction anchors, this simulator \
                 {n} and {springs}: it was taken of another scene",
                snapshot.q.len(),
                snapshot.anchors.len()
            )));
        }
        if !snapshot.time.is_finite()
            || !snapshot.q.iter().chain(&snapshot.v).all(|x| x.is_finite())
            || !snapshot.anchors.iter().all(|x| x.is_finite())
        {
            return Err(SimError::Invalid(
                "the snapshot holds non-finite values".into(),
            ));
        }
        let mut anchors = snapshot.anchors.iter();
        for (_, spring, _) in self.elastic.iter_mut_of::<AnchoredSpring, 1>() {
            spring.anchor = *anchors.next().expect("counted");
        }
        for (_, pair, _) in self.elastic.iter_mut_of::<ParallelSpring, 2>() {
            pair.spring.anchor = *anchors.next().expect("counted");
        }
        self.fixed.clone_from(&snapshot.fixed);
        self.time = snapshot.time;
        self.state.q.clone_from(&snapshot.q);
        self.state.v.clone_from(&snapshot.v);
        // The time-driven parts as the last step left them: the compression estimate at the
        // start of the next step reads the wrapping rest angles before they are ramped on.
        self.move_obstacles(self.time);
        self.apply_wrapping_ramp(self.time);
        self.flush_caches();
        Ok(())
    }

    /// Empties the caches a restored simulator starts without (module documentation): the
    /// contact pairs are searched again and the damping matrices and the Newton solver rebuilt
    /// at the next step.
    pub fn flush_caches(&mut self) {
        self.contact.searched_at.clear();
        self.damping_built = None;
        self.solver.0 = None;
    }
}
