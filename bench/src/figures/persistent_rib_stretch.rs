//! `rib-stretch` (seed 000 §5.2.3, Fig. 11): the pull on one side of a 2 × 2 rib swatch
//! against the side-to-side distance, with the elastic energy of each force term beside it,
//! so the regimes (ridges flattened against stitch wrapping, loops bent, yarns stretched) are
//! read off the shares rather than guessed.
//!
//! Protocol ([`crate::studies::persistent::RibStretch`]): the rib settles free from its flat
//! layout (it compresses in width), then its first and last columns are clamped where they
//! settled and the right clamp is driven away at a constant speed, slow against the swatch's
//! dynamics, with implicit Euler at dt = 1 ms. The force is the moving clamp's pull.
//!
//! **Caveat, measured.** The figure uses the paper's explicit friction update, under which
//! friction acts as a viscous brake of coefficient ≈ `k_f dt` on sliding
//! (`sim_persistent::forces::friction`). The pull therefore depends on the step: a 4 × 4
//! rib pulled 8 mm gives 2.7, 0.88, 0.38 and 0.10 N at 1, 0.25, 0.1 and 0.025 ms, and
//! 4–5 mN at every one of these steps with Coulomb-consistent friction (the return
//! mapping; `friction_dt` example). The regimes this figure shows are those of the paper's
//! model at its 1 ms step, not a step-converged response.

use crate::plot::{LineChart, Series, save_side_by_side};
use crate::studies::persistent::{RibStretch, RibStretchRun, SwatchSettings, kind_name};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "rib-stretch",
        title: "Rib stretch: force and per-term energy against side-to-side distance",
        shows: "pull (N) on the driven side clamp of a settled 2×2 rib swatch against the distance between the clamps (mm), and each force term's share of the elastic energy along the same axis",
        paper: "seed 000 Fig. 11: strongly nonlinear, three regimes (wrapping, bending, stretching); their swatch is larger (≈0.35 N at 0.14 m), ours is a few stitches, so only the shape compares",
        guarded: true,
        run,
    }
}

/// The experiment of the figure (quick: 8 × 4 stitches; full: 16 × 10).
pub fn experiment(quick: bool) -> RibStretch {
    let (width, height, extension) = if quick {
        (8, 4, 24e-3)
    } else {
        (16, 10, 48e-3)
    };
    RibStretch {
        width,
        height,
        speed: 0.1,
        extension,
        sample_every: 0.5e-3,
        settings: SwatchSettings::default(),
    }
}

/// The energy-share chart and data columns of a run: the term kinds present, in order.
pub fn kinds(run: &RibStretchRun) -> Vec<sim_persistent::forces::TermKind> {
    let mut kinds: Vec<_> = run
        .samples
        .iter()
        .flat_map(|s| s.energies.iter().map(|(k, _)| *k))
        .collect();
    kinds.sort();
    kinds.dedup();
    kinds
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let experiment = experiment(ctx.quick);
    let progress = ctx.progress(1, "settle and pull");
    let result = experiment.run()?;
    progress.inc(1);
    let kinds = kinds(&result);
    let mut columns = vec![
        "extension_m".to_string(),
        "distance_m".to_string(),
        "force_n".to_string(),
    ];
    columns.extend(kinds.iter().map(|k| format!("energy_{}_j", kind_name(*k))));
    let mut data = Table::new(&columns);
    let energy = |s: &crate::studies::persistent::StretchSample, k| {
        s.energies
            .iter()
            .find(|(kind, _)| *kind == k)
            .map_or(0.0, |(_, e)| *e)
    };
    for s in &result.samples {
        let mut row = vec![s.extension, s.distance, s.force];
        row.extend(kinds.iter().map(|&k| energy(s, k)));
        data.push_row(row);
    }
    let mm = |s: &crate::studies::persistent::StretchSample| 1e3 * s.distance;
    let force = LineChart::new("Rib stretch")
        .x_label("side-to-side distance (mm)")
        .y_label("pull on the side clamp (N)")
        .series(Series::line_markers(
            "force",
            result.samples.iter().map(|s| (mm(s), s.force)),
        ));
    // What opposes the stretch: each term's share of the elastic energy stored over a
    // sliding window of the pull (terms that release energy count as zero).
    let window = 2;
    let marginal: Vec<(f64, Vec<f64>)> = result
        .samples
        .windows(window + 1)
        .map(|w| {
            let (a, b) = (&w[0], &w[window]);
            let gains: Vec<f64> = kinds
                .iter()
                .map(|&k| (energy(b, k) - energy(a, k)).max(0.0))
                .collect();
            let total: f64 = gains.iter().sum();
            let shares = gains
                .iter()
                .map(|g| if total > 0.0 { g / total } else { 0.0 })
                .collect();
            (0.5 * (mm(a) + mm(b)), shares)
        })
        .collect();
    let mut shares = LineChart::new("Share of the energy stored over each 1 mm of pull")
        .x_label("side-to-side distance (mm)")
        .y_label("fraction");
    for (j, &k) in kinds.iter().enumerate() {
        shares = shares.series(Series::line(
            kind_name(k),
            marginal.iter().map(|(d, sh)| (*d, sh[j])),
        ));
    }
    save_side_by_side(&force, &shares, &ctx.out_dir, ctx.name)?;

    // The dominant term along the pull, as runs of windows.
    let mut regimes: Vec<(String, f64, f64)> = Vec::new();
    for (d, sh) in &marginal {
        let Some((j, _)) = sh
            .iter()
            .enumerate()
            .filter(|(_, v)| **v > 0.0)
            .max_by(|a, b| a.1.total_cmp(b.1))
        else {
            continue;
        };
        let name = kind_name(kinds[j]);
        match regimes.last_mut() {
            Some((last, _, end)) if *last == name => *end = *d,
            _ => regimes.push((name, *d, *d)),
        }
    }
    let first = &result.samples[0];
    let last = result.samples.last().expect("at least the start sample");
    let slipped: usize = result.samples.iter().map(|s| s.slipped).sum();
    let mut summary = vec![
        (
            "settled width / laid-out width".to_string(),
            format!("{:.3}", result.settled_width_ratio),
        ),
        (
            "distance at start, end of pull".to_string(),
            format!("{:.1} mm, {:.1} mm", mm(first), mm(last)),
        ),
        (
            "pull at start, end".to_string(),
            format!("{:.3e} N, {:.3e} N", first.force, last.force),
        ),
        (
            "dominant share of the stored energy along the pull (window centres)".to_string(),
            regimes
                .iter()
                .map(|(n, a, b)| format!("{n} {a:.1}–{b:.1} mm"))
                .collect::<Vec<_>>()
                .join(", "),
        ),
        (
            "sliding coordinates slipped (sum)".to_string(),
            slipped.to_string(),
        ),
        (
            "run".to_string(),
            format!(
                "{} DoFs, {} pull steps, {} Newton iterations, {:.1} s",
                result.dofs, result.steps, result.newton_iterations, result.seconds
            ),
        ),
    ];
    if let Some(stiff) = stiffness_ratio(&result) {
        summary.push((
            "stiffness last fifth / first fifth of the pull".to_string(),
            format!("{stiff:.1}"),
        ));
    }
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "pattern": "rib 2x2", "width": experiment.width, "height": experiment.height,
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width 3 mm, no gravity",
            "damping_alpha": crate::studies::persistent::ALPHA,
            "dt_s": experiment.settings.dt, "settle_time_s": experiment.settings.settle_time,
            "clamp_speed_m_per_s": experiment.speed, "extension_m": experiment.extension,
            "newton_abs_tol_n": experiment.settings.newton_abs_tol,
        }),
        data,
    })
}

/// Secant stiffness of the last fifth of the samples over that of the first fifth.
fn stiffness_ratio(run: &RibStretchRun) -> Option<f64> {
    let s = &run.samples;
    let n = s.len();
    let k = (n / 5).max(1);
    if n < 2 * k + 1 {
        return None;
    }
    let slope = |a: usize, b: usize| (s[b].force - s[a].force) / (s[b].distance - s[a].distance);
    let (early, late) = (slope(0, k), slope(n - 1 - k, n - 1));
    (early.abs() > 0.0).then(|| late / early)
}
