//! The procedural pattern library: the polyline → tile builder against the real stockinette
//! tile, rest-state consistency of the built rest shape, and for every pattern: validity,
//! periodicity, relaxation to convergence, clearance after relaxing, a relaxed tile being its
//! own equilibrium, and the `.pyp` round trip.

use nalgebra::Vector3;
use sim_periodic::coarse::Coarse;
use sim_periodic::patterns::{
    Pattern, PatternError, PatternParams, RelaxSettings, Yarn, min_clearance, rebase, relax,
    reset_rest_shape, tile_from_yarns,
};
use sim_periodic::periodic::{
    EquilibriumSettings, PeriodicTile, YarnModel, initial_dofs, solve_equilibrium,
};
use solver::Assembler;
use yarn_pattern::pyp::{parse_pyp, read_pyp, to_pyp_string, write_pyp};
use yarn_pattern::tile::Tile;

const R: f64 = 1e-3;

mod common;
use common::stockinette;

/// Coarse test resolution: 16 vertices per knit loop, 3 per weave crossing.
fn test_params(pattern: Pattern) -> PatternParams {
    let mut p = pattern.default_params(R);
    p.resolution = if pattern.is_knit() { 16 } else { 3 };
    p
}

/// The yarns of a tile as unwrapped polylines (loop order), with the original vertex of
/// every point.
fn yarns_of(tile: &Tile) -> (Vec<Yarn>, Vec<usize>) {
    let topology = tile.topology().unwrap();
    let mut yarns = Vec::new();
    let mut vertex = Vec::new();
    for lp in topology.loops() {
        let mut p = tile.positions[tile.edges[lp[0]].v0];
        let mut points = Vec::new();
        let mut shift = [0, 0];
        for &e in &lp {
            points.push(p);
            vertex.push(tile.edges[e].v0);
            p += tile.edge_vector(e);
            shift[0] += tile.edges[e].shift[0];
            shift[1] += tile.edges[e].shift[1];
        }
        yarns.push(Yarn { points, shift });
    }
    (yarns, vertex)
}

#[test]
fn builder_reproduces_the_real_stockinette_geometry_and_rest_lengths() {
    let real = stockinette();
    let (yarns, vertex) = yarns_of(&real);
    let built = tile_from_yarns(real.period, real.skew, real.radius, &yarns).unwrap();
    assert_eq!(built.n_vertices(), real.n_vertices());
    let real_loops: Vec<usize> = real
        .topology()
        .unwrap()
        .loops()
        .iter()
        .map(Vec::len)
        .collect();
    let built_loops: Vec<usize> = built
        .topology()
        .unwrap()
        .loops()
        .iter()
        .map(Vec::len)
        .collect();
    assert_eq!(built_loops, real_loops);
    let real_topology = real.topology().unwrap();
    let mut worst = 0.0f64;
    for (i, &v) in vertex.iter().enumerate() {
        // Same point up to a whole number of periods.
        let d = built.positions[i] - real.positions[v];
        for c in 0..2 {
            let k = d[c] / real.period[c];
            assert!((k - k.round()).abs() < 1e-9, "vertex {v}: offset {d:?}");
        }
        assert!(d.z.abs() < 1e-15);
        // Built edge i starts at built vertex i; the real edge leaving v.
        let e = real_topology.outgoing(v);
        assert!((built.edge_vector(i) - real.edge_vector(e)).norm() < 1e-12);
        assert!((built.rest_lengths[i] - real.edge_vector(e).norm()).abs() < 1e-15);
        worst = worst.max((built.rest_lengths[i] / real.rest_lengths[e] - 1.0).abs());
        // Directors orthogonal to their edges and unit.
        let t = built.edge_vector(i).normalize();
        assert!(built.reference_directors[i].dot(&t).abs() < 1e-12);
        assert!((built.reference_directors[i].norm() - 1.0).abs() < 1e-12);
    }
    // The file's *RL agrees with the rest geometry to 0.3 % (see the pyp module docs).
    assert!(worst < 4e-3, "rest lengths differ by up to {worst}");
    // Genuinely periodic: edges cross the tile boundary.
    assert!(built.edges.iter().any(|e| e.shift != [0, 0]));
}

/// Gradient (positions and twists) of stretch, bending and twist at the tile's rest state, with
/// the given rest shape, and the same with zero rest curvature for scale.
fn rest_gradients(tile: &Tile) -> (f64, f64, f64) {
    let model = YarnModel::default_for_radius(tile.radius);
    let x = initial_dofs(tile).unwrap();
    let grad = |t: &Tile| {
        let problem = PeriodicTile::new(t, model, Coarse::identity(), vec![]).unwrap();
        let mut asm = Assembler::new(&problem).unwrap();
        let (energy, g) = asm.gradient(&problem, &x).unwrap();
        (energy, g.iter().fold(0.0f64, |m, v| m.max(v.abs())))
    };
    let (energy, g) = grad(tile);
    let mut straight = tile.clone();
    straight
        .rest_curvatures
        .iter_mut()
        .for_each(|k| *k = [0.0; 2]);
    let (_, g_straight) = grad(&straight);
    (energy, g, g_straight)
}

#[test]
fn built_rest_shape_has_zero_bending_and_twist_gradient_at_rest() {
    let real = stockinette();
    let (yarns, _) = yarns_of(&real);
    let mut tiles = vec![tile_from_yarns(real.period, real.skew, real.radius, &yarns).unwrap()];
    for pattern in Pattern::ALL {
        tiles.push(pattern.generate(&test_params(pattern)).unwrap());
    }
    for tile in &tiles {
        let (energy, g, g_straight) = rest_gradients(tile);
        assert!(
            g_straight > 1e-4,
            "scale check: curved yarns bend ({g_straight})"
        );
        assert!(energy.abs() < 1e-18, "rest energy {energy}");
        assert!(g < 1e-9 * g_straight, "rest gradient {g} vs {g_straight}");
    }
}

#[test]
fn every_pattern_generates_a_valid_periodic_tile_without_deep_overlaps() {
    let model = YarnModel::default_for_radius(R);
    for pattern in Pattern::ALL {
        let params = test_params(pattern);
        let tile = pattern.generate(&params).unwrap();
        tile.validate().unwrap();
        check_periodic(pattern, &tile);
        // Edge vectors, shifts included, are exactly the unwrapped polyline's edges.
        let (_, yarns) = pattern.yarns(&params).unwrap();
        let mut e = 0;
        for yarn in &yarns {
            let m = yarn.points.len();
            for k in 0..m {
                let next = if k + 1 < m {
                    yarn.points[k + 1]
                } else {
                    yarn.points[0] + tile.period_offset(yarn.shift)
                };
                assert!((tile.edge_vector(e) - (next - yarn.points[k])).norm() < 1e-12);
                e += 1;
            }
        }
        let c = min_clearance(&tile, &model).unwrap();
        // The guess may have yarns closer than 2R (contacts resolve that) but not deeply
        // interpenetrating.
        if let Some(c) = c {
            assert!(
                c.distance > 0.6 * 2.0 * R,
                "{}: guess clearance {c:?}",
                pattern.name()
            );
        }
        assert_eq!(Pattern::from_name(pattern.name()), Some(pattern));
        // Vertex count from the construction.
        let expected = match pattern {
            Pattern::Stockinette => 16,
            Pattern::Garter | Pattern::Rib1x1 | Pattern::Seed => 32,
            Pattern::Rib2x2 => 64,
            Pattern::PlainWeave => 4 * 2 * 3,
            Pattern::BasketWeave => 8 * 4 * 3,
            Pattern::Satin => 10 * 5 * 3,
        };
        assert_eq!(tile.n_vertices(), expected, "{}", pattern.name());
        // Only the seed stitch has a sheared primitive repeat; its rectangular repeat is
        // 2 × 2 (twice the vertices), every other pattern's is its primitive tile.
        let rectangular = pattern.generate_rectangular(&params).unwrap();
        assert_eq!(rectangular.skew, 0.0, "{}", pattern.name());
        check_periodic(pattern, &rectangular);
        if pattern == Pattern::Seed {
            assert_eq!(tile.skew, 0.5);
            assert_eq!(pattern.repeat(), [2, 1]);
            assert_eq!(rectangular.n_vertices(), 2 * expected);
            assert_eq!(rectangular.period, [tile.period[0], 2.0 * tile.period[1]]);
        } else {
            assert_eq!(tile.skew, 0.0, "{}", pattern.name());
            assert_eq!(rectangular, tile, "{}", pattern.name());
        }
    }
}

/// Every vertex lies in the centred cell, every yarn crosses the boundary (the loop's total
/// shift is non-zero) and the 3 × 3 copy has no jumps: every edge, shift included, is shorter
/// than twice the mean rest length and consecutive edges turn by less than 90° (an edge with
/// a wrong shift would point back across the tile).
fn check_periodic(pattern: Pattern, tile: &Tile) {
    let name = pattern.name();
    let topology = tile.topology().unwrap();
    for lp in topology.loops() {
        let total = lp.iter().fold([0, 0], |s, &e| {
            [s[0] + tile.edges[e].shift[0], s[1] + tile.edges[e].shift[1]]
        });
        assert_ne!(total, [0, 0], "{name}: a yarn loop closes inside the tile");
    }
    let bound = 2.0 * tile.rest_lengths.iter().sum::<f64>() / tile.n_vertices() as f64;
    for i in -1..=1 {
        for j in -1..=1 {
            let image = tile.period_offset([i, j]);
            for e in 0..tile.n_vertices() {
                let a = tile.positions[tile.edges[e].v0] + image;
                let b = tile.edge_end_shifted(e) + image;
                assert!(
                    (b - a).norm() < bound,
                    "{name}: edge {e} jumps {} m in the 3x3 copy (bound {bound})",
                    (b - a).norm()
                );
            }
        }
    }
    for e in 0..tile.n_vertices() {
        let next = topology.next_edge(e);
        let cos = tile
            .edge_vector(e)
            .normalize()
            .dot(&tile.edge_vector(next).normalize());
        assert!(
            cos > 0.0,
            "{name}: edges {e} → {next} turn by more than 90°"
        );
    }
    for (v, p) in tile.positions.iter().enumerate() {
        for c in 0..2 {
            assert!(
                p[c].abs() <= 0.5 * tile.period[c] + 0.5 * tile.radius,
                "{name}: vertex {v} outside the cell"
            );
        }
    }
}

fn tmp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "sim-periodic-patterns-{}-{name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn every_pattern_relaxes_keeps_clearance_is_its_own_equilibrium_and_round_trips() {
    let model = YarnModel::default_for_radius(R);
    let settings = RelaxSettings::default();
    let dir = tmp_dir("relaxed");
    for pattern in Pattern::ALL {
        let name = pattern.name();
        let guess = pattern.generate(&test_params(pattern)).unwrap();
        let (tile, report) = relax(&guess, &model, &settings)
            .unwrap_or_else(|e| panic!("{name}: relaxation failed: {e}"));
        tile.validate().unwrap();
        let solves = report.iterations.len();
        assert!(solves > settings.rounds && solves <= settings.rounds + settings.max_settle_solves);
        assert!(*report.max_displacement.last().unwrap() < settings.settle_tolerance);
        assert!(report.density.is_finite() && report.density >= 0.0);
        check_periodic(pattern, &tile);
        // Rest lengths stay within the bound of the guess's.
        for (l, l0) in tile.rest_lengths.iter().zip(&guess.rest_lengths) {
            assert!((l / l0 - 1.0).abs() <= settings.max_rest_length_change + 1e-12);
        }
        // No two non-neighbouring segments closer than 0.8 · 2R (the soft contact phase
        // lets touching yarns overlap a little; across periodic images).
        let c = min_clearance(&tile, &model).unwrap();
        if let Some(c) = c {
            assert!(
                c.distance > 0.8 * 2.0 * R,
                "{name}: relaxed clearance {c:?}"
            );
        }
        // The relaxed tile is an equilibrium of its own rest shape: solving it again does not
        // move it (ΔQ at zero strain ≈ 0, far below the 1e-6 m the displacement database asks
        // for).
        let again = solve_equilibrium(
            &tile,
            &model,
            Coarse::identity(),
            None,
            &EquilibriumSettings::default(),
        )
        .unwrap();
        let n = tile.n_vertices();
        let moved = (0..n)
            .map(|v| {
                Vector3::new(
                    again.dofs[3 * v],
                    again.dofs[3 * v + 1],
                    again.dofs[3 * v + 2],
                )
            })
            .fold(0.0f64, |m, u| m.max(u.norm()));
        assert!(
            moved < 1e-9,
            "{name}: relaxed tile moves {moved} m when re-solved"
        );
        // .pyp round trip, through a file and through a string.
        let path = dir.join(format!("{name}.pyp"));
        write_pyp(&tile, &path).unwrap();
        let read = read_pyp(&path).unwrap();
        assert!(read.defaulted.is_empty());
        assert_eq!(read.tile, tile, "{name}: file round trip");
        let text = to_pyp_string(&tile).unwrap();
        assert_eq!(parse_pyp(&text, name).unwrap().tile, tile);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn rebase_keeps_the_energy_of_the_moved_configuration() {
    let tile = Pattern::Rib1x1
        .generate(&test_params(Pattern::Rib1x1))
        .unwrap();
    let model = YarnModel::default_for_radius(R);
    let n = tile.n_vertices();
    let mut x = initial_dofs(&tile).unwrap();
    for (i, xi) in x.iter_mut().enumerate() {
        let scale = if i < 3 * n { 0.1 * R } else { 0.2 };
        *xi += scale * (0.37 * i as f64).sin();
    }
    let energy = |t: &Tile, y: &[f64]| {
        let problem = PeriodicTile::new(t, model, Coarse::identity(), vec![]).unwrap();
        Assembler::new(&problem)
            .unwrap()
            .energy(&problem, y)
            .unwrap()
    };
    let e0 = energy(&tile, &x);
    assert!(e0 > 0.0);
    let moved = rebase(&tile, &x).unwrap();
    let e1 = energy(&moved, &initial_dofs(&moved).unwrap());
    assert!((e1 - e0).abs() <= 1e-9 * e0, "{e0} vs {e1}");
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mut p = Pattern::Stockinette.default_params(R);
    p.resolution = 3;
    assert!(matches!(
        Pattern::Stockinette.generate(&p),
        Err(PatternError::Invalid(_))
    ));
    let mut p = Pattern::Satin.default_params(R);
    p.radius = -1.0;
    assert!(Pattern::Satin.generate(&p).is_err());
    p.radius = R;
    p.spacing[1] = f64::NAN;
    assert!(Pattern::Satin.generate(&p).is_err());
    assert_eq!(Pattern::from_name("twill"), None);
    let yarn = |points: Vec<Vector3<f64>>, shift| Yarn { points, shift };
    let a = Vector3::new(0.0, 0.0, 0.0);
    let b = Vector3::new(1e-3, 0.0, 0.0);
    // Zero-length edge, non-finite point, too few points, no yarns, bad period.
    assert!(tile_from_yarns([4e-3, 4e-3], 0.0, R, &[yarn(vec![a, a, b], [1, 0])]).is_err());
    assert!(
        tile_from_yarns(
            [4e-3, 4e-3],
            0.0,
            R,
            &[yarn(vec![a, Vector3::new(f64::NAN, 0.0, 0.0)], [1, 0])]
        )
        .is_err()
    );
    assert!(tile_from_yarns([4e-3, 4e-3], 0.0, R, &[yarn(vec![a, b], [0, 0])]).is_err());
    assert!(tile_from_yarns([4e-3, 4e-3], 0.0, R, &[]).is_err());
    assert!(tile_from_yarns([0.0, 4e-3], 0.0, R, &[yarn(vec![a, b], [1, 0])]).is_err());
    // A lattice skew outside [-1/2, 1/2] (the tile's validation rejects it).
    let err = tile_from_yarns([4e-3, 4e-3], 0.7, R, &[yarn(vec![a, b], [1, 0])]).unwrap_err();
    assert!(err.to_string().contains("skew"), "{err}");
    // A straight periodic yarn is fine.
    let ok = tile_from_yarns([2e-3, 4e-3], 0.0, R, &[yarn(vec![a, b], [1, 0])]).unwrap();
    // b lies on the cell boundary x = px/2 and wraps to −px/2: edge 0 crosses.
    assert_eq!(ok.edges[0].shift, [1, 0]);
    assert_eq!(ok.edges[1].shift, [0, 0]);
    // Non-convergence of a solve is an error.
    let guess = Pattern::Garter
        .generate(&test_params(Pattern::Garter))
        .unwrap();
    let mut settings = RelaxSettings::default();
    settings.equilibrium.newton.max_iterations = 1;
    let err = relax(&guess, &YarnModel::default_for_radius(R), &settings).unwrap_err();
    assert!(matches!(err, PatternError::Periodic(_)), "{err}");
    settings = RelaxSettings {
        max_rest_length_change: 1.5,
        ..RelaxSettings::default()
    };
    assert!(relax(&guess, &YarnModel::default_for_radius(R), &settings).is_err());
    settings = RelaxSettings {
        max_settle_solves: 0,
        ..RelaxSettings::default()
    };
    assert!(relax(&guess, &YarnModel::default_for_radius(R), &settings).is_err());
    let mut t = guess.clone();
    let l0 = guess.rest_lengths.clone();
    assert!(reset_rest_shape(&mut t, Some((&l0, f64::NAN))).is_err());
    assert!(reset_rest_shape(&mut t, Some((&l0[1..], 0.2))).is_err());
    // Rebase with the wrong number of DOFs.
    assert!(rebase(&guess, &[0.0; 3]).is_err());
}

/// The seed stitch's primitive tile (two loops on a lattice sheared by one loop per course)
/// implements the same periodic fabric as its rectangular repeat: its equilibrium, copied
/// into the rectangular 2 × 2 repeat built from it, has the same energy density and stress, and
/// the repeat's unconstrained residual is the small tile's (only the copied no-sliding
/// constraint forces remain), at rest and under stretch, shear and compression. (Not under
/// bending: there a copied equilibrium is not one of a larger tile even for rectangular tiles,
/// the 2 × 2 copy of the relaxed garter has a third more energy density at κ = 20 /m.)
#[test]
fn sheared_seed_tile_is_its_rectangular_repeat() {
    let params = test_params(Pattern::Seed);
    let model = YarnModel::default_for_radius(R);
    let guess = Pattern::Seed.generate(&params).unwrap();
    let primitive = relax(&guess, &model, &RelaxSettings::default()).unwrap().0;
    let rectangular = common::rectangular_of_half_skew(&primitive);
    let n = primitive.n_vertices();
    let settings = EquilibriumSettings::default();
    let strains = [
        (0.0, 0.0, 0.0),
        (0.2, 0.0, 0.0),
        (0.0, 0.0, 0.3),
        (0.1, 0.3, -0.05),
        (-0.1, 0.0, 0.0),
    ];
    for (k, &(sx, sa, sy)) in strains.iter().enumerate() {
        let coarse = Coarse::from_strain(&sim_periodic::coarse::Strain { sx, sa, sy });
        let eq = solve_equilibrium(&primitive, &model, coarse, None, &settings).unwrap();
        // Copy the DOFs: fluctuations of both copies, then twists of both copies.
        let mut x = [&eq.dofs[..3 * n], &eq.dofs[..3 * n]].concat();
        x.extend_from_slice(&eq.dofs[3 * n..]);
        x.extend_from_slice(&eq.dofs[3 * n..]);
        let pairs = PeriodicTile::find_pairs(&rectangular, &model, &coarse, &x, 1.5).unwrap();
        let big = PeriodicTile::new(&rectangular, model, coarse, pairs).unwrap();
        let mut asm = Assembler::new(&big).unwrap();
        let (energy, g_big) = asm.gradient(&big, &x).unwrap();
        let rb = g_big.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        let small = PeriodicTile::new(&primitive, model, coarse, eq.pairs.clone()).unwrap();
        let mut asm = Assembler::new(&small).unwrap();
        let (_, g_small) = asm.gradient(&small, &eq.dofs).unwrap();
        let rs = g_small.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        let density = energy / big.area();
        let stress_gap = (big.stress(&x) - eq.stress).abs().max();
        eprintln!(
            "strain ({sx}, {sa}, {sy}): Ψ {:.12e} vs {density:.12e} J/m², |Δσ| = \
             {stress_gap:.2e} of {:.2e} N/m, max |∂E/∂q| {rs:.3e} vs {rb:.3e}",
            eq.density,
            eq.stress.abs().max(),
        );
        assert!(
            (density - eq.density).abs() <= 1e-10 * eq.density.abs(),
            "strain {k}"
        );
        assert!(stress_gap <= 1e-9 * eq.stress.abs().max(), "strain {k}");
        assert!(rb <= 1.0001 * rs + 1e-12, "strain {k}: {rb} vs {rs}");
    }
}
