//! Fixed-pattern assembly against dense references.

mod common;

use common::{LinearChain, Quadratic, Rng, SpringNet, assert_close, to_dense};
use proptest::prelude::*;
use solver::{Assembler, Problem, SolveError};

/// Three springs k = 1, 2, 3 N/m on a line, assembled by hand.
#[test]
fn spring_chain_matches_hand_assembled_dense_reference() {
    let chain = LinearChain {
        edges: vec![[0, 1], [1, 2], [2, 3]],
        k: vec![1.0, 2.0, 3.0],
        rest: vec![0.5, 0.5, 0.5],
    };
    let x = [0.0, 1.0, 1.25, 2.0];
    // Extensions: 0.5, -0.25, 0.25 → forces k·s: 0.5, -0.5, 0.75.
    let energy_ref = 0.5 * (1.0 * 0.25 + 2.0 * 0.0625 + 3.0 * 0.0625);
    let grad_ref = [-0.5, 0.5 + 0.5, -0.5 - 0.75, 0.75];
    let hess_ref = [
        [1.0, -1.0, 0.0, 0.0],
        [-1.0, 3.0, -2.0, 0.0],
        [0.0, -2.0, 5.0, -3.0],
        [0.0, 0.0, -3.0, 3.0],
    ];

    let mut asm = Assembler::new(&chain).unwrap();
    let out = asm.assemble(&chain, &x, false).unwrap();
    assert!((out.energy - energy_ref).abs() < 1e-15);
    assert_close(out.gradient, &grad_ref, 1e-15, "gradient");
    let dense = to_dense(out.hessian);
    for i in 0..4 {
        for j in 0..4 {
            // Lower triangle stored, upper triangle empty.
            let expected = if i >= j { hess_ref[i][j] } else { 0.0 };
            assert_eq!(dense[i][j], expected, "H[{i}][{j}]");
        }
    }
    // Pattern: lower triangle of the tridiagonal matrix, diagonal included.
    assert_eq!(out.hessian.symbolic().col_ptr(), &[0, 2, 4, 6, 7]);
    assert_eq!(out.hessian.symbolic().row_idx(), &[0, 1, 1, 2, 2, 3, 3]);
}

/// Dirichlet DOFs 0 and 3 of the same chain: the Hessian is the free–free block, renumbered.
#[test]
fn fixed_dofs_give_the_free_block() {
    let chain = LinearChain::uniform(4, 2.0, 1.0);
    let fixed = [true, false, false, true];
    let mut asm = Assembler::with_fixed_dofs(&chain, &fixed).unwrap();
    assert_eq!(asm.n_free(), 2);
    assert_eq!(
        (asm.free_index(0), asm.free_index(1), asm.free_index(2)),
        (None, Some(0), Some(1))
    );
    let x = [0.0, 0.5, 2.5, 3.0];
    let out = asm.assemble(&chain, &x, false).unwrap();
    assert_eq!(to_dense(out.hessian), vec![vec![4.0, 0.0], vec![-2.0, 4.0]]);
    // The gradient keeps all DOFs (reaction forces at the fixed ones).
    assert_close(out.gradient, &[1.0, -3.0, 3.0, -1.0], 1e-15, "gradient");
}

/// A 3D nonlinear spring network against a dense accumulation of the same stencils, plus the
/// energy-only and gradient-only paths.
#[test]
fn spring_net_matches_dense_accumulation() {
    let mut rng = Rng::new(7);
    let n_points = 12;
    let pairs: Vec<(usize, usize)> = (0..30)
        .map(|_| {
            let a = rng.index(n_points);
            (a, (a + 1 + rng.index(n_points - 1)) % n_points)
        })
        .collect();
    let rest = (0..pairs.len()).map(|_| rng.range(0.5, 1.5)).collect();
    let net = SpringNet::new(n_points, 3.0, &pairs, rest, [0.0, 0.0, -9.81]);
    let x: Vec<f64> = (0..net.n_dofs()).map(|_| rng.range(-1.0, 1.0)).collect();

    let n = net.n_dofs();
    let (mut h_ref, mut g_ref, mut e_ref) = (vec![vec![0.0; n]; n], vec![0.0; n], 0.0);
    for s in 0..net.n_stencils() {
        let dofs = net.stencil_dofs(s);
        let m = dofs.len();
        let (mut g, mut h) = (vec![0.0; m], vec![0.0; m * m]);
        e_ref += net.eval_stencil(s, &x, &mut g, Some(&mut h));
        for a in 0..m {
            g_ref[dofs[a]] += g[a];
            for b in 0..m {
                h_ref[dofs[a]][dofs[b]] += h[a + m * b];
            }
        }
    }

    let mut asm = Assembler::new(&net).unwrap();
    let out = asm.assemble(&net, &x, false).unwrap();
    assert!((out.energy - e_ref).abs() <= 1e-12 * e_ref.abs());
    assert_close(out.gradient, &g_ref, 1e-12, "gradient");
    let dense = to_dense(out.hessian);
    for i in 0..n {
        for j in 0..=i {
            assert!((dense[i][j] - h_ref[i][j]).abs() <= 1e-12, "H[{i}][{j}]");
        }
    }
    let energy = asm.energy(&net, &x).unwrap();
    assert!((energy - e_ref).abs() <= 1e-12 * e_ref.abs());
    let (e2, g2) = asm.gradient(&net, &x).unwrap();
    assert!((e2 - e_ref).abs() <= 1e-12 * e_ref.abs());
    assert_close(g2, &g_ref, 1e-12, "gradient-only path");
}

/// With projection, every assembled Hessian is PSD even where springs are compressed.
#[test]
fn projected_hessian_is_positive_semidefinite() {
    let mut rng = Rng::new(11);
    let n_points = 8;
    let pairs: Vec<(usize, usize)> = (0..n_points - 1).map(|i| (i, i + 1)).collect();
    // Rest lengths far above the actual distances: every spring compressed, exact Hessian
    // indefinite.
    let rest = vec![5.0; pairs.len()];
    let net = SpringNet::new(n_points, 1.0, &pairs, rest, [0.0; 3]);
    let x: Vec<f64> = (0..net.n_dofs()).map(|_| rng.range(-0.5, 0.5)).collect();
    let mut asm = Assembler::new(&net).unwrap();
    let min_eig = |asm: &mut Assembler, project: bool| {
        let dense = to_dense(asm.assemble(&net, &x, project).unwrap().hessian);
        let n = dense.len();
        let full =
            nalgebra::DMatrix::from_fn(n, n, |i, j| if i >= j { dense[i][j] } else { dense[j][i] });
        full.symmetric_eigenvalues().min()
    };
    assert!(min_eig(&mut asm, false) < -1.0);
    assert!(min_eig(&mut asm, true) > -1e-12);
}

#[test]
fn bad_inputs_are_errors() {
    let chain = LinearChain::uniform(4, 1.0, 1.0);
    let mut asm = Assembler::new(&chain).unwrap();
    assert!(matches!(
        asm.assemble(&chain, &[0.0; 3], false),
        Err(SolveError::DimensionMismatch {
            expected: 4,
            got: 3,
            ..
        })
    ));
    assert!(matches!(
        Assembler::with_fixed_dofs(&chain, &[false; 5]),
        Err(SolveError::DimensionMismatch { .. })
    ));
    // A problem whose stencils differ from the pattern's.
    let other = LinearChain {
        edges: vec![[0, 1], [1, 3], [2, 3]],
        k: vec![1.0; 3],
        rest: vec![1.0; 3],
    };
    assert!(matches!(
        asm.energy(&other, &[0.0; 4]),
        Err(SolveError::PatternChanged(_))
    ));
    let longer = LinearChain::uniform(5, 1.0, 1.0);
    assert!(matches!(
        asm.assemble(&longer, &[0.0; 5], false),
        Err(SolveError::DimensionMismatch { .. })
    ));
    // A stencil referencing a DOF that does not exist.
    let broken = LinearChain {
        edges: vec![[0, 1], [1, 7]],
        k: vec![1.0; 2],
        rest: vec![1.0; 2],
    };
    struct Wrong(LinearChain);
    impl Problem for Wrong {
        fn n_dofs(&self) -> usize {
            3
        }
        fn n_stencils(&self) -> usize {
            self.0.n_stencils()
        }
        fn stencil_dofs(&self, k: usize) -> &[usize] {
            self.0.stencil_dofs(k)
        }
        fn eval_stencil(&self, k: usize, x: &[f64], g: &mut [f64], h: Option<&mut [f64]>) -> f64 {
            self.0.eval_stencil(k, x, g, h)
        }
    }
    assert!(matches!(
        Assembler::new(&Wrong(broken)),
        Err(SolveError::InvalidProblem(_))
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random stencil structures (repeated DOFs, random sizes, random Dirichlet masks):
    /// the assembled free–free lower triangle and gradient equal the dense reference.
    #[test]
    fn random_quadratics_match_dense_reference(seed in any::<u64>(), n in 1usize..12, n_stencils in 0usize..20) {
        let mut rng = Rng::new(seed);
        let q = Quadratic::random(&mut rng, n, n_stencils, 5, 0.0);
        let fixed: Vec<bool> = (0..n).map(|_| rng.uniform() < 0.3).collect();
        let x: Vec<f64> = (0..n).map(|_| rng.range(-2.0, 2.0)).collect();
        let (h_ref, g_ref) = q.dense(&x);
        let mut asm = Assembler::with_fixed_dofs(&q, &fixed).unwrap();
        let out = asm.assemble(&q, &x, false).unwrap();
        assert_close(out.gradient, &g_ref, 1e-12, "gradient");
        let free: Vec<usize> = (0..n).filter(|&i| !fixed[i]).collect();
        let dense = to_dense(out.hessian);
        prop_assert_eq!(dense.len(), free.len());
        for (fi, &i) in free.iter().enumerate() {
            for (fj, &j) in free.iter().enumerate() {
                let expected = if fi >= fj { h_ref[i][j] } else { 0.0 };
                prop_assert!((dense[fi][fj] - expected).abs() <= 1e-12, "H[{}][{}]", fi, fj);
            }
        }
    }
}

/// Projection is limited to stencils of at most 32 DOFs: larger ones are an error, not a panic.
#[test]
fn oversized_stencil_with_projection_is_an_error() {
    let mut rng = Rng::new(1);
    let mut q = Quadratic::random(&mut rng, 40, 0, 1, 0.0);
    q.dofs.push((0..33).collect());
    q.a.push(
        (0..33 * 33)
            .map(|i| if i % 34 == 0 { 1.0 } else { 0.0 })
            .collect(),
    );
    q.b.push(vec![0.0; 33]);
    let mut asm = Assembler::new(&q).unwrap();
    let x = vec![0.0; 40];
    assert!(asm.assemble(&q, &x, false).is_ok());
    assert!(matches!(
        asm.assemble(&q, &x, true),
        Err(SolveError::InvalidProblem(_))
    ));
}

/// Degenerate sizes: no DOFs, no stencils.
#[test]
fn empty_problems_are_handled() {
    let empty = Quadratic {
        n: 0,
        dofs: vec![],
        a: vec![],
        b: vec![],
    };
    let mut asm = Assembler::new(&empty).unwrap();
    let out = asm.assemble(&empty, &[], true).unwrap();
    assert_eq!(
        (out.energy, out.gradient.len(), out.hessian.nrows()),
        (0.0, 0, 0)
    );
    let mut x: Vec<f64> = vec![];
    let settings = solver::NewtonSettings::default();
    assert_eq!(
        solver::minimize(&empty, &mut x, &[], &settings)
            .unwrap()
            .iterations,
        0
    );
    let none = solver::LinearConstraints::new(0, &[], &[]).unwrap();
    assert!(
        solver::minimize_constrained(&empty, &mut x, &none, &settings)
            .unwrap()
            .converged()
    );
    // DOFs but no stencils: zero energy, zero (singular) Hessian, already stationary.
    let idle = Quadratic {
        n: 3,
        dofs: vec![],
        a: vec![],
        b: vec![],
    };
    let mut x = vec![1.0, 2.0, 3.0];
    let report = solver::minimize(&idle, &mut x, &[false; 3], &settings).unwrap();
    assert_eq!((report.iterations, x), (0, vec![1.0, 2.0, 3.0]));
}
