//! `persistent-time-vs-error`: wall time of a rib-stretch pull (see `rib-stretch`) against
//! the error of its force curve relative to a small-step, tight-tolerance reference,
//! sweeping the time step (with the friction return mapping and with the paper's explicit
//! anchor update, the simulator's default), the Newton tolerance, and the time step of the
//! fast configuration (linearized implicit Euler, one Newton iteration per step, IC(0)-CG
//! at relative tolerance 1e-3, the diagonal shift warm-started from step to step, damped by
//! the line search and the material-length bound of `StepSettings::linearized_implicit_euler`:
//! what `examples/scaling.rs` times at 1 M DoFs), the same with every CG solve started from
//! the previous step's solution (`StepSettings::warm_started_cg`), the same at CG tolerance
//! 1e-2 (`examples/scaling.rs`'s `linear-ic-lag-2`, which halves the CG iterations of the 251 K
//! sweater), and the same at full length as seed 000's ref. 6 (no line search, no bound), so
//! that its speed is reported with its error.
//!
//! Every pull starts from one rib settled free at the reference settings, so the error is
//! that of the pull alone (earlier versions settled each run with its own step and folded
//! the differences between the settled swatches into the error). Error: RMS over the
//! samples (every 1 mm of clamp travel) of the difference to the reference pull, over the
//! reference's largest pull. Time: the pull only.
//!
//! Every run has the segment floor and the contact between adjacent loops, which the
//! return mapping needs (`sim_persistent::forces::segment_floor`), and yarn self-contact
//! (the default) but one family: the return-mapping time steps without it, which give the
//! contact's cost (its time against the same family with contact) and its effect (its
//! error against the reference, which has contact).
//!
//! Measurements of earlier runs, with the model they were made on, are in
//! `reports/persistent-time-vs-error/NOTES.md`; the current numbers in the manifest and
//! reports/README.md.

use anyhow::Context;

use crate::plot::{LineChart, Series};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};
use sim_persistent::experiment::{RibStretch, RibStretchRun, SwatchSettings};
use sim_persistent::integrator::StepSettings;

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "persistent-time-vs-error",
        title: "Persistent contacts: run time against rib-stretch force error",
        shows: "wall time of a rib-stretch pull (one shared settle, then a pull per setting) against the RMS error of its force curve (relative to the reference's peak pull) vs a small-step, tight-tolerance reference with Coulomb-consistent friction (return mapping); families: time step with the return mapping, time step with the paper's explicit anchor update, Newton force tolerance, time step with linearized steps and IC-CG (the fast configuration: one Newton iteration per step and re-solve, damped by the line search and a bound on segment shrinkage, shift warm-started), the same with warm-started CG, the same at CG tolerance 1e-2, the same at full length (ref. 6: no line search, no bound)",
        paper: "our study (no paper figure); the paper runs dt = 1 ms",
        guarded: false,
        run,
    }
}

/// (family, parameter) of a run.
#[derive(Clone, Copy)]
enum Family {
    /// Time step, friction return mapping.
    Dt(f64),
    /// [`Family::Dt`] without yarn self-contact (on by default): its cost and its effect.
    DtNoContact(f64),
    /// Time step, the paper's explicit anchor update (the simulator's default).
    DtExplicit(f64),
    /// Newton force tolerance at dt = 1 ms, return mapping.
    Tolerance(f64),
    /// Time step, linearized implicit Euler with IC(0)-CG (the fast configuration of
    /// `examples/scaling.rs`), return mapping.
    Linearized(f64),
    /// [`Family::Linearized`] with every CG solve started from the previous solution.
    LinearizedWarmCg(f64),
    /// [`Family::Linearized`] at CG tolerance [`LOOSE_CG_TOL`].
    LinearizedLooseCg(f64),
    /// [`Family::Linearized`] at full length, as seed 000's ref. 6 (no line search, no
    /// material-length bound: `SwatchSettings::linearized_full_steps`).
    LinearizedFull(f64),
}

/// Relative CG tolerance of the linearized family (scaling's `linear-ic-lag-3`).
const LINEARIZED_CG_TOL: f64 = 1e-3;

/// Relative CG tolerance of the loose-CG family (scaling's `linear-ic-lag-2`).
const LOOSE_CG_TOL: f64 = 1e-2;

/// The rib families' [`Family::index`] (the table's `family` code) and legend names; codes
/// 4, 5, 7, 9 and 11 are the garment study's.
const FAMILIES: [(usize, &str); 8] = [
    (0, "time step, implicit friction (return mapping)"),
    (12, "time step, implicit friction, no yarn self-contact"),
    (1, "time step, explicit anchor update (paper)"),
    (2, "Newton tolerance (dt = 1 ms, implicit friction)"),
    (3, "time step, linearized steps, IC-CG (implicit friction)"),
    (
        6,
        "time step, linearized, warm-started IC-CG (implicit friction)",
    ),
    (
        8,
        "time step, linearized at full length (ref. 6), IC-CG (implicit friction)",
    ),
    (
        10,
        "time step, linearized, IC-CG at tolerance 1e-2 (implicit friction)",
    ),
];

impl Family {
    fn index(self) -> usize {
        match self {
            Family::Dt(_) => 0,
            Family::DtNoContact(_) => 12,
            Family::DtExplicit(_) => 1,
            Family::Tolerance(_) => 2,
            Family::Linearized(_) => 3,
            Family::LinearizedWarmCg(_) => 6,
            Family::LinearizedFull(_) => 8,
            Family::LinearizedLooseCg(_) => 10,
        }
    }

    fn value(self) -> f64 {
        match self {
            Family::Dt(v)
            | Family::DtNoContact(v)
            | Family::DtExplicit(v)
            | Family::Tolerance(v)
            | Family::Linearized(v)
            | Family::LinearizedWarmCg(v)
            | Family::LinearizedLooseCg(v)
            | Family::LinearizedFull(v) => v,
        }
    }

    /// The pull settings of this run.
    fn settings(self, reference_tol: f64) -> SwatchSettings {
        let (dt, tol, return_mapping) = match self {
            Family::Dt(dt)
            | Family::DtNoContact(dt)
            | Family::Linearized(dt)
            | Family::LinearizedWarmCg(dt)
            | Family::LinearizedLooseCg(dt)
            | Family::LinearizedFull(dt) => (dt, reference_tol, true),
            Family::DtExplicit(dt) => (dt, reference_tol, false),
            Family::Tolerance(t) => (1e-3, t, true),
        };
        let mut s = settings(dt, tol, return_mapping);
        s.linearized_cg = self.linearized_cg_tolerance();
        s.cg_warm_start = matches!(self, Family::LinearizedWarmCg(_));
        s.linearized_full_steps = matches!(self, Family::LinearizedFull(_));
        s.forces.yarn_contact = !matches!(self, Family::DtNoContact(_));
        s
    }

    /// The relative CG tolerance of the linearized families (`None`: full Newton steps).
    fn linearized_cg_tolerance(self) -> Option<f64> {
        match self {
            Family::Linearized(_) | Family::LinearizedWarmCg(_) | Family::LinearizedFull(_) => {
                Some(LINEARIZED_CG_TOL)
            }
            Family::LinearizedLooseCg(_) => Some(LOOSE_CG_TOL),
            Family::Dt(_)
            | Family::DtNoContact(_)
            | Family::DtExplicit(_)
            | Family::Tolerance(_) => None,
        }
    }

    fn key(self) -> String {
        match self {
            Family::Dt(dt) => format!("dt = {:.4} ms, return mapping", 1e3 * dt),
            Family::DtNoContact(dt) => {
                format!("dt = {:.4} ms, return mapping, no yarn contact", 1e3 * dt)
            }
            Family::DtExplicit(dt) => format!("dt = {:.4} ms, explicit anchors", 1e3 * dt),
            Family::Tolerance(t) => format!("Newton |g| ≤ {t:.0e} N"),
            Family::Linearized(dt) => format!("dt = {:.4} ms, linearized, IC-CG", 1e3 * dt),
            Family::LinearizedWarmCg(dt) => {
                format!("dt = {:.4} ms, linearized, warm-started IC-CG", 1e3 * dt)
            }
            Family::LinearizedFull(dt) => {
                format!("dt = {:.4} ms, linearized at full length, IC-CG", 1e3 * dt)
            }
            Family::LinearizedLooseCg(dt) => {
                format!("dt = {:.4} ms, linearized, IC-CG at 1e-2", 1e3 * dt)
            }
        }
    }
}

fn settings(dt: f64, tol: f64, return_mapping: bool) -> SwatchSettings {
    let mut s = SwatchSettings {
        dt,
        newton_abs_tol: tol,
        ..SwatchSettings::default()
    };
    // Coulomb-consistent friction lets yarns slide freely through uncompressed contacts:
    // contact between adjacent loops keeps narrowing loops from passing through each other
    // (the segment floor, on by default, keeps draining segments from collapsing; see
    // sim_persistent::forces::friction).
    s.forces.loop_contact = true;
    s.friction_return_mapping = if return_mapping {
        StepSettings::RETURN_MAPPING_RESOLVES
    } else {
        0
    };
    s
}

fn experiment(quick: bool, settings: SwatchSettings) -> RibStretch {
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
    runs.extend(dts.iter().map(|&d| Family::DtNoContact(d)));
    runs.extend(dts.iter().map(|&d| Family::DtExplicit(d)));
    runs.extend(tolerances.iter().map(|&t| Family::Tolerance(t)));
    runs.extend(dts.iter().map(|&d| Family::Linearized(d)));
    runs.extend(dts.iter().map(|&d| Family::LinearizedWarmCg(d)));
    runs.extend(dts.iter().map(|&d| Family::LinearizedLooseCg(d)));
    runs.extend(dts.iter().map(|&d| Family::LinearizedFull(d)));
    let progress = ctx.progress(runs.len() as u64 + 2, "runs");
    let reference_settings = settings(reference_dt, reference_tol, true);
    // The settle uses the simulator's default (explicit) friction update.
    let protocol = experiment(q, settings(reference_dt, reference_tol, false));
    let settled = protocol
        .settle()
        .context("settling the rib (reference settings)")?;
    progress.inc(1);
    let reference = protocol
        .pull(&settled, &reference_settings)
        .context("reference pull")?;
    progress.inc(1);
    let mut data = Table::new(&[
        "family",
        "parameter",
        "seconds",
        "error",
        "newton_iterations",
        "dofs",
    ]);
    let mut points: [Vec<(f64, f64)>; 13] = Default::default();
    let mut summary = vec![
        (
            "settle (shared)".to_string(),
            format!(
                "dt = {reference_dt} s, Newton |g| ≤ {reference_tol} N: {:.1} s, {} Newton iterations, width ratio {:.3}",
                settled.seconds, settled.newton_iterations, settled.width_ratio
            ),
        ),
        (
            "reference pull".to_string(),
            format!(
                "dt = {reference_dt} s, Newton |g| ≤ {reference_tol} N, return mapping: {:.1} s, {} DoFs, peak pull {:.3e} N",
                reference.seconds,
                reference.dofs,
                reference
                    .samples
                    .iter()
                    .map(|s| s.force.abs())
                    .fold(0.0, f64::max)
            ),
        ),
    ];
    for family in runs {
        let result = protocol.pull(&settled, &family.settings(reference_tol));
        progress.inc(1);
        let key = family.key();
        match result {
            Ok(run) => {
                let e = error(&run, &reference)?;
                data.push_row([
                    family.index() as f64,
                    family.value(),
                    run.seconds,
                    e,
                    run.newton_iterations as f64,
                    run.dofs as f64,
                ]);
                points[family.index()].push((e.max(1e-12), run.seconds));
                summary.push((
                    key,
                    format!(
                        "{:.2} s, error {}, {} Newton iterations, {} steps with an unresolved return mapping",
                        run.seconds,
                        crate::percent(e),
                        run.newton_iterations,
                        run.friction_unresolved
                    ),
                ));
            }
            Err(err) => {
                // A setting that fails is a result of the study, not an error of the figure.
                summary.push((key, format!("failed: {err:#}")));
                data.push_row([
                    family.index() as f64,
                    family.value(),
                    f64::NAN,
                    f64::NAN,
                    0.0,
                    0.0,
                ]);
            }
        }
    }
    let mut chart = LineChart::new("Rib stretch: time vs force error")
        .x_label("RMS force error / peak reference pull")
        .y_label("wall time (s)")
        .log_x()
        .log_y();
    for &(family, name) in &FAMILIES {
        if !points[family].is_empty() {
            chart = chart.series(Series::line_markers(name, points[family].clone()));
        }
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    garment_study(ctx, &mut data, &mut summary)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "experiment": "rib-stretch protocol (rib 2x2, one settle of 0.3 s at the reference settings, then a pull at 0.1 m/s per run)",
            "size": if q { "4x4" } else { "8x6" },
            "reference_dt_s": reference_dt, "reference_newton_abs_tol_n": reference_tol,
            "dts_s": dts, "tolerances_n": tolerances,
            "linearized": {"cg_relative_tolerance": LINEARIZED_CG_TOL, "preconditioner": "IC(0)", "shift": "warm-started", "max_material_shrink": sim_persistent::integrator::LINEARIZED_MAX_SHRINK, "warm_started_cg_family": 6, "full_length_family": 8, "loose_cg_family": 10, "loose_cg_relative_tolerance": LOOSE_CG_TOL},
            "garment": {"hat": if q { "hat_chart(8, 4, 2, 4)" } else { "hat_chart(8, 6, 3, 6)" }, "time_s": GARMENT_TIME, "reference_dt_s": GARMENT_REFERENCE_DT, "dts_s": GARMENT_DTS},
        }),
        data,
    })
}

/// Simulated time (s) of the garment runs: the first stage of dressing (the wrapping ramp
/// contracts the hat onto the head).
const GARMENT_TIME: f64 = 0.05;

/// Time step (s) of the garment reference (full Newton, Cholesky).
const GARMENT_REFERENCE_DT: f64 = 1.25e-4;

/// Time steps (s) of the garment runs.
const GARMENT_DTS: [f64; 3] = [5e-4, 1e-3, 2e-3];

/// The same study on a garment: a hat knitted in the round dressed on a head mesh
/// (`sim_persistent::experiment::garment`, the `garment` figure's scene, smaller), simulated
/// for [`GARMENT_TIME`] with full Newton (Cholesky, the default) and with linearized steps and
/// IC-CG (the fast configuration), with and without warm-started CG, at CG tolerance
/// [`LOOSE_CG_TOL`], and at full length (ref. 6), at each of [`GARMENT_DTS`]. Error: RMS
/// over the nodes of the distance to the reference's node positions at the end, in yarn
/// radii. Rows of family 4 (full Newton), 5 (linearized), 7 (linearized, warm-started CG),
/// 9 (linearized at full length) and 11 (linearized, CG at [`LOOSE_CG_TOL`]) in the table,
/// their `error` column in yarn radii (the rib families 0–3, 6, 8 and 10 hold the relative
/// force error there); chart `…-garment`.
fn garment_study(
    ctx: &FigureContext,
    data: &mut Table,
    summary: &mut Vec<(String, String)>,
) -> anyhow::Result<()> {
    use sim_persistent::experiment::garment::{Dressing, hat_chart, head_for_hat};
    use sim_persistent::experiment::positions;
    let (sectors, width, brim, body) = if ctx.quick {
        (8, 4, 2, 4)
    } else {
        (8, 6, 3, 6)
    };
    let chart = hat_chart(sectors, width, brim, body)?;
    let profile = head_for_hat(sectors * width);
    type Run = (Vec<rod::geometry::V3>, f64, usize, f64, usize);
    /// Full Newton, linearized IC-CG, linearized with warm-started CG, linearized at full
    /// length (ref. 6).
    #[derive(Clone, Copy, PartialEq)]
    enum Method {
        Newton,
        Linearized,
        LinearizedWarmCg,
        LinearizedFull,
        LinearizedLooseCg,
    }
    let simulate = |dt: f64, method: Method| -> anyhow::Result<Run> {
        let mut settings = StepSettings {
            dt,
            rayleigh_alpha: 10.0,
            rayleigh_beta: 0.01,
            ..StepSettings::default()
        };
        if method == Method::LinearizedLooseCg {
            settings = settings.linearized_ic_cg(LOOSE_CG_TOL);
        } else if method != Method::Newton {
            settings = settings.linearized_ic_cg(LINEARIZED_CG_TOL);
        }
        if method == Method::LinearizedWarmCg {
            settings = settings.warm_started_cg();
        }
        if method == Method::LinearizedFull {
            settings = settings.at_full_length();
        }
        let mut d = Dressing::new(&chart, &profile, 48, settings)?;
        let steps = (GARMENT_TIME / dt).round() as usize;
        let start = std::time::Instant::now();
        let iterations = d.run(steps)?;
        let seconds = start.elapsed().as_secs_f64();
        let r = d.params.radius;
        Ok((
            positions(&d.sim),
            seconds,
            iterations,
            d.lowest_gap() / r,
            d.sim.dofs().n_dofs(),
        ))
    };
    let (reference, reference_seconds, reference_iterations, _, _) =
        simulate(GARMENT_REFERENCE_DT, Method::Newton).context("garment reference")?;
    let r = sim_persistent::params::YarnParams::sweater().radius;
    summary.push((
        "garment reference".into(),
        format!(
            "hat of {} loops around on a head, {} nodes, {GARMENT_TIME} s at dt = {GARMENT_REFERENCE_DT} s, full Newton: {reference_seconds:.1} s, {reference_iterations} Newton iterations",
            sectors * width,
            reference.len()
        ),
    ));
    const METHODS: [(Method, f64, &str); 5] = [
        (Method::Newton, 4.0, "full Newton, Cholesky"),
        (Method::Linearized, 5.0, "linearized steps, IC-CG"),
        (
            Method::LinearizedWarmCg,
            7.0,
            "linearized steps, warm-started IC-CG",
        ),
        (
            Method::LinearizedFull,
            9.0,
            "linearized steps at full length (ref. 6), IC-CG",
        ),
        (
            Method::LinearizedLooseCg,
            11.0,
            "linearized steps, IC-CG at 1e-2",
        ),
    ];
    let mut points: [Vec<(f64, f64)>; 5] = Default::default();
    for (k, &(method, family, label)) in METHODS.iter().enumerate() {
        for dt in GARMENT_DTS {
            let name = format!("garment, dt = {:.2} ms, {label}", 1e3 * dt);
            match simulate(dt, method) {
                Ok((p, seconds, iterations, gap, dofs)) => {
                    let rms = (p
                        .iter()
                        .zip(&reference)
                        .map(|(a, b)| (a - b).norm_squared())
                        .sum::<f64>()
                        / p.len() as f64)
                        .sqrt()
                        / r;
                    data.push_row([family, dt, seconds, rms, iterations as f64, dofs as f64]);
                    points[k].push((rms.max(1e-12), seconds));
                    summary.push((
                        name,
                        format!(
                            "{seconds:.2} s, RMS node error {rms:.3e} R, {iterations} Newton iterations, lowest gap {gap:+.3} R"
                        ),
                    ));
                }
                Err(err) => {
                    data.push_row([family, dt, f64::NAN, f64::NAN, 0.0, 0.0]);
                    summary.push((name, format!("failed: {err:#}")));
                }
            }
        }
    }
    let mut chart = LineChart::new("Hat dressed on a head: time vs position error")
        .x_label("RMS node position error after 0.05 s (R)")
        .y_label("wall time (s)")
        .log_x()
        .log_y();
    for (k, &(_, _, label)) in METHODS.iter().enumerate() {
        if !points[k].is_empty() {
            chart = chart.series(Series::line_markers(label, points[k].clone()));
        }
    }
    chart.save(&ctx.out_dir, &format!("{}-garment", ctx.name))?;
    Ok(())
}
