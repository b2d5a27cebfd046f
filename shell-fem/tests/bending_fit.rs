//! The bending fit (seed 002 §5.2): implicit-differentiation sensitivities of the pear-loop
//! ratio against finite differences, and identifiability (recovery of known `k_θ` from
//! virtual pear-loop data within 1 %).

use shell_fem::bending_fit::{
    BendingFitConfig, BendingTarget, fit_bending, target_distances, virtual_targets,
};
use shell_fem::elements::BendingParams;
use shell_fem::material::{InPlaneParams, Material};
use shell_fem::pear_loop::{PearLoop, PearLoopConfig};
use yarn_pattern::direction::Direction;

/// A coarse strip (one cell across) keeps the tests fast.
fn coarse() -> PearLoopConfig {
    PearLoopConfig {
        nx: 24,
        ny: 1,
        max_step: 0.006,
        ..PearLoopConfig::default()
    }
}

fn material() -> Material {
    Material::augmented(InPlaneParams::example())
}

const TRUTH: BendingParams = BendingParams {
    weft: 3e-6,
    bias: 1.5e-6,
    warp: 6e-6,
};

#[test]
fn target_distances_span_the_protocol() {
    let d = target_distances(7);
    assert_eq!(d.len(), 7);
    assert!((d[0] - 0.034).abs() < 1e-15 && (d[6] - 0.003).abs() < 1e-15);
    for w in d.windows(2) {
        assert!(((w[0] - w[1]) - 0.031 / 6.0).abs() < 1e-12);
    }
}

#[test]
fn ratio_sensitivities_match_finite_differences() {
    // Tight equilibria so that central differences resolve the small cross sensitivities.
    let mut cfg = coarse();
    cfg.newton.gradient_abs_tol = 1e-14;
    cfg.newton.gradient_rel_tol = 0.0;
    for (dir, d) in [(Direction::Bias, 0.0137), (Direction::Weft, 0.003)] {
        let mut pear = PearLoop::new(&cfg, material(), TRUTH, dir.angle(), 0.034).unwrap();
        pear.solve_to(d).unwrap();
        let x0 = pear.positions().to_vec();
        let sens = pear.ratio_sensitivity().unwrap();
        let base = TRUTH.to_array();
        let mut fd = [0.0; 3];
        for j in 0..3 {
            let h = 1e-3 * base[j];
            let mut at = |sign: f64| {
                let mut p = base;
                p[j] += sign * h;
                pear.set_bending(BendingParams::from_array(p)).unwrap();
                pear.set_state(d, &x0).unwrap();
                pear.equilibrate().unwrap().ratio
            };
            fd[j] = (at(1.0) - at(-1.0)) / (2.0 * h);
        }
        println!("{dir:?} d = {d}: adjoint {sens:?}, FD {fd:?}");
        let scale = fd.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(scale > 0.0, "the ratio must depend on k_θ");
        for j in 0..3 {
            assert!(
                (sens[j] - fd[j]).abs() <= 1e-3 * scale,
                "{dir:?} d = {d}, k_{j}: adjoint {} vs FD {}",
                sens[j],
                fd[j]
            );
        }
        // Edge-direction interpolation: the loop bends about hinges across the strip.
        let dominant = match dir {
            Direction::Weft => 2, // hinges along the warp
            Direction::Bias => 1,
            Direction::Warp => 0,
        };
        assert_eq!(
            (0..3)
                .max_by(|&a, &b| fd[a].abs().total_cmp(&fd[b].abs()))
                .unwrap(),
            dominant
        );
    }
}

#[test]
fn bending_fit_recovers_known_stiffnesses() {
    let cfg = BendingFitConfig {
        pear: coarse(),
        material: material(),
        ..BendingFitConfig::default()
    };
    let t0 = std::time::Instant::now();
    let targets = virtual_targets(
        &cfg.pear,
        cfg.material,
        &TRUTH,
        &Direction::ALL,
        &target_distances(7),
    )
    .unwrap();
    assert_eq!(targets.len(), 21);
    println!("virtual data: {:.2} s", t0.elapsed().as_secs_f64());
    // The data must actually vary with d (a flat curve could not identify anything).
    for dir in Direction::ALL {
        let r: Vec<f64> = targets
            .iter()
            .filter(|t| t.direction == dir)
            .map(|t| t.ratio)
            .collect();
        assert!(r.iter().all(|v| v.is_finite() && *v > 0.0));
        assert!((r[6] - r[0]).abs() > 0.05, "{dir:?}: {r:?}");
    }
    let initial = BendingParams {
        weft: 1e-6,
        bias: 1e-6,
        warp: 1e-6,
    };
    let mut costs = Vec::new();
    let mut progress = |_: usize, c: f64| costs.push(c);
    let fit = fit_bending(&targets, initial, &cfg, Some(&mut progress)).unwrap();
    println!(
        "fit: {:?} in {} iterations, {:.2} s, cost {:.3e} → {:.3e}, {}",
        fit.params, fit.iterations, fit.seconds, fit.cost_history[0], fit.cost, fit.termination
    );
    let got = fit.params.to_array();
    let truth = TRUTH.to_array();
    for j in 0..3 {
        let rel = (got[j] - truth[j]).abs() / truth[j];
        assert!(
            rel < 0.01,
            "parameter {j}: {} vs {} ({rel:.2e})",
            got[j],
            truth[j]
        );
    }
    assert!(fit.ratio_rel_error < 1e-3, "{}", fit.ratio_rel_error);
    println!("cost history {:?}", fit.cost_history);
    assert!(fit.cost < 1e-6 * fit.cost_history[0]);
    assert!(!costs.is_empty() && costs.windows(2).all(|w| w[1] < w[0]));
}

#[test]
fn bending_fit_rejects_bad_input() {
    let cfg = BendingFitConfig {
        pear: coarse(),
        ..BendingFitConfig::default()
    };
    assert!(fit_bending(&[], TRUTH, &cfg, None).is_err());
    let bad = [BendingTarget {
        direction: Direction::Weft,
        d: 0.02,
        ratio: f64::NAN,
    }];
    assert!(fit_bending(&bad, TRUTH, &cfg, None).is_err());
    let ok = [BendingTarget {
        direction: Direction::Weft,
        d: 0.02,
        ratio: 1.0,
    }];
    let zero = BendingParams { weft: 0.0, ..TRUTH };
    assert!(fit_bending(&ok, zero, &cfg, None).is_err());
}

#[test]
fn missing_directions_leave_their_stiffness_unidentified() {
    use shell_fem::bending_fit::unidentified;
    assert_eq!(unidentified(&Direction::ALL), [false; 3]);
    // Weft and warp loops only: k_θ,bias is not identified.
    assert_eq!(
        unidentified(&[Direction::Weft, Direction::Warp]),
        [false, true, false]
    );
    // The weft loop bends about warp-direction hinges.
    assert_eq!(unidentified(&[Direction::Weft]), [true, true, false]);
}

#[test]
fn bending_csv_reader_names_file_line_and_problem() {
    use shell_fem::bending_fit::read_bending_csv;
    let dir = std::env::temp_dir().join(format!("shell-fem-bending-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.csv");
    std::fs::write(
        &good,
        "# pear loop\ndirection,d,r\nweft,0.034,1.2\n\nbias,0.003,2.5\n",
    )
    .unwrap();
    let t = read_bending_csv(&good).unwrap();
    assert_eq!(t.len(), 2);
    assert_eq!(t[1].direction, Direction::Bias);
    assert_eq!((t[1].d, t[1].ratio), (0.003, 2.5));
    for (text, expect) in [
        ("d,r\n0.01,1\n", "bad.csv:1: expected the header"),
        (
            "direction,d,r\nwarp,3.4,1.2\n",
            "bad.csv:2: clamp distance d = 3.4 m is implausible",
        ),
        (
            "direction,d,r\nsideways,0.01,1\n",
            "bad.csv:2: unknown direction `sideways`",
        ),
        (
            "direction,d,r\nweft,0.01\n",
            "bad.csv:2: expected 3 columns, found 2",
        ),
        ("direction,d,r\n", "bad.csv:0: no bending targets"),
    ] {
        let bad = dir.join("bad.csv");
        std::fs::write(&bad, text).unwrap();
        let e = read_bending_csv(&bad).unwrap_err().to_string();
        assert!(e.contains(expect), "{e}");
    }
}
