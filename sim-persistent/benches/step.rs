//! One implicit (backward Euler) step of a hanging knit swatch against its size, with the
//! throughput in DoF-steps (criterion `Throughput::Elements(n_dofs)`; issue 6's benchmark,
//! the paper's reference is ≈ 0.38 M DoF-steps/s at 1.1 M DoFs).
//!
//! `cargo bench -p sim-persistent --bench step` (add `-- --quick` for a short run). Setup (not
//! timed): a garter or stockinette swatch of the Table 1 sweater yarn (loop width 3 mm),
//! Rayleigh α = 10 /s, β = 0.01 s, every implemented force term, gravity, the bind-off edge
//! pinned, dt = 1 ms, and one warm-up step (which builds the sparsity pattern and the
//! symbolic factorization). One iteration is one further step of the same, evolving, swatch.
//! `examples/scaling.rs` covers larger sizes (≥ 1e5 DoFs) and splits a step into its
//! phases; sizes here stop at 48 × 48 (≈ 3 s a step) to keep a full run short. Besides the
//! default step (full Newton, sparse Cholesky) the 32 × 32 garter is also timed with
//! linearized implicit Euler and IC(0)-preconditioned CG (`garter-linear-ic`), the same with
//! every CG solve started from the previous step's solution (`garter-linear-ic-guess`,
//! `StepSettings::warm_started_cg`) and with
//! linearized implicit Euler, Cholesky and Rayleigh-β matrices refreshed every 10 steps
//! (`garter-linear-chol-lag`).

#![allow(missing_docs)] // criterion_group! generates undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_boundary_nodes};
use solver::{LinearSolver, PcgSettings, Preconditioner};
use std::time::Duration;

/// A `chart` swatch hanging from its pinned bind-off edge, after one warm-up step, with
/// `adjust` applied to the step settings.
fn hanging(chart: &Chart, adjust: fn(StepSettings) -> StepSettings) -> Simulator {
    let (w, h) = (chart.width(), chart.height());
    let params = YarnParams::sweater();
    let topo = Topology::knit(chart);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).expect("layout");
    let settings = adjust(StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    });
    let mut sim =
        Simulator::new(topo, &layout, params, ForceSet::default(), settings).expect("simulator");
    let pins: Vec<usize> = knit_boundary_nodes(w, h);
    sim.pin_nodes(&pins).expect("pins");
    sim.step().expect("warm-up step");
    sim
}

/// Linearized implicit Euler with IC(0)-preconditioned CG at relative tolerance 1e-6.
fn linear_ic(s: StepSettings) -> StepSettings {
    let mut s = s.linearized_implicit_euler();
    s.newton.linear_solver = LinearSolver::ConjugateGradient(PcgSettings::new(
        1e-6,
        20_000,
        Preconditioner::IncompleteCholesky,
    ));
    s
}

/// [`linear_ic`] with every CG solve started from the previous step's solution.
fn linear_ic_guess(s: StepSettings) -> StepSettings {
    linear_ic(s).warm_started_cg()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("implicit step, dt = 1 ms");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(3));
    let default: fn(StepSettings) -> StepSettings = |s| s;
    let linear_chol_lag: fn(StepSettings) -> StepSettings = |s| StepSettings {
        damping_refresh_steps: 10,
        ..s.linearized_implicit_euler()
    };
    for (pattern, n, adjust) in [
        ("garter", 8, default),
        ("garter", 16, default),
        ("garter", 32, default),
        ("garter", 48, default),
        ("stockinette", 16, default),
        ("stockinette", 32, default),
        ("garter-linear-ic", 32, linear_ic),
        ("garter-linear-ic-guess", 32, linear_ic_guess),
        ("garter-linear-chol-lag", 32, linear_chol_lag),
    ] {
        let chart = match pattern {
            "stockinette" => Chart::stockinette(n, n),
            _ => Chart::garter(n, n),
        }
        .expect("valid size");
        let mut sim = hanging(&chart, adjust);
        let n_dofs = sim.dofs().n_dofs();
        group.throughput(Throughput::Elements(n_dofs as u64));
        group.bench_function(
            BenchmarkId::new(pattern, format!("{n}x{n} ({n_dofs} DoFs)")),
            |b| b.iter(|| sim.step().expect("step converges")),
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
