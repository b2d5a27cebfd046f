//! `yarn-fit-ablations`: the yarn fit of the development fabric (`acrylic-yarn-stockinette`
//! on the procedural stockinette, the stiffening shell's targets) with one ingredient changed
//! at a time, as seed 002's Figs. 11, 16 and 17 do: without the particle swarm, with a linear
//! instead of the bi-phasic yarn stretch law, without the rest-shape estimation; and the two
//! local methods, the paper's COBYLA and Levenberg–Marquardt with exact sensitivities, compared
//! for cost and final error. Beyond the paper: `k_s2` fitted too, and the input geometry's
//! stretch along x and y fitted too, then with Levenberg–Marquardt from three distinct swarm
//! points instead of one (the settings `yarn-fit` adopted from this comparison). Every other
//! variant runs one Levenberg–Marquardt start, so the two local methods are compared from the
//! same single start. Every variant's swarm has `yarn-fit`'s settings, the paper's inertia
//! decaying from 0.9 to 0.1 among them
//! ([`SWARM_INERTIA`](super::yarn_fit::SWARM_INERTIA), which says how it was chosen from
//! this figure). Then `yarn-fit`'s settings with argmin's constant swarm inertia
//! instead. Last, `yarn-fit`'s settings with Levenberg–Marquardt keeping the swarm's geometry
//! instead of refining it ([`FitSettings::local_geometry`]; the default before it was
//! adopted; with argmin's constant inertia and the Jacobian at accepted points only it ended
//! at g 0.0734, below the 0.0775 of refining it, and with the paper's inertia at 0.0804).
//! Then `yarn-fit`'s settings with the paper's evenly spaced stress samples instead of half of
//! them in the comfort range ([`SAMPLE_LAYOUT`](super::yarn_fit::SAMPLE_LAYOUT)), and with one
//! swarm instead of [`RESTARTS`](super::yarn_fit::RESTARTS) (both chosen on all eight
//! fabrics, see their docs). Every variant with a swarm runs `yarn-fit`'s restarts and sample
//! layout unless it says otherwise.

use std::time::Instant;

use rod::stretch::StretchLaw;
use sim_periodic::fit::{
    Bound, Evaluation, FitSettings, Journal, LocalMethod, Parameter, ParameterSpace, SampleLayout,
    Targets, constant_inertia, estimated_radius, fit,
};
use sim_periodic::periodic::YarnModel;
use yarn_pattern::direction::Direction;

use super::yarn_fit::{
    DEVELOPMENT_FABRIC, LOCAL_STARTS, fabrics, fit_geometry, on_paper_grid, pattern_of, settings,
    shell_targets, with_fitted_geometry,
};
use crate::plot::{LineChart, Series, save_grid};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "yarn-fit-ablations",
        title: "Yarn fit ablations: swarm, stretch law, rest shape, local method",
        shows: "stretch stress against stretch (weft, warp) of the development fabric's shell targets and of the yarn model fitted with: swarm + Levenberg–Marquardt (ours, default), swarm + COBYLA (paper), COBYLA without swarm (Fig. 11), Levenberg–Marquardt without swarm, a linear yarn stretch law (Fig. 16), no rest-shape estimation (Fig. 17), and (beyond the paper) k_s2 fitted too, or the procedural tile's stretch along x and y fitted too, with one or three Levenberg–Marquardt starts, with argmin's constant instead of the paper's decaying swarm inertia, with Levenberg–Marquardt keeping the swarm's geometry instead of refining it, with the paper's even sample layout, and with one swarm instead of two; last panel: comfort-range error (on each fit's own samples and on the paper's even grid) and fit time per variant",
        paper: "Figs. 11, 16, 17: without the swarm, with a linear stretch law or without rest-shape estimation the stretching error blows up",
        guarded: false,
        run,
    }
}

/// One variant: its name and how it changes the default settings and model.
struct Variant {
    name: &'static str,
    swarm: bool,
    local: LocalMethod,
    linear_stretch: bool,
    rest_shape: bool,
    /// Also fit the stiff stretch stiffness `k_s2` (beyond the paper), in [10, 1000] N.
    free_k2: bool,
    /// Also fit the input geometry's stretch along x and y (beyond the paper, the default of
    /// `yarn-fit`: [`with_fitted_geometry`]).
    free_geometry: bool,
    /// Levenberg–Marquardt starts ([`FitSettings::local_starts`]; `yarn-fit` uses
    /// [`LOCAL_STARTS`]).
    local_starts: usize,
    /// argmin's constant swarm inertia `1/(2 ln 2)` instead of `yarn-fit`'s, the paper's
    /// decaying from 0.9 to 0.1 (§7.3.3, [`SWARM_INERTIA`](super::yarn_fit::SWARM_INERTIA)).
    constant_inertia: bool,
    /// Levenberg–Marquardt refines the fitted geometry too ([`FitSettings::local_geometry`],
    /// the default) instead of keeping the swarm's.
    local_geometry: bool,
    /// The paper's evenly spaced stress samples instead of `yarn-fit`'s
    /// [`SAMPLE_LAYOUT`](super::yarn_fit::SAMPLE_LAYOUT).
    even_samples: bool,
    /// One swarm instead of `yarn-fit`'s [`RESTARTS`](super::yarn_fit::RESTARTS).
    one_swarm: bool,
}

/// Bounds of `k_s2` in the "free k2" variant (N): a decade either side of the 200 N default
/// and then some; the paper fixes it to the stiffest yarn's.
const K2_BOUNDS: (f64, f64) = (10.0, 1000.0);

/// The default: swarm, then one Levenberg–Marquardt start, on the paper's parameter space and
/// model; every variant changes one or two of these.
const DEFAULT: Variant = Variant {
    name: "swarm + LM (default)",
    swarm: true,
    local: LocalMethod::LevenbergMarquardt,
    linear_stretch: false,
    rest_shape: true,
    free_k2: false,
    free_geometry: false,
    local_starts: 1,
    constant_inertia: false,
    local_geometry: true,
    even_samples: false,
    one_swarm: false,
};

const VARIANTS: [Variant; 13] = [
    DEFAULT,
    Variant {
        name: "swarm + COBYLA (paper)",
        local: LocalMethod::Cobyla,
        ..DEFAULT
    },
    Variant {
        name: "COBYLA, no swarm",
        swarm: false,
        local: LocalMethod::Cobyla,
        ..DEFAULT
    },
    Variant {
        name: "LM, no swarm",
        swarm: false,
        ..DEFAULT
    },
    Variant {
        name: "linear stretch",
        linear_stretch: true,
        ..DEFAULT
    },
    Variant {
        name: "no rest shape",
        rest_shape: false,
        ..DEFAULT
    },
    Variant {
        name: "free k2 (beyond the paper)",
        free_k2: true,
        ..DEFAULT
    },
    Variant {
        name: "fitted geometry (beyond the paper)",
        free_geometry: true,
        ..DEFAULT
    },
    Variant {
        name: "fitted geometry, 3 LM starts (yarn-fit)",
        free_geometry: true,
        local_starts: LOCAL_STARTS,
        ..DEFAULT
    },
    Variant {
        name: "as yarn-fit, argmin's constant swarm inertia",
        free_geometry: true,
        local_starts: LOCAL_STARTS,
        constant_inertia: true,
        ..DEFAULT
    },
    Variant {
        name: "as yarn-fit, LM keeps the swarm's geometry",
        free_geometry: true,
        local_starts: LOCAL_STARTS,
        local_geometry: false,
        ..DEFAULT
    },
    Variant {
        name: "as yarn-fit, the paper's even sample layout",
        free_geometry: true,
        local_starts: LOCAL_STARTS,
        even_samples: true,
        ..DEFAULT
    },
    Variant {
        name: "as yarn-fit, one swarm",
        free_geometry: true,
        local_starts: LOCAL_STARTS,
        one_swarm: true,
        ..DEFAULT
    },
];

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let (all, opts) = fabrics(ctx.quick)?;
    let fabric = all
        .iter()
        .find(|f| f.name == DEVELOPMENT_FABRIC)
        .ok_or_else(|| anyhow::anyhow!("fabric {DEVELOPMENT_FABRIC} not found"))?;
    let targets: Targets = shell_targets(fabric, &opts)?;
    let pattern = pattern_of(&fabric.name)?;
    let geometry = fit_geometry(pattern, 1e-3)?;
    let progress = ctx.progress(VARIANTS.len() as u64, "variants");
    let mut data = Table::new(&[
        "variant",
        "comfort_error",
        "comfort_error_paper_grid",
        "power_error",
        "compression_error",
        "objective",
        "swarm_evaluations",
        "local_evaluations",
        "seconds",
    ]);
    let mut summary = Vec::new();
    // Per variant: its final evaluation, its comfort-range error on the paper's grid, its time.
    let mut results: Vec<(&Variant, Evaluation, f64, f64)> = Vec::new();
    let mut config = Vec::new();
    for (i, v) in VARIANTS.iter().enumerate() {
        let mut base = YarnModel::default_for_radius(1e-3);
        if v.linear_stretch
            && let StretchLaw::TwoPhase { k2, .. } = base.stretch
        {
            base.stretch = StretchLaw::Linear { k: k2 };
        }
        let mut space = ParameterSpace::paper(&base, estimated_radius(&geometry, &base)?)?;
        if v.free_k2 {
            let mut free = space.free.clone();
            free.push(Bound {
                parameter: Parameter::StretchStiff,
                min: K2_BOUNDS.0,
                max: K2_BOUNDS.1,
            });
            space = ParameterSpace::new(space.base, free)?;
        }
        if v.free_geometry {
            space = with_fitted_geometry(space, pattern, 1e-3)?;
        }
        let mut s: FitSettings = settings(ctx.quick);
        if !v.swarm {
            s.swarm = None;
        }
        s.local = v.local;
        s.local_starts = v.local_starts;
        s.local_geometry = v.local_geometry;
        if v.constant_inertia
            && let Some(swarm) = &mut s.swarm
        {
            let w = constant_inertia();
            swarm.inertia = (w, w);
        }
        if v.local == LocalMethod::Cobyla {
            // COBYLA counts evaluations, LM iterations: give COBYLA as many evaluations as
            // the default LM run is allowed iterations, and at least n + 2.
            s.local_evaluations = s.local_evaluations.max(space.dim() + 2);
        }
        if v.one_swarm
            && let Some(swarm) = &mut s.swarm
        {
            swarm.restarts = 1;
        }
        if v.even_samples {
            s.set_sample_layout(SampleLayout::Even);
        }
        s.swarm_objective.rest_shape = v.rest_shape;
        s.local_objective.rest_shape = v.rest_shape;
        let t = Instant::now();
        let result = fit(
            &geometry,
            &targets,
            &space,
            &s,
            &Journal::in_memory(),
            &|_| {},
        )?;
        let seconds = t.elapsed().as_secs_f64();
        let e = result.evaluation.clone();
        let paper = on_paper_grid(&geometry, &targets, &space, &s, &result)?;
        data.push_row([
            i as f64,
            e.comfort_error,
            paper.comfort_error,
            e.power_error,
            e.compression_error,
            e.value,
            result.evaluations[0] as f64,
            result.evaluations[1] as f64,
            seconds,
        ]);
        summary.push((
            v.name.to_string(),
            format!(
                "comfort-range error {} (on the paper's grid {}), power range {}, compression {:.3}, g = {:.3e}; {} + {} evaluations, {seconds:.1} s ({})",
                crate::percent(e.comfort_error),
                crate::percent(paper.comfort_error),
                crate::percent(e.power_error),
                e.compression_error,
                e.value,
                result.evaluations[0],
                result.evaluations[1],
                result.local_status
            ),
        ));
        config.push(serde_json::json!({
            "variant": v.name, "parameters": result.values, "normalized": result.x,
            "space": space.free.iter().map(|b| b.parameter.name()).collect::<Vec<_>>(),
        }));
        results.push((v, e, paper.comfort_error, seconds));
        progress.inc(1);
    }

    let mut charts = Vec::new();
    for d in [Direction::Weft, Direction::Warp] {
        let Some(curve) = targets.curves.get(&d) else {
            continue;
        };
        let mut chart = LineChart::new(format!("{DEVELOPMENT_FABRIC}: {}", d.name()))
            .x_label("stretch s")
            .y_label("stretch stress σ_s (N/m)")
            .series(Series::line(
                "shell targets",
                curve.iter().map(|p| (p.s, p.sigma)),
            ));
        for (v, e, _, _) in &results {
            chart = chart.series(Series::line_markers(
                v.name,
                e.samples
                    .iter()
                    .filter(|p| p.direction == d)
                    .map(|p| (p.target.s, p.sigma)),
            ));
        }
        charts.push(chart);
    }
    let errors = LineChart::new("comfort-range error (%) and fit time (s) per variant")
        .x_label("variant (order of the summary)")
        .y_label("error (%) / time (s)")
        .series(Series::line_markers(
            "comfort-range error, own samples (%)",
            results
                .iter()
                .enumerate()
                .map(|(i, (_, e, _, _))| (i as f64, 100.0 * e.comfort_error)),
        ))
        .series(Series::line_markers(
            "comfort-range error, paper's grid (%)",
            results
                .iter()
                .enumerate()
                .map(|(i, (_, _, paper, _))| (i as f64, 100.0 * paper)),
        ))
        .series(Series::line_markers(
            "fit time (s)",
            results
                .iter()
                .enumerate()
                .map(|(i, (_, _, _, t))| (i as f64, *t)),
        ));
    charts.push(errors);
    let refs: Vec<&LineChart> = charts.iter().collect();
    save_grid(&refs, 3, 1.0, &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "fabric": DEVELOPMENT_FABRIC,
            "pattern": pattern.name(),
            "variants": config,
            "threads": rayon::current_num_threads(),
        }),
        data,
    })
}
