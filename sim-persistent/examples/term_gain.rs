//! What assembling only the terms a scene needs saves (issue 6: "only terms the scene needs
//! are assembled (no wrapping for a weave, no friction bookkeeping when sliding is off, no
//! obstacle queries without obstacles) — measure the gain").
//!
//! ```text
//! cargo run --release -p sim-persistent --example term_gain -- [--knit 16] [--weave 32] [--steps 20]
//! ```
//!
//! Scenes (Table 1 sweater yarn, loop width / yarn spacing 3 mm, gravity along −z, Table 1
//! Rayleigh damping α = 10 /s, β = 0.01 s, dt = 1 ms, sparse Cholesky Newton, no pins):
//!
//! - **(a) knit**: a flat `--knit × --knit` garter swatch with every default term (gravity,
//!   stretch, bending, stitch length, friction with the compression estimate, stitch
//!   wrapping), against the same swatch with `ForceSet::friction = false` (no friction
//!   springs, no anchor updates, no compression estimate) and with `ForceSet::wrapping =
//!   false`;
//! - **(b) weave**: a `--weave × --weave` plain weave (it never gets wrapping terms) with every
//!   term, against `ForceSet::crossing_shear = false`;
//! - **(c) obstacles**: the knit of (a) without obstacles, with one sphere 1 m away (its
//!   contact terms are assembled, one per node, but never active), and lying on a sphere of
//!   radius 0.4 × its width under its centre (lowest yarn surface touching at the release).
//!
//! Each configuration is built from its flat layout and stepped `WARMUP` steps (the first
//! builds the sparsity pattern and the symbolic factorization); then `--steps` steps of each
//! configuration of a scene are timed, one step of each configuration in turn, so that
//! other jobs on the machine slow them alike. Printed: DoFs, the Rayleigh-β damping terms and
//! the elastic terms assembled per kind, mean and median wall time per step, the mean setup
//! (inertia and damping forms, friction limits with the compression estimate), assembly and
//! linear-solve parts, Newton iterations per step, median time per Newton iteration, and the
//! cost relative to the first configuration of the scene from the medians, per step and per
//! Newton iteration (terms change the dynamics, hence the iteration count, as well as the
//! cost of an iteration).
//!
//! **Measured** (release, defaults `--knit 16 --weave 32 --steps 20`, 2 cores shared with
//! other jobs, load ≈ 5; the identical configurations "(a) every term" and "(c) no obstacle"
//! differ by 1.7 %, which is the noise level; whole run 54 s):
//!
//! ```text
//! scene          config              DoFs  damp  ms/step median setup assem solve   it  ms/it   rel rel/it
//! (a) knit       every term          5312  7828   265.6  263.8 141.6  57.9  58.5 3.00   87.9 1.000  1.000
//! (a) knit       no friction         5312  5938   264.4  264.1 136.6  57.7  62.4 3.00   88.0 1.001  1.001
//! (a) knit       no wrapping         5312  6898   173.7  172.5  94.8  34.5  38.2 3.00   57.5 0.654  0.654
//! (b) weave      every term          5120  9668   373.2  367.9  46.7  25.5 297.9 1.00  367.9 1.000  1.000
//! (b) weave      no crossing shear   5120  5824   278.1  281.2  30.2  15.0 230.8 1.00  281.2 0.764  0.764
//! (c) obstacles  no obstacle         5312  7828   269.4  268.4 141.3  60.3  59.4 3.00   89.5 1.000  1.000
//! (c) obstacles  far sphere          5312  7828   270.8  271.8 141.3  61.2  59.7 3.00   90.6 1.013  1.013
//! (c) obstacles  resting on sphere   5312  7828   310.2  279.5 141.4  76.5  80.8 4.05   69.0 1.042  0.772
//! ```
//!
//! A second run at lower load (knit 167 ms per step): relative median cost no friction
//! 0.957, no wrapping 0.637, weave without crossing shear 0.736, far sphere 1.039, resting on
//! the sphere 1.058 (0.784 per Newton iteration at 4.05 iterations).
//!
//! Elastic terms: knit grav 2032, str 2032, bend 2016, len 960, fric 1890, wrap 930 (+ obst
//! 1088 with a sphere); weave grav 1984, str 1984, bend 1920, fric 1920, shear 3844.
//!
//! Reading: **stitch wrapping** is the expensive term of a knit: its 930 twelve-DoF stencils
//! and their β-damping forms cost 35 % of a step (setup 142 → 95 ms, assembly 58 → 35 ms), so a
//! weave, which never gets them, pays none of it. **Crossing shear** costs 24 % of a weave step
//! (3844 terms, the most numerous of the weave). **Friction** costs 0–4 % (1890 one-DoF
//! springs, their damping forms and the compression estimate: at the noise level), so switching
//! it off gains little time. **Obstacle terms** that are assembled but inactive (a far sphere:
//! one per node, 1088) cost 1–4 % (noise level); a swatch resting on the sphere needs 4.05
//! instead of 3 Newton iterations per step (+4–6 % per step, the contact iterations being
//! cheaper). So "only the terms the scene needs" matters for wrapping and crossing shear, not
//! for friction or idle obstacles. Also seen: the setup (Rayleigh-β damping forms) is half of a
//! knit step, and the weave's single Newton iteration spends ≈ 230–300 ms in the linear solve,
//! about three times a whole knit Newton iteration of the same size (not investigated here).

use sim_persistent::chart::Chart;
use sim_persistent::forces::obstacle::{Obstacle, Shape};
use sim_persistent::forces::{ForceSet, TermKind};
use sim_persistent::integrator::{Simulator, StepReport, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::Topology;
use sim_persistent::weave::WeavePattern;
use std::collections::BTreeMap;
use std::time::Instant;

/// Untimed steps before the timed ones.
const WARMUP: usize = 3;

/// Loop width / yarn spacing (m).
const SPACING: f64 = 3e-3;

/// Where a scene's obstacle is.
#[derive(Clone, Copy, Debug)]
enum Sphere {
    None,
    /// One sphere 1 m below the swatch: assembled, never touched.
    Far,
    /// A sphere under the swatch's centre, touching its lowest yarn surface.
    Under,
}

/// One configuration of a scene.
struct Config {
    scene: &'static str,
    name: &'static str,
    topology: Topology,
    forces: ForceSet,
    sphere: Sphere,
}

fn params() -> YarnParams {
    let mut p = YarnParams::sweater();
    p.gravity = rod::geometry::V3::new(0.0, 0.0, -9.81);
    p
}

fn settings() -> StepSettings {
    StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    }
}

fn build(config: &Config) -> Result<Simulator, String> {
    let params = params();
    let layout = Layout::new(&config.topology, &LayoutParams::new(SPACING, params.radius))
        .map_err(|e| e.to_string())?;
    let (mut lo, mut hi) = (
        rod::geometry::V3::repeat(f64::INFINITY),
        rod::geometry::V3::repeat(f64::NEG_INFINITY),
    );
    for p in &layout.positions {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let mid = 0.5 * (lo + hi);
    let mut sim = Simulator::new(
        config.topology.clone(),
        &layout,
        params,
        config.forces,
        settings(),
    )
    .map_err(|e| e.to_string())?;
    let width = (hi.x - lo.x).max(hi.y - lo.y);
    let sphere = match config.sphere {
        Sphere::None => None,
        Sphere::Far => Some(Shape::Sphere {
            center: rod::geometry::V3::new(mid.x, mid.y, lo.z - 1.0),
            radius: 0.4 * width,
        }),
        Sphere::Under => {
            let rho = 0.4 * width;
            Some(Shape::Sphere {
                center: rod::geometry::V3::new(mid.x, mid.y, lo.z - rho - params.radius),
                radius: rho,
            })
        }
    };
    if let Some(shape) = sphere {
        sim.add_obstacles(&[Obstacle::new(shape, None)?])
            .map_err(|e| e.to_string())?;
    }
    Ok(sim)
}

/// Counts of the elastic terms per kind (short names), and of the damping terms.
fn term_counts(sim: &Simulator) -> (String, usize) {
    let mut counts: BTreeMap<TermKind, usize> = BTreeMap::new();
    for &kind in sim.static_terms().kinds() {
        *counts.entry(kind).or_default() += 1;
    }
    let damping = sim.step_terms().count(TermKind::Damping);
    let text = counts
        .iter()
        .map(|(k, n)| {
            let name = match k {
                TermKind::Gravity => "grav",
                TermKind::Stretch => "str",
                TermKind::Bending => "bend",
                TermKind::StitchLength => "len",
                TermKind::Friction => "fric",
                TermKind::ParallelFriction => "pfric",
                TermKind::Wrapping => "wrap",
                TermKind::CrossingShear => "shear",
                TermKind::Obstacle => "obst",
                TermKind::LoopContact => "loop",
                TermKind::YarnContact => "yarn",
                TermKind::SegmentFloor => "floor",
                TermKind::Inertia => "inert",
                TermKind::Damping => "damp",
            };
            format!("{name} {n}")
        })
        .collect::<Vec<_>>()
        .join(", ");
    (text, damping)
}

/// A built, warmed-up configuration and its timings so far.
struct Run<'a> {
    config: &'a Config,
    sim: Simulator,
    terms: String,
    damping: usize,
    /// Wall time of each timed step (s).
    times: Vec<f64>,
    reports: Vec<StepReport>,
}

impl<'a> Run<'a> {
    fn new(config: &'a Config) -> Result<Self, String> {
        let mut sim = build(config)?;
        for k in 0..WARMUP {
            sim.step().map_err(|e| format!("warm-up step {k}: {e}"))?;
        }
        let (terms, damping) = term_counts(&sim);
        Ok(Self {
            config,
            sim,
            terms,
            damping,
            times: Vec::new(),
            reports: Vec::new(),
        })
    }

    /// Times one further step.
    fn step(&mut self) -> Result<(), String> {
        let start = Instant::now();
        let report = self
            .sim
            .step()
            .map_err(|e| format!("step {}: {e}", self.reports.len()))?;
        self.times.push(start.elapsed().as_secs_f64());
        self.reports.push(report);
        Ok(())
    }

    /// Mean over every timed step of `f`.
    fn mean(&self, f: &dyn Fn(&StepReport) -> f64) -> f64 {
        self.reports.iter().map(f).sum::<f64>() / self.reports.len() as f64
    }

    /// (mean, median) wall time per step (ms).
    fn ms_per_step(&self) -> (f64, f64) {
        let mut t = self.times.clone();
        t.sort_by(f64::total_cmp);
        let n = t.len();
        let median = if n % 2 == 1 {
            t[n / 2]
        } else {
            0.5 * (t[n / 2 - 1] + t[n / 2])
        };
        (1e3 * t.iter().sum::<f64>() / n as f64, 1e3 * median)
    }
}

fn arg(args: &[String], name: &str, default: usize) -> Result<usize, String> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => args
            .get(i + 1)
            .ok_or_else(|| format!("{name} needs a value"))?
            .parse::<usize>()
            .ok()
            .filter(|&v| v >= 1)
            .ok_or_else(|| format!("{name} needs a positive integer, got {:?}", args[i + 1])),
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("term_gain: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    for a in args.iter().filter(|a| a.starts_with("--")) {
        if !["--knit", "--weave", "--steps"].contains(&a.as_str()) {
            return Err(format!(
                "unknown option {a} (--knit N, --weave N, --steps N)"
            ));
        }
    }
    let n_knit = arg(&args, "--knit", 16)?;
    let n_weave = arg(&args, "--weave", 32)?;
    let steps = arg(&args, "--steps", 20)?;
    let knit = Topology::knit(&Chart::garter(n_knit, n_knit).map_err(|e| e.to_string())?);
    let weave =
        Topology::weave(WeavePattern::Plain, n_weave, n_weave).map_err(|e| e.to_string())?;
    let all = ForceSet::default();
    let configs = [
        Config {
            scene: "(a) knit",
            name: "every term",
            topology: knit.clone(),
            forces: all,
            sphere: Sphere::None,
        },
        Config {
            scene: "(a) knit",
            name: "no friction",
            topology: knit.clone(),
            forces: ForceSet {
                friction: false,
                ..all
            },
            sphere: Sphere::None,
        },
        Config {
            scene: "(a) knit",
            name: "no wrapping",
            topology: knit.clone(),
            forces: ForceSet {
                wrapping: false,
                ..all
            },
            sphere: Sphere::None,
        },
        Config {
            scene: "(b) weave",
            name: "every term",
            topology: weave.clone(),
            forces: all,
            sphere: Sphere::None,
        },
        Config {
            scene: "(b) weave",
            name: "no crossing shear",
            topology: weave,
            forces: ForceSet {
                crossing_shear: false,
                ..all
            },
            sphere: Sphere::None,
        },
        Config {
            scene: "(c) obstacles",
            name: "no obstacle",
            topology: knit.clone(),
            forces: all,
            sphere: Sphere::None,
        },
        Config {
            scene: "(c) obstacles",
            name: "far sphere",
            topology: knit.clone(),
            forces: all,
            sphere: Sphere::Far,
        },
        Config {
            scene: "(c) obstacles",
            name: "resting on sphere",
            topology: knit,
            forces: all,
            sphere: Sphere::Under,
        },
    ];
    println!(
        "garter {n_knit}×{n_knit}, plain weave {n_weave}×{n_weave}; {WARMUP} warm-up steps, then \
         {steps} timed steps per configuration, the configurations of a scene stepped in turn; \
         dt = 1 ms"
    );
    println!(
        "{:<14} {:<18} {:>6} {:>6} {:>8} {:>8} {:>7} {:>7} {:>7} {:>5} {:>7} {:>7} {:>7}  elastic terms",
        "scene",
        "config",
        "DoFs",
        "damp",
        "ms/step",
        "median",
        "setup",
        "assem",
        "solve",
        "it",
        "ms/it",
        "rel",
        "rel/it"
    );
    let total = Instant::now();
    let mut scenes: Vec<&str> = configs.iter().map(|c| c.scene).collect();
    scenes.dedup();
    for scene in scenes {
        let mut runs = configs
            .iter()
            .filter(|c| c.scene == scene)
            .map(|c| Run::new(c).map_err(|e| format!("{scene} / {}: {e}", c.name)))
            .collect::<Result<Vec<_>, _>>()?;
        // One step of each configuration in turn, so that the load of the machine affects
        // them alike.
        for _ in 0..steps {
            for run in &mut runs {
                run.step()
                    .map_err(|e| format!("{scene} / {}: {e}", run.config.name))?;
            }
        }
        let mut base: Option<(f64, f64)> = None;
        for run in &runs {
            let (all, best) = run.ms_per_step();
            // Relative costs from the medians (robust to other jobs on the machine).
            let iterations = run.mean(&|r| r.newton_iterations as f64);
            let per_it = best / iterations.max(1e-12);
            let (b_step, b_it) = *base.get_or_insert((best, per_it));
            println!(
                "{:<14} {:<18} {:>6} {:>6} {:>8.1} {:>8.1} {:>7.1} {:>7.1} {:>7.1} {:>5.2} {:>7.1} {:>7.3} {:>7.3}  {}",
                scene,
                run.config.name,
                run.sim.dofs().n_dofs(),
                run.damping,
                all,
                best,
                1e3 * run.mean(&|r| r.setup_seconds),
                1e3 * run.mean(&|r| r.last_newton.as_ref().map_or(0.0, |n| n.timings.assembly)),
                1e3 * run.mean(&|r| r
                    .last_newton
                    .as_ref()
                    .map_or(0.0, |n| n.timings.linear_solve)),
                iterations,
                per_it,
                best / b_step,
                per_it / b_it,
                run.terms
            );
        }
    }
    println!("total {:.1} s", total.elapsed().as_secs_f64());
    Ok(())
}
