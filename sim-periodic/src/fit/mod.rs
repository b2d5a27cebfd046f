//! Yarn-level parameter estimation from uniform target curves (seed 002 §7).
//!
//! The pipeline of the paper's main contribution: a thin shell fitted to fabric tests produces
//! uniform target curves (`shell-fem curves`); this module fits the mechanical parameters of
//! the periodic yarn model to them.
//!
//! - [`parameters`]: the optimized parameters `p = {k_s1, Ȳ_s, k_b, R₁, k_c1}` and their
//!   bounds (§7.3.2);
//! - [`objective`]: the rest-shape estimation (§7.2) and the objective of Eq. 11 (§7.3.1);
//! - [`targets`]: reading the target curves;
//! - [`journal`]: the evaluation journal that makes a fit resumable;
//! - [`fit`] (here): global search by particle swarm ([`argmin`]'s), then local refinement,
//!   by default Levenberg–Marquardt on the residuals of Eq. 11 with Jacobians from implicit
//!   differentiation of every equilibrium ([`crate::periodic::stress_sensitivities`]; beyond
//!   the paper), or COBYLA ([`cobyla`], as the paper, §7.3.3).
//!
//! Beyond the paper, the input geometry's proportions can be searched too: stretch factors
//! along x and y applied to it before the rest-shape estimation ([`Parameter::GeometryX`],
//! [`Parameter::GeometryY`]). The swarm and COBYLA search them with the rest;
//! Levenberg–Marquardt too, with forward differences for their Jacobian columns, since they
//! act only through the rest-shape estimation, which is not differentiated
//! ([`FitSettings::local_geometry`]).
//!
//! **Differences from the paper.** The swarm is argmin's standard PSO (SPSO 2011: constant
//! inertia `1/(2 ln 2)`, cognitive and social factors `½ + ln 2`) by default; the paper's
//! decaying inertia (0.9 → 0.1) is [`SwarmSettings::inertia`] (argmin's swarm with the weight
//! set before each iteration; the `yarn-fit` figure uses it), and its heuristic repulsion is
//! not available. The swarm is
//! sized for two cores
//! ([`SwarmSettings`]), not the paper's 64 particles × 10 steps on 256 cores. After the
//! rest-shape rounds the period is relaxed to zero normal coarse stress
//! ([`ObjectiveSettings::stress_free_period`]).

pub mod journal;
pub mod objective;
pub mod parameters;
pub mod targets;

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use argmin::core::{CostFunction, Executor, KV, PopulationState, Problem, Solver, State};
use argmin::solver::particleswarm::{Particle, ParticleSwarm};
use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::SeedableRng;
use rayon::prelude::*;

use crate::curves::CurveError;
use crate::patterns::PatternError;
use crate::periodic::{PeriodicError, YarnModel};
pub use journal::Journal;
pub use objective::{
    Evaluation, Objective, ObjectiveSettings, Sample, SampleLayout, Solved, comfort_end,
};
pub use parameters::{
    Bound, Parameter, ParameterSpace, estimated_radius, parameter_partial, stretched_geometry,
};
pub use targets::{TargetPoint, Targets};

/// Errors of the yarn-parameter fit.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// An input file is malformed (line 0: the file as a whole).
    #[error("{}{}: {problem}", path.display(), if *line > 0 { format!(", line {line}") } else { String::new() })]
    Input {
        /// The file.
        path: PathBuf,
        /// 1-based line, 0 when not about one line.
        line: usize,
        /// What is wrong and what was expected.
        problem: String,
    },
    /// A setting or parameter is not admissible.
    #[error("invalid fit input: {0}")]
    Invalid(String),
    /// The rest-shape estimation failed.
    #[error("rest-shape estimation: {0}")]
    RestShape(#[from] PatternError),
    /// The stress-free period could not be found.
    #[error("rest period: {0}")]
    RestPeriod(#[from] crate::database::GenerationError),
    /// A compression root-find failed.
    #[error("compression: {0}")]
    Curve(#[from] CurveError),
    /// A stress sample could not be solved.
    #[error("{direction} stretch s = {s}: {source}")]
    Solve {
        /// Direction name.
        direction: &'static str,
        /// Stretch.
        s: f64,
        /// Solver error.
        source: PeriodicError,
    },
    /// A periodic-tile problem could not be built.
    #[error(transparent)]
    Periodic(#[from] PeriodicError),
    /// The optimizer failed.
    #[error("optimizer: {0}")]
    Optimizer(String),
    /// No candidate could be evaluated.
    #[error("every one of {0} evaluations failed; the last error: {1}")]
    NothingEvaluated(usize, String),
}

/// Smallest ∞-norm distance (normalized coordinates) between two local starts
/// ([`FitSettings::local_starts`]).
pub const LOCAL_START_SEPARATION: f64 = 0.25;

/// Settings of the global search.
#[derive(Clone, Debug, PartialEq)]
pub struct SwarmSettings {
    /// Particles. Default 16.
    pub particles: usize,
    /// Swarm iterations after the initial population. Default 6.
    pub iterations: u64,
    /// Seed of the swarm's random numbers (a fit is reproducible for a given seed).
    pub seed: u64,
    /// Inertia weight on the particles' velocity at the first and the last iteration, linear
    /// in between (the paper, §7.3.3: 0.9 to 0.1). Default: argmin's constant `1/(2 ln 2)`
    /// ([`constant_inertia`]) at both ends.
    pub inertia: (f64, f64),
    /// Independent restarts of the whole fit (beyond the paper): swarms with the seeds
    /// `seed, seed + 1, …`, each followed by its local search; the lowest final objective
    /// wins (the first on ties). The cost grows linearly. The swarm's basin is chance: on the
    /// development fabric of the `yarn-fit` figure four seeds ended at g 0.073–0.157
    /// (`bench::figures::yarn_fit`'s docs). Default 1.
    pub restarts: usize,
}

/// argmin's constant inertia weight of the particle swarm, `1/(2 ln 2)`.
pub fn constant_inertia() -> f64 {
    1.0 / (2.0 * 2f64.ln())
}

impl Default for SwarmSettings {
    fn default() -> Self {
        Self {
            particles: 16,
            iterations: 6,
            seed: 2022,
            inertia: (constant_inertia(), constant_inertia()),
            restarts: 1,
        }
    }
}

/// Settings of a fit.
#[derive(Clone, Debug)]
pub struct FitSettings {
    /// The global search; `None` starts the local search at [`FitSettings::start`] (the
    /// "no swarm" ablation of Fig. 11).
    pub swarm: Option<SwarmSettings>,
    /// The local start without a swarm (normalized). Default: the middle of the box.
    pub start: Option<Vec<f64>>,
    /// Objective settings of the swarm (the paper: 7 samples per direction).
    pub swarm_objective: ObjectiveSettings,
    /// Objective settings of the local search and the final evaluation (the paper: 20).
    pub local_objective: ObjectiveSettings,
    /// The local method. Default [`LocalMethod::LevenbergMarquardt`].
    pub local: LocalMethod,
    /// Most local evaluations (COBYLA: at least `n + 2`) or iterations (Levenberg–Marquardt,
    /// at least 1). Default 60.
    pub local_evaluations: usize,
    /// COBYLA's initial step in the normalized box. Default 0.1.
    pub local_step: f64,
    /// Levenberg–Marquardt after a swarm: runs from the swarm's best and from the next-best
    /// evaluated points at least [`LOCAL_START_SEPARATION`] from every start before them, up
    /// to this many starts in all (run in parallel), and keeps the lowest objective. Default 1.
    pub local_starts: usize,
    /// The local search stops when a step changes every normalized coordinate by less than
    /// this. Default 1e-4.
    pub local_x_tol: f64,
    /// Levenberg–Marquardt refines the geometric parameters ([`Parameter::is_geometric`]) too.
    /// They act through the rest-shape estimation only, which is not differentiated: their
    /// Jacobian columns are forward differences (step [`GEOMETRY_DIFFERENCE_STEP`]), one
    /// extra evaluation per geometric parameter at the start and at every accepted
    /// Levenberg–Marquardt point (rejected trial points need no Jacobian). `false` keeps them
    /// at the start (the swarm's choice). Default `true`.
    ///
    /// The differences are about half of the local phase's evaluations. Differencing them
    /// less often, with Broyden's update carrying the columns in between, was faster by up to
    /// a third but moved the fits to other paths with no consistent gain, so it is not
    /// offered (measured in `reports/yarn-fit/NOTES.md`).
    pub local_geometry: bool,
}

impl FitSettings {
    /// Sets the sample layout of both phases' objectives ([`ObjectiveSettings::layout`]).
    pub fn set_sample_layout(&mut self, layout: SampleLayout) {
        self.swarm_objective.layout = layout;
        self.local_objective.layout = layout;
    }
}

/// Forward-difference step (normalized coordinates) of the geometric parameters' Jacobian
/// columns in Levenberg–Marquardt ([`FitSettings::local_geometry`]): 2 % of the box,
/// e.g. 0.012 in stretch for the bounds (0.75, 1.35).
pub const GEOMETRY_DIFFERENCE_STEP: f64 = 0.02;

/// The local refinement after the swarm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocalMethod {
    /// Derivative-free COBYLA on `g`, as the paper (§7.3.3).
    Cobyla,
    /// Bounded Levenberg–Marquardt ([`solver::bounded_lm`]) on the residuals of `g` with the
    /// Jacobian from implicit differentiation of every equilibrium
    /// ([`Objective::evaluate_with_jacobian`]); beyond the paper.
    LevenbergMarquardt,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            swarm: Some(SwarmSettings::default()),
            start: None,
            swarm_objective: ObjectiveSettings::default(),
            local_objective: ObjectiveSettings {
                samples: 20,
                ..ObjectiveSettings::default()
            },
            local: LocalMethod::LevenbergMarquardt,
            local_evaluations: 60,
            local_step: 0.1,
            local_starts: 1,
            local_x_tol: 1e-4,
            local_geometry: true,
        }
    }
}

/// Progress of a fit, passed to the callback after every evaluation.
#[derive(Clone, Debug)]
pub struct Progress {
    /// `swarm`, `local` or `final`.
    pub phase: &'static str,
    /// Evaluations of this phase so far (journaled ones included).
    pub evaluations: usize,
    /// Best objective value of this phase so far.
    pub best: f64,
    /// Whether this evaluation came from the journal.
    pub resumed: bool,
}

/// The result of [`fit`].
#[derive(Clone, Debug)]
pub struct FitResult {
    /// The fitted model.
    pub model: YarnModel,
    /// Its normalized point.
    pub x: Vec<f64>,
    /// Its free parameter values (SI, in the space's order).
    pub values: Vec<f64>,
    /// The stretch `[a_x, a_y]` of the input geometry the model was fitted on
    /// ([`ParameterSpace::geometry_stretch`]; `[1, 1]` without geometric parameters): the
    /// model belongs to [`parameters::stretched_geometry`] of the input at it.
    pub geometry_stretch: [f64; 2],
    /// The swarm's best point and value, if a swarm ran.
    pub swarm_best: Option<(Vec<f64>, f64)>,
    /// The evaluation of the fitted model with the local objective settings.
    pub evaluation: Evaluation,
    /// Evaluations per phase: swarm, local (journaled ones included).
    pub evaluations: [usize; 2],
    /// Failed evaluations (no equilibrium for the candidate), counted as `+∞`.
    pub failed: usize,
    /// Wall time (s) of each phase: swarm (with the choice of the local starts), local search
    /// (with the final evaluation); summed over the restarts.
    pub seconds: [f64; 2],
    /// How the local search stopped.
    pub local_status: String,
}

/// A phase's cost: the journaled objective.
struct Cost<'a> {
    objective: Objective<'a>,
    space: &'a ParameterSpace,
    journal: &'a Journal,
    phase: &'static str,
    count: AtomicUsize,
    failed: AtomicUsize,
    best: std::sync::Mutex<f64>,
    last_error: std::sync::Mutex<String>,
    progress: &'a (dyn Fn(&Progress) + Sync),
    /// Every finite evaluation `(x, g)`, for the local starts.
    seen: std::sync::Mutex<Vec<(Vec<f64>, f64)>>,
}

impl<'a> Cost<'a> {
    fn new(
        objective: Objective<'a>,
        space: &'a ParameterSpace,
        journal: &'a Journal,
        phase: &'static str,
        progress: &'a (dyn Fn(&Progress) + Sync),
    ) -> Self {
        Self {
            objective,
            space,
            journal,
            phase,
            count: AtomicUsize::new(0),
            failed: AtomicUsize::new(0),
            best: std::sync::Mutex::new(f64::INFINITY),
            last_error: std::sync::Mutex::new(String::new()),
            progress,
            seen: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// `first`, then evaluated points, best first, each at least `separation` (∞-norm,
    /// normalized coordinates) from every one before it, up to `k` points in all; ties and
    /// order broken by the coordinates' bits, so the choice does not depend on the order
    /// parallel evaluations finished in.
    fn distinct_best(&self, first: Vec<f64>, k: usize, separation: f64) -> Vec<Vec<f64>> {
        let mut seen = self.seen.lock().expect("seen lock").clone();
        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
        seen.sort_by(|a, b| {
            a.1.total_cmp(&b.1)
                .then_with(|| bits(&a.0).cmp(&bits(&b.0)))
        });
        let mut chosen: Vec<Vec<f64>> = vec![first];
        for (x, _) in seen {
            if chosen.len() >= k {
                break;
            }
            let far = chosen.iter().all(|c| {
                c.iter()
                    .zip(&x)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
                    >= separation
            });
            if far {
                chosen.push(x);
            }
        }
        chosen
    }

    /// The objective at `x` (`+∞` when no equilibrium was found), journaled.
    fn value(&self, x: &[f64]) -> Result<f64, FitError> {
        let (result, resumed) = match self.journal.get(self.phase, x) {
            Some(r) => (r, true),
            None => {
                let r = self
                    .objective
                    .evaluate_at(self.space, x)
                    .map(|e| e.value)
                    .map_err(|e| e.to_string());
                self.journal.record(self.phase, x, &r)?;
                (r, false)
            }
        };
        let value = match result {
            Ok(v) => {
                if v.is_finite() {
                    self.seen.lock().expect("seen lock").push((x.to_vec(), v));
                }
                v
            }
            Err(e) => {
                self.failed.fetch_add(1, Ordering::Relaxed);
                *self.last_error.lock().expect("error lock") = e;
                f64::INFINITY
            }
        };
        let evaluations = self.count.fetch_add(1, Ordering::Relaxed) + 1;
        let best = {
            let mut b = self.best.lock().expect("best lock");
            *b = b.min(value);
            *b
        };
        (self.progress)(&Progress {
            phase: self.phase,
            evaluations,
            best,
            resumed,
        });
        Ok(value)
    }
}

/// [`Cost`] as argmin sees it (borrowed, so its counters stay readable).
struct SwarmCost<'c, 'a>(&'c Cost<'a>);

impl CostFunction for SwarmCost<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, x: &Self::Param) -> Result<f64, argmin::core::Error> {
        Ok(self.0.value(x)?)
    }
}

/// argmin's particle swarm with the inertia weight set before every iteration, linear from
/// `inertia.0` at the first to `inertia.1` at the last (seed 002 §7.3.3 decays it from 0.9 to
/// 0.1); argmin's own swarm keeps it constant. Everything else is argmin's.
struct DecayingInertia {
    /// The swarm (taken out and put back to reset its inertia, which argmin sets by value).
    swarm: Option<ParticleSwarm<Vec<f64>, f64, Xoshiro256PlusPlus>>,
    inertia: (f64, f64),
}

type SwarmState = PopulationState<Particle<Vec<f64>, f64>, f64>;

impl<O> Solver<O, SwarmState> for DecayingInertia
where
    O: CostFunction<Param = Vec<f64>, Output = f64> + argmin::core::SyncAlias,
{
    fn name(&self) -> &str {
        "Particle Swarm Optimization, decaying inertia"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: SwarmState,
    ) -> Result<(SwarmState, Option<KV>), argmin::core::Error> {
        self.swarm
            .as_mut()
            .expect("the swarm is put back after every use")
            .init(problem, state)
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: SwarmState,
    ) -> Result<(SwarmState, Option<KV>), argmin::core::Error> {
        let weight = inertia_at(self.inertia, state.get_iter(), state.get_max_iters());
        let swarm = self
            .swarm
            .take()
            .expect("the swarm is put back after every use")
            .with_inertia_factor(weight)?;
        let swarm = self.swarm.insert(swarm);
        swarm.next_iter(problem, state)
    }
}

/// The inertia weight of swarm iteration `iter` (from 0) of `iterations`: linear from
/// `inertia.0` at the first to `inertia.1` at the last.
fn inertia_at(inertia: (f64, f64), iter: u64, iterations: u64) -> f64 {
    let steps = iterations.saturating_sub(1).max(1) as f64;
    let t = (iter as f64 / steps).min(1.0);
    inertia.0 + t * (inertia.1 - inertia.0)
}

/// A stable fingerprint of a fit's inputs, for its journal.
pub fn fingerprint(
    geometry: &yarn_pattern::tile::Tile,
    targets: &Targets,
    space: &ParameterSpace,
    settings: &FitSettings,
) -> String {
    format!(
        "{:016x}",
        solver::checksum::fnv1a(
            format!("{geometry:?}|{targets:?}|{space:?}|{settings:?}|fit-v1").as_bytes()
        )
    )
}

/// Fits `space`'s free parameters to `targets` on the input yarn geometry `geometry`: a
/// particle swarm over the normalized box (unless `settings.swarm` is `None`), then the local
/// method ([`FitSettings::local`]) from the swarm's best point (Levenberg–Marquardt: and from
/// up to [`FitSettings::local_starts`]` − 1` more distinct swarm points, keeping the lowest
/// objective), and the result's evaluation with the local settings (Levenberg–Marquardt's
/// end point is its last accepted point, whose evaluation is kept; COBYLA's is evaluated once
/// more); with
/// [`SwarmSettings::restarts`] all of it once per seed, keeping the lowest final objective
/// (the result's evaluations and failures are summed over the restarts; a restart that fails
/// fails the fit). Every swarm and COBYLA evaluation goes through `journal`
/// (see [`journal`]), so an interrupted fit rerun with the same journal resumes and ends with
/// the same result; Levenberg–Marquardt evaluations are not journaled (a rerun repeats them,
/// deterministically).
pub fn fit(
    geometry: &yarn_pattern::tile::Tile,
    targets: &Targets,
    space: &ParameterSpace,
    settings: &FitSettings,
    journal: &Journal,
    progress: &(dyn Fn(&Progress) + Sync),
) -> Result<FitResult, FitError> {
    let Some(swarm) = settings.swarm.as_ref().filter(|s| s.restarts != 1) else {
        return fit_once(geometry, targets, space, settings, journal, progress);
    };
    if swarm.restarts == 0 {
        return Err(FitError::Invalid(
            "the swarm needs at least one run (restarts ≥ 1)".into(),
        ));
    }
    // Independent restarts (SwarmSettings::restarts): the lowest final objective wins.
    let mut best: Option<FitResult> = None;
    let (mut evaluations, mut failed, mut seconds) = ([0, 0], 0, [0.0, 0.0]);
    for r in 0..swarm.restarts {
        let seed = swarm.seed.wrapping_add(r as u64);
        let mut once = settings.clone();
        if let Some(s) = &mut once.swarm {
            s.seed = seed;
            s.restarts = 1;
        }
        let mut result = fit_once(geometry, targets, space, &once, journal, progress)?;
        evaluations[0] += result.evaluations[0];
        evaluations[1] += result.evaluations[1];
        failed += result.failed;
        seconds[0] += result.seconds[0];
        seconds[1] += result.seconds[1];
        result.local_status = format!(
            "restart {} of {} (seed {seed}): {}",
            r + 1,
            swarm.restarts,
            result.local_status
        );
        if best
            .as_ref()
            .is_none_or(|b| result.evaluation.value < b.evaluation.value)
        {
            best = Some(result);
        }
    }
    let mut best = best.expect("at least one restart");
    best.evaluations = evaluations;
    best.failed = failed;
    best.seconds = seconds;
    Ok(best)
}

/// One fit ([`fit`] without restarts).
fn fit_once(
    geometry: &yarn_pattern::tile::Tile,
    targets: &Targets,
    space: &ParameterSpace,
    settings: &FitSettings,
    journal: &Journal,
    progress: &(dyn Fn(&Progress) + Sync),
) -> Result<FitResult, FitError> {
    let n = space.dim();
    if settings.local_evaluations == 0 {
        return Err(FitError::Invalid(
            "the local search needs at least one evaluation".into(),
        ));
    }
    if settings.local_starts == 0 {
        return Err(FitError::Invalid(
            "the local search needs at least one start (local_starts ≥ 1)".into(),
        ));
    }
    if settings.local == LocalMethod::Cobyla && settings.local_evaluations < n + 2 {
        return Err(FitError::Invalid(format!(
            "COBYLA needs at least n + 2 = {} evaluations, found {}",
            n + 2,
            settings.local_evaluations
        )));
    }
    let objective = |settings: &ObjectiveSettings| Objective {
        geometry,
        targets,
        settings: settings.clone(),
    };
    objective(&settings.swarm_objective).check()?;
    objective(&settings.local_objective).check()?;

    // Global search.
    let clock = std::time::Instant::now();
    let mut failed = 0;
    let mut last_error = String::new();
    let (starts, swarm_best, swarm_evaluations) = match &settings.swarm {
        Some(swarm) => {
            if swarm.particles < 2 {
                return Err(FitError::Invalid(format!(
                    "the swarm needs at least 2 particles, found {}",
                    swarm.particles
                )));
            }
            let cost = Cost::new(
                objective(&settings.swarm_objective),
                space,
                journal,
                "swarm",
                progress,
            );
            let (first, last) = swarm.inertia;
            if !(first.is_finite() && last.is_finite() && first >= 0.0 && last >= 0.0) {
                return Err(FitError::Invalid(format!(
                    "the swarm's inertia weights must be finite and non-negative, found \
                     ({first}, {last})"
                )));
            }
            let solver = DecayingInertia {
                swarm: Some(
                    ParticleSwarm::new((vec![0.0; n], vec![1.0; n]), swarm.particles)
                        .with_rng_generator(Xoshiro256PlusPlus::seed_from_u64(swarm.seed)),
                ),
                inertia: swarm.inertia,
            };
            let result = Executor::new(SwarmCost(&cost), solver)
                .configure(|state| state.max_iters(swarm.iterations))
                .run()
                .map_err(|e| FitError::Optimizer(e.to_string()))?;
            let state = result.state();
            let best = state
                .get_best_param()
                .map(|p| p.position.clone())
                .ok_or_else(|| FitError::Optimizer("the swarm has no best particle".into()))?;
            let value = state.get_best_cost();
            failed += cost.failed.load(Ordering::Relaxed);
            last_error = cost.last_error.lock().expect("error lock").clone();
            let count = cost.count.load(Ordering::Relaxed);
            if !value.is_finite() {
                return Err(FitError::NothingEvaluated(count, last_error));
            }
            // The swarm's best first, then the best evaluated points far from it.
            let starts = if settings.local == LocalMethod::LevenbergMarquardt {
                cost.distinct_best(best.clone(), settings.local_starts, LOCAL_START_SEPARATION)
            } else {
                vec![best.clone()]
            };
            (starts, Some((best, value)), count)
        }
        None => {
            let start = settings.start.clone().unwrap_or_else(|| vec![0.5; n]);
            if start.len() != n || !start.iter().all(|t| (0.0..=1.0).contains(t)) {
                return Err(FitError::Invalid(format!(
                    "the local start must have {n} coordinates in [0, 1], found {start:?}"
                )));
            }
            (vec![start], None, 0)
        }
    };
    let start = starts[0].clone();
    let swarm_seconds = clock.elapsed().as_secs_f64();

    // Local refinement in the normalized box.
    let (x, status, local_evaluations, kept) = match settings.local {
        LocalMethod::Cobyla => {
            let cost = Cost::new(
                objective(&settings.local_objective),
                space,
                journal,
                "local",
                progress,
            );
            let (x, status) = cobyla_search(&cost, &start, settings)?;
            failed += cost.failed.load(Ordering::Relaxed);
            let error = cost.last_error.lock().expect("error lock").clone();
            if !error.is_empty() {
                last_error = error;
            }
            (x, status, cost.count.load(Ordering::Relaxed), None)
        }
        LocalMethod::LevenbergMarquardt => {
            // From every start; the lowest local objective wins (the first on ties). A start's
            // end point is its last accepted point, whose evaluation the search kept; it is
            // evaluated again only where the search could not start. A later start whose
            // search fails is skipped (its error kept for the report); the first start's
            // failure is the fit's. The starts run in parallel (each is deterministic, and the
            // choice is made in start order afterwards).
            let local = objective(&settings.local_objective);
            let searched: Vec<Result<LocalRun, FitError>> = starts
                .par_iter()
                .map(|s| {
                    let (x, status, count, kept) = lm_search(&local, space, s, settings, progress)?;
                    // A start whose end point cannot be evaluated loses to every other.
                    let (evaluation, error) = match kept {
                        Some(e) => (Some(e), None),
                        None => match local.evaluate_at(space, &x) {
                            Ok(e) => (Some(e), None),
                            Err(e) => (None, Some(e.to_string())),
                        },
                    };
                    let g = evaluation.as_ref().map_or(f64::INFINITY, |e| {
                        if e.value.is_nan() {
                            f64::INFINITY
                        } else {
                            e.value
                        }
                    });
                    Ok((g, x, status, count, evaluation, error))
                })
                .collect();
            let mut best: Option<(f64, Vec<f64>, String, Option<Evaluation>)> = None;
            let mut total = 0;
            for (i, found) in searched.into_iter().enumerate() {
                let (g, x, status, count, evaluation, error) = match found {
                    Ok(found) => found,
                    Err(e) if i > 0 => {
                        last_error = e.to_string();
                        continue;
                    }
                    Err(e) => return Err(e),
                };
                total += count;
                if let Some(error) = error {
                    last_error = error;
                }
                let status = if starts.len() == 1 {
                    status
                } else {
                    format!("start {} of {}: {status}", i + 1, starts.len())
                };
                if best.as_ref().is_none_or(|b| g < b.0) {
                    best = Some((g, x, status, evaluation));
                }
            }
            let (_, x, status, evaluation) = best.expect("at least one start");
            (x, status, total, evaluation)
        }
    };
    // The result's evaluation: the winning start's where it has one and its end point lies in
    // the box (Levenberg–Marquardt's always does), else one more evaluation.
    let clamped: Vec<f64> = x.iter().map(|t| t.clamp(0.0, 1.0)).collect();
    let kept = kept.filter(|_| clamped == x);
    let x = clamped;
    let model = space.model(&x);
    let evaluation = match kept {
        Some(e) => e,
        None => objective(&settings.local_objective)
            .evaluate_at(space, &x)
            .map_err(|e| {
                FitError::NothingEvaluated(
                    local_evaluations,
                    format!("{e} (last other: {last_error})"),
                )
            })?,
    };
    Ok(FitResult {
        model,
        values: space.values(&x),
        geometry_stretch: space.geometry_stretch(&x),
        x,
        swarm_best,
        evaluation,
        evaluations: [swarm_evaluations, local_evaluations],
        failed,
        seconds: [swarm_seconds, clock.elapsed().as_secs_f64() - swarm_seconds],
        local_status: status,
    })
}

/// One Levenberg–Marquardt start's outcome: its end point's local objective, the end point,
/// how it stopped, its evaluations, the end point's evaluation, and why the end point could
/// not be evaluated, if it could not.
type LocalRun = (
    f64,
    Vec<f64>,
    String,
    usize,
    Option<Evaluation>,
    Option<String>,
);

/// COBYLA from `start`; returns the best point and how it stopped.
fn cobyla_search(
    cost: &Cost<'_>,
    start: &[f64],
    settings: &FitSettings,
) -> Result<(Vec<f64>, String), FitError> {
    let n = start.len();
    let fatal: std::sync::Mutex<Option<FitError>> = std::sync::Mutex::new(None);
    let func = |x: &[f64], _: &mut ()| -> f64 {
        match cost.value(x) {
            Ok(v) if v.is_finite() => v,
            Ok(_) => 1e30,
            Err(e) => {
                fatal.lock().expect("fatal lock").get_or_insert(e);
                1e30
            }
        }
    };
    let no_constraints: Vec<&dyn cobyla::Func<()>> = vec![];
    let stop = cobyla::StopTols {
        xtol_abs: vec![settings.local_x_tol; n],
        ..cobyla::StopTols::default()
    };
    let outcome = cobyla::minimize(
        func,
        start,
        &vec![(0.0, 1.0); n],
        &no_constraints,
        (),
        settings.local_evaluations,
        cobyla::RhoBeg::All(settings.local_step),
        Some(stop),
    );
    if let Some(e) = fatal.into_inner().expect("fatal lock") {
        return Err(e);
    }
    Ok(match outcome {
        Ok((status, x, _)) => (x, format!("COBYLA: {status:?}")),
        Err((status, x, _)) => (x, format!("COBYLA failed ({status:?}); best point kept")),
    })
}

/// Levenberg–Marquardt from `start` on the full objective (every point gets its own
/// estimated rest shape). The Jacobian of a point is the exact one of its frozen rest tile
/// ([`Objective::evaluate_with_jacobian`]) plus a correction `B` for the rest shape's own
/// dependence on the parameters, which is not differentiable in closed form: Broyden's update
/// from every pair of consecutive accepted points, `B ← B + ((Δr − J̄Δx) − BΔx) Δxᵀ / ‖Δx‖²`,
/// with `J̄` the mean of the two frozen Jacobians (starts at `B = 0`). With
/// [`FitSettings::local_geometry`] the geometric parameters' columns are forward differences
/// of the whole objective (rest shape included), and Broyden's update corrects only the other
/// columns (`Δx` with its geometric entries zeroed on the right). Both are computed where
/// Levenberg–Marquardt accepts a point (its `commit`), not at trial points it rejects. Returns
/// the last accepted point, how it stopped, the evaluations used and the last accepted point's
/// evaluation (`None` where the search could not start).
fn lm_search(
    objective: &Objective<'_>,
    space: &ParameterSpace,
    start: &[f64],
    settings: &FitSettings,
    progress: &(dyn Fn(&Progress) + Sync),
) -> Result<(Vec<f64>, String, usize, Option<Evaluation>), FitError> {
    use nalgebra::{DMatrix, DVector};
    const N: usize = Parameter::ALL.len();
    let n = start.len();
    let mut p0 = [0.0; N];
    p0[..n].copy_from_slice(start);
    let geometric = |k: usize| k < n && space.free[k].parameter.is_geometric();
    let differenced = |k: usize| geometric(k) && settings.local_geometry;
    let bounds = solver::LmBounds {
        lower: [0.0; N],
        upper: [1.0; N],
        // Without `local_geometry` the geometric parameters stay at the start (the swarm's
        // choice).
        fixed: std::array::from_fn(|k| k >= n || (geometric(k) && !differenced(k))),
        scale: [1.0; N],
    };
    // The local phase ends on the step tolerance. Its tail is long: on the development fabric
    // (yarn-fit's settings, a throw-away trace of every evaluation) the winning
    // start spent its last 16 of 64 evaluations lowering g from 0.073147 to 0.073090 (8e-4
    // relative), the last 6 of them rejections while the damping grew, and another start crept
    // from 0.0909 to 0.0850 over 40. A stop on the decrease over several accepted steps (this
    // `cost_rtol` tests one step) or after a few rejections in a row would not be safe: traced
    // the same way, the babyredo stockinette's winning start went from g 0.080415
    // to 0.080413 in 7 iterations, 6 of them rejections, then fell to 0.075507 (6 % lower).
    // A stop on one accepted step's decrease at 1e-4 (that step's: 3e-5), or after 4
    // rejections in a row, would have ended it at 0.0804; one on the decrease over two accepted
    // steps at 1e-3 was missed by 29 % (1.29e-3). What is left to save safely is the rejections
    // after the last accepted step: 2–8 evaluations per start.
    let lm_settings = solver::LmSettings {
        max_iterations: settings.local_evaluations,
        cost_rtol: 1e-12,
        step_tol: settings.local_x_tol,
        residual_tol: 0.0,
    };
    let count = std::cell::Cell::new(0);
    let rest_shape = objective.settings.rest_shape;
    // Trial points: residuals only; the point, its residuals, its evaluation and its equilibria
    // are kept for `commit` (the Jacobian handed back is a placeholder).
    type Trial = (DVector<f64>, DVector<f64>, Evaluation, Solved);
    let mut best = f64::INFINITY;
    let mut eval = |p: &[f64; N]| -> Result<solver::LmEval<Trial>, FitError> {
        let (evaluation, solved) = objective.solve_at(space, &p[..n], None)?;
        let r = Objective::residuals(&evaluation);
        count.set(count.get() + 1);
        best = best.min(evaluation.value);
        progress(&Progress {
            phase: "local",
            evaluations: count.get(),
            best,
            resumed: false,
        });
        let placeholder = DMatrix::zeros(r.len(), N);
        let x = DVector::from_column_slice(&p[..n]);
        Ok((r.clone(), placeholder, (x, r, evaluation, solved)))
    };
    // Accepted points (and the start) get their Jacobian: the exact one of the frozen rest
    // tile (geometric columns zero), the geometric columns, then the Broyden correction of the
    // rest shape's dependence, all only where the step is taken (a rejected trial needs none).
    // A point whose sensitivities do not exist (e.g. its equilibrium is a saddle) is rejected
    // after all.
    let mut correction: Option<DMatrix<f64>> = None;
    let mut previous: Option<(DVector<f64>, DVector<f64>, DMatrix<f64>)> = None;
    let differenced_columns: Vec<usize> = (0..n).filter(|&k| differenced(k)).collect();
    // The last accepted point and its evaluation: the search's end point.
    let mut accepted: Option<(DVector<f64>, Evaluation)> = None;
    let mut commit = |(x, r, evaluation, solved): Trial,
                      jacobian: &mut DMatrix<f64>|
     -> Result<(), FitError> {
        // The geometric parameters' columns (zero in the frozen Jacobian): forward differences,
        // towards the box's inside, or away from it when that point has no equilibrium; a
        // column stays zero when neither has one. Each is a whole evaluation, independent of
        // the frozen Jacobian and of the other columns, so all run in parallel with it (the
        // result does not depend on the schedule). Run one after another, a lone local start
        // kept 1.0–1.5 of the 2 cores busy (the acrylic seed fit's last 150 s). The whole
        // seed fit took 549.5 s (a timed run) and 580.9 s (`cargo bench -p bench --bench
        // yarn_fit -- acrylic-yarn-seed`) against 627.2 s before (one timed run), a gain of
        // the order of this machine's run-to-run spread.
        let column = |k: usize| -> (Option<DVector<f64>>, usize) {
            let d = GEOMETRY_DIFFERENCE_STEP;
            let step = if x[k] + d <= 1.0 { d } else { -d };
            let mut evaluations = 0;
            for h in [step, -step] {
                let mut q = x.as_slice().to_vec();
                q[k] = (q[k] + h).clamp(0.0, 1.0);
                if q[k] == x[k] {
                    // Outside the box (the point lies on a bound): no difference that way.
                    continue;
                }
                evaluations += 1;
                if let Ok(shifted) = objective.evaluate_at(space, &q) {
                    let dr = Objective::residuals(&shifted) - &r;
                    return (Some(dr / (q[k] - x[k])), evaluations);
                }
            }
            (None, evaluations)
        };
        let (frozen, columns) = rayon::join(
            || objective.jacobian(&solved, space, x.as_slice()),
            || {
                differenced_columns
                    .par_iter()
                    .map(|&k| (k, column(k)))
                    .collect::<Vec<_>>()
            },
        );
        // A point whose frozen Jacobian fails is rejected; its differences, computed
        // speculatively, are dropped uncounted, as when they ran after it and never started.
        let mut frozen = frozen?;
        for (k, (difference, evaluations)) in columns {
            count.set(count.get() + evaluations);
            if let Some(difference) = difference {
                frozen.set_column(k, &difference);
            }
        }
        let b = correction.get_or_insert_with(|| DMatrix::zeros(r.len(), n));
        if let Some((x0, r0, j0)) = &previous
            && rest_shape
        {
            let dx = &x - x0;
            // The differenced geometric columns are whole derivatives already: only the
            // other columns are corrected.
            let corrected = DVector::from_fn(n, |k, _| if differenced(k) { 0.0 } else { dx[k] });
            let norm2 = corrected.norm_squared();
            if norm2 > 0.0 {
                let mean = (j0 + &frozen) * 0.5;
                let miss = (&r - r0) - &mean * &dx - &*b * &dx;
                *b += miss * corrected.transpose() / norm2;
            }
        }
        jacobian.columns_mut(0, n).copy_from(&(&frozen + &*b));
        accepted = Some((x.clone(), evaluation));
        previous = Some((x, r, frozen));
        Ok(())
    };
    let outcome = match solver::bounded_lm(
        p0,
        &bounds,
        &lm_settings,
        &|_| {},
        &mut eval,
        &mut commit,
        None,
    ) {
        Ok(outcome) => outcome,
        // No Jacobian at the start (e.g. its equilibrium is a saddle, whose sensitivities do
        // not exist): keep the start and say why.
        Err(solver::LmError::InitialEvaluation(e)) => {
            return Ok((
                start.to_vec(),
                format!("Levenberg–Marquardt could not start ({e}); the start point is kept"),
                count.get(),
                None,
            ));
        }
        Err(other) => return Err(FitError::Optimizer(other.to_string())),
    };
    let x = outcome.p[..n].to_vec();
    // The end point is the last accepted one (`LmOutcome::p`); checked, not assumed.
    let kept = accepted.and_then(|(p, e)| (p.as_slice() == x.as_slice()).then_some(e));
    Ok((
        x,
        format!(
            "Levenberg–Marquardt: {} after {} iterations",
            outcome.termination, outcome.iterations
        ),
        count.get(),
        kept,
    ))
}

#[cfg(test)]
mod tests {
    use super::inertia_at;

    /// The paper's schedule (§7.3.3): 0.9 at the first swarm iteration, 0.1 at the last,
    /// linear in between; a single iteration takes the first weight.
    #[test]
    fn the_inertia_weight_decays_linearly_from_the_first_to_the_last_iteration() {
        let paper = (0.9, 0.1);
        assert_eq!(inertia_at(paper, 0, 5), 0.9);
        assert!((inertia_at(paper, 2, 5) - 0.5).abs() < 1e-15);
        assert!((inertia_at(paper, 4, 5) - 0.1).abs() < 1e-15);
        assert_eq!(inertia_at(paper, 0, 1), 0.9);
        let w = super::constant_inertia();
        assert!((0..6).all(|k| inertia_at((w, w), k, 6) == w));
    }
}
