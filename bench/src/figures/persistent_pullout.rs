//! `pullout` (seed 000 §5.2.4, Fig. 13): one row's yarn pulled out of a garter whose edges are
//! pinned (`sim_persistent::experiment::pullout`). The yarn slides through its stitches; the
//! stitch contacts its free end leaves break (the nodes lose the yarn's sliding coordinate)
//! and the simulation continues on the new topology. Plotted: the pull force against the
//! pulled length, with the passes of the yarn still in the fabric; rendered: the swatch at
//! four stages of the pull.

use sim_persistent::experiment::PullOut;

use crate::plot::{LineChart, Series, save_images};
use crate::studies::persistent::render;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "pullout",
        title: "Yarn pull-out",
        shows: "pull force (mN) and passes of the pulled yarn still in the fabric against the pulled length (mm), the middle row of a garter with pinned edges pulled at 5 cm/s; renderings of the unravelling (pullout-images.png)",
        paper: "seed 000 Fig. 13: a single row pulled out of the fabric unravels its stitches, with non-linear plastic effects (no force curve published)",
        guarded: false,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let (w, h, distance) = if ctx.quick {
        (5, 5, 0.004)
    } else {
        (8, 7, 0.04)
    };
    let mut test = PullOut::garter(w, h, distance)?;
    test.snapshots = vec![0.0, distance / 3.0, 2.0 * distance / 3.0, distance];
    let start = std::time::Instant::now();
    let run = test.run()?;
    if let Some(f) = &run.failure {
        anyhow::bail!("the pull failed: {f}");
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut data = Table::new(&["pulled_mm", "force_mN", "passes", "stitch_contacts"]);
    for s in &run.samples {
        data.push_row([
            1e3 * s.pulled,
            1e3 * s.force,
            s.passes as f64,
            s.contacts as f64,
        ]);
    }
    let pulled = data.column("pulled_mm").expect("column");
    let force = data.column("force_mN").expect("column");
    let passes = data.column("passes").expect("column");
    LineChart::new(format!("Pull-out of the middle row of a {w} × {h} garter"))
        .x_label("pulled length (mm)")
        .y_label("pull force (mN); passes of the yarn in the fabric")
        .series(Series::line(
            "pull force (mN)",
            pulled.iter().copied().zip(force.iter().copied()),
        ))
        .series(Series::line(
            "passes still in the fabric",
            pulled.iter().copied().zip(passes.iter().copied()),
        ))
        .save(&ctx.out_dir, ctx.name)?;
    let radius = test.settings.params.radius;
    let mut images = Vec::new();
    for (d, sim) in &run.snapshots {
        let image = render(sim, radius, (420, 360), [0.0, 0.0, -1.0], [0.0, 1.0, 0.0])?;
        images.push((format!("pulled {:.1} mm", 1e3 * d), image.image));
    }
    let panels: Vec<(&str, &yarn_output::render::Image)> =
        images.iter().map(|(t, i)| (t.as_str(), i)).collect();
    save_images(&panels, &ctx.out_dir, &format!("{}-images", ctx.name))?;
    let first = run.samples.first().copied();
    let last = run.samples.last().copied();
    let peak = run
        .samples
        .iter()
        .map(|s| s.force)
        .fold(f64::NEG_INFINITY, f64::max);
    let (Some(first), Some(last)) = (first, last) else {
        anyhow::bail!("the pull produced no samples");
    };
    let summary = vec![
        (
            format!(
                "{w} × {h} garter, row {} pulled {:.0} mm at 5 cm/s",
                test.row,
                1e3 * distance
            ),
            format!(
                "{} passes left their nodes while settling, {} during the pull ({} → {} passes of the yarn, {} → {} stitch contacts){}; {} Newton iterations, {seconds:.1} s",
                run.broken_settling,
                run.broken,
                first.passes,
                last.passes,
                first.contacts,
                last.contacts,
                run.out_at
                    .map(|d| format!("; the yarn is out at {:.1} mm", 1e3 * d))
                    .unwrap_or_default(),
                run.newton_iterations,
            ),
        ),
        (
            "pull force".into(),
            format!(
                "peak {:.2} mN, at the end {:.2} mN",
                1e3 * peak,
                1e3 * last.force
            ),
        ),
    ];
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "pattern": format!("garter {w}x{h}, one yarn per row, pulled row {}", test.row),
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width 3 mm, no gravity",
            "pins": "cast-on, bind-off and side columns, except the nodes of the pulled yarn; the handle is driven",
            "speed_m_per_s": test.speed, "distance_m": distance, "handle_m": test.handle,
            "dt_s": test.settings.dt, "settle_time_s": test.settings.settle_time,
            "friction": "return mapping, at most 5 re-solves a step; loop contact on",
            "newton_abs_tol_N": test.settings.newton_abs_tol,
        }),
        data,
    })
}
