//! `plasticity` (seed 000 §4.5, Fig. 9): a small garter swatch is stretched side to side in
//! cycles of growing amplitude and released each time; where inter-yarn friction cannot hold
//! the yarns, they slide and the swatch keeps a residual deformation. A control run with
//! friction that never slips (a slip force far above any contact force) shows what is
//! elastic: its residual stays near zero.

use sim_persistent::chart::Chart;

use crate::plot::{LineChart, Series, save_side_by_side};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};
use sim_persistent::experiment::{Cycles, CyclesRun, SwatchSettings};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "plasticity",
        title: "Plasticity: residual deformation after over-stretch",
        shows: "pull (N) on the driven side clamp of a settled garter swatch against clamp travel (mm) over loading–unloading cycles of growing amplitude with sliding friction; residual travel at zero pull against the cycle amplitude, with sliding friction and with friction that never slips (control)",
        paper: "seed 000 Fig. 9: over-stretched until friction cannot prevent sliding, the released fabric keeps a plastic deformation",
        guarded: false,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let (w, h, amplitudes): (usize, usize, Vec<f64>) = if ctx.quick {
        (6, 5, vec![4e-3, 8e-3, 12e-3])
    } else {
        (10, 9, (1..=6).map(|k| 4e-3 * k as f64).collect())
    };
    let chart = Chart::garter(w, h)?;
    let base = SwatchSettings::default();
    let mut sticky = base.clone();
    // Far above any contact force of this swatch (≈ mN): the anchors never move.
    sticky.params.friction_max_force = Some(1e3);
    let variants = [("sliding friction", base), ("no slip (control)", sticky)];
    let progress = ctx.progress(variants.len() as u64, "cycle tests");
    let runs: Vec<anyhow::Result<CyclesRun>> = std::thread::scope(|scope| {
        let handles: Vec<_> = variants
            .iter()
            .map(|(_, settings)| {
                let test = Cycles {
                    chart: chart.clone(),
                    speed: 0.05,
                    amplitudes: amplitudes.clone(),
                    settings: settings.clone(),
                };
                let progress = &progress;
                scope.spawn(move || {
                    let r = test.run();
                    progress.inc(1);
                    r
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("cycle thread panicked"))
            .collect()
    });
    let mut data = Table::new(&["variant", "cycle", "travel_m", "force_n", "max_slide_m"]);
    let mut loops = LineChart::new("Loading and unloading (sliding friction)")
        .x_label("clamp travel (mm)")
        .y_label("pull on the side clamp (N)");
    let mut residual_chart = LineChart::new("Residual deformation")
        .x_label("cycle amplitude (mm)")
        .y_label("travel at zero pull after release (mm)");
    let mut summary = Vec::new();
    for (v, ((name, _), result)) in variants.iter().zip(runs).enumerate() {
        let result = result.map_err(|e| e.context(format!("variant {name}")))?;
        for s in &result.samples {
            data.push_row([v as f64, s.cycle as f64, s.travel, s.force, s.max_slide]);
        }
        // The control's pull grows ~30× larger (the yarns stretch instead of sliding), so
        // the loops panel shows the sliding run only; the control is in the data table.
        if v == 0 {
            loops = loops.series(Series::line(
                *name,
                result.samples.iter().map(|s| (1e3 * s.travel, s.force)),
            ));
        }
        let peak = result.samples.iter().map(|s| s.force).fold(0.0, f64::max);
        residual_chart = residual_chart.series(Series::line_markers(
            *name,
            result.residuals.iter().map(|(a, r, _)| (1e3 * a, 1e3 * r)),
        ));
        summary.push((
            format!("{name}: residual travel per amplitude"),
            result
                .residuals
                .iter()
                .map(|(a, r, _)| format!("{:.0} mm → {:.2} mm", 1e3 * a, 1e3 * r))
                .collect::<Vec<_>>()
                .join(", "),
        ));
        let (_, _, slide) = result.residuals.last().copied().unwrap_or_default();
        summary.push((
            format!("{name}: slips, largest slide at the last turn"),
            format!(
                "{} slips, {:.3} mm (clamp distance {:.1} mm), peak pull {peak:.3} N",
                result.slipped,
                1e3 * slide,
                1e3 * result.clamp_distance
            ),
        ));
    }
    save_side_by_side(&loops, &residual_chart, &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "pattern": format!("garter {w}x{h}"), "amplitudes_m": amplitudes,
            "clamp_speed_m_per_s": 0.05,
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width 3 mm, no gravity",
            "control": "friction_max_force = Some(1e3 N) (constant slip force instead of μλ)",
        }),
        data,
    })
}
