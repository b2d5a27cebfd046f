//! The settings, errors and per-step reports of [`super::Simulator`].

use solver::{NewtonReport, NewtonSettings, SolveError};

/// Time-step parameters (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct StepSettings {
    /// Time step h (s). Default 1 ms (seed 000 §5).
    pub dt: f64,
    /// Rayleigh mass-damping coefficient α (1/s). Default 0 (Table 1 uses 2–10).
    pub rayleigh_alpha: f64,
    /// Rayleigh stiffness-damping coefficient β (s). Default 0 (Table 1 uses 0.01–0.1).
    pub rayleigh_beta: f64,
    /// Newton settings of each step. Default: `solver` defaults with a relative gradient
    /// tolerance of 1e-9, at most 100 iterations (a 10 ms step of the hanging swatch of
    /// `examples/stability.rs` needs 51–80) and no per-stencil SPD projection: the
    /// inertia term keeps the step's Hessian positive definite for cloth-sized steps, plain
    /// Newton then converges in 2–3 iterations where projection needs ≈ 5 (and projects
    /// every 8 × 8 and 12 × 12 block each iteration); the solver's diagonal shift still
    /// catches an indefinite Hessian. The linear solver of the Newton system is
    /// `newton.linear_solver` (sparse Cholesky by default, or preconditioned conjugate
    /// gradients); [`StepSettings::linearized_implicit_euler`] turns the step into a single
    /// Newton iteration.
    pub newton: NewtonSettings,
    /// How often a step whose Newton solve fails may be halved (recursively). Default 4
    /// (down to dt/16). A step is also a Newton minimization far from its start when the
    /// layout is not at rest (no rest-shape compensation yet) and damping is off.
    pub max_halvings: usize,
    /// Duration `T` (s) of the ramp of the stitch-wrapping rest angles from the layout's
    /// angles to ψ₀ (module documentation); `0` applies ψ₀ from the start. Default 0.1 s
    /// (100 steps of 1 ms), several periods of the slowest loop modes of a swatch of the
    /// Table 1 yarns, so that the contacts wrap up quasi-statically.
    pub wrapping_ramp_time: f64,
    /// Recompute the Rayleigh-β damping matrices `K⁺` every this many (sub)steps (≥ 1);
    /// in between they stay lagged (only their centres move to `qₙ`), like the lagged mass
    /// matrix. Default 1: every step (the per-stencil PSD projections of `K⁺` are the largest
    /// part of a step's setup).
    pub damping_refresh_steps: usize,
    /// At most this many re-solves of a step for the implicit stick/slip decision of friction
    /// (the return mapping of [`crate::forces::friction`], e.g. 20); `0` moves the anchors
    /// only after the step, as the paper does (explicit update: friction then grows with the
    /// step). Default 0, the paper's model: with Coulomb-consistent friction yarns slide
    /// freely through uncompressed contacts, and the return mapping needs
    /// [`crate::forces::ForceSet::segment_floor`] (default on) and, for consistent results,
    /// [`crate::forces::ForceSet::loop_contact`] (measured in [`crate::forces::friction`]). A
    /// step whose modes still change after the last re-solve is kept, its anchors get the
    /// explicit update, and [`StepReport::friction_unresolved`] counts it. With Rayleigh
    /// β > 0 the friction springs get no β-damping form under the return mapping (it would
    /// brake slipping coordinates by `β k_f u̇`). With
    /// [`StepSettings::linearized_implicit_euler`] each re-solve adds one more (damped)
    /// Newton iteration, so the step is no longer a single linearized solve.
    pub friction_return_mapping: usize,
    /// If set, the largest fraction `∈ (0, 1)` of its material length `L = u₁ − u₀` a segment
    /// may lose in one Newton iteration: every step is shortened to keep it
    /// ([`crate::forces::Potential::bound_material_steps`]), with or without a line search.
    /// Default `None` (no bound).
    pub max_material_shrink: Option<f64>,
}

impl StepSettings {
    /// A re-solve budget for [`StepSettings::friction_return_mapping`] that the measured
    /// runs never exhausted in more than 1 % of their steps (3–11 re-solves per step while
    /// coordinates slip; `persistent-time-vs-error`, `rib-stretch`).
    pub const RETURN_MAPPING_RESOLVES: usize = 20;
}

impl Default for StepSettings {
    fn default() -> Self {
        Self {
            dt: 1e-3,
            rayleigh_alpha: 0.0,
            rayleigh_beta: 0.0,
            newton: NewtonSettings {
                max_iterations: 100,
                gradient_rel_tol: 1e-9,
                project_spd: false,
                ..NewtonSettings::default()
            },
            max_halvings: 4,
            wrapping_ramp_time: 0.1,
            damping_refresh_steps: 1,
            friction_return_mapping: 0,
            max_material_shrink: None,
        }
    }
}

impl StepSettings {
    /// Checks the ranges (`dt > 0`, `α, β ≥ 0`, valid Newton settings).
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(SimError::Invalid(format!(
                "dt must be > 0, got {}",
                self.dt
            )));
        }
        for (name, v) in [
            ("Rayleigh α", self.rayleigh_alpha),
            ("Rayleigh β", self.rayleigh_beta),
            ("wrapping ramp time", self.wrapping_ramp_time),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SimError::Invalid(format!("{name} must be ≥ 0, got {v}")));
            }
        }
        if self.damping_refresh_steps == 0 {
            return Err(SimError::Invalid(
                "damping_refresh_steps must be ≥ 1".into(),
            ));
        }
        if let Some(f) = self.max_material_shrink
            && !(f > 0.0 && f < 1.0)
        {
            return Err(SimError::Invalid(format!(
                "max_material_shrink must be in (0, 1), got {f}"
            )));
        }
        self.newton.validate()?;
        Ok(())
    }

    /// These settings with *linearized* implicit Euler: one Newton iteration per step from
    /// `qₙ` (the integrator of seed 000's ref. 6, Cirio et al. 2014, i.e. Baraff & Witkin
    /// 1998's linearized backward Euler: `(M + h D + h² K) Δv = h (f − D vₙ − h K vₙ)`, which
    /// is exactly the first Newton step on the incremental potential), *damped* (ours): the
    /// step keeps the backtracking line search on the incremental potential, and no segment
    /// may lose more than half its material length in it ([`StepSettings::max_material_shrink`]
    /// = [`LINEARIZED_MAX_SHRINK`] unless already set). Ref. 6 takes the step at full length:
    /// [`StepSettings::at_full_length`] after this call.
    /// Why (measured on `persistent-time-vs-error`'s rib pull with the return mapping and
    /// IC-CG at 1e-3, release, 2 cores): at full length a slipping sliding coordinate has only
    /// its small u-inertia as stiffness and the segment floor has no gradient at its onset, so
    /// one step drains segments past the floor and inverts them (material length < 0,
    /// negative stretch energy). On the quick 4 × 4 rib pulled 8 mm (full-Newton pull 5–15
    /// mN) the full-length pull reaches 21–180 N at dt = 1 ms; with the line search alone it
    /// follows full Newton's at 1 ms but still jams (10–130 N) from 4–7 mm at 0.5 and 2 ms;
    /// with the bound alone it jams at 1 ms (90–140 N); with both the forces stay within a few
    /// mN of full Newton's at 0.25–2 ms and within 0.01–0.3 N at 5–10 ms. On the full 8 × 6
    /// rib pulled 20 mm the RMS force error over the peak pull fell from 5e4–3e10 to 0.20 /
    /// 0.28 / 6.1 / 19 / 78 / 84 at dt = 0.25 / 0.5 / 1 / 2 / 5 / 10 ms (full Newton: 0.15 /
    /// 0.16 / 0.47 / 0.54 / 0.41, failed at 10 ms; the simulator's default, full Newton with
    /// the explicit anchor update: 36 / 65 / failed / 211 / 452 / 686), in 0.6–0.7× full
    /// Newton's time at 0.25–1 ms. The cost: on the hat of the same figure (no return
    /// mapping, Rayleigh β) one of 50 steps at 1 ms backtracks to α = ½, and the RMS node
    /// error after 0.05 s rises from 1.25 to 1.79 R at 1 ms and from 3.33 to 4.14 R at 2 ms
    /// (0.83 R at 0.5 ms either way; the bound alone changes nothing there); on the dressed
    /// 1 M-DoF sweater of `examples/scaling.rs` the line search took 0.29 of 8.3 s per step. A
    /// step whose Armijo test passes at full length costs one extra energy evaluation.
    ///
    /// The step is not iterated to convergence; its Newton report
    /// ends with [`solver::Termination::IterationLimit`] and still records the gradient
    /// residual of the incremental potential after the iteration
    /// ([`NewtonReport::residual_history`]), so the linearization error stays visible; that
    /// costs a gradient evaluation per step, which `newton.final_residual = false` skips
    /// (the same steps bit for bit; measured on the dressed 92 352-DoF sweater of
    /// `examples/scaling.rs`, 10 steps, 4 alternated pairs of runs: assembly 288–322 →
    /// 172–234 ms, step 1044–1143 → 820–1069 ms). A
    /// step whose linear solve fails (or whose result is not finite) is halved as usual.
    /// The diagonal shift that an indefinite step's Hessian needs is carried from step to
    /// step ([`NewtonSettings::warm_start_regularization`]): with one iteration per step the
    /// escalation would otherwise restart from 1e-8 every step (measured on the dressed
    /// 1 M-DoF sweater of `examples/scaling.rs`: 7 solves per step, 3–4 with the warm start,
    /// 7.2 → 4.1 s per step over 3 steps without a β refresh, the same residual after the step; the steps differ from cold
    /// ones only where the needed shift falls by more than the growth factor between steps).
    /// With conjugate gradients the attempts below the needed shift mostly cost no solve: the
    /// CG back end keeps the directions of negative curvature its failed solves stopped at
    /// and rejects every shift they prove too small (`solver::NewtonReport::shifts_skipped`),
    /// so the accepted shift and step are the same (measured: the same final state, bit for
    /// bit, after 20 steps of the 251 392-DoF sweater; the same errors in
    /// `persistent-time-vs-error`), and on the 1 M-DoF sweater the solve fell from 5.3–5.7
    /// to 4.2–4.3 s and the step from 8.5–9.1 to 7.1–7.3 s (10 steps; 3 runs before, 2
    /// after, alternating, on one 2-core machine).
    ///
    /// Starting every step at the carried shift itself between probes
    /// ([`NewtonSettings::carried_shift_probe_interval`], e.g. every
    /// [`CARRIED_SHIFT_PROBE_INTERVAL`]-th Newton run, which is every 10th step where no step
    /// is halved) is faster where the needed shift stays put, but it is not the default,
    /// because where the shift varies it takes far larger shifts than needed (measured: on
    /// the 1 M-DoF sweater 3.9 → 2.5 s per step over 10 steps with one β refresh, the same
    /// residual after the step; on the hat of `persistent-time-vs-error`'s garment study the RMS node
    /// error after 0.05 s rose from 0.83 / 1.25 / 3.33 R to 3.13 / 9.08 / 4.54 R at
    /// dt = 0.5 / 1 / 2 ms).
    pub fn linearized_implicit_euler(mut self) -> Self {
        self.newton.max_iterations = 1;
        self.newton.accept_iteration_limit = true;
        self.max_material_shrink
            .get_or_insert(LINEARIZED_MAX_SHRINK);
        self.newton.warm_start_regularization = true;
        self
    }

    /// These settings with every Newton step taken at full length: no line search and no
    /// [`StepSettings::max_material_shrink`] (seed 000's ref. 6 after
    /// [`StepSettings::linearized_implicit_euler`], which explains why it is not the default).
    pub fn at_full_length(mut self) -> Self {
        self.newton.line_search = false;
        self.max_material_shrink = None;
        self
    }

    /// [`StepSettings::linearized_implicit_euler`] with IC(0)-preconditioned conjugate
    /// gradients at relative tolerance `tol` (at most 20 000 iterations): the fast
    /// configuration of `examples/scaling.rs` (`linear-ic-lag-3` there with `tol = 1e-3`).
    pub fn linearized_ic_cg(self, tol: f64) -> Self {
        let mut s = self.linearized_implicit_euler();
        s.newton.linear_solver = solver::LinearSolver::ConjugateGradient(solver::PcgSettings::new(
            tol,
            20_000,
            solver::Preconditioner::IncompleteCholesky,
        ));
        s
    }

    /// These settings with every conjugate-gradient solve of a step started from the last
    /// successful solve's solution instead of zero ([`solver::PcgSettings::warm_start`];
    /// nothing changes with Cholesky). For linearized steps that solution is the previous
    /// step's displacement `h vₙ`, close to this step's `h vₙ₊₁`. Measured on 2 cores, the
    /// solves ending at the same relative residual test: criterion bench `step` (32 × 32
    /// garter, 20 864 DoFs, tolerance 1e-6, one run) 325.6 → 290.0 ms per step
    /// (`garter-linear-ic` → `garter-linear-ic-guess`); on the dressed sweater of
    /// `examples/scaling.rs` the CG iterations per step fell from 47 to 30 at 251 392 DoFs
    /// (20 steps) and from 33 to 24 at 998 144 DoFs (10 steps; solve 4.34 → 3.81 s, step
    /// 7.30 → 7.14 s, single runs on a machine whose speed drifted by ±20 %). It is not the
    /// default: on the hat of
    /// `persistent-time-vs-error`'s garment study it is 8–12 % faster at about the same error
    /// (RMS node error 0.834 / 1.794 / 4.071 R against 0.832 / 1.788 / 4.136 R at dt = 0.5 /
    /// 1 / 2 ms; before linearized steps were damped, 0.834 / 1.249 / 3.53 R against 0.832 /
    /// 1.247 / 3.33 R). A warm-started CG solution need not be a descent direction:
    /// under a line search (linearized steps keep one,
    /// [`StepSettings::linearized_implicit_euler`]) such a step fails it and is retried with a
    /// diagonal shift, as after a failed solve.
    pub fn warm_started_cg(mut self) -> Self {
        if let solver::LinearSolver::ConjugateGradient(pcg) = &mut self.newton.linear_solver {
            pcg.warm_start = true;
        }
        self
    }
}

/// The [`StepSettings::max_material_shrink`] of linearized steps
/// ([`StepSettings::linearized_implicit_euler`]): a segment may at most halve its material
/// length in one step (0.5 and 0.9 were measured there; neither was better at every step).
pub const LINEARIZED_MAX_SHRINK: f64 = 0.5;

/// Steps between the probes of a carried diagonal shift, for linearized steps that opt in
/// ([`StepSettings::linearized_implicit_euler`] explains why it is not the default).
pub const CARRIED_SHIFT_PROBE_INTERVAL: usize = 10;

/// Errors of the simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// Invalid parameters, layout or pins.
    #[error("invalid simulation input: {0}")]
    Invalid(String),
    /// The Newton solve of a step (after all halvings) or of a static equilibrium failed.
    #[error("Newton solve failed (time step or static equilibrium): {0}")]
    Solve(#[from] SolveError),
}

/// What one step did.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// Newton iterations over all substeps.
    pub newton_iterations: usize,
    /// Number of backward Euler solves that succeeded (1 unless the step was halved).
    pub substeps: usize,
    /// Number of slips of sliding coordinates (friction anchors moved, Eq. 5), summed over
    /// the substeps.
    pub slipped: usize,
    /// The Newton report of the last successful substep.
    pub last_newton: Option<NewtonReport>,
    /// Wall time (s) spent preparing the backward Euler solves, summed over all attempted
    /// substeps (failed ones included): rest-angle ramp, lagged mass matrices, Rayleigh
    /// damping forms, `q̂`, and the one-off sparsity pattern and symbolic factorization when
    /// the Newton solver is (re)built. Timing only; it changes nothing in the step.
    pub setup_seconds: f64,
    /// Wall time (s) spent in the Newton minimizations (assembly, line searches, sparse
    /// Cholesky factorizations and solves), summed over all attempted substeps (failed
    /// ones included).
    pub newton_seconds: f64,
    /// Conjugate-gradient iterations over all accepted Newton iterations of all substeps
    /// (0 with the sparse Cholesky solver).
    pub linear_iterations: usize,
    /// Extra Newton solves of the friction return mapping over all substeps (0 when no
    /// coordinate changed between sticking and slipping, or with the explicit update).
    pub friction_resolves: usize,
    /// Substeps whose return mapping still changed modes after
    /// [`StepSettings::friction_return_mapping`] re-solves (kept with the explicit update).
    pub friction_unresolved: usize,
}
