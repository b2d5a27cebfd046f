//! Sphere and plane obstacles (`forces::obstacle`): asserting finite-difference checks of the
//! penalty contact away from, near and across the contact boundary and the onset depth,
//! C² continuity, validation, "no obstacle terms without obstacles", swatches dropped onto a
//! sphere and onto a plane, and `[[obstacle]]` / `[crossing_shear]` scene tables with
//! located errors.

mod common;
use common::{SPACING, weave_sim};
use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::Stencil;
use rod::fd::{FdOptions, assert_stencil_derivatives, check_gradient};
use sim_persistent::forces::TermKind;
use sim_persistent::forces::crossing_shear::CrossingShear;
use sim_persistent::forces::obstacle::{ONSET_FRACTION, Obstacle, ObstacleContact, Shape};
use sim_persistent::integrator::Simulator;
use sim_persistent::params::YarnParams;
use sim_persistent::scene::{Scene, SceneError};
use std::path::Path;

/// Fixed seed, no failure files written into the source tree.
fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x000c_0b57),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Yarn radius (m): the Table 1 sweater.
const R: f64 = 0.75e-3;

fn sphere() -> Shape {
    Shape::Sphere {
        center: Vector3::new(1e-3, -2e-3, 0.5e-3),
        radius: 8e-3,
    }
}

fn plane() -> Shape {
    Shape::Plane {
        point: Vector3::new(0.0, 0.0, -1e-3),
        normal: Vector3::new(0.3, -0.2, 1.0).normalize(),
    }
}

fn contact(shape: Shape) -> ObstacleContact {
    let params = YarnParams::sweater();
    ObstacleContact {
        shape,
        offset: R,
        stiffness: params.stretch_stiffness() / R,
        onset: ONSET_FRACTION * R,
    }
}

/// The point at penetration depth `d` (m) along the unit direction `dir` from the shape.
fn at_depth(shape: &Shape, dir: Vector3<f64>, d: f64) -> SVector<f64, 3> {
    match *shape {
        Shape::Sphere { center, radius } => center + dir * (radius + R - d),
        Shape::Plane { point, normal } => {
            // dir's tangential part moves along the plane.
            let t = dir - normal * dir.dot(&normal);
            point + t * 5e-3 + normal * (R - d)
        }
        Shape::Mesh(_) => unreachable!("spheres and planes only"),
    }
}

fn v3(range: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

proptest! {
    #![proptest_config(config(128))]

    /// Random points from well outside (d = −R, no contact: zero energy) through the cubic
    /// onset to deep penetration (d = 4δ), for both shapes. The Hessian check stays a
    /// thousandth of δ off the two depths where `V'''` jumps (the FD step is 1e-6 R).
    #[test]
    fn obstacle_contact_derivatives(dir in v3(1.0), d in -R..4.0 * ONSET_FRACTION * R, on_sphere in any::<bool>()) {
        prop_assume!(dir.norm() > 0.1);
        let delta = ONSET_FRACTION * R;
        prop_assume!(d.abs() > 1e-3 * delta && (d - delta).abs() > 1e-3 * delta);
        let shape = if on_sphere { sphere() } else { plane() };
        let c = contact(shape.clone());
        let q = at_depth(&shape, dir.normalize(), d);
        prop_assert!((c.gap(&q) + d).abs() < 1e-15);
        let e = c.eval(&q);
        if d < 0.0 {
            prop_assert!(e.energy == 0.0 && e.gradient.norm() == 0.0 && e.hessian.norm() == 0.0);
        } else {
            prop_assert!(e.energy > 0.0);
            // The force pushes out of the obstacle.
            let (_, n, _) = shape.distance(&q);
            prop_assert!(e.gradient.dot(&n) < 0.0);
        }
        assert_stencil_derivatives(&c, &q, R);
    }
}

/// Across the boundaries: the gradient check straddles `d = 0` and `d = δ` exactly (V is
/// C², so central differences of the energy stay second-order accurate there), and V, V',
/// V'' agree from both sides of each (relative jump ≤ 1e-6 of the step's change), so the
/// Hessian is continuous.
#[test]
fn obstacle_contact_is_c2_across_the_boundary() {
    for shape in [sphere(), plane()] {
        let c = contact(shape.clone());
        let delta = c.onset;
        let dir = Vector3::new(0.2, 0.5, 0.8).normalize();
        for d0 in [0.0, delta] {
            let q = at_depth(&shape, dir, d0);
            let e = c.eval(&q);
            let g_typ = c.stiffness * delta;
            let opts = FdOptions::for_scale(R, g_typ);
            let as_vec = |x: &[f64]| SVector::<f64, 3>::from_column_slice(x);
            check_gradient(
                |x| c.energy(&as_vec(x)),
                e.gradient.as_slice(),
                q.as_slice(),
                &opts,
            )
            .unwrap_or_else(|err| panic!("gradient at d = {d0}: {err}"));
            let eps = 1e-9 * delta;
            let (lo, hi) = (c.profile(d0 - eps), c.profile(d0 + eps));
            let scale = c.profile(2.0 * delta);
            assert!((hi.0 - lo.0).abs() <= 1e-6 * scale.0);
            assert!((hi.1 - lo.1).abs() <= 1e-6 * scale.1);
            assert!(
                (hi.2 - lo.2).abs() <= 1e-6 * scale.2,
                "V'' jumps at d = {d0}"
            );
            // Hessians on both sides agree too.
            let (h_lo, h_hi) = (
                c.eval(&at_depth(&shape, dir, d0 - eps)).hessian,
                c.eval(&at_depth(&shape, dir, d0 + eps)).hessian,
            );
            assert!((h_hi - h_lo).amax() <= 1e-6 * c.stiffness);
        }
        // Deterministic depths on both sides of both boundaries: worst FD errors.
        let mut worst = (0.0f64, 0.0f64);
        for d in [
            0.3 * delta,
            0.999 * delta,
            1.001 * delta,
            2.0 * delta,
            20.0 * delta,
        ] {
            let r = assert_stencil_derivatives(&c, &at_depth(&shape, dir, d), R);
            worst.0 = worst.0.max(r.gradient_rel_error);
            worst.1 = worst.1.max(r.hessian_rel_error);
        }
        eprintln!(
            "{shape:?}: worst FD rel. error gradient {:.2e}, Hessian {:.2e}",
            worst.0, worst.1
        );
        // Past the onset the stiffness is k: V'' = k, and V' = k (d − δ/2).
        let (_, v1, v2) = c.profile(3.0 * delta);
        assert!((v2 - c.stiffness).abs() < 1e-12 * c.stiffness);
        assert!((v1 - c.stiffness * 2.5 * delta).abs() < 1e-12 * v1);
    }
}

/// Invalid obstacles are rejected with a message naming the quantity; plane normals are
/// normalized; the default stiffness is `k_s/R`.
#[test]
fn obstacles_are_validated() {
    let cases = [
        (
            Shape::Sphere {
                center: Vector3::zeros(),
                radius: 0.0,
            },
            None,
            "radius",
        ),
        (
            Shape::Sphere {
                center: Vector3::new(f64::NAN, 0.0, 0.0),
                radius: 1.0,
            },
            None,
            "centre",
        ),
        (
            Shape::Plane {
                point: Vector3::zeros(),
                normal: Vector3::zeros(),
            },
            None,
            "normal",
        ),
        (plane(), Some(-3.0), "stiffness"),
    ];
    for (shape, k, word) in cases {
        let e = Obstacle::new(shape, k).unwrap_err();
        assert!(e.contains(word), "{e}");
    }
    let o = Obstacle::new(
        Shape::Plane {
            point: Vector3::zeros(),
            normal: Vector3::new(0.0, 0.0, 2.0),
        },
        None,
    )
    .unwrap();
    assert_eq!(
        o.shape,
        Shape::Plane {
            point: Vector3::zeros(),
            normal: Vector3::z()
        }
    );
    let p = YarnParams::sweater();
    assert!((o.stiffness(&p) - p.stretch_stiffness() / p.radius).abs() < 1e-9);
}

fn obstacle_terms(sim: &Simulator) -> usize {
    sim.static_terms().count(TermKind::Obstacle)
}

/// "No obstacle queries without obstacles": a simulator has no obstacle terms until
/// obstacles are added, adding none changes nothing, an invalid obstacle is an error that
/// adds nothing, and each valid obstacle adds one term per node.
#[test]
fn obstacle_terms_exist_only_with_obstacles() {
    let mut sim = weave_sim(3);
    let before = sim.static_terms().len();
    assert_eq!(obstacle_terms(&sim), 0);
    sim.add_obstacles(&[]).unwrap();
    assert_eq!(sim.static_terms().len(), before);
    let bad = Obstacle {
        shape: Shape::Sphere {
            center: Vector3::zeros(),
            radius: -1.0,
        },
        stiffness: None,
        midpoints: false,
    };
    assert!(sim.add_obstacles(&[bad]).is_err());
    assert_eq!(sim.static_terms().len(), before);
    let ground = Obstacle::new(plane(), None).unwrap();
    let ball = Obstacle::new(sphere(), Some(1e3)).unwrap();
    sim.add_obstacles(&[ground, ball]).unwrap();
    assert_eq!(obstacle_terms(&sim), 2 * 9);
    assert_eq!(sim.static_terms().len(), before + 18);
    // The simulator still steps (new terms, new sparsity pattern).
    sim.step().unwrap();
}

/// Runs `steps` steps; returns (min gap over nodes / R, max gap / R, max node speed m/s).
fn settle(sim: &mut Simulator, contact: &ObstacleContact, steps: usize) -> (f64, f64, f64) {
    for k in 0..steps {
        sim.step().unwrap_or_else(|e| panic!("step {k}: {e}"));
    }
    let n = sim.topology().nodes.len();
    let (mut lo, mut hi, mut speed) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
    for node in 0..n {
        let x = sim.dofs().position(&sim.state().q, node);
        let g = contact.gap(&x) / R;
        lo = lo.min(g);
        hi = hi.max(g);
        let i = sim.dofs().x(node);
        let v = &sim.state().v;
        speed = speed.max(Vector3::new(v[i], v[i + 1], v[i + 2]).norm());
    }
    (lo, hi, speed)
}

/// Seed 000 Fig. 12 in small: a `6 × 6` plain weave (15 mm square) dropped from 1 mm above a
/// sphere of radius 8 mm centred under it. After 0.5 s it rests on top: the nodes nearest
/// the pole touch (min gap within 5 % of R), no node penetrates by more than 1 % of R
/// (a penetration of 1 % R takes ≈ 0.018 N per node, five times the swatch's weight), every node has slowed below 5 mm/s, the swatch is still
/// centred on the sphere (frictionless contact, symmetric drop) and has draped over it
/// (corners below the top nodes).
#[test]
fn swatch_dropped_onto_a_sphere_rests_on_top() {
    let n = 6;
    let mut sim = weave_sim(n);
    let params = YarnParams::sweater();
    let mid = 0.5 * (n - 1) as f64 * SPACING;
    let rho = 8e-3;
    let shape = Shape::Sphere {
        center: Vector3::new(mid, mid, -(rho + params.radius + 1e-3)),
        radius: rho,
    };
    sim.add_obstacles(&[Obstacle::new(shape.clone(), None).unwrap()])
        .unwrap();
    let c = contact(shape.clone());
    let start = std::time::Instant::now();
    let (lo, hi, speed) = settle(&mut sim, &c, 500);
    let elapsed = start.elapsed().as_secs_f64();
    let q = &sim.state().q;
    let pos: Vec<Vector3<f64>> = (0..n * n).map(|k| sim.dofs().position(q, k)).collect();
    let centroid = pos.iter().sum::<Vector3<f64>>() / pos.len() as f64;
    let corner_z = pos[0].z;
    let top_z = pos.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
    eprintln!(
        "sphere drop 6×6, 0.5 s in {elapsed:.2} s: gap/R min {lo:.4} max {hi:.3}, max speed \
         {speed:.2e} m/s, centroid offset ({:.2e}, {:.2e}) m, corner {:.2} mm below top",
        centroid.x - mid,
        centroid.y - mid,
        (top_z - corner_z) * 1e3
    );
    assert!(lo >= -0.01, "penetration {:.4} R", -lo);
    assert!(lo <= 0.05, "not touching: min gap {lo:.3} R");
    assert!(speed < 5e-3, "still moving at {speed} m/s");
    assert!((centroid.x - mid).abs() < 1e-4 && (centroid.y - mid).abs() < 1e-4);
    assert!(top_z - corner_z > 1e-3, "not draped");
}

/// A `4 × 4` weave dropped from 1 mm onto a horizontal plane rests flat on it after 0.3 s:
/// every node touches and none penetrates by more than 1 % of R (a node's weight,
/// ≈ 1e-4 N, sinks it by `√(2δF/k)` ≈ 0.08 % R into the smoothed onset), all at rest.
#[test]
fn swatch_dropped_onto_a_plane_rests_on_it() {
    let mut sim = weave_sim(4);
    let params = YarnParams::sweater();
    let shape = Shape::Plane {
        point: Vector3::new(0.0, 0.0, -(params.radius + 1e-3)),
        normal: Vector3::z(),
    };
    sim.add_obstacles(&[Obstacle::new(shape.clone(), None).unwrap()])
        .unwrap();
    let c = contact(shape.clone());
    let start = std::time::Instant::now();
    let (lo, hi, speed) = settle(&mut sim, &c, 300);
    eprintln!(
        "plane drop 4×4, 0.3 s in {:.2} s: gap/R min {lo:.4} max {hi:.4}, max speed {speed:.2e} m/s",
        start.elapsed().as_secs_f64()
    );
    assert!(lo >= -0.01 && hi <= 0.0, "gaps {lo}..{hi} R");
    assert!(speed < 1e-3, "still moving at {speed} m/s");
}

fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::parse(text, Path::new("obstacles.toml"))
}

const HEADER: &str = r#"steps = 2
[pattern]
builder = "stockinette"
width = 3
height = 3
"#;

const WEAVE: &str = r#"steps = 2
[pattern]
builder = "plain"
warps = 4
wefts = 3
"#;

/// A weave scene with a sphere, a plane and crossing-shear parameters parses and builds a
/// simulator with one obstacle term per node and obstacle and crossing-shear terms with the
/// scene's parameters, and steps; `[forces] crossing_shear = false` removes those terms, and
/// a scene without `[[obstacle]]` tables has no obstacle terms.
#[test]
fn scene_obstacles_build_terms() {
    let text = format!(
        "{WEAVE}
[crossing_shear]
stiffness = 0.05
jamming_angle = 0.8

[[obstacle]]
kind = \"sphere\"
centre = [0.0, 0.0, -0.02]
radius = 0.01

[[obstacle]]
kind = \"plane\"
point = [0.0, -0.01, 0.0]
normal = [0.0, 1.0, 0.0]
stiffness = 500.0
"
    );
    let scene = parse(&text).unwrap();
    let mut run = scene.build().unwrap();
    let nodes = run.sim.topology().nodes.len();
    assert_eq!(nodes, 12);
    assert_eq!(obstacle_terms(&run.sim), 2 * nodes);
    let shear: Vec<CrossingShear> = run
        .sim
        .static_terms()
        .iter_of::<CrossingShear, 9>()
        .map(|(_, s)| *s)
        .collect();
    assert_eq!(shear.len(), 4 * 3 * 2);
    assert!(
        shear
            .iter()
            .all(|s| s.stiffness == 0.05 && s.jamming.angle == 0.8)
    );
    run.step().unwrap();
    let off = parse(&format!("{WEAVE}[forces]\ncrossing_shear = false\n"))
        .unwrap()
        .build()
        .unwrap();
    assert!(off.sim.static_terms().count(TermKind::CrossingShear) == 0);
    // Without [[obstacle]] tables: no obstacle terms.
    let plain = parse(HEADER).unwrap().build().unwrap();
    assert_eq!(obstacle_terms(&plain.sim), 0);
}

/// Malformed `[[obstacle]]` and `[crossing_shear]` entries fail with the file, line and a
/// message naming the problem.
#[test]
fn malformed_scene_obstacles_name_the_line() {
    let cases = [
        ("[[obstacle]]\nkind = \"cube\"\nradius = 1.0\n", "cube"),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\n",
            "radius",
        ),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = -1.0\n",
            "radius",
        ),
        (
            "[[obstacle]]\nkind = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 0.0]\n",
            "normal",
        ),
        (
            "[[obstacle]]\nkind = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 2.0\n",
            "radius",
        ),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\n",
            "center",
        ),
        ("[crossing_shear]\njamming_angle = 3.0\n", "angle"),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 0.01\nsticky = \"yes\"\n",
            "bool",
        ),
    ];
    let first = HEADER.lines().count() + 1;
    for (body, word) in cases {
        let text = format!("{HEADER}{body}");
        let err = parse(&text)
            .err()
            .unwrap_or_else(|| panic!("{body} parsed"));
        let msg = err.to_string();
        match &err {
            SceneError::Parse { line, .. } => {
                assert!(
                    (first..first + body.lines().count()).contains(line),
                    "line {line} not in the entry: {msg}"
                );
            }
            other => panic!("not a located error: {other}"),
        }
        eprintln!("{msg}");
        assert!(msg.contains(word), "{msg}");
        assert!(msg.starts_with("obstacles.toml:"), "{msg}");
    }
    // The second of two entries is reported at its own header.
    let body = "[[obstacle]]\nkind = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n\n\
                [[obstacle]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 0.0\n";
    match parse(&format!("{HEADER}{body}")) {
        Err(SceneError::Parse { line, message, .. }) => {
            assert_eq!(line, first + 5, "{message}");
            assert!(message.contains("radius"), "{message}");
        }
        other => panic!("expected a located error, got {other:?}"),
    }
}

/// `sticky = true` on an obstacle pins every node that touches it at the end of a step where
/// it is; without it (or with `sticky = false`) nothing is pinned.
#[test]
fn sticky_obstacles_pin_touching_nodes() {
    let probe = parse(HEADER).unwrap().build().unwrap();
    let x0 = probe.sim.dofs().position(&probe.sim.state().q, 0);
    // A sphere whose top touches node 0 from below.
    let radius = 0.01;
    let scene = |sticky: &str| {
        let text = format!(
            "{HEADER}[forces]\ngravity = false\n\n[[obstacle]]\nkind = \"sphere\"\n\
             centre = [{}, {}, {}]\nradius = {radius}\n{sticky}",
            x0.x,
            x0.y,
            x0.z - radius,
        );
        let mut run = parse(&text).unwrap().build().unwrap();
        run.step().unwrap();
        run
    };
    let run = scene("sticky = true\n");
    let held: Vec<usize> = (0..run.sticky.contacts.held.len())
        .filter(|&n| run.sticky.contacts.held[n])
        .collect();
    assert!(held.contains(&0), "{held:?}");
    assert!(held.len() < run.sim.topology().nodes.len());
    for &n in &held {
        let x = run.sim.dofs().x(n);
        assert!(
            (x..x + 3).all(|i| run.sim.fixed()[i]),
            "node {n} not pinned"
        );
    }
    assert_eq!(run.sticky.contacts.first, Some(run.sim.time()));
    for text in ["sticky = false\n", ""] {
        let run = scene(text);
        assert!(run.sticky.obstacles.is_empty());
        assert!(run.sticky.contacts.held.iter().all(|&h| !h));
        assert!(!run.sim.fixed()[run.sim.dofs().x(0)]);
    }
}
