//! Equality-constrained Newton (augmented KKT system, range-space solve).

mod common;

use common::{CoshChain, Rng, assert_close, dense_solve, hanging_net, spd_quadratic};
use solver::{
    ConstrainedNewtonSolver, LinearConstraints, NewtonSettings, Problem, SolveError, minimize,
    minimize_constrained,
};

/// Random sparse rows: `m` constraints with `per_row` entries each.
fn random_constraints(
    rng: &mut Rng,
    n: usize,
    m: usize,
    per_row: usize,
) -> (Vec<(usize, usize, f64)>, Vec<f64>) {
    let mut triplets = vec![];
    for r in 0..m {
        for _ in 0..per_row {
            triplets.push((r, rng.index(n), rng.range(-2.0, 2.0)));
        }
    }
    let d = (0..m).map(|_| rng.range(-1.0, 1.0)).collect();
    (triplets, d)
}

/// The dense KKT matrix `[H Cᵀ; C 0]` of a dense `H` and constraint triplets (`m` rows).
fn dense_kkt(h: &[Vec<f64>], triplets: &[(usize, usize, f64)], m: usize) -> Vec<Vec<f64>> {
    let n = h.len();
    let mut kkt = vec![vec![0.0; n + m]; n + m];
    for i in 0..n {
        kkt[i][..n].copy_from_slice(&h[i]);
    }
    for &(r, c, v) in triplets {
        kkt[n + r][c] += v;
        kkt[c][n + r] += v;
    }
    kkt
}

/// Closed form: the minimizer of `½xᵀHx − bᵀx` s.t. `Cx = d` solves
/// `[H Cᵀ; C 0] [x; λ] = [b; d]`.
#[test]
fn constrained_quadratic_matches_closed_form_kkt_solution() {
    let mut rng = Rng::new(21);
    let q = spd_quadratic(4, 30);
    let (n, m) = (q.n, 6);
    let (triplets, d) = random_constraints(&mut rng, n, m, 4);
    let constraints = LinearConstraints::new(n, &triplets, &d).unwrap();

    let (h, g0) = q.dense(&vec![0.0; n]);
    let kkt = dense_kkt(&h, &triplets, m);
    let rhs: Vec<f64> = g0.iter().map(|g| -g).chain(d.iter().copied()).collect();
    let reference = dense_solve(&kkt, &rhs);

    let mut x = vec![0.0; n]; // infeasible start
    let report =
        minimize_constrained(&q, &mut x, &constraints, &NewtonSettings::default()).unwrap();
    assert!(report.converged());
    assert_eq!(
        report.iterations, 1,
        "quadratic: one step after restoration"
    );
    assert!(report.initial_constraint_violation > 0.1);
    assert_close(&x, &reference[..n], 1e-10, "x");
    assert!(constraints.violation(&x).unwrap() <= 1e-10);
    assert!(
        report
            .constraint_violation_history
            .iter()
            .all(|&v| v <= 1e-12)
    );
}

/// A nonlinear convex energy with one coupling constraint `Σ x_i = d`: at the solution the
/// gradient is parallel to `Cᵀ = (1, …, 1)`, i.e. all its entries are equal.
#[test]
fn nonlinear_problem_with_sum_constraint_satisfies_kkt_conditions() {
    let mut rng = Rng::new(8);
    let n = 40;
    let problem = CoshChain::new(n, 0.2, (0..n).map(|_| rng.range(-1.0, 1.0)).collect());
    let triplets: Vec<_> = (0..n).map(|i| (0, i, 1.0)).collect();
    let constraints = LinearConstraints::new(n, &triplets, &[7.5]).unwrap();
    let mut x: Vec<f64> = (0..n).map(|_| rng.range(-3.0, 3.0)).collect();
    let settings = NewtonSettings {
        gradient_abs_tol: 1e-11,
        gradient_rel_tol: 0.0,
        ..Default::default()
    };
    let report = minimize_constrained(&problem, &mut x, &constraints, &settings).unwrap();
    assert!(report.converged() && report.iterations > 2);
    assert!((x.iter().sum::<f64>() - 7.5).abs() <= 1e-10);
    let mut asm = solver::Assembler::new(&problem).unwrap();
    let (_, g) = asm.gradient(&problem, &x).unwrap();
    let mean = g.iter().sum::<f64>() / n as f64;
    let dev = g.iter().fold(0.0f64, |m, gi| m.max((gi - mean).abs()));
    assert!(
        dev <= 1e-10,
        "projected gradient not zero: {dev:e}, {report:?}"
    );
    assert!(report.last_residual() <= 1e-11);
}

/// Clamping the top row of a hanging nonlinear spring net with pin constraints gives the same
/// equilibrium as eliminating those DOFs, even from a start that violates the pins.
#[test]
fn clamping_by_constraints_equals_dirichlet_elimination() {
    let (net, x0, fixed) = hanging_net(5, 4);
    let mut x_dirichlet = x0.clone();
    minimize(&net, &mut x_dirichlet, &fixed, &NewtonSettings::default()).unwrap();

    let pinned: Vec<usize> = (0..net.n_dofs()).filter(|&d| fixed[d]).collect();
    let values: Vec<f64> = pinned.iter().map(|&d| x0[d]).collect();
    let constraints = LinearConstraints::pin(net.n_dofs(), &pinned, &values).unwrap();
    let mut x = x0.clone();
    for &d in &pinned {
        x[d] += 0.05; // violate the pins
    }
    let report =
        minimize_constrained(&net, &mut x, &constraints, &NewtonSettings::default()).unwrap();
    assert!(report.converged());
    assert!((report.initial_constraint_violation - 0.05).abs() < 1e-15);
    assert!(constraints.violation(&x).unwrap() <= 1e-12);
    assert_close(&x, &x_dirichlet, 1e-9, "x");
}

#[test]
fn without_constraints_it_is_plain_newton() {
    let q = spd_quadratic(6, 20);
    let none = LinearConstraints::new(q.n, &[], &[]).unwrap();
    let mut x1 = vec![0.0; q.n];
    let mut x2 = vec![0.0; q.n];
    minimize_constrained(&q, &mut x1, &none, &NewtonSettings::default()).unwrap();
    minimize(&q, &mut x2, &vec![false; q.n], &NewtonSettings::default()).unwrap();
    assert_close(&x1, &x2, 1e-12, "x");
}

#[test]
fn rank_deficient_constraints_fail_loudly() {
    let q = spd_quadratic(2, 10);
    let n = q.n;
    type Case = (&'static str, Vec<(usize, usize, f64)>, Vec<f64>);
    let cases: Vec<Case> = vec![
        (
            "repeated row",
            vec![(0, 1, 1.0), (0, 2, -1.0), (1, 1, 1.0), (1, 2, -1.0)],
            vec![0.5, 0.5],
        ),
        (
            "dependent row (r2 = r0 + 2 r1)",
            vec![
                (0, 0, 1.0),
                (0, 3, 2.0),
                (1, 4, 1.0),
                (1, 0, -1.0),
                (2, 0, -1.0),
                (2, 3, 2.0),
                (2, 4, 2.0),
            ],
            vec![1.0, 2.0, 5.0],
        ),
        ("zero row", vec![(0, 1, 1.0), (1, 2, 0.0)], vec![0.0, 0.0]),
        (
            "same DOF pinned twice",
            vec![(0, 5, 1.0), (1, 5, 2.0)],
            vec![1.0, 2.0],
        ),
    ];
    for (what, triplets, d) in cases {
        let constraints = LinearConstraints::new(n, &triplets, &d).unwrap();
        match ConstrainedNewtonSolver::new(&q, &constraints) {
            Err(SolveError::RankDeficientConstraints(msg)) => assert!(!msg.is_empty()),
            Err(e) => panic!("{what}: unexpected error {e}"),
            Ok(_) => panic!("{what}: rank deficiency not detected"),
        }
    }
    // More constraints than DOFs.
    let triplets: Vec<_> = (0..n + 1).map(|r| (r, r % n, 1.0 + r as f64)).collect();
    let constraints = LinearConstraints::new(n, &triplets, &vec![0.0; n + 1]).unwrap();
    assert!(matches!(
        ConstrainedNewtonSolver::new(&q, &constraints),
        Err(SolveError::RankDeficientConstraints(_))
    ));
}

#[test]
fn malformed_constraints_are_rejected() {
    assert!(matches!(
        LinearConstraints::new(3, &[(0, 3, 1.0)], &[0.0]),
        Err(SolveError::InvalidConstraints(_))
    ));
    assert!(matches!(
        LinearConstraints::new(3, &[(1, 0, 1.0)], &[0.0]),
        Err(SolveError::InvalidConstraints(_))
    ));
    assert!(matches!(
        LinearConstraints::new(3, &[(0, 0, f64::NAN)], &[0.0]),
        Err(SolveError::InvalidConstraints(_))
    ));
    assert!(matches!(
        LinearConstraints::new(3, &[(0, 0, 1.0)], &[f64::INFINITY]),
        Err(SolveError::InvalidConstraints(_))
    ));
    assert!(matches!(
        LinearConstraints::pin(3, &[0, 1], &[0.0]),
        Err(SolveError::DimensionMismatch { .. })
    ));
    let q = spd_quadratic(1, 4);
    let wrong_width = LinearConstraints::new(5, &[(0, 0, 1.0)], &[0.0]).unwrap();
    assert!(matches!(
        ConstrainedNewtonSolver::new(&q, &wrong_width),
        Err(SolveError::DimensionMismatch { .. })
    ));
    let ok = LinearConstraints::new(4, &[(0, 0, 1.0)], &[0.0]).unwrap();
    assert!(matches!(
        ok.violation(&[0.0; 3]),
        Err(SolveError::DimensionMismatch { .. })
    ));
}

/// A free-floating chain has a singular Hessian (rigid translation); the constraint
/// `Σ x_i = 0` on the mean position removes the mode, and the KKT system is nonsingular without
/// any regularization. Closed form: every spring at rest length, centred at 0.
#[test]
fn constraint_removes_the_rigid_mode_of_a_floating_chain() {
    let n = 25;
    let chain = common::LinearChain::uniform(n, 10.0, 0.2);
    let triplets: Vec<_> = (0..n).map(|i| (0, i, 1.0)).collect();
    let constraints = LinearConstraints::new(n, &triplets, &[0.0]).unwrap();
    let mut rng = Rng::new(3);
    let mut x: Vec<f64> = (0..n).map(|_| rng.range(-1.0, 1.0)).collect();
    let report =
        minimize_constrained(&chain, &mut x, &constraints, &NewtonSettings::default()).unwrap();
    assert!(report.converged());
    assert!(report.regularizations.iter().all(|&mu| mu == 0.0));
    let expected: Vec<f64> = (0..n).map(|i| 0.2 * (i as f64 - 12.0)).collect();
    assert_close(&x, &expected, 1e-12, "x");
}

/// `E = −x² + x⁴ + (y − 1)² + (y + z)²` on DOFs `(x, y, z)` under `y + 2z = 1`: started at
/// `x = 0`, where `∂E/∂x = 0`, shifted Newton steps keep `x = 0` exactly and converge to the
/// saddle; the negative-curvature direction along `x` must take the solve to a minimum,
/// `x² = ½`.
struct Saddle;

impl Problem for Saddle {
    fn n_dofs(&self) -> usize {
        3
    }
    fn n_stencils(&self) -> usize {
        1
    }
    fn stencil_dofs(&self, _: usize) -> &[usize] {
        &[0, 1, 2]
    }
    fn eval_stencil(&self, _: usize, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let (x, y, z) = (q[0], q[1], q[2]);
        grad[0] = -2.0 * x + 4.0 * x.powi(3);
        grad[1] = 2.0 * (y - 1.0) + 2.0 * (y + z);
        grad[2] = 2.0 * (y + z);
        if let Some(h) = hess {
            h.copy_from_slice(&[-2.0 + 12.0 * x * x, 0.0, 0.0, 0.0, 4.0, 2.0, 0.0, 2.0, 2.0]);
        }
        -x * x + x.powi(4) + (y - 1.0).powi(2) + (y + z).powi(2)
    }
}

#[test]
fn constrained_newton_leaves_a_saddle_with_no_gradient_along_its_unstable_mode() {
    let constraints = LinearConstraints::new(3, &[(0, 1, 1.0), (0, 2, 2.0)], &[1.0]).unwrap();
    let settings = NewtonSettings {
        project_spd: false,
        ..NewtonSettings::default()
    };
    let mut q = vec![0.0, 3.0, -1.0];
    let report = minimize_constrained(&Saddle, &mut q, &constraints, &settings).unwrap();
    assert!(report.converged());
    assert!(
        (q[0] * q[0] - 0.5).abs() < 1e-10,
        "x = {} (a saddle at x = 0 is not a minimum)",
        q[0]
    );
    assert!((q[1] + 2.0 * q[2] - 1.0).abs() < 1e-12);
    // Every accepted step of an indefinite reduced Hessian was shifted.
    assert!(report.regularizations.iter().any(|&mu| mu > 0.0));
}

/// Implicit differentiation: at the minimizer, `sensitivities` solves the KKT system for each
/// right-hand side, as the dense KKT matrix does; at a saddle it refuses.
#[test]
fn sensitivities_solve_the_kkt_system_and_refuse_a_saddle() {
    let mut rng = Rng::new(7);
    let q = spd_quadratic(3, 24);
    let (n, m) = (q.n, 4);
    let (triplets, d) = random_constraints(&mut rng, n, m, 3);
    let constraints = LinearConstraints::new(n, &triplets, &d).unwrap();
    let mut x = vec![0.0; n];
    let mut solver = ConstrainedNewtonSolver::new(&q, &constraints).unwrap();
    solver
        .minimize(&q, &mut x, &NewtonSettings::default())
        .unwrap();
    let (h, _) = q.dense(&x);
    let kkt = dense_kkt(&h, &triplets, m);
    let rhs: Vec<Vec<f64>> = (0..2)
        .map(|_| (0..n).map(|_| rng.range(-1.0, 1.0)).collect())
        .collect();
    let got = solver.sensitivities(&q, &x, &rhs).unwrap();
    for (b, y) in rhs.iter().zip(&got) {
        let full: Vec<f64> = b.iter().copied().chain(vec![0.0; m]).collect();
        let reference = dense_solve(&kkt, &full);
        assert_close(y, &reference[..n], 1e-10, "dx");
    }
    // `Saddle` at its stationary point (0, 1, −1), where H_xx = −2: no sensitivities.
    let none = LinearConstraints::new(3, &[], &[]).unwrap();
    let mut s = ConstrainedNewtonSolver::new(&Saddle, &none).unwrap();
    let e = s
        .sensitivities(&Saddle, &[0.0, 1.0, -1.0], &[vec![1.0, 0.0, 0.0]])
        .unwrap_err();
    assert!(matches!(e, SolveError::NotAStrictMinimum(_)), "{e}");
}
