//! The linear solver and integrator variants of a step: preconditioned CG against sparse
//! Cholesky, linearized implicit Euler against the full Newton solve, and lagged Rayleigh-β
//! damping matrices.

use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{SimError, Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_boundary_nodes};
use solver::{LinearSolver, PcgSettings, Preconditioner, Termination};

/// A 4 × 4 garter swatch of the Table 1 sweater yarn (loop width 3 mm) hanging from its
/// pinned bind-off edge, α = 10 /s, β = 0.01 s, dt = 1 ms, with `adjust` applied to the
/// settings.
fn hanging(adjust: impl FnOnce(StepSettings) -> StepSettings) -> Simulator {
    let chart = Chart::garter(4, 4).unwrap();
    let params = YarnParams::sweater();
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).unwrap();
    let settings = adjust(StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    });
    let mut sim = Simulator::new(topo, &layout, params, ForceSet::default(), settings).unwrap();
    let (w, h) = (chart.width(), chart.height());
    let pins: Vec<usize> = knit_boundary_nodes(w, h);
    sim.pin_nodes(&pins).unwrap();
    sim
}

fn pcg(relative_tolerance: f64, preconditioner: Preconditioner) -> LinearSolver {
    LinearSolver::ConjugateGradient(PcgSettings::new(relative_tolerance, 20_000, preconditioner))
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

const STEPS: usize = 5;

/// Five full backward Euler steps with CG (relative tolerance 1e-10; Jacobi and IC(0)) end
/// within 1e-6 of the state's total change of the same steps with Cholesky: the Newton
/// solves converge to the same gradient tolerance, and the CG iterations are reported.
#[test]
fn pcg_steps_match_cholesky_steps() {
    for preconditioner in [Preconditioner::Jacobi, Preconditioner::IncompleteCholesky] {
        pcg_steps_match_cholesky_steps_with(preconditioner);
    }
}

fn pcg_steps_match_cholesky_steps_with(preconditioner: Preconditioner) {
    let mut chol = hanging(|s| s);
    let mut cg = hanging(|mut s| {
        s.newton.linear_solver = pcg(1e-10, preconditioner);
        s
    });
    let q0 = chol.state().q.clone();
    for _ in 0..STEPS {
        let a = chol.step().unwrap();
        let b = cg.step().unwrap();
        assert_eq!(a.linear_iterations, 0);
        assert!(b.linear_iterations >= b.newton_iterations);
        assert!(b.last_newton.unwrap().converged());
    }
    let change = max_abs_diff(&chol.state().q, &q0);
    let diff = max_abs_diff(&chol.state().q, &cg.state().q);
    assert!(change > 1e-7, "the swatch moves: {change:.3e}");
    assert!(
        diff <= 1e-6 * change,
        "CG ({preconditioner:?}) vs Cholesky: {diff:.3e} m after a change of {change:.3e} m"
    );
}

/// Linearized implicit Euler takes exactly one Newton iteration per step, reports
/// [`Termination::IterationLimit`] with the residual after the iteration (not converged),
/// and agrees between Cholesky and CG. Its distance to the full backward Euler solution
/// after 5 ms (the linearization error; measured ≈ 8 % of the state change at dt = 1 ms in
/// the first, fast-sagging milliseconds) shrinks when dt is halved (first order: ≤ 0.75×).
#[test]
fn linearized_steps_take_one_iteration_and_report_their_residual() {
    let linearization_error = |dt: f64| {
        let with_dt = |mut s: StepSettings| {
            s.dt = dt;
            s
        };
        let mut full = hanging(with_dt);
        let mut lin = hanging(|s| with_dt(s).linearized_implicit_euler());
        let q0 = full.state().q.clone();
        let steps = (5e-3 / dt).round() as usize;
        for _ in 0..steps {
            full.step().unwrap();
            lin.step().unwrap();
        }
        let change = max_abs_diff(&full.state().q, &q0);
        (max_abs_diff(&full.state().q, &lin.state().q), change)
    };
    let (coarse, change) = linearization_error(1e-3);
    let (fine, _) = linearization_error(5e-4);
    assert!(
        coarse > 0.0 && coarse < change,
        "{coarse:.3e} of {change:.3e}"
    );
    assert!(
        fine <= 0.75 * coarse,
        "linearization error {fine:.3e} m (dt/2) vs {coarse:.3e} m (dt)"
    );

    let mut lin = hanging(StepSettings::linearized_implicit_euler);
    let mut lin_cg = hanging(|s| {
        let mut s = s.linearized_implicit_euler();
        s.newton.linear_solver = pcg(1e-10, Preconditioner::IncompleteCholesky);
        s
    });
    let q0 = lin.state().q.clone();
    for _ in 0..STEPS {
        let r = lin.step().unwrap();
        lin_cg.step().unwrap();
        assert_eq!((r.newton_iterations, r.substeps), (1, 1));
        let newton = r.last_newton.unwrap();
        assert_eq!(newton.termination, Termination::IterationLimit);
        assert_eq!(newton.residual_history.len(), 2);
        assert!(newton.last_residual() > 0.0 && newton.last_residual().is_finite());
        assert_eq!(newton.step_lengths, vec![1.0]);
    }
    let change = max_abs_diff(&lin.state().q, &q0);
    let cg_err = max_abs_diff(&lin.state().q, &lin_cg.state().q);
    assert!(
        cg_err <= 1e-6 * change,
        "linearized CG vs Cholesky: {cg_err:.3e} m of {change:.3e} m"
    );
}

/// Lagged Rayleigh-β matrices: `damping_refresh_steps = 1` is bit-identical to the default;
/// with a lag the first step is identical (the matrices are built at the first step either
/// way), later steps differ, and the difference after 5 ms grows with the lag (2 < 3 steps;
/// measured ≈ 14 % of the state change with 3 during the initial sag, where the damping
/// matrices change fastest); 0 is rejected.
#[test]
fn lagged_damping_matrices() {
    let mut every = hanging(|s| s);
    let mut once = hanging(|mut s| {
        s.damping_refresh_steps = 1;
        s
    });
    let lag = |steps: usize| {
        hanging(move |mut s| {
            s.damping_refresh_steps = steps;
            s
        })
    };
    let (mut lag2, mut lag3) = (lag(2), lag(3));
    let q0 = every.state().q.clone();
    for step in 0..STEPS {
        every.step().unwrap();
        once.step().unwrap();
        lag2.step().unwrap();
        lag3.step().unwrap();
        assert_eq!(every.state().q, once.state().q);
        if step == 0 {
            assert_eq!(every.state().q, lag3.state().q);
        }
    }
    let change = max_abs_diff(&every.state().q, &q0);
    let diff2 = max_abs_diff(&every.state().q, &lag2.state().q);
    let diff3 = max_abs_diff(&every.state().q, &lag3.state().q);
    assert!(diff2 > 0.0, "later steps use lagged matrices");
    assert!(
        diff2 < diff3 && diff3 < change,
        "lagged damping: {diff2:.3e} m (lag 2), {diff3:.3e} m (lag 3) of {change:.3e} m"
    );
    let chart = Chart::garter(2, 2).unwrap();
    let params = YarnParams::sweater();
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).unwrap();
    let settings = StepSettings {
        damping_refresh_steps: 0,
        ..StepSettings::default()
    };
    assert!(matches!(
        Simulator::new(topo, &layout, params, ForceSet::default(), settings),
        Err(SimError::Invalid(_))
    ));
}
