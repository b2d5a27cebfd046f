//! The virtual swatch test (`experiment::uniaxial`): clamped uniaxial stretch of knits and
//! weaves, and the shared yarn description's mapping onto the persistent parameters.

use rod::stretch::StretchLaw;
use rod::yarn::YarnMaterial;
use sim_persistent::chart::Chart;
use sim_persistent::experiment::uniaxial::{Pull, UniaxialTest, default_test};
use sim_persistent::params::YarnParams;
use sim_persistent::scene::Fabric;
use sim_persistent::topology::Construction;
use sim_persistent::weave::WeavePattern;

fn quick(fabric: Fabric, pull: Pull) -> UniaxialTest {
    let mut t = default_test(fabric, pull);
    t.max_stretch = 0.2;
    t.steps = 4;
    t.settings.settle_time = 0.1;
    t.settle_free = true;
    t
}

/// A stockinette pulled in weft: the clamp force rises with the stretch, starts near zero
/// (the swatch settled free first and was mounted as it relaxed), and the free edges draw in
/// (positive compression). Mounted in its layout instead, it would push on the clamps
/// (measured −0.39 N/m): yarn self-contact opens the crowded 3 mm layout, whose unstitched
/// segments start 0.65 d apart, by about a third.
#[test]
fn stockinette_weft_pull_stiffens_and_contracts() {
    let chart = Chart::stockinette(6, 6).unwrap();
    let run = quick(Fabric::Knit(chart, Construction::FlatPerRow), Pull::Weft)
        .run()
        .unwrap();
    assert_eq!(run.samples.len(), 5);
    assert_eq!(run.periods, 6);
    let s: Vec<f64> = run.samples.iter().map(|p| p.stretch).collect();
    // The clamps move rigidly, so the stretch is exactly the prescribed one.
    for (k, s) in s.iter().enumerate() {
        assert!((s - 0.05 * k as f64).abs() < 1e-9, "{s}");
    }
    let sigma: Vec<f64> = run.samples.iter().map(|p| p.stress).collect();
    assert!(sigma.windows(2).all(|w| w[1] > w[0]), "{sigma:?}");
    assert!(sigma[0].abs() < 0.05 * sigma[4], "{sigma:?}");
    let last = run.samples.last().unwrap();
    assert!(last.compression > 0.0, "{last:?}");
    // Mounted relaxed: 5 loop widths between the clamps, longer than in the crowded 3 mm
    // layout (15 mm) and shorter than at a relaxed tile's gauge (5 × 3.76 d = 28.2 mm);
    // measured 19.4 mm.
    assert!(
        run.length > 15e-3 && run.length < 28.2e-3,
        "{} m between the clamps",
        run.length
    );
    // Measured along the fabric: six rows of 2–3.3 mm (3 mm in the layout; the settle between
    // the clamps draws them to 2.67 mm, 16.0 mm across, measured). A width taken across a
    // curled swatch instead came out at 1.4 mm.
    assert!(
        (12e-3..=20e-3).contains(&run.width),
        "{} m across six rows",
        run.width
    );
}

/// A plain weave pulled in warp: the same checks on a woven topology.
#[test]
fn plain_weave_warp_pull() {
    let fabric = Fabric::Weave {
        pattern: WeavePattern::Plain,
        warps: 8,
        wefts: 8,
    };
    let run = quick(fabric, Pull::Warp).run().unwrap();
    let sigma: Vec<f64> = run.samples.iter().map(|p| p.stress).collect();
    assert!(sigma.windows(2).all(|w| w[1] > w[0]), "{sigma:?}");
    assert_eq!(run.periods, 8);
}

#[test]
fn bias_and_bad_settings_are_errors() {
    let e = Pull::parse("bias").unwrap_err();
    assert!(e.contains("diagonal"), "{e}");
    let e = Pull::parse("sideways").unwrap_err();
    assert!(e.contains("sideways") && e.contains("weft or warp"), "{e}");
    assert_eq!(Pull::parse("warp"), Ok(Pull::Warp));
    let chart = Chart::stockinette(4, 4).unwrap();
    let mut t = quick(Fabric::Knit(chart, Construction::FlatPerRow), Pull::Weft);
    t.max_stretch = -0.1;
    let e = t.run().unwrap_err().to_string();
    assert!(e.contains("max_stretch"), "{e}");
}

/// The shared yarn description maps onto the persistent parameters: stiffnesses through
/// `Y = k/(πR²)` and `B = k_b/(πR²)`, the bi-phasic law as the segments' law.
#[test]
fn yarn_material_maps_onto_the_persistent_parameters() {
    let yarn = YarnMaterial {
        radius: 0.75e-3,
        stretch: StretchLaw::TwoPhase {
            k1: 15.0,
            k2: 150.0,
            onset: 0.05,
        },
        bending: 2e-8,
        twist: 1e-8,
        friction: 0.25,
        linear_density: 2e-3,
    };
    let p = YarnParams::from_material(&yarn).unwrap();
    assert!((p.stretch_stiffness() - 15.0).abs() < 1e-12);
    assert!((p.bending_stiffness() - 2e-8).abs() < 1e-20);
    assert_eq!(p.stretch_law(), yarn.stretch);
    assert_eq!(p.friction_coefficient, 0.25);
    assert_eq!(p.linear_density, 2e-3);
    assert_eq!(p.radius, 0.75e-3);
    let linear = YarnMaterial {
        stretch: StretchLaw::Linear { k: 15.0 },
        ..yarn
    };
    assert_eq!(
        YarnParams::from_material(&linear).unwrap().stretch_law(),
        StretchLaw::Linear { k: 15.0 }
    );
    let bad = YarnMaterial {
        friction: -1.0,
        ..yarn
    };
    assert!(
        YarnParams::from_material(&bad)
            .unwrap_err()
            .contains("friction")
    );
}

/// The persistent weave carries a stretch in straight yarns: its yarns run between crossing
/// nodes at the layout's lengths with nothing to pull out (no crimp), so the clamped swatch's
/// stress is the yarns' own, `σ = ψ'(s)/d` for yarn spacing `d`, from the first strain, and
/// it does not contract. This is why `cross-method` finds the persistent plain weave 65×
/// stiffer than the periodic tile at 10 % stretch, where the tile's crimp interchange
/// (compression 0.18) takes the strain first.
#[test]
fn the_persistent_weave_stretches_its_yarns_straight() {
    let law = StretchLaw::TwoPhase {
        k1: 20.0,
        k2: 200.0,
        onset: 0.03,
    };
    let yarn = YarnMaterial {
        radius: 1e-3,
        stretch: law,
        bending: 1e-7,
        twist: 8e-8,
        friction: 0.3,
        linear_density: 3e-3,
    };
    let fabric = Fabric::Weave {
        pattern: WeavePattern::Plain,
        warps: 4,
        wefts: 4,
    };
    let mut t = quick(fabric, Pull::Warp);
    let mut params = YarnParams::from_material(&yarn).unwrap();
    params.gravity *= 0.0;
    t.settings.params = params;
    let d = 4e-3;
    t.layout = sim_persistent::layout::LayoutParams::new(d, yarn.radius);
    let run = t.run().unwrap();
    for p in &run.samples[1..] {
        let expected = law.eval(p.stretch).1 / d;
        assert!(
            (p.stress - expected).abs() <= 1e-3 * expected,
            "s = {}: σ = {} N/m, straight yarns {} N/m",
            p.stretch,
            p.stress,
            expected
        );
        assert!(p.compression.abs() < 1e-6, "{p:?}");
    }
}

/// A scene's `[uniaxial]` table builds the test; clamps beside it, a bias direction and an
/// empty load are errors that name the table.
#[test]
fn scenes_express_the_swatch_test() {
    use sim_persistent::scene::Scene;
    use std::path::Path;
    let text = |extra: &str| {
        format!(
            "steps = 20\n[pattern]\nbuilder = \"garter\"\nwidth = 4\nheight = 4\n\
             [forces]\ngravity = false\n[uniaxial]\ndirection = \"warp\"\nmax_stretch = 0.1\n\
             load_steps = 2\n{extra}"
        )
    };
    let scene = Scene::parse(&text(""), Path::new("test.toml")).unwrap();
    let test = scene.uniaxial_test().unwrap().unwrap();
    assert_eq!(test.pull, Pull::Warp);
    assert_eq!((test.max_stretch, test.steps), (0.1, 2));
    assert!((test.settings.settle_time - 0.02).abs() < 1e-15);
    assert!(!test.zero_force_start);
    let run = test.run().unwrap();
    assert_eq!(run.samples.len(), 3);
    let zero = Scene::parse(&text("zero_force_start = true\n"), Path::new("test.toml")).unwrap();
    assert!(zero.uniaxial_test().unwrap().unwrap().zero_force_start);
    let clamped = Scene::parse(
        &text("[[clamp]]\nedge = \"left\"\n"),
        Path::new("test.toml"),
    )
    .unwrap();
    let e = clamped.uniaxial_test().unwrap_err().to_string();
    assert!(e.contains("[uniaxial]") && e.contains("[[clamp]]"), "{e}");
    let bias = Scene::parse(
        &text("").replace("\"warp\"", "\"bias\""),
        Path::new("test.toml"),
    )
    .unwrap();
    let e = bias.uniaxial_test().unwrap_err().to_string();
    assert!(
        e.contains("[uniaxial] direction") && e.contains("diagonal"),
        "{e}"
    );
    let empty = Scene::parse(
        &text("").replace("load_steps = 2", "load_steps = 0"),
        Path::new("test.toml"),
    )
    .unwrap();
    assert!(
        empty
            .uniaxial_test()
            .unwrap_err()
            .to_string()
            .contains("load_steps")
    );
    for (extra, named) in [
        ("[damping]\nalpha = 5.0\n", "[damping]"),
        (
            "[[obstacle]]\nkind = \"sphere\"\ncentre = [0.0, 0.0, -1.0]\nradius = 0.1\n",
            "[[obstacle]]",
        ),
    ] {
        let scene = Scene::parse(&text(extra), Path::new("test.toml")).unwrap();
        let e = scene.uniaxial_test().unwrap_err().to_string();
        assert!(e.contains(named), "{e}");
    }
    // No [uniaxial]: none.
    let plain = Scene::parse(
        "steps = 1\n[pattern]\nbuilder = \"garter\"\nwidth = 4\nheight = 4\n",
        Path::new("test.toml"),
    )
    .unwrap();
    assert!(plain.uniaxial_test().unwrap().is_none());
}

/// The zero-force start moves the clamp against the settled swatch's force, out where the
/// clamped swatch pushes and in where it pulls, and removes that force to 2 % (the single
/// move back to the interpolated zero leaves a little). Stockinette 6 × 6, warp and weft,
/// clamped in its layout, under the paper's fixed quarter turn without yarn contact: the
/// model whose preload (tens of N/m) this start was made for. With the default model the
/// swatch is mounted after a free settle (above); clamped in its layout its preload is
/// removed to 0.3 % in warp but only to 8 % in weft, where contact makes the force–length
/// curve bend between the overshoot and the zero.
#[test]
fn the_zero_force_start_removes_the_preload() {
    for pull in [Pull::Warp, Pull::Weft] {
        let chart = Chart::stockinette(6, 6).unwrap();
        let mut test = quick(Fabric::Knit(chart, Construction::FlatPerRow), pull);
        test.settle_free = false;
        test.settings.forces.yarn_contact = false;
        test.settings.params.wrapping_rest = sim_persistent::params::WrappingRest::paper();
        let layout_start = test.run().unwrap();
        test.zero_force_start = true;
        let zero_start = test.run().unwrap();
        let (s0, z0) = (layout_start.samples[0], zero_start.samples[0]);
        println!(
            "{}: layout start L₀ {:.3} mm, σ₀ {:.4} N/m; zero-force start L₀ {:.3} mm, σ₀ {:.4} N/m",
            pull.name(),
            layout_start.length * 1e3,
            s0.stress,
            zero_start.length * 1e3,
            z0.stress
        );
        // Against the preload: a swatch that pushes (σ₀ < 0) is lengthened.
        assert_eq!(
            (zero_start.length - layout_start.length).signum(),
            -s0.stress.signum(),
            "{pull:?}"
        );
        assert!(
            z0.stress.abs() < 0.02 * s0.stress.abs(),
            "{pull:?}: {z0:?} {s0:?}"
        );
    }
}
