//! Preconditioned conjugate gradients: standalone solves (tolerance, shift, loud failures) and
//! as the linear solver of Newton (same minimum as Cholesky), plus the fixed-iteration mode.

mod common;

use common::{Quadratic, Rng, hanging_net};
use solver::{
    Assembler, LinearSolver, NewtonSettings, Pcg, PcgFailure, PcgSettings, Preconditioner,
    SolveError, Termination, minimize,
};

/// A random SPD problem (sum of SPD stencils) assembled into the lower-triangle CSC form, with
/// its dense Hessian for checking.
fn random_spd(seed: u64, n: usize) -> (Assembler, Vec<Vec<f64>>) {
    let mut rng = Rng::new(seed);
    let q = Quadratic::random(&mut rng, n, 3 * n, 6, 0.05);
    let x = vec![0.0; n];
    let mut asm = Assembler::new(&q).unwrap();
    asm.assemble(&q, &x, false).unwrap();
    let (dense, _) = q.dense(&x);
    (asm, dense)
}

/// [`random_spd`] with a right-hand side of entries uniform in [−1, 1] (seed `rhs_seed`).
fn random_system(seed: u64, rhs_seed: u64, n: usize) -> (Assembler, Vec<Vec<f64>>, Vec<f64>) {
    let (asm, dense) = random_spd(seed, n);
    let mut rng = Rng::new(rhs_seed);
    let b = (0..n).map(|_| rng.range(-1.0, 1.0)).collect();
    (asm, dense, b)
}

/// `‖b − (A + μI) x‖₂ / ‖b‖₂` with the dense `A`.
fn relative_residual(a: &[Vec<f64>], mu: f64, x: &[f64], b: &[f64]) -> f64 {
    let mut r2 = 0.0;
    for i in 0..b.len() {
        let ax: f64 = (0..x.len()).map(|j| a[i][j] * x[j]).sum::<f64>() + mu * x[i];
        r2 += (b[i] - ax).powi(2);
    }
    r2.sqrt() / b.iter().map(|v| v * v).sum::<f64>().sqrt()
}

#[test]
fn pcg_solves_an_spd_system_to_its_tolerance() {
    let n = 300;
    let (asm, dense, b) = random_system(11, 5, n);
    let mut pcg = Pcg::new(asm.hessian()).unwrap();
    let mut iterations_by_preconditioner = Vec::new();
    for (tol, mu, preconditioner) in [
        (1e-6, 0.0, Preconditioner::Jacobi),
        (1e-10, 0.0, Preconditioner::Jacobi),
        (1e-10, 0.7, Preconditioner::Jacobi),
        (1e-6, 0.0, Preconditioner::IncompleteCholesky),
        (1e-10, 0.0, Preconditioner::IncompleteCholesky),
        (1e-10, 0.7, Preconditioner::IncompleteCholesky),
    ] {
        let settings = PcgSettings::new(tol, 10 * n, preconditioner);
        let mut x = vec![0.0; n];
        let report = pcg.solve(asm.hessian(), mu, &b, &mut x, &settings).unwrap();
        let true_residual = relative_residual(&dense, mu, &x, &b);
        assert!(report.iterations > 0 && report.iterations < 10 * n);
        assert!(report.relative_residual <= tol, "{report:?}");
        // The recursively updated residual tracks the true one (rounding allowance 1e-12).
        assert!(
            true_residual <= tol + 1e-12,
            "tol {tol}, μ {mu}, {preconditioner:?}: true residual {true_residual:.3e}"
        );
        iterations_by_preconditioner.push(report.iterations);
    }
    // IC(0) needs fewer iterations than Jacobi on every case.
    for k in 0..3 {
        let (jacobi, ic) = (
            iterations_by_preconditioner[k],
            iterations_by_preconditioner[k + 3],
        );
        assert!(
            ic < jacobi,
            "case {k}: IC(0) {ic} vs Jacobi {jacobi} iterations"
        );
    }
    // A tighter tolerance takes more iterations.
    let mut iterations = |tol: f64| {
        let mut x = vec![0.0; n];
        let s = PcgSettings::new(tol, 10 * n, Preconditioner::Jacobi);
        pcg.solve(asm.hessian(), 0.0, &b, &mut x, &s)
            .unwrap()
            .iterations
    };
    let (tight, loose) = (iterations(1e-10), iterations(1e-3));
    assert!(tight > loose, "{tight} vs {loose}");
    // b = 0: x = 0 without iterating.
    let mut x = vec![1.0; n];
    let settings = PcgSettings::new(1e-8, 10, Preconditioner::IncompleteCholesky);
    let r = pcg
        .solve(asm.hessian(), 0.0, &vec![0.0; n], &mut x, &settings)
        .unwrap();
    assert_eq!(r.iterations, 0);
    assert!(x.iter().all(|&v| v == 0.0));
}

#[test]
fn pcg_reports_non_convergence_clearly() {
    let n = 300;
    let (asm, _) = random_spd(12, n);
    let b = vec![1.0; n];
    let mut pcg = Pcg::new(asm.hessian()).unwrap();
    let settings = PcgSettings::new(1e-12, 3, Preconditioner::Jacobi);
    let mut x = vec![0.0; n];
    let err = pcg
        .solve(asm.hessian(), 0.0, &b, &mut x, &settings)
        .unwrap_err();
    let PcgFailure::NotConverged {
        iterations,
        relative_residual,
        tolerance,
    } = err
    else {
        panic!("expected NotConverged, got {err:?}");
    };
    assert_eq!(iterations, 3);
    assert_eq!(tolerance, 1e-12);
    assert!(relative_residual > 1e-12 && relative_residual.is_finite());
    assert!(err.to_string().contains("did not converge in 3 iterations"));
}

#[test]
fn pcg_detects_indefinite_matrices_and_bad_input() {
    // E = ½ xᵀ A x with A = [[1, 2], [2, 1]] (eigenvalues 3 and −1; positive diagonal).
    let q = Quadratic {
        n: 2,
        dofs: vec![vec![0, 1]],
        a: vec![vec![1.0, 2.0, 2.0, 1.0]],
        b: vec![vec![0.0, 0.0]],
    };
    let mut asm = Assembler::new(&q).unwrap();
    asm.assemble(&q, &[0.0, 0.0], false).unwrap();
    let mut pcg = Pcg::new(asm.hessian()).unwrap();
    let settings = PcgSettings::new(1e-10, 50, Preconditioner::Jacobi);
    let mut x = vec![0.0; 2];
    // b along the negative-curvature eigenvector (1, −1).
    let err = pcg
        .solve(asm.hessian(), 0.0, &[1.0, -1.0], &mut x, &settings)
        .unwrap_err();
    assert!(matches!(err, PcgFailure::Indefinite(_)), "{err:?}");
    // It leaves the direction it stopped at, p ∥ (1, −1), with its Rayleigh quotient −1,
    // which the quadratic form reproduces.
    let (p, rho) = pcg
        .negative_curvature()
        .expect("a direction of negative curvature");
    let p = p.to_vec();
    assert!(
        (p[0] + p[1]).abs() <= 1e-12 * p[0].abs() && p[0] != 0.0,
        "{p:?}"
    );
    assert!((rho + 1.0).abs() < 1e-12, "ρ = {rho}");
    let pap = pcg.quadratic_form(asm.hessian(), &p).unwrap();
    let pp = p[0] * p[0] + p[1] * p[1];
    assert!((pap / pp - rho).abs() < 1e-12, "{pap} / {pp} vs {rho}");
    // A large enough shift makes it SPD and solvable: (A + 2I) x = (1, −1) → x = (1, −1).
    pcg.solve(asm.hessian(), 2.0, &[1.0, -1.0], &mut x, &settings)
        .unwrap();
    assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] + 1.0).abs() < 1e-12);
    assert!(
        pcg.negative_curvature().is_none(),
        "a converged solve leaves none"
    );
    // A negative diagonal (shift −1.5) is indefinite before any iteration; its direction is
    // the first unit vector, of curvature 1 − 1.5.
    let err = pcg
        .solve(asm.hessian(), -1.5, &[1.0, 1.0], &mut x, &settings)
        .unwrap_err();
    assert!(err.to_string().contains("diagonal entry"), "{err}");
    let (p, rho) = pcg.negative_curvature().expect("the diagonal's direction");
    assert_eq!((p, rho), (&[1.0, 0.0][..], -0.5));
    // IC(0) of the indefinite matrix breaks down: the failure is still reported as
    // indefiniteness.
    let ic = PcgSettings {
        preconditioner: Preconditioner::IncompleteCholesky,
        ..settings
    };
    let err = pcg
        .solve(asm.hessian(), 0.0, &[1.0, -1.0], &mut x, &ic)
        .unwrap_err();
    // (With the shift the last pivot is zero up to rounding: either the factorization
    // reports its breakdown, or CG meets the negative curvature.)
    assert!(matches!(err, PcgFailure::Indefinite(_)), "{err:?}");
    // Wrong lengths and non-finite input are errors.
    assert!(matches!(
        pcg.solve(asm.hessian(), 0.0, &[1.0], &mut x, &settings),
        Err(PcgFailure::Input(_))
    ));
    assert!(matches!(
        pcg.solve(asm.hessian(), 0.0, &[f64::NAN, 1.0], &mut x, &settings),
        Err(PcgFailure::NonFinite(_))
    ));
    // Invalid settings.
    for bad in [(0.0, 10), (1.0, 10), (f64::NAN, 10), (1e-6, 0)] {
        let s = PcgSettings::new(bad.0, bad.1, Preconditioner::Jacobi);
        assert!(matches!(s.validate(), Err(SolveError::InvalidSettings(_))));
    }
}

fn cg(relative_tolerance: f64, max_iterations: usize) -> LinearSolver {
    LinearSolver::ConjugateGradient(PcgSettings::new(
        relative_tolerance,
        max_iterations,
        Preconditioner::Jacobi,
    ))
}

fn cg_ic(relative_tolerance: f64, max_iterations: usize) -> LinearSolver {
    LinearSolver::ConjugateGradient(PcgSettings::new(
        relative_tolerance,
        max_iterations,
        Preconditioner::IncompleteCholesky,
    ))
}

#[test]
fn newton_with_pcg_reaches_the_cholesky_minimum() {
    let (net, x0, fixed) = hanging_net(12, 10);
    let mut x_llt = x0.clone();
    let llt = minimize(&net, &mut x_llt, &fixed, &NewtonSettings::default()).unwrap();
    for linear_solver in [cg(1e-10, 5000), cg_ic(1e-10, 5000)] {
        let settings = NewtonSettings {
            linear_solver,
            ..NewtonSettings::default()
        };
        let mut x_cg = x0.clone();
        let report = minimize(&net, &mut x_cg, &fixed, &settings).unwrap();
        assert!(report.converged() && llt.converged());
        assert_eq!(report.linear_iterations.len(), report.iterations);
        assert!(report.linear_iterations.iter().all(|&k| k > 0));
        assert!(llt.linear_iterations.iter().all(|&k| k == 0));
        let diff = x_cg
            .iter()
            .zip(&x_llt)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let scale = x_llt.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            diff <= 1e-8 * scale,
            "max |x_cg − x_llt| = {diff:.3e} (scale {scale:.3e})"
        );
        assert!(
            (report.last_energy() - llt.last_energy()).abs() <= 1e-10 * llt.last_energy().abs()
        );
    }
}

#[test]
fn newton_fails_loudly_when_cg_does_not_converge() {
    let (net, x0, fixed) = hanging_net(12, 10);
    let settings = NewtonSettings {
        linear_solver: cg(1e-12, 2),
        ..NewtonSettings::default()
    };
    let mut x = x0.clone();
    let err = minimize(&net, &mut x, &fixed, &settings).unwrap_err();
    let SolveError::FactorizationFailed { report, detail } = &err else {
        panic!("expected FactorizationFailed, got {err:?}");
    };
    assert_eq!(report.termination, Termination::FactorizationFailed);
    assert!(
        detail.contains("did not converge in 2 iterations"),
        "{detail}"
    );
    // Not retried with a shift: the failure is reported at the first solve's shift (0).
    assert!(detail.contains("μ = 0.000e0"), "{detail}");
    // The constrained solver does not offer CG.
    let c = solver::LinearConstraints::new(x0.len(), &[(0, 0, 1.0)], &[x0[0]]).unwrap();
    let mut x = x0.clone();
    assert!(matches!(
        solver::minimize_constrained(&net, &mut x, &c, &settings),
        Err(SolveError::InvalidSettings(_))
    ));
}

#[test]
fn one_linearized_iteration_reports_its_residual() {
    let (net, x0, fixed) = hanging_net(12, 10);
    let mut results = Vec::new();
    for linear_solver in [LinearSolver::Cholesky, cg(1e-12, 5000), cg_ic(1e-12, 5000)] {
        let settings = NewtonSettings {
            max_iterations: 1,
            line_search: false,
            accept_iteration_limit: true,
            linear_solver,
            ..NewtonSettings::default()
        };
        let mut x = x0.clone();
        let report = minimize(&net, &mut x, &fixed, &settings).unwrap();
        assert_eq!(report.termination, Termination::IterationLimit);
        assert!(!report.converged());
        assert_eq!(report.iterations, 1);
        assert_eq!(report.step_lengths, vec![1.0]);
        assert_eq!(report.line_search_backtracks, 0);
        assert_eq!(report.residual_history.len(), 2);
        // The reported residual is the free-DOF gradient norm at the returned x.
        let mut asm = Assembler::new(&net).unwrap();
        let (energy, g) = asm.gradient(&net, &x).unwrap();
        let residual = g
            .iter()
            .zip(&fixed)
            .filter(|(_, f)| !**f)
            .fold(0.0f64, |m, (g, _)| m.max(g.abs()));
        assert_eq!(report.last_residual(), residual);
        assert_eq!(report.last_energy(), energy);
        // One full Newton step from a far start does not converge.
        assert!(residual > 1e-6 * report.residual_history[0]);
        results.push(x.clone());
        // Without accept_iteration_limit the same run is an error.
        let strict = NewtonSettings {
            accept_iteration_limit: false,
            ..settings
        };
        let mut x = x0.clone();
        assert!(matches!(
            minimize(&net, &mut x, &fixed, &strict),
            Err(SolveError::NotConverged(_))
        ));
    }
    // All linear solvers take the same full Newton step.
    for other in &results[1..] {
        let diff = results[0]
            .iter()
            .zip(other)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff < 1e-9, "Cholesky and CG steps differ by {diff:.3e} m");
    }
}

#[test]
fn pcg_newton_is_bit_identical_for_one_and_two_threads() {
    // 48 × 40 points: 5760 DOFs, more than one 4096-entry chunk of the parallel sums.
    let run = |threads: usize, linear_solver: LinearSolver| {
        let (net, x0, fixed) = hanging_net(48, 40);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut x = x0.clone();
            let settings = NewtonSettings {
                linear_solver,
                ..NewtonSettings::default()
            };
            let report = minimize(&net, &mut x, &fixed, &settings).unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (
                bits(&x),
                bits(&report.residual_history),
                report.linear_iterations,
            )
        })
    };
    for solver in [cg(1e-10, 20000), cg_ic(1e-10, 20000)] {
        assert_eq!(run(1, solver), run(2, solver));
    }
}

/// `warm_start`: started at a solution of a tighter tolerance, a solve takes no iteration
/// and keeps it; started near the solution it takes fewer iterations than from zero, and
/// from a poor guess it still meets the tolerance (checked with the dense matrix); a guess
/// with a non-finite entry is ignored (started from zero, as without the option).
#[test]
fn a_warm_start_begins_at_the_given_point() {
    let n = 300;
    let (asm, dense, b) = random_system(13, 7, n);
    let mut rng = Rng::new(8);
    let mut pcg = Pcg::new(asm.hessian()).unwrap();
    let cold = PcgSettings::new(1e-8, 10 * n, Preconditioner::IncompleteCholesky);
    let warm = PcgSettings {
        warm_start: true,
        ..cold
    };
    let mut x = vec![0.0; n];
    let from_zero = pcg.solve(asm.hessian(), 0.3, &b, &mut x, &cold).unwrap();
    assert!(from_zero.iterations > 1);
    let solution = x.clone();
    let tight = PcgSettings::new(1e-12, 10 * n, Preconditioner::IncompleteCholesky);
    let mut exact = vec![0.0; n];
    pcg.solve(asm.hessian(), 0.3, &b, &mut exact, &tight)
        .unwrap();
    let mut x = exact.clone();
    let at_solution = pcg.solve(asm.hessian(), 0.3, &b, &mut x, &warm).unwrap();
    assert_eq!(at_solution.iterations, 0);
    assert_eq!(x, exact);
    // Starting near the solution saves iterations; far from it, it still converges.
    for (scale, fewer) in [(1e-6, true), (1e3, false)] {
        let mut x: Vec<f64> = exact
            .iter()
            .map(|v| v + scale * rng.range(-1.0, 1.0))
            .collect();
        let report = pcg.solve(asm.hessian(), 0.3, &b, &mut x, &warm).unwrap();
        assert!(
            relative_residual(&dense, 0.3, &x, &b) <= 1e-8 + 1e-12,
            "{report:?}"
        );
        if fewer {
            assert!(report.iterations < from_zero.iterations, "{report:?}");
        }
    }
    let mut x = vec![f64::NAN; n];
    let report = pcg.solve(asm.hessian(), 0.3, &b, &mut x, &warm).unwrap();
    assert_eq!(report, from_zero);
    assert_eq!(x, solution);
}
