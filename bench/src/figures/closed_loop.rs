//! `closed-loop`: the loop seed 002 §9 leaves open, on the stockinette of `cross-method`:
//!
//! 1. a `sim-persistent` swatch with known yarn parameters ([`super::cross_method::yarn`]) is
//!    stretched in weft and warp ([`super::cross_method::persistent_test`]);
//! 2. the stiffening shell is fitted to its curves (clamped swatch of the same size);
//! 3. the shell's homogeneous curves are the uniform targets;
//! 4. the yarn-level parameters are fitted to them (`sim_periodic::fit` with `yarn-fit`'s
//!    swarm and Levenberg–Marquardt, but the paper's even samples and one swarm, on the
//!    procedural stockinette);
//! 5. the recovered parameters are compared with the known ones;
//! 6. the recovered yarn is stretched again in `sim-persistent` and its curves compared with
//!    the original's, in the paper's metric (mean absolute stress error relative to the
//!    largest original stress).
//!
//! The periodic model's contact radius and stiffness have no persistent counterpart
//! (`rod::yarn`): their "known" values are the ones the shared description maps to. The
//! re-simulated yarn takes the recovered stretch law and bending stiffness; its radius stays
//! the known one (the persistent layout, and so the swatch's geometry, is built from it).

use anyhow::Context;
use rod::stretch::StretchLaw;
use rod::yarn::YarnMaterial;
use sim_periodic::fit::{Journal, SampleLayout, TargetPoint, Targets, fit};
use sim_periodic::patterns::Pattern;
use sim_periodic::periodic::YarnModel;
use sim_persistent::experiment::uniaxial::{Pull, UniaxialRun};
use yarn_pattern::direction::Direction;

use super::cross_method::{
    PersistentLayout, at, persistent_layout, persistent_test, rest_tile, shell_curves, yarn,
};
use super::yarn_fit::{comfort_counts, on_layout};
use crate::plot::{LineChart, Series, save_side_by_side};
use crate::{FigureContext, FigureOutput, FigureSpec, Table, percent};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "closed-loop",
        title: "Closed loop: persistent swatch → shell → targets → yarn fit → persistent swatch",
        shows: "left: stretch stress (N/m) against stretch of the original persistent stockinette swatch (weft, warp), the shell targets derived from it, the fitted periodic yarn model's curves, and the persistent swatch re-simulated with the recovered yarn; right: the recovered parameters over the known ones",
        paper: "seed 002 §9 names this loop as future work; no published numbers",
        guarded: true,
        run,
    }
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let pattern = Pattern::Stockinette;
    let known = yarn();
    let progress = ctx.progress(4, "swatch, shell, yarn fit, re-simulation");
    // The fabric (loop width and row height) is the known yarn's relaxed tile's; the
    // re-simulation changes the yarn only.
    let layout = persistent_layout(pattern, &rest_tile(pattern)?, PersistentLayout::Seed000)?;
    let stretch_all = |y: &YarnMaterial| -> anyhow::Result<Vec<UniaxialRun>> {
        [Pull::Weft, Pull::Warp]
            .into_iter()
            .map(|pull| {
                let mut test = persistent_test(pattern, pull, ctx.quick, y, layout)?;
                // Original and re-simulated swatches start at the same clamp distance (the
                // layout's), so the loop compares the two yarns on one swatch geometry; a
                // zero-force start would give each its own length and reference width.
                test.zero_force_start = false;
                test.run()
                    .with_context(|| format!("persistent swatch, {}", pull.name()))
            })
            .collect()
    };
    // 1. The original swatch.
    let original = stretch_all(&known)?;
    progress.inc(1);
    // 2-3. Shell and its uniform targets.
    let (shell, _) = shell_curves("closed-loop stockinette", &original, ctx.quick)?;
    let mut targets = Targets::default();
    for (d, (_, uniform)) in &shell {
        targets.curves.insert(
            *d,
            uniform
                .iter()
                .map(|&(s, sigma, c)| TargetPoint { s, c, sigma })
                .collect(),
        );
    }
    progress.inc(1);
    // 4. The yarn fit.
    let base = YarnModel::from_material(&known).map_err(anyhow::Error::msg)?;
    let (geometry, space) = super::yarn_fit::geometry_and_space(pattern, &base, known.radius)?;
    // yarn-fit's settings as they were before its comfort-half samples and second swarm.
    // Full runs, one per row (the recovered k1, onset and g; the
    // comfort-range error on the fit's own samples, with how many lie in the comfort range, and
    // on the comfort-half grid of 20 samples per direction, 18 of them in it; the
    // re-simulation's error in the paper's metric):
    //
    // | layout, swarms | k1 (N) | onset | g | comfort, own samples | comfort-half grid | re-simulated |
    // |---|---|---|---|---|---|---|
    // | even, 1 (this) | 200 (upper bound) | 0.144 | 0.388 | 7.0 % (1) | 26.8 % | weft 344 %, warp 96 % |
    // | comfort-half, 1 | 170 | 0.127 | 0.386 | 36.1 % (18) | 36.1 % | weft 283 %, warp 76 % |
    // | even, 2 | 0.2 (lower bound) | 0 (lower bound) | 0.375 | 2.0 % (1) | 26.3 % | weft 344 %, warp 96 % |
    // | comfort-half, 2 | 0.2 (lower bound) | 0.0053 | 0.286 | 33.4 % (18) | 33.4 % | weft fails at s = 0.019 |
    //
    // The comfort range ends at s ≈ 0.04 (weft) and 0.02 (warp) of 0.5, inside the first of
    // the shell curves' ten intervals, so of the even layout's 20 samples per direction one
    // weft sample lies in it and no warp sample: its 7.0 and 2.0 % rest on one sample. On the
    // comfort-half grid the even fits are the better ones (26.8 and 26.3 % against 36.1 and
    // 33.4 %), and they score lower on the comfort-half objective too (g 0.289 and 0.280,
    // re-evaluated) than the comfort-half fits reached on it: with these targets the
    // comfort-half search ended at worse points of its own objective, so the search, not the
    // layout's weighting, decides (throw-away probe, the same fits). No fit comes near the
    // targets beyond the comfort range: the power-range error is 1200–1600 % in every row.
    //
    // The table was measured before the weft and warp compression nodes became one Newton
    // solve with the compression as a DOF. In its committed run the figure's fit
    // (even, 1) moved to k1 200 N (upper bound) and onset 0.150 (upper bound), with 112 + 61
    // evaluations: 4.8 % on its own samples (the same one weft sample) and 25.9 % on the
    // comfort-half grid, re-simulated as before (weft 344 %, warp 96 %). The other rows were
    // not rerun.
    //
    // The second swarm (seed 2023) wins in both layouts at the box's other corner: k1 and the
    // onset at or near their lower bounds, a yarn stiff (k2 = 200 N) from its rest length, as
    // the first swarm's k1 = 200 N is. The targets ask for that stiffness (the persistent
    // swatch is 3–1200× stiffer than the periodic tile, `cross-method`). With the onset at 0
    // the law is linear with k2 whatever k1, and since `rod::yarn`'s small-strain stiffness
    // says so, both even-sample yarns re-simulate alike; before, the persistent swatch took
    // its contact stiffnesses from k1 = 0.2 N and failed at s = 0.044. With the onset at
    // 0.0053 it still takes them from k1, 100× below the known yarn's, and its static solve
    // fails (Newton, 200 iterations, after 4 halvings); with them from the known 20 N it fails
    // later, at s = 0.275, where the law's stiffness jumps 1000× within 0.5 % strain
    // (throw-away probe). The loop keeps the paper's even samples and one swarm: the two-swarm
    // fits re-simulate no better or not at all, the onset at 0 leaves k1 undetermined (its
    // ratio to the known one means nothing, and the onset's ratio 0 has no place on the
    // chart's log axis), and the even fit has the lower comfort-range error on either grid.
    let mut settings = super::yarn_fit::settings(ctx.quick);
    settings.set_sample_layout(SampleLayout::Even);
    if let Some(swarm) = &mut settings.swarm {
        swarm.restarts = 1;
    }
    let result = fit(
        &geometry,
        &targets,
        &space,
        &settings,
        &Journal::in_memory(),
        &|_| {},
    )
    .context("yarn fit")?;
    // The comfort range ends inside the first target interval, so the fit's even samples put
    // one or none in it: the error is also measured with half of the samples there.
    let resolved = on_layout(
        &geometry,
        &targets,
        &space,
        &settings,
        &result,
        SampleLayout::ComfortHalf,
    )
    .context("the fitted yarn on the comfort-half samples")?;
    progress.inc(1);
    // 5. Recovered against known.
    let known_values: Vec<f64> = space.free.iter().map(|b| b.parameter.get(&base)).collect();
    let names: Vec<&str> = space.free.iter().map(|b| b.parameter.name()).collect();
    // 6. Re-simulation with the recovered stretch law and bending.
    let recovered = YarnMaterial {
        stretch: result.model.stretch,
        bending: result.model.bending,
        twist: result.model.twist,
        ..known
    };
    let again = stretch_all(&recovered)?;
    progress.inc(1);

    let mut data = Table::new(&["direction", "curve", "s", "sigma_n_per_m", "c"]);
    let mut chart = LineChart::new("stockinette: original, targets, fit, re-simulated")
        .x_label("stretch s")
        .y_label("σ (N/m)");
    let mut summary = Vec::new();
    let mut errors = Vec::new();
    for (orig, re) in original.iter().zip(&again) {
        let d = match orig.pull {
            Pull::Weft => Direction::Weft,
            Pull::Warp => Direction::Warp,
        };
        let pts = |r: &UniaxialRun| -> Vec<(f64, f64, f64)> {
            r.samples
                .iter()
                .map(|p| (p.stretch, p.stress, p.compression))
                .collect()
        };
        let (o, r) = (pts(orig), pts(re));
        let fitted: Vec<(f64, f64, f64)> = result
            .evaluation
            .samples
            .iter()
            .filter(|p| p.direction == d)
            .map(|p| (p.target.s, p.sigma, p.c))
            .collect();
        let curves = [
            ("original swatch", o.clone()),
            ("shell targets", shell[&d].1.clone()),
            ("yarn fit (periodic)", fitted),
            ("re-simulated swatch", r.clone()),
        ];
        for (ci, (label, curve)) in curves.iter().enumerate() {
            for &(s, sigma, c) in curve {
                data.push_row([d.angle().to_degrees(), ci as f64, s, sigma, c]);
            }
            chart = chart.series(Series::line_markers(
                format!("{} {label}", d.name()),
                curve.iter().map(|p| (p.0, p.1)),
            ));
        }
        // The paper's metric: mean |Δσ| over the samples, relative to the largest original σ.
        let max = o.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
        let e = o
            .iter()
            .skip(1)
            .map(|&(s, sigma, _)| (at(&r, s).0 - sigma).abs())
            .sum::<f64>()
            / (o.len() - 1) as f64
            / max;
        errors.push(e);
        summary.push((
            format!("re-simulated vs original, {}", d.name()),
            format!(
                "{} mean |Δσ| / max |σ| (σ at the last stretch {:.2} vs {:.2} N/m)",
                percent(e),
                r.last().map_or(f64::NAN, |p| p.1),
                o.last().map_or(f64::NAN, |p| p.1)
            ),
        ));
    }
    let mut ratios = LineChart::new("recovered / known parameter")
        .x_label("parameter (k1, onset, k_b, R1, k_c1)")
        .y_label("ratio (log)")
        .log_y();
    let mut points = Vec::new();
    for (i, ((name, k), v)) in names
        .iter()
        .zip(&known_values)
        .zip(&result.values)
        .enumerate()
    {
        points.push((i as f64, v / k));
        summary.push((
            format!("parameter {name}"),
            format!("recovered {v:.4e}, known {k:.4e} (ratio {:.3})", v / k),
        ));
    }
    ratios = ratios
        .series(Series::markers("recovered / known", points))
        .hline("1", 1.0);
    save_side_by_side(&chart, &ratios, &ctx.out_dir, ctx.name)?;
    summary.insert(
        0,
        (
            "yarn fit".into(),
            format!(
                "comfort-range error against the shell targets {} on the fit's even samples \
                 ({} of them in the comfort range), {} with half of them there ({}); {} + {} \
                 evaluations",
                percent(result.evaluation.comfort_error),
                comfort_counts(&result.evaluation),
                percent(resolved.comfort_error),
                comfort_counts(&resolved),
                result.evaluations[0],
                result.evaluations[1]
            ),
        ),
    );
    let stiff = match known.stretch {
        StretchLaw::TwoPhase { k2, .. } => k2,
        StretchLaw::Linear { k } => k,
    };
    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "pattern": "stockinette",
            "known_yarn": format!("{known:?}"),
            "fixed_k2_n": stiff,
            "parameters": names,
            "known": known_values,
            "recovered": result.values,
            "resimulation_errors": errors,
            "comfort_error": [result.evaluation.comfort_error, resolved.comfort_error],
            "comfort_samples": [comfort_counts(&result.evaluation), comfort_counts(&resolved)],
        }),
        data,
    })
}
