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
//! Levenberg–Marquardt refines the geometry since it was measured on the development fabric
//! (release, 2 cores, 3 starts): g 0.0789 → 0.0776, comfort-range error 11.0 → 10.7 %, fit
//! 87 → 144 s (each Levenberg–Marquardt evaluation pays two more objective evaluations for
//! the geometry's forward differences). In the committed full run that followed, `g` fell on
//! all eight fabrics (babyredo garter 0.957 → 0.433, whose swarm had left it far from the
//! others' basin); the comfort-range error fell on five, rose on two (acrylic seed 10.4 →
//! 12.5 %, babyredo stockinette 9.2 → 16.7 %: `g` also weighs the power range and the
//! compression) and stayed on one; the fits take about three times as long.
//!
//! Since then Levenberg–Marquardt computes a point's Jacobian (sensitivities, geometric
//! differences) only where it accepts the point (`commit` of [`solver::bounded_lm`]), so a
//! rejected trial point costs one objective evaluation instead of four, and Broyden's update
//! sees the accepted points only. Development fabric (release, 2 cores, 3 starts): g 0.0776 →
//! 0.0775, fit 144 → 54 s. In the committed full run that followed, `g` fell on four fabrics
//! and rose on four (babyredo garter 0.433 → 0.684, acrylic rib 0.149 → 0.172, acrylic seed
//! 0.0772 → 0.0819, babyredo stockinette 0.0715 → 0.0791: Broyden's update has fewer pairs),
//! the comfort-range error mean fell from 16.0 to 15.6 % (3 instead of 1 of 8 within 10 %) and
//! the slowest fit from 608 to 543 s. A Broyden update at every trial point instead (from the
//! last accepted point, with its Jacobian) ended the development fabric at g 0.0780 in 55 s
//! and was not adopted.
//!
//! **Seed sensitivity** (measured on the development fabric, release, 2 cores, these
//! settings with only the swarm's seed, size or length changed): the committed seed (2022)
//! ends at g 0.0731 (comfort-range error 10.6 %) in 78 s, of which the swarm takes 19 s;
//! seeds 1 / 2 / 3 end at 0.134 / 0.151 / 0.157 (23.4 / 12.9 / 8.4 %). Twice the particles
//! (32) end at 0.165 / 0.085 / 0.097 / 0.169 with seeds 2022 / 1 / 2 / 3 (10.0 / 9.4 / 12.9 /
//! 22.2 %; swarm 29–49 s; mean g 0.129, as with 16), twice the swarm iterations (12) at
//! 0.158 / 0.090 / 0.157 with seeds 1 / 2 / 3 (8.4 / 10.9 / 9.3 %). The objective has at least
//! two basins near g ≈ 0.08 and g ≈ 0.155 that the 16 × 6 swarm reaches by chance, and the
//! higher one has the lower comfort-range error here; every choice below that was made by
//! comparing single runs on this fabric is within this spread. Independent restarts
//! ([`sim_periodic::fit::SwarmSettings::restarts`], the lowest g of several seeds) remove the
//! chance at a linear cost: four restarts from the committed seed (seeds 2022–2025) end at its
//! g 0.0731 in 273 s; three from seed 1 would end at 0.134. This figure has run two since
//! a5c8811 ([`RESTARTS`]), adopted with the comfort-half sample layout ([`SAMPLE_LAYOUT`]),
//! which makes the lower `g` of two swarms the better comfort-range fit.
//!
//! **Path dependence.** Since a6e870b the objective's stress samples at compression nodes are
//! the nodes' equilibria instead of second solves, which moves each of those samples by the
//! Newton tolerance (about 10⁻⁷ relative) and makes a swarm evaluation 11–17 % cheaper at
//! fixed points (`cargo bench -p bench --bench yarn_objective`). The committed full run that
//! followed (against e30cc82): both stockinettes kept their paths (g and evaluation counts as
//! before); g fell on three fabrics (acrylic garter 0.0891 → 0.0884, acrylic rib 0.153 →
//! 0.137, babyredo garter 0.627 → 0.459) and rose on three (acrylic seed 0.0385 → 0.0393,
//! babyredo rib 0.068 → 0.075, babyredo seed 0.237 → 0.248); mean g 0.170 → 0.149, but the
//! comfort-range error mean rose from 9.4 to 11.7 % (held-out 9.3 → 11.8 %; babyredo seed
//! 7.5 → 18.5 %), 3 instead of 4 of 8 within 10 %. Kept: the objective is the same to its
//! solver tolerance and cheaper, and which basin the swarm and Levenberg–Marquardt reach at
//! that level of perturbation is chance (the seed study above).
//!
//! **The seed stitch's primitive tile.** Since 1d6ab80 [`Pattern::Seed`] is the seed's
//! primitive repeat, two loops on a sheared lattice (32 vertices at [`FIT_RESOLUTION`]) instead
//! of its rectangular 2 × 2 repeat (64), chosen for speed before any fit ran on it. The
//! committed full run that followed (against 99f8199, another session): the six other fabrics
//! kept their fits bit for bit (2–13 % slower, the machine's drift); acrylic seed 603 → 360 s,
//! g 0.0393 → 0.0388, comfort-range error 5.2 → 4.8 %; babyredo seed 535 → 305 s, g 0.248 →
//! 0.0815, 18.5 → 13.0 %. Comfort-range mean 11.7 → 10.9 % (held-out 11.8 → 11.0 %), still 3
//! of 8 within 10 %; the slowest fit is now the acrylic seed's 360 s, then the ribs' 349 and
//! 327 s.
//!
//! **Supernodal factorization.** Since 345f92d the periodic solver's KKT matrix is factorized
//! supernodally and the contact Hessian is accumulated as rank-one terms, which moves every
//! equilibrium at the level of rounding. The committed full run that followed (against the run of
//! 1d6ab80, another session): both stockinettes kept their paths (g and evaluation counts as
//! before) in 95 → 80 s and 87 → 80 s; the eight yarn fits took 1417 s instead of 1930 s. The six
//! others took other paths: g rose on five (acrylic garter 0.088 → 0.184, acrylic rib 0.137 →
//! 0.174, acrylic seed 0.0388 → 0.0406, babyredo rib 0.074 → 0.084, babyredo seed 0.081 → 0.316)
//! and fell on one (babyredo garter 0.459 → 0.401); comfort-range mean 10.9 → 13.5 % (held-out 11.0
//! → 13.9 %), 2 instead of 3 of 8 within 10 %; slowest fit 360 → 321 s (acrylic rib, 112 + 91 →
//! 112 + 127 evaluations). Kept, as the change before: the same objective to rounding,
//! cheaper at every point, and the basin reached is chance.
//!
//! **Machine speed.** The committed full run at 60294ab (2026-11-30, later session) has every
//! fit of the run above bit for bit (every CSV value but the times) in 805 s instead of 1417 s;
//! slowest the acrylic rib's 179 s (321 s above; shell fit 18.7 s). Most of that is the
//! machine: the same code (0681d07) fitted the rib in 197 s on it. The rest is 60294ab's dense
//! pattern table, which leaves every solve bit for bit (the rib 197 → 192 s in the benchmark,
//! one run each). The run at ba222cc, whose shell fit runs its directions in parallel (the
//! same fits bit for bit), took the eight shell fits 96 → 56 s (the rib's 18.7 → 9.5 s; its
//! whole fit 189 s) and the yarn fits 797 s.
//!
//! **Comfort-half samples and two swarms.** The committed full run at a5c8811 (2026-11-30,
//! same session and machine as the run above at ba222cc) is, fabric by fabric, the lower-`g`
//! fit of the two comfort-half runs in [`SAMPLE_LAYOUT`]'s table, bit for bit (`g` to every
//! printed digit). Its comfort-range error, on the fit's own samples (half of them in the
//! comfort range): mean 13.5 → 9.5 % (development fabric 10.6 → 10.1 %, held-out 13.9 →
//! 9.4 %), 3 of 8 within 10 % (2 before: acrylic garter 3.6 %, acrylic seed 5.7 %, babyredo
//! rib 7.1 %; acrylic rib 11.9 %, babyredo garter 12.7 %, seed 12.3 %, stockinette 12.7 %);
//! on the paper's even grid of 20 samples, as in the table, 13.5 → 9.2 %, 5 of 8 within
//! 10 %. The eight yarn fits took 797 → 1584 s; the slowest, babyredo rib, 336 s (its shell
//! fit 2.8 s more), above the 300 s goal; one swarm took 204 s.
//!
//! **The paper's grid.** Since 139e613 the figure evaluates each result once more on the
//! paper's even layout ([`on_paper_grid`]) and reports both errors. Its committed full run
//! (2026-11-30, a later hour of the same session) has every fit of the run at a5c8811 bit for
//! bit (`g`, parameters and evaluation counts), and on the paper's grid the throw-away probe's
//! numbers above: mean 9.2 % (development fabric 9.6 %, held-out 9.2 %), 5 of 8 within 10 %.
//! The eight yarn fits took 1688 s, the babyredo rib 379 s (336 s at a5c8811, 341 s in
//! `cargo bench -p bench --bench yarn_fit -- babyredo-rib` earlier that day): the machine's
//! spread between hours.
//!
//! **No repeated evaluations.** Through 0078cf2 every Levenberg–Marquardt start's end point
//! (its last accepted point, already evaluated by the search) was evaluated once more to
//! compare the starts, and the winner once more for the result: 4 local-objective evaluations
//! per swarm, 8 per fit, none of them counted in the evaluations reported. The search now
//! keeps its last accepted point's evaluation. The full run that followed (3658155,
//! 2026-11-30, a later hour) had every fit bit for bit; the eight yarn fits took 1551 s
//! instead of 1688 s (−8 %), the babyredo rib 333 s (379 s), still above the 300 s goal. The
//! unchanged shell fits took 57.1 against 60.3 s (−5 %) in the same runs, so most of the
//! difference is the machine's. `cargo bench -p bench --bench yarn_fit -- babyredo-rib` took
//! 331.0 s (swarm 130.8 s, local search 200.2 s) against 340.7 s (133.0 + 207.7 s) that
//! morning; the acrylic rib 293.3 s. The committed run after it, which adds the comfort-range
//! sample counts ([`comfort_counts`]), has the same fits again in 1663 s (the rib 351 s, the
//! shell fits 60.3 s): the machine's spread within one afternoon.
//!
//! **The compression as a DOF.** Since 2fb7d16 the weft and warp compression nodes are one
//! Newton solve each with `c` as a degree of freedom ([`sim_periodic::periodic::solve_compressed`])
//! instead of a root-find over solves at fixed `c`; the bias kept the root-find until 81a5247
//! (below). Where the
//! curves have one zero-orthogonal-stress state the two agree to the root-find's tolerance,
//! elsewhere they can end on different ones, so most fits took other paths. The committed
//! full run at 2fb7d16 (2026-11-30, the session after the run above) against that run
//! (91ade96):
//!
//! | fabric | g | comfort-range error, own samples | paper's grid | local evaluations | yarn fit |
//! |---|---|---|---|---|---|
//! | acrylic garter | 0.0965 → 0.1505 | 3.6 → 12.5 % | 3.4 → 14.6 % | 341 → 316 | 206 → 191 s |
//! | acrylic rib | 0.1862 → 0.1064 | 11.9 → 10.4 % | 9.8 → 10.2 % | 189 → 151 | 292 → 289 s |
//! | acrylic seed | 0.0350 → 0.0348 | 5.7 → 5.9 % | 5.5 → 5.8 % | 370 → 389 | 248 → 228 s |
//! | acrylic stockinette (development) | 0.0653 → 0.0602 | 10.1 → 7.1 % | 9.6 → 7.1 % | 228 → 308 | 88 → 74 s |
//! | babyredo garter | 0.2008 → 0.1228 | 12.7 → 6.8 % | 13.8 → 6.9 % | 173 → 175 | 173 → 148 s |
//! | babyredo rib | 0.0633 → 0.0603 | 7.1 → 6.8 % | 5.9 → 7.2 % | 187 → 241 | 351 → 263 s |
//! | babyredo seed | 0.1054 → 0.1054 | 12.3 → 12.3 % | 12.4 → 12.4 % | 196 → 214 | 236 → 218 s |
//! | babyredo stockinette | 0.0660 → 0.0438 | 12.7 → 10.3 % | 13.3 → 10.6 % | 250 → 213 | 70 → 59 s |
//!
//! (224 swarm evaluations each, both runs.) `g` fell on six fabrics, stayed on one and rose on
//! the acrylic garter, whose comfort-range error rose most; the mean error went 9.5 → 9.0 % on
//! the fits' own samples (development fabric 10.1 → 7.1 %, held-out 9.4 → 9.3 %), 3 → 4 of 8
//! within 10 %, and 9.2 → 9.3 % on the paper's grid (5 → 4 of 8). The eight yarn fits took
//! 1663 → 1469 s (−12 %) while the unchanged shell fits took 60.3 → 65.8 s (+9 %): this run's
//! machine was the slower. The slowest fit is now the acrylic rib's, 289 s, under the 300 s
//! goal; the babyredo rib took 263 s. `cargo bench -p bench --bench yarn_fit -- babyredo-rib
//! acrylic-yarn-rib` an hour later, the same fits: babyredo rib 298.3 s (swarm 110.1 s, local
//! search 188.2 s; shell fit 3.3 s more) against 331.0 s (130.8 + 200.2 s) before, i.e. 0.49
//! against 0.58 s per swarm evaluation and 0.78 against 1.07 s per local one; acrylic rib
//! 292.3 s (120.1 + 172.3 s; shell 10.8 s) against 293.3 s, with 151 instead of 189 local
//! evaluations. So the yarn fits meet the goal in both runs, by 0.6–2.6 % in the benchmark,
//! and the shell fit in front of them takes the whole chain 1 % past it there.
//!
//! **The bias nodes as well.** Since 81a5247 the bias compression nodes are one joint solve
//! too, its no-sliding rows frozen at the compression of its last pair round, then one solve
//! at the compression found ([`sim_periodic::curves`]). The curves agree with the root-find's
//! to its tolerance (`periodic-curves`: every bias point one joint solve instead of 4–8
//! solves, compressions within 2·10⁻⁷), but, as with every change that moves an evaluation in
//! its last digits, the swarms took other paths. The committed full run at 81a5247
//! (2026-11-30, the session after the run above) against it (2fb7d16):
//!
//! | fabric | g | comfort-range error, own samples | paper's grid | local evaluations | yarn fit |
//! |---|---|---|---|---|---|
//! | acrylic garter | 0.1505 → 0.1716 | 12.5 → 15.0 % | 14.6 → 18.4 % | 316 → 254 | 191 → 147 s |
//! | acrylic rib | 0.1064 → 0.1487 | 10.4 → 10.5 % | 10.2 → 9.9 % | 151 → 190 | 289 → 269 s |
//! | acrylic seed | 0.0348 → 0.0349 | 5.9 → 5.7 % | 5.8 → 5.5 % | 389 → 564 | 228 → 224 s |
//! | acrylic stockinette (development) | 0.0602 → 0.0651 | 7.1 → 8.9 % | 7.1 → 9.4 % | 308 → 253 | 74 → 51 s |
//! | babyredo garter | 0.1228 → 0.2612 | 6.8 → 6.7 % | 6.9 → 7.4 % | 175 → 186 | 148 → 172 s |
//! | babyredo rib | 0.0603 → 0.0614 | 6.8 → 7.0 % | 7.2 → 6.9 % | 241 → 228 | 263 → 252 s |
//! | babyredo seed | 0.1054 → 0.2490 | 12.3 → 17.5 % | 12.4 → 16.2 % | 214 → 194 | 218 → 176 s |
//! | babyredo stockinette | 0.0438 → 0.0438 | 10.3 → 10.3 % | 10.6 → 10.6 % | 213 → 213 | 59 → 49 s |
//!
//! (224 swarm evaluations each, both runs.) The eight yarn fits took 1469 → 1339 s (−9 %)
//! with the unchanged shell fits at 65.8 → 62.0 s (−6 %) in the same runs, so part of that is
//! the machine's; the slowest fit is the acrylic rib's, 269 s, the babyredo rib 252 s. `g`
//! rose on five fabrics, twice over on the babyredo garter and seed; the mean comfort-range
//! error went 9.0 → 10.2 % on the fits' own samples (development fabric 7.1 → 8.9 %, held-out
//! 9.3 → 10.4 %), 4 of 8 within 10 % in both runs, and 9.3 → 10.5 % on the paper's grid (4 → 5
//! of 8). Nothing in the objective's definition changed; the babyredo seed, which had the same
//! fit (`g` 0.1054) in the two runs before, shows how far one fit moves with its path.
//! `cargo bench -p bench --bench yarn_fit -- babyredo-rib acrylic-yarn-rib` right after, the
//! same fits: babyredo rib 253.9 s (swarm 84.5 s, local search 169.4 s; shell fit 2.7 s more)
//! against 298.3 s (110.1 + 188.2 s), i.e. 0.38 against 0.49 s per swarm evaluation and 0.74
//! against 0.78 s per local one; acrylic rib 259.3 s (95.0 + 164.2 s; shell 11.0 s) against
//! 292.3 s (120.1 + 172.3 s). Shell fit and yarn fit together: 256.6 and 270.3 s, 10–15 %
//! under the goal.
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
/// Enough in the comfort range, where the error is measured: there the 21-point curves of
/// the eight shared fabrics differ from 401-point curves of the same shells by 0.01–0.25 %
/// of the comfort-range maximum on average and 0.58 % at most, over 2.7–20 of their
/// intervals (the babyredo stockinette's the fewest; throw-away probe, 200 stretches per
/// comfort range, 2026-11-30).
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
/// Measured on the eight shared fabrics with this figure's targets and settings, one
/// [`fit`] per fabric at each resolution (release, 2 cores; reproducible with `sim-periodic
/// fit` and its `resolution` key; the closing note of issue 15 has the table; this figure
/// times the 16-vertex fits): at 16 the slowest fit (a seed) takes 173 s instead of 291 s, and
/// the comfort-range error is lower on seven fabrics (mean 24.9 → 20.4 %) and higher on the
/// babyredo seed (15.0 → 20.4 %). The fitted parameters belong to tiles of this resolution:
/// with the same yarn model a 24-vertex tile's curves differ by 1–10 % of their largest
/// comfort-range stress where that stress exceeds 100 N/m, and by more on softer curves
/// (stockinette, rib and garter at three points of the paper's box).
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
/// Wider bounds were measured on the development fabric only, with [`LOCAL_STARTS`] starts
/// (release, 2 cores; reproducible with `sim-periodic fit` and its `geometry_x`, `geometry_y`
/// bounds): (0.6, 1.6) ends at g = 0.0787 against 0.0789 here (comfort-range error
/// 9.8 against 11.0 %), with a similar fitted stretch (0.99, 1.25 against 1.01, 1.31), and
/// (0.5, 2.0) at g = 0.105 (14.3 %; the larger box is searched worse by the same swarm). Not
/// adopted: no gain in `g` on the development fabric. 10 of the 16 fitted stretches of the
/// full run lay at a bound while Levenberg–Marquardt kept the swarm's geometry, 4 since it
/// refines it ([`FitSettings::local_geometry`]).
///
/// In the committed run at e30cc82, 7 of the 16 fitted stretches lay at or within 0.5 % of a
/// bound (along x: both ribs and the babyredo seed and garter at 0.75, the acrylic seed at
/// 1.35; along y: both garters). A full run of this figure with (0.6, 1.6) instead (along y for
/// garter and seed: (0.4, 1.07); release, 2 cores, 2026-11-29, against e30cc82) was not
/// adopted. `g` fell on three fabrics (acrylic rib 0.153 → 0.149, babyredo garter 0.627 →
/// 0.153, babyredo seed 0.237 → 0.189) and rose on five (acrylic garter 0.089 → 0.217, acrylic
/// seed 0.039 → 0.050, the development fabric 0.073 → 0.100, babyredo rib 0.068 → 0.071,
/// babyredo stockinette 0.076 → 0.107). The comfort-range error mean rose from 9.4 to 12.3 %
/// (development fabric 10.6 → 14.0 %, held-out 9.3 → 12.1 %), with 2 instead of 4 of 8 within
/// 10 %. Seven of the 16 stretches still lay at a bound of the wider box (x 0.6: acrylic rib,
/// babyredo garter and seed; y 0.4: both garters, both seeds), and the slowest fit took 602 s
/// against 592 s.
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
/// With [`GEOMETRY_BOUNDS`] along y for every pattern, the fitted stretch along y lay at its
/// lower bound on the acrylic garter and both seeds, and at 0.88 on the babyredo garter (the
/// committed full run before this function). Measured with (0.5, 1.35) along
/// x and y on six fabrics (single fits, release, 2 cores, the figure's settings otherwise;
/// against the committed run): acrylic garter g 0.271 → 0.186 (comfort-range error 19.9 →
/// 12.8 %, stretch y 0.50), babyredo garter 0.889 → 0.191 (18.0 → 12.5 %, y 0.54), acrylic
/// seed 0.147 → 0.083 (18.0 → 8.7 %, y 0.55), acrylic rib 0.153 → 0.116 (11.6 → 10.9 %), but
/// babyredo seed 0.228 → 0.483 (10.2 → 32.6 %) and the development fabric 0.0731 → 0.0861
/// (10.6 → 11.9 %): a larger box is searched worse by the same swarm, so only the course height,
/// the bound that was active, moved.
///
/// The committed full run with these bounds (against the one before; stockinette and rib keep
/// their box and their fits bit for bit): acrylic garter g 0.271 → 0.089 (comfort-range error
/// 19.9 → 5.8 %, stretch (1.22, 0.50)), acrylic seed 0.147 → 0.039 (18.0 → 5.9 %, (1.35,
/// 0.54)), babyredo garter 0.889 → 0.627 (18.0 → 13.6 %, at the corner (0.75, 0.90) of its
/// box), babyredo seed 0.228 → 0.237 (10.2 → 7.5 %, (0.75, 0.54)); mean 13.6 → 9.4 %, within
/// 10 %: 1 → 4 of 8. This choice saw six of the eight fabrics (the measurements above).
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
/// Chosen on the development fabric alone (`yarn-fit-ablations`, variants "fitted geometry"
/// and "fitted geometry, 3 LM starts"; measured there with the fitted geometry, release, 2
/// cores): one start ends at g = 0.115 (comfort-range error 15.0 %), two at 0.088 (9.7 %),
/// three at 0.079 (11.0 %) and five at the same point as three; the choice follows `g`, the
/// fit's objective, not the comfort-range error. Each start costs one Levenberg–Marquardt run;
/// the starts run in parallel (the ablation figure times the fit at 16 s with one start and
/// 41 s with three). A larger swarm instead (32 × 10 or 64 × 10 particles × iterations, the
/// paper's size) reached g = 0.091 and 0.092 at 2–4 × the cost, and the swarm's outcome
/// varies with its size (g from 0.078 to 0.18 over five sizes), which the extra starts smooth
/// out. The two-, five-start and swarm-size numbers are reproducible with `sim-periodic fit`
/// (keys `local_starts`, `particles`, `swarm_iterations`) on this figure's targets.
///
/// On the seven held-out fabrics (the committed full run, against one start): `g` fell on the
/// acrylic rib (0.186 → 0.165) and seed (0.083 → 0.082), where another start won, and stayed
/// on the five where the swarm's best won; the comfort-range error rose on those two (19.6 →
/// 22.0 % and 9.6 → 10.4 %), so the held-out mean rose from 17.9 to 18.4 %. The objective
/// (Eq. 11) also weighs the power range and the compression, and on those fabrics a lower `g`
/// trades comfort-range error for them.
///
/// Since Levenberg–Marquardt refines the geometry too ([`FitSettings::local_geometry`]), one
/// start reaches the same point as three on the development fabric (`yarn-fit-ablations`:
/// g 0.0776 in 61 s against 143 s; with the Jacobian at accepted points only, 0.0775 in 35
/// against 67 s; with the paper's swarm inertia as well ([`SWARM_INERTIA`]) no longer: one
/// start ends at 0.1115 in 38 s, three at 0.0731 in 75 s). A full run of this figure with one start (this constant set to 1; release,
/// 2 cores, before the Jacobian was computed at accepted points only) was not adopted: `g` rose on three held-out
/// fabrics (babyredo garter 0.433 → 0.879, comfort-range error 23.2 → 37.3 %; acrylic rib
/// 0.149 → 0.186; acrylic seed 0.0772 → 0.0788, although its comfort-range error fell from
/// 12.5 to 8.5 %) and stayed on the other five, for the slowest fit 383 s instead of 608 s.
pub const LOCAL_STARTS: usize = 3;

/// The swarm's inertia weights at its first and last iteration: the paper's 0.9 → 0.1
/// (§7.3.3, [`sim_periodic::fit::SwarmSettings::inertia`]) instead of argmin's constant
/// `1/(2 ln 2)` (the library's default).
///
/// Chosen on the development fabric alone (`yarn-fit-ablations`, release, 2 cores, three
/// starts, the Jacobian at accepted points only): g 0.0775 → 0.0731 (comfort-range error 9.9
/// → 10.6 %), fit 67 → 75 s; with Levenberg–Marquardt also keeping the swarm's geometry
/// 0.0804. Measured there twice before and not adopted then: with Levenberg–Marquardt keeping
/// the swarm's geometry (g 0.0818 against 0.0789), and with every Jacobian computed eagerly
/// (0.0731 against 0.0776, not tried on the other fabrics).
///
/// In the committed full run that followed (against the constant inertia's run just before,
/// same machine): `g` fell on four fabrics (babyredo seed 0.596 → 0.228, acrylic rib 0.172 →
/// 0.153, babyredo stockinette 0.0791 → 0.0755, the development fabric), stayed on babyredo
/// rib and rose on three (acrylic garter 0.170 → 0.271, acrylic seed 0.082 → 0.147, babyredo
/// garter 0.684 → 0.889): the small swarm lands in different basins with either schedule.
/// Comfort-range error mean 15.6 → 13.6 % (held-out 16.4 → 14.0 %), within 10 %: 3 → 1 of 8
/// (two more at 10.2 and 10.6 %), slowest fit 543 → 780 s (babyredo rib).
pub const SWARM_INERTIA: (f64, f64) = (0.9, 0.1);

/// Where the objective's stress samples lie: half of each direction's in its comfort range
/// ([`SampleLayout::ComfortHalf`], beyond the paper; [`sim_periodic::fit::objective`]'s
/// *Sample layout*), the other half beyond it, instead of evenly over the tested range.
///
/// Chosen after a diagnosis on all eight fabrics (at the committed fits of 565c3a9, the
/// comfort-range terms were 7–42 % of `g`; the rest, mostly power-range compression, is what
/// the fits had traded the comfort range for), then measured with two swarm seeds, one full
/// run each (release, 2 cores, 2026-11-30). The comfort-range error below is measured on the
/// paper's even grid of 20 samples for every fit, so both layouts are compared on one metric
/// (a throw-away probe re-evaluating the fitted parameters); in brackets the objective `g` of
/// the fit's own layout, which is what a fit and its restarts minimize:
///
/// | fabric | even, seed 2022 | even, 2023 | comfort-half, 2022 | comfort-half, 2023 |
/// |---|---|---|---|---|
/// | acrylic garter | 12.6 % (0.184) | 13.2 % (0.154) | 3.4 % (0.097) | 18.0 % (0.188) |
/// | acrylic rib | 16.7 % (0.174) | 11.7 % (0.140) | 9.8 % (0.186) | 20.6 % (0.235) |
/// | acrylic seed | 6.8 % (0.041) | 2.7 % (0.054) | 5.3 % (0.040) | 5.5 % (0.035) |
/// | acrylic stockinette (development) | 10.6 % (0.073) | 8.3 % (0.157) | 9.5 % (0.066) | 9.6 % (0.065) |
/// | babyredo garter | 19.3 % (0.401) | 25.0 % (0.477) | 13.8 % (0.201) | 26.8 % (0.574) |
/// | babyredo rib | 9.0 % (0.084) | 8.0 % (0.074) | 9.6 % (0.071) | 5.9 % (0.063) |
/// | babyredo seed | 18.3 % (0.316) | 34.6 % (0.498) | 12.4 % (0.105) | 44.7 % (1.244) |
/// | babyredo stockinette | 14.7 % (0.076) | 12.9 % (0.074) | 13.3 % (0.066) | 12.8 % (0.067) |
/// | mean | 13.5 % | 14.6 % | 9.7 % | 18.0 % |
/// | best `g` of the two seeds ([`RESTARTS`]) | 12.6 % | | 9.2 % | |
///
/// With one swarm the layout's effect is smaller than the seed's: comfort-half is better
/// with seed 2022 and worse with 2023. What it changes is which fit has the lower `g`: over
/// the two seeds, the even layout's lower `g` had the higher comfort-range error on three
/// fabrics, by 0.7, 4.1 and 2.2 points; the comfort-half layout's on three by 0.2, 0.1 and
/// 0.5. So the best of two swarms by `g` ([`RESTARTS`]) keeps the better comfort-range fit
/// with this layout: 9.2 % mean (5 of 8 within 10 %) against 12.6 % (2 of 8) with the even
/// one, at the same cost. Two seeds are a small sample; the table is the whole of it.
pub const SAMPLE_LAYOUT: SampleLayout = SampleLayout::ComfortHalf;

/// Independent swarms per fit, each with its local search, the lowest final `g` kept
/// ([`sim_periodic::fit::SwarmSettings::restarts`], seeds 2022 and 2023): the swarm's seed
/// moves a fit more than any setting measured here (the [`SAMPLE_LAYOUT`] table; the seed
/// study in this module's docs). Doubles the fit's cost: the slowest yarn fit in the table's
/// runs would take 204 + 113 s (babyredo rib) instead of 204 s.
///
/// What more swarms would give is `yarn-fit-seeds` (one swarm per fit, seeds 2022–2025 on all
/// eight fabrics, release, 2 cores, full run at 23ad93e): keeping the lowest `g` of the first
/// 1, 2 or 4 seeds lowers the mean `g` 0.203 → 0.130 → 0.083 and the mean comfort-range error
/// 11.9 → 10.2 → 9.3 % (3 → 4 → 5 of 8 within 10 %; the two-seed row is this figure's
/// committed run, fit for fit), but on four fabrics the lowest `g` of the four is not their
/// lowest comfort-range error (acrylic rib 13.1 % at g 0.108 against 10.5 % at 0.149,
/// babyredo garter 16.5 % at 0.178 against 6.7 % at 0.261, babyredo stockinette 10.3 % at
/// 0.044 against 6.8 % at 0.062, the development fabric 8.9 % against 8.6 %), and the acrylic
/// rib is above 10 % with every seed. Four swarms would also double the fit's cost (the
/// slowest single-swarm fit took 195 s). So more swarms are not what the remaining fabrics
/// need: there the paper's objective, not the search, stands between the fit and 10 %.
/// Split into its terms (`yarn-fit-seeds`' columns `g_comfort_stretch` and `g_power`), the
/// lower `g` of each of the three pairs above has the larger comfort-range stretch term, the
/// only part the comfort-range error measures (higher → lower `g`: acrylic rib 0.0148 → 0.0189,
/// babyredo garter 0.0043 → 0.0184, babyredo stockinette 0.0028 → 0.0077), and buys its
/// decrease in the power range (stretch plus compression terms 0.119 → 0.084, 0.217 → 0.136,
/// 0.053 → 0.031).
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
