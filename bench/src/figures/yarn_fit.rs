//! `yarn-fit`: seed 002's whole estimation pipeline on every shared hand-knit fabric (Fig. 11 /
//! Fig. 15): the stiffening shell fitted to the fabric's weft and warp stretch tests
//! (the best shell model of `shell-fit-all`), its uniform target curves (weft, bias and warp;
//! bias is the shell's prediction, the data have no bias test), then the yarn-level fit of the
//! fabric's procedural pattern to them (swarm, then Levenberg–Marquardt with exact
//! sensitivities). The comfort-range error is the paper's Fig. 15 metric.
//!
//! **Geometry.** Beyond the paper, which registers each fabric's yarn geometry by hand
//! (§4.2), the swarm also searches the procedural tile's stretch along x and y
//! ([`with_fitted_geometry`]); Levenberg–Marquardt then refines the yarn model and the
//! geometry's stretch (its Jacobian columns by forward differences,
//! [`FitSettings::local_geometry`]), from the swarm's best point and the two next-best
//! distinct ones ([`LOCAL_STARTS`]), keeping the lowest objective.
//!
//! **Settings and their history.** Levenberg–Marquardt computes a point's Jacobian only where
//! it accepts the point ([`solver::bounded_lm`]'s `commit`), so a rejected trial costs one
//! objective evaluation. The objective has more than one basin that a small swarm reaches by
//! chance, so the swarm restarts from several seeds and keeps the lowest `g` ([`RESTARTS`]),
//! with half of the stress samples in the comfort range ([`SAMPLE_LAYOUT`]). Each result is
//! evaluated once more on the paper's even grid ([`on_paper_grid`]) so that both errors are
//! reported. The measurements behind each of these choices, and how each change to the
//! objective moved the fits, are in `reports/yarn-fit/NOTES.md`.
//!
//! **Hold-out.** The fit's settings were chosen while looking at one fabric only,
//! `acrylic-yarn-stockinette` (the development fabric); the other seven were first fitted by
//! the committed full run. The key numbers report both groups. One later choice saw every
//! fabric: the tile resolution ([`FIT_RESOLUTION`]) was lowered for speed, and its errors on
//! all eight, at both resolutions, were measured before it was committed. The course-height
//! bounds of garter and seed ([`geometry_bounds`]) were chosen after single fits of six
//! fabrics with a wider box.

use std::path::PathBuf;
use std::time::Instant;

use shell_fem::curves::TargetCurves;
use shell_fem::fabrics::{Fabric, FabricFitOptions, discover, fit_fabric};
use shell_fem::material::{Material, Model};
use shell_fem::measurements::BinOptions;
use shell_fem::swatch::SwatchConfig;
use sim_periodic::fit::targets::interpolate;
use sim_periodic::fit::{
    Bound, Evaluation, FitResult, FitSettings, Journal, Objective, ObjectiveSettings, Parameter,
    ParameterSpace, SampleLayout, TargetPoint, Targets, comfort_end, estimated_radius, fit,
};
use sim_periodic::patterns::Pattern;
use sim_periodic::periodic::YarnModel;
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series, save_grid};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "yarn-fit",
        title: "Yarn-level fits to every shared hand-knit (shell targets → yarn model)",
        shows: "per fabric: target curves of the fitted stiffening shell (lines) and the fitted yarn model of the fabric's procedural pattern, its stretch along x and y fitted too (markers), for weft, bias and warp: stretch stress against stretch over the tested range, the same over each direction's comfort range (where the comfort-range error is measured), and orthogonal compression against stretch; the table lists the comfort-range error (Fig. 15 metric) on the fit's own samples and on the paper's even grid, the power-range and compression errors, the fitted parameters (the yarn model's five and the geometry's stretch) and the fit time",
        paper: "Fig. 11 / Fig. 15: comfort-range error 10.40 % on average, 24 of 33 fabrics within 10 %, 25 min per fabric on average on a 256-core machine (swarm solver)",
        guarded: false,
        run,
    }
}

/// The fabric the fit's settings were developed on.
pub const DEVELOPMENT_FABRIC: &str = "acrylic-yarn-stockinette";

/// Target points per direction from the shell, evenly spaced over the tested range; the
/// objective interpolates them linearly.
///
/// Enough in the comfort range, where the error is measured: finer target curves move it by a
/// fraction of a percent of the comfort-range maximum (measured in `reports/yarn-fit/NOTES.md`).
const TARGET_POINTS: usize = 21;

/// The procedural pattern of a shared fabric (by the stitch in its name; the rib is 1×1).
pub fn pattern_of(fabric: &str) -> anyhow::Result<Pattern> {
    let table = [
        ("stockinette", Pattern::Stockinette),
        ("garter", Pattern::Garter),
        ("rib", Pattern::Rib1x1),
        ("seed", Pattern::Seed),
    ];
    table
        .iter()
        .find(|(k, _)| fabric.contains(k))
        .map(|&(_, p)| p)
        .ok_or_else(|| anyhow::anyhow!("no procedural pattern for fabric {fabric}"))
}

/// The shared fabrics.
pub fn fabrics(quick: bool) -> anyhow::Result<(Vec<Fabric>, FabricFitOptions)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/measurements");
    let (nx, ny, max_iterations) = if quick { (10, 6, 40) } else { (20, 12, 200) };
    let opts = FabricFitOptions {
        swatch: SwatchConfig {
            nx,
            ny,
            ..SwatchConfig::default()
        },
        max_iterations,
        ..FabricFitOptions::default()
    };
    let bins = BinOptions {
        bins: 24,
        swatch_width: opts.swatch.width,
    };
    Ok((discover(&dir, &bins)?, opts))
}

/// The fabrics of `all` named by `names` (each must be one of them; `all` in `names`: every
/// fabric; none named: the development fabric), for the benches' command lines.
pub fn select<'a>(all: &'a [Fabric], names: &[String]) -> anyhow::Result<Vec<&'a Fabric>> {
    if names.iter().any(|n| n == "all") {
        return Ok(all.iter().collect());
    }
    if names.is_empty() {
        return Ok(all
            .iter()
            .filter(|f| f.name == DEVELOPMENT_FABRIC)
            .collect());
    }
    names
        .iter()
        .map(|name| {
            all.iter().find(|f| &f.name == name).ok_or_else(|| {
                let known: Vec<&str> = all.iter().map(|f| f.name.as_str()).collect();
                anyhow::anyhow!("no fabric {name:?}; known: {}", known.join(", "))
            })
        })
        .collect()
}

/// The uniform target curves of the stiffening shell fitted to `fabric`: weft and warp over
/// their measured ranges, bias over the smaller of the two.
pub fn shell_targets(fabric: &Fabric, opts: &FabricFitOptions) -> anyhow::Result<Targets> {
    let model = Model::Stiffening;
    let fitted = fit_fabric(fabric, model, opts)?;
    let material = Material {
        params: fitted.fit.params,
        model,
    };
    let mut ranges: Vec<(Direction, f64)> = fabric
        .measurements
        .iter()
        .map(|m| (m.direction, m.s_max()))
        .collect();
    let bias = ranges.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    if !ranges.iter().any(|r| r.0 == Direction::Bias) && bias.is_finite() {
        ranges.push((Direction::Bias, bias));
    }
    let curves = TargetCurves::generate(&material, &ranges, TARGET_POINTS, None)?;
    let mut targets = Targets::default();
    for (name, points) in &curves.stretch {
        let d = Direction::parse(name)
            .ok_or_else(|| anyhow::anyhow!("shell curve direction {name}"))?;
        targets.curves.insert(
            d,
            points
                .iter()
                .map(|p| TargetPoint {
                    s: p.s,
                    c: p.c,
                    sigma: p.sigma,
                })
                .collect(),
        );
    }
    Ok(targets)
}

/// Yarn radius of the fits (m): the scale of the procedural tiles.
pub const RADIUS: f64 = 1e-3;

/// Vertices per stitch loop of the fitted knit tiles (the procedural default is 24).
///
/// Chosen for speed on all eight shared fabrics: the fits are faster and their comfort-range
/// errors comparable (measured in `reports/yarn-fit/NOTES.md`). The fitted parameters belong
/// to tiles of this resolution: a finer tile with the same yarn model has other curves.
pub const FIT_RESOLUTION: usize = 16;

/// The input geometry of the fits: `pattern` for a yarn of radius `radius` (m), knits at
/// [`FIT_RESOLUTION`] vertices per loop.
pub fn fit_geometry(pattern: Pattern, radius: f64) -> anyhow::Result<Tile> {
    let mut params = pattern.default_params(radius);
    if pattern.is_knit() {
        params.resolution = FIT_RESOLUTION;
    }
    Ok(pattern.generate(&params)?)
}

/// The input geometry of `pattern` ([`fit_geometry`]) and the paper's parameter space around
/// `base`.
pub fn geometry_and_space(
    pattern: Pattern,
    base: &YarnModel,
    radius: f64,
) -> anyhow::Result<(Tile, ParameterSpace)> {
    let geometry = fit_geometry(pattern, radius)?;
    let r_est = estimated_radius(&geometry, base)?;
    let space = ParameterSpace::paper(base, r_est)?;
    Ok((geometry, space))
}

/// Bounds of the input geometry's stretch factors along x and y when they are fitted
/// ([`with_fitted_geometry`]; along y scaled per pattern, [`geometry_bounds`]), chosen before
/// any fit with them: ±25–35 % around the procedural proportions.
///
/// Wider boxes were measured and not adopted: the same swarm searches a larger box worse
/// (`reports/yarn-fit/NOTES.md`).
pub const GEOMETRY_BOUNDS: (f64, f64) = (0.75, 1.35);

/// The course height (m) of the procedural tiles that [`GEOMETRY_BOUNDS`] was chosen for (the
/// stockinette's and the rib's: 4 yarn radii); [`geometry_bounds`] gives every pattern's
/// course height this box.
fn reference_course_height(radius: f64) -> f64 {
    Pattern::Stockinette.default_params(radius).spacing[1]
}

/// Bounds of the input geometry's stretch factors `[along x, along y]` for `pattern`: along x
/// [`GEOMETRY_BOUNDS`]; along y the bounds that give the fitted course height the same range
/// in yarn radii as the stockinette's, `4 R × GEOMETRY_BOUNDS` = 3–5.4 R. The procedural
/// garter and seed are built with courses 6 R apart instead of 4 R (so that knit and purl
/// courses start clear of each other), and for them the range is (0.5, 0.9).
///
/// Chosen because the course height was the active bound of garter and seed with
/// [`GEOMETRY_BOUNDS`] along y for every pattern (measured in `reports/yarn-fit/NOTES.md`).
pub fn geometry_bounds(pattern: Pattern, radius: f64) -> [(f64, f64); 2] {
    let scale = reference_course_height(radius) / pattern.default_params(radius).spacing[1];
    [
        GEOMETRY_BOUNDS,
        (GEOMETRY_BOUNDS.0 * scale, GEOMETRY_BOUNDS.1 * scale),
    ]
}

/// `space` with the input geometry's stretch along x and y free too ([`Parameter::GeometryX`],
/// [`Parameter::GeometryY`] in [`geometry_bounds`] of `pattern`; beyond the paper, which
/// starts from each fabric's hand-registered geometry where these fits have only a procedural
/// guess).
///
/// Adopted for this figure on the development fabric alone (`yarn-fit-ablations`, variant
/// "fitted geometry"): its comfort-range error fell from 20.0 to 15.0 % and its objective g
/// from 0.224 to 0.115, with the fitted stretch (0.93, 1.28). The seven held-out fabrics were
/// first fitted this way by the committed full run.
pub fn with_fitted_geometry(
    space: ParameterSpace,
    pattern: Pattern,
    radius: f64,
) -> anyhow::Result<ParameterSpace> {
    let mut free = space.free;
    let bounds = geometry_bounds(pattern, radius);
    for (parameter, (min, max)) in [Parameter::GeometryX, Parameter::GeometryY]
        .into_iter()
        .zip(bounds)
    {
        free.push(Bound {
            parameter,
            min,
            max,
        });
    }
    Ok(ParameterSpace::new(space.base, free)?)
}

/// Levenberg–Marquardt starts of the full run ([`FitSettings::local_starts`]): the swarm's
/// best point and the two next-best distinct swarm points, the lowest objective kept.
///
/// The starts run in parallel. Chosen by the fit's objective `g` on the development fabric
/// (`yarn-fit-ablations`); measured in `reports/yarn-fit/NOTES.md`.
pub const LOCAL_STARTS: usize = 3;

/// The swarm's inertia weights at its first and last iteration: the paper's 0.9 → 0.1
/// (§7.3.3, [`sim_periodic::fit::SwarmSettings::inertia`]) instead of argmin's constant
/// `1/(2 ln 2)` (the library's default).
///
/// Chosen on the development fabric (`yarn-fit-ablations`); the small swarm lands in
/// different basins with either schedule (measured in `reports/yarn-fit/NOTES.md`).
pub const SWARM_INERTIA: (f64, f64) = (0.9, 0.1);

/// Where the objective's stress samples lie: half of each direction's in its comfort range
/// ([`SampleLayout::ComfortHalf`], beyond the paper; [`sim_periodic::fit::objective`]'s
/// *Sample layout*), the other half beyond it, instead of evenly over the tested range.
///
/// Chosen after a diagnosis on all eight fabrics with the even layout, whose fits had traded
/// the comfort range for the power range: with this layout the lower `g` of two swarms
/// ([`RESTARTS`]) is also the better comfort-range fit (measured with two swarm seeds on all
/// eight fabrics, in `reports/yarn-fit/NOTES.md`).
pub const SAMPLE_LAYOUT: SampleLayout = SampleLayout::ComfortHalf;

/// Independent swarms per fit, each with its local search, the lowest final `g` kept
/// ([`sim_periodic::fit::SwarmSettings::restarts`], seeds 2022 and 2023): the swarm's seed
/// moves a fit more than any setting measured (`reports/yarn-fit/NOTES.md`: the sample-layout
/// table and the seed study). Doubles the fit's cost.
///
/// More swarms lower `g` further at a linear cost, but on the fabrics still above 10 % the
/// paper's objective, not the search, stands between the fit and the comfort range
/// (`yarn-fit-seeds`; measured in `reports/yarn-fit/NOTES.md`).
pub const RESTARTS: usize = 2;

/// Fit settings of the full and the quick run (the quick run: a tiny swarm and one start).
pub fn settings(quick: bool) -> FitSettings {
    let mut s = FitSettings {
        local_starts: LOCAL_STARTS,
        ..FitSettings::default()
    };
    if let Some(swarm) = &mut s.swarm {
        swarm.inertia = SWARM_INERTIA;
        swarm.restarts = RESTARTS;
    }
    s.set_sample_layout(SAMPLE_LAYOUT);
    if quick {
        s.local_starts = 1;
        if let Some(swarm) = &mut s.swarm {
            swarm.particles = 4;
            swarm.iterations = 1;
            swarm.restarts = 1;
        }
        s.swarm_objective.samples = 5;
        s.local_objective.samples = 10;
        s.local_evaluations = 4;
    }
    s
}

/// One fitted fabric.
pub struct Fitted {
    /// The fabric's name.
    pub name: String,
    /// Its procedural pattern ([`pattern_of`]).
    pub pattern: Pattern,
    /// The shell's uniform target curves.
    pub targets: Targets,
    /// The fitted parameters ([`with_fitted_geometry`]).
    pub space: ParameterSpace,
    /// The yarn fit.
    pub result: FitResult,
    /// Its result evaluated on the paper's sample layout ([`on_paper_grid`]).
    pub paper_grid: Evaluation,
    /// Wall time (s) of the shell fit and its target curves.
    pub shell_seconds: f64,
    /// Wall time (s) of the yarn fit.
    pub yarn_seconds: f64,
}

/// The whole pipeline on one fabric: the shell fit and its uniform targets
/// ([`shell_targets`]), then the yarn fit of its pattern with `settings` (the figure's:
/// [`settings`]), each timed.
pub fn fit_one(
    fabric: &Fabric,
    opts: &FabricFitOptions,
    settings: &FitSettings,
) -> anyhow::Result<Fitted> {
    let t = Instant::now();
    let targets = shell_targets(fabric, opts)?;
    let shell_seconds = t.elapsed().as_secs_f64();
    let pattern = pattern_of(&fabric.name)?;
    let base = YarnModel::default_for_radius(RADIUS);
    let (geometry, space) = geometry_and_space(pattern, &base, RADIUS)?;
    let space = with_fitted_geometry(space, pattern, RADIUS)?;
    let t = Instant::now();
    let result = fit(
        &geometry,
        &targets,
        &space,
        settings,
        &Journal::in_memory(),
        &|_| {},
    )?;
    let yarn_seconds = t.elapsed().as_secs_f64();
    let paper_grid = on_paper_grid(&geometry, &targets, &space, settings, &result)?;
    Ok(Fitted {
        name: fabric.name.clone(),
        pattern,
        targets,
        space,
        result,
        paper_grid,
        shell_seconds,
        yarn_seconds,
    })
}

/// A fit's result evaluated on the paper's layout: the local search's objective
/// ([`FitSettings::local_objective`], 20 samples per direction in full mode) with its samples
/// evenly spaced over each target curve ([`SampleLayout::Even`], seed 002 §7.3.1), whatever
/// layout the fit used ([`SAMPLE_LAYOUT`]). Its comfort-range error is the paper's Fig. 15
/// metric on the paper's samples, so fits with either layout compare on one grid
/// ([`on_layout`]).
pub fn on_paper_grid(
    geometry: &Tile,
    targets: &Targets,
    space: &ParameterSpace,
    settings: &FitSettings,
    result: &FitResult,
) -> anyhow::Result<Evaluation> {
    on_layout(
        geometry,
        targets,
        space,
        settings,
        result,
        SampleLayout::Even,
    )
}

/// A fit's result evaluated with the local search's objective on the sample layout `layout`:
/// one more objective evaluation, outside the fit's time; none when the fit's local search
/// used `layout` (its final evaluation is this one).
pub fn on_layout(
    geometry: &Tile,
    targets: &Targets,
    space: &ParameterSpace,
    settings: &FitSettings,
    result: &FitResult,
    layout: SampleLayout,
) -> anyhow::Result<Evaluation> {
    if settings.local_objective.layout == layout {
        return Ok(result.evaluation.clone());
    }
    let objective = Objective {
        geometry,
        targets,
        settings: ObjectiveSettings {
            layout,
            ..settings.local_objective.clone()
        },
    };
    Ok(objective.evaluate_at(space, &result.x)?)
}

/// The samples an evaluation's comfort-range error is taken over, per direction
/// ([`Evaluation::comfort_samples`]), e.g. `weft 10, bias 10, warp 10`: the paper's even grid
/// puts few in a narrow comfort range.
pub fn comfort_counts(evaluation: &Evaluation) -> String {
    evaluation
        .comfort_samples()
        .iter()
        .map(|(d, n)| format!("{} {n}", d.name()))
        .collect::<Vec<_>>()
        .join(", ")
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let (mut all, opts) = fabrics(ctx.quick)?;
    if ctx.quick {
        all.retain(|f| f.name == DEVELOPMENT_FABRIC);
    }
    let base = YarnModel::default_for_radius(RADIUS);
    let settings = settings(ctx.quick);
    let progress = ctx.progress(all.len() as u64, "fabrics");
    let mut fitted = Vec::new();
    for fabric in &all {
        fitted.push(fit_one(fabric, &opts, &settings)?);
        progress.inc(1);
    }

    let mut data = Table::new(&[
        "fabric_index",
        "comfort_error",
        "comfort_error_paper_grid",
        "power_error",
        "compression_error",
        "objective",
        "k1",
        "onset",
        "bending",
        "contact_radius",
        "contact_stiffness",
        "geometry_x",
        "geometry_y",
        "swarm_evaluations",
        "local_evaluations",
        "shell_seconds",
        "yarn_seconds",
        "comfort_samples",
        "comfort_samples_paper_grid",
    ]);
    let mut summary = Vec::new();
    let mut charts = Vec::new();
    for (i, f) in fitted.iter().enumerate() {
        let e = &f.result.evaluation;
        let mut row = vec![
            i as f64,
            e.comfort_error,
            f.paper_grid.comfort_error,
            e.power_error,
            e.compression_error,
            e.value,
        ];
        // The yarn model's five, then the input geometry's stretch (1 where not fitted).
        row.extend(
            f.result
                .values
                .iter()
                .zip(&f.space.free)
                .filter(|(_, b)| !b.parameter.is_geometric())
                .map(|(v, _)| *v),
        );
        row.extend(f.result.geometry_stretch);
        row.extend([
            f.result.evaluations[0] as f64,
            f.result.evaluations[1] as f64,
            f.shell_seconds,
            f.yarn_seconds,
        ]);
        row.extend(
            [e, &f.paper_grid]
                .map(|e| e.comfort_samples().iter().map(|(_, n)| n).sum::<usize>() as f64),
        );
        data.push_row(row);
        summary.push((
            format!("{} ({})", f.name, f.pattern.name()),
            format!(
                "comfort-range error {} over {} samples (on the paper's grid {} over {}), power range {}, compression {:.3}; yarn fit {:.1} s ({} + {} evaluations), shell {:.1} s",
                crate::percent(e.comfort_error),
                comfort_counts(e),
                crate::percent(f.paper_grid.comfort_error),
                comfort_counts(&f.paper_grid),
                crate::percent(e.power_error),
                e.compression_error,
                f.yarn_seconds,
                f.result.evaluations[0],
                f.result.evaluations[1],
                f.shell_seconds
            ),
        ));
        charts.extend(curve_charts(f, settings.local_objective.comfort_stress));
    }
    let group = |dev: bool| -> Vec<&Fitted> {
        fitted
            .iter()
            .filter(|f| (f.name == DEVELOPMENT_FABRIC) == dev)
            .collect()
    };
    // The comfort-range error on the fit's own samples and on the paper's grid.
    let own = |f: &Fitted| f.result.evaluation.comfort_error;
    let paper = |f: &Fitted| f.paper_grid.comfort_error;
    let mean = |fs: &[&Fitted], error: &dyn Fn(&Fitted) -> f64| {
        if fs.is_empty() {
            return "none".to_string();
        }
        crate::percent(fs.iter().map(|f| error(f)).sum::<f64>() / fs.len() as f64)
    };
    let within =
        |error: &dyn Fn(&Fitted) -> f64| fitted.iter().filter(|f| error(f) <= 0.10).count();
    let slowest = fitted.iter().map(|f| f.yarn_seconds).fold(0.0, f64::max);
    summary.insert(
        0,
        (
            "comfort-range error: development fabric / held-out mean".into(),
            format!(
                "{} / {} ({} held-out fabrics) on the fits' own samples, {} / {} on the paper's \
                 even grid; paper: 10.40 % mean",
                mean(&group(true), &own),
                mean(&group(false), &own),
                group(false).len(),
                mean(&group(true), &paper),
                mean(&group(false), &paper),
            ),
        ),
    );
    summary.insert(
        1,
        (
            "fabrics within 10 % (comfort range)".into(),
            format!(
                "{} of {} on the fits' own samples, {} on the paper's even grid (paper: 24 of 33)",
                within(&own),
                fitted.len(),
                within(&paper)
            ),
        ),
    );
    summary.insert(
        2,
        (
            "slowest yarn fit".into(),
            format!(
                "{slowest:.1} s on {} threads (goal ≤ 300 s; paper: 25 min average on 256 cores)",
                rayon::current_num_threads()
            ),
        ),
    );
    let refs: Vec<&LineChart> = charts.iter().collect();
    save_grid(&refs, 6, 0.7, &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "fabrics": fitted.iter().map(|f| serde_json::json!({
                "name": f.name, "pattern": f.pattern.name(),
                "parameters": f.result.values, "normalized": f.result.x,
                "local_status": f.result.local_status, "failed_evaluations": f.result.failed,
                "phase_seconds": f.result.seconds,
            })).collect::<Vec<_>>(),
            "shell": { "model": "stiffening", "test": "swatch", "nx": opts.swatch.nx, "ny": opts.swatch.ny, "target_points": TARGET_POINTS },
            "yarn": { "radius_m": 1e-3, "base_model": format!("{base:?}"), "settings": format!("{settings:?}") },
            "development_fabric": DEVELOPMENT_FABRIC,
            "threads": rayon::current_num_threads(),
        }),
        data,
    })
}

/// The charts of one fitted fabric, targets as lines and the yarn fit's samples as markers:
/// stretch stress over the tested range, stretch stress over each direction's comfort range
/// (up to `comfort_stress`, [`comfort_end`]: where the comfort-range error is measured), and
/// orthogonal compression.
fn curve_charts(f: &Fitted, comfort_stress: f64) -> [LineChart; 3] {
    let e = &f.result.evaluation;
    let mut stress = LineChart::new(format!("{} ({})", f.name, f.pattern.name()))
        .x_label("stretch s")
        .y_label("stretch stress σ_s (N/m)");
    let mut comfort = LineChart::new(format!(
        "comfort range: error {} (paper's grid {})",
        crate::percent(e.comfort_error),
        crate::percent(f.paper_grid.comfort_error)
    ))
    .x_label("stretch s")
    .y_label("stretch stress σ_s (N/m)")
    .hline("comfort limit (2 N on 6 cm)", comfort_stress);
    let mut compression = LineChart::new(format!("{}: compression", f.name))
        .x_label("stretch s")
        .y_label("orthogonal compression c");
    for (&d, curve) in &f.targets.curves {
        stress = stress.series(Series::line(
            format!("{} shell", d.name()),
            curve.iter().map(|p| (p.s, p.sigma)),
        ));
        let end = comfort_end(curve, comfort_stress).unwrap_or(0.0);
        comfort = comfort.series(Series::line(
            format!("{} shell", d.name()),
            (0..=COMFORT_LINE_POINTS)
                .filter_map(|i| {
                    let s = end * i as f64 / COMFORT_LINE_POINTS as f64;
                    interpolate(curve, s)
                })
                .map(|p| (p.s, p.sigma)),
        ));
        compression = compression.series(Series::line(
            format!("{} shell", d.name()),
            curve.iter().map(|p| (p.s, p.c)),
        ));
        let yarn = e.samples.iter().filter(|p| p.direction == d);
        stress = stress.series(Series::markers(
            format!("{} yarns", d.name()),
            yarn.clone().map(|p| (p.target.s, p.sigma)),
        ));
        comfort = comfort.series(Series::markers(
            format!("{} yarns", d.name()),
            yarn.clone()
                .filter(|p| p.comfort)
                .map(|p| (p.target.s, p.sigma)),
        ));
        compression = compression.series(Series::markers(
            format!("{} yarns", d.name()),
            yarn.map(|p| (p.target.s, p.c)),
        ));
    }
    [stress, comfort, compression]
}

/// Points of a target line in the comfort-range chart (the target curve itself has only a
/// few there).
const COMFORT_LINE_POINTS: usize = 40;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_benches_select_fabrics_by_name_and_list_the_known_ones_for_an_unknown_name() {
        let (all, _) = fabrics(true).unwrap();
        let names = |chosen: Vec<&Fabric>| -> Vec<String> {
            chosen.iter().map(|f| f.name.clone()).collect()
        };
        assert_eq!(names(select(&all, &[]).unwrap()), [DEVELOPMENT_FABRIC]);
        assert_eq!(select(&all, &["all".into()]).unwrap().len(), all.len());
        let two = ["babyredo-rib".to_string(), "acrylic-yarn-seed".to_string()];
        assert_eq!(names(select(&all, &two).unwrap()), two);
        let e = select(&all, &["babyredo-rib".into(), "no-such-fabric".into()])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("\"no-such-fabric\"") && e.contains("acrylic-yarn-garter"),
            "{e}"
        );
    }

    #[test]
    fn every_pattern_gets_the_stockinette_course_height_range() {
        let radius = 1e-3;
        let stockinette = geometry_bounds(Pattern::Stockinette, radius);
        assert_eq!(stockinette, [GEOMETRY_BOUNDS, GEOMETRY_BOUNDS]);
        for pattern in [Pattern::Garter, Pattern::Seed, Pattern::Rib1x1] {
            let bounds = geometry_bounds(pattern, radius);
            assert_eq!(bounds[0], GEOMETRY_BOUNDS, "{}", pattern.name());
            let h = pattern.default_params(radius).spacing[1];
            let (lo, hi) = (bounds[1].0 * h / radius, bounds[1].1 * h / radius);
            assert!(
                (lo - 3.0).abs() < 1e-12 && (hi - 5.4).abs() < 1e-12,
                "{lo} {hi}"
            );
        }
        // Garter and seed courses are 6 R apart: (0.5, 0.9).
        let garter = geometry_bounds(Pattern::Garter, radius)[1];
        assert!((garter.0 - 0.5).abs() < 1e-12 && (garter.1 - 0.9).abs() < 1e-12);
    }
}
