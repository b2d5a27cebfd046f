//! One backward Euler step of [`Simulator`]: the per-step inertia and damping terms, the
//! Newton solve with the friction return mapping, step halving and the wrapping ramp.

use super::{SimError, Simulator, StepReport};
use crate::forces::Potential;
use crate::forces::compression::slip_forces;
use crate::forces::friction::{AnchoredSpring, ParallelSpring};
use crate::forces::quadratic::Quadratic;
use crate::forces::wrapping::StitchWrap;
use crate::state::{gather, segment_mass_matrix};
use rayon::prelude::*;
use solver::{Concat, NewtonReport, NewtonSolver, RodTerm, SolveError, StepError};

/// Applies `f(spring, coordinate, slip force)` to every friction spring of `terms` at `q`:
/// the single springs on `u`, and the parallel pairs on `Δu` with the slip force stored at
/// their far coordinate `d[1]` ([`crate::forces::compression::slip_forces`]). Returns how
/// many calls returned `true`.
fn each_friction_spring(
    terms: &mut Potential,
    q: &[f64],
    limits: &[f64],
    mut f: impl FnMut(&mut AnchoredSpring, f64, f64) -> bool,
) -> usize {
    let own: usize = terms
        .iter_mut_of::<AnchoredSpring, 1>()
        .map(|(_, spring, d)| usize::from(f(spring, q[d[0]], limits[d[0]])))
        .sum();
    let pairs: usize = terms
        .iter_mut_of::<ParallelSpring, 2>()
        .map(|(_, p, d)| {
            let du = ParallelSpring::delta(q[d[0]], q[d[1]]);
            usize::from(f(&mut p.spring, du, limits[d[1]]))
        })
        .sum();
    own + pairs
}

/// The return-mapping classification of every friction spring of `terms` at `q`
/// ([`AnchoredSpring::classify`]); returns how many changed mode.
fn classify_friction(terms: &mut Potential, q: &[f64], limits: &[f64]) -> usize {
    each_friction_spring(terms, q, limits, |s, u, limit| s.classify(u, limit))
}

/// Ends a step at `q` for every friction spring of `terms` ([`AnchoredSpring::finish_step`]);
/// returns how many slipped.
pub(super) fn finish_friction(terms: &mut Potential, q: &[f64], limits: &[f64]) -> usize {
    each_friction_spring(terms, q, limits, |s, u, limit| s.finish_step(u, limit))
}

impl Simulator {
    /// Advances the state by one step of length `dt` (module documentation). If the Newton
    /// solve of a step fails, the step is replaced by two half steps, recursively, at most
    /// [`super::StepSettings::max_halvings`] times ([`solver::bisect`]); the state only changes on
    /// success.
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        let mut report = StepReport {
            newton_iterations: 0,
            substeps: 0,
            slipped: 0,
            last_newton: None,
            setup_seconds: 0.0,
            newton_seconds: 0.0,
            linear_iterations: 0,
            friction_resolves: 0,
            friction_unresolved: 0,
        };
        solver::bisect(
            self.settings.dt,
            self.settings.max_halvings,
            |&h| (0.5 * h, 0.5 * h),
            |&h, _| match self.solve_step(h, &mut report) {
                Ok(()) => Ok(()),
                // A Newton solve that ran and failed: retry with two half steps.
                Err(SimError::Solve(e)) if e.report().is_some() => {
                    Err(StepError::Halve(SimError::Solve(e)))
                }
                Err(e) => Err(StepError::Abort(e)),
            },
        )
        .map_err(|e| e.source)?;
        Ok(report)
    }

    /// Progress `s ∈ [0, 1]` of the wrapping rest-angle ramp at time `t` (s): the smoothstep
    /// of the module documentation (1 without a ramp).
    pub fn wrapping_ramp_progress(&self, t: f64) -> f64 {
        let duration = self.settings.wrapping_ramp_time;
        if duration <= 0.0 {
            return 1.0;
        }
        let l = (t / duration).clamp(0.0, 1.0);
        l * l * (3.0 - 2.0 * l)
    }

    /// Sets every wrapping term's rest angle to its value on the ramp at time `t` (s).
    pub(super) fn apply_wrapping_ramp(&mut self, t: f64) {
        let s = self.wrapping_ramp_progress(t);
        for &(k, start, target) in &self.wrap_ramp {
            if let Some(wrap) = self.elastic.get_mut::<StitchWrap, 12>(k) {
                wrap.rest_angle = start + s * (target - start);
            }
        }
    }

    /// One backward Euler step of length `h`; commits the state only on success.
    fn solve_step(&mut self, h: f64, report: &mut StepReport) -> Result<(), SimError> {
        let setup_start = std::time::Instant::now();
        self.refresh_contact(false);
        self.move_obstacles(self.time + h);
        // Lagged Coulomb bound (Eq. 5): the compression of the state at the start of the step.
        let limits = self.slip_limits(&self.state.q)?;
        self.apply_wrapping_ramp(self.time + h);
        self.apply_contact_ramp(self.time + h);
        let qn = self.state.q.clone();
        self.update_step_terms(&qn, h);
        if self.solver.0.is_none() {
            let problem = Concat::new(&self.elastic, &self.step);
            self.solver.0 = Some(NewtonSolver::new(&problem, &self.fixed)?);
        }
        let mut q = qn.clone();
        let newton_start = std::time::Instant::now();
        report.setup_seconds += (newton_start - setup_start).as_secs_f64();
        let outcome = self.minimize_step(&mut q, &limits, report);
        report.newton_seconds += newton_start.elapsed().as_secs_f64();
        let newton = match outcome {
            Ok(newton) => newton,
            Err(e) => {
                // The step is retried (halved) from the start state: no slip mode stays.
                let q = self.state.q.clone();
                each_friction_spring(&mut self.elastic, &q, &limits, |s, _, _| {
                    s.slip = None;
                    false
                });
                return Err(e.into());
            }
        };
        for (i, v) in self.state.v.iter_mut().enumerate() {
            *v = if self.fixed[i] {
                0.0
            } else {
                (q[i] - qn[i]) / h
            };
        }
        report.slipped += finish_friction(&mut self.elastic, &q, &limits);
        self.state.q = q;
        self.time += h;
        report.substeps += 1;
        report.newton_iterations += newton.iterations;
        report.linear_iterations += newton.linear_iterations.iter().sum::<usize>();
        report.last_newton = Some(newton);
        Ok(())
    }

    /// Sets the inertia and Rayleigh-β damping terms of a step of length `h` from `qn`.
    fn update_step_terms(&mut self, qn: &[f64], h: f64) {
        let (alpha, beta) = (self.settings.rayleigh_alpha, self.settings.rayleigh_beta);
        let v = &self.state.v;
        let rho = self.params.linear_density;
        let inertia_scale = 1.0 / (h * h) + alpha / h;
        let n_inertia = self.segment_dofs.len();
        // Every form below is independent of the others (each task writes only its own
        // form), so they are built in parallel; the results do not depend on the threads.
        self.step
            .par_iter_mut()
            .take(n_inertia)
            .zip(self.segment_dofs.par_iter())
            .for_each(|(term, d)| {
                if let Some(form) = term.downcast_mut::<RodTerm<Quadratic<8>, 8>>() {
                    let local = gather(qn, d);
                    let q_hat = local + h * gather(v, d); // q̂ = qₙ + h vₙ
                    form.center = (q_hat + alpha * h * local) / (1.0 + alpha * h);
                    form.matrix = inertia_scale * segment_mass_matrix(rho, &local);
                }
            });
        // Rayleigh β forms: the per-stencil eigen-projections of K⁺ are the larger part of
        // the setup, so with `damping_refresh_steps > 1` they are only recomputed every so
        // many steps; in between the lagged matrices are rescaled to the current β/h and
        // recentred at qₙ.
        let factor = beta / h;
        let refresh = self
            .damping_built
            .is_none_or(|(uses, _)| uses >= self.settings.damping_refresh_steps);
        let rescale = match self.damping_built {
            Some((_, built)) if !refresh && built != factor && built > 0.0 => Some(factor / built),
            _ => None,
        };
        let lagged = (!refresh).then_some(rescale);
        let elastic = &self.elastic;
        self.step
            .par_iter_mut()
            .skip(n_inertia)
            .zip(self.damped.par_iter())
            .for_each(|(target, source)| {
                source.update(elastic, qn, factor, lagged, target);
            });
        self.damping_built = Some(match self.damping_built {
            Some((uses, _)) if !refresh => (uses + 1, factor),
            _ => (1, factor),
        });
    }

    /// The Newton minimization of a step from `q` (the solver is built), re-solved for the
    /// friction return mapping ([`StepSettings::friction_return_mapping`]) until no
    /// coordinate changes between sticking and slipping; counts the extra solves in `report`.
    fn minimize_step(
        &mut self,
        q: &mut [f64],
        limits: &[f64],
        report: &mut StepReport,
    ) -> Result<NewtonReport, SolveError> {
        let max_resolves = self.settings.friction_return_mapping;
        let solver = self.solver.0.as_mut().expect("built before the step");
        let mut resolves = 0;
        let outcome = loop {
            let problem = Concat::new(&self.elastic, &self.step);
            let newton = match solver.minimize(&problem, q, &self.settings.newton) {
                Ok(newton) => newton,
                Err(e) => break Err(e),
            };
            if max_resolves == 0 || classify_friction(&mut self.elastic, q, limits) == 0 {
                break Ok(newton);
            }
            if resolves == max_resolves {
                report.friction_unresolved += 1;
                break Ok(newton);
            }
            resolves += 1;
            report.newton_iterations += newton.iterations;
            report.linear_iterations += newton.linear_iterations.iter().sum::<usize>();
        };
        report.friction_resolves += resolves;
        outcome
    }

    /// Slip force (N) of every DOF for the friction anchors (Eq. 5): the constant
    /// [`YarnParams::friction_max_force`] if set, else `μ λ` from the compression estimate at
    /// `q` ([`crate::forces::compression`]).
    pub(super) fn slip_limits(&self, q: &[f64]) -> Result<Vec<f64>, SimError> {
        if let Some(f) = self.params.friction_max_force {
            return Ok(vec![f; self.dofs.n_dofs()]);
        }
        let Some(estimator) = &self.compression else {
            return Ok(vec![0.0; self.dofs.n_dofs()]);
        };
        let c = &self.params.compression;
        let estimates = estimator
            .estimate(&self.elastic, q, &self.dofs, self.params.radius, c)
            .map_err(|e| SimError::Invalid(e.to_string()))?;
        Ok(slip_forces(
            &estimates,
            &self.dofs,
            self.params.friction_coefficient,
            c.solver,
        ))
    }
}
