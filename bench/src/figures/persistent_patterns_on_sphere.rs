//! `patterns-on-sphere` (seed 000 §5.2.1, Fig. 12): garter, 2×2 rib and plain-woven swatches
//! of the same yarn dropped onto a sphere and simulated until nearly at rest.
//!
//! Every swatch uses the Table 1 sweater yarn (R = 0.75 mm; the paper uses R = 1 mm for
//! Fig. 12 with otherwise unstated parameters) with a loop width / yarn spacing of 3 mm,
//! Table 1 mass damping α = 10 /s and every default force term. Each swatch is
//!
//! 1. **settled** free and weightless from its flat layout (as in the `curl` figure: the stitch
//!    wrapping rest angles ramp in over 0.1 s; rib pulls in, garter edges roll a little; the
//!    weave layout is already at rest);
//! 2. **re-laid at rest** (zero velocity, the settled positions and sliding coordinates as a new
//!    layout, wrapping rest angles of the flat layout, friction anchors at the settled coordinates)
//!    with its node centroid over the centre of a sphere of radius ρ, face up or face down (a half
//!    turn about x), whichever puts its centre (the pole nodes below) lowest relative to the rest —
//!    a settled knit is not flat, and one that lands on its edges slides off the frictionless
//!    sphere — and lifted so that its lowest yarn surface is 1 mm above the sphere;
//! 3. **dropped** under gravity (−z) onto the sphere ([`sim_persistent::forces::obstacle`]:
//!    frictionless penalty contact of the contact nodes), until it is **nearly at rest**:
//!    the rms node speed `v_rms = √(2 E_kin / M)` (M the yarn mass) has stayed below
//!    `REST_SPEED` over the last `REST_WINDOW`, at least `MIN_DROP_TIME` after the release
//!    (the kinetic energy oscillates as the swatch rocks, so one low value is not enough), or
//!    the time limit is reached (reported).
//!
//! **A sticking sphere (a deviation).** The obstacle contact is frictionless, and a cloth
//! draped over a frictionless sphere is an unstable equilibrium (like a rope over a
//! frictionless peg: the side hanging lower pulls the rest after it); the first runs of this
//! figure slid the knits off the sphere (0.3 m below it after 0.5 s). Holding only the nodes
//! near the pole failed for a saddle-shaped settled knit (garter 12 × 11), which lands on its
//! rolled edges, and holding only the first contact left the knits swinging from one node.
//! As a stand-in for the sphere's friction (the limit μ → ∞), every node is held (pinned)
//! where it is at the end of the first step in which it touches the sphere: contacts stick,
//! the parts not yet in contact drape freely.
//!
//! Drape measures (seed 000 gives images only): the **drape ratio**, the projected area on the
//! horizontal plane (convex hull of the nodes) of the draped swatch over that of the settled
//! flat swatch before the drop (1: flat; like the drape coefficient of fabric testing, smaller
//! is more drape); the **corner drop**, the mean height of the four layout corners below a
//! yarn resting on the sphere's pole; and the deepest penetration of a node into the sphere
//! (in R).
//!
//! Measurements of earlier runs, with the model they were made on, are in
//! `reports/patterns-on-sphere/NOTES.md`; the current numbers in the manifest and
//! reports/README.md.

use rod::geometry::V3;
use serde_json::json;
use sim_persistent::chart::Chart;
use sim_persistent::experiment::sphere_drop::{
    DROP_GAP, DropSetup, Dropped, MIN_DROP_TIME, POLE_RADIUS, REST_SPEED, REST_WINDOW, SphereDrop,
    drop_pattern,
};
use sim_persistent::experiment::{ALPHA, SwatchSettings};
use sim_persistent::output::{CurveOptions, RenderCurves};
use sim_persistent::topology::Topology;
use sim_persistent::weave::WeavePattern;
use yarn_output::render::{Camera, Framing, Image, RenderOptions};

use crate::plot::{LineChart, Series, save_images};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "patterns-on-sphere",
        title: "Knit and woven patterns dropped on a sphere",
        shows: "garter, 2×2 rib and plain-weave swatches of the same yarn, settled, dropped onto a sphere under gravity and simulated until nearly at rest: tube images (oblique and top views) and, over the drop, kinetic energy, drape ratio (projected area / flat projected area) and corner drop",
        paper: "seed 000 §5.2.1, Fig. 12: images only (R = 1 mm yarn, larger samples); here R = 0.75 mm, a frictionless sphere and the nodes at the pole held once they touch",
        guarded: false,
        run,
    }
}

/// Sizes and times of one run.
#[derive(Clone, Debug)]
struct Setup {
    /// Stitches per row (garter); rib is two wider, the weave has `n + 1` yarns each way.
    n: usize,
    /// Sphere, settling and drop times.
    drop: DropSetup,
}

impl Setup {
    fn new(quick: bool) -> Self {
        let (n, sphere_radius, settle_time, max_drop_time) = if quick {
            (6, 6e-3, 0.12, 0.4)
        } else {
            (20, 20e-3, 0.3, 1.5)
        };
        Self {
            n,
            drop: DropSetup {
                sphere_radius,
                settle_time,
                max_drop_time,
            },
        }
    }
}

/// (name, topology) of the patterns.
fn patterns(n: usize) -> anyhow::Result<Vec<(String, Topology)>> {
    let garter = Chart::garter(n, n + 1)?;
    let rib = Chart::rib(n + 2, n, 2, 2)?;
    Ok(vec![
        (
            format!("garter {}×{}", garter.width(), garter.height()),
            Topology::knit(&garter),
        ),
        (
            format!("rib 2×2 {}×{}", rib.width(), rib.height()),
            Topology::knit(&rib),
        ),
        (
            format!("plain weave {}×{}", n + 1, n + 1),
            Topology::weave(WeavePattern::Plain, n + 1, n + 1)?,
        ),
    ])
}

/// An oblique view from above (z up).
const OBLIQUE: Camera = Camera {
    direction: [0.55, 0.75, -0.45],
    up: [0.0, 0.0, 1.0],
};

/// A view from straight above.
const TOP: Camera = Camera {
    direction: [0.0, 0.0, -1.0],
    up: [0.0, 1.0, 0.0],
};

/// Image size (pixels).
const IMAGE_SIZE: u32 = 400;

/// The yarns as tubes (`sim_persistent::output` rendering curves) over a grey wire sphere
/// (latitude and meridian rings of the upper 110° of the sphere, drawn just inside its
/// surface).
fn render(
    drop: &SphereDrop,
    camera: Camera,
    framing: Framing,
    size: u32,
) -> anyhow::Result<yarn_output::render::Rendering> {
    let r = drop.yarn_radius;
    let curves = RenderCurves::from_simulator(
        &drop.sim,
        &CurveOptions {
            radius: r,
            samples_per_segment: 4,
        },
    )?;
    let mut lines: Vec<Vec<V3>> = curves.samples.clone();
    let mut palette: Vec<[u8; 3]> = (0..lines.len())
        .map(|c| yarn_output::render::DEFAULT_PALETTE[c % 7])
        .collect();
    let rho = drop.radius - r;
    let point = |theta: f64, phi: f64| {
        drop.center
            + rho
                * V3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
    };
    let deg = std::f64::consts::PI / 180.0;
    let max_theta = 110.0 * deg;
    for k in 1..=5 {
        let theta = k as f64 * 20.0 * deg;
        lines.push(
            (0..=72)
                .map(|i| point(theta, i as f64 * 5.0 * deg))
                .collect(),
        );
    }
    for k in 0..12 {
        let phi = k as f64 * 30.0 * deg;
        lines.push(
            (0..=22)
                .map(|i| point(i as f64 * max_theta / 22.0, phi))
                .collect(),
        );
    }
    palette.resize(lines.len(), [170, 170, 170]);
    let (mut x, mut y, mut z) = (Vec::new(), Vec::new(), Vec::new());
    let mut offsets = vec![0u32];
    for line in &lines {
        for p in line {
            x.push(p.x);
            y.push(p.y);
            z.push(p.z);
        }
        offsets.push(u32::try_from(x.len())?);
    }
    let closed = vec![false; lines.len()];
    let polylines = yarn_output::Polylines {
        x: &x,
        y: &y,
        z: &z,
        curve_offsets: &offsets,
        closed: &closed,
    };
    let options = RenderOptions {
        camera,
        framing,
        supersample: 2,
        palette,
        ..RenderOptions::new(size, size, r)
    };
    Ok(yarn_output::render::render_tubes(&polylines, &options)?)
}

/// Renders every drop with `camera` at one common scale (the smallest auto-fit scale), each
/// centred on its own swatch.
fn render_all(dropped: &[Dropped], camera: Camera) -> anyhow::Result<Vec<Image>> {
    // A small auto-fitted pass gives each view's centre and scale.
    const PROBE: u32 = IMAGE_SIZE / 4;
    let mut fits = Vec::new();
    for d in dropped {
        let probe = render(&d.drop, camera, Framing::Auto { margin: 0.05 }, PROBE)?;
        match probe.framing {
            Framing::Fixed {
                center,
                pixels_per_metre,
            } => fits.push((center, pixels_per_metre * f64::from(IMAGE_SIZE / PROBE))),
            Framing::Auto { .. } => anyhow::bail!("the renderer returned an auto framing"),
        }
    }
    let scale = fits.iter().map(|f| f.1).fold(f64::INFINITY, f64::min);
    dropped
        .iter()
        .zip(&fits)
        .map(|(d, (center, _))| {
            let framing = Framing::Fixed {
                center: *center,
                pixels_per_metre: scale,
            };
            Ok(render(&d.drop, camera, framing, IMAGE_SIZE)?.image)
        })
        .collect()
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let setup = Setup::new(ctx.quick);
    let patterns = patterns(setup.n)?;
    let progress = ctx.progress(patterns.len() as u64, "drops");
    let mut dropped = Vec::new();
    for (name, topo) in patterns {
        dropped.push(drop_pattern(&name, topo, &setup.drop)?);
        progress.inc(1);
    }
    let mut data = Table::new(&[
        "pattern",
        "time_s",
        "kinetic_energy_J",
        "rms_speed_m_per_s",
        "drape_ratio",
        "corner_drop_mm",
        "penetration_R",
    ]);
    let mut summary = Vec::new();
    let mut energy_chart = LineChart::new("Dropped swatches: kinetic energy")
        .x_label("time since release (s)")
        .y_label("kinetic energy (J)")
        .log_y();
    let mut drape_chart = LineChart::new("Dropped swatches: drape ratio")
        .x_label("time since release (s)")
        .y_label("projected area / flat projected area");
    for (k, d) in dropped.iter().enumerate() {
        for s in &d.samples {
            data.push_row([
                k as f64,
                s.time,
                s.kinetic,
                s.rms_speed,
                s.drape_ratio,
                s.corner_drop * 1e3,
                s.penetration,
            ]);
        }
        energy_chart = energy_chart.series(Series::line(
            d.name.clone(),
            d.samples
                .iter()
                .filter(|s| s.kinetic > 0.0)
                .map(|s| (s.time, s.kinetic)),
        ));
        drape_chart = drape_chart.series(Series::line(
            d.name.clone(),
            d.samples.iter().map(|s| (s.time, s.drape_ratio)),
        ));
        let last = d
            .samples
            .last()
            .expect("the first sample is taken at release");
        summary.push((
            format!("{}: drape ratio, corner drop", d.name),
            format!("{:.3}, {:.2} mm", last.drape_ratio, last.corner_drop * 1e3),
        ));
        summary.push((
            format!("{}: deepest penetration over the drop, at the end", d.name),
            format!("{:.4} R, {:.4} R", d.deepest, last.penetration),
        ));
        summary.push((
            format!("{}: final kinetic energy, rms speed", d.name),
            format!(
                "{:.2e} J, {:.2} mm/s after {:.3} s ({})",
                last.kinetic,
                last.rms_speed * 1e3,
                last.time,
                if d.at_rest {
                    "at rest"
                } else {
                    "time limit, not at rest"
                }
            ),
        ));
        summary.push((
            format!("{}: sticking contacts", d.name),
            match d.held_at {
                Some(t) => format!(
                    "{} nodes held, the first from {t:.3} s, {} of them within {} mm of the \
                     pole axis (laid face {})",
                    d.held.0,
                    d.held.1,
                    POLE_RADIUS * 1e3,
                    if d.drop.flipped { "down" } else { "up" }
                ),
                None => "never touched the sphere".to_string(),
            },
        ));
        summary.push((
            format!("{}: run", d.name),
            format!(
                "{} DoFs ({} obstacle terms), {} drop steps, {} Newton iterations with the settle, {:.1} s",
                d.dofs, d.obstacle_terms, d.steps, d.newton_iterations, d.seconds
            ),
        ));
    }
    let oblique = render_all(&dropped, OBLIQUE)?;
    let top = render_all(&dropped, TOP)?;
    for (images, stem, view) in [(&oblique, "images", "oblique"), (&top, "top", "top")] {
        let titles: Vec<String> = dropped
            .iter()
            .map(|d| format!("{} ({view})", d.name))
            .collect();
        let panels: Vec<(&str, &Image)> = titles
            .iter()
            .map(String::as_str)
            .zip(images.iter())
            .collect();
        save_images(&panels, &ctx.out_dir, &format!("{}-{stem}", ctx.name))?;
    }
    crate::plot::save_side_by_side(&energy_chart, &drape_chart, &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: json!({
            "patterns": dropped.iter().map(|d| d.name.clone()).collect::<Vec<_>>(),
            "yarn": "Table 1 sweater (R = 0.75 mm), loop width / yarn spacing 3 mm, gravity 9.81 m/s² along -z",
            "damping_alpha": ALPHA,
            "dt_s": SwatchSettings::default().dt,
            "settle_time_s": setup.drop.settle_time,
            "sphere_radius_m": setup.drop.sphere_radius,
            "drop_gap_m": DROP_GAP,
            "rest": format!("rms node speed < {REST_SPEED} m/s over the last {REST_WINDOW} s, at least {MIN_DROP_TIME} s after the release"),
            "max_drop_time_s": setup.drop.max_drop_time,
            "obstacle": "frictionless penalty contact, default stiffness k_s/R",
            "contact": "every node is pinned at the end of the first step in which it touches the sphere (sticking contact)",
        }),
        data,
    })
}
