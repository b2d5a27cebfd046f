//! Newton minimization: convergence, Dirichlet elimination, failure reporting.

mod common;

use common::{
    CoshChain, DoubleWell, LinearChain, Rng, assert_close, dense_solve, hanging_net, spd_quadratic,
};
use solver::{
    LinearSolver, NewtonSettings, NewtonSolver, PcgSettings, Preconditioner, Problem, SolveError,
    Termination, minimize,
};

#[test]
fn quadratic_is_solved_in_one_step() {
    let q = spd_quadratic(3, 40);
    let mut x = vec![0.0; q.n];
    let report = minimize(&q, &mut x, &vec![false; q.n], &NewtonSettings::default()).unwrap();
    assert_eq!(report.iterations, 1);
    assert_eq!(report.termination, Termination::GradientTolerance);
    assert_eq!(report.step_lengths, vec![1.0]);
    assert_eq!(report.regularizations, vec![0.0]);
    // Reference: H x = −g(0).
    let (h, g0) = q.dense(&vec![0.0; q.n]);
    let neg_g0: Vec<f64> = g0.iter().map(|g| -g).collect();
    assert_close(&x, &dense_solve(&h, &neg_g0), 1e-10, "x");
}

#[test]
fn convex_cosh_chain_converges_quadratically() {
    let mut rng = Rng::new(5);
    let n = 60;
    let anchors = (0..n).map(|_| rng.range(-2.0, 2.0)).collect();
    let problem = CoshChain::new(n, 0.3, anchors);
    let mut x = vec![3.0; n];
    let settings = NewtonSettings {
        gradient_abs_tol: 1e-12,
        gradient_rel_tol: 0.0,
        ..Default::default()
    };
    let report = minimize(&problem, &mut x, &vec![false; n], &settings).unwrap();
    assert!(report.converged());
    assert!(
        report.iterations > 2,
        "should need several steps, took {}",
        report.iterations
    );
    assert!(report.last_residual() <= 1e-12);
    assert_eq!(report.energy_history.len(), report.iterations + 1);
    assert_eq!(report.residual_history.len(), report.iterations + 1);
    for w in report.energy_history.windows(2) {
        assert!(w[1] <= w[0] + 1e-12 * w[0].abs(), "energy increased: {w:?}");
    }
    // Quadratic convergence at the end: r_{k+1} ≲ C r_k².
    let r = &report.residual_history;
    let k = r.len() - 2;
    assert!(
        r[k] < 1e-3 && r[k + 1] <= 10.0 * r[k] * r[k] + 1e-13,
        "{r:?}"
    );
    // Independent optimality check.
    let mut asm = solver::Assembler::new(&problem).unwrap();
    let (_, g) = asm.gradient(&problem, &x).unwrap();
    assert!(g.iter().all(|g| g.abs() <= 1e-12));
}

#[test]
fn double_well_converges_with_projection() {
    let n = 20;
    let problem = DoubleWell::new(n, 0.1);
    // Start inside the concave region |x| < 1/√3 of every well.
    let x0: Vec<f64> = (0..n).map(|i| 0.1 * (i as f64).sin()).collect();
    for project_spd in [true, false] {
        let mut x = x0.clone();
        let settings = NewtonSettings {
            project_spd,
            ..Default::default()
        };
        let report = minimize(&problem, &mut x, &vec![false; n], &settings)
            .unwrap_or_else(|e| panic!("project_spd = {project_spd}: {e}"));
        assert!(report.converged());
        assert!(problem.gradient(&x).iter().all(|g| g.abs() <= 1e-9));
        // Early iterations needed the diagonal shift (H is singular or indefinite at x0).
        assert!(
            report.regularizations[0] > 0.0,
            "{:?}",
            report.regularizations
        );
        // A local minimum: the exact Hessian is positive definite there.
        let h = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            let deg = if i == 0 || i == n - 1 { 1.0 } else { 2.0 };
            match i.abs_diff(j) {
                0 => 12.0 * x[i] * x[i] - 4.0 + 0.1 * deg,
                1 => -0.1,
                _ => 0.0,
            }
        });
        assert!(h.symmetric_eigenvalues().min() > 0.0);
        assert!(report.energy_history.last().unwrap() < &report.energy_history[0]);
    }
}

#[test]
fn iteration_limit_is_an_error_with_report() {
    let problem = CoshChain::new(10, 0.0, vec![0.0; 10]);
    let mut x = vec![20.0; 10];
    let settings = NewtonSettings {
        max_iterations: 1,
        ..Default::default()
    };
    let err = minimize(&problem, &mut x, &[false; 10], &settings).unwrap_err();
    let SolveError::NotConverged(report) = &err else {
        panic!("expected NotConverged, got {err}")
    };
    assert_eq!(report.iterations, 1);
    assert_eq!(report.termination, Termination::MaxIterations);
    assert_eq!(report.energy_history.len(), 2);
    assert_eq!(report.residual_history.len(), 2);
    assert!(report.energy_history[1] < report.energy_history[0]);
    assert!(!report.converged());
    assert!(err.report().is_some());
    assert!(err.to_string().contains("did not converge"));
}

/// Series springs with both ends clamped: every spring carries the same tension
/// `F = (X_N − X_0 − Σ L_e) / Σ (1 / k_e)`, so `x_i = x_{i−1} + L_e + F / k_e`.
#[test]
fn dirichlet_dofs_stay_fixed_and_free_dofs_are_optimal() {
    let mut rng = Rng::new(9);
    let n = 30;
    let chain = LinearChain {
        edges: (0..n - 1).map(|i| [i, i + 1]).collect(),
        k: (0..n - 1).map(|_| rng.range(1.0, 100.0)).collect(),
        rest: (0..n - 1).map(|_| rng.range(0.01, 0.1)).collect(),
    };
    let (x_start, x_end) = (0.1, 2.3);
    let mut x: Vec<f64> = (0..n).map(|_| rng.range(-1.0, 1.0)).collect();
    x[0] = x_start;
    x[n - 1] = x_end;
    let mut fixed = vec![false; n];
    fixed[0] = true;
    fixed[n - 1] = true;
    let report = minimize(&chain, &mut x, &fixed, &NewtonSettings::default()).unwrap();
    assert!(report.converged());
    assert_eq!(x[0].to_bits(), x_start.to_bits());
    assert_eq!(x[n - 1].to_bits(), x_end.to_bits());
    let compliance: f64 = chain.k.iter().map(|k| 1.0 / k).sum();
    let tension = (x_end - x_start - chain.rest.iter().sum::<f64>()) / compliance;
    let mut expected = vec![x_start];
    for e in 0..n - 1 {
        expected.push(expected[e] + chain.rest[e] + tension / chain.k[e]);
    }
    assert_close(&x, &expected, 1e-12, "x");
}

/// A hanging nonlinear spring net (clamped top row, gravity load): fixed DOFs are bit-for-bit
/// unchanged and the free gradient vanishes.
#[test]
fn hanging_spring_net_with_dirichlet_rows() {
    let (net, mut x, fixed) = hanging_net(6, 5);
    let x0 = x.clone();
    let mut solver = NewtonSolver::new(&net, &fixed).unwrap();
    let report = solver
        .minimize(&net, &mut x, &NewtonSettings::default())
        .unwrap();
    assert!(report.converged());
    for d in 0..net.n_dofs() {
        if fixed[d] {
            assert_eq!(x[d].to_bits(), x0[d].to_bits());
        }
    }
    let mut asm = solver::Assembler::with_fixed_dofs(&net, &fixed).unwrap();
    let (_, g) = asm.gradient(&net, &x).unwrap();
    for d in (0..net.n_dofs()).filter(|&d| !fixed[d]) {
        assert!(g[d].abs() <= 1e-9, "g[{d}] = {}", g[d]);
    }
    // The solver is reusable: restarting from the solution converges immediately.
    let mut x2 = x.clone();
    let again = solver
        .minimize(&net, &mut x2, &NewtonSettings::default())
        .unwrap();
    assert!(again.iterations <= 1);
}

#[test]
fn all_dofs_fixed_converges_immediately() {
    let chain = LinearChain::uniform(3, 1.0, 1.0);
    let mut x = vec![0.0, 5.0, 6.0];
    let report = minimize(&chain, &mut x, &[true; 3], &NewtonSettings::default()).unwrap();
    assert_eq!(report.iterations, 0);
    assert_eq!(x, vec![0.0, 5.0, 6.0]);
}

/// `E(x) = x − ln x` (minimum at 1): the full Newton step from x = 10 leaves the domain
/// (E = NaN), so the line search must backtrack; starting outside the domain is an error.
struct LogBarrier([usize; 1]);

impl Problem for LogBarrier {
    fn n_dofs(&self) -> usize {
        1
    }
    fn n_stencils(&self) -> usize {
        1
    }
    fn stencil_dofs(&self, _: usize) -> &[usize] {
        &self.0
    }
    fn eval_stencil(&self, _: usize, x: &[f64], g: &mut [f64], h: Option<&mut [f64]>) -> f64 {
        g[0] = 1.0 - 1.0 / x[0];
        if let Some(h) = h {
            h[0] = 1.0 / (x[0] * x[0]);
        }
        x[0] - x[0].ln()
    }
}

#[test]
fn line_search_rejects_non_finite_trials_and_non_finite_start_fails() {
    let problem = LogBarrier([0]);
    let mut x = vec![10.0];
    let report = minimize(&problem, &mut x, &[false], &NewtonSettings::default()).unwrap();
    assert!((x[0] - 1.0).abs() < 1e-10);
    assert!(report.line_search_backtracks > 0);
    assert!(report.step_lengths[0] < 1.0);

    let mut bad = vec![-1.0];
    let err = minimize(&problem, &mut bad, &[false], &NewtonSettings::default()).unwrap_err();
    assert!(
        matches!(err, SolveError::NonFinite(ref r) if r.iterations == 0),
        "{err}"
    );
}

/// [`LogBarrier`] whose admissible steps move `x` by at most `max_move` (a stand-in for a
/// collision filter).
struct Filtered(LogBarrier, f64);

impl Problem for Filtered {
    fn n_dofs(&self) -> usize {
        1
    }
    fn n_stencils(&self) -> usize {
        1
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        self.0.stencil_dofs(k)
    }
    fn eval_stencil(&self, k: usize, x: &[f64], g: &mut [f64], h: Option<&mut [f64]>) -> f64 {
        self.0.eval_stencil(k, x, g, h)
    }
    fn max_step(&self, _: &[f64], dx: &[f64]) -> f64 {
        self.1 / dx[0].abs()
    }
}

#[test]
fn line_search_starts_within_the_problem_step_filter() {
    // From x = 10 the Newton step is −90: unfiltered, the first trial is at −80.
    let mut x = vec![10.0];
    let report = minimize(
        &Filtered(LogBarrier([0]), 0.5),
        &mut x,
        &[false],
        &NewtonSettings::default(),
    )
    .unwrap();
    assert!((x[0] - 1.0).abs() < 1e-10);
    assert!(
        report.step_lengths[0] <= 0.5 / 90.0 + 1e-15,
        "{:?}",
        report.step_lengths
    );
    // Travelling 9 in moves of at most 0.5 takes at least 18 steps.
    assert!(report.iterations >= 18, "{}", report.iterations);

    // A filter that admits no step at all (or answers NaN) is a line-search failure, not a
    // hang and not an unfiltered step.
    for bound in [0.0, f64::NAN] {
        let mut x = vec![10.0];
        let err = minimize(
            &Filtered(LogBarrier([0]), bound),
            &mut x,
            &[false],
            &NewtonSettings::default(),
        )
        .unwrap_err();
        assert!(matches!(err, SolveError::LineSearchFailed(_)), "{err}");
        assert_eq!(x, [10.0]);
    }
}

#[test]
fn a_stalled_run_fails_early_and_a_progressing_one_is_unchanged() {
    // A filter that admits moves of 1e-13 only: every step changes the energy by less than
    // its rounding allowance and the residual not at all.
    let stalled = Filtered(LogBarrier([0]), 1e-13);
    let settings = NewtonSettings {
        stall_iterations: 5,
        ..Default::default()
    };
    let mut x = vec![10.0];
    let err = minimize(&stalled, &mut x, &[false], &settings).unwrap_err();
    let SolveError::Stalled(report) = &err else {
        panic!("expected Stalled, got {err}")
    };
    assert_eq!(report.termination, Termination::Stalled);
    assert_eq!(report.iterations, 5);
    assert!(err.to_string().contains("stalled"), "{err}");
    assert!((x[0] - 10.0).abs() <= 5e-13 * 1.01, "{}", x[0]);
    // Without the setting the same run goes on to the iteration limit.
    let mut x = vec![10.0];
    let err = minimize(&stalled, &mut x, &[false], &NewtonSettings::default()).unwrap_err();
    assert!(
        matches!(err, SolveError::NotConverged(ref r) if r.iterations == 100),
        "{err}"
    );

    // A run that makes progress in small filtered steps (at least 18 of them, each lowering
    // the energy) is not stalled: the same iterates with and without the test.
    let slow = Filtered(LogBarrier([0]), 0.5);
    let tight = NewtonSettings {
        stall_iterations: 2,
        ..Default::default()
    };
    let (mut a, mut b) = (vec![10.0], vec![10.0]);
    let with = minimize(&slow, &mut a, &[false], &tight).unwrap();
    let without = minimize(&slow, &mut b, &[false], &NewtonSettings::default()).unwrap();
    assert!(with.iterations >= 18, "{}", with.iterations);
    assert_eq!(with.residual_history, without.residual_history);
    assert_eq!(a, b);
}

#[test]
fn invalid_settings_and_lengths_are_errors() {
    let chain = LinearChain::uniform(3, 1.0, 1.0);
    let mut x = vec![0.0; 3];
    let settings = NewtonSettings {
        armijo: 1.5,
        ..Default::default()
    };
    assert!(matches!(
        minimize(&chain, &mut x, &[false; 3], &settings),
        Err(SolveError::InvalidSettings(_))
    ));
    let settings = NewtonSettings {
        regularization_growth: 1.0,
        ..Default::default()
    };
    assert!(matches!(
        minimize(&chain, &mut x, &[false; 3], &settings),
        Err(SolveError::InvalidSettings(_))
    ));
    assert!(matches!(
        minimize(&chain, &mut x, &[false; 2], &NewtonSettings::default()),
        Err(SolveError::DimensionMismatch { .. })
    ));
    let mut short = vec![0.0; 2];
    let mut solver = NewtonSolver::new(&chain, &[false; 3]).unwrap();
    assert!(matches!(
        solver.minimize(&chain, &mut short, &NewtonSettings::default()),
        Err(SolveError::DimensionMismatch { .. })
    ));
}

/// `E = a x² − ε y² + y⁴` with a stiff `x` (`a = 10⁴`) and a weak negative curvature in `y`
/// (`ε = 3·10⁻³`): a saddle at the origin, minima at `(0, ±√(ε/2))`. The diagonal scale of the
/// shift comes from the stiff direction, as with the yarn contacts of a jammed tile.
struct Saddle;

const STIFF: f64 = 1e4;
const WEAK: f64 = 3e-3;

impl Problem for Saddle {
    fn n_dofs(&self) -> usize {
        2
    }
    fn n_stencils(&self) -> usize {
        1
    }
    fn stencil_dofs(&self, _: usize) -> &[usize] {
        &[0, 1]
    }
    fn eval_stencil(&self, _: usize, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let (x, y) = (q[0], q[1]);
        grad[0] = 2.0 * STIFF * x;
        grad[1] = -2.0 * WEAK * y + 4.0 * y.powi(3);
        if let Some(h) = hess {
            h.copy_from_slice(&[2.0 * STIFF, 0.0, 0.0, -2.0 * WEAK + 12.0 * y * y]);
        }
        STIFF * x * x - WEAK * y * y + y.powi(4)
    }
}

#[test]
fn exact_hessian_newton_escapes_a_saddle_along_negative_curvature() {
    // Started next to the saddle, the shifted steps move y by about g/μ; doubling them while
    // the energy falls (ΔᵀHΔ < 0) reaches the minimum in a handful of iterations.
    let settings = NewtonSettings {
        project_spd: false,
        gradient_rel_tol: 0.0,
        ..NewtonSettings::default()
    };
    let mut q = vec![0.3, 1e-6];
    let report = minimize(&Saddle, &mut q, &[false, false], &settings).unwrap();
    assert!(
        q[0].abs() < 1e-9 && (q[1] - (WEAK / 2.0).sqrt()).abs() < 1e-8,
        "{q:?}"
    );
    assert!(report.iterations <= 20, "{} iterations", report.iterations);
}

/// The warm-start tests' setup: a 12-D double well, a start in its concave region (every
/// run from it needs a shift) and one-iteration Newton runs (linearized steps) with the
/// exact, unprojected Hessian.
fn concave_one_iteration_runs() -> (usize, DoubleWell, Vec<f64>, NewtonSettings) {
    let n = 12;
    let x0 = (0..n).map(|i| 0.1 * (i as f64).sin()).collect();
    let settings = NewtonSettings {
        project_spd: false,
        max_iterations: 1,
        line_search: false,
        accept_iteration_limit: true,
        ..Default::default()
    };
    (n, DoubleWell::new(n, 0.1), x0, settings)
}

/// `warm_start_regularization`: one-iteration runs (linearized steps) from the same point in
/// the concave region of the double well need the same shift every run. Cold, every run
/// escalates from `μ₀ s` and makes the same number of linear solves; warm, the runs after the
/// first start one factor below the last shift and need fewer solves, and every run takes
/// the same step as the cold one.
#[test]
fn warm_started_regularization_skips_the_escalation() {
    let (n, problem, x0, base) = concave_one_iteration_runs();
    let mut results = Vec::new();
    for warm in [false, true] {
        let settings = NewtonSettings {
            warm_start_regularization: warm,
            ..base.clone()
        };
        let mut solver = NewtonSolver::new(&problem, &vec![false; n]).unwrap();
        let mut runs = Vec::new();
        for _ in 0..3 {
            let mut x = x0.clone();
            let report = solver.minimize(&problem, &mut x, &settings).unwrap();
            runs.push((x, report.linear_solves, report.regularizations[0]));
        }
        results.push(runs);
    }
    let (cold, warm) = (&results[0], &results[1]);
    eprintln!(
        "linear solves per run: cold {:?}, warm {:?}; shift {:.3e}",
        cold.iter().map(|r| r.1).collect::<Vec<_>>(),
        warm.iter().map(|r| r.1).collect::<Vec<_>>(),
        cold[0].2
    );
    assert!(cold[0].2 > 0.0, "the start needs a shift");
    assert!(cold.iter().all(|r| r.1 == cold[0].1) && cold[0].1 >= 4);
    assert_eq!(
        warm[0].1, cold[0].1,
        "the first warm run has nothing to start from"
    );
    for k in 1..3 {
        assert!(
            warm[k].1 < cold[k].1,
            "run {k}: {} vs {}",
            warm[k].1,
            cold[k].1
        );
    }
    // The same shift up to the rounding of (μ/γ)·γ, and so the same step.
    for (c, w) in cold.iter().zip(warm) {
        assert!(
            (c.2 - w.2).abs() <= 1e-12 * c.2,
            "shifts {} vs {}",
            c.2,
            w.2
        );
        for (a, b) in c.0.iter().zip(&w.0) {
            assert!((a - b).abs() <= 1e-12, "steps differ: {a} vs {b}");
        }
    }
}

/// `carried_shift_probe_interval`: where every run needs the same shift (one-iteration runs
/// from the same point of the double well's concave region), the runs between probes start
/// at the carried shift and make one linear solve instead of the warm start's failing
/// unshifted and lower attempts; every third run probes from `μ = 0` like the warm start;
/// every run takes the warm start's step.
#[test]
fn a_carried_shift_skips_the_failing_solves() {
    let (n, problem, x0, base) = concave_one_iteration_runs();
    let warm = NewtonSettings {
        warm_start_regularization: true,
        ..base
    };
    let carry = NewtonSettings {
        carried_shift_probe_interval: 3,
        ..warm.clone()
    };
    // Without the warm start there is nothing to carry: an error, not a silent no-op.
    let lone = NewtonSettings {
        warm_start_regularization: false,
        ..carry.clone()
    };
    assert!(lone.validate().is_err());
    let runs = |settings: &NewtonSettings| {
        let mut solver = NewtonSolver::new(&problem, &vec![false; n]).unwrap();
        (0..7)
            .map(|_| {
                let mut x = x0.clone();
                let report = solver.minimize(&problem, &mut x, settings).unwrap();
                (x, report.linear_solves)
            })
            .collect::<Vec<_>>()
    };
    let (w, c) = (runs(&warm), runs(&carry));
    let solves = |r: &[(Vec<f64>, usize)]| r.iter().map(|r| r.1).collect::<Vec<_>>();
    eprintln!(
        "linear solves per run: warm {:?}, carried {:?}",
        solves(&w),
        solves(&c)
    );
    for k in 0..7 {
        if k % 3 == 0 {
            assert_eq!(c[k].1, w[k].1, "run {k} probes like the warm start");
        } else {
            assert_eq!(c[k].1, 1, "run {k} starts at the carried shift");
            assert!(w[k].1 > 1, "run {k}: the warm start fails first");
        }
        for (a, b) in w[k].0.iter().zip(&c[k].0) {
            assert!((a - b).abs() <= 1e-12, "run {k}: steps differ: {a} vs {b}");
        }
    }
}

/// Known unstable directions of the CG back end: the double well's one-iteration runs from
/// its concave region escalate the shift from `μ = 0` every run (no warm start of the shift).
/// The first failed solve of the first run leaves a direction of negative curvature that
/// rejects the next shifts without solving (`shifts_skipped`); the later runs know it from
/// the start and solve only at the accepted shift. Every run tries the same shifts (solved
/// or skipped) and accepts the shift the sparse Cholesky escalation accepts, and the runs
/// take the same step bit for bit.
#[test]
fn known_directions_of_negative_curvature_skip_the_failing_cg_solves() {
    let (n, problem, x0, base) = concave_one_iteration_runs();
    let cg = NewtonSettings {
        linear_solver: LinearSolver::ConjugateGradient(PcgSettings::new(
            1e-10,
            1000,
            Preconditioner::Jacobi,
        )),
        ..base.clone()
    };
    let mut x = x0.clone();
    let cholesky = minimize(&problem, &mut x, &vec![false; n], &base).unwrap();
    let mut solver = NewtonSolver::new(&problem, &vec![false; n]).unwrap();
    let runs: Vec<_> = (0..3)
        .map(|_| {
            let mut x = x0.clone();
            let report = solver.minimize(&problem, &mut x, &cg).unwrap();
            (
                x,
                report.linear_solves,
                report.shifts_skipped,
                report.regularizations[0],
            )
        })
        .collect();
    eprintln!(
        "(solves, skipped) per run: {:?}; shift {:.3e}; Cholesky: {} solves",
        runs.iter().map(|r| (r.1, r.2)).collect::<Vec<_>>(),
        runs[0].3,
        cholesky.linear_solves
    );
    assert!(runs[0].3 > 0.0, "the start needs a shift");
    assert!(
        runs[0].1 >= 2,
        "the first run fails a solve before it knows a direction"
    );
    assert!(runs[0].2 >= 1, "its direction rejects the next shifts");
    for run in &runs {
        assert_eq!(
            run.1 + run.2,
            cholesky.linear_solves,
            "the same shifts tried"
        );
        assert_eq!(
            run.3, cholesky.regularizations[0],
            "the same shift accepted"
        );
        assert_eq!(run.0, runs[0].0, "the same step bit for bit");
    }
    for run in &runs[1..] {
        assert_eq!(run.1, 1, "later runs solve at the accepted shift only");
    }
}

/// Counts the stencil evaluations of the problem it wraps (with and without Hessian).
struct Counted<'a, P> {
    inner: &'a P,
    gradients: std::sync::atomic::AtomicUsize,
    hessians: std::sync::atomic::AtomicUsize,
}

impl<P: Problem> Problem for Counted<'_, P> {
    fn n_dofs(&self) -> usize {
        self.inner.n_dofs()
    }
    fn n_stencils(&self) -> usize {
        self.inner.n_stencils()
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        self.inner.stencil_dofs(k)
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let counter = if hess.is_some() {
            &self.hessians
        } else {
            &self.gradients
        };
        counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.eval_stencil(k, x, grad, hess)
    }
    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        self.inner.stencil_energy(k, x)
    }
}

/// `final_residual = false`: a run stopped by the iteration limit ends without evaluating
/// the gradient at its last iterate, which is the same bit for bit; its histories end
/// before the last step. Without a line search the setting is refused.
#[test]
fn runs_at_the_iteration_limit_can_skip_the_final_residual() {
    let (n, problem, x0, base) = concave_one_iteration_runs();
    let mut results = Vec::new();
    for final_residual in [true, false] {
        let settings = NewtonSettings {
            line_search: true,
            final_residual,
            ..base.clone()
        };
        let counted = Counted {
            inner: &problem,
            gradients: 0.into(),
            hessians: 0.into(),
        };
        let mut x = x0.clone();
        let report = minimize(&counted, &mut x, &vec![false; n], &settings).unwrap();
        assert_eq!(report.termination, Termination::IterationLimit);
        assert_eq!(report.iterations, 1);
        let stencils = problem.n_stencils();
        results.push((
            x,
            report.residual_history.len(),
            report.energy_history.len(),
            counted.gradients.into_inner() / stencils,
            counted.hessians.into_inner() / stencils,
        ));
    }
    let (with, without) = (&results[0], &results[1]);
    assert_eq!(with.0, without.0, "the same iterate");
    assert_eq!(
        (with.1, with.2),
        (2, 2),
        "residual and energy after the step"
    );
    assert_eq!((without.1, without.2), (1, 1), "only those before it");
    assert_eq!(with.4, without.4, "the same Hessian assemblies");
    assert_eq!(with.3, without.3 + 1, "one gradient evaluation fewer");
    let unchecked = NewtonSettings {
        final_residual: false,
        ..base
    };
    let mut x = x0.clone();
    let err = minimize(&problem, &mut x, &vec![false; n], &unchecked).unwrap_err();
    assert!(
        matches!(&err, SolveError::InvalidSettings(m) if m.contains("final_residual")),
        "{err}"
    );
}
