//! `periodic-vs-reference` (issue 57; seed 004 §3): our displacement table of MADYPG's
//! published stockinette tile against MADYPG's own published table, through
//! [`compare_with_published`] (relax the file tile at zero strain under our model with the
//! file's period, generate on the published axes, express relative to the file geometry,
//! compare with [`yarn_pattern::agreement`]: per-sample rigid translation removed).
//!
//! - `periodic-vs-reference.png`: per-sample field correlation and RMS difference (in yarn
//!   radii R) on the 9³ table (5³ in quick mode) for the default model and for the variant
//!   that agrees best on 5³; and the pooled correlation and RMS difference of every model
//!   variant on the 5³ table (which change moved the agreement how much).
//! - `periodic-vs-reference-fields.png`: the ΔQ fields side by side for a weft stretch, a
//!   wale stretch, a shear and a combined sample of the default model's table. Top row: the
//!   tile's yarns over one period, seen along z (the fabric normal), in material space, at
//!   the file geometry and displaced by the published and by our ΔQ (each without its mean
//!   translation). Bottom row: the length of the difference per vertex.

use anyhow::Context;
use rod::stretch::StretchLaw;
use sim_periodic::database::DatabaseSettings;
use sim_periodic::periodic::YarnModel;
use sim_periodic::reference::{PublishedComparison, compare_with_published};
use yarn_pattern::madypg::Database;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series, save_grid};
use crate::studies::periodic::real_stockinette;
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "periodic-vs-reference",
        title: "Our displacement table of MADYPG's stockinette against the published one",
        shows: "per-sample field correlation and RMS difference of our ΔQ table against MADYPG's published 9³ stockinette table (default model and the best 5³ variant), the pooled agreement of each model variant on the published 5³ table, and the ΔQ fields side by side (file geometry, published, ours) with their per-vertex difference for weft stretch, wale stretch, shear and a combined sample",
        paper: "seed 004 §3 (the database of periodic displacements ΔQ); the reference is MADYPG's published table, MIT",
        guarded: false,
        run,
    }
}

/// The published tables shipped with the tests (MADYPG, see its licence).
fn published(n: usize) -> anyhow::Result<Database> {
    let dir = format!(
        "{}/../tests/data/madypg/model_stock_{n}",
        env!("CARGO_MANIFEST_DIR")
    );
    Database::read(&dir).with_context(|| format!("reading {dir}"))
}

/// The model variants compared on the 5³ table: a name and the change to the default model.
/// The chart's axis numbers them with [`SHORT`].
fn variants(radius: f64) -> Vec<(&'static str, YarnModel)> {
    let base = YarnModel::default_for_radius(radius);
    let with = |f: &dyn Fn(&mut YarnModel)| {
        let mut m = base;
        f(&mut m);
        m
    };
    vec![
        ("default", base),
        ("k_b / 10", with(&|m| m.bending *= 0.1)),
        ("k_b / 100", with(&|m| m.bending *= 0.01)),
        ("k_b / 1000", with(&|m| m.bending *= 1e-3)),
        (
            "k_b / 100, k_t × 10",
            with(&|m| {
                m.bending *= 0.01;
                m.twist *= 10.0;
            }),
        ),
        ("contact R₁ = 1.1 R", with(&|m| m.contact[0].radius *= 1.1)),
        ("contact k₁ × 0.1", with(&|m| m.contact[0].stiffness *= 0.1)),
        (
            "linear stretch 200 N, k_b / 10",
            with(&|m| {
                m.stretch = StretchLaw::Linear { k: 200.0 };
                m.bending *= 0.1;
            }),
        ),
        (
            "linear stretch 200 N, k_b / 100",
            with(&|m| {
                m.stretch = StretchLaw::Linear { k: 200.0 };
                m.bending *= 0.01;
            }),
        ),
        (
            "linear stretch 2000 N, k_b / 100",
            with(&|m| {
                m.stretch = StretchLaw::Linear { k: 2000.0 };
                m.bending *= 0.01;
            }),
        ),
    ]
}

/// Short names of [`variants`], in order, for the chart's axis (`b`: the bending stiffness's
/// factor, `t`: the twist stiffness's, `L`: a linear stretch law of that stiffness in N).
const SHORT: [&str; 10] = [
    "default",
    "b/10",
    "b/100",
    "b/1e3",
    "b/100 t×10",
    "R₁×1.1",
    "k₁×0.1",
    "L200 b/10",
    "L200 b/100",
    "L2000 b/100",
];

/// The index of the entry of `axis` closest to `value`.
fn nearest(axis: &[f64], value: f64) -> usize {
    (0..axis.len())
        .min_by(|&a, &b| (axis[a] - value).abs().total_cmp(&(axis[b] - value).abs()))
        .expect("a non-empty axis")
}

/// The vertices of one period of the tile's yarns in order along each yarn, unwrapped
/// across the period (vertex, lattice offset in m), one list per yarn chain.
fn chains(tile: &Tile) -> Vec<Vec<(usize, [f64; 2])>> {
    let n = tile.n_vertices();
    let mut next = vec![None; n];
    for e in &tile.edges {
        next[e.v0] = Some((e.v1, e.shift));
    }
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    for start in 0..n {
        if seen[start] {
            continue;
        }
        let (mut v, mut offset) = (start, [0.0f64; 2]);
        let mut chain = Vec::new();
        while !seen[v] {
            seen[v] = true;
            chain.push((v, offset));
            let Some((w, shift)) = next[v] else { break };
            let o = tile.period_offset(shift);
            offset = [offset[0] + o.x, offset[1] + o.y];
            v = w;
        }
        // Close the loop back to the start of the chain (one full period of the yarn).
        if v == start {
            chain.push((start, offset));
        }
        out.push(chain);
    }
    out
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let tile = real_stockinette()?;
    let radius = tile.radius;
    let settings = DatabaseSettings::default();
    let table5 = published(5)?;
    let main_n = if ctx.quick { 5 } else { 9 };
    let main_table = if ctx.quick {
        table5.clone()
    } else {
        published(9)?
    };
    let variants = variants(radius);
    let variants: Vec<_> = if ctx.quick {
        variants.into_iter().take(3).collect()
    } else {
        variants
    };
    let progress = ctx.progress(variants.len() as u64 + 2, "comparisons");
    let compare = |table: &Database, model: &YarnModel| -> anyhow::Result<PublishedComparison> {
        let c = compare_with_published(&tile, table, model, &settings)?;
        progress.inc(1);
        Ok(c)
    };

    let mut data = Table::new(&[
        "run",
        "table_n",
        "isx",
        "isa",
        "isy",
        "sx",
        "sa",
        "sy",
        "correlation",
        "rms_difference_r",
        "rms_ours_r",
        "rms_reference_r",
        "rms_twist_difference_rad",
    ]);
    let mut summary = Vec::new();
    let push_samples = |data: &mut Table, run: usize, n: usize, c: &PublishedComparison| {
        for s in &c.agreement.samples {
            data.push_row([
                run as f64,
                n as f64,
                s.index[0] as f64,
                s.index[1] as f64,
                s.index[2] as f64,
                s.strain[0],
                s.strain[1],
                s.strain[2],
                s.correlation,
                s.rms_difference / radius,
                s.rms_ours / radius,
                s.rms_reference / radius,
                s.rms_twist_difference,
            ]);
        }
    };
    let describe = |c: &PublishedComparison| {
        format!(
            "correlation {:.2}, RMS difference {:.2} R (reference {:.2} R), twist {:.3} rad; \
             zero-strain relaxation moved the file tile {:.2} R; {} unsolved; {:.0} s",
            c.agreement.correlation,
            c.agreement.rms_difference / radius,
            c.agreement.rms_reference / radius,
            c.agreement.rms_twist_difference,
            c.relaxation_shift / radius,
            c.unsolved,
            c.seconds
        )
    };

    // The variants on the 5³ table (runs 0…): which change moves the agreement how much.
    let mut pooled = Vec::new();
    for (k, (name, model)) in variants.iter().enumerate() {
        let c = compare(&table5, model)?;
        push_samples(&mut data, k, 5, &c);
        summary.push((format!("5³, {name}"), describe(&c)));
        pooled.push((
            *name,
            c.agreement.correlation,
            c.agreement.rms_difference / radius,
        ));
    }
    let best = (0..pooled.len())
        .max_by(|&a, &b| pooled[a].1.total_cmp(&pooled[b].1))
        .expect("at least one variant");

    // The main table: default and best variant.
    let main_runs = [(0usize, variants[0].0), (best, variants[best].0)];
    let mut main = Vec::new();
    for (k, (v, name)) in main_runs.iter().enumerate() {
        let c = compare(&main_table, &variants[*v].1)?;
        push_samples(&mut data, variants.len() + k, main_n, &c);
        summary.push((format!("{main_n}³, {name}"), describe(&c)));
        main.push((*name, c));
    }

    // Per-sample agreement on the main table.
    let mut corr = LineChart::new(format!("{main_n}³: field correlation per sample"))
        .x_label("sample (sx fastest, then sa, then sy)")
        .y_label("correlation of ΔQ")
        .hline("0.9 (goal)", 0.9);
    let mut rms = LineChart::new(format!("{main_n}³: RMS difference per sample"))
        .x_label("sample (sx fastest, then sa, then sy)")
        .y_label("RMS of the difference (R)")
        .hline("0.2 R (goal)", 0.2);
    for (name, c) in &main {
        let pts = |f: &dyn Fn(&yarn_pattern::agreement::SampleAgreement) -> f64| {
            c.agreement
                .samples
                .iter()
                .enumerate()
                .map(|(i, s)| (i as f64, f(s)))
                .collect::<Vec<_>>()
        };
        corr = corr.series(Series::markers(*name, pts(&|s| s.correlation)));
        rms = rms.series(Series::markers(*name, pts(&|s| s.rms_difference / radius)));
    }
    rms = rms.series(Series::line(
        "RMS of the reference",
        main[0]
            .1
            .agreement
            .samples
            .iter()
            .enumerate()
            .map(|(i, s)| (i as f64, s.rms_reference / radius)),
    ));
    let index_label = (0..pooled.len())
        .map(|i| format!("{i} {}", SHORT[i]))
        .collect::<Vec<_>>()
        .join(", ");
    let by_variant = LineChart::new(
        "5³: pooled agreement per variant (b: k_b ×, t: k_t ×, L: linear stretch, N)",
    )
    .x_label(index_label)
    .y_label("correlation; RMS difference (R)")
    .series(Series::markers(
        "correlation",
        pooled.iter().enumerate().map(|(i, p)| (i as f64, p.1)),
    ))
    .series(Series::triangles(
        "RMS difference (R)",
        pooled.iter().enumerate().map(|(i, p)| (i as f64, p.2)),
    ));
    save_grid(&[&corr, &rms, &by_variant], 3, 1.0, &ctx.out_dir, ctx.name)?;

    // The fields of the default model on the main table.
    let axes = &main_table.axes;
    let (zx, za, zy) = (
        nearest(&axes[0], 0.0),
        nearest(&axes[1], 0.0),
        nearest(&axes[2], 0.0),
    );
    let top = |a: &[f64]| a.len() - 1;
    let high = |a: &[f64]| a.len().saturating_sub(2);
    let picks = [
        ("weft stretch", [top(&axes[0]), za, zy]),
        ("wale stretch", [zx, za, top(&axes[2])]),
        ("shear", [zx, top(&axes[1]), zy]),
        ("combined", [high(&axes[0]), high(&axes[1]), high(&axes[2])]),
    ];
    let ours = &main[0].1.ours;
    let chain_list = chains(&tile);
    let mut shapes = Vec::new();
    let mut differences = Vec::new();
    for (name, index) in picks {
        let strain = [axes[0][index[0]], axes[1][index[1]], axes[2][index[2]]];
        let (f_ref, f_ours) = (
            main_table.translation_free(index),
            ours.translation_free(index),
        );
        let sample = main[0]
            .1
            .agreement
            .samples
            .iter()
            .find(|s| s.index == index)
            .expect("every sample is compared");
        let mut shape = LineChart::new(format!(
            "{name} ({:.2}, {:.2}, {:.2}): corr {:.2}",
            strain[0], strain[1], strain[2], sample.correlation
        ))
        .x_label("x (R, material space)")
        .y_label("y (R)");
        for (label, f) in [
            ("file geometry", None),
            ("published", Some(&f_ref)),
            ("ours", Some(&f_ours)),
        ] {
            // Every yarn of the tile in one series, the yarns separated by a NaN point.
            let pts: Vec<(f64, f64)> = chain_list
                .iter()
                .flat_map(|chain| {
                    chain
                        .iter()
                        .map(|&(v, o)| {
                            let p = tile.positions[v];
                            let d = f.map_or([0.0; 3], |f| f[v]);
                            ((p.x + o[0] + d[0]) / radius, (p.y + o[1] + d[1]) / radius)
                        })
                        .chain([(f64::NAN, f64::NAN)])
                })
                .collect();
            shape = shape.series(if f.is_none() {
                Series::dashed(label, pts)
            } else {
                Series::line(label, pts)
            });
        }
        shapes.push(shape);
        let diff = LineChart::new(format!(
            "{name}: |ΔQ ours − published|, RMS {:.2} R",
            sample.rms_difference / radius
        ))
        .x_label("vertex")
        .y_label("difference (R)")
        .series(Series::line(
            "difference",
            (0..tile.n_vertices()).map(|v| {
                let d: f64 = (0..3).map(|k| (f_ours[v][k] - f_ref[v][k]).powi(2)).sum();
                (v as f64, d.sqrt() / radius)
            }),
        ))
        .series(Series::dashed(
            "|ΔQ published|",
            (0..tile.n_vertices()).map(|v| {
                let d: f64 = (0..3).map(|k| f_ref[v][k].powi(2)).sum();
                (v as f64, d.sqrt() / radius)
            }),
        ));
        differences.push(diff);
    }
    let panels: Vec<&LineChart> = shapes.iter().chain(differences.iter()).collect();
    save_grid(
        &panels,
        picks.len(),
        0.8,
        &ctx.out_dir,
        &format!("{}-fields", ctx.name),
    )?;

    Ok(FigureOutput {
        summary,
        config: serde_json::json!({
            "tile": "tests/data/patterns/stockinette.pyp (MADYPG's stockinette, byte-identical to the table's pyp)",
            "published": ["tests/data/madypg/model_stock_5", format!("tests/data/madypg/model_stock_{main_n}")],
            "variants": pooled.iter().map(|p| p.0).collect::<Vec<_>>(),
            "runs": "0…(variants − 1): each variant on the 5³ table; then the default and the best 5³ variant on the main table",
            "main_table": main_n,
            "best_variant": variants[best].0,
            "fields_samples": picks.iter().map(|(n, i)| format!("{n} {i:?}")).collect::<Vec<_>>(),
            "metric": "yarn_pattern::agreement: per-sample mean translation removed, correlation and RMS pooled over samples",
            "settings": "DatabaseSettings::default() with fill_unsolved; relaxation keeps the file period",
        }),
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chains of the real stockinette visit every vertex once and are continuous: each
    /// step is one edge of the tile, unwrapped across the period.
    #[test]
    fn chains_are_continuous_yarns() {
        let tile = real_stockinette().unwrap();
        let chains = chains(&tile);
        let mut seen: Vec<usize> = chains
            .iter()
            .flat_map(|c| c[..c.len() - 1].iter().map(|&(v, _)| v))
            .collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..tile.n_vertices()).collect::<Vec<_>>());
        for chain in &chains {
            assert_eq!(chain.first().unwrap().0, chain.last().unwrap().0, "closed");
            for w in chain.windows(2) {
                let at = |(v, o): (usize, [f64; 2])| {
                    tile.positions[v] + nalgebra::Vector3::new(o[0], o[1], 0.0)
                };
                let e = tile.edges.iter().position(|e| e.v0 == w[0].0).unwrap();
                let step = (at(w[1]) - at(w[0])).norm();
                let edge = (tile.edge_end_shifted(e) - tile.positions[w[0].0]).norm();
                assert!(
                    (step - edge).abs() < 1e-12 * edge.max(1.0),
                    "{step} vs {edge}"
                );
            }
        }
    }

    #[test]
    fn every_variant_has_a_short_name() {
        assert_eq!(variants(1e-3).len(), SHORT.len());
    }
}
