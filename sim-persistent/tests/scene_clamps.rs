//! `[[clamp]]` clamp sets in scene files (`sim_persistent::experiment::clamps`): side and
//! column clamps of knits and weaves select the nodes of the clamp set, a driven side clamp
//! moves exactly by its velocity, and a bad entry (unknown edge, both or neither of `edge`
//! and `column`, a column beyond the pattern) fails to parse with its line.

use sim_persistent::experiment::clamps::{ClampSet, Grid};
use sim_persistent::scene::{Scene, SceneError};
use std::path::Path;

/// A 4 × 3 stockinette (lines 1–20): left side fixed, right side pulled along x at 1 cm/s,
/// column 2 fixed.
const SIDES: &str = r#"dt = 1e-3
steps = 2

[pattern]
builder = "stockinette"
width = 4
height = 3

[yarn]
gravity = [0.0, 0.0, 0.0]

[[clamp]]
edge = "left"

[[clamp]]
edge = "right"
velocity = [0.01, 0.0, 0.0]

[[clamp]]
column = 2
"#;

fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::parse(text, Path::new("clamps.toml"))
}

/// Asserts that `text` fails to parse at `line` with a message containing `needle`.
fn assert_parse_error(text: &str, line: usize, needle: &str) {
    match parse(text) {
        Err(e @ SceneError::Parse { .. }) => {
            let SceneError::Parse {
                line: l, message, ..
            } = &e
            else {
                unreachable!()
            };
            assert_eq!(*l, line, "{e}");
            assert!(message.contains(needle), "{message:?} lacks {needle:?}");
            assert!(
                e.to_string().starts_with(&format!("clamps.toml:{line}:")),
                "{e}"
            );
        }
        other => panic!("expected a parse error at line {line}, got {other:?}"),
    }
}

#[test]
fn side_and_column_clamps_select_their_nodes_and_drive() {
    let scene = parse(SIDES).unwrap();
    let grid = Grid::Knit {
        width: 4,
        height: 3,
        shaped: None,
    };
    let mut run = scene.build().unwrap();
    let sets = [ClampSet::Left, ClampSet::Right, ClampSet::Column(2)];
    assert_eq!(run.clamps.len(), 3);
    for ((nodes, _), set) in run.clamps.iter().zip(sets) {
        assert_eq!(nodes, &set.nodes(grid).unwrap(), "{set}");
        assert_eq!(nodes.len(), 4 * 4);
    }
    let right = run.clamps[1].0.clone();
    let position = |run: &sim_persistent::scene::SceneRun, n: usize| {
        run.sim.dofs().position(&run.sim.state().q, n)
    };
    let before: Vec<_> = right.iter().map(|&n| position(&run, n)).collect();
    for _ in 0..scene.steps {
        run.step().unwrap();
    }
    for (&n, b) in right.iter().zip(&before) {
        let d = position(&run, n) - b;
        assert!(
            (d.x - 2e-5).abs() < 1e-15 && d.y == 0.0 && d.z == 0.0,
            "{d}"
        );
    }
}

#[test]
fn weave_side_clamps_are_warps() {
    let text = r#"steps = 1

[pattern]
builder = "plain"
warps = 4
wefts = 3

[[clamp]]
edge = "left"

[[clamp]]
column = 3
"#;
    let run = parse(text).unwrap().build().unwrap();
    assert_eq!(run.clamps[0].0, vec![0, 4, 8]);
    assert_eq!(run.clamps[1].0, vec![3, 7, 11]);
}

#[test]
fn bad_clamp_entries_name_their_line() {
    // Unknown edge: at the value (line 13).
    assert_parse_error(
        &SIDES.replace("edge = \"left\"", "edge = \"top\""),
        13,
        "unknown clamp edge \"top\" (cast-on, bind-off, left, right)",
    );
    // Both, or neither, of `edge` and `column`: at the entry (line 19).
    assert_parse_error(
        &SIDES.replace("column = 2", "column = 2\nedge = \"left\""),
        19,
        "exactly one of `edge` and `column`",
    );
    assert_parse_error(
        &SIDES.replace("column = 2", "velocity = [0.0, 0.0, 0.0]"),
        19,
        "exactly one of `edge` and `column`",
    );
    // A column beyond the pattern (4 stitches wide): at the entry.
    assert_parse_error(
        &SIDES.replace("column = 2", "column = 4"),
        19,
        "clamp column 4 is out of range: the swatch has 4 columns",
    );
    // A column of the wrong type: at the value.
    assert_parse_error(&SIDES.replace("column = 2", "column = -1"), 20, "");
}

/// The shipped side-stretch scene clamps the first and last columns of its 8 × 6 rib.
#[test]
fn shipped_side_stretch_scene_is_valid() {
    let scene = parse(include_str!("../scenes/rib-side-stretch.toml")).unwrap();
    let run = scene.build().unwrap();
    let grid = Grid::Knit {
        width: 8,
        height: 6,
        shaped: None,
    };
    assert_eq!(run.clamps[0].0, ClampSet::Left.nodes(grid).unwrap());
    assert_eq!(run.clamps[1].0, ClampSet::Right.nodes(grid).unwrap());
    assert_eq!(run.clamps[1].1.x, 0.1);
}
