//! Throughput of one implicit step against swatch size and linear solver (issue 6: "benchmark
//! of DoF-steps per second vs swatch size", "faer factorization or preconditioned CG —
//! measure which wins at scale"; the paper ran 1.1 M DoFs at 96 s per frame of 33 steps,
//! ≈ 0.38 M DoF-steps/s, quad-core CPU + K40 GPU, linearized implicit Euler with GPU CG).
//!
//! ```text
//! cargo run --release -p sim-persistent --example scaling -- \
//!     [--scene garter|sweater] [--sides 8,16,32,72,100,144,224] \
//!     [--configs newton-chol,linear-pcg,...] [--steps 3] [--max-chol-dofs 250000] [--budget 600]
//! ```
//!
//! `--scene sweater` times a garment instead (issue 18): a sweater body knitted in the round
//! (`sim_persistent::experiment::garment::sweater_chart`, 8 sectors of `n` loops around)
//! dressed on a mannequin mesh, from its dressed layout (the wrapping ramp contracts it onto
//! the body); `n = 40` is ≈ 51 K loops and ≈ 1 M DoFs, the paper's sweater (56 K loops,
//! 1.1 M DoFs).
//!
//! For square garter swatches of `n × n` stitches (Table 1 sweater yarn, loop width 3 mm,
//! Rayleigh α = 10 /s, β = 0.01 s, every implemented force term, gravity, bind-off edge
//! pinned, dt = 1 ms) and every configuration it builds the simulator, takes one warm-up
//! step (which also builds the sparsity pattern and the symbolic factorization or the CG
//! workspace) and times `--steps` further steps. Configurations:
//!
//! - `newton-chol`: backward Euler as a full Newton minimization per step (the default
//!   [`StepSettings`]), sparse Cholesky (faer, AMD, supernodal);
//! - `newton-jacobi`, `newton-ic`: the same with preconditioned CG (Jacobi or IC(0),
//!   relative tolerance 1e-8);
//! - `linear-chol`, `linear-jacobi`, `linear-ic`: linearized implicit Euler
//!   ([`StepSettings::linearized_implicit_euler`]: one damped Newton iteration),
//!   Cholesky or CG (relative tolerance 1e-6);
//! - `linear-chol-lag`, `linear-ic-lag`: the same with the Rayleigh-β matrices refreshed
//!   every 10 steps ([`StepSettings::damping_refresh_steps`]);
//! - `newton-chol-warm`, `linear-ic-lag-3-warm`: `newton-chol` and `linear-ic-lag-3` with the
//!   Newton shift carried from step to step (`NewtonSettings::warm_start_regularization`:
//!   where the step's Hessian is indefinite, as in the dressed sweater, the escalation of
//!   the diagonal shift starts one factor below the last step's instead of from 1e-8);
//! - `linear-ic-lag-3-carry`: `linear-ic-lag-3-warm` whose steps start at the carried shift
//!   between probes every 10th Newton run, here every 10th step
//!   (`NewtonSettings::carried_shift_probe_interval`): faster
//!   where the needed shift stays put, as on the sweater, but not a default, because where it
//!   varies the steps take far larger shifts than needed and lose accuracy (measured in
//!   [`StepSettings::linearized_implicit_euler`]'s documentation);
//! - `linear-ic-lag-3-warm-guess`: `linear-ic-lag-3-warm` with every CG solve started from
//!   the previous step's solution instead of zero
//!   ([`StepSettings::warm_started_cg`]);
//! - `linear-ic-lag-3-warm-lean`: `linear-ic-lag-3-warm` without the gradient evaluation
//!   after each step that only reports its residual (`solver::NewtonSettings::final_residual`
//!   `= false`): the same steps bit for bit (the same `state` fingerprint), one gradient
//!   evaluation fewer per step, no `res/res0` (printed as `NaN`);
//! - `linear-ic-lag-3`, `linear-ic-lag-2`: `linear-ic-lag` with a CG tolerance of 1e-3 and
//!   1e-2 (the linearization itself leaves ≈ 10–15 % of the step's initial residual, see the
//!   `res/res0` column, and it is the same at all three tolerances).
//!
//! Printed per size and configuration: DoFs (all coordinates, pinned ones included, as the
//! paper counts them), mean wall time per step and its split into setup (integrator:
//! inertia and damping forms, friction limits), assembly, linear solve and line search
//! (measured inside Newton, [`solver::NewtonTimings`]), Newton iterations, linear solves of
//! the last substep (failed attempts at too small a diagonal shift included; shifts that a
//! known direction of negative curvature rejects without a solve not, see
//! `solver::NewtonReport::shifts_skipped`) and CG iterations of the accepted solves per step,
//! the gradient residual after the step relative to its value at `qₙ` (the linearization
//! error of the linearized steps; below 1e-9 for converged Newton), DoF-steps per second,
//! the peak resident memory of the size (`VmHWM`, reset per size through
//! `/proc/self/clear_refs`) and a fingerprint of the final state (a hash of the bits of `q`
//! and `v`: a change meant to leave the steps bit for bit the same must leave it
//! unchanged). Cholesky runs are skipped above `--max-chol-dofs` (the factor's memory grows
//! superlinearly). The machine this was written for has 2 cores shared with
//! other jobs, so the numbers are noisy (± tens of percent).
//!
//! **Roofline.** The run starts by measuring the machine's memory bandwidth (STREAM triad on
//! one thread and on every rayon thread). Under every IC-CG row it prints the memory roofline
//! of that row's linear solves: the bytes that the CG iterations (of the accepted solves, as
//! the `CG its` column counts them) and IC(0) factorizations (one per linear solve, the
//! `solves` column) of a step must stream at least ([`solver::PcgTraffic`], for the step's own pattern, rebuilt after
//! the timed steps), the time they take at the measured bandwidths (the triangular solves and
//! the factorization at one thread's, the rest at all threads'), the measured solve time as a
//! multiple of it, and the DoF-steps per second that this bound alone allows. Measured on the
//! dressed sweater on 2026-11-29 (16.4 stored lower entries per unknown), `linear-ic-lag-3-warm-lean`:
//!
//! | DoFs | bandwidth, 1 / 2 threads | CG iterations per step | roofline of the solve | measured solve | cap |
//! |---|---|---|---|---|---|
//! | 92 352 (5 steps) | 14.1 / 19.7 GB/s | 17 | 101 ms | 323 ms (3.2×) | 9.1e5 DoF-steps/s |
//! | 251 392 (5 steps) | 14.1 / 19.7 GB/s | 17 | 277 ms | 975 ms (3.5×) | 9.1e5 DoF-steps/s |
//! | 998 144 (10 steps) | 11.1 / 14.8 GB/s | 33 | 2.64 s | 5.48 s (2.1×) | 3.8e5 DoF-steps/s |
//! | 998 144 (10 steps, a second run) | 10.9 / 15.2 GB/s | 33 | 2.63 s | 5.17 s (2.0×) | 3.8e5 DoF-steps/s |
//!
//! So with IC-CG at these iteration counts a 2-core machine cannot reach 1e6 DoF-steps/s at
//! 1 M DoFs, however fast the code: the solve's memory traffic alone takes 2.6 s per step
//! there. Reaching it needs fewer bytes per step (fewer CG iterations, a smaller matrix), not
//! faster loops. The measured solves take 2–3.5× their roofline; the triangular solves are
//! bound by the latency of their scattered updates rather than by bandwidth (a factor stored
//! in `f32` was no faster).

use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{
    CARRIED_SHIFT_PROBE_INTERVAL, Simulator, StepReport, StepSettings,
};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_boundary_nodes};
use solver::{LinearSolver, PcgSettings, PcgTraffic, Preconditioner};
use std::time::Instant;

/// A step configuration of the benchmark.
#[derive(Clone, Copy, Debug)]
struct Config {
    name: &'static str,
    linearized: bool,
    /// CG (relative tolerance, preconditioner); `None`: sparse Cholesky.
    pcg: Option<(f64, Preconditioner)>,
    damping_refresh_steps: usize,
    /// Carry the Newton shift from step to step (`NewtonSettings::warm_start_regularization`).
    warm: bool,
}

const JACOBI: Preconditioner = Preconditioner::Jacobi;
const IC0: Preconditioner = Preconditioner::IncompleteCholesky;

const CONFIGS: [Config; 15] = [
    Config {
        name: "newton-chol",
        linearized: false,
        pcg: None,
        damping_refresh_steps: 1,
        warm: false,
    },
    Config {
        name: "newton-jacobi",
        linearized: false,
        pcg: Some((1e-8, JACOBI)),
        damping_refresh_steps: 1,
        warm: false,
    },
    Config {
        name: "newton-ic",
        linearized: false,
        pcg: Some((1e-8, IC0)),
        damping_refresh_steps: 1,
        warm: false,
    },
    Config {
        name: "linear-chol",
        linearized: true,
        pcg: None,
        damping_refresh_steps: 1,
        warm: false,
    },
    Config {
        name: "linear-jacobi",
        linearized: true,
        pcg: Some((1e-6, JACOBI)),
        damping_refresh_steps: 1,
        warm: false,
    },
    Config {
        name: "linear-ic",
        linearized: true,
        pcg: Some((1e-6, IC0)),
        damping_refresh_steps: 1,
        warm: false,
    },
    Config {
        name: "linear-chol-lag",
        linearized: true,
        pcg: None,
        damping_refresh_steps: 10,
        warm: false,
    },
    Config {
        name: "linear-ic-lag",
        linearized: true,
        pcg: Some((1e-6, IC0)),
        damping_refresh_steps: 10,
        warm: false,
    },
    Config {
        name: "linear-ic-lag-3",
        linearized: true,
        pcg: Some((1e-3, IC0)),
        damping_refresh_steps: 10,
        warm: false,
    },
    Config {
        name: "linear-ic-lag-2",
        linearized: true,
        pcg: Some((1e-2, IC0)),
        damping_refresh_steps: 10,
        warm: false,
    },
    Config {
        name: "newton-chol-warm",
        linearized: false,
        pcg: None,
        damping_refresh_steps: 1,
        warm: true,
    },
    Config {
        name: "linear-ic-lag-3-warm",
        linearized: true,
        pcg: Some((1e-3, IC0)),
        damping_refresh_steps: 10,
        warm: true,
    },
    Config {
        name: "linear-ic-lag-3-carry",
        linearized: true,
        pcg: Some((1e-3, IC0)),
        damping_refresh_steps: 10,
        warm: true,
    },
    Config {
        name: "linear-ic-lag-3-warm-guess",
        linearized: true,
        pcg: Some((1e-3, IC0)),
        damping_refresh_steps: 10,
        warm: true,
    },
    Config {
        name: "linear-ic-lag-3-warm-lean",
        linearized: true,
        pcg: Some((1e-3, IC0)),
        damping_refresh_steps: 10,
        warm: true,
    },
];

impl Config {
    fn settings(&self) -> StepSettings {
        let mut s = StepSettings {
            rayleigh_alpha: 10.0,
            rayleigh_beta: 0.01,
            damping_refresh_steps: self.damping_refresh_steps,
            ..StepSettings::default()
        };
        if self.linearized {
            s = s.linearized_implicit_euler();
        }
        s.newton.warm_start_regularization = self.warm;
        s.newton.carried_shift_probe_interval = if self.name.ends_with("-carry") {
            CARRIED_SHIFT_PROBE_INTERVAL
        } else {
            0
        };
        if let Some((tol, preconditioner)) = self.pcg {
            s.newton.linear_solver =
                LinearSolver::ConjugateGradient(PcgSettings::new(tol, 20_000, preconditioner));
        }
        if self.name.ends_with("-guess") {
            s = s.warm_started_cg();
        }
        if self.name.ends_with("-lean") {
            s.newton.final_residual = false;
        }
        s
    }
}

/// A hanging garter swatch of `n × n` stitches with its bind-off edge pinned.
fn hanging_garter(n: usize, settings: StepSettings) -> Simulator {
    let chart = Chart::garter(n, n).expect("valid size");
    let params = YarnParams::sweater();
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).expect("layout");
    let mut sim =
        Simulator::new(topo, &layout, params, ForceSet::default(), settings).expect("simulator");
    let pins: Vec<usize> = knit_boundary_nodes(n, n);
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

/// Resets the peak RSS to the current RSS (Linux ≥ 4.0; ignored elsewhere).
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The sweater of size `n` dressed on a mannequin (`--scene sweater`): 8 sectors of `n`
/// loops around, a rib hem of `n/4` rounds, `3.3 n` plain rounds and a yoke narrowing every
/// round to `0.6 n` loops per sector; the mannequin's height is `0.75 m × n/40` (its chest
/// fits the contracted knit). `n = 40`: 320 loops around, ≈ 51 K loops, ≈ 1 M DoFs.
fn sweater(n: usize, settings: StepSettings) -> Simulator {
    use sim_persistent::experiment::garment::{Dressing, mannequin, sweater_chart};
    let hem = (n / 4).max(1);
    let body = (3.3 * n as f64).round() as usize;
    let neck = ((0.6 * n as f64).round() as usize).max(1);
    let chart = sweater_chart(8, n, hem, body, neck).expect("sweater chart");
    let profile = mannequin(0.75 * n as f64 / 40.0);
    Dressing::new(&chart, &profile, 96, settings)
        .expect("dressing")
        .sim
}

/// The scene of `--scene`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scene {
    Garter,
    Sweater,
}

/// STREAM-triad bandwidth (bytes/s, counting 24 bytes per element as STREAM does) on
/// `threads` threads: the best of 5 passes of `a = b + 3 c` over arrays of 2²³ doubles
/// (64 MiB each, beyond the caches), in fixed chunks.
fn triad_bandwidth(threads: usize) -> f64 {
    use rayon::prelude::*;
    let n = 1 << 23;
    let (b, c) = (vec![1.0f64; n], vec![2.0f64; n]);
    let mut a = vec![0.0f64; n];
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let start = Instant::now();
        pool.install(|| {
            a.par_chunks_mut(1 << 16)
                .zip(b.par_chunks(1 << 16))
                .zip(c.par_chunks(1 << 16))
                .for_each(|((a, b), c)| {
                    for i in 0..a.len() {
                        a[i] = b[i] + 3.0 * c[i];
                    }
                });
        });
        best = best.min(start.elapsed().as_secs_f64());
        std::hint::black_box(&a);
    }
    24.0 * n as f64 / best
}

/// Memory bandwidths of this machine (bytes/s): one thread and every rayon thread.
#[derive(Clone, Copy)]
struct Bandwidth {
    serial: f64,
    parallel: f64,
}

/// Builds, warms up and times the scene of size `n` under `config`; prints its row (and, for
/// CG configurations, the memory roofline of its solve at `bandwidth`).
fn measure(scene: Scene, n: usize, config: &Config, steps: usize, bandwidth: Bandwidth) {
    reset_peak_rss();
    let build_start = Instant::now();
    let mut sim = match scene {
        Scene::Garter => hanging_garter(n, config.settings()),
        Scene::Sweater => sweater(n, config.settings()),
    };
    let build = build_start.elapsed().as_secs_f64();
    let n_dofs = sim.dofs().n_dofs();
    let warm_start = Instant::now();
    if let Err(e) = sim.step() {
        println!(
            "{:<15} {n:>4} {n_dofs:>8}  warm-up step failed: {e}",
            config.name
        );
        return;
    }
    let warmup = warm_start.elapsed().as_secs_f64();
    let mut reports: Vec<StepReport> = Vec::new();
    let run_start = Instant::now();
    for _ in 0..steps {
        match sim.step() {
            Ok(r) => reports.push(r),
            Err(e) => {
                println!("{:<15} {n:>4} {n_dofs:>8}  step failed: {e}", config.name);
                return;
            }
        }
    }
    let per_step = run_start.elapsed().as_secs_f64() / steps as f64;
    let mean = |f: &dyn Fn(&StepReport) -> f64| reports.iter().map(f).sum::<f64>() / steps as f64;
    let timing = |f: &dyn Fn(&solver::NewtonTimings) -> f64| {
        mean(&|r| r.last_newton.as_ref().map_or(0.0, |nr| f(&nr.timings)))
    };
    let iterations = mean(&|r| r.newton_iterations as f64);
    let cg = mean(&|r| r.linear_iterations as f64);
    let solves = mean(&|r| {
        r.last_newton
            .as_ref()
            .map_or(0.0, |nr| nr.linear_solves as f64)
    });
    let substeps = mean(&|r| r.substeps as f64);
    let setup = mean(&|r| r.setup_seconds);
    let assembly = timing(&|t| t.assembly);
    let solve = timing(&|t| t.linear_solve);
    let search = timing(&|t| t.line_search);
    // Worst relative residual after a step (last substep; not evaluated without the final
    // residual).
    let residual = reports
        .iter()
        .filter_map(|r| r.last_newton.as_ref())
        .filter(|nr| nr.residual_history.len() > nr.iterations)
        .map(|nr| nr.last_residual() / nr.residual_history[0])
        .fold(f64::NAN, f64::max);
    let ms = |x: f64| 1e3 * x;
    println!(
        "{:<15} {n:>4} {n_dofs:>8} {build:>7.2} {warmup:>8.2} {:>9.1} {:>8.1} {:>8.1} {:>8.1} \
         {:>7.1} {iterations:>5.1} {solves:>6.1} {cg:>7.0} {residual:>9.1e} {:>11.3e} {:>8} {:016x}",
        config.name,
        ms(per_step),
        ms(setup),
        ms(assembly),
        ms(solve),
        ms(search),
        n_dofs as f64 / per_step,
        peak_rss_mib().map_or("?".into(), |m| format!("{m:.0}")),
        state_fingerprint(sim.state()),
    );
    if substeps > 1.0 {
        println!("      (steps were halved: {substeps:.1} substeps per step on average)");
    }
    if matches!(config.pcg, Some((_, Preconditioner::IncompleteCholesky))) {
        // The step's pattern, as the simulator's Newton solver built it.
        match solver::Assembler::with_fixed_dofs(&sim.step_potential(), sim.fixed()) {
            Ok(asm) => {
                let (free, lower) = (asm.n_free(), asm.hessian().col_ptr()[asm.n_free()]);
                let traffic = PcgTraffic::incomplete_cholesky(free, lower);
                let roof = traffic.seconds(cg, solves, bandwidth.parallel, bandwidth.serial);
                println!(
                    "      roofline: {free} unknowns, {lower} lower entries; {:.0} MB per CG \
                     iteration ({:.0} serial), {:.0} MB per solve ({:.0} serial); at the \
                     measured bandwidths the CG iterations and solves of a step take ≥ {:.1} \
                     ms (measured solve {:.2}× that), which caps the step at {:.3e} \
                     DoF-steps/s were everything else free",
                    1e-6 * (traffic.iteration_parallel + traffic.iteration_serial),
                    1e-6 * traffic.iteration_serial,
                    1e-6 * (traffic.solve_parallel + traffic.solve_serial),
                    1e-6 * traffic.solve_serial,
                    ms(roof),
                    solve / roof,
                    n_dofs as f64 / roof,
                );
            }
            Err(e) => println!("      roofline: pattern not rebuilt ({e})"),
        }
    }
}

/// FNV-1a hash of the bits of the final positions and velocities: equal fingerprints mean
/// the same steps bit for bit (to check that a change meant to be exact is).
fn state_fingerprint(state: &sim_persistent::state::State) -> u64 {
    state
        .q
        .iter()
        .chain(&state.v)
        .flat_map(|x| x.to_bits().to_le_bytes())
        .fold(0xcbf2_9ce4_8422_2325, |h, byte| {
            (h ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3)
        })
}

/// The value after `flag` in the command line, if any.
fn arg(flag: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1).cloned())
}

fn main() {
    let sides: Vec<usize> = arg("--sides")
        .unwrap_or_else(|| "8,16,32,72".into())
        .split(',')
        .map(|s| s.parse().expect("--sides: comma-separated integers"))
        .collect();
    let configs: Vec<Config> = match arg("--configs") {
        None => CONFIGS.to_vec(),
        Some(list) => list
            .split(',')
            .map(|name| {
                *CONFIGS
                    .iter()
                    .find(|c| c.name == name)
                    .unwrap_or_else(|| panic!("unknown configuration {name}"))
            })
            .collect(),
    };
    let steps: usize = arg("--steps").map_or(3, |s| s.parse().expect("--steps: integer"));
    let scene = match arg("--scene").as_deref() {
        None | Some("garter") => Scene::Garter,
        Some("sweater") => Scene::Sweater,
        Some(other) => panic!("--scene: garter or sweater, got {other}"),
    };
    let max_chol: f64 = arg("--max-chol-dofs").map_or(2.5e5, |s| s.parse().expect("number"));
    let budget: f64 = arg("--budget").map_or(600.0, |s| s.parse().expect("--budget: seconds"));
    let threads = rayon::current_num_threads();
    let bandwidth = Bandwidth {
        serial: triad_bandwidth(1),
        parallel: triad_bandwidth(threads),
    };
    let what = match scene {
        Scene::Garter => "hanging garter n × n",
        Scene::Sweater => "sweater of 8 sectors of n loops dressed on a mannequin mesh",
    };
    println!(
        "scaling: {what}, sweater yarn, dt = 1 ms, α = 10 /s, β = 0.01 s, all terms; \
         {threads} rayon threads; {steps} timed steps after one warm-up; times in ms per step \
         (a 30 fps frame is 33 steps)"
    );
    println!(
        "memory bandwidth (STREAM triad, best of 5 over 3 × 64 MiB): {:.1} GB/s on 1 thread, \
         {:.1} GB/s on {threads}",
        1e-9 * bandwidth.serial,
        1e-9 * bandwidth.parallel
    );
    println!(
        "{:<15} {:>4} {:>8} {:>7} {:>8} {:>9} {:>8} {:>8} {:>8} {:>7} {:>5} {:>6} {:>7} {:>9} {:>11} {:>8} {:>16}",
        "config",
        "n",
        "DoFs",
        "build s",
        "warmup s",
        "step",
        "setup",
        "assembly",
        "solve",
        "search",
        "iters",
        "solves",
        "CG its",
        "res/res0",
        "DoF-steps/s",
        "peak MiB",
        "state"
    );
    let start = Instant::now();
    for n in sides {
        let dofs = match scene {
            Scene::Garter => 20.2 * (n * n) as f64,
            Scene::Sweater => 20.2 * 8.0 * 3.6 * (n * n) as f64,
        };
        for config in &configs {
            if config.pcg.is_none() && dofs > max_chol {
                println!(
                    "{:<15} {n:>4} {dofs:>8.0}  skipped (Cholesky above --max-chol-dofs)",
                    config.name
                );
                continue;
            }
            if start.elapsed().as_secs_f64() > budget {
                println!("budget of {budget:.0} s spent; stopping");
                return;
            }
            measure(scene, n, config, steps, bandwidth);
        }
    }
    println!("total {:.1} s", start.elapsed().as_secs_f64());
    println!("paper (Cirio et al. 2017): 1.1 M DoFs, 96 s per 33-step frame ≈ 3.8e5 DoF-steps/s");
}
