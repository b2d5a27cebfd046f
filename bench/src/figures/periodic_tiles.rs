//! `periodic-tiles`: yarn centre-lines of a periodic tile (2 × 2 copies, top view) at rest and
//! stretched by 50 % along the weft with zero orthogonal stress, showing the loops tighten.

use nalgebra::Vector3;
use sim_periodic::coarse::Coarse;
use sim_periodic::curves::CurveSettings;
use sim_periodic::periodic::{YarnModel, solve_equilibrium};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

use crate::plot::{LineChart, Series, save_side_by_side};
use crate::studies::periodic::{curve, real_stockinette, stress_free};
use crate::{FigureContext, FigureOutput, FigureSpec, Table};

/// Registry entry.
pub fn spec() -> FigureSpec {
    FigureSpec {
        name: "periodic-tiles",
        title: "Stockinette tile at rest and at 50 % weft stretch",
        shows: "top view of the yarn centre-lines (2 × 2 periodic copies, mm) of the real stockinette tile at rest and at s = 0.5 with zero orthogonal stress; the table lists loop geometry per state",
        paper: "seed 002 / 004 periodic tiles: loops straighten along the pull and the fabric narrows",
        guarded: false,
        run,
    }
}

/// Centre-line polylines of every yarn loop of the tile at `positions`, over `copies × copies`
/// periods of the deformed lattice `f`, in mm.
fn polylines(
    tile: &Tile,
    positions: &[Vector3<f64>],
    f: &Coarse,
    copies: i32,
) -> Vec<Vec<(f64, f64)>> {
    let topology = tile.topology().expect("valid tile");
    let f3 = f.f3();
    let mut lines = Vec::new();
    for lp in topology.loops() {
        for i in 0..copies {
            for j in 0..copies {
                let base = f3 * tile.period_offset([i, j]);
                let mut shift = Vector3::zeros();
                let mut line = Vec::new();
                for &e in &lp {
                    let edge = tile.edges[e];
                    let p = positions[edge.v0] + base + shift;
                    line.push((1e3 * p.x, 1e3 * p.y));
                    shift += f3 * tile.period_offset(edge.shift);
                }
                let last = tile.edges[*lp.last().expect("non-empty loop")];
                let p = positions[last.v1] + base + shift;
                line.push((1e3 * p.x, 1e3 * p.y));
                lines.push(line);
            }
        }
    }
    lines
}

fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
    let progress = ctx.progress(2, "relax and stretch");
    let tile = real_stockinette()?;
    let model = YarnModel::default_for_radius(tile.radius);
    let settings = CurveSettings::default();
    let tile = stress_free(&tile, &model, &settings.equilibrium)?;
    progress.inc(1);
    let stretches: Vec<f64> = (0..=5).map(|i| 0.1 * i as f64).collect();
    let points = curve(&tile, &model, Direction::Weft, &stretches, &settings)?;
    let last = points.last().expect("points");
    let coarse = Coarse::uniaxial(last.s, last.c, 0.0);
    let eq = solve_equilibrium(&tile, &model, coarse, None, &settings.equilibrium)?;
    progress.inc(1);
    let rest = Coarse::identity();
    let mut data = Table::new(&["s", "c", "width_mm", "height_mm", "sigma_s_n_per_m"]);
    let mut charts = Vec::new();
    for (label, f, pos) in [
        ("at rest", rest, tile.positions.clone()),
        (
            "s = 0.5",
            coarse,
            sim_periodic::periodic::PeriodicTile::new(&tile, model, coarse, vec![])?
                .positions(&eq.dofs),
        ),
    ] {
        let lines = polylines(&tile, &pos, &f, 2);
        let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        let mut chart = LineChart::new(format!("stockinette, {label}"))
            .x_label("x (mm, weft), one colour per yarn loop copy")
            .y_label("y (mm, warp)");
        for line in lines {
            for &(x, y) in &line {
                (xmin, xmax, ymin, ymax) = (xmin.min(x), xmax.max(x), ymin.min(y), ymax.max(y));
            }
            chart = chart.series(Series::line(String::new(), line));
        }
        let s = if label == "at rest" { 0.0 } else { last.s };
        let c = if label == "at rest" { 0.0 } else { last.c };
        let sigma = if label == "at rest" {
            points[0].sigma_s
        } else {
            last.sigma_s
        };
        data.push_row([s, c, xmax - xmin, ymax - ymin, sigma]);
        charts.push(chart);
    }
    save_side_by_side(&charts[0], &charts[1], &ctx.out_dir, ctx.name)?;
    Ok(FigureOutput {
        summary: vec![
            ("compression at s = 0.5".into(), format!("{:.3}", last.c)),
            (
                "stress at s = 0.5".into(),
                format!("{:.1} N/m", last.sigma_s),
            ),
        ],
        config: serde_json::json!({"tile": "tests/data/patterns/stockinette.pyp", "copies": 2, "stretch": last.s}),
        data,
    })
}
