//! Scene files: a full scene parses, builds and runs with driven clamps and OBJ output; a
//! woven scene writes every output format; unknown keys, wrong types and malformed
//! `[output]` / `[pattern]` entries fail with the line of the offending text.

use sim_persistent::output::{BccCurve, CurveOptions, FrameWriter, RenderCurves};
use sim_persistent::scene::{Scene, SceneError, obj_text, write_obj};
use std::path::Path;

const SCENE: &str = r#"# a small rib, stretched upwards
dt = 1e-3
steps = 3
output_every = 1

[pattern]
builder = "rib"
width = 4
height = 3
rib = [1, 1]

[yarn]
preset = "sweater"
gravity = [0.0, 0.0, 0.0]

[damping]
alpha = 10.0
beta = 0.0

[forces]
friction = false

[[clamp]]
edge = "cast-on"

[[clamp]]
edge = "bind-off"
velocity = [0.0, 0.01, 0.0]
"#;

fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::parse(text, Path::new("test.toml"))
}

/// The example scene: 4 × 3 rib, Table 1 sweater yarn without gravity, friction off, cast-on
/// fixed and bind-off moving up at 1 cm/s. After 3 steps of 1 ms the bind-off nodes have
/// moved up by exactly 30 µm, the cast-on nodes not at all, and each written OBJ frame has
/// one `v` per node and one `l` polyline per yarn (one per row) through all of its passes.
#[test]
fn scene_runs_with_driven_clamps_and_writes_obj_frames() {
    let scene = parse(SCENE).unwrap();
    assert_eq!(scene.steps, 3);
    assert!(!scene.forces.friction && scene.forces.wrapping);
    let mut run = scene.build().unwrap();
    let (bottom, top) = (run.clamps[0].0.clone(), run.clamps[1].0.clone());
    let y = |run: &sim_persistent::scene::SceneRun, n: usize| {
        run.sim.dofs().position(&run.sim.state().q, n).y
    };
    let (b0, t0) = (y(&run, bottom[0]), y(&run, top[0]));
    let dir = std::env::temp_dir().join(format!("sim-persistent-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for k in 0..scene.steps {
        run.step().unwrap();
        write_obj(&run.sim, &dir, k).unwrap();
    }
    assert_eq!(y(&run, bottom[0]), b0);
    assert!((y(&run, top[0]) - t0 - 3e-5).abs() < 1e-12);
    let text = std::fs::read_to_string(dir.join("frame_00002.obj")).unwrap();
    assert_eq!(text, obj_text(&run.sim));
    std::fs::remove_dir_all(&dir).unwrap();
    let topo = run.sim.topology();
    assert_eq!(
        text.lines().filter(|l| l.starts_with("v ")).count(),
        topo.nodes.len()
    );
    let polylines: Vec<&str> = text.lines().filter(|l| l.starts_with("l ")).collect();
    assert_eq!(polylines.len(), topo.yarns.len());
    for (line, yarn) in polylines.iter().zip(&topo.yarns) {
        assert_eq!(line.split_whitespace().count() - 1, yarn.passes.len());
    }
}

/// The friction return mapping and the terms it needs are scene options (the return
/// mapping and loop contact off by default, the segment floor on), and when given they
/// reach the simulator (settings and terms) and the scene steps with friction on.
#[test]
fn return_mapping_options_reach_the_simulator() {
    use sim_persistent::forces::TermKind;
    let defaults = parse(SCENE).unwrap();
    assert_eq!(defaults.friction_return_mapping, 0);
    assert!(!defaults.forces.loop_contact && defaults.forces.segment_floor);
    let text = SCENE
        .replace("steps = 3\n", "steps = 3\nfriction_return_mapping = 20\n")
        .replace(
            "friction = false\n",
            "friction = true\nloop_contact = true\n",
        );
    let scene = parse(&text).unwrap();
    assert_eq!(scene.friction_return_mapping, 20);
    let mut run = scene.build().unwrap();
    assert_eq!(run.sim.settings().friction_return_mapping, 20);
    let terms = run.sim.static_terms();
    let floors = terms.count(TermKind::SegmentFloor);
    assert_eq!(floors, run.sim.topology().segments().count());
    assert!(terms.count(TermKind::Friction) > 0);
    assert!(terms.count(TermKind::LoopContact) > 0);
    for _ in 0..scene.steps {
        run.step().unwrap();
    }
    assert!(run.sim.state().q.iter().all(|v| v.is_finite()));
}

/// A misspelt key is rejected (deny_unknown_fields) at its line and column.
#[test]
fn unknown_key_names_line_and_column() {
    let text = SCENE.replace("friction = false", "  fricton = false");
    let offset = text.find("fricton").unwrap();
    let expected_line = text[..offset].matches('\n').count() + 1;
    assert_eq!(expected_line, 21);
    match parse(&text) {
        Err(SceneError::Parse {
            line,
            column,
            message,
            ..
        }) => {
            assert_eq!((line, column), (expected_line, 3), "{message}");
            assert!(message.contains("fricton"), "{message}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

/// A value of the wrong type and malformed TOML are located too; an inconsistent `[pattern]`
/// (unknown builder, missing size, malformed chart) is a parse error at the `[pattern]`
/// header (line 6); a non-finite clamp velocity and an unknown clamp edge are parse errors
/// at their line.
#[test]
fn bad_values_are_errors() {
    let text = SCENE.replace("width = 4", "width = \"four\"");
    assert!(matches!(
        parse(&text),
        Err(SceneError::Parse { line: 8, .. })
    ));
    let text = SCENE.replace("steps = 3", "steps = = 3");
    assert!(matches!(
        parse(&text),
        Err(SceneError::Parse { line: 3, .. })
    ));
    for (from, to, needle) in [
        ("\"rib\"", "\"cable\"", "unknown builder \"cable\""),
        ("width = 4\n", "", "needs `width` and `height`"),
        (
            "builder = \"rib\"\nwidth = 4\nheight = 3\nrib = [1, 1]",
            "chart = \"K4\\nP2 X2\"",
            "chart",
        ),
    ] {
        assert_parse_error(&SCENE.replace(from, to), 6, needle);
    }
    // A non-finite clamp velocity is a parse error at its line.
    for bad in ["nan", "inf"] {
        let text = SCENE.replace(
            "velocity = [0.0, 0.01, 0.0]",
            &format!("velocity = [0.0, {bad}, 0.0]"),
        );
        let line = 1 + text
            .lines()
            .position(|l| l.starts_with("velocity"))
            .expect("the scene has a clamp velocity");
        assert_parse_error(&text, line, "finite");
    }
    // An unknown clamp edge is a parse error at its value (line 24).
    let text = SCENE.replace("edge = \"cast-on\"", "edge = \"side\"");
    assert_parse_error(&text, 24, "unknown clamp edge \"side\"");
}

/// Asserts that `text` fails to parse at `line` with a message containing `needle`.
fn assert_parse_error(text: &str, line: usize, needle: &str) {
    match parse(text) {
        Err(SceneError::Parse {
            line: l, message, ..
        }) => {
            assert_eq!(l, line, "{message}");
            assert!(message.contains(needle), "{message:?} lacks {needle:?}");
        }
        other => panic!("expected a parse error at line {line}, got {other:?}"),
    }
}

/// A 4 × 3 twill scene (lines 1–22) with every output format.
const WEAVE: &str = r#"dt = 1e-3
steps = 2

[pattern]
builder = "twill"
warps = 4
wefts = 3
twill = [2, 1]

[yarn]
gravity = [0.0, -9.81, 0.0]

[[clamp]]
edge = "bind-off"

[output]
formats = ["obj", "ply", "bcc", "png", "nodes"]
every = 1
samples = 3
png_size = [64, 48]
view = "oblique"
supersample = 1
"#;

/// Malformed `[output]` entries are parse errors at their line, naming the problem.
#[test]
fn malformed_output_entries_name_the_line() {
    assert!(parse(WEAVE).is_ok());
    for (from, to, line, needle) in [
        (
            "\"png\", \"nodes\"",
            "\"jpg\", \"nodes\"",
            17,
            "unknown variant `jpg`",
        ),
        ("\"png\", \"nodes\"", "\"obj\"", 17, "listed twice"),
        (
            "[\"obj\", \"ply\", \"bcc\", \"png\", \"nodes\"]",
            "[]",
            17,
            "at least one",
        ),
        ("every = 1", "every = 0", 18, "`every` must be ≥ 1"),
        ("samples = 3", "samples = 0", 19, "`samples` must be 1"),
        ("samples = 3", "samples = 1000", 19, "`samples` must be 1"),
        ("png_size = [64, 48]", "png_size = [64, 0]", 20, "png_size"),
        ("png_size = [64, 48]", "png_size = [64]", 20, ""),
        (
            "view = \"oblique\"",
            "view = \"top\"",
            21,
            "unknown variant `top`",
        ),
        (
            "supersample = 1",
            "supersample = 9",
            22,
            "`supersample` must be 1",
        ),
        ("supersample = 1", "supersampel = 1", 22, "supersampel"),
        ("samples = 3", "samples = \"many\"", 19, ""),
        (
            "steps = 2",
            "steps = 2\noutput_every = 0",
            3,
            "`output_every` must be ≥ 1",
        ),
        // Both spellings of the frame interval: reported at `[output] every` (line 19).
        ("steps = 2", "steps = 2\noutput_every = 2", 19, "not both"),
    ] {
        let text = WEAVE.replace(from, to);
        assert_ne!(text, WEAVE, "{from}");
        assert_parse_error(&text, line, needle);
    }
}

/// Malformed woven `[pattern]` tables are parse errors at the `[pattern]` header (line 4).
#[test]
fn malformed_weave_patterns_name_the_line() {
    for (from, to, needle) in [
        ("warps = 4\n", "", "needs `warps` and `wefts`"),
        ("warps = 4", "warps = 1", "≥ 2 warps"),
        ("twill = [2, 1]", "twill = [0, 1]", "twill 0/1"),
        ("twill = [2, 1]", "satin = [5, 2]", "`satin` only applies"),
        ("twill = [2, 1]", "width = 4", "`width` does not apply"),
        ("\"twill\"", "\"satin\"", "`twill` only applies"),
        (
            "\"twill\"\nwarps = 4\nwefts = 3\ntwill = [2, 1]",
            "\"satin\"\nwarps = 4\nwefts = 3\nsatin = [6, 2]",
            "satin 6/2",
        ),
        ("\"twill\"", "\"basket\"", "unknown builder \"basket\""),
    ] {
        let text = WEAVE.replace(from, to);
        assert_ne!(text, WEAVE, "{from}");
        assert_parse_error(&text, 4, needle);
    }
}

/// The woven scene builds a twill (4 warps × 3 wefts: 12 crossing nodes, 7 yarns), pins its
/// top weft, steps under gravity with finite states, and writes every format of every frame
/// (the initial state and one per step): 3 frames × 5 files, with consistent contents.
#[test]
fn woven_scene_steps_and_writes_every_format() {
    let scene = parse(WEAVE).unwrap();
    assert_eq!(scene.frame_every(), 1);
    let mut run = scene.build().unwrap();
    let topo = run.sim.topology().clone();
    assert_eq!((topo.nodes.len(), topo.yarns.len()), (12, 7));
    assert_eq!(topo.crossings.len(), 12);
    assert_eq!(run.clamps.len(), 1);
    assert_eq!(run.clamps[0].0, vec![8, 9, 10, 11]);
    let (params, ..) = scene.yarn().unwrap();
    let dir = std::env::temp_dir().join(format!("sim-persistent-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let dt = run.sim.settings().dt;
    let mut writer = FrameWriter::new(&dir, &scene.output, params.radius, dt).unwrap();
    let mut files = writer.write(&run.sim).unwrap();
    let y0 = run.sim.dofs().position(&run.sim.state().q, 0).y;
    for _ in 0..scene.steps {
        run.step().unwrap();
        files.extend(writer.write(&run.sim).unwrap());
    }
    let s = run.sim.state();
    assert!(s.q.iter().chain(&s.v).all(|v| v.is_finite()));
    assert!(
        run.sim.dofs().position(&s.q, 0).y < y0,
        "the free bottom weft falls"
    );
    assert_eq!(writer.frames_written(), 3);
    assert_eq!(files.len(), 15);
    for frame in 0..3 {
        for ext in ["obj", "ply", "bcc", "png", "nodes.obj"] {
            let path = dir.join(format!("frame_{frame:05}.{ext}"));
            assert!(files.contains(&path), "{}", path.display());
            let bytes = std::fs::read(&path).unwrap();
            assert!(!bytes.is_empty(), "{}", path.display());
        }
    }
    let last = |ext: &str| dir.join(format!("frame_00002.{ext}"));
    let curves = RenderCurves::from_simulator(
        &run.sim,
        &CurveOptions {
            radius: params.radius,
            samples_per_segment: 3,
        },
    )
    .unwrap();
    assert_eq!(
        std::fs::read_to_string(last("obj")).unwrap(),
        curves.obj_text().unwrap()
    );
    assert_eq!(
        std::fs::read_to_string(last("ply")).unwrap(),
        curves.ply_text().unwrap()
    );
    assert_eq!(
        std::fs::read(last("bcc")).unwrap(),
        curves.bcc_bytes(BccCurve::C0).unwrap()
    );
    assert_eq!(
        std::fs::read_to_string(last("nodes.obj")).unwrap(),
        obj_text(&run.sim)
    );
    let png = std::fs::read(last("png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 64);
    // Samples: (passes − 1) · 3 + 1 per yarn.
    let samples: usize = topo
        .yarns
        .iter()
        .map(|y| (y.passes.len() - 1) * 3 + 1)
        .sum();
    assert_eq!(curves.sample_count(), samples);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The scene files shipped in `scenes/` parse and build.
#[test]
fn shipped_scenes_are_valid() {
    let text = include_str!("../scenes/stockinette-curl.toml");
    let scene = parse(text).unwrap();
    let run = scene.build().unwrap();
    assert!(run.clamps.is_empty());
    assert_eq!(scene.steps, 300);
    assert_eq!(scene.frame_every(), 10);
    let text = include_str!("../scenes/twill-hanging.toml");
    let scene = parse(text).unwrap();
    let run = scene.build().unwrap();
    assert_eq!(run.sim.topology().crossings.len(), 100);
    assert_eq!(scene.output.formats.len(), 4);
    let text = include_str!("../scenes/stockinette-uniaxial.toml");
    let test = parse(text).unwrap().uniaxial_test().unwrap().unwrap();
    assert_eq!((test.max_stretch, test.steps), (0.3, 15));
    // Stacked stitches on one continuous yarn; a tube in the round.
    for (text, yarns) in [
        (include_str!("../scenes/lace-hanging.toml"), 1),
        (include_str!("../scenes/tube-round.toml"), 1),
    ] {
        let run = parse(text).unwrap().build().unwrap();
        assert_eq!(run.sim.topology().yarns.len(), yarns);
        assert!(run.sim.topology().nodes.iter().any(|n| n.passes.len() > 2));
        assert_eq!(run.clamps.len(), 1);
        let bind_off = run.sim.topology().knit.as_ref().unwrap().boundaries.len() - 1;
        assert_eq!(run.clamps[0].0, run.sim.topology().boundary_nodes(bind_off));
    }
}

/// `construction` names a knit construction, applies to knits only, and a shaped chart has
/// no side clamps.
#[test]
fn construction_and_shaped_chart_errors() {
    let err = |text: &str| match parse(text) {
        Ok(scene) => scene
            .build()
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default(),
        Err(e) => e.to_string(),
    };
    let e = err("steps = 1\n[pattern]\nchart = \"K4\"\nconstruction = \"spiral\"\n");
    assert!(
        e.contains("construction \"spiral\"") && e.contains("\"round\""),
        "{e}"
    );
    let e = err(
        "steps = 1\n[pattern]\nbuilder = \"plain\"\nwarps = 3\nwefts = 3\nconstruction = \"flat\"\n",
    );
    assert!(e.contains("applies to knits"), "{e}");
    let e = err("steps = 1\n[pattern]\nchart = \"K4\\nK2TOG K2\"\n[[clamp]]\nedge = \"left\"\n");
    assert!(e.contains("rectangular"), "{e}");
    let e = err("steps = 1\n[pattern]\nchart = \"K4\\nK2TOG K\"\n");
    assert!(
        e.contains("line 2") && e.contains("works 3 of the 4 loops"),
        "{e}"
    );
}

/// `[yarn] wrapping_rest` and `wrapping_bias` reach the parameters: the default is the
/// layout rest state with the default bias, `"paper"` the fixed quarter turn; a bias with
/// `"paper"` is refused, an unknown rest state and a negative bias are parse errors at their
/// line.
#[test]
fn wrapping_rest_keys_reach_the_parameters() {
    use sim_persistent::params::{DEFAULT_WRAP_BIAS, WrappingRest};
    let scene = |yarn: &str| {
        format!(
            "steps = 1\n[pattern]\nbuilder = \"garter\"\nwidth = 4\nheight = 4\n[yarn]\n{yarn}\n"
        )
    };
    let rest = |yarn: &str| parse(&scene(yarn)).unwrap().yarn().unwrap().0.wrapping_rest;
    assert_eq!(
        rest(""),
        WrappingRest::Layout {
            wrap: DEFAULT_WRAP_BIAS
        }
    );
    assert_eq!(rest("wrapping_rest = \"paper\""), WrappingRest::paper());
    assert_eq!(
        rest("wrapping_rest = \"layout\"\nwrapping_bias = 0.05"),
        WrappingRest::Layout { wrap: 0.05 }
    );
    let e = parse(&scene("wrapping_rest = \"paper\"\nwrapping_bias = 0.1"))
        .unwrap()
        .yarn()
        .unwrap_err()
        .to_string();
    assert!(e.contains("wrapping_bias"), "{e}");
    assert_parse_error(&scene("wrapping_rest = \"rolled\""), 7, "layout");
    assert_parse_error(&scene("wrapping_bias = -0.1"), 7, "≥ 0");
    assert!(
        parse(&scene("wrapping_bias = 4.0"))
            .unwrap()
            .yarn()
            .is_err()
    );
}
