//! The cost of one yarn-fit objective evaluation (issue 15's speed goal), apart from the
//! optimizers' paths.
//!
//! ```text
//! cargo bench -p bench --bench yarn_objective [-- FABRIC ... | all] [--points N]
//! ```
//!
//! For each named fabric (default: the development fabric; `all`: every shared fabric) it
//! builds the `yarn-fit` figure's targets and parameter box ([`bench::figures::yarn_fit`]:
//! shell fit and uniform targets, the paper's five parameters and the tile's stretch along x
//! and y), then evaluates the swarm's objective (Eq. 11 with the rest-shape estimation, the
//! figure's full-mode swarm settings) at `N` (default 10) fixed pseudo-random points of the
//! normalized box, one at a time, and prints the tile's vertices, how many evaluations solved
//! and failed, seconds per solved and per failed evaluation, and Newton iterations and
//! milliseconds per Newton iteration of the solved ones.
//!
//! A whole fit (`--bench yarn_fit`) takes minutes and, after any change that moves rounding,
//! follows another path through the swarm and the local search, so its time mixes the cost of
//! an evaluation with the path. These points do not depend on any optimizer. Failed
//! evaluations are counted apart: a solve that runs to its iteration limit can cost several
//! solved evaluations.
//!
//! Measured (release, 2 cores, 2026-11-29, 10 points each): a Newton iteration costs
//! 0.71–0.76 ms on the 16-vertex stockinettes, 1.33–1.45 ms on the 32-vertex garters and ribs
//! and 2.49–2.64 ms on the 64-vertex seeds, linear in the tile's size; a solved evaluation
//! 0.21, 0.67–0.97 and 1.72–1.80 s (278–296, 503–698 and 651–722 Newton iterations). The seeds'
//! fits are the slowest because their tile is the largest. Since the samples at compression
//! nodes reuse the nodes' equilibria ([`sim_periodic::fit::objective`], same points, same
//! solved and failed counts): 241–258, 437–621 and 574–612 Newton iterations (11–17 % fewer
//! on every fabric), 0.19–0.20, 0.60–0.85 and 1.55–1.57 s (release, 2 cores, 2026-11-29).
//! With the supernodal factorization and the rank-one contact Hessian (345f92d; 12 points,
//! 2026-11-30, same hour): acrylic seed 1.530 → 1.253 ms per Newton iteration (32 vertices since
//! the seed's primitive tile), acrylic rib 1.811 → 1.364 ms and acrylic stockinette 0.864 →
//! 0.827 ms (these two "before" figures with the blocked solve of `Y` already in).
//! With the weft and warp compression nodes solved with the compression as a DOF (2fb7d16;
//! 10 points, `all`, 2026-11-30, the binary of 2acc5cf and of dc2c8dc run one after the other,
//! same solved and failed counts): Newton iterations per solved evaluation 25–33 % fewer on
//! every fabric (stockinettes 255 / 266 → 182 / 183, garters 457 / 630 → 338 / 424, ribs 577 /
//! 534 → 402 / 398, seeds 499 / 511 → 351 / 351; acrylic / babyredo), seconds per solved
//! evaluation 0.163 / 0.136 → 0.085 / 0.107, 0.390 / 0.584 → 0.285 / 0.364, 0.539 / 0.519 →
//! 0.377 / 0.463, 0.496 / 0.474 → 0.312 / 0.362, the whole run 32.9 → 23.7 s. Some of these
//! points end on other equilibria than before ([`sim_periodic::fit::objective`]'s *The
//! compression as a DOF*), so the iterations compare the same points, not the same states.
//!
//! Uniform points understate what a fit's swarm pays, about half on the acrylic seed
//! ([`sim_periodic::fit::objective`]'s cost paragraph: after its uniform initial population
//! the swarm's particles sit on the box's bounds, where the solves are harder); the
//! `yarn_fit` benchmark's swarm phase is the representative figure.

use std::time::Instant;

use bench::figures::yarn_fit::{
    RADIUS, fabrics, geometry_and_space, pattern_of, select, settings, shell_targets,
    with_fitted_geometry,
};
use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::{RngCore, SeedableRng};
use sim_periodic::fit::Objective;
use sim_periodic::periodic::YarnModel;

/// Seed of the evaluation points.
const POINTS_SEED: u64 = 2022;

fn main() -> anyhow::Result<()> {
    // `cargo bench` passes `--bench` (and the harness options) to the binary.
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut points = 10;
    let mut names = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--points" {
            let value = it
                .next()
                .ok_or_else(|| anyhow::anyhow!("--points needs a count"))?;
            points = value
                .parse()
                .map_err(|_| anyhow::anyhow!("--points: expected a count, found {value:?}"))?;
        } else if !a.starts_with("--") {
            names.push(a.clone());
        }
    }
    let (all, opts) = fabrics(false)?;
    let chosen = select(&all, &names)?;
    let swarm_objective = settings(false).swarm_objective;
    println!(
        "yarn-fit swarm objective at {points} fixed points of the box, {} threads",
        rayon::current_num_threads()
    );
    println!(
        "{:<26} {:>8} {:>6} {:>6} {:>10} {:>10} {:>10} {:>9} {:>8}",
        "fabric",
        "vertices",
        "solved",
        "failed",
        "s / solved",
        "s / failed",
        "its/solved",
        "ms / it",
        "total s"
    );
    for fabric in chosen {
        let targets = shell_targets(fabric, &opts)?;
        let pattern = pattern_of(&fabric.name)?;
        let base = YarnModel::default_for_radius(RADIUS);
        let (geometry, space) = geometry_and_space(pattern, &base, RADIUS)?;
        let space = with_fitted_geometry(space, pattern, RADIUS)?;
        let objective = Objective {
            geometry: &geometry,
            targets: &targets,
            settings: swarm_objective.clone(),
        };
        // The same points for every fabric and run: uniform in [0, 1) from a fixed seed.
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(POINTS_SEED);
        let (mut solved, mut failed) = ((0, 0.0, 0), (0, 0.0));
        for _ in 0..points {
            let x: Vec<f64> = (0..space.dim())
                .map(|_| (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
                .collect();
            let clock = Instant::now();
            let result = objective.evaluate_at(&space, &x);
            let seconds = clock.elapsed().as_secs_f64();
            match result {
                Ok(e) => {
                    solved.0 += 1;
                    solved.1 += seconds;
                    solved.2 += e.iterations;
                }
                Err(_) => {
                    failed.0 += 1;
                    failed.1 += seconds;
                }
            }
        }
        // A ratio, or "-" without evaluations to divide by.
        let per = |s: f64, n: usize, scale: f64, digits: usize| {
            if n > 0 {
                format!("{:.digits$}", scale * s / n as f64)
            } else {
                "-".to_string()
            }
        };
        println!(
            "{:<26} {:>8} {:>6} {:>6} {:>10} {:>10} {:>10} {:>9} {:>8.2}",
            fabric.name,
            geometry.n_vertices(),
            solved.0,
            failed.0,
            per(solved.1, solved.0, 1.0, 3),
            per(failed.1, failed.0, 1.0, 3),
            per(solved.2 as f64, solved.0, 1.0, 0),
            per(solved.1, solved.2, 1e3, 3),
            solved.1 + failed.1
        );
    }
    Ok(())
}
