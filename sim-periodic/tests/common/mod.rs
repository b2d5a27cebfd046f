//! Helpers shared by the integration tests.

// Each test binary includes this module and uses only part of it.
#![allow(dead_code)]

use sim_periodic::coarse::Coarse;
use sim_periodic::fit::{Objective, ObjectiveSettings, TargetPoint, Targets};
use sim_periodic::periodic::{PeriodicTile, YarnModel, initial_dofs};
use solver::{Assembler, Problem};
use yarn_pattern::direction::Direction;
use yarn_pattern::tile::Tile;

/// The real stockinette tile of the test data.
pub fn stockinette() -> Tile {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    yarn_pattern::pyp::read_pyp(path)
        .expect("the real tile loads")
        .tile
}

/// A deterministic, smooth perturbation of the DOFs (fluctuations ~0.05 R, twists ~0.05 rad).
pub fn perturbed(tile: &Tile) -> Vec<f64> {
    let mut x = initial_dofs(tile).unwrap();
    let n = tile.n_vertices();
    for (i, xi) in x.iter_mut().enumerate() {
        let scale = if i < 3 * n { 0.05 * tile.radius } else { 0.05 };
        *xi += scale * ((i as f64) * 0.7).sin();
    }
    x
}

/// Checks the assembled gradient of the tile energy under `coarse` at the perturbed DOFs
/// against central differences of the energy (every DOF), and every `stride`-th Hessian
/// column against central differences of the gradient; both to 1e-5 of the largest entry
/// (Hessian entries coupling a position to a twist are scaled by R).
pub fn assert_assembled_derivatives(tile: &Tile, model: YarnModel, coarse: Coarse, stride: usize) {
    let x = perturbed(tile);
    let pairs = PeriodicTile::find_pairs(tile, &model, &coarse, &x, 1.5).unwrap();
    assert!(pairs.len() > 100, "contacts expected in a knit tile");
    let problem = PeriodicTile::new(tile, model, coarse, pairs).unwrap();
    let n = tile.n_vertices();
    assert_problem_derivatives(&problem, &x, tile.radius, |i| i < 3 * n, stride);
}

/// [`assert_assembled_derivatives`] for any tile problem at `x`: `length(i)` tells the DOFs
/// that are lengths (m, step `1e-6 radius`) from angles (rad, step `1e-6`); every `stride`-th
/// Hessian column and the last one are checked.
pub fn assert_problem_derivatives<P: Problem>(
    problem: &P,
    x: &[f64],
    radius: f64,
    length: impl Fn(usize) -> bool,
    stride: usize,
) {
    let mut asm = Assembler::new(problem).unwrap();
    let a = asm.assemble(problem, x, false).unwrap();
    assert!(a.energy.is_finite());
    let gradient = a.gradient.to_vec();
    // The assembler stores the lower triangle of the symmetric Hessian.
    let lower = a.hessian.to_dense();
    let hessian = |i: usize, j: usize| if i >= j { lower[(i, j)] } else { lower[(j, i)] };
    // Positions are in m (~1e-3), twists in rad: a step per kind.
    let step = |i: usize| if length(i) { 1e-6 * radius } else { 1e-6 };
    let gmax = gradient.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    let mut y = x.to_vec();
    for i in 0..x.len() {
        let h = step(i);
        y[i] = x[i] + h;
        let ep = asm.energy(problem, &y).unwrap();
        y[i] = x[i] - h;
        let em = asm.energy(problem, &y).unwrap();
        y[i] = x[i];
        let fd = (ep - em) / (2.0 * h);
        assert!(
            (fd - gradient[i]).abs() <= 1e-5 * gmax,
            "gradient {i}: {} vs fd {fd}",
            gradient[i]
        );
    }
    let hmax = (0..x.len())
        .map(|i| hessian(i, i).abs())
        .fold(0.0, f64::max);
    let columns = (0..x.len()).step_by(stride).chain([x.len() - 1]);
    for j in columns {
        let h = step(j);
        y[j] = x[j] + h;
        let gp = asm.gradient(problem, &y).unwrap().1.to_vec();
        y[j] = x[j] - h;
        let gm = asm.gradient(problem, &y).unwrap().1.to_vec();
        y[j] = x[j];
        for i in 0..x.len() {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            let scale = if length(i) == length(j) {
                hmax
            } else {
                hmax * radius
            };
            assert!(
                (fd - hessian(i, j)).abs() <= 1e-5 * scale,
                "Hessian ({i}, {j}): {} vs fd {fd}",
                hessian(i, j)
            );
        }
    }
}

/// The tile repeated `k × k` times as one larger periodic tile (copy `(i, j)` of vertex `v` is
/// vertex `v + n (i + k j)`); edge data travel with their copies.
pub fn repeated(tile: &Tile, k: i32) -> Tile {
    let n = tile.n_vertices();
    let copy = |v: usize, i: i32, j: i32| v + n * (i + k * j) as usize;
    let mut big = tile.clone();
    big.period = [k as f64 * tile.period[0], k as f64 * tile.period[1]];
    let (mut positions, mut edges) = (vec![], vec![]);
    for j in 0..k {
        for i in 0..k {
            for v in 0..n {
                positions.push(tile.positions[v] + tile.period_offset([i, j]));
            }
            for e in &tile.edges {
                let (ti, tj) = (i + e.shift[0], j + e.shift[1]);
                edges.push(yarn_pattern::tile::Edge {
                    v0: copy(e.v0, i, j),
                    v1: copy(e.v1, ti.rem_euclid(k), tj.rem_euclid(k)),
                    shift: [ti.div_euclid(k), tj.div_euclid(k)],
                });
            }
        }
    }
    with_copies(big, tile, positions, edges, (k * k) as usize)
}

/// `big` with the copied `positions` and `edges`, and every per-vertex and per-edge array of
/// `tile` repeated for its `copies` copies (copy `c` of vertex `v` is vertex `v + c n`),
/// validated.
fn with_copies(
    mut big: Tile,
    tile: &Tile,
    positions: Vec<nalgebra::Vector3<f64>>,
    edges: Vec<yarn_pattern::tile::Edge>,
    copies: usize,
) -> Tile {
    big.positions = positions;
    big.edges = edges;
    big.twists = tile.twists.repeat(copies);
    big.rest_lengths = tile.rest_lengths.repeat(copies);
    big.rest_twists = tile.rest_twists.repeat(copies);
    big.reference_twists = tile.reference_twists.repeat(copies);
    big.rest_curvatures = tile.rest_curvatures.repeat(copies);
    big.reference_directors = tile.reference_directors.repeat(copies);
    big.validate().unwrap();
    big
}

/// The DOFs of `repeated(tile, k)` that replicate the small tile's `dofs` (fluctuations, then
/// twists) in every copy; positions F X + ũ are then the periodic copies.
pub fn replicated_dofs(dofs: &[f64], n: usize, k: usize) -> Vec<f64> {
    let copies = k * k;
    let mut x = vec![0.0; 4 * copies * n];
    for c in 0..copies {
        x[3 * n * c..3 * n * (c + 1)].copy_from_slice(&dofs[..3 * n]);
        x[3 * n * copies + n * c..3 * n * copies + n * (c + 1)].copy_from_slice(&dofs[3 * n..]);
    }
    x
}

/// The procedural stockinette's input geometry (not relaxed: the fit estimates rest shapes).
pub fn stockinette_geometry() -> Tile {
    let p = sim_periodic::patterns::Pattern::Stockinette;
    p.generate(&p.default_params(1e-3)).unwrap()
}

/// Target curves of `model` on `geometry`, exactly as the objective sees a yarn model: rest
/// shape estimated, then uniaxial curves with zero orthogonal stress.
pub fn targets_of(
    geometry: &Tile,
    model: &YarnModel,
    ranges: &[(Direction, f64)],
    n: usize,
) -> Targets {
    let objective = Objective {
        geometry,
        targets: &Targets::default(),
        settings: ObjectiveSettings::default(),
    };
    let (tile, _, _) = objective.rest_tile(model).unwrap();
    let mut targets = Targets::default();
    for &(d, s_max) in ranges {
        let s: Vec<f64> = (0..n).map(|i| s_max * i as f64 / (n - 1) as f64).collect();
        let curve =
            sim_periodic::curves::uniaxial_curve(&tile, model, d, &s, &Default::default()).unwrap();
        targets.curves.insert(
            d,
            curve
                .iter()
                .map(|p| TargetPoint {
                    s: p.s,
                    c: p.c,
                    sigma: p.sigma_s,
                })
                .collect(),
        );
    }
    targets
}

/// Small weft target curves (3 samples to s = 0.3) of a known yarn inside the paper's bounds
/// on the procedural stockinette, for fits run through the command line.
pub fn known_weft_targets() -> Targets {
    let geometry = stockinette_geometry();
    let base = YarnModel::default_for_radius(1e-3);
    let r = sim_periodic::fit::estimated_radius(&geometry, &base).unwrap();
    let space = sim_periodic::fit::ParameterSpace::paper(&base, r).unwrap();
    let truth = space.model(&[0.6, 0.4, 0.55, 0.45, 0.58]);
    targets_of(&geometry, &truth, &[(Direction::Weft, 0.3)], 3)
}

/// Writes into `dir` a small database run over a 5 × 5 × 3 grid on the real stockinette
/// (`stockinette.pyp`), as two configs with the outputs `single/` and `sharded/`
/// (`single.toml`, `sharded.toml`), for sharded runs through the command line.
pub fn write_sharding_database(dir: &std::path::Path) {
    let tile = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/patterns/stockinette.pyp"
    );
    std::fs::copy(tile, dir.join("stockinette.pyp")).unwrap();
    let config = "tile = \"stockinette.pyp\"\nrelax_period = false\n[database]\n\
                  sx = [-0.1, 0.0, 0.1, 0.2, 0.3]\nsa = [-0.2, -0.1, 0.0, 0.1, 0.2]\n\
                  sy = [0.0, 0.1, 0.2]\n";
    for name in ["single", "sharded"] {
        std::fs::write(
            dir.join(format!("{name}.toml")),
            format!("out = \"{name}\"\n{config}"),
        )
        .unwrap();
    }
}

/// A tiny fit config on the procedural `pattern` against `curves.csv` (seconds per fit).
pub fn small_fit_config(pattern: &str) -> String {
    format!(
        "targets = \"curves.csv\"\npattern = \"{pattern}\"\nout = \"unused\"\n\
         [parameters]\nk1 = \"paper\"\nbending = \"paper\"\n[fit]\nparticles = 4\n\
         swarm_iterations = 2\nswarm_samples = 3\nlocal_samples = 3\nlocal_evaluations = 4\n\
         compression_nodes = 2\nsample_layout = \"comfort-half\"\n"
    )
}

/// Writes into `dir` a campaign of two tiny fits (`stockinette.toml`, `garter.toml`, on
/// [`known_weft_targets`]) × seeds 1 and 2, as `single.toml` and `sharded.toml` with the
/// outputs `single/` and `sharded/`.
pub fn write_sharding_campaign(dir: &std::path::Path) {
    std::fs::write(dir.join("curves.csv"), known_weft_targets().to_csv()).unwrap();
    for pattern in ["stockinette", "garter"] {
        std::fs::write(
            dir.join(format!("{pattern}.toml")),
            small_fit_config(pattern),
        )
        .unwrap();
    }
    for name in ["single", "sharded"] {
        std::fs::write(
            dir.join(format!("{name}.toml")),
            format!(
                "out = \"{name}\"\nfits = [\"stockinette.toml\", \"garter.toml\"]\nseeds = [1, 2]\n"
            ),
        )
        .unwrap();
    }
}

/// The rectangular repeat of a tile with lattice skew ½ as one periodic tile: copies `c = 0, 1`
/// of every vertex at `X + c a₂` (copy `c` of vertex `v` is vertex `v + c n`), periods
/// `A₁ = a₁`, `A₂ = 2 a₂ − a₁ = (0, 2 p_y)`. An edge of copy `c` with shift `(dx, dy)` ends at
/// `X_v1 + (c + dy) a₂ + dx a₁`; writing `c + dy = c' + 2m` (`c' ∈ {0, 1}`) and
/// `2 a₂ = A₂ + a₁`, that is copy `c'` of `v1` shifted by `(dx + m, m)`.
pub fn rectangular_of_half_skew(tile: &Tile) -> Tile {
    assert_eq!(tile.skew, 0.5, "expected a tile with lattice skew ½");
    let n = tile.n_vertices();
    let mut big = tile.clone();
    big.skew = 0.0;
    big.period = [tile.period[0], 2.0 * tile.period[1]];
    let (mut positions, mut edges) = (vec![], vec![]);
    for c in 0..2 {
        for v in 0..n {
            positions.push(tile.positions[v] + tile.period_offset([0, c]));
        }
        for e in &tile.edges {
            let t = c + e.shift[1];
            let (copy, m) = (t.rem_euclid(2), t.div_euclid(2));
            edges.push(yarn_pattern::tile::Edge {
                v0: e.v0 + n * c as usize,
                v1: e.v1 + n * copy as usize,
                shift: [e.shift[0] + m, m],
            });
        }
    }
    with_copies(big, tile, positions, edges, 2)
}
