//! `persistent-time-vs-error`: wall time of a whole rib-stretch run (settle + pull, see
//! `rib-stretch`) against the error of its force curve relative to a small-step,
//! tight-tolerance reference, sweeping the time step and the Newton tolerance.
//!
//! Error: RMS over the samples (every 1 mm of clamp travel) of the difference to the
//! reference pull, over the reference's largest pull. Each run settles with its own
//! settings, so the error covers the whole run, not only the pull.
//!
//! What it shows (measured): the error does not fall below tens of percent at any step, and
//! grows about linearly with dt. The likely cause (not isolated: a control run whose friction
//! never slips failed to converge at the reference step) is the anchored-spring friction of
//! Eq. 5: within a step a
//! sliding coordinate meets a spring force up to `k_f Δu`, far above the Coulomb bound `μλ`
//! once it slides more than `μλ/k_f` (nanometres to micrometres), so the friction — and the
//! pull — grow with the step (see `sim_persistent::forces::friction`).

use anyhow::Context;

use crate::plot::{LineChart, Series};
use crate::studies::persistent::{RibStretch, RibStretchRun, SwatchSettings};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "persistent-time-vs-error",
        title: "Persistent contacts: run time against rib-stretch force error",
        shows: "wall time of a settle-and-pull rib stretch against the RMS error of its force curve (relative to the reference's peak pull) vs a small-step, tight-tolerance reference; families: time step dt and Newton force tolerance",
        paper: "our study (no paper figure); the paper runs dt = 1 ms",
        guarded: false,
        run,
    }
}

/// (family, parameter) of a run.
#[derive(Clone, Copy)]
enum Family {
    Dt(f64),
    Tolerance(f64),
}

impl Family {
    fn index(self) -> f64 {
        match self {
            Family::Dt(_) => 0.0,
            Family::Tolerance(_) => 1.0,
        }
    }

    fn value(self) -> f64 {
        match self {
            Family::Dt(v) | Family::Tolerance(v) => v,
        }
    }
}

fn experiment(quick: bool, dt: f64, tol: f64) -> RibStretch {
    let settings = SwatchSettings {
        dt,
        newton_abs_tol: tol,
        ..SwatchSettings::default()
    };
    let (width, height, extension) = if quick { (4, 4, 8e-3) } else { (8, 6, 20e-3) };
    RibStretch {
        width,
        height,
        speed: 0.1,
        extension,
        // 1 mm of travel (10 ms at 0.1 m/s): a whole number of steps for every dt of the sweep.
        sample_every: 1e-3,
        settings,
    }
}

/// RMS of the force difference over the reference's largest |pull|.
fn error(run: &RibStretchRun, reference: &RibStretchRun) -> anyhow::Result<f64> {
    anyhow::ensure!(
        run.samples.len() == reference.samples.len(),
        "sample counts differ: {} vs {}",
        run.samples.len(),
        reference.samples.len()
    );
    let scale = reference
        .samples
        .iter()
        .map(|s| s.force.abs())
        .fold(0.0, f64::max);
    anyhow::ensure!(scale > 0.0, "the reference pull is zero");
    let sum: f64 = run
        .samples
        .iter()
        .zip(&reference.samples)
        .map(|(a, b)| (a.force - b.force).powi(2))
        .sum();
    Ok((sum / run.samples.len() as f64).sqrt() / scale)
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let q = ctx.quick;
    let (reference_dt, dts): (f64, Vec<f64>) = if q {
        (2.5e-4, vec![5e-4, 1e-3, 2e-3, 5e-3, 1e-2])
    } else {
        (1.25e-4, vec![2.5e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2])
    };
    let reference_tol = 1e-7;
    let tolerances = [1e-4, 1e-5, 1e-6];
    let mut runs: Vec<Family> = dts.iter().map(|&d| Family::Dt(d)).collect();
    runs.extend(tolerances.iter().map(|&t| Family::Tolerance(t)));
    let progress = ctx.progress(runs.len() as u64 + 1, "runs");
    let reference = experiment(q, reference_dt, reference_tol)
        .run()
        .context("reference run")?;
    progress.inc(1);
    let mut data = Table::new(&[
        "family",
        "parameter",
        "seconds",
        "rel_error",
        "newton_iterations",
        "dofs",
    ]);
    let mut points: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    let mut summary = vec![(
        "reference".to_string(),
        format!(
            "dt = {reference_dt} s, Newton |g| ≤ {reference_tol} N: {:.1} s, {} DoFs, peak pull {:.3e} N",
            reference.seconds,
            reference.dofs,
            reference
                .samples
                .iter()
                .map(|s| s.force.abs())
                .fold(0.0, f64::max)
        ),
    )];
    for family in runs {
        let (dt, tol) = match family {
            Family::Dt(dt) => (dt, 1e-7),
            Family::Tolerance(t) => (1e-3, t),
        };
        let result = experiment(q, dt, tol).run();
        progress.inc(1);
        let key = match family {
            Family::Dt(dt) => format!("dt = {:.4} ms", 1e3 * dt),
            Family::Tolerance(t) => format!("Newton |g| ≤ {t:.0e} N"),
        };
        match result {
            Ok(run) => {
                let e = error(&run, &reference)?;
                data.push_row([
                    family.index(),
                    family.value(),
                    run.seconds,
                    e,
                    run.newton_iterations as f64,
                    run.dofs as f64,
                ]);
                points[family.index() as usize].push((e.max(1e-12), run.seconds));
                summary.push((
                    key,
                    format!(
                        "{:.2} s, error {}, {} Newton iterations",
                        run.seconds,
                        crate::percent(e),
                        run.newton_iterations
                    ),
                ));
            }
            Err(err) => {
                // A setting that fails is a result of the study, not an error of the figure.
                summary.push((key, format!("failed: {err:#}")));
                data.push_row([family.index(), family.value(), f64::NAN, f64::NAN, 0.0, 0.0]);
            }
        }
    }
    let mut chart = LineChart::new("Rib stretch: time vs force error")
        .x_label("RMS force error / peak reference pull")
        .y_label("wall time (s)")
        .log_x()
        .log_y();
    for (k, name) in ["time step (Newton 1e-7 N)", "Newton tolerance (dt = 1 ms)"]
        .iter()
        .enumerate()
    {
        if !points[k].is_empty() {
            chart = chart.series(Series::line_markers(*name, points[k].clone()));
        }
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "experiment": "rib-stretch protocol (rib 2x2, settle 0.3 s, clamp 0.1 m/s)",
            "size": if q { "4x4" } else { "8x6" },
            "reference_dt_s": reference_dt, "reference_newton_abs_tol_n": reference_tol,
            "dts_s": dts, "tolerances_n": tolerances,
        }),
        data,
    })
}
