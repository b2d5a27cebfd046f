//! `garment` (issue 18; seed 000 Fig. 1 and §5.3 dress a character in a knitted sweater): a
//! hat knitted in the round from a chart (2 × 2 rib brim, stockinette, a crown narrowing in
//! eight decrease lines) dressed on a head mesh (an ellipsoid on a neck, a surface of
//! revolution, `sim_persistent::experiment::garment`). The hat is laid out around the head
//! with 1 mm clearance; gravity and the wrapping rest angles that ramp in over 0.1 s (the
//! knit contracts) pull it onto the head, where the frictionless mesh contact of the nodes
//! and segment midpoints holds it. Plotted: the lowest gap between yarn and head, the hat's
//! top and bottom heights and its kinetic energy against time; rendered: the laid-out and the
//! dressed hat (front and from above); written: PNG frames every 0.1 s and the last frame as
//! USD (yarns and head) in `frames/`.

use sim_persistent::experiment::garment::{Dressing, LOOP_WIDTH, hat_chart, head_for_hat};
use sim_persistent::experiment::positions;
use sim_persistent::integrator::StepSettings;
use sim_persistent::output::{Format, FrameWriter, OutputSpec, View};

use crate::plot::{LineChart, Series, save_images};
use crate::studies::persistent::render;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "garment",
        title: "A hat knitted in the round, dressed on a head mesh",
        shows: "lowest yarn–head gap (R), hat top and bottom heights (mm) and kinetic energy against time of a hat (rib brim, stockinette, 8-line crown) knitted in the round and dressed on a head mesh (Table 1 sweater yarn, dt = 1 ms); renderings before and after (garment-images.png); PNG frames and a USD frame with the head (frames/)",
        paper: "seed 000 Fig. 1 / §5.3: garments knitted from stitch charts on characters (a 56 K-loop sweater); here a hat, with mesh obstacles",
        guarded: false,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    // (sectors, sector width, brim rounds, body rounds, simulated time)
    let (sectors, width, brim, body, duration) = if ctx.quick {
        (8, 4, 2, 4, 0.1)
    } else {
        (8, 8, 6, 12, 0.6)
    };
    let chart = hat_chart(sectors, width, brim, body)?;
    // A head whose width is 0.8 of the laid-out hat's radius: the knit contracts onto it.
    let radius = (sectors * width) as f64 * LOOP_WIDTH / std::f64::consts::TAU;
    let (a, b, c) = (0.8 * radius, 0.9 * radius, 0.85 * radius);
    let profile = head_for_hat(sectors * width);
    let settings = StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    };
    let dt = settings.dt;
    let built = std::time::Instant::now();
    let mut dressing = Dressing::new(&chart, &profile, 64, settings)?;
    let build_seconds = built.elapsed().as_secs_f64();
    let r = dressing.params.radius;
    let (n_nodes, n_dofs) = (
        dressing.sim.topology().nodes.len(),
        dressing.sim.dofs().n_dofs(),
    );
    let loops: usize = (0..chart.height()).map(|k| chart.loops_made(k)).sum();
    let triangles = dressing.body.triangles().len();
    let steps = (duration / dt).round() as usize;
    let sample_every = (steps / 60).max(1);
    let frame_every = (0.1 / dt).round() as usize;
    let frames_dir = ctx.out_dir.join("frames");
    std::fs::create_dir_all(&frames_dir)?;
    let png = OutputSpec {
        formats: vec![Format::Png],
        png_size: [480, 480],
        view: View::Front,
        supersample: 2,
        ..OutputSpec::default()
    };
    let mut frames = FrameWriter::new(&frames_dir, &png, r, frame_every as f64 * dt)?;
    frames.write(&dressing.sim)?;
    let view_front = [0.0, 0.0, -1.0];
    let view_top = [0.3, -1.0, -0.5];
    let laid_out = render(&dressing.sim, r, (480, 480), view_front, [0.0, 1.0, 0.0])?;
    let extent = |d: &Dressing| {
        let p = positions(&d.sim);
        let top = p.iter().map(|x| x.y).fold(f64::NEG_INFINITY, f64::max);
        let bottom = p.iter().map(|x| x.y).fold(f64::INFINITY, f64::min);
        (1e3 * top, 1e3 * bottom)
    };
    let mut data = Table::new(&[
        "time_s",
        "lowest_gap_R",
        "top_mm",
        "bottom_mm",
        "kinetic_energy_J",
    ]);
    let sample = |d: &Dressing, data: &mut Table| {
        let (top, bottom) = extent(d);
        data.push_row([
            d.sim.time(),
            d.lowest_gap() / r,
            top,
            bottom,
            d.sim.kinetic_energy(),
        ]);
    };
    sample(&dressing, &mut data);
    let progress = ctx.progress(steps as u64, "steps");
    let start = std::time::Instant::now();
    let (mut iterations, mut substeps, mut deepest) = (0, 0, f64::INFINITY);
    for s in 1..=steps {
        let report = dressing
            .sim
            .step()
            .map_err(|e| anyhow::anyhow!("step {s} (t = {:.3} s): {e}", dressing.sim.time()))?;
        iterations += report.newton_iterations;
        substeps += report.substeps;
        if s % sample_every == 0 || s == steps {
            sample(&dressing, &mut data);
            deepest = deepest.min(dressing.lowest_gap() / r);
        }
        if s % frame_every == 0 {
            frames.write(&dressing.sim)?;
        }
        progress.inc(1);
    }
    let seconds = start.elapsed().as_secs_f64();
    anyhow::ensure!(
        dressing.sim.state().q.iter().all(|x| x.is_finite()),
        "non-finite state"
    );
    let usd = OutputSpec {
        formats: vec![Format::Usda],
        ..OutputSpec::default()
    };
    let mut last = FrameWriter::new(&frames_dir, &usd, r, frame_every as f64 * dt)?;
    let usd_paths = last.write(&dressing.sim)?;
    let final_usd = frames_dir.join("final.usda");
    std::fs::rename(&usd_paths[0], &final_usd)?;

    let front = render(&dressing.sim, r, (480, 480), view_front, [0.0, 1.0, 0.0])?;
    let top = render(&dressing.sim, r, (480, 480), view_top, [0.0, 1.0, 0.0])?;
    save_images(
        &[
            ("laid out around the head", &laid_out.image),
            (&format!("after {duration} s, front"), &front.image),
            (&format!("after {duration} s, from above"), &top.image),
        ],
        &ctx.out_dir,
        &format!("{}-images", ctx.name),
    )?;
    let time = data.column("time_s").expect("a column of the table");
    let column = |name: &str| -> Vec<(f64, f64)> {
        let values = data.column(name).expect("a column of the table");
        time.iter().copied().zip(values).collect()
    };
    LineChart::new("Hat dressed on a head: heights")
        .x_label("time (s)")
        .y_label("height (mm)")
        .series(Series::line("hat top", column("top_mm")))
        .series(Series::line("hat bottom", column("bottom_mm")))
        .save(&ctx.out_dir, ctx.name)?;
    LineChart::new("Hat dressed on a head: lowest gap")
        .x_label("time (s)")
        .y_label("lowest yarn–head gap (R)")
        .series(Series::line(
            "nodes and segment midpoints",
            column("lowest_gap_R"),
        ))
        .save(&ctx.out_dir, &format!("{}-gap", ctx.name))?;
    let (top_mm, bottom_mm) = extent(&dressing);
    let final_gap = dressing.lowest_gap() / r;
    let head_top_mm = 1e3 * (dressing.body_offset + profile.rings[profile.rings.len() - 1].0);
    Ok(FigureOutput {
        summary: vec![
            (
                format!(
                    "hat: {} rounds, {} loops around, {loops} loops, {n_nodes} nodes, {n_dofs} DoFs",
                    chart.height(),
                    sectors * width
                ),
                format!(
                    "head {:.1} × {:.1} × {:.1} mm (semi-axes) on a neck, {triangles} triangles; laid out in {build_seconds:.2} s",
                    1e3 * a,
                    1e3 * b,
                    1e3 * c
                ),
            ),
            (
                format!("{duration} s in {steps} steps of {dt} s"),
                format!(
                    "{substeps} substeps, {iterations} Newton iterations, {seconds:.1} s ({:.0} DoF-steps/s)",
                    (n_dofs * steps) as f64 / seconds
                ),
            ),
            (
                "lowest yarn–head gap".into(),
                format!(
                    "{final_gap:+.4} R at the end, {deepest:+.4} R lowest sampled (every {sample_every} steps)"
                ),
            ),
            (
                "hat on the head".into(),
                format!(
                    "top {top_mm:.1} mm (head top {head_top_mm:.1} mm), bottom {bottom_mm:.1} mm"
                ),
            ),
        ],
        config: serde_json::json!({
            "chart": format!("hat_chart(sectors {sectors}, sector width {width}, brim {brim}, body {body})"),
            "head_semi_axes_m": [a, b, c],
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width 3 mm, gravity −y",
            "damping": {"alpha": 10.0, "beta": 0.01},
            "dt_s": dt, "duration_s": duration,
            "contact": "frictionless mesh penalty contact, nodes and segment midpoints, default stiffness k_s/R",
            "frames": "frames/frame_NNNNN.png every 0.1 s, frames/final.usda",
        }),
        data,
    })
}
