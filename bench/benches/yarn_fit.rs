//! One fabric's whole yarn-parameter fit in wall time (issue 15's speed goal: ≤ 5 min on 2
//! cores; the paper's average was 25 min on 256 cores).
//!
//! ```text
//! cargo bench -p bench --bench yarn_fit [-- FABRIC ... | all]
//! ```
//!
//! Runs the `yarn-fit` figure's pipeline ([`bench::figures::yarn_fit::fit_one`]: shell fit and
//! uniform targets, then the swarm and Levenberg–Marquardt with the figure's full-mode
//! settings) once per named fabric (default: the development fabric; `all`: every shared
//! fabric) and prints the shell and yarn fit times, the yarn fit's phases (swarm, then
//! local search) in seconds and in objective evaluations, the yarn fit's seconds per
//! evaluation, the final objective `g` and the comfort-range error, on the fit's own samples
//! and on the paper's even grid ([`bench::figures::yarn_fit::on_paper_grid`]). A fit is
//! minutes long and deterministic, so it is timed once, not sampled.

use bench::figures::yarn_fit::{fabrics, fit_one, select, settings};

fn main() -> anyhow::Result<()> {
    // `cargo bench` passes `--bench` (and the harness options) to the binary.
    let names: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let (all, opts) = fabrics(false)?;
    let chosen = select(&all, &names)?;
    let settings = settings(false);
    println!(
        "yarn fit, full-mode settings, {} threads (goal: ≤ 300 s per fabric)",
        rayon::current_num_threads()
    );
    println!(
        "{:<28} {:>9} {:>9} {:>9} {:>9} {:>7} {:>7} {:>9} {:>8} {:>8} {:>8}",
        "fabric",
        "shell s",
        "yarn s",
        "swarm s",
        "local s",
        "swarm",
        "local",
        "s / eval",
        "g",
        "comfort",
        "(paper)"
    );
    for fabric in chosen {
        let f = fit_one(fabric, &opts, &settings)?;
        let [swarm, local] = f.result.evaluations;
        let [swarm_s, local_s] = f.result.seconds;
        println!(
            "{:<28} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>7} {:>7} {:>9.3} {:>8.4} {:>7.1}% {:>7.1}%",
            f.name,
            f.shell_seconds,
            f.yarn_seconds,
            swarm_s,
            local_s,
            swarm,
            local,
            f.yarn_seconds / (swarm + local).max(1) as f64,
            f.result.evaluation.value,
            100.0 * f.result.evaluation.comfort_error,
            100.0 * f.paper_grid.comfort_error
        );
    }
    Ok(())
}
