//! Triangle-mesh obstacles (`forces::obstacle::mesh`): the closest-point query against brute
//! force, signed distance against the analytic sphere, asserting finite-difference checks of
//! the node and segment-midpoint contact in the face, edge and vertex regions of a cube, a
//! swatch dropped onto an icosphere against the same drop onto the analytic sphere, an
//! animated floor that lifts a swatch, and `[[obstacle]] kind = "mesh"` scenes with located
//! errors.

mod common;
use common::{SPACING, weave_sim};
use nalgebra::{SVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use rod::Stencil;
use rod::fd::assert_stencil_derivatives;
use sim_persistent::forces::TermKind;
use sim_persistent::forces::obstacle::mesh::{
    Feature, MeshAnimation, TriangleMesh, closest_on_triangle,
};
use sim_persistent::forces::obstacle::{
    MidpointContact, ONSET_FRACTION, Obstacle, ObstacleContact, Shape,
};
use sim_persistent::integrator::Simulator;
use sim_persistent::params::YarnParams;
use sim_persistent::scene::{Scene, SceneError};

type V3 = Vector3<f64>;

/// Fixed seed, no failure files written into the source tree.
fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x6e_5b),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Yarn radius (m): the Table 1 sweater.
const R: f64 = 0.75e-3;

fn v3(range: f64) -> impl Strategy<Value = V3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| V3::new(x, y, z))
}

/// The cube `[−h, h]³` as 12 triangles, wound counter-clockwise seen from outside.
fn cube(h: f64, reach: f64) -> TriangleMesh {
    let vertices: Vec<V3> = (0..8)
        .map(|i| {
            let s = |b: usize| if i >> b & 1 == 1 { h } else { -h };
            V3::new(s(0), s(1), s(2))
        })
        .collect();
    let quads = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    let mut triangles = Vec::new();
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            let [a, b, c] = t.map(|i: u32| vertices[i as usize]);
            let outward = (b - a).cross(&(c - a)).dot(&(a + b + c)) > 0.0;
            triangles.push(if outward { t } else { [t[0], t[2], t[1]] });
        }
    }
    TriangleMesh::new(vertices, triangles, reach).unwrap()
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

proptest! {
    #![proptest_config(config(256))]

    /// The closest point lies on the triangle (barycentric coordinates in [0, 1]) and no
    /// point of a 60 × 60 barycentric sampling of the triangle is nearer; the feature is the
    /// one whose region holds it.
    #[test]
    fn closest_point_on_a_triangle_is_closest(a in v3(1.0), b in v3(1.0), c in v3(1.0), p in v3(2.0)) {
        prop_assume!((b - a).cross(&(c - a)).norm() > 1e-2);
        let (x, feature) = closest_on_triangle(&p, &a, &b, &c);
        let d = (p - x).norm();
        let n = 60;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let y = a + u * (b - a) + v * (c - a);
                prop_assert!(d <= (p - y).norm() + 1e-12);
            }
        }
        // x = a + u (b − a) + v (c − a)
        let (e1, e2, r) = (b - a, c - a, x - a);
        let m = nalgebra::Matrix2::new(e1.dot(&e1), e1.dot(&e2), e1.dot(&e2), e2.dot(&e2));
        let uv = m.try_inverse().unwrap() * nalgebra::Vector2::new(e1.dot(&r), e2.dot(&r));
        let tol = 1e-9;
        prop_assert!(uv.x >= -tol && uv.y >= -tol && uv.x + uv.y <= 1.0 + tol);
        match feature {
            Feature::Vertex(k) => prop_assert!((x - [a, b, c][k]).norm() < 1e-12),
            Feature::Edge(0) => prop_assert!(uv.y.abs() < tol),
            Feature::Edge(1) => prop_assert!((uv.x + uv.y - 1.0).abs() < tol),
            Feature::Edge(_) => prop_assert!(uv.x.abs() < tol),
            Feature::Face => prop_assert!(uv.x > -tol && uv.y > -tol && uv.x + uv.y < 1.0 + tol),
        }
    }
}

/// The tree's closest point equals a linear scan over all 1280 triangles of an icosphere for
/// 2000 points around it (within and beyond the search radius), and the icosphere's signed
/// distance has the sign of the analytic sphere's and differs from it by at most the
/// faceting depth.
#[test]
fn tree_query_and_signed_distance_on_an_icosphere() {
    let (center, rho) = (V3::new(1e-3, -2e-3, 0.5e-3), 8e-3);
    let mesh = TriangleMesh::icosphere(center, rho, 3, 4e-3).unwrap();
    assert_eq!(mesh.triangles().len(), 1280);
    // Outward winding.
    for t in mesh.triangles() {
        let [a, b, c] = t.map(|i| mesh.vertices()[i as usize]);
        assert!((b - a).cross(&(c - a)).dot(&((a + b + c) / 3.0 - center)) > 0.0);
    }
    // The faceting depth: the largest distance of a face's centroid inside the sphere.
    let sag = mesh
        .triangles()
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices()[i as usize]);
            rho - ((a + b + c) / 3.0 - center).norm()
        })
        .fold(0.0, f64::max);
    let mut rng = 0x1234_5678_u64;
    let mut uniform = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut found, mut inside) = (0, 0);
    for _ in 0..2000 {
        let dir = V3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize();
        let r = rho + (uniform() - 0.5) * 12e-3;
        let x = center + r * dir;
        let brute = mesh
            .triangles()
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.vertices()[i as usize]);
                (x - closest_on_triangle(&x, &a, &b, &c).0).norm()
            })
            .fold(f64::INFINITY, f64::min);
        match mesh.closest(&x, 4e-3) {
            Some(c) => {
                found += 1;
                assert!((c.distance2.sqrt() - brute).abs() < 1e-15, "{x:?}");
            }
            None => assert!(brute >= 4e-3, "missed a point at {brute} m"),
        }
        if let Some((phi, grad, _)) = mesh.signed_distance(&x) {
            let exact = r - rho;
            assert!(
                phi.signum() == exact.signum() || exact.abs() < sag,
                "{phi} vs {exact}"
            );
            assert!((phi - exact).abs() <= sag + 1e-12, "{phi} vs {exact}");
            assert!(grad.dot(&dir) > 0.9);
            inside += usize::from(phi < 0.0);
        }
    }
    eprintln!("icosphere: {found} of 2000 points within reach, {inside} inside, sag {sag:.2e} m");
    assert!(found > 500 && inside > 200);
}

/// Points at penetration depths from −R (no contact) to 4δ in the face, edge and vertex
/// regions of a cube, outside and inside: the contact's energy, gradient and Hessian pass the
/// finite-difference check, and the force pushes out along the region's normal. The segment
/// midpoint contact passes the same check on segments around those points.
#[test]
fn mesh_contact_derivatives_in_every_region() {
    let h = 5e-3;
    let shape = Shape::mesh(cube(h, 4e-3));
    let c = contact(shape.clone());
    let mid = MidpointContact(c.clone());
    let regions = [
        (V3::new(0.3 * h, -0.2 * h, h), V3::z()),
        (V3::new(h, 0.1 * h, h), V3::new(1.0, 0.0, 1.0).normalize()),
        (V3::new(h, h, h), V3::new(1.0, 1.0, 1.0).normalize()),
    ];
    let delta = ONSET_FRACTION * R;
    let mut checked = 0;
    for (k, (base, normal)) in regions.into_iter().enumerate() {
        for d in [-R, 0.3 * delta, 0.8 * delta, 1.7 * delta, 3.9 * delta] {
            // Inside points exist only for the face region (an edge's or corner's inside is
            // nearest a face).
            let q: SVector<f64, 3> = base + normal * (R - d);
            let (phi, n, _) = shape.distance(&q);
            assert!((phi - (R - d)).abs() < 1e-15, "region {k}: φ {phi}");
            let e = c.eval(&q);
            if d < 0.0 {
                assert_eq!(e.energy, 0.0);
            } else {
                assert!(e.energy > 0.0 && e.gradient.dot(&n) < 0.0);
            }
            assert_stencil_derivatives(&c, &q, R);
            let t = V3::new(0.4, -0.7, 0.2).normalize() * 0.5e-3;
            let seg: SVector<f64, 6> =
                SVector::from_iterator((q - t).iter().chain((q + t).iter()).copied());
            assert_stencil_derivatives(&mid, &seg, R);
            checked += 1;
        }
    }
    // Inside the cube under the top face, nearer it than any other face.
    for depth in [0.2 * R, 0.7 * R] {
        let q: SVector<f64, 3> = V3::new(0.1 * h, 0.2 * h, h - depth);
        let (phi, n, _) = shape.distance(&q);
        assert!((phi + depth).abs() < 1e-15 && n == V3::z());
        assert!(c.eval(&q).gradient.z < 0.0);
        assert_stencil_derivatives(&c, &q, R);
        checked += 1;
    }
    // Deeper than the reach: let go.
    let q = V3::new(0.0, 0.0, h - 4.5e-3);
    assert!(shape.distance(&q).0.is_infinite() && c.eval(&q).energy == 0.0);
    assert_eq!(checked, 17);
}

fn node_positions(sim: &Simulator) -> Vec<V3> {
    (0..sim.topology().nodes.len())
        .map(|k| sim.dofs().position(&sim.state().q, k))
        .collect()
}

/// The drop of `obstacles::swatch_dropped_onto_a_sphere_rests_on_top` (a 6 × 6 plain weave,
/// 1 mm above a sphere of radius 8 mm, 0.4 s) onto the analytic sphere and onto icospheres of
/// 1280, 5120 and 20480 triangles, node contact only on all so that the contact models are
/// the same: the largest distance of a node from where it ends on the analytic sphere at
/// least halves with each refinement (the facets' tilt, first order in the edge length, moves
/// the frictionless swatch sideways) and ends below 2 % R. With segment midpoints (the mesh
/// default) no midpoint penetrates the mesh by more than 1 % R, while on the analytic sphere, without them, the midpoints cut
/// into it by up to the segments' sagitta.
#[test]
fn drop_onto_an_icosphere_matches_the_analytic_sphere() {
    let n = 6;
    let mid = 0.5 * (n - 1) as f64 * SPACING;
    let rho = 8e-3;
    let center = V3::new(mid, mid, -(rho + R + 1e-3));
    let analytic = Shape::Sphere {
        center,
        radius: rho,
    };
    let run = |shape: &Shape, midpoints: bool| {
        let mut sim = weave_sim(n);
        let mut o = Obstacle::new(shape.clone(), None).unwrap();
        o.midpoints = midpoints;
        sim.add_obstacles(&[o]).unwrap();
        for k in 0..400 {
            sim.step().unwrap_or_else(|e| panic!("step {k}: {e}"));
        }
        sim
    };
    let reference = node_positions(&run(&analytic, false));
    // Refining the icosphere converges to the analytic sphere.
    let mut faceted = None;
    let mut gaps = Vec::new();
    for sub in [3, 4, 5] {
        let mesh = Shape::mesh(TriangleMesh::icosphere(center, rho, sub, 4e-3).unwrap());
        let on_mesh = node_positions(&run(&mesh, false));
        let gap = reference
            .iter()
            .zip(&on_mesh)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        gaps.push(gap / R);
        if sub == 4 {
            faceted = Some(mesh);
        }
    }
    let faceted = faceted.unwrap();
    let with_midpoints = run(&faceted, true);
    let midpoint_gap = |sim: &Simulator, shape: &Shape| {
        let q = &sim.state().q;
        let t = sim.topology();
        t.segments()
            .map(|(y, i)| {
                let p = &t.yarns[y].passes;
                let m = 0.5
                    * (sim.dofs().position(q, p[i].node) + sim.dofs().position(q, p[i + 1].node));
                shape.distance(&m).0 - R
            })
            .fold(f64::INFINITY, f64::min)
    };
    let sphere_mid = midpoint_gap(&run(&analytic, false), &analytic);
    let mesh_mid = midpoint_gap(&with_midpoints, &faceted);
    let mesh_terms = with_midpoints.static_terms().count(TermKind::Obstacle);
    eprintln!(
        "icosphere (1280, 5120, 20480 triangles) vs sphere: largest node distance {gaps:.4?} R; \
         lowest midpoint gap: sphere (nodes only) {:.4} R, mesh (with midpoints) {:.4} R; \
         {mesh_terms} mesh terms",
        sphere_mid / R,
        mesh_mid / R
    );
    assert!(
        gaps[1] < 0.5 * gaps[0] && gaps[2] < 0.5 * gaps[1],
        "no convergence: {gaps:?}"
    );
    assert!(gaps[2] < 0.02, "nodes differ by {} R", gaps[2]);
    assert!(
        mesh_mid > -0.01 * R,
        "midpoint penetrates {} R",
        -mesh_mid / R
    );
    assert!(
        sphere_mid < -0.05 * R,
        "expected the sagitta to cut the analytic sphere"
    );
    let segments = with_midpoints.topology().segments().count();
    assert_eq!(mesh_terms, n * n + segments);
}

/// A 4 × 4 weave resting on a horizontal floor mesh that rises 2 mm at 1 cm/s (an animated
/// mesh of two frames, 0.2 s apart): the floor lifts it, and at rest 0.4 s after the end of
/// the motion every node rests on the raised floor (gap within 1 % R), none went through it.
/// The mesh at a time between frames is the linear interpolation.
#[test]
fn animated_floor_lifts_a_swatch() {
    let params = YarnParams::sweater();
    let z0 = -(params.radius + 1e-3);
    let corners = |z: f64| {
        vec![
            V3::new(-0.05, -0.05, z),
            V3::new(0.05, -0.05, z),
            V3::new(0.05, 0.05, z),
            V3::new(-0.05, 0.05, z),
        ]
    };
    let first = TriangleMesh::new(corners(z0), vec![[0, 1, 2], [0, 2, 3]], 4e-3).unwrap();
    let anim = MeshAnimation::new(first, vec![corners(z0), corners(z0 + 2e-3)], 5.0).unwrap();
    let halfway = anim.at(0.1);
    assert!((halfway.vertices()[2].z - (z0 + 1e-3)).abs() < 1e-15);
    assert!((anim.at(7.0).vertices()[0].z - (z0 + 2e-3)).abs() < 1e-15);
    let mut sim = weave_sim(4);
    let floor = Shape::animated_mesh(anim);
    sim.add_obstacles(&[Obstacle::new(floor, None).unwrap()])
        .unwrap();
    let mut lowest = f64::INFINITY;
    for k in 0..600 {
        sim.step().unwrap_or_else(|e| panic!("step {k}: {e}"));
        let now = sim.obstacles()[0].shape.clone();
        for x in node_positions(&sim) {
            lowest = lowest.min(now.distance(&x).0 - R);
        }
    }
    let top = z0 + 2e-3;
    let gaps: Vec<f64> = node_positions(&sim)
        .iter()
        .map(|x| (x.z - top - R) / R)
        .collect();
    let (lo, hi) = gaps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &g| {
            (a.min(g), b.max(g))
        });
    eprintln!(
        "animated floor: final gaps {lo:.4}..{hi:.4} R, lowest gap during the lift {:.4} R",
        lowest / R
    );
    assert!(lo > -0.01 && hi < 0.01, "gaps {lo}..{hi} R");
    assert!(
        lowest > -0.05 * R,
        "went {} R into the moving floor",
        -lowest / R
    );
}

fn tmpdir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("mesh-obstacles-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const HEADER: &str = r#"steps = 2
[pattern]
builder = "plain"
warps = 3
wefts = 3
"#;

/// A cube in millimetres as OBJ text, moved by `dz` mm.
fn cube_obj(dz: f64) -> String {
    let mesh = cube(5.0, 1.0);
    let mut s = String::from("# cube\n");
    for v in mesh.vertices() {
        s += &format!("v {} {} {}\n", v.x, v.y, v.z - 8.0 + dz);
    }
    for t in mesh.triangles() {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// `kind = "mesh"` reads an OBJ relative to the scene file (scaled from mm) or a numbered
/// sequence with `fps`; the simulator gets one term per node and one per segment and steps.
/// A missing file, a sequence without `fps`, `fps` on a single mesh, sphere keys on a mesh
/// and mesh keys on a sphere are errors at the entry's line naming the problem. The parse
/// reads a mesh file once: the scene builds after the file is gone.
#[test]
fn scene_mesh_obstacles() {
    let dir = tmpdir("scene");
    std::fs::write(dir.join("cube.obj"), cube_obj(0.0)).unwrap();
    for f in 0..3 {
        std::fs::write(dir.join(format!("lift_{f}.obj")), cube_obj(f as f64)).unwrap();
    }
    let scene_path = dir.join("scene.toml");
    let parse = |body: &str| Scene::parse(&format!("{HEADER}{body}"), &scene_path);
    std::fs::write(dir.join("once.obj"), cube_obj(0.0)).unwrap();
    let good =
        parse("[[obstacle]]\nkind = \"mesh\"\nfile = \"once.obj\"\nscale = 0.001\n").unwrap();
    // The parse read the mesh; building does not read it again.
    std::fs::remove_file(dir.join("once.obj")).unwrap();
    let mut run = good.build().unwrap();
    let nodes = run.sim.topology().nodes.len();
    let segments = run.sim.topology().segments().count();
    assert_eq!(
        run.sim.static_terms().count(TermKind::Obstacle),
        nodes + segments
    );
    run.step().unwrap();
    let seq =
        parse("[[obstacle]]\nkind = \"mesh\"\nfile = \"lift_*.obj\"\nfps = 30.0\nscale = 0.001\n")
            .unwrap();
    let mut run = seq.build().unwrap();
    let lowest = |run: &sim_persistent::scene::SceneRun| match &run.sim.obstacles()[0].shape {
        Shape::Mesh(m) => (
            m.time,
            m.mesh
                .vertices()
                .iter()
                .map(|v| v.z)
                .fold(f64::INFINITY, f64::min),
        ),
        _ => panic!("not a mesh"),
    };
    let (t0, z0) = lowest(&run);
    for _ in 0..10 {
        run.step().unwrap();
    }
    assert!(run.sim.obstacles()[0].shape.is_animated());
    // The sequence rises 1 mm per frame at 30 fps: after 10 ms, 0.3 mm.
    let (t1, z1) = lowest(&run);
    assert_eq!((t0, t1), (0.0, run.sim.time()));
    assert!((z1 - z0 - 0.3e-3).abs() < 1e-9, "moved {} m", z1 - z0);
    let first = HEADER.lines().count() + 1;
    let cases = [
        (
            "[[obstacle]]\nkind = \"mesh\"\nfile = \"nothere.obj\"\n",
            "nothere.obj",
        ),
        (
            "[[obstacle]]\nkind = \"mesh\"\nfile = \"lift_*.obj\"\n",
            "fps",
        ),
        (
            "[[obstacle]]\nkind = \"mesh\"\nfile = \"cube.obj\"\nfps = 30.0\n",
            "fps",
        ),
        (
            "[[obstacle]]\nkind = \"mesh\"\nfile = \"cube.obj\"\nradius = 1.0\n",
            "radius",
        ),
        ("[[obstacle]]\nkind = \"mesh\"\n", "file"),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 0.01\nfile = \"cube.obj\"\n",
            "file",
        ),
        (
            "[[obstacle]]\nkind = \"mesh\"\nfile = \"cube.obj\"\nscale = -1.0\n",
            "scale",
        ),
    ];
    for (body, word) in cases {
        let err = parse(body).err().unwrap_or_else(|| panic!("{body} parsed"));
        let msg = err.to_string();
        eprintln!("{msg}");
        match &err {
            SceneError::Parse { line, .. } => assert!(
                (first..first + body.lines().count()).contains(line),
                "line {line} not in the entry: {msg}"
            ),
            other => panic!("not a located error: {other}"),
        }
        assert!(msg.contains(word), "{msg}");
    }
    // A malformed OBJ names its own file and line.
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    let msg = parse("[[obstacle]]\nkind = \"mesh\"\nfile = \"bad.obj\"\n")
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("bad.obj:3:"), "{msg}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Frames of a simulation with a mesh obstacle show it: the PNG has pixels of the obstacle's
/// colour (shaded) and the USD file holds a `Mesh` prim with its triangles beside the yarns.
/// The run's USD cache holds the yarns and the obstacle over three frames, and Pixar's USD
/// library loads it as one animation ([`yarn_output::usda::check_with_usd_if_available`]).
#[test]
fn frames_draw_mesh_obstacles() {
    use sim_persistent::output::{CACHE_FILE, Format, FrameWriter, OBSTACLE_COLOUR, OutputSpec};
    let mut sim = weave_sim(3);
    let mesh = TriangleMesh::icosphere(V3::new(3e-3, 3e-3, -6e-3), 4e-3, 2, 4e-3).unwrap();
    let triangles = mesh.triangles().len();
    sim.add_obstacles(&[Obstacle::new(Shape::mesh(mesh), None).unwrap()])
        .unwrap();
    let dir = tmpdir("frames");
    let spec = OutputSpec {
        formats: vec![Format::Png, Format::Usda, Format::UsdCache],
        png_size: [120, 90],
        ..OutputSpec::default()
    };
    let dt = sim.settings().dt;
    let mut writer = FrameWriter::new(&dir, &spec, R, dt).unwrap();
    let paths = writer.write(&sim).unwrap();
    assert_eq!(paths.len(), 2, "the cache is written at the end: {paths:?}");
    for _ in 0..2 {
        sim.step().unwrap();
        writer.write(&sim).unwrap();
    }
    let cache = writer.finish().unwrap().expect("a cache was asked for");
    assert_eq!(cache, dir.join(CACHE_FILE));
    match yarn_output::usda::check_with_usd_if_available(&cache, 3, 1).unwrap() {
        Some(report) => assert_eq!(report.lines().count(), 3, "{report}"),
        None => eprintln!(
            "skipping the USD check of {}: no pxr module",
            cache.display()
        ),
    }
    let usda = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(usda.contains("def Mesh \"Mesh0\""), "{}", &usda[..200]);
    let counts = usda
        .lines()
        .find(|l| l.contains("faceVertexCounts"))
        .unwrap();
    assert_eq!(counts.matches('3').count(), triangles);
    let png = std::fs::read(&paths[0]).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(png));
    let mut reader = decoder.read_info().unwrap();
    let mut rgb = vec![0; reader.output_buffer_size()];
    reader.next_frame(&mut rgb).unwrap();
    // Shaded obstacle pixels keep the colour's proportions (no yarn colour has them).
    let [r0, g0, b0] = OBSTACLE_COLOUR.map(f64::from);
    let skin = rgb
        .chunks(3)
        .filter(|p| {
            let [r, g, b] = [p[0], p[1], p[2]].map(f64::from);
            r > 40.0 && (g / r - g0 / r0).abs() < 0.03 && (b / r - b0 / r0).abs() < 0.03
        })
        .count();
    assert!(skin > 200, "{skin} obstacle pixels");
    std::fs::remove_dir_all(&dir).ok();
}
