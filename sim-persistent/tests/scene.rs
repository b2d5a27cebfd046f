//! Scene files: a full scene parses, builds and runs with driven clamps and OBJ output;
//! unknown keys and wrong types fail with the line and column of the offending text.

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

/// A value of the wrong type and malformed TOML are located too; a well-formed scene with an
/// unknown builder, a missing size or a malformed chart is an `Invalid`/`Chart` error.
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
    let text = SCENE.replace("\"rib\"", "\"cable\"");
    assert!(matches!(
        parse(&text).unwrap().build(),
        Err(SceneError::Invalid(_))
    ));
    let text = SCENE.replace("width = 4\n", "");
    assert!(matches!(
        parse(&text).unwrap().build(),
        Err(SceneError::Invalid(_))
    ));
    let text = SCENE.replace(
        "builder = \"rib\"\nwidth = 4\nheight = 3\nrib = [1, 1]",
        "chart = \"K4\\nP2 X2\"",
    );
    assert!(matches!(
        parse(&text).unwrap().build(),
        Err(SceneError::Chart(_))
    ));
    let text = SCENE.replace("edge = \"cast-on\"", "edge = \"side\"");
    assert!(matches!(
        parse(&text).unwrap().build(),
        Err(SceneError::Invalid(_))
    ));
}

/// The scene files shipped in `scenes/` parse and build.
#[test]
fn shipped_scenes_are_valid() {
    let text = include_str!("../scenes/stockinette-curl.toml");
    let scene = parse(text).unwrap();
    let run = scene.build().unwrap();
    assert!(run.clamps.is_empty());
    assert_eq!(scene.steps, 300);
}
