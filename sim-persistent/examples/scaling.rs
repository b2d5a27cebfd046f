//! Throughput of one implicit step against swatch size (issue 6: "benchmark of DoF-steps per
//! second vs swatch size"; the paper ran 1.1 M DoFs at 96 s per frame of 33 steps,
//! ≈ 0.38 M DoF-steps/s).
//!
//! `cargo run --release -p sim-persistent --example scaling [-- BUDGET_SECONDS]`
//!
//! For square garter swatches of growing size (Table 1 sweater yarn, loop width 3 mm,
//! Rayleigh α = 10 /s, β = 0.01 s, every implemented force term, gravity, bind-off edge
//! pinned, dt = 1 ms) it builds the simulator, takes one warm-up step (which also builds the
//! sparsity pattern and the symbolic Cholesky factorization) and then times
//! [`MEASURED_STEPS`] steps. Printed per size: DoFs (all coordinates, pinned ones included,
//! as the paper counts them), mean wall time per step, mean Newton iterations per step,
//! DoF-steps per second, and the split of a step into
//!
//! - `setup`: the per-step preparation in the integrator (lagged mass matrices, Rayleigh
//!   damping forms with their per-stencil PSD projection, rest-angle ramp), measured
//!   ([`StepReport::setup_seconds`]);
//! - `asm`: assembly inside Newton, *modelled* as `(iterations + 1) × t_assemble +
//!   (energy evaluations) × t_energy`, with `t_assemble` and `t_energy` timed separately on
//!   the same step potential after the run ([`Simulator::step_potential`] with a fresh
//!   [`solver::Assembler`]) and the energy evaluations counted from the Newton report
//!   (one per line-search trial);
//! - `solve`: the rest of the Newton time ([`StepReport::newton_seconds`] − `asm`): sparse
//!   Cholesky factorizations and triangular solves plus vector updates.
//!
//! Sizes grow until the next one would not fit in the time budget (default 120 s in all);
//! the peak resident memory is printed at the end. The machine this was written for has
//! 2 cores shared with other jobs, so the numbers are noisy (± tens of percent).

use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepReport, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Side, Topology, knit_node};
use std::time::Instant;

/// Timed steps per size (after one warm-up step).
const MEASURED_STEPS: usize = 3;

/// Square swatch sizes (stitches per side) to try, in order (≈ 20 n² DoFs: 72 → 1.0e5,
/// 224 → 1.0e6).
const SIDES: [usize; 9] = [8, 16, 32, 48, 72, 100, 144, 224, 320];

/// A hanging garter swatch of `n × n` stitches with its bind-off edge pinned, Rayleigh
/// α = 10 /s and β = `beta` (s).
fn hanging_garter(n: usize, beta: f64) -> Simulator {
    let chart = Chart::garter(n, n).expect("valid size");
    let params = YarnParams::sweater();
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).expect("layout");
    let settings = StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: beta,
        ..StepSettings::default()
    };
    let mut sim =
        Simulator::new(topo, &layout, params, ForceSet::default(), settings).expect("simulator");
    let pins: Vec<usize> = (0..n)
        .flat_map(|c| {
            [Side::Left, Side::Right]
                .into_iter()
                .flat_map(move |s| [knit_node(n, n, c, s, false), knit_node(n, n, c, s, true)])
        })
        .collect();
    sim.pin_nodes(&pins).expect("pins");
    sim
}

/// Peak resident set size (MiB) from `/proc/self/status`, if available.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Median wall time (s) of `f` over `reps` calls.
fn median_time(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

/// Builds, warms up and times the `n × n` swatch with Rayleigh `beta` (s); prints its row
/// and returns its DoF count.
fn measure(n: usize, beta: f64) -> usize {
    let size_start = Instant::now();
    let mut sim = hanging_garter(n, beta);
    let build = size_start.elapsed().as_secs_f64();
    let n_dofs = sim.dofs().n_dofs();
    let n_free = sim.fixed().iter().filter(|f| !**f).count();
    let warm_start = Instant::now();
    sim.step().expect("warm-up step");
    let warmup = warm_start.elapsed().as_secs_f64();
    let mut reports: Vec<StepReport> = Vec::new();
    let run_start = Instant::now();
    for _ in 0..MEASURED_STEPS {
        reports.push(sim.step().expect("step converges"));
    }
    let per_step = run_start.elapsed().as_secs_f64() / MEASURED_STEPS as f64;
    let mean =
        |f: &dyn Fn(&StepReport) -> f64| reports.iter().map(f).sum::<f64>() / MEASURED_STEPS as f64;
    let iterations = mean(&|r| r.newton_iterations as f64);
    let setup = mean(&|r| r.setup_seconds);
    let newton = mean(&|r| r.newton_seconds);
    let energy_evals = mean(&|r| {
        r.last_newton
            .as_ref()
            .map_or(0.0, |nr| (nr.iterations + nr.line_search_backtracks) as f64)
    });
    let substeps = mean(&|r| r.substeps as f64);

    // Probe: one full assembly and one energy evaluation of the step potential.
    let potential = sim.step_potential();
    let mut asm = solver::Assembler::with_fixed_dofs(potential, sim.fixed()).expect("assembler");
    let q = sim.state().q.clone();
    let t_assemble = median_time(3, || {
        asm.assemble(potential, &q, false).expect("assembles");
    });
    let t_energy = median_time(3, || {
        asm.energy(potential, &q).expect("energy");
    });
    let assembly = (iterations + substeps) * t_assemble + energy_evals * t_energy;
    let solve = (newton - assembly).max(0.0);
    let pct = |x: f64| 100.0 * x / per_step;
    println!(
        "{n:>5} {n_dofs:>9} {n_free:>8} {build:>9.2} {:>10.2} {iterations:>6.1} {:>8.0} \
         {:>8.0} {:>8.0} {warmup:>9.2} {:>12.3e}",
        1e3 * per_step,
        pct(setup),
        pct(assembly),
        pct(solve),
        n_dofs as f64 / per_step
    );
    if substeps > 1.0 {
        println!("      (steps were halved: {substeps:.1} substeps per step on average)");
    }
    n_dofs
}

fn main() {
    let budget: f64 = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("BUDGET_SECONDS must be a number"))
        .unwrap_or(120.0);
    let threads = rayon::current_num_threads();
    println!(
        "scaling: hanging garter n × n, sweater yarn, dt = 1 ms, α = 10, β = 0.01, all terms; \
         {threads} rayon threads; budget {budget:.0} s"
    );
    println!(
        "{:>5} {:>9} {:>8} {:>9} {:>10} {:>6} {:>8} {:>8} {:>8} {:>9} {:>12}",
        "n",
        "DoFs",
        "free",
        "build s",
        "ms/step",
        "iters",
        "setup%",
        "asm%",
        "solve%",
        "warmup s",
        "DoF-steps/s"
    );
    let start = Instant::now();
    // Seconds per DoF of the whole per-size run, to predict the next size.
    let mut cost_per_dof: Option<f64> = None;
    let mut reached = 0;
    for n in SIDES {
        // Every size is ≈ 20 n² DoFs; assume slightly superlinear cost (×1.3 margin).
        let predicted_dofs = 20.0 * (n * n) as f64;
        if let Some(c) = cost_per_dof {
            let remaining = budget - start.elapsed().as_secs_f64();
            let predicted = 1.3 * c * predicted_dofs;
            if predicted > remaining {
                println!(
                    "stop before n = {n} (≈ {predicted_dofs:.2e} DoFs): predicted {predicted:.0} s \
                     > {remaining:.0} s left of the budget"
                );
                break;
            }
        }
        let size_start = Instant::now();
        let n_dofs = measure(n, 0.01);
        reached = n_dofs;
        cost_per_dof = Some(size_start.elapsed().as_secs_f64() / n_dofs as f64);
    }
    // The integrator's per-step setup is dominated by the Rayleigh β damping forms (a PSD
    // projection per elastic stencil): the same mid-size swatch without them.
    if budget - start.elapsed().as_secs_f64() > 20.0 {
        println!("without stiffness damping (β = 0, α = 10 /s), same columns:");
        measure(32, 0.0);
    }
    println!(
        "largest size: {reached} DoFs; total {:.1} s; peak RSS {}",
        start.elapsed().as_secs_f64(),
        peak_rss_mib().map_or("unknown".into(), |m| format!("{m:.0} MiB"))
    );
    println!("paper (Cirio et al. 2017): 1.1 M DoFs, 96 s per 33-step frame ≈ 3.8e5 DoF-steps/s");
}
