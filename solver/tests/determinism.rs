//! Results must not depend on the rayon thread count: bit-identical assembly and solves in
//! 1- and 2-thread pools.

mod common;

use common::{Rng, SpringNet, hanging_net};
use solver::{Assembler, NewtonSettings, Problem, minimize};

/// A random spring network of `n_points` points, a chain through all of them plus `extra`
/// random springs, random positions and rest lengths.
fn random_net_of(n_points: usize, extra: usize, seed: u64) -> (SpringNet, Vec<f64>) {
    let mut rng = Rng::new(seed);
    let mut pairs: Vec<(usize, usize)> = (0..n_points - 1).map(|i| (i, i + 1)).collect();
    for _ in 0..extra {
        let a = rng.index(n_points);
        pairs.push((a, (a + 1 + rng.index(n_points - 1)) % n_points));
    }
    let rest = (0..pairs.len()).map(|_| rng.range(0.2, 1.0)).collect();
    let net = SpringNet::new(n_points, 7.0, &pairs, rest, [0.1, -0.2, -9.81]);
    let x = (0..net.n_dofs()).map(|_| rng.range(-1.0, 1.0)).collect();
    (net, x)
}

/// A random spring network: 700 points, a chain through all of them plus 1800 random springs,
/// random positions and rest lengths (many springs compressed, so projection matters).
fn random_net() -> (SpringNet, Vec<f64>) {
    random_net_of(700, 1800, 0x5eed)
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// (energy, gradient, CSC values, energy-only result) as bit patterns, assembled in a pool of
/// `threads` threads.
fn assemble_in_pool(threads: usize, project: bool) -> (u64, Vec<u64>, Vec<u64>, u64) {
    let (net, x) = random_net();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut asm = Assembler::new(&net).unwrap();
        let out = asm.assemble(&net, &x, project).unwrap();
        let result = (
            out.energy.to_bits(),
            bits(out.gradient),
            bits(out.hessian.val()),
        );
        let energy_only = asm.energy(&net, &x).unwrap().to_bits();
        (result.0, result.1, result.2, energy_only)
    })
}

#[test]
fn assembly_is_bit_identical_for_one_and_two_threads() {
    let (net, _) = random_net();
    assert!(net.n_stencils() >= 2000, "{} stencils", net.n_stencils());
    for project in [false, true] {
        let one = assemble_in_pool(1, project);
        let two = assemble_in_pool(2, project);
        assert_eq!(one.0, two.0, "energy (project = {project})");
        assert_eq!(one.1, two.1, "gradient (project = {project})");
        assert_eq!(one.2, two.2, "Hessian values (project = {project})");
        assert_eq!(one.3, two.3, "energy-only path (project = {project})");
        // And the energy-only path agrees with the full assembly.
        assert_eq!(one.0, one.3);
    }
}

#[test]
fn newton_solve_is_bit_identical_for_one_and_two_threads() {
    let run = |threads: usize| {
        let (net, x0, fixed) = hanging_net(12, 10);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut x = x0.clone();
            let report = minimize(&net, &mut x, &fixed, &NewtonSettings::default()).unwrap();
            (
                bits(&x),
                bits(&report.energy_history),
                bits(&report.residual_history),
            )
        })
    };
    assert_eq!(run(1), run(2));
}

/// The parallel gather adds every gradient entry's and every Hessian value's local pieces in
/// stencil order: bit for bit what a serial scatter in stencil order gives, on a network large
/// enough for many evaluation and gather chunks (6000 DOFs; 7999 springs and 2000 load
/// stencils; projected).
#[test]
fn assembly_equals_a_serial_scatter_in_stencil_order_bit_for_bit() {
    let (net, x) = random_net_of(2000, 6000, 0xfeed);
    let n = net.n_dofs();
    assert_eq!((n, net.n_stencils()), (6000, 9999));
    let mut asm = Assembler::new(&net).unwrap();
    let out = asm.assemble(&net, &x, true).unwrap();
    let (col_ptr, row_idx) = (out.hessian.col_ptr(), out.hessian.row_idx());
    let mut gradient = vec![0.0; n];
    let mut values = vec![0.0; row_idx.len()];
    let mut energy = 0.0;
    for k in 0..net.n_stencils() {
        let dofs = net.stencil_dofs(k);
        let m = dofs.len();
        let (mut g, mut h) = (vec![0.0; m], vec![0.0; m * m]);
        energy += net.eval_stencil(k, &x, &mut g, Some(&mut h));
        rod::spd::project_spd(&mut h, m);
        for (a, &d) in dofs.iter().enumerate() {
            gradient[d] += g[a];
        }
        for (b, &col) in dofs.iter().enumerate() {
            for (a, &row) in dofs.iter().enumerate() {
                if row >= col {
                    let column = &row_idx[col_ptr[col]..col_ptr[col + 1]];
                    let e = col_ptr[col] + column.binary_search(&row).unwrap();
                    values[e] += h[a + m * b];
                }
            }
        }
    }
    assert_eq!(out.energy.to_bits(), energy.to_bits());
    assert_eq!(bits(out.gradient), bits(&gradient));
    assert_eq!(bits(out.hessian.val()), bits(&values));
}
