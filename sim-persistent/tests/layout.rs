//! Layouts of a given yarn per loop (`LayoutParams::with_loop_length`) and the scene keys
//! that set them.

use sim_persistent::chart::Chart;
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::scene::{Fabric, Scene};
use sim_persistent::topology::{Construction, Topology};
use sim_persistent::weave::WeavePattern;
use std::path::Path;

const R: f64 = 1e-3;

fn stockinette(n: usize) -> Topology {
    Fabric::Knit(Chart::stockinette(n, n).unwrap(), Construction::FlatPerRow)
        .topology()
        .unwrap()
}

fn yarn_per_loop(topology: &Topology, params: &LayoutParams) -> f64 {
    Layout::new(topology, params)
        .unwrap()
        .yarn_per_loop(topology)
        .unwrap()
}

/// The yarn per loop grows with the out-of-plane offset, and the solved offset gives the
/// requested length to the bisection's tolerance; a chart with purls (rib) as well.
#[test]
fn the_solved_offset_gives_the_requested_yarn_per_loop() {
    for topology in [
        stockinette(8),
        Fabric::Knit(Chart::rib(6, 5, 1, 1).unwrap(), Construction::Flat)
            .topology()
            .unwrap(),
    ] {
        let base = LayoutParams::new(7.5 * R, R);
        let lengths: Vec<f64> = [0.1, 0.5, 1.0, 2.0, 4.0]
            .iter()
            .map(|d| {
                yarn_per_loop(
                    &topology,
                    &LayoutParams {
                        out_of_plane: d * R,
                        ..base
                    },
                )
            })
            .collect();
        assert!(lengths.windows(2).all(|w| w[1] > w[0]), "{lengths:?}");
        for target in [1.1 * lengths[0], 0.5 * (lengths[2] + lengths[3])] {
            let solved = base.with_loop_length(&topology, target).unwrap();
            let got = yarn_per_loop(&topology, &solved);
            assert!((got / target - 1.0).abs() < 1e-9, "{got} vs {target}");
            // Only the offset changes.
            assert_eq!(solved.loop_width, base.loop_width);
            assert_eq!(solved.row_height, base.row_height);
            assert_eq!(solved.contact_length, base.contact_length);
        }
    }
}

/// What the layout cannot reach, and weaves, are errors that say why.
#[test]
fn unreachable_loop_lengths_and_weaves_are_errors() {
    let topology = stockinette(4);
    let base = LayoutParams::new(7.5 * R, R);
    let flat = yarn_per_loop(
        &topology,
        &LayoutParams {
            out_of_plane: 1e-9 * base.loop_width,
            ..base
        },
    );
    for (length, needle) in [
        (0.9 * flat, "out of this layout's reach"),
        (100.0 * flat, "out of this layout's reach"),
        (f64::NAN, "finite and > 0"),
        (-1.0, "finite and > 0"),
    ] {
        let e = base
            .with_loop_length(&topology, length)
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{length}: {e}");
    }
    let weave = Fabric::Weave {
        pattern: WeavePattern::Plain,
        warps: 4,
        wefts: 4,
    }
    .topology()
    .unwrap();
    let e = base.with_loop_length(&weave, flat).unwrap_err().to_string();
    assert!(e.contains("weave"), "{e}");
    let round = Fabric::Knit(Chart::stockinette(8, 4).unwrap(), Construction::Round)
        .topology()
        .unwrap();
    let e = base.with_loop_length(&round, flat).unwrap_err().to_string();
    assert!(e.contains("laid out flat"), "{e}");
}

const SCENE: &str = r#"dt = 1e-3
steps = 2

[pattern]
builder = "stockinette"
width = 6
height = 6

[yarn]
preset = "sweater"
loop_width = 7.5e-3
row_height = 4e-3
LOOP
"#;

/// `[yarn] row_height` and `loop_length` reach the scene's simulator and its uniaxial test;
/// an unreachable length names the key.
#[test]
fn scene_keys_set_row_height_and_loop_length() {
    let scene = |extra: &str| {
        Scene::parse(&SCENE.replace("LOOP", extra), Path::new("layout.toml")).unwrap()
    };
    let topology = stockinette(6);
    let plain = scene("").layout_params(&topology).unwrap();
    assert_eq!(plain.row_height, 4e-3);
    let flat = yarn_per_loop(&topology, &plain);
    let target = 1.3 * flat;
    let params = scene(&format!("loop_length = {target}"))
        .layout_params(&topology)
        .unwrap();
    assert!((yarn_per_loop(&topology, &params) / target - 1.0).abs() < 1e-9);
    assert!(params.out_of_plane > plain.out_of_plane);
    // The simulator starts in that layout: its nodes are the layout's.
    let run = scene(&format!("loop_length = {target}")).build().unwrap();
    let layout = Layout::new(&topology, &params).unwrap();
    let dofs = run.sim.dofs();
    for (n, p) in layout.positions.iter().enumerate() {
        assert_eq!(dofs.position(&run.sim.state().q, n), *p);
    }
    let e = scene("loop_length = 1e-6")
        .build()
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("[yarn] loop_length") && e.contains("reach"),
        "{e}"
    );
    // A weave has no row height.
    let weave = Scene::parse(
        "steps = 1\n[pattern]\nbuilder = \"plain\"\nwarps = 4\nwefts = 4\n[yarn]\nrow_height = 4e-3\n",
        Path::new("layout.toml"),
    )
    .unwrap();
    let e = weave.build().err().unwrap().to_string();
    assert!(e.contains("[yarn] row_height is for knits"), "{e}");
}

/// `[yarn] gauge` in knitters' units sets loop width, row height and yarn per loop as
/// `Gauge::from_knitting` and `LayoutParams::at_gauge` do; it excludes the keys it sets, and
/// bad values name the key.
#[test]
fn scene_gauge_in_knitters_units_sets_the_layout() {
    let base = "dt = 1e-3\nsteps = 1\n[pattern]\nbuilder = \"stockinette\"\nwidth = 6\nheight = 6\n[yarn]\npreset = \"sweater\"\n";
    let parse = |extra: &str| Scene::parse(&format!("{base}{extra}"), Path::new("gauge.toml"));
    let topology = stockinette(6);
    // 18 stitches and 34 rows per 10 cm, 14 mm of yarn per stitch, for the 1.5 mm yarn.
    let gauge = "gauge = { stitches = 18, rows = 34, stitch_length_mm = 14.0 }\n";
    let params = parse(gauge).unwrap().layout_params(&topology).unwrap();
    assert!((params.loop_width - 0.1 / 18.0).abs() < 1e-15);
    assert!((params.row_height - 0.1 / 34.0).abs() < 1e-15);
    assert!((yarn_per_loop(&topology, &params) / 14e-3 - 1.0).abs() < 1e-9);
    let expected = sim_persistent::layout::LayoutParams::at_gauge(
        &topology,
        0.75e-3,
        sim_persistent::layout::Gauge::from_knitting(18.0, 34.0, 14.0, 1.5e-3),
    )
    .unwrap();
    assert_eq!(params, expected);
    // The simulator is built in that layout.
    let run = parse(gauge).unwrap().build().unwrap();
    let layout = Layout::new(&topology, &params).unwrap();
    let dofs = run.sim.dofs();
    for (n, p) in layout.positions.iter().enumerate() {
        assert_eq!(dofs.position(&run.sim.state().q, n), *p);
    }
    let error = |extra: &str| match parse(extra) {
        Ok(scene) => scene.build().err().unwrap().to_string(),
        Err(e) => e.to_string(),
    };
    let e = error(&format!("{gauge}loop_width = 3e-3\n"));
    assert!(
        e.contains("[yarn] gauge") && e.contains("loop_width"),
        "{e}"
    );
    let e = error("gauge = { stitches = 0, rows = 34, stitch_length_mm = 14.0 }\n");
    assert!(e.contains("`stitches`"), "{e}");
    let e = error("gauge = { stitches = 18, rows = 34 }\n");
    assert!(e.contains("stitch_length_mm"), "{e}");
    // A stitch length the layout cannot hold at that gauge.
    let e = error("gauge = { stitches = 18, rows = 34, stitch_length_mm = 1.0 }\n");
    assert!(e.contains("[yarn] gauge") && e.contains("reach"), "{e}");
    let weave = "steps = 1\n[pattern]\nbuilder = \"plain\"\nwarps = 4\nwefts = 4\n[yarn]\n";
    let e = Scene::parse(&format!("{weave}{gauge}"), Path::new("gauge.toml"))
        .unwrap()
        .build()
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("[yarn] gauge is for knits"), "{e}");
}
