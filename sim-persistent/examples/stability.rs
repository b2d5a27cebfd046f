//! Stability study (issue 6: "the largest stable dt and the stretch range without NaN or
//! blow-up"; goal: stable up to 10 ms, ten times the paper's step).
//!
//! `cargo run --release -p sim-persistent --example stability`
//!
//! Every run uses a 6 × 6 garter swatch of the Table 1 sweater yarn (loop width 3 mm, so
//! 18 mm × 18 mm), Table 1 Rayleigh damping α = 10 /s, β = 0.01 s, and every implemented
//! force term (gravity, stretch, bending with jamming, stitch-contact length, friction,
//! stitch wrapping with its default 0.1 s rest-angle ramp) unless stated.
//!
//! # Part 1: time step
//!
//! For dt ∈ {1, 2, 5, 10, 20} ms, two scenes are run to `T_END` = 0.6 s of simulated time:
//!
//! - **hanging**: the bind-off edge pinned, the swatch falls and settles under gravity;
//! - **stretched**: cast-on and bind-off edges clamped, the bind-off clamp driven up at
//!   36 mm/s for 0.25 s (50 % wale strain, 9 mm) and then held, so the swatch stretches
//!   dynamically and then settles.
//!
//! A run is **stable** at dt when all of the following hold:
//!
//! 1. *converges*: every step's Newton solve converges at the full step (no step halving,
//!    [`StepSettings::max_halvings`] = 0, so a failed solve ends the run);
//! 2. *finite*: every coordinate and velocity is finite after every step;
//! 3. *bounded energy*: the kinetic energy never exceeds 10× the peak kinetic energy of
//!    the dt = 1 ms run of the same scene, and no node ever moves more than 10 swatch
//!    sizes (18 cm) from its start;
//! 4. *settles*: the kinetic energy at `T_END` is below 1 % of its peak over the run.
//!
//! A run that fails criterion 1 is repeated with the integrator's default step halving
//! (at most 4 halvings per step) to show whether the default settings get through.
//!
//! The largest stable dt is the largest dt of the list for which this holds (the smaller
//! ones are all checked too). Also printed: the Newton iterations per step, and the accuracy
//! against the dt = 1 ms run: the RMS distance of the node positions at `T_END` (m).
//!
//! # Part 2: stretch range
//!
//! - **quasi-static**: weightless swatch without stitch wrapping (its rest angle would be at
//!   the layout's value in a static solve, see [`Simulator::solve_static`]), both edges
//!   clamped, the bind-off clamp moved up in 1 % strain increments (0.18 mm) with a static
//!   equilibrium solve after each, up to 100 % wale strain; the range is the largest strain
//!   whose solve converged with a finite state. The clamp force and the largest sliding
//!   distance `max Δu` since the unstretched equilibrium are printed every 10 %.
//! - **driven**: the dynamic stretched scene of part 1 at dt = 1 ms, but driven on at
//!   36 mm/s to 100 % strain (0.5 s); the range is the largest strain reached with every
//!   step converged (halving allowed here, the default four times), finite, and the kinetic
//!   energy below 10× the peak of the first 50 % (the dynamics of part 1).
//!
//! Measured on a 2-core machine shared with other jobs; only the run times are noisy, the
//! outcomes are deterministic.
//!
//! **Results** (with the segment floor, on by default, and the default Newton cap of 100
//! iterations): hanging stable up to 10 ms (20 ms converges every step but has not settled
//! by 0.6 s: 2 % of its peak kinetic energy left), stretched stable up to 20 ms (every step
//! of the list); quasi-static stretch to 100 % wale strain; driven stretch to 100 % with no
//! step halved. Without the floor the stretched scene was stable only up to 2 ms (5–20 ms
//! diverged as segments drained, see `sim_persistent::forces::segment_floor`), the
//! quasi-static stretch failed at 30 % and the driven one at 81 %; with the former cap of
//! 50 one 10 ms hanging step stopped early (it needs 51–80 iterations).

use rod::geometry::V3;
use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Topology, knit_boundary_nodes};
use std::time::Instant;

/// Stitches per side.
const N: usize = 6;
/// Loop width and row height (m).
const LOOP: f64 = 3e-3;
/// Swatch height (m).
const HEIGHT: f64 = N as f64 * LOOP;
/// Simulated time of each dt run (s).
const T_END: f64 = 0.6;
/// Clamp speed of the stretched scenes (m/s): 2 swatch heights per second.
const CLAMP_SPEED: f64 = 2.0 * HEIGHT;
/// Duration of the drive in part 1 (s): 50 % strain.
const DRIVE_TIME: f64 = 0.25;

fn simulator(params: YarnParams, forces: ForceSet, settings: StepSettings) -> Simulator {
    let chart = Chart::garter(N, N).expect("valid size");
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &LayoutParams::new(LOOP, params.radius)).expect("layout");
    Simulator::new(topo, &layout, params, forces, settings).expect("simulator")
}

fn settings(dt: f64, max_halvings: usize) -> StepSettings {
    StepSettings {
        dt,
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        max_halvings,
        ..StepSettings::default()
    }
}

/// The two dynamic scenes of part 1.
#[derive(Clone, Copy, PartialEq)]
enum Scene {
    Hanging,
    Stretched,
}

/// Outcome of one dynamic run.
struct Run {
    /// `None` if every step converged; else the time (s) and error of the failed step.
    failure: Option<(f64, String)>,
    finite: bool,
    peak_kinetic: f64,
    final_kinetic: f64,
    max_travel: f64,
    steps: usize,
    halved: usize,
    mean_iterations: f64,
    positions: Vec<V3>,
    wall: f64,
}

fn positions(sim: &Simulator) -> Vec<V3> {
    (0..sim.topology().nodes.len())
        .map(|n| sim.dofs().position(&sim.state().q, n))
        .collect()
}

/// Runs `scene` with step `dt` until `t_end`, driving the clamp for `drive_time`.
fn run(scene: Scene, dt: f64, t_end: f64, drive_time: f64, max_halvings: usize) -> Run {
    let mut sim = simulator(
        YarnParams::sweater(),
        ForceSet::default(),
        settings(dt, max_halvings),
    );
    let top = knit_boundary_nodes(N, N);
    sim.pin_nodes(&top).expect("pins");
    if scene == Scene::Stretched {
        sim.pin_nodes(&knit_boundary_nodes(N, 0)).expect("pins");
    }
    let start = positions(&sim);
    let steps = (t_end / dt).round() as usize;
    let mut out = Run {
        failure: None,
        finite: true,
        peak_kinetic: 0.0,
        final_kinetic: f64::NAN,
        max_travel: 0.0,
        steps: 0,
        halved: 0,
        mean_iterations: 0.0,
        positions: Vec::new(),
        wall: 0.0,
    };
    let clock = Instant::now();
    let mut iterations = 0;
    for k in 0..steps {
        if scene == Scene::Stretched && (k as f64 + 0.5) * dt < drive_time {
            sim.displace_pinned_nodes(&top, V3::new(0.0, CLAMP_SPEED * dt, 0.0))
                .expect("pinned");
        }
        match sim.step() {
            Ok(r) => {
                iterations += r.newton_iterations;
                out.halved += usize::from(r.substeps > 1);
            }
            Err(e) => {
                out.failure = Some(((k + 1) as f64 * dt, e.to_string()));
                break;
            }
        }
        out.steps += 1;
        let s = sim.state();
        if !s.q.iter().chain(&s.v).all(|v| v.is_finite()) {
            out.finite = false;
            break;
        }
        let t = sim.kinetic_energy();
        out.peak_kinetic = out.peak_kinetic.max(t);
        out.final_kinetic = t;
        let now = positions(&sim);
        let travel = now
            .iter()
            .zip(&start)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        out.max_travel = out.max_travel.max(travel);
    }
    out.mean_iterations = iterations as f64 / out.steps.max(1) as f64;
    out.positions = positions(&sim);
    out.wall = clock.elapsed().as_secs_f64();
    out
}

fn rms_distance(a: &[V3], b: &[V3]) -> f64 {
    (a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm_squared())
        .sum::<f64>()
        / a.len() as f64)
        .sqrt()
}

fn part1() {
    println!("## Part 1: largest stable time step (6 × 6 garter, to t = {T_END} s, no halving)");
    for (scene, name) in [(Scene::Hanging, "hanging"), (Scene::Stretched, "stretched")] {
        println!("\n### {name}");
        println!(
            "{:>6} {:>10} {:>6} {:>6} {:>11} {:>11} {:>10} {:>10} {:>11} {:>8} {:>7}",
            "dt ms",
            "converged",
            "finite",
            "iters",
            "peak T (J)",
            "T_end/peak",
            "travel m",
            "bounded",
            "rms vs 1ms",
            "wall s",
            "STABLE"
        );
        let mut reference: Option<Run> = None;
        let mut largest = None;
        let mut all_stable = true;
        for dt_ms in [1.0, 2.0, 5.0, 10.0, 20.0] {
            let dt = dt_ms * 1e-3;
            let r = run(scene, dt, T_END, DRIVE_TIME, 0);
            let reference_peak = reference
                .as_ref()
                .map_or(r.peak_kinetic, |x| x.peak_kinetic);
            let converged = r.failure.is_none();
            let bounded = r.peak_kinetic <= 10.0 * reference_peak && r.max_travel < 10.0 * HEIGHT;
            let settles = r.final_kinetic < 1e-2 * r.peak_kinetic;
            let stable = converged && r.finite && bounded && settles;
            all_stable &= stable;
            if all_stable {
                largest = Some(dt_ms);
            }
            let rms = reference
                .as_ref()
                .map_or(0.0, |x| rms_distance(&x.positions, &r.positions));
            let conv = match &r.failure {
                None => "all".to_string(),
                Some((t, _)) => format!("fail@{t:.3}s"),
            };
            println!(
                "{dt_ms:>6} {conv:>10} {:>6} {:>6.2} {:>11.3e} {:>11.2e} {:>10.2e} {:>10} \
                 {rms:>11.2e} {:>8.2} {:>7}",
                r.finite,
                r.mean_iterations,
                r.peak_kinetic,
                r.final_kinetic / r.peak_kinetic,
                r.max_travel,
                bounded,
                r.wall,
                if stable { "yes" } else { "no" }
            );
            if let Some((t, e)) = &r.failure {
                println!("       step ending at {t:.3} s: {e}");
                let h = run(scene, dt, T_END, DRIVE_TIME, 4);
                match &h.failure {
                    None => println!(
                        "       with the default halving (≤ 4 times): all steps succeed, {} of {} \
                         halved, finite {}, T_end/peak {:.2e}",
                        h.halved,
                        h.steps,
                        h.finite,
                        h.final_kinetic / h.peak_kinetic
                    ),
                    Some((t, e)) => {
                        println!(
                            "       with the default halving (≤ 4 times): fails at {t:.3} s: {e}"
                        )
                    }
                }
            }
            if reference.is_none() {
                reference = Some(r);
            }
        }
        match largest {
            Some(dt) => println!("largest stable dt ({name}): {dt} ms"),
            None => println!("largest stable dt ({name}): none of the tried steps"),
        }
    }
}

fn part2_static() {
    println!("\n## Part 2a: quasi-static wale stretch (weightless, no wrapping, 1 % increments)");
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    let forces = ForceSet {
        wrapping: false,
        ..ForceSet::default()
    };
    let mut sim = simulator(params, forces, StepSettings::default());
    let (bottom, top) = (knit_boundary_nodes(N, 0), knit_boundary_nodes(N, N));
    sim.pin_nodes(&bottom).expect("pins");
    sim.pin_nodes(&top).expect("pins");
    sim.solve_static().expect("rest solve");
    let u0 = sim.state().q.clone();
    println!(
        "{:>8} {:>12} {:>7} {:>12} {:>8}",
        "strain", "force N", "iters", "max Δu m", "wall s"
    );
    let clock = Instant::now();
    let mut range = 0;
    for k in 1..=100 {
        sim.displace_pinned_nodes(&top, V3::new(0.0, 0.01 * HEIGHT, 0.0))
            .expect("pinned");
        let report = match sim.solve_static() {
            Ok(r) => r,
            Err(e) => {
                println!("{k:>7}% static solve failed: {e}");
                break;
            }
        };
        if !sim.state().q.iter().all(|v| v.is_finite()) {
            println!("{k:>7}% non-finite state");
            break;
        }
        range = k;
        if k % 10 == 0 || k <= 2 {
            let f = -sim.force_on_nodes(&top).y;
            let s = sim.state();
            let max_u = sim
                .topology()
                .nodes
                .iter()
                .enumerate()
                .flat_map(|(n, node)| (0..node.passes.len()).map(move |p| (n, p)))
                .map(|(n, p)| {
                    let i = sim.dofs().u(n, p);
                    (s.q[i] - u0[i]).abs()
                })
                .fold(0.0, f64::max);
            println!(
                "{k:>7}% {f:>12.4e} {:>7} {max_u:>12.4e} {:>8.2}",
                report.iterations,
                clock.elapsed().as_secs_f64()
            );
        }
    }
    println!("quasi-static stretch range without failure or NaN: 0–{range} % wale strain");
}

fn part2_driven() {
    println!("\n## Part 2b: driven clamp, dt = 1 ms, 36 mm/s to 100 % wale strain (with gravity)");
    let dt = 1e-3;
    let mut sim = simulator(YarnParams::sweater(), ForceSet::default(), settings(dt, 4));
    let (bottom, top) = (knit_boundary_nodes(N, 0), knit_boundary_nodes(N, N));
    sim.pin_nodes(&bottom).expect("pins");
    sim.pin_nodes(&top).expect("pins");
    let steps = (1.0 / CLAMP_SPEED * HEIGHT / dt).round() as usize; // 100 % strain
    let clock = Instant::now();
    let (mut peak_half, mut peak, mut halved, mut iterations) = (0.0f64, 0.0f64, 0, 0);
    let mut reached = 0.0;
    let mut why = String::from("reached the end of the drive");
    println!(
        "{:>8} {:>12} {:>11} {:>7} {:>8}",
        "strain", "force N", "T (J)", "iters", "wall s"
    );
    for k in 1..=steps {
        sim.displace_pinned_nodes(&top, V3::new(0.0, CLAMP_SPEED * dt, 0.0))
            .expect("pinned");
        let strain = k as f64 * CLAMP_SPEED * dt / HEIGHT;
        match sim.step() {
            Ok(r) => {
                iterations += r.newton_iterations;
                halved += usize::from(r.substeps > 1);
            }
            Err(e) => {
                why = format!("step failed at {:.0} % strain: {e}", 100.0 * strain);
                break;
            }
        }
        let s = sim.state();
        if !s.q.iter().chain(&s.v).all(|v| v.is_finite()) {
            why = format!("non-finite state at {:.0} % strain", 100.0 * strain);
            break;
        }
        let t = sim.kinetic_energy();
        peak = peak.max(t);
        if strain <= 0.5 {
            peak_half = peak_half.max(t);
        } else if t > 10.0 * peak_half {
            why = format!(
                "kinetic energy {t:.3e} J > 10× the peak of the first 50 % at {:.0} % strain",
                100.0 * strain
            );
            break;
        }
        reached = strain;
        if k % (steps / 10) == 0 {
            println!(
                "{:>7.0}% {:>12.4e} {t:>11.3e} {:>7.2} {:>8.2}",
                100.0 * strain,
                -sim.force_on_nodes(&top).y,
                iterations as f64 / k as f64,
                clock.elapsed().as_secs_f64()
            );
        }
    }
    println!(
        "driven stretch range: 0–{:.0} % wale strain ({why}); steps halved: {halved}; peak \
         kinetic energy {peak:.3e} J",
        100.0 * reached
    );
}

fn main() {
    let clock = Instant::now();
    part1();
    part2_static();
    part2_driven();
    println!("\ntotal {:.1} s", clock.elapsed().as_secs_f64());
}
