//! `stitches` (seed 000 §3.1–§3.2.3, Figs. 3–4): charts beyond knit and purl. A lace repeat
//! (yarn-overs paired with K2TOG, SSK, S2KP and K3TOG: stacked stitches on nodes of up to
//! 3 + 4 DoFs) and a shaped chart (M1L/M1R, KFB/PFB increases, P2TOG/SSP/K2TOG/SSK/K3TOG
//! decreases, slipped loops) knitted flat with one continuous yarn, and a stockinette tube
//! with a decrease round knitted in the round, each hung from its bind-off under gravity.
//! Plotted: the mean height of the nodes against time; rendered: the layouts and the hanging
//! fabrics.

use sim_persistent::chart::Chart;
use sim_persistent::experiment::positions;
use sim_persistent::forces::ForceSet;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::topology::{Construction, Topology};

use crate::plot::{LineChart, Series, save_images};
use crate::studies::persistent::render;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "stitches",
        title: "Lace, shaping and a tube knitted in the round",
        shows: "mean node height (mm) against time of a lace chart and a shaped chart (flat, one continuous yarn) and a tube knitted in the round, hung from their bind-off under gravity (Table 1 sweater yarn, dt = 0.5 ms); the laid-out and the hanging fabrics rendered as yarn tubes (stitches-layouts.png, stitches-images.png)",
        paper: "seed 000 Figs. 3–4: decreases stack loops on (3 + n)-DoF contact nodes, increases and yarn-overs keep two-yarn stitches",
        guarded: false,
        run,
    }
}

/// A shaped chart: widens from 9 to 13 loops, then narrows to 7.
const SHAPED: &str = "\
K9
K M1L K7 M1R K
K KFB K7 PFB K
K13
K2 P2TOG K5 SSP K2
K2 K2TOG K3 SSK K2
K2 SL K K3TOG K SL
K7
K7
";

/// A tube: 12 stitches a round, a decrease round to 9.
const TUBE: &str = "\
K12
K12
K12
K12
K K2TOG K3 K2TOG K SSK K
K9
K9
K9
";

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let duration = if ctx.quick { 0.1 } else { 1.0 };
    let fabrics: Vec<(&str, Chart, Construction)> = vec![
        (
            "lace (flat, continuous yarn)",
            Chart::lace(if ctx.quick { 1 } else { 2 }, 2)?,
            Construction::Flat,
        ),
        (
            "shaped (flat, continuous yarn)",
            Chart::parse(SHAPED)?,
            Construction::Flat,
        ),
        (
            "tube (in the round)",
            Chart::parse(TUBE)?,
            Construction::Round,
        ),
    ];
    let params = YarnParams::sweater();
    let settings = StepSettings {
        dt: 5e-4,
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    };
    // dt = 0.5 ms: at 1 ms the tube's step 409 failed (Newton residual 1.4e-2 N after 4
    // halvings), and with loop contact at 1 ms the shaped chart's step 984 did, measured.
    let forces = ForceSet::default();
    let steps = (duration / settings.dt).round() as usize;
    let sample_every = (steps / 50).max(1);
    let progress = ctx.progress((fabrics.len() * steps) as u64, "steps");
    let mut data = Table::new(&["fabric", "time_s", "mean_height_mm"]);
    let mut chart = LineChart::new("Fabrics hanging from their bind-off")
        .x_label("time (s)")
        .y_label("mean node height (mm)");
    let mut summary = Vec::new();
    let mut images = Vec::new();
    let mut layouts = Vec::new();
    for (k, (name, chart_k, construction)) in fabrics.iter().enumerate() {
        let topo = Topology::knit_with(chart_k, *construction)?;
        topo.validate()?;
        let stacked = topo.nodes.iter().map(|n| n.passes.len()).max().unwrap_or(0);
        let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius))?;
        let bind_off = topo.boundary_nodes(chart_k.height());
        let (n_nodes, n_dofs) = (topo.nodes.len(), topo.n_dofs());
        let mut sim = Simulator::new(topo, &layout, params, forces, settings.clone())?;
        sim.pin_nodes(&bind_off)?;
        let view = if *construction == Construction::Round {
            [0.35, -0.35, -1.0]
        } else {
            [0.0, 0.0, -1.0]
        };
        let laid_out = render(&sim, params.radius, (420, 420), view, [0.0, 1.0, 0.0])?;
        layouts.push((format!("{name}: layout"), laid_out.image));
        let mean_height = |sim: &Simulator| {
            let p = positions(sim);
            1e3 * p.iter().map(|x| x.y).sum::<f64>() / p.len() as f64
        };
        let start = std::time::Instant::now();
        let mut points = vec![(0.0, mean_height(&sim))];
        let (mut iterations, mut substeps) = (0, 0);
        // A step that fails after its halvings ends this fabric's run, which is reported with
        // the state it reached; the other fabrics go on.
        let mut failure = None;
        for s in 1..=steps {
            let report = match sim.step() {
                Ok(report) => report,
                Err(e) => {
                    failure = Some(format!("step {s} at t = {:.4} s failed: {e}", sim.time()));
                    break;
                }
            };
            iterations += report.newton_iterations;
            substeps += report.substeps;
            if s % sample_every == 0 {
                points.push((sim.time(), mean_height(&sim)));
            }
            progress.inc(1);
        }
        let seconds = start.elapsed().as_secs_f64();
        anyhow::ensure!(
            sim.state().q.iter().all(|x| x.is_finite()),
            "{name}: non-finite state"
        );
        for &(t, y) in &points {
            data.push_row([k as f64, t, y]);
        }
        let change = points.last().map_or(f64::NAN, |p| p.1) - points[0].1;
        let outcome = match &failure {
            None => format!(
                "{duration} s in {steps} steps ({substeps} substeps, {iterations} Newton iterations), {seconds:.1} s; mean height {change:+.2} mm"
            ),
            Some(f) => format!(
                "FAILED: {f}; {substeps} substeps, {iterations} Newton iterations before, {seconds:.1} s; mean height {change:+.2} mm"
            ),
        };
        summary.push((
            format!(
                "{name}: {} rows, {n_nodes} nodes, {n_dofs} DoFs, up to {stacked} yarns per node",
                chart_k.height()
            ),
            outcome,
        ));
        chart = chart.series(Series::line(*name, points));
        let image = render(&sim, params.radius, (420, 420), view, [0.0, 1.0, 0.0])?;
        let caption = match failure {
            None => format!("{name}: after {duration} s"),
            Some(_) => format!("{name}: failed at {:.3} s", sim.time()),
        };
        images.push((caption, image.image));
    }
    for (list, stem) in [(&layouts, "layouts"), (&images, "images")] {
        let panels: Vec<(&str, &yarn_output::render::Image)> =
            list.iter().map(|(t, i)| (t.as_str(), i)).collect();
        save_images(&panels, &ctx.out_dir, &format!("{}-{stem}", ctx.name))?;
    }
    chart.save(&ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "fabrics": fabrics.iter().map(|(n, c, _)| format!("{n}: {}", c.to_text().replace('\n', " / "))).collect::<Vec<_>>(),
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width 3 mm, gravity",
            "damping": {"alpha": settings.rayleigh_alpha, "beta": settings.rayleigh_beta},
            "dt_s": settings.dt, "duration_s": duration,
            "pins": "bind-off boundary",
            "forces": "default",
        }),
        data,
    })
}
